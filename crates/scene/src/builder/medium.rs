//! `<medium>`, `<phase>` and `<volume>` nodes → [`Medium`]s, as Mitsuba
//! 3.9.1 reads them:
//!
//! | plugin          | parameters (defaults) |
//! |-----------------|-----------------------|
//! | `homogeneous`   | `sigma_t` (1), `albedo` (0.75), `scale` (1), `sample_emitters` (true), a nested phase (isotropic) |
//! | `heterogeneous` | the same, `sigma_t` and `albedo` as volumes; the medium fills `sigma_t`'s bounds |
//! | `isotropic`     | — |
//! | `hg`            | `g` (0.8), in (−1, 1) |
//! | `rayleigh`      | — |
//! | `tabphase`      | `values` (required): a string of comma- or space-separated values of the phase function over cos θ regularly spaced on [−1, 1] (cos θ = 1 forward), at least two, not negative, normalised |
//! | `sggx`          | `S` (required): a nested 6-channel `gridvolume` of S_xx, S_yy, S_zz, S_xy, S_xz, S_yz (Mitsuba cannot read a `constvolume` there either) |
//! | `blendphase`    | `weight` (0.5), two nested phase functions |
//! | `constvolume`   | `value` (1), `to_world` |
//! | `gridvolume`    | `filename` (`.vol`, 1, 3 or 6 channels; 6 only for `sggx`), `filter_type` (trilinear / nearest), `wrap_mode` (clamp / repeat / mirror), `to_world`, `use_grid_bbox` (false), `max_value`, `raw`, `accel` |
//!
//! A volume parameter may be a float, a colour or a nested `<volume>`.

use super::{plugin, resolve, Plugins};
use crate::desc::{Kind, Node};
use crate::error::{LoadError, Result};
use crate::scene_builder::SceneBuilder;
use glam::{Mat4, Vec3};
use penumbra_render::math::Spectrum;
use penumbra_render::medium::phase::{Sggx, TabulatedPhase};
use penumbra_render::medium::volume::unit_cube_bounds;
use penumbra_render::medium::{GridVolume, Medium, MediumKind, PhaseFunction, Volume, VolumeFilter, WrapMode};
use std::collections::HashMap;
use std::rc::Rc;
use std::sync::Arc;

type BuildMedium = fn(&Node) -> Result<MediumKind>;
type BuildPhase = fn(&Node) -> Result<PhaseFunction>;
type BuildVolume = fn(&Node) -> Result<Volume>;

pub(super) const MEDIA: &Plugins<BuildMedium> = &[("homogeneous", homogeneous), ("heterogeneous", heterogeneous)];
pub(super) const PHASES: &Plugins<BuildPhase> = &[
    ("isotropic", |_| Ok(PhaseFunction::Isotropic)),
    ("hg", hg),
    ("rayleigh", |_| Ok(PhaseFunction::Rayleigh)),
    ("tabphase", tabphase),
    ("sggx", sggx),
    ("blendphase", blendphase),
];
pub(super) const VOLUMES: &Plugins<BuildVolume> = &[("constvolume", constvolume), ("gridvolume", gridvolume)];

/// Media already built, by node identity (shared through `<ref>`).
#[derive(Default)]
pub(super) struct Media {
    index: HashMap<*const Node, u32>,
}

impl Media {
    /// The index of the medium `node`, built on first use.
    pub(super) fn get(&mut self, node: &Rc<Node>, scene: &mut SceneBuilder) -> Result<u32> {
        let key = Rc::as_ptr(node);
        if let Some(&i) = self.index.get(&key) {
            return Ok(i);
        }
        let mut kind = plugin(MEDIA, node)?(node)?;
        let phase = match node.single_child(Kind::Phase)? {
            Some(p) => phase(&p)?,
            None => PhaseFunction::Isotropic,
        };
        // sggx scales the extinction by its projected area (Mitsuba's
        // heterogeneous.cpp), which may exceed 1: the majorant covers it.
        if let MediumKind::Heterogeneous { majorant, .. } = &mut kind {
            *majorant *= phase.projected_area_bound();
        }
        let sample_emitters = node.bool("sample_emitters", true)?;
        // Spectrally varying extinction is always handled (RGB variants'
        // default); the flag cannot change the image.
        node.accept(&["has_spectral_extinction"]);
        node.check_all_used(&[Kind::Phase, Kind::Volume])?;
        let i = scene.add_medium(Medium { kind, phase, sample_emitters });
        self.index.insert(key, i);
        Ok(i)
    }
}

