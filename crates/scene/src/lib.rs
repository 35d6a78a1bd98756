//! Scene loading for Penumbra: Mitsuba 3 XML → format-neutral description
//! (`desc`) → render job (`build`), plus mesh readers, image output and atomic file writes.

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
pub mod ply;
pub mod props;
pub mod serialized;
pub mod spectrum;
pub mod vol;

pub use builder::{supported_plugins, Overrides};
pub use error::{FileLoc, LoadError, Result};

use penumbra_render::render::RenderJob;
use std::path::Path;

/// Loads a Mitsuba 3 XML scene with `-D name=value` definitions.
pub fn load_scene(path: &Path, defines: &[(String, String)], ov: &Overrides) -> Result<RenderJob> {
    load_scene_noted(path, defines, ov).map(|(job, _)| job)
}

/// As [`load_scene`], with the notes a user should see: the files of an
/// older version that were upgraded, and what was renamed in them.
pub fn load_scene_noted(path: &Path, defines: &[(String, String)], ov: &Overrides) -> Result<(RenderJob, Vec<String>)> {
    let desc = mitsuba::parse_file(path, defines)?;
    let job = builder::build(&desc, ov).map_err(|e| desc.explain(e))?;
    Ok((job, desc.upgrade_notes()))
}
