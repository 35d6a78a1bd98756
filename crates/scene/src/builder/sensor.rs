//! `<sensor>` nodes → the camera, with the sensor's `<film>` (and its
//! `<rfilter>`) and `<sampler>`, as Mitsuba 3.9.1 reads them.

use super::fov::fov_and_axis;
use super::{plugin, Overrides, Plugins};
use crate::desc::{Kind, Node};
use crate::error::{LoadError, Result};
use penumbra_render::camera::{tan_half_x, Camera, FovAxis};
use penumbra_render::film::{Filter, FilterKind, MAX_MARGIN};
use penumbra_render::sampling::{Sampler, SamplerKind};

/// Sampler names `--sampler` accepts.
pub const SAMPLER_OVERRIDES: &[&str] =
    &["independent", "stratified", "multijitter", "orthogonal", "ldsampler", "sobol"];

/// Film geometry: full size and the crop window rendered.
pub(super) use crate::scene_builder::Film as FilmRect;

pub(super) type SensorParts = (Camera, Filter, FilmRect, Sampler);

/// The sensor's projection parameters, read as Mitsuba 3.9.1's
/// `perspective`, `thinlens` and `orthographic` read them.
pub(super) enum SensorModel {
    Perspective {
        fov: f64,
        axis: FovAxis,
    },
    ThinLens {
        fov: f64,
        axis: FovAxis,
        aperture_radius: f64,
        focus_distance: f64,
    },
    Orthographic,
    RadianceMeter {
        to_world: glam::DMat4,
    },
    IrradianceMeter,
    Distant {
        to_world: glam::DMat4,
        target: Option<glam::DVec3>,
        shape: Option<Box<penumbra_render::geometry::Shape>>,
    },
    /// Never built through the table: [`batch`] reads its nested sensors.
    Batch,
}

/// Whether a camera-to-world matrix scales (Mitsuba's `has_scale`: some
/// column of the linear part is not of unit length).
fn has_scale(m: &glam::DMat4) -> bool {
    [m.x_axis, m.y_axis, m.z_axis].iter().any(|c| (c.truncate().length_squared() - 1.0).abs() > 1e-3)
}

/// A builder of a sensor's projection, from its node, camera-to-world
/// transform and far clip distance.
type BuildSensor = fn(&Node, &glam::DMat4, f64) -> Result<SensorModel>;

pub(super) const SENSORS: &Plugins<BuildSensor> = &[
    ("perspective", perspective),
    ("thinlens", thinlens),
    ("orthographic", orthographic),
    ("radiancemeter", radiancemeter),
    ("irradiancemeter (inside a shape)", irradiancemeter),
    ("distant", distant),
    ("batch", |_, _, _| Ok(SensorModel::Batch)),
];

/// A builder of a film's geometry and reconstruction filter.
type BuildFilm = fn(&Node) -> Result<(FilmRect, Filter)>;

pub(super) const FILMS: &Plugins<BuildFilm> = &[("hdrfilm", hdrfilm)];

pub(super) const RFILTERS: &Plugins<fn(&Node) -> Result<FilterKind>> = &[
    ("box", |_| Ok(FilterKind::Box)),
    ("tent", |f| Ok(FilterKind::Tent { radius: f.float("radius", 1.0)? as f32 })),
    ("gaussian", |f| Ok(FilterKind::Gaussian { stddev: f.float("stddev", 0.5)? as f32 })),
    ("mitchell", |f| {
        Ok(FilterKind::Mitchell { b: f.float("B", 1.0 / 3.0)? as f32, c: f.float("C", 1.0 / 3.0)? as f32 })
    }),
    ("catmullrom", |_| Ok(FilterKind::CatmullRom)),
    ("lanczos", lanczos),
];

fn lanczos(f: &Node) -> Result<FilterKind> {
    let lobes = f.int("lobes", 3)?;
    if !(1..=MAX_MARGIN as i64).contains(&lobes) {
        return Err(LoadError::at(f.loc_of("lobes"), format!("lobes = {lobes} must lie in 1..={MAX_MARGIN}")));
    }
    Ok(FilterKind::Lanczos { lobes: lobes as u32 })
}

