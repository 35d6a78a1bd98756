//! A [`PbrtScene`] → [`SceneBuilder`] calls: pbrt-v4's camera, film,
//! filter, sampler and integrator (here), textures, materials, shapes and
//! lights (one module each). Whatever Penumbra does not render as pbrt-v4
//! does is an error naming its position, or (where the expected image is
//! the same, or the difference is documented) a note.
//!
//! | directive   | kinds and parameters read                                          |
//! |-------------|--------------------------------------------------------------------|
//! | Camera      | perspective: fov (90, along the shorter image axis), lensradius (0: a pinhole; else a thin lens), focaldistance (10⁶), shutteropen, shutterclose; orthographic: screenwindow (centred), lensradius 0 |
//! | Film        | rgb (gbuffer: the same, `coordinatesystem` read; its channels are `--aov`): xresolution (1280), yresolution (720), cropwindow, filename (not used: the output is Penumbra's `-o`), sensor cie1931, iso 100, exposuretime 1, whitebalance 0, savefp16, diagonal |
//! | PixelFilter | gaussian (sigma 0.5; truncated at 4σ, pbrt-v4 at its radius 1.5), box (radius 0.5), triangle (radius), mitchell (radius 2, B, C) |
//! | Sampler     | pixelsamples (16), seed; independent, stratified (xsamples × ysamples, jittered); zsobol, sobol, paddedsobol, halton, pmj02bn: Owen-scrambled Sobol' (the same expected image) |
//! | Integrator  | path, volpath (with media: Penumbra's volumetric path tracer; see `media`): maxdepth (5 bounces = Mitsuba's max_depth 6), lightsampler (bvh, power, uniform), regularize false; `--integrator` replaces it as for XML scenes (max_depth carried over) |
//! | Option      | seed                                                               |
//! | ColorSpace  | srgb                                                               |
//!
//! pbrt-v4's camera looks along +z with +y up and +x to the *right* of the
//! image (left-handed screen space); Mitsuba's camera puts +x at the left.
//! The camera-to-world transform is therefore mirrored in x, which renders
//! pbrt-v4's image, not its mirror image.

#![allow(clippy::neg_cmp_op_on_partial_ord)] // `!(x > y)` is also true for NaN, on purpose

mod lights;
mod materials;
mod media;
mod shapes;
mod spectra;
mod textures;

use super::params::ParamList;
use super::parser::{Entity, MaterialRef, PbrtScene, ShapeEntity};
use crate::builder::Overrides;
use crate::error::{FileLoc, LoadError, Result};
use crate::scene_builder::{Emission, Film, SceneBuilder, ShapeDesc};
use glam::{DMat4, DVec3};
use materials::Materials;
use penumbra_render::camera::{Camera, FovAxis};
use penumbra_render::film::{Filter, FilterKind};
use penumbra_render::integrator::{Integrator, PathIntegrator, Termination, VolPathIntegrator, DEFAULT_CAUSTICS};
use penumbra_render::light::LightSelection;
use penumbra_render::material::Material;
use penumbra_render::render::RenderJob;
use penumbra_render::sampling::{Sampler, SamplerKind};
use penumbra_render::texture::Texture;
use std::collections::HashMap;
use std::path::Path;
use std::sync::Arc;
use textures::Textures;

/// Near and far clip distances: pbrt-v4's cameras do not clip.
const NEAR: f32 = 1e-4;
const FAR: f32 = 1e30;

