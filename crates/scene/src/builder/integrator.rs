//! `<integrator>` nodes (and `--integrator` specs) → [`Integrator`]s with
//! the light-selection strategy they ask for.

use super::{plugin, Plugins};
use crate::desc::{Kind, Node, Property, Value};
use crate::error::{FileLoc, LoadError, Result};
use penumbra_render::integrator::{
    AovIntegrator, AovType, BruteForceIntegrator, DepthIntegrator, DirectIntegrator, Guiding, HemisphereSampling,
    Integrator, MomentIntegrator, ParticleTracer, PathIntegrator, Termination, VolPathIntegrator, DEFAULT_CAUSTICS,
    DEFAULT_CAUSTIC_BOUNCES, DEFAULT_CAUSTIC_PATHS, MAX_LIGHT_CANDIDATES,
};
use penumbra_render::light::LightSelection;
use std::cell::Cell;
use std::path::PathBuf;

/// A builder of an integrator and the light-selection strategy it asks for.
type BuildIntegrator = fn(&Node) -> Result<(Integrator, LightSelection)>;

pub(super) const INTEGRATORS: &Plugins<BuildIntegrator> = &[
    ("path", path),
    ("direct", direct),
    ("bruteforce", bruteforce),
    ("volpath", volpath),
    ("volpathmis", volpath),
    ("depth", |_| Ok((Integrator::Depth(DepthIntegrator), LightSelection::Uniform))),
    ("aov", aov),
    ("moment", moment),
    ("ptracer", ptracer),
];

/// Termination parameters shared by `path` and `bruteforce`.
#[allow(clippy::neg_cmp_op_on_partial_ord)] // `!(x > y)` is also true for NaN, on purpose
fn termination(node: &Node) -> Result<Termination> {
    let max_depth = node.int("max_depth", -1)?;
    let rr_depth = node.int("rr_depth", 5)?;
    if max_depth < -1 {
        return Err(LoadError::at(node.loc_of("max_depth"), "max_depth must be -1 (unbounded) or >= 0"));
    }
    if rr_depth <= 0 {
        return Err(LoadError::at(node.loc_of("rr_depth"), "rr_depth must be positive"));
    }
    let threshold = node.float("throughput_threshold", 0.0)?;
    if !(threshold >= 0.0) {
        return Err(LoadError::at(node.loc_of("throughput_threshold"), "throughput_threshold must be >= 0"));
    }
    Ok(Termination {
        max_depth: if max_depth < 0 { u32::MAX } else { max_depth.min(u32::MAX as i64 - 1) as u32 },
        rr_depth: rr_depth.min(u32::MAX as i64) as u32,
        throughput_threshold: threshold as f32,
    })
}

fn light_selection(node: &Node) -> Result<LightSelection> {
    match node.string("light_selection", "uniform")?.as_str() {
        "uniform" => Ok(LightSelection::Uniform),
        "power" => Ok(LightSelection::Power),
        "bvh" => Ok(LightSelection::Bvh),
        other => Err(LoadError::at(
            node.loc_of("light_selection"),
            format!("light_selection '{other}' is not one of uniform, power, bvh"),
        )),
    }
}

fn count(node: &Node, name: &str, default: i64) -> Result<u32> {
    let v = node.int(name, default)?;
    if !(0..=1 << 20).contains(&v) {
        return Err(LoadError::at(node.loc_of(name), format!("{name} must be between 0 and 2^20")));
    }
    Ok(v as u32)
}

/// Builds an integrator and the light-selection strategy it asks for.
pub(crate) fn build_integrator(node: &Node) -> Result<(Integrator, LightSelection)> {
    let result = plugin(INTEGRATORS, node)?(node)?;
    let nests = matches!(result.0, Integrator::Aov(_) | Integrator::Moment(_));
    node.check_all_used(if nests { &[Kind::Integrator] } else { &[] })?;
    Ok(result)
}