fn phase(node: &Node) -> Result<PhaseFunction> {
    let p = plugin(PHASES, node)?(node)?;
    let children: &[Kind] = match node.plugin.as_str() {
        "blendphase" => &[Kind::Phase],
        "sggx" => &[Kind::Volume],
        _ => &[],
    };
    node.check_all_used(children)?;
    Ok(p)
}

/// `values`: a string of numbers separated by commas and/or spaces, as
/// Mitsuba's `string::tokenize(values, " ,")` splits it.
fn tabphase(node: &Node) -> Result<PhaseFunction> {
    let Some((text, loc)) = node.get_string("values")? else {
        return Err(node.error(
            "tabphase needs 'values': a string of phase-function values over cos theta in [-1, 1], e.g. \"0.5, 1, 2\"",
        ));
    };
    let mut values = Vec::new();
    for token in text.split([' ', ',']).filter(|t| !t.is_empty()) {
        let v: f32 = token.parse().map_err(|_| {
            LoadError::at(&loc, format!("tabphase values: '{token}' (entry {}) is not a number", values.len()))
        })?;
        values.push(v);
    }
    let t = TabulatedPhase::new(&values).map_err(|e| LoadError::at(&loc, format!("tabphase values: {e}")))?;
    Ok(PhaseFunction::Tabulated(Arc::new(t)))
}

/// `S`: a nested gridvolume with six channels (Mitsuba's `eval_6`, which
/// only `gridvolume` implements).
fn sggx(node: &Node) -> Result<PhaseFunction> {
    let Some(child) = node.children_of(Kind::Volume).find(|c| c.name.as_deref() == Some("S")) else {
        let loc = if node.props.iter().any(|p| p.name == "S") { node.loc_of("S") } else { &node.loc };
        return Err(LoadError::at(
            loc,
            "sggx needs 'S' as a nested <volume type=\"gridvolume\" name=\"S\"> with 6 channels \
             (S_xx, S_yy, S_zz, S_xy, S_xz, S_yz)",
        ));
    };
    let v = plugin(VOLUMES, &child.node)?(&child.node)?;
    child.node.check_all_used(&[])?;
    match v {
        Volume::Grid { grid, .. } if grid.grid.channels == 6 => Ok(PhaseFunction::Sggx(Arc::new(Sggx { s: grid }))),
        Volume::Grid { grid, .. } => Err(LoadError::at(
            &child.loc,
            format!("sggx's S has {} channel(s); it needs a gridvolume with 6", grid.grid.channels),
        )),
        Volume::Constant { .. } => Err(LoadError::at(
            &child.loc,
            "sggx's S must be a 6-channel gridvolume; a constvolume has no six values (Mitsuba's eval_6 fails on it)",
        )),
    }
}

fn hg(node: &Node) -> Result<PhaseFunction> {
    let g = node.float("g", 0.8)?;
    if !(g > -1.0 && g < 1.0) {
        return Err(LoadError::at(node.loc_of("g"), format!("g = {g}: the asymmetry must lie in (-1, 1)")));
    }
    Ok(PhaseFunction::HenyeyGreenstein { g: g as f32 })
}