/// The render job of a parsed scene (from `path`), with notes on what
/// Penumbra renders differently from pbrt-v4 in a way a user should know.
pub fn translate(scene: &PbrtScene, path: &Path, ov: &Overrides) -> Result<(RenderJob, Vec<String>)> {
    let file = FileLoc::new(Arc::new(path.to_path_buf()), 0, 0);
    let mut notes = Vec::new();
    let mut b = SceneBuilder::new(file.clone());
    if let Some((cs, at)) = &scene.color_space {
        if cs != "srgb" {
            return Err(LoadError::at(at, format!("ColorSpace \"{cs}\" is not supported; only \"srgb\"")));
        }
    }
    let option_seed = scene.options.int("seed", 0)?;
    scene.options.check_unused("Option")?;
    if let Some(a) = &scene.accelerator {
        a.params.int("maxnodeprims", 4)?;
        a.params.string("splitmethod")?;
        a.params.check_unused(&format!("Accelerator \"{}\"", a.kind))?;
    }

    // Camera and film.
    let (film, (w, h)) = film(scene.film.as_ref(), &mut notes)?;
    let camera = camera(scene, w, h)?;
    b.set_film(film, filter(scene.filter.as_ref(), &mut notes)?);
    b.set_sampler(sampler(scene.sampler.as_ref(), option_seed, ov, &mut notes)?);
    let (integrator, selection, iat) = integrator(scene.integrator.as_ref(), &file, ov, &mut notes)?;
    // Media: rendered by `volpath` only, as in pbrt-v4 (see `media`).
    let volumetric = matches!(integrator, Integrator::VolPath(_));
    b.set_integrator(integrator, selection, &iat);
    let media = media::Media::new(scene, &mut b)?;
    let camera_medium = match &scene.camera {
        Some(c) if volumetric => media.get(&c.medium, &c.entity.loc)?,
        _ => None,
    };
    b.set_camera(camera, camera_medium);
    let uses_media = scene.shapes.iter().any(|s| !s.media.0.is_empty() || !s.media.1.is_empty())
        || scene.camera.as_ref().is_some_and(|c| !c.medium.is_empty());
    if uses_media && !volumetric {
        notes.push(
            "the scene's media are not rendered: pbrt-v4's \"path\" integrator ignores them (use \"volpath\")".into(),
        );
    }

    // Materials and shapes.
    let tex = Textures::new(&scene.textures)?;
    let mats = Materials::new(&scene.named_materials);
    let mut ids: HashMap<String, u32> = HashMap::new();
    let mut material_id = |b: &mut SceneBuilder, s: &ShapeEntity, alpha: Option<Texture>| -> Result<u32> {
        let key = match &s.material {
            MaterialRef::Anonymous(i) => format!("#{i:?}"),
            MaterialRef::Named(n, _) => format!("@{n}"),
        };
        let key = match &alpha {
            Some(_) => format!("{key}|alpha {}", s.entity.loc),
            None => key,
        };
        if let Some(&id) = ids.get(&key) {
            return Ok(id);
        }
        let m = match &s.material {
            MaterialRef::Anonymous(None) => {
                let d = Material::Diffuse(penumbra_render::bsdf::DiffuseParams {
                    reflectance: Texture::Constant(glam::Vec3::splat(0.5)),
                });
                Material::TwoSided(Box::new(d.clone()), Box::new(d))
            }
            MaterialRef::Anonymous(Some(i)) => mats.entity(&scene.materials[*i], &tex, 0)?,
            MaterialRef::Named(n, at) => mats_named(&mats, &scene.named_materials, n, &tex, at)?,
        };
        let m = match alpha {
            Some(opacity) => Material::Mask { opacity, inner: Box::new(m) },
            None => m,
        };
        let id = b.add_material(m);
        ids.insert(key, id);
        Ok(id)
    };
    let alpha_of = |s: &ShapeEntity| -> Result<Option<Option<Texture>>> {
        // None: not drawn (alpha 0); Some(None): opaque.
        match tex.optional(&s.entity.params, "alpha", None)? {
            None => Ok(Some(None)),
            Some(t) => match t.constant() {
                Some([a, ..]) if a <= 0.0 => Ok(None),
                Some([a, ..]) if a >= 1.0 => Ok(Some(None)),
                _ => Ok(Some(Some(t.build(&s.entity.loc)?))),
            },
        }
    };
    // Media inside object definitions are not supported (a group's members share one placement).
    let media_check = |s: &ShapeEntity| -> Result<()> {
        if volumetric && (!s.media.0.is_empty() || !s.media.1.is_empty()) {
            return Err(LoadError::at(
                &s.entity.loc,
                format!(
                    "MediumInterface \"{}\" \"{}\" inside ObjectBegin: media of instanced shapes are not supported",
                    s.media.0, s.media.1
                ),
            ));
        }
        Ok(())
    };
    for s in &scene.shapes {
        let shape_media = if volumetric { media.interface(&s.media, &s.entity.loc)? } else { Default::default() };
        let Some(alpha) = alpha_of(s)? else {
            s.entity.params.check_unused(&format!("Shape \"{}\"", s.entity.kind))?;
            continue;
        };
        let geometry = shapes::geometry(s)?;
        s.entity.params.check_unused(&format!("Shape \"{}\"", s.entity.kind))?;
        if alpha.is_some() && s.area_light.is_some() {
            // pbrt-v4 cuts the emission out too; Penumbra's area lights emit everywhere on the shape.
            return Err(LoadError::at(&s.entity.loc, "\"alpha\" on an area light's shape is not supported"));
        }
        let material = material_id(&mut b, s, alpha)?;
        let emission = match &s.area_light {
            None => None,
            Some(al) => {
                let (l, two_sided) = lights::area_radiance(al, geometry.0.area(), &s.entity.loc)?;
                let l = Texture::Constant(l);
                Some(if two_sided { Emission::DiffuseTwoSided(l) } else { Emission::Diffuse(l) })
            }
        };
        let desc = ShapeDesc { emission, media: shape_media, ..ShapeDesc::new(geometry, material) };
        let id = b.add_shape(desc, &s.entity.loc)?;
        b.place_shape(id);
    }

    // Object instances: each definition a group, built where first used.
    let mut groups: HashMap<&str, u32> = HashMap::new();
    for inst in &scene.instances {
        let g = match groups.get(inst.name.as_str()) {
            Some(&g) => g,
            None => {
                let Some((name, def)) = scene.instance_definitions.get_key_value(&inst.name) else {
                    return Err(LoadError::at(
                        &inst.loc,
                        format!("ObjectInstance \"{}\": no such ObjectBegin", inst.name),
                    ));
                };
                let mut members = Vec::new();
                for s in &def.shapes {
                    media_check(s)?;
                    let Some(alpha) = alpha_of(s)? else { continue };
                    let geometry = shapes::geometry(s)?;
                    s.entity.params.check_unused(&format!("Shape \"{}\"", s.entity.kind))?;
                    let material = material_id(&mut b, s, alpha)?;
                    members.push(b.add_shape(ShapeDesc::new(geometry, material), &s.entity.loc)?);
                }
                let g = b.add_group(members, &def.loc)?;
                groups.insert(name.as_str(), g);
                g
            }
        };
        b.add_instance(g, inst.world_from_instance.as_mat4(), &inst.loc)?;
    }

    // Lights.
    for l in &scene.lights {
        let light = lights::light(l)?;
        b.add_light(light, &l.entity.loc)?;
    }
    let job = b.finish()?;
    Ok((job, notes))
}