pub(super) const SAMPLERS: &Plugins<fn(&Node) -> Result<SamplerKind>> = &[
    ("independent", |_| Ok(SamplerKind::Independent)),
    ("stratified", stratified),
    ("multijitter", |s| Ok(SamplerKind::Multijitter { jitter: s.bool("jitter", true)? })),
    ("orthogonal", orthogonal),
    ("ldsampler", |_| Ok(SamplerKind::LowDiscrepancy)),
];

fn perspective(node: &Node, _: &glam::DMat4, _: f64) -> Result<SensorModel> {
    let (fov, axis) = fov_and_axis(node)?;
    Ok(SensorModel::Perspective { fov, axis })
}

#[allow(clippy::neg_cmp_op_on_partial_ord)] // `!(x > y)` is also true for NaN, on purpose
fn thinlens(node: &Node, to_world: &glam::DMat4, far: f64) -> Result<SensorModel> {
    let (fov, axis) = fov_and_axis(node)?;
    let aperture_radius =
        node.get_float("aperture_radius")?.ok_or_else(|| node.error("thinlens: 'aperture_radius' is required"))?;
    if !(aperture_radius >= 0.0) {
        return Err(LoadError::at(node.loc_of("aperture_radius"), "aperture_radius must not be negative"));
    }
    // Mitsuba replaces a zero radius by machine epsilon (with a warning).
    let aperture_radius = if aperture_radius == 0.0 { f32::EPSILON as f64 } else { aperture_radius };
    let focus_distance = node.float("focus_distance", far)?;
    if !(focus_distance > 0.0) {
        return Err(LoadError::at(node.loc_of("focus_distance"), "focus_distance must be positive"));
    }
    if has_scale(to_world) {
        return Err(
            node.error("thinlens: scale factors in the camera-to-world transformation are not allowed (as in Mitsuba)")
        );
    }
    Ok(SensorModel::ThinLens { fov, axis, aperture_radius, focus_distance })
}

fn orthographic(_: &Node, _: &glam::DMat4, _: f64) -> Result<SensorModel> {
    Ok(SensorModel::Orthographic)
}

/// A frame whose +z is the unit vector `d` and whose origin is `o` (any
/// perpendicular axes: Mitsuba's `coordinate_system`).
fn frame_along(o: glam::DVec3, d: glam::DVec3) -> glam::DMat4 {
    let up = if d.z.abs() < 0.9 { glam::DVec3::Z } else { glam::DVec3::X };
    let up = (up - d * d.dot(up)).normalize();
    let x = up.cross(d);
    glam::DMat4::from_cols(x.extend(0.0), up.extend(0.0), d.extend(0.0), o.extend(1.0))
}

/// Mitsuba's `irradiancemeter`, nested in the shape it measures over (no
/// parameters of its own; `srf` is for spectral variants).
///
/// | parameter | type | default |
/// |-----------|------|---------|
/// | (film)    | hdrfilm | any size; Mitsuba advises a box filter |
fn irradiancemeter(node: &Node, _: &glam::DMat4, _: f64) -> Result<SensorModel> {
    if node.has("to_world") {
        return Err(LoadError::at(
            node.loc_of("to_world"),
            "irradiancemeter takes no 'to_world': it measures over its shape (as in Mitsuba)",
        ));
    }
    Ok(SensorModel::IrradianceMeter)
}