/// The nested integrators of `aov` and `moment`, named as Mitsuba names
/// them (the `name` attribute, else `_arg_N` counting the unnamed ones),
/// and the light selection the first one asks for.
fn nested(node: &Node) -> Result<(Vec<(String, Integrator)>, LightSelection)> {
    let mut out = Vec::new();
    let mut selection = LightSelection::Uniform;
    let mut unnamed = 0;
    for c in node.children.iter().filter(|c| c.node.kind == Kind::Integrator) {
        let name = c.name.clone().unwrap_or_else(|| {
            unnamed += 1;
            format!("_arg_{}", unnamed - 1)
        });
        let (mut integrator, sel) = build_integrator(&c.node)?;
        // Light paths run for a `path` at the top only; nested, its camera
        // paths keep the caustics.
        if let Integrator::Path(p) = &mut integrator {
            p.caustics = false;
        }
        if out.is_empty() {
            selection = sel;
        }
        out.push((name, integrator));
    }
    Ok((out, selection))
}

/// Mitsuba `aov`: `aovs` (required) and nested integrators.
fn aov(node: &Node) -> Result<(Integrator, LightSelection)> {
    let Some((spec, loc)) = node.get_string("aovs")? else {
        return Err(LoadError::at(
            &node.loc,
            "aov: the parameter 'aovs' is required (e.g. \"dd.y:depth,nn:sh_normal\")",
        ));
    };
    let loc = &loc;
    let mut aovs = Vec::new();
    // Mitsuba's string::tokenize: separated by commas and spaces.
    for token in spec.split([',', ' ']).filter(|t| !t.is_empty()) {
        let item: Vec<&str> = token.split(':').collect();
        if item.len() != 2 || item[0].is_empty() || item[1].is_empty() {
            return Err(LoadError::at(loc, format!("aovs: '{token}' is not a <name>:<type> pair")));
        }
        let Some(t) = AovType::from_name(item[1]) else {
            let names: Vec<&str> = AovType::ALL.iter().map(|(n, _)| *n).collect();
            return Err(LoadError::at(
                loc,
                format!("aovs: invalid AOV type '{}' in '{token}'; the types are {}", item[1], names.join(", ")),
            ));
        };
        aovs.push((item[0].to_string(), t));
    }
    let (integrators, selection) = nested(node)?;
    Ok((Integrator::Aov(Box::new(AovIntegrator { integrators, aovs })), selection))
}

/// Mitsuba `ptracer` (its `samples_per_pass` is checked against the sample
/// count where the scene is assembled).
#[allow(clippy::neg_cmp_op_on_partial_ord)]
fn ptracer(node: &Node) -> Result<(Integrator, LightSelection)> {
    let max_depth = node.int("max_depth", -1)?;
    let rr_depth = node.int("rr_depth", 5)?;
    if max_depth < -1 {
        return Err(LoadError::at(node.loc_of("max_depth"), "max_depth must be -1 (unbounded) or >= 0"));
    }
    if rr_depth <= 0 {
        return Err(LoadError::at(node.loc_of("rr_depth"), "rr_depth must be positive"));
    }
    let spp_pass = node.int("samples_per_pass", -1)?;
    if spp_pass == 0 || spp_pass < -1 || spp_pass > u32::MAX as i64 {
        return Err(LoadError::at(node.loc_of("samples_per_pass"), "samples_per_pass must be -1 (all) or positive"));
    }
    let term = Termination {
        max_depth: if max_depth < 0 { u32::MAX } else { max_depth.min(u32::MAX as i64 - 1) as u32 },
        rr_depth: rr_depth.min(u32::MAX as i64) as u32,
        throughput_threshold: 0.0,
    };
    let pt = ParticleTracer {
        term,
        hide_emitters: node.bool("hide_emitters", false)?,
        samples_per_pass: (spp_pass > 0).then_some(spp_pass as u32),
    };
    Ok((Integrator::PTracer(pt), LightSelection::Uniform))
}

/// Mitsuba `moment`: nested integrators only.
fn moment(node: &Node) -> Result<(Integrator, LightSelection)> {
    let (integrators, selection) = nested(node)?;
    if integrators.is_empty() {
        return Err(LoadError::at(&node.loc, "moment needs at least one nested integrator"));
    }
    Ok((Integrator::Moment(Box::new(MomentIntegrator { integrators })), selection))
}