fn mats_named(
    mats: &Materials,
    named: &HashMap<String, Entity>,
    n: &str,
    tex: &Textures,
    at: &FileLoc,
) -> Result<Material> {
    match named.get(n) {
        Some(e) => mats.entity(e, tex, 0),
        None => Err(LoadError::at(at, format!("no material named \"{n}\" (MakeNamedMaterial) is defined"))),
    }
}

/// The film's size and crop window.
fn film(e: Option<&Entity>, notes: &mut Vec<String>) -> Result<(Film, (u32, u32))> {
    let empty = ParamList::default();
    let (p, at) = match e {
        Some(e) => {
            match e.kind.as_str() {
                "rgb" => {}
                // The RGB film plus geometric channels (Penumbra's --aov).
                "gbuffer" => {
                    e.params.string("coordinatesystem")?;
                    notes.push("Film \"gbuffer\" renders as \"rgb\"; its extra channels are Penumbra's --aov".into());
                }
                other => {
                    return Err(LoadError::at(
                        &e.loc,
                        format!("Film \"{other}\" is not supported; supported: rgb, gbuffer"),
                    ))
                }
            }
            (&e.params, e.loc.clone())
        }
        None => (&empty, FileLoc::new(Arc::new(Default::default()), 0, 0)),
    };
    let (w, h) = (p.int("xresolution", 1280)?, p.int("yresolution", 720)?);
    if !(1..=1 << 16).contains(&w) || !(1..=1 << 16).contains(&h) {
        return Err(LoadError::at(&at, format!("film resolution {w}x{h}: each side must lie in 1..=65536")));
    }
    if let Some(f) = p.string("filename")? {
        notes.push(format!("Film \"filename\" \"{f}\" is not used: give the output with -o"));
    }
    for (name, default) in [("iso", 100.0), ("exposuretime", 1.0), ("whitebalance", 0.0)] {
        let v = p.float(name, default)?;
        if v != default {
            return Err(LoadError::at(&at, format!("Film \"float {name}\" {v} is not supported; only {default}")));
        }
    }
    if let Some(s) = p.string("sensor")? {
        if s != "cie1931" {
            return Err(LoadError::at(&at, format!("Film sensor \"{s}\" is not supported; only \"cie1931\"")));
        }
    }
    if p.float("maxcomponentvalue", f64::INFINITY)?.is_finite() {
        return Err(LoadError::at(&at, "Film \"maxcomponentvalue\" (clamping samples) is not supported"));
    }
    p.bool("savefp16", true)?;
    p.float("diagonal", 35.0)?;
    let (w, h) = (w as u32, h as u32);
    let mut film = Film::new(w, h);
    if let Some(c) = p.floats("cropwindow")? {
        let [x0, x1, y0, y1] = c[..] else {
            return Err(LoadError::at(&at, "cropwindow takes four numbers: x0 x1 y0 y1"));
        };
        let (x0, x1, y0, y1) = (x0.min(x1), x0.max(x1), y0.min(y1), y0.max(y1));
        if !(x0 >= 0.0 && x1 <= 1.0 && y0 >= 0.0 && y1 <= 1.0) {
            return Err(LoadError::at(&at, "cropwindow's numbers must lie in [0, 1]"));
        }
        // pbrt-v4: pixel bounds from ⌈res · crop⌉ on both ends.
        let px = |f: f64, n: u32| (n as f64 * f).ceil() as u32;
        let (ax, bx, ay, by) = (px(x0, w), px(x1, w), px(y0, h), px(y1, h));
        if bx <= ax || by <= ay {
            return Err(LoadError::at(&at, "cropwindow holds no pixel"));
        }
        film = Film { size: (w, h), crop_offset: (ax, ay), crop_size: (bx - ax, by - ay) };
    }
    if let Some(e) = e {
        e.params.check_unused(&format!("Film \"{}\"", e.kind))?;
    }
    Ok((film, (w, h)))
}