/// Mitsuba's `distant`: the radiance leaving the scene along -`direction`,
/// averaged over a target.
///
/// | parameter | type | default |
/// |-----------|------|---------|
/// | direction | vector | (or `to_world`): the direction the sensor's rays travel |
/// | to_world  | transform | identity: rays along its +z |
/// | target    | point or nested shape | the scene's bounding-sphere cross section |
/// | (film)    | hdrfilm | width or height 1 |
#[allow(clippy::neg_cmp_op_on_partial_ord)] // `!(x > y)` is also true for NaN, on purpose
fn distant(node: &Node, to_world: &glam::DMat4, _: f64) -> Result<SensorModel> {
    let to_world = match node.get_point("direction")? {
        Some(_) if node.has("to_world") => {
            return Err(LoadError::at(
                node.loc_of("direction"),
                "distant: give either 'direction' or 'to_world', not both",
            ))
        }
        Some(d) => {
            if !(d.is_finite() && d.length() > 0.0) {
                return Err(LoadError::at(node.loc_of("direction"), "direction must be a non-zero vector"));
            }
            frame_along(glam::DVec3::ZERO, d.normalize())
        }
        None => *to_world,
    };
    let target = node.get_point("target")?;
    let shapes: Vec<_> = node.children_of(Kind::Shape).collect();
    let shape = match (target, shapes.as_slice()) {
        (None, []) => None,
        (None, [c]) if c.name.as_deref() == Some("target") => Some(Box::new(super::shape::detached_shape(&c.node)?)),
        (Some(_), [c, ..]) => {
            return Err(LoadError::at(&c.loc, "distant: give 'target' as a point or as a shape, not both"))
        }
        (None, [c, ..]) => {
            return Err(LoadError::at(&c.loc, "distant: the sensor takes one nested shape, named 'target'"))
        }
        (Some(_), []) => None,
    };
    Ok(SensorModel::Distant { to_world, target, shape })
}

/// Mitsuba's `radiancemeter`: `to_world`, or `origin` and `direction`
/// (both), placing one ray along local +z.
fn radiancemeter(node: &Node, to_world: &glam::DMat4, _: f64) -> Result<SensorModel> {
    let origin = node.get_point("origin")?;
    let direction = node.get_point("direction")?;
    if node.has("to_world") {
        return Ok(SensorModel::RadianceMeter { to_world: *to_world });
    }
    match (origin, direction) {
        (None, None) => Ok(SensorModel::RadianceMeter { to_world: *to_world }),
        (Some(o), Some(d)) => {
            if !(d.is_finite() && d.length() > 0.0) {
                return Err(LoadError::at(node.loc_of("direction"), "direction must be a non-zero vector"));
            }
            Ok(SensorModel::RadianceMeter { to_world: frame_along(o, d.normalize()) })
        }
        _ => Err(node.error("radiancemeter: give both 'origin' and 'direction', or a 'to_world'")),
    }
}

/// Mitsuba's `hdrfilm`: its size, crop window and `<rfilter>`.
fn hdrfilm(film: &Node) -> Result<(FilmRect, Filter)> {
    let width = film.int("width", 768)?;
    let height = film.int("height", 576)?;
    if !(1..=1 << 16).contains(&width) || !(1..=1 << 16).contains(&height) {
        return Err(film.error("film width and height must be between 1 and 65536"));
    }
    let (w, h) = (width as u32, height as u32);
    let cx = film.int("crop_offset_x", 0)?;
    let cy = film.int("crop_offset_y", 0)?;
    let cw = film.int("crop_width", width)?;
    let ch = film.int("crop_height", height)?;
    if cx < 0 || cy < 0 || cw < 1 || ch < 1 || cx + cw > width || cy + ch > height {
        return Err(film.error(format!(
            "the crop window ({cx}, {cy}) + ({cw} x {ch}) does not lie inside the {width} x {height} film"
        )));
    }
    let rect = FilmRect { size: (w, h), crop_offset: (cx as u32, cy as u32), crop_size: (cw as u32, ch as u32) };
    // Output-format settings that cannot change the rendered values.
    film.accept(&["pixel_format", "component_format", "file_format", "sample_border", "compensate"]);
    Ok((rect, rfilter(film)?))
}

/// The film's reconstruction filter: its `<rfilter>`, else Mitsuba's
/// default, a Gaussian of standard deviation 0.5.
#[allow(clippy::neg_cmp_op_on_partial_ord)] // `!(x > y)` is also true for NaN, on purpose
fn rfilter(film: &Node) -> Result<Filter> {
    Ok(match film.single_child(Kind::Rfilter)? {
        None => Filter::new(FilterKind::Gaussian { stddev: 0.5 }),
        Some(f) => {
            let kind = plugin(RFILTERS, &f)?(&f)?;
            f.check_all_used(&[])?;
            let filter = Filter::new(kind);
            if filter.margin() > MAX_MARGIN || !(filter.radius > 0.0) {
                return Err(f.error(format!(
                    "the {} filter's radius {} is not supported: it must be positive and reach at most {MAX_MARGIN} pixels",
                    f.plugin, filter.radius
                )));
            }
            filter
        }
    })
}

