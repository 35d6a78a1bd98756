//! Scene loading for Penumbra: each format's reader translates its scene
//! into calls of the format-neutral [`SceneBuilder`], which assembles the
//! render job (Mitsuba 3 XML: `mitsuba` → `desc` → `builder`), plus mesh
//! readers, image output and atomic file writes.

#![warn(missing_docs)]

pub mod atomic;
pub mod builder;
pub mod desc;
pub mod error;
#[doc(hidden)]
pub mod fuzzing;
#[cfg(feature = "gltf")]
pub mod gltf;
pub mod image_io;
pub mod mitsuba;
pub mod obj;
pub mod pbrt;
pub mod ply;
pub mod props;
pub mod scene_builder;
pub mod serialized;
pub mod spectrum;
pub mod sunsky_data;
pub mod tensor;
pub mod vol;

pub use builder::{supported_plugins, Overrides};
pub use error::{FileLoc, LoadError, Result};
pub use scene_builder::{Location, SceneBuilder};

use penumbra_render::render::RenderJob;
use std::path::Path;

/// Whether `path` names a pbrt-v4 scene (`.pbrt`, `.pbrt.gz`).
pub fn is_pbrt(path: &Path) -> bool {
    let name = path.file_name().and_then(|n| n.to_str()).unwrap_or("").to_ascii_lowercase();
    name.ends_with(".pbrt") || name.ends_with(".pbrt.gz")
}

/// Loads a scene, its format chosen by the file name: Mitsuba 3 XML with
/// `-D name=value` definitions, a pbrt-v4 scene ([`is_pbrt`]), or glTF 2.0
/// (`.gltf`, `.glb`; see [`gltf`]); the last two take no definitions.
pub fn load_scene(path: &Path, defines: &[(String, String)], ov: &Overrides) -> Result<RenderJob> {
    load_scene_noted(path, defines, ov).map(|(job, _)| job)
}

/// As [`load_scene`], with the notes a user should see: the files of an
/// older version that were upgraded, and what was renamed in them (XML),
/// or what is rendered differently from pbrt-v4.
pub fn load_scene_noted(path: &Path, defines: &[(String, String)], ov: &Overrides) -> Result<(RenderJob, Vec<String>)> {
    if is_pbrt(path) {
        if let Some((name, _)) = defines.first() {
            return Err(LoadError::in_file(path, format!("-D {name}=...: pbrt-v4 scenes take no definitions")));
        }
        let scene = pbrt::parse_file(path)?;
        return pbrt::translate::translate(&scene, path, ov);
    }
    if let Some(job) = load_other_format(path, defines, ov) {
        return job;
    }
    let desc = mitsuba::parse_file(path, defines)?;
    let job = builder::build(&desc, ov).map_err(|e| desc.explain(e))?;
    Ok((job, desc.upgrade_notes()))
}

/// The scene of a file that is not Mitsuba XML, chosen by its extension
/// (`None`: read it as Mitsuba XML).
fn load_other_format(
    path: &Path,
    defines: &[(String, String)],
    ov: &Overrides,
) -> Option<Result<(RenderJob, Vec<String>)>> {
    let ext = path.extension().and_then(|e| e.to_str()).map(str::to_ascii_lowercase);
    match ext.as_deref() {
        Some("gltf" | "glb") => Some(if !defines.is_empty() {
            Err(LoadError::new(None, "-D definitions apply to Mitsuba XML scenes only, not to glTF"))
        } else {
            load_gltf(path, ov)
        }),
        _ => None,
    }
}

#[cfg(feature = "gltf")]
fn load_gltf(path: &Path, ov: &Overrides) -> Result<(RenderJob, Vec<String>)> {
    gltf::load(path, ov)
}

#[cfg(not(feature = "gltf"))]
fn load_gltf(path: &Path, _ov: &Overrides) -> Result<(RenderJob, Vec<String>)> {
    Err(LoadError::in_file(path, "this build has no glTF support; build penumbra-scene with the feature `gltf`"))
}