fn blendphase(node: &Node) -> Result<PhaseFunction> {
    let weight = node.float("weight", 0.5)?;
    if !(0.0..=1.0).contains(&weight) {
        return Err(LoadError::at(node.loc_of("weight"), format!("weight = {weight} must lie in [0, 1]")));
    }
    let nested: Vec<_> = node.children_of(Kind::Phase).map(|c| c.node.clone()).collect();
    if nested.len() != 2 {
        return Err(node.error(format!("blendphase needs exactly two nested phase functions, found {}", nested.len())));
    }
    Ok(PhaseFunction::Blend {
        weight: weight as f32,
        first: Box::new(phase(&nested[0])?),
        second: Box::new(phase(&nested[1])?),
    })
}

/// Finite and not negative in every channel.
fn check_coefficient(node: &Node, name: &str, v: Spectrum) -> Result<()> {
    if !(v.is_finite() && v.min_element() >= 0.0) {
        return Err(LoadError::at(node.loc_of(name), format!("{name} = {v} must be finite and not negative")));
    }
    Ok(())
}

/// A nested `<volume>` used for colours or scalars (a medium's
/// coefficients, the `volume` texture): constvolume, or a gridvolume of 1
/// or 3 channels.
pub(super) fn colour_volume(child: &crate::desc::Child, name: &str) -> Result<Volume> {
    let v = plugin(VOLUMES, &child.node)?(&child.node)?;
    child.node.check_all_used(&[])?;
    if let Volume::Grid { grid, .. } = &v {
        if grid.grid.channels == 6 {
            return Err(LoadError::at(
                &child.loc,
                format!("{name}: a 6-channel gridvolume holds sggx parameters, not a colour; give 1 or 3 channels"),
            ));
        }
    }
    Ok(v)
}

/// The volume parameter `name` of `node`: a nested `<volume>`, or a
/// float or colour (a constant over the unit cube, as Mitsuba's
/// `get_volume` makes it).
fn volume_param(node: &Node, name: &str, default: f32) -> Result<Volume> {
    if let Some(child) = node.children_of(Kind::Volume).find(|c| c.name.as_deref() == Some(name)) {
        return colour_volume(child, name);
    }
    let v = node.get_rgb(name)?.map(|v| Vec3::new(v[0] as f32, v[1] as f32, v[2] as f32));
    let v = v.unwrap_or(Spectrum::splat(default));
    check_coefficient(node, name, v)?;
    // Mitsuba's RGB variants read an <rgb> volume parameter as a
    // reflectance and refuse components above 1.
    let is_rgb = node.props.iter().any(|p| p.name == name && matches!(p.value, crate::desc::Value::Rgb(_)));
    if is_rgb && v.max_element() > 1.0 {
        return Err(LoadError::at(
            node.loc_of(name),
            format!(
                "{name} = {v}: an <rgb> volume value must lie in [0, 1] per channel (Mitsuba 3 reads it as a \
                 reflectance); give the colour in [0, 1] and the magnitude with 'scale', or a <float>"
            ),
        ));
    }
    Ok(Volume::constant(v))
}

fn scale(node: &Node) -> Result<f32> {
    let s = node.float("scale", 1.0)?;
    if !(s.is_finite() && s >= 0.0) {
        return Err(LoadError::at(node.loc_of("scale"), format!("scale = {s} must be finite and not negative")));
    }
    Ok(s as f32)
}

fn homogeneous(node: &Node) -> Result<MediumKind> {
    let constant = |name: &str, default: f32| -> Result<Spectrum> {
        volume_param(node, name, default)?.as_constant().ok_or_else(|| {
            LoadError::at(
                node.loc_of(name),
                format!("a homogeneous medium takes a constant {name}; use a heterogeneous medium for a grid"),
            )
        })
    };
    let sigma_t = constant("sigma_t", 1.0)? * scale(node)?;
    let albedo = constant("albedo", 0.75)?;
    Ok(MediumKind::Homogeneous { sigma_t, albedo })
}

fn heterogeneous(node: &Node) -> Result<MediumKind> {
    let sigma_t = volume_param(node, "sigma_t", 1.0)?;
    let albedo = volume_param(node, "albedo", 0.75)?;
    let scale = scale(node)?;
    let majorant = scale * sigma_t.max();
    Ok(MediumKind::Heterogeneous { sigma_t: Box::new(sigma_t), albedo: Box::new(albedo), scale, majorant })
}