fn stratified(s: &Node) -> Result<SamplerKind> {
    if !s.bool("jitter", true)? {
        return Err(LoadError::at(s.loc_of("jitter"), "stratified: jitter=false is not supported"));
    }
    Ok(SamplerKind::Stratified)
}

fn orthogonal(s: &Node) -> Result<SamplerKind> {
    if s.int("strength", 2)? != 2 {
        return Err(LoadError::at(
            s.loc_of("strength"),
            "orthogonal: only strength 2 (Bose construction, the default) is supported",
        ));
    }
    Ok(SamplerKind::Orthogonal { jitter: s.bool("jitter", true)? })
}

/// The sensor `node`; `on_shape` is the shape it is nested in (world space).
pub(super) fn build_sensor(
    node: &Node,
    ov: &Overrides,
    on_shape: Option<penumbra_render::geometry::Shape>,
) -> Result<SensorParts> {
    if node.plugin == "batch" {
        if on_shape.is_some() {
            return Err(node.error("a batch sensor cannot be nested in a shape"));
        }
        return batch(node, ov);
    }
    let (model, to_world, near, far) = sensor_model(node, on_shape.is_some())?;
    let (rect, filter, sampler) = film_and_sampler(node, ov)?;
    let target_shape = matches!(model, SensorModel::Distant { shape: Some(_), .. });
    node.check_all_used(if target_shape {
        &[Kind::Film, Kind::Sampler, Kind::Medium, Kind::Shape]
    } else {
        &[Kind::Film, Kind::Sampler, Kind::Medium]
    })?;
    let camera = camera(node, model, &to_world, near, far, on_shape, rect.size)?;
    Ok((camera, filter, rect, sampler))
}

/// Mitsuba's `batch` sensor (src/sensors/batch.cpp):
///
/// | parameter | default | meaning |
/// |-----------|---------|---------|
/// | nested `<sensor>`s | (at least one) | rendered side by side, sensor i over film x in [i w/n, (i+1) w/n); a perspective or thinlens sensor keeps the horizontal field of view its `fov` gives on its own film (default 768 x 576), as Mitsuba's |
/// | `<film>`, `<sampler>` | | the batch's: width a multiple of the sensor count; each nested sensor is built for a film of width / n by height, and its own film and sampler (checked, as Mitsuba creates them) are ignored |
/// | `to_world`, `shutter_open`, `shutter_close` | | read, no effect (as in Mitsuba) |
///
/// `srf` is a spectral parameter that Mitsuba's RGB variants refuse; shapes
/// carrying sensors (irradiancemeters) inside a batch are not supported; the
/// camera's medium is the batch's (`<medium>` of the batch sensor, as
/// Mitsuba's volpath reads it), so nested sensors may not have one; `ptracer`
/// cannot render a batch (as in Mitsuba).
fn batch(node: &Node, ov: &Overrides) -> Result<SensorParts> {
    let to_world = node.transform("to_world")?;
    node.accept(&["shutter_open", "shutter_close"]);
    if node.has("srf") {
        return Err(LoadError::at(
            node.loc_of("srf"),
            "srf (a sensor response function) is spectral; Mitsuba's RGB variants refuse it",
        ));
    }
    let subs: Vec<_> = node.children_of(Kind::Sensor).map(|c| c.node.clone()).collect();
    if subs.is_empty() {
        return Err(node.error("batch: at least one nested sensor must be given"));
    }
    let (rect, filter, sampler) = film_and_sampler(node, ov)?;
    node.check_all_used(&[Kind::Film, Kind::Sampler, Kind::Medium, Kind::Sensor])?;
    let (w, h) = rect.size;
    let n = subs.len() as u32;
    if w % n != 0 {
        return Err(node.error(format!(
            "batch: the film width ({w}) must be divisible by the number of nested sensors ({n}), as in Mitsuba"
        )));
    }
    let mut cameras = Vec::with_capacity(subs.len());
    for sub in &subs {
        if sub.plugin == "batch" {
            return Err(sub.error("a batch sensor cannot be nested in another"));
        }
        if let Some(m) = sub.children_of(Kind::Medium).next() {
            return Err(LoadError::at(
                &m.loc,
                "a sensor inside a batch cannot have a medium (Mitsuba uses the batch's); give it to the batch sensor",
            ));
        }
        let (model, to_world, near, far) = sensor_model(sub, false)?;
        // Checked as Mitsuba creates them, then superseded by the batch's;
        // without one, Mitsuba's default hdrfilm (768 x 576).
        let own_size = match sub.single_child(Kind::Film)? {
            Some(film) => {
                let (r, _) = plugin(FILMS, &film)?(&film)?;
                film.check_all_used(&[Kind::Rfilter])?;
                r.size
            }
            None => (768, 576),
        };
        // Mitsuba turns `fov` into the horizontal field of view once, with
        // the aspect of the sensor's own film, and keeps it when the batch
        // resizes that film (perspective.cpp / thinlens.cpp's x_fov).
        let fov = match &model {
            SensorModel::Perspective { fov, axis } | SensorModel::ThinLens { fov, axis, .. } => Some((*fov, *axis)),
            _ => None,
        };
        if let Some(s) = sub.single_child(Kind::Sampler)? {
            plugin(SAMPLERS, &s)?(&s)?;
            s.accept(&["sample_count", "seed"]);
            s.check_all_used(&[])?;
        }
        let target_shape = matches!(model, SensorModel::Distant { shape: Some(_), .. });
        sub.check_all_used(if target_shape {
            &[Kind::Film, Kind::Sampler, Kind::Shape]
        } else {
            &[Kind::Film, Kind::Sampler]
        })?;
        let mut c = camera(sub, model, &to_world, near, far, None, (w / n, h))?;
        if let Some((fov, axis)) = fov {
            let tan_x = tan_half_x(fov as f32, axis, own_size.0 as f32 / own_size.1 as f32);
            c.tan_half = glam::Vec2::new(tan_x, tan_x * h as f32 / (w / n) as f32);
        }
        cameras.push(c);
    }
    Ok((Camera::batch(to_world.as_mat4(), cameras), filter, rect, sampler))
}

