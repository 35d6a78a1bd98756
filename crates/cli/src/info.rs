//! `penumbra info SCENE.xml`: what a scene uses and how Penumbra will
//! render it, without rendering.

use crate::args::InfoArgs;
use anyhow::{anyhow, Result};
use penumbra_render::geometry::Shape;
use penumbra_scene::desc::{Kind, Node, SceneDesc, Value};
use penumbra_scene::Overrides;
use std::collections::BTreeMap;
use std::fmt::Write;

pub fn run(a: &InfoArgs) -> Result<()> {
    if penumbra_scene::is_pbrt(&a.scene) {
        return run_pbrt(a);
    }
    let ext = a.scene.extension().and_then(|e| e.to_str()).map(str::to_ascii_lowercase);
    if matches!(ext.as_deref(), Some("gltf" | "glb")) {
        return run_other_format(a);
    }
    let desc = penumbra_scene::mitsuba::parse_file(&a.scene, &a.define).map_err(|e| anyhow!(e))?;
    let mut out = String::new();
    writeln!(out, "scene: {} (format version {})", a.scene.display(), desc.version)?;
    for n in desc.upgrade_notes() {
        writeln!(out, "upgraded: {n}")?;
    }
    describe_plugins(&desc, &mut out)?;
    if let Some(integrator) = desc.root.children_of(Kind::Integrator).next() {
        writeln!(out, "integrator: {}", with_params(&integrator.node))?;
    } else {
        writeln!(out, "integrator: path (Mitsuba's default)")?;
    }
    let notes = approximations(&desc);
    let built = penumbra_scene::builder::build(&desc, &Overrides::default()).map_err(|e| desc.explain(e));
    if let Ok(job) = &built {
        describe_job(job, &mut out)?;
    }
    write_notes(&notes, &mut out)?;
    print!("{out}");
    match built {
        Ok(_) => {
            println!("status: ready to render");
            Ok(())
        }
        Err(e) => Err(anyhow!("the scene cannot be rendered by Penumbra: {e}")),
    }
}

/// A pbrt-v4 scene: what its translation holds, and what Penumbra renders
/// differently from pbrt-v4.
fn run_pbrt(a: &InfoArgs) -> Result<()> {
    let mut out = String::new();
    writeln!(out, "scene: {} (pbrt-v4)", a.scene.display())?;
    let built = penumbra_scene::load_scene_noted(&a.scene, &a.define, &Overrides::default());
    if let Ok((job, notes)) = &built {
        let integrator = match &job.integrator {
            penumbra_render::integrator::Integrator::Path(p) => {
                format!("path (Mitsuba's max_depth = {}: pbrt's maxdepth + 1)", p.term.max_depth)
            }
            penumbra_render::integrator::Integrator::VolPath(p) => format!(
                "volpath, with the scene's media (Mitsuba's max_depth = {}: pbrt's maxdepth + 1)",
                p.term.max_depth
            ),
            _ => "other".to_string(),
        };
        writeln!(out, "integrator: {integrator}")?;
        describe_job(job, &mut out)?;
        write_notes(notes, &mut out)?;
    }
    print!("{out}");
    match built {
        Ok(_) => {
            println!("status: ready to render");
            Ok(())
        }
        Err(e) => Err(anyhow!("the scene cannot be rendered by Penumbra: {e}")),
    }
}

/// The notes on what Penumbra renders differently, as `info` lists them.
fn write_notes(notes: &[String], out: &mut String) -> Result<()> {
    if notes.is_empty() {
        writeln!(out, "approximations: none")?;
    } else {
        writeln!(out, "approximations:")?;
        for n in notes {
            writeln!(out, "  - {n}")?;
        }
    }
    Ok(())
}

/// The `path` integrator's sampling parameters (`None` for the others).
pub fn path_summary(job: &penumbra_render::render::RenderJob) -> Option<String> {
    match &job.integrator {
        penumbra_render::integrator::Integrator::Path(p) => {
            Some(p.summary(job.scene.lights.len(), job.scene.light_sampler().kind()))
        }
        _ => None,
    }
}