fn path(node: &Node) -> Result<(Integrator, LightSelection)> {
    Ok((
        Integrator::Path(PathIntegrator {
            term: termination(node)?,
            hide_emitters: node.bool("hide_emitters", false)?,
            mis: node.bool("mis", true)?,
            guiding: guiding(node)?,
            light_candidates: light_candidates(node)?,
            caustics: node.bool("caustics", DEFAULT_CAUSTICS)?,
            caustic_paths: caustic_paths(node)?,
            caustic_bounces: caustic_bounces(node)?,
        }),
        light_selection(node)?,
    ))
}

/// `caustic_paths`: light paths per camera sample, in (0, 1].
fn caustic_paths(node: &Node) -> Result<f32> {
    let f = node.float("caustic_paths", DEFAULT_CAUSTIC_PATHS as f64)?;
    if !(f > 0.0 && f <= 1.0) {
        return Err(LoadError::at(
            node.loc_of("caustic_paths"),
            "caustic_paths must be in (0, 1]: the share of camera samples that also trace a light path for the caustics",
        ));
    }
    Ok(f as f32)
}

/// `caustic_bounces`: non-delta bounces a caustics' light path may take,
/// -1 (the default) for as many as the depth allows.
fn caustic_bounces(node: &Node) -> Result<u32> {
    let default = if DEFAULT_CAUSTIC_BOUNCES == u32::MAX { -1 } else { DEFAULT_CAUSTIC_BOUNCES as i64 };
    match node.int("caustic_bounces", default)? {
        -1 => Ok(u32::MAX),
        n @ 0..=64 => Ok(n as u32),
        _ => Err(LoadError::at(
            node.loc_of("caustic_bounces"),
            "caustic_bounces must be -1 (as many as max_depth allows) or from 0 to 64: the non-delta bounces a caustics' light path may take before the vertex the camera sees",
        )),
    }
}

/// `light_candidates`: 1 to [`MAX_LIGHT_CANDIDATES`], or 0 (automatic)
/// where it is not given (see `integrator::path`).
fn light_candidates(node: &Node) -> Result<u32> {
    let Some(m) = node.get_int("light_candidates")? else { return Ok(0) };
    if !(1..=MAX_LIGHT_CANDIDATES as i64).contains(&m) {
        return Err(LoadError::at(
            node.loc_of("light_candidates"),
            format!(
                "light_candidates must be from 1 (the light sample as drawn) to {MAX_LIGHT_CANDIDATES}: each candidate costs a light sample and a BSDF evaluation"
            ),
        ));
    }
    Ok(m as u32)
}

/// `guiding`, `guiding_budget`, `guiding_bsdf_fraction`, `guiding_roulette`,
/// `guiding_spatial_threshold` and `guiding_min_roughness` (see `integrator::path`).
fn guiding(node: &Node) -> Result<Option<Guiding>> {
    let on = node.bool("guiding", false)?;
    let d = Guiding::default();
    let budget = node.float("guiding_budget", d.budget as f64)?;
    if !(0.0..=1.0).contains(&budget) {
        return Err(LoadError::at(
            node.loc_of("guiding_budget"),
            "guiding_budget must be in [0, 1] (a share of the samples)",
        ));
    }
    let fraction = node.float("guiding_bsdf_fraction", d.bsdf_fraction as f64)?;
    if !(fraction > 0.0 && fraction <= 1.0) {
        return Err(LoadError::at(
            node.loc_of("guiding_bsdf_fraction"),
            "guiding_bsdf_fraction must be in (0, 1]: the BSDF must keep a share of the samples for the estimate to stay unbiased",
        ));
    }
    let roulette = node.bool("guiding_roulette", d.roulette)?;
    let threshold = node.float("guiding_spatial_threshold", d.spatial_threshold as f64)?;
    if !(threshold.is_finite() && threshold >= 1.0) {
        return Err(LoadError::at(
            node.loc_of("guiding_spatial_threshold"),
            "guiding_spatial_threshold must be at least 1 (records per spatial leaf before it splits)",
        ));
    }
    let min_roughness = node.float("guiding_min_roughness", d.min_roughness as f64)?;
    if !(min_roughness.is_finite() && min_roughness >= 0.0) {
        return Err(LoadError::at(
            node.loc_of("guiding_min_roughness"),
            "guiding_min_roughness must be a roughness of at least 0 (0: guide every non-delta lobe)",
        ));
    }
    Ok(on.then_some(Guiding {
        budget: budget as f32,
        bsdf_fraction: fraction as f32,
        roulette,
        spatial_threshold: threshold as f32,
        min_roughness: min_roughness as f32,
    }))
}