#[allow(clippy::neg_cmp_op_on_partial_ord)] // `!(x > y)` is also true for NaN, on purpose
/// A sensor's projection, `to_world`, near and far clip distances, with
/// the checks of its parameters; `on_shape`: nested in a shape.
fn sensor_model(node: &Node, on_shape: bool) -> Result<(SensorModel, glam::DMat4, f64, f64)> {
    let sensor_model = plugin(SENSORS, node)?;
    let to_world = node.transform("to_world")?;
    let near = node.float("near_clip", 0.01)?;
    let far = node.float("far_clip", 10000.0)?;
    if !(near > 0.0 && far > near) {
        return Err(node.error("near_clip must be positive and smaller than far_clip"));
    }
    let model = sensor_model(node, &to_world, far)?;
    match (&model, on_shape) {
        (SensorModel::IrradianceMeter, false) => {
            return Err(node.error("an irradiancemeter must be nested inside the shape it measures over"))
        }
        (SensorModel::IrradianceMeter, true) | (_, false) => {}
        (_, true) => {
            return Err(node
                .error(format!("a {} sensor cannot be nested in a shape; only an irradiancemeter can", node.plugin)))
        }
    }
    if let SensorModel::RadianceMeter { .. } | SensorModel::IrradianceMeter | SensorModel::Distant { .. } = model {
        node.accept(&["near_clip", "far_clip"]);
    } else if !matches!(model, SensorModel::Orthographic) {
        for p in ["principal_point_offset_x", "principal_point_offset_y"] {
            if node.float(p, 0.0)? != 0.0 {
                return Err(LoadError::at(node.loc_of(p), format!("{p} is not supported yet")));
            }
        }
    }
    node.accept(&["shutter_open", "shutter_close"]);
    // Every projective camera of Mitsuba reads it; only thinlens uses it.
    node.accept(&["focus_distance"]);
    Ok((model, to_world, near, far))
}