/// pbrt-v4's camera as Penumbra's (see the module documentation for the mirror).
fn camera(scene: &PbrtScene, w: u32, h: u32) -> Result<Camera> {
    let default = Entity {
        kind: "perspective".into(),
        params: ParamList::default(),
        loc: FileLoc::new(Arc::new(Default::default()), 0, 0),
    };
    let (e, camera_from_world) = match &scene.camera {
        Some(c) => (&c.entity, c.camera_from_world),
        None => (&default, DMat4::IDENTITY),
    };
    let (p, at) = (&e.params, &e.loc);
    let world_from_camera = (camera_from_world.inverse() * DMat4::from_scale(DVec3::new(-1.0, 1.0, 1.0))).as_mat4();
    if !world_from_camera.is_finite() {
        return Err(LoadError::at(at, "the camera's transform is singular"));
    }
    p.float("shutteropen", 0.0)?;
    p.float("shutterclose", 1.0)?;
    if p.type_of("frameaspectratio").is_some() {
        return Err(LoadError::at(
            at,
            "Camera \"frameaspectratio\" is not supported (the film's aspect ratio is used)",
        ));
    }
    let lens = p.float("lensradius", 0.0)?;
    let focus = p.float("focaldistance", 1e6)?;
    let cam = match e.kind.as_str() {
        "perspective" => {
            if p.type_of("screenwindow").is_some() {
                return Err(LoadError::at(at, "a perspective Camera's \"screenwindow\" is not supported"));
            }
            let fov = p.float("fov", 90.0)?;
            if !(fov > 0.0 && fov < 180.0) {
                return Err(LoadError::at(at, format!("fov {fov} must lie strictly between 0 and 180 degrees")));
            }
            if lens > 0.0 {
                if !(focus > 0.0) {
                    return Err(LoadError::at(at, "focaldistance must be positive"));
                }
                Camera::thin_lens(
                    world_from_camera,
                    fov as f32,
                    FovAxis::Smaller,
                    w,
                    h,
                    NEAR,
                    FAR,
                    lens as f32,
                    focus as f32,
                )
            } else {
                Camera::new(world_from_camera, fov as f32, FovAxis::Smaller, w, h, NEAR, FAR)
            }
        }
        "orthographic" => {
            if lens > 0.0 {
                return Err(LoadError::at(at, "an orthographic Camera with a lens (lensradius > 0) is not supported"));
            }
            let aspect = w as f64 / h as f64;
            let sw = p.floats("screenwindow")?;
            let (hx, hy) = match sw.as_deref() {
                None if aspect > 1.0 => (aspect, 1.0),
                None => (1.0, 1.0 / aspect),
                Some(&[x0, x1, y0, y1]) => {
                    if (x0 + x1).abs() > 1e-9 * x1.abs() || (y0 + y1).abs() > 1e-9 * y1.abs() || !(x1 > x0 && y1 > y0) {
                        return Err(LoadError::at(at, "an off-centre or empty screenwindow is not supported"));
                    }
                    (x1, y1)
                }
                Some(_) => return Err(LoadError::at(at, "screenwindow takes four numbers: x0 x1 y0 y1")),
            };
            // Penumbra's film spans [-1, 1] x [-1/aspect, 1/aspect] in camera space.
            let s = DMat4::from_scale(DVec3::new(hx, hy * aspect, 1.0)).as_mat4();
            Camera::orthographic(world_from_camera * s, w, h, NEAR, FAR)
        }
        other => {
            return Err(LoadError::at(
                at,
                format!("Camera \"{other}\" is not supported; supported: perspective, orthographic"),
            ))
        }
    };
    p.check_unused(&format!("Camera \"{}\"", e.kind))?;
    Ok(cam)
}