/// Geometry, emitters and image of a built scene.
fn describe_job(job: &penumbra_render::render::RenderJob, out: &mut String) -> Result<()> {
    let (mut triangles, mut meshes, mut analytic) = (0usize, 0usize, BTreeMap::<&str, usize>::new());
    for shape in &job.scene.shapes {
        match shape {
            Shape::Mesh(m) => {
                meshes += 1;
                triangles += m.mesh.indices.len();
            }
            Shape::Sphere(_) => *analytic.entry("sphere").or_default() += 1,
            _ => *analytic.entry("other").or_default() += 1,
        }
    }
    let mut geometry = format!("{triangles} triangles in {meshes} meshes");
    for (kind, n) in &analytic {
        write!(geometry, ", {n} analytic {kind}{}", if *n == 1 { "" } else { "s" })?;
    }
    // Shape-group members are counted once above, however often placed.
    let n = job.scene.instances.len();
    if n > 0 {
        write!(geometry, ", {n} instance{}", if n == 1 { "" } else { "s" })?;
    }
    writeln!(out, "geometry: {geometry}")?;
    let mut lights = BTreeMap::<&str, usize>::new();
    for l in &job.scene.lights {
        // `Light::name` matches every kind of light, so a new one is counted by its own name.
        *lights.entry(l.name()).or_default() += 1;
    }
    let by_kind: Vec<String> = lights.iter().map(|(k, n)| format!("{n} {k}")).collect();
    writeln!(out, "emitters: {} ({})", job.scene.lights.len(), by_kind.join(", "))?;
    if let Some(s) = path_summary(job) {
        writeln!(out, "path: {s}")?;
    }
    let (w, h) = job.full_size;
    let crop = if (job.width, job.height) != (w, h) {
        format!(", crop {}x{} at ({}, {})", job.width, job.height, job.crop_offset.0, job.crop_offset.1)
    } else {
        String::new()
    };
    writeln!(
        out,
        "image: {w}x{h}{crop}, {} samples per pixel ({:?} sampler, seed {})",
        job.sampler.spp, job.sampler.kind, job.sampler.seed
    )?;
    Ok(())
}

