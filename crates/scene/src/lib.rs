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

/// Whether `path` names a pbrt-v4 scene (`.pbrt`, `.pbrt.gz`); other
/// files are read as Mitsuba 3 XML.
pub fn is_pbrt(path: &Path) -> bool {
    let name = path.file_name().and_then(|n| n.to_str()).unwrap_or("").to_ascii_lowercase();
    name.ends_with(".pbrt") || name.ends_with(".pbrt.gz")
}

/// Loads a scene, its format chosen by the file name ([`is_pbrt`]): a
/// Mitsuba 3 XML scene with `-D name=value` definitions, or a pbrt-v4
/// scene (which takes no definitions).
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
    let desc = mitsuba::parse_file(path, defines)?;
    let job = builder::build(&desc, ov).map_err(|e| desc.explain(e))?;
    Ok((job, desc.upgrade_notes()))
}