fn filter(e: Option<&Entity>, notes: &mut Vec<String>) -> Result<Filter> {
    let Some(e) = e else {
        notes.push("pbrt-v4's default Gaussian filter (radius 1.5) is truncated at 4 sigma = 2 pixels".into());
        return Ok(Filter::new(FilterKind::Gaussian { stddev: 0.5 }));
    };
    let (p, at) = (&e.params, &e.loc);
    let radius = |d: f64| -> Result<f64> {
        let (x, y) = (p.float("xradius", d)?, p.float("yradius", d)?);
        if x != y {
            return Err(LoadError::at(at, "a filter with xradius != yradius is not supported"));
        }
        Ok(x)
    };
    let fixed = |r: f64, d: f64| -> Result<()> {
        if r != d {
            return Err(LoadError::at(at, format!("PixelFilter \"{}\": only radius {d} is supported", e.kind)));
        }
        Ok(())
    };
    let kind = match e.kind.as_str() {
        "gaussian" => {
            radius(1.5)?;
            notes.push("the Gaussian filter is truncated at 4 sigma (pbrt-v4: at its radius)".into());
            FilterKind::Gaussian { stddev: p.float("sigma", 0.5)? as f32 }
        }
        "box" => {
            fixed(radius(0.5)?, 0.5)?;
            FilterKind::Box
        }
        "triangle" => FilterKind::Tent { radius: radius(2.0)? as f32 },
        "mitchell" => {
            fixed(radius(2.0)?, 2.0)?;
            FilterKind::Mitchell { b: p.float("B", 1.0 / 3.0)? as f32, c: p.float("C", 1.0 / 3.0)? as f32 }
        }
        other => {
            return Err(LoadError::at(
                at,
                format!("PixelFilter \"{other}\" is not supported; supported: gaussian, box, triangle, mitchell"),
            ))
        }
    };
    p.check_unused(&format!("PixelFilter \"{}\"", e.kind))?;
    let f = Filter::new(kind);
    if f.margin() > penumbra_render::film::MAX_MARGIN || !(f.radius > 0.0) {
        return Err(LoadError::at(at, format!("the filter's radius {} is not supported", f.radius)));
    }
    Ok(f)
}

fn sampler(e: Option<&Entity>, option_seed: i64, ov: &Overrides, notes: &mut Vec<String>) -> Result<Sampler> {
    let empty = ParamList::default();
    let (p, kind_name, at) = match e {
        Some(e) => (&e.params, e.kind.as_str(), Some(&e.loc)),
        None => (&empty, "zsobol", None),
    };
    let mut spp = p.int("pixelsamples", 16)?;
    let kind = match kind_name {
        "independent" => SamplerKind::Independent,
        "stratified" => {
            if !p.bool("jitter", true)? {
                return Err(LoadError::at(at.expect("given"), "stratified: jitter false is not supported"));
            }
            spp = p.int("xsamples", 4)? * p.int("ysamples", 4)?;
            SamplerKind::Stratified
        }
        "zsobol" | "sobol" | "paddedsobol" | "halton" | "pmj02bn" => {
            p.string("randomization")?;
            if e.is_some() {
                notes.push(format!("Sampler \"{kind_name}\" is rendered with Owen-scrambled Sobol' (same expected image)"));
            }
            SamplerKind::Sobol
        }
        other => {
            return Err(LoadError::at(
                at.expect("given"),
                format!("Sampler \"{other}\" is not supported; supported: independent, stratified, zsobol, sobol, paddedsobol, halton, pmj02bn"),
            ))
        }
    };
    let seed = p.int("seed", option_seed)?;
    if let Some(e) = e {
        e.params.check_unused(&format!("Sampler \"{}\"", e.kind))?;
    }
    if !(1..=u32::MAX as i64).contains(&spp) {
        return Err(LoadError::new(at.cloned(), format!("{spp} samples per pixel: must be positive")));
    }
    let kind = match ov.sampler.as_deref() {
        None => kind,
        Some("independent") => SamplerKind::Independent,
        Some("stratified") => SamplerKind::Stratified,
        Some("multijitter") => SamplerKind::Multijitter { jitter: true },
        Some("orthogonal") => SamplerKind::Orthogonal { jitter: true },
        Some("ldsampler") => SamplerKind::LowDiscrepancy,
        Some("sobol") => SamplerKind::Sobol,
        Some(other) => return Err(LoadError::new(None, format!("--sampler {other}: unknown sampler"))),
    };
    let spp = kind.round_sample_count(ov.spp.unwrap_or(spp as u32));
    Ok(Sampler::new(kind, ov.seed.unwrap_or(seed as u64), spp))
}