/// Every object of the scene, counted by kind and plugin (shared objects once).
fn describe_plugins(desc: &SceneDesc, out: &mut String) -> Result<()> {
    let mut counts: BTreeMap<(usize, &'static str), BTreeMap<String, usize>> = BTreeMap::new();
    let mut seen = std::collections::HashSet::new();
    let mut stack: Vec<&Node> = vec![&desc.root];
    while let Some(node) = stack.pop() {
        if !seen.insert(node as *const Node) {
            continue;
        }
        if node.kind != Kind::Scene {
            let order = KIND_ORDER.iter().position(|k| *k == node.kind).unwrap_or(KIND_ORDER.len());
            *counts.entry((order, node.kind.tag())).or_default().entry(node.plugin.clone()).or_default() += 1;
        }
        stack.extend(node.children.iter().rev().map(|c| c.node.as_ref()));
    }
    writeln!(out, "plugins:")?;
    for ((_, kind), plugins) in &counts {
        let list: Vec<String> =
            plugins.iter().map(|(p, n)| if *n == 1 { p.clone() } else { format!("{p} x{n}") }).collect();
        writeln!(out, "  {kind:<10} {}", list.join(", "))?;
    }
    Ok(())
}

const KIND_ORDER: &[Kind] = &[
    Kind::Integrator,
    Kind::Sensor,
    Kind::Film,
    Kind::Rfilter,
    Kind::Sampler,
    Kind::Shape,
    Kind::Bsdf,
    Kind::Texture,
    Kind::Emitter,
    Kind::Medium,
    Kind::Phase,
    Kind::Volume,
];

/// `path (max_depth=6)`.
fn with_params(node: &Node) -> String {
    let params: Vec<String> = node.props.iter().map(|p| format!("{}={}", p.name, short(&p.value))).collect();
    if params.is_empty() {
        node.plugin.clone()
    } else {
        format!("{} ({})", node.plugin, params.join(", "))
    }
}

fn short(v: &Value) -> String {
    match v {
        Value::Float(f) => format!("{f}"),
        Value::Integer(i) => format!("{i}"),
        Value::Boolean(b) => format!("{b}"),
        Value::String(s) => s.clone(),
        other => other.type_name().to_string(),
    }
}

/// Features Penumbra renders differently from Mitsuba's spectral variants
/// or serves by another method, found in the scene description.
fn approximations(desc: &SceneDesc) -> Vec<String> {
    let (mut sampled, mut constant, mut visible, mut skies, mut sggx) = (0, 0, 0, 0, 0);
    let mut seen = std::collections::HashSet::new();
    let mut stack: Vec<&Node> = vec![&desc.root];
    while let Some(node) = stack.pop() {
        if !seen.insert(node as *const Node) {
            continue;
        }
        if node.kind == Kind::Emitter && matches!(node.plugin.as_str(), "sunsky" | "timed_sunsky") {
            skies += 1;
        }
        if node.kind == Kind::Phase && node.plugin == "sggx" {
            sggx += 1;
        }
        for p in &node.props {
            match &p.value {
                Value::SpectrumSampled(_) => sampled += 1,
                Value::SpectrumConstant(_) => constant += 1,
                Value::Boolean(false) if p.name == "sample_visible" && node.kind == Kind::Bsdf => visible += 1,
                _ => {}
            }
        }
        stack.extend(node.children.iter().map(|c| c.node.as_ref()));
    }
    let mut notes = Vec::new();
    if sampled > 0 {
        notes.push(format!(
            "{sampled} wavelength-sampled spectra converted to linear sRGB when loading, exactly as \
             Mitsuba's *_rgb variants do (reflectances under D65, emission against CIE 1931); \
             Mitsuba's spectral variants would differ slightly"
        ));
    }
    if constant > 0 {
        notes.push(format!(
            "{constant} constant spectra converted to RGB as Mitsuba's *_rgb variants do \
             (emitters: times xyz_to_srgb(1, 1, 1))"
        ));
    }
    if visible > 0 {
        notes.push(format!(
            "{visible} BSDFs with sample_visible=false are sampled with visible normals \
             (same expected image, different noise)"
        ));
    }
    if skies > 0 {
        notes.push(format!(
            "{skies} sunsky / timed_sunsky emitters: the Hosek-Wilkie RGB tables, as Mitsuba's *_rgb variants \
             (its spectral variants would differ slightly); a timed_sunsky at the sensor's one instant"
        ));
    }
    if sggx > 0 {
        notes.push(format!(
            "{sggx} sggx phase functions sampled exactly; Mitsuba 3.9.1's sggx sampling does not follow its \
             density, so paths that go on after an sggx scattering differ from Mitsuba's (see README)"
        ));
    }
    notes
}

/// `info` for a scene that is not Mitsuba XML (glTF): the built job, and
/// the reader's notes as its approximations.
fn run_other_format(a: &InfoArgs) -> Result<()> {
    let (job, notes) = penumbra_scene::load_scene_noted(&a.scene, &a.define, &Overrides::default())
        .map_err(|e| anyhow!("the scene cannot be rendered by Penumbra: {e}"))?;
    let mut out = String::new();
    writeln!(out, "scene: {}", a.scene.display())?;
    writeln!(out, "integrator: path (the default for glTF scenes)")?;
    describe_job(&job, &mut out)?;
    write_notes(&notes, &mut out)?;
    print!("{out}");
    println!("status: ready to render");
    Ok(())
}