/// The sensor's film (its size, crop window and filter) and sampler, with
/// the command line's overrides.
fn film_and_sampler(node: &Node, ov: &Overrides) -> Result<(FilmRect, Filter, Sampler)> {
    // Film.
    let film =
        node.single_child(Kind::Film)?.ok_or_else(|| node.error("the sensor needs a <film type=\"hdrfilm\">"))?;
    let (rect, filter) = plugin(FILMS, &film)?(&film)?;
    film.check_all_used(&[Kind::Rfilter])?;

    // Sampler.
    let (kind, mut spp, mut seed) = match node.single_child(Kind::Sampler)? {
        None => (SamplerKind::Independent, 4, 0),
        Some(s) => {
            let kind = plugin(SAMPLERS, &s)?(&s)?;
            let spp = s.int("sample_count", 4)?;
            let seed = s.int("seed", 0)?;
            if spp < 1 || spp > u32::MAX as i64 {
                return Err(LoadError::at(s.loc_of("sample_count"), "sample_count must be a positive integer"));
            }
            s.check_all_used(&[])?;
            (kind, spp as u32, seed as u64)
        }
    };
    let kind = sampler_kind(ov.sampler.as_deref(), kind)?;
    if let Some(o) = ov.spp {
        spp = o;
    }
    // Mitsuba's stratified samplers round the count up to what their
    // construction needs (checked with 3.9.1, e.g. stratified 10 -> 16,
    // multijitter 10 -> 12, orthogonal 16 -> 25, ldsampler 17 -> 64).
    spp = kind.round_sample_count(spp);
    if let Some(o) = ov.seed {
        seed = o;
    }
    Ok((rect, filter, Sampler::new(kind, seed, spp)))
}

/// The camera of sensor `node` for a film of `(w, h)` pixels.
fn camera(
    node: &Node,
    model: SensorModel,
    to_world: &glam::DMat4,
    near: f64,
    far: f64,
    on_shape: Option<penumbra_render::geometry::Shape>,
    (w, h): (u32, u32),
) -> Result<Camera> {
    let m = to_world.as_mat4();
    Ok(match model {
        SensorModel::Perspective { fov, axis } => Camera::new(m, fov as f32, axis, w, h, near as f32, far as f32),
        SensorModel::ThinLens { fov, axis, aperture_radius, focus_distance } => Camera::thin_lens(
            m,
            fov as f32,
            axis,
            w,
            h,
            near as f32,
            far as f32,
            aperture_radius as f32,
            focus_distance as f32,
        ),
        SensorModel::Orthographic => Camera::orthographic(m, w, h, near as f32, far as f32),
        SensorModel::RadianceMeter { to_world } => {
            // Mitsuba refuses films whose width and height both differ from 1.
            if w != 1 && h != 1 {
                return Err(node.error(format!("radiancemeter needs a film of 1x1 pixels, not {w}x{h}")));
            }
            Camera::radiance_meter(to_world.as_mat4())
        }
        SensorModel::IrradianceMeter => match on_shape {
            Some(shape) => Camera::irradiance_meter(shape),
            None => return Err(node.error("an irradiancemeter must be nested inside the shape it measures over")),
        },
        SensorModel::Distant { to_world, target, shape } => {
            // Mitsuba refuses films whose width and height both differ from 1.
            if w != 1 && h != 1 {
                return Err(node.error(format!("distant needs a film of 1x1 pixels, not {w}x{h}")));
            }
            Camera::distant(to_world.as_mat4(), target.map(|t| t.as_vec3()), shape.map(|s| *s))
        }
        SensorModel::Batch => return Err(node.error("a batch sensor cannot be nested in another")),
    })
}

/// The sampler `--sampler NAME` selects, else `default`.
pub fn sampler_kind(name: Option<&str>, default: SamplerKind) -> Result<SamplerKind> {
    Ok(match name {
        None => default,
        Some("independent") => SamplerKind::Independent,
        Some("stratified") => SamplerKind::Stratified,
        Some("multijitter") => SamplerKind::Multijitter { jitter: true },
        Some("orthogonal") => SamplerKind::Orthogonal { jitter: true },
        Some("ldsampler") => SamplerKind::LowDiscrepancy,
        Some("sobol") => SamplerKind::Sobol,
        Some(other) => {
            return Err(LoadError::new(
                None,
                format!("--sampler {other}: unknown sampler; use one of {}", SAMPLER_OVERRIDES.join(", ")),
            ))
        }
    })
}
