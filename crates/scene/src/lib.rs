//! Scene loading for Penumbra: Mitsuba 3 XML → format-neutral description
//! (`desc`) → render scene (`build`), plus mesh readers and image output.

pub mod desc;
pub mod error;
pub mod mitsuba;
pub mod obj;
pub mod ply;
pub mod props;

pub use error::{FileLoc, LoadError, Result};