/// pbrt-v4 integrators that converge to the image `path` renders (unbiased,
/// or consistent for `sppm`): rendered by path tracing, with a note.
const SAME_IMAGE_INTEGRATORS: &[&str] = &["bdpt", "mlt", "sppm", "lightpath", "simplepath", "randomwalk"];

fn integrator(
    e: Option<&Entity>,
    file: &FileLoc,
    ov: &Overrides,
    notes: &mut Vec<String>,
) -> Result<(Integrator, LightSelection, FileLoc)> {
    let empty = ParamList::default();
    let (p, at) = match e {
        Some(e) => {
            let kind = e.kind.as_str();
            if kind != "path" && kind != "volpath" && !SAME_IMAGE_INTEGRATORS.contains(&kind) {
                return Err(LoadError::at(
                    &e.loc,
                    format!(
                        "Integrator \"{kind}\" is not supported; supported: path, volpath, and {} (rendered by path \
                         tracing, which converges to the same image)",
                        SAME_IMAGE_INTEGRATORS.join(", ")
                    ),
                ));
            }
            (&e.params, e.loc.clone())
        }
        None => (&empty, file.clone()),
    };
    let maxdepth = p.int("maxdepth", 5)?;
    if maxdepth < 0 {
        return Err(LoadError::at(&at, "maxdepth must not be negative"));
    }
    if p.bool("regularize", false)? {
        return Err(LoadError::at(&at, "\"regularize\" true (a biased roughening) is not supported"));
    }
    let selection = match p.string("lightsampler")?.as_deref() {
        None | Some("bvh") => LightSelection::Bvh,
        Some("power") => LightSelection::Power,
        Some("uniform") => LightSelection::Uniform,
        Some(other) => {
            return Err(LoadError::at(&at, format!("lightsampler \"{other}\" is not one of bvh, power, uniform")))
        }
    };
    if let Some(e) = e.filter(|e| SAME_IMAGE_INTEGRATORS.contains(&e.kind.as_str())) {
        let unused = e.params.take_unused();
        let unused = if unused.is_empty() {
            String::new()
        } else {
            format!("; its parameters {} are not used", unused.join(", "))
        };
        notes.push(format!(
            "Integrator \"{}\" is rendered by path tracing with the same maxdepth (the same image in expectation){unused}",
            e.kind
        ));
    }
    if let Some(e) = e {
        e.params.check_unused(&format!("Integrator \"{}\"", e.kind))?;
    }
    let max_depth = (maxdepth as u32).saturating_add(1);
    if let Some(spec) = &ov.integrator {
        // `--integrator NAME[:key=value,...]`: as for XML scenes, the file's
        // path length (in Mitsuba's count) carries over.
        let scene = crate::desc::Node {
            kind: crate::desc::Kind::Integrator,
            plugin: "path".into(),
            id: None,
            name: None,
            props: vec![crate::desc::Property {
                name: "max_depth".into(),
                value: crate::desc::Value::Integer(max_depth as i64),
                loc: at.clone(),
                used: Default::default(),
            }],
            children: Vec::new(),
            loc: at.clone(),
        };
        let node = crate::builder::integrator_from_spec(spec, Some(&scene))?;
        let (integrator, selection) = crate::builder::build_integrator(&node)?;
        return Ok((integrator, selection, at));
    }
    let term = Termination { max_depth, ..Termination::default() };
    if e.is_some_and(|e| e.kind == "volpath") {
        return Ok((Integrator::VolPath(VolPathIntegrator { term, hide_emitters: false }), selection, at));
    }
    Ok((
        Integrator::Path(PathIntegrator { term, caustics: DEFAULT_CAUSTICS, ..PathIntegrator::default() }),
        selection,
        at,
    ))
}