fn to_world(node: &Node) -> Result<Mat4> {
    let m = node.transform("to_world")?.as_mat4();
    if !(m.is_finite() && m.determinant().abs() > 0.0) {
        return Err(LoadError::at(node.loc_of("to_world"), "to_world must be finite and invertible"));
    }
    Ok(m)
}

fn constvolume(node: &Node) -> Result<Volume> {
    let to_world = to_world(node)?;
    let v = node.get_rgb("value")?.map(|v| Vec3::new(v[0] as f32, v[1] as f32, v[2] as f32));
    let value = v.unwrap_or(Spectrum::ONE);
    check_coefficient(node, "value", value)?;
    Ok(Volume::Constant { value, bounds: unit_cube_bounds(to_world) })
}

fn gridvolume(node: &Node) -> Result<Volume> {
    let mut to_world = to_world(node)?;
    let filter = match node.string("filter_type", "trilinear")?.as_str() {
        "trilinear" => VolumeFilter::Trilinear,
        "nearest" => VolumeFilter::Nearest,
        other => {
            return Err(LoadError::at(
                node.loc_of("filter_type"),
                format!("filter_type '{other}' is not one of trilinear, nearest"),
            ))
        }
    };
    let wrap = match node.string("wrap_mode", "clamp")?.as_str() {
        "clamp" => WrapMode::Clamp,
        "repeat" => WrapMode::Repeat,
        "mirror" => WrapMode::Mirror,
        other => {
            return Err(LoadError::at(
                node.loc_of("wrap_mode"),
                format!("wrap_mode '{other}' is not one of clamp, repeat, mirror"),
            ))
        }
    };
    // Spectral upsampling switches (`raw`) and Dr.Jit's texture
    // acceleration (`accel`) cannot change an RGB image.
    node.accept(&["raw", "accel"]);
    let Some((name, loc)) = node.get_string("filename")? else {
        return Err(node.error("gridvolume needs a 'filename' (a Mitsuba .vol file)"));
    };
    let path = resolve(&loc, &name, "volume file")?;
    let file =
        crate::vol::read(&path).map_err(|e| LoadError::at(&loc, format!("volume file '{}': {e}", path.display())))?;
    // Coefficients are never negative; of sggx's six channels only the
    // diagonal S_xx, S_yy, S_zz must not be.
    let channels = file.grid.channels as usize;
    let may_be_negative = |i: usize| channels == 6 && i % 6 >= 3;
    if let Some(i) = file.grid.data.iter().enumerate().position(|(i, &v)| v < 0.0 && !may_be_negative(i)) {
        return Err(LoadError::at(
            &loc,
            format!(
                "volume file '{}': value {} of voxel {} is negative",
                path.display(),
                file.grid.data[i],
                i / file.grid.channels as usize
            ),
        ));
    }
    if node.bool("use_grid_bbox", false)? {
        let (min, max) = (file.bbox.min, file.bbox.max);
        if !(max.cmpgt(min).all()) {
            return Err(LoadError::at(node.loc_of("use_grid_bbox"), "the volume file's bounding box is empty"));
        }
        // The unit cube placed on the file's box, then by to_world.
        to_world *= Mat4::from_translation(min) * Mat4::from_scale(max - min);
    }
    let max = match node.get_float("max_value")? {
        Some(m) if m.is_finite() && m >= 0.0 => m as f32,
        Some(m) => {
            return Err(LoadError::at(
                node.loc_of("max_value"),
                format!("max_value = {m} must be finite and not negative"),
            ))
        }
        None => file.grid.max(),
    };
    let grid = GridVolume { grid: Arc::new(file.grid), to_local: to_world.inverse(), filter, wrap, max };
    Ok(Volume::Grid { grid, bounds: unit_cube_bounds(to_world) })
}