/// `volpath` and `volpathmis` (one estimator; see `integrator::volpath`).
fn volpath(node: &Node) -> Result<(Integrator, LightSelection)> {
    Ok((
        Integrator::VolPath(VolPathIntegrator {
            term: termination(node)?,
            hide_emitters: node.bool("hide_emitters", false)?,
        }),
        light_selection(node)?,
    ))
}

fn direct(node: &Node) -> Result<(Integrator, LightSelection)> {
    let shading = node.get_int("shading_samples")?;
    let default = shading.unwrap_or(1);
    Ok((
        Integrator::Direct(DirectIntegrator {
            emitter_samples: count(node, "emitter_samples", default)?,
            bsdf_samples: count(node, "bsdf_samples", default)?,
            hide_emitters: node.bool("hide_emitters", false)?,
        }),
        light_selection(node)?,
    ))
}

/// Penumbra's `bruteforce`: pure path sampling, no light sampling.
fn bruteforce(node: &Node) -> Result<(Integrator, LightSelection)> {
    let sampling = match node.string("sampling", "cosine")?.as_str() {
        "uniform" => HemisphereSampling::Uniform,
        "cosine" => HemisphereSampling::Cosine,
        "bsdf" => HemisphereSampling::Bsdf,
        other => {
            return Err(LoadError::at(
                node.loc_of("sampling"),
                format!("sampling '{other}' is not one of uniform, cosine, bsdf"),
            ))
        }
    };
    Ok((
        Integrator::BruteForce(BruteForceIntegrator {
            term: termination(node)?,
            hide_emitters: node.bool("hide_emitters", false)?,
            sampling,
        }),
        LightSelection::Uniform,
    ))
}

/// Parameters that carry over from the scene's integrator to one chosen on
/// the command line, so estimators compare on equal terms.
const SHARED_INTEGRATOR_PARAMS: &[&str] = &["max_depth", "rr_depth", "hide_emitters"];

/// Turns `--integrator NAME[:key=value,...]` into an integrator node, typing
/// each value as Mitsuba's XML would (boolean, integer, float, else string)
/// and filling unset shared parameters from the scene's integrator.
pub fn integrator_from_spec(spec: &str, scene_integrator: Option<&Node>) -> Result<Node> {
    let loc = FileLoc::new(std::sync::Arc::new(PathBuf::from("--integrator")), 0, 0);
    let (name, rest) = spec.split_once(':').unwrap_or((spec, ""));
    let mut props = Vec::new();
    for kv in rest.split(',').map(str::trim).filter(|s| !s.is_empty()) {
        let (k, v) = kv.split_once('=').ok_or_else(|| {
            LoadError::new(None, format!("--integrator: '{kv}' is not of the form key=value (in '{spec}')"))
        })?;
        let value = match v {
            "true" => Value::Boolean(true),
            "false" => Value::Boolean(false),
            _ => match (v.parse::<i64>(), v.parse::<f64>()) {
                (Ok(i), _) => Value::Integer(i),
                (_, Ok(f)) => Value::Float(f),
                _ => Value::String(v.to_string()),
            },
        };
        props.push(Property { name: k.to_string(), value, loc: loc.clone(), used: Cell::new(false) });
    }
    let accepts = |param: &str| match name {
        "direct" => param == "hide_emitters",
        "depth" | "aov" | "moment" => false,
        _ => true,
    };
    if let Some(scene) = scene_integrator {
        for p in &scene.props {
            if SHARED_INTEGRATOR_PARAMS.contains(&p.name.as_str())
                && accepts(&p.name)
                && !props.iter().any(|q: &Property| q.name == p.name)
            {
                props.push(Property { used: Cell::new(false), ..p.clone() });
            }
        }
    }
    Ok(Node {
        kind: Kind::Integrator,
        plugin: name.to_string(),
        id: None,
        name: None,
        props,
        children: Vec::new(),
        loc,
    })
}
