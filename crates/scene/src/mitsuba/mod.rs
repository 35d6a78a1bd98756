//! Mitsuba 3 XML reader: turns a scene file (and the files it includes)
//! into a [`SceneDesc`](crate::desc::SceneDesc), following the rules of
//! Mitsuba 3's own parser (`src/core/parser.cpp`).

pub mod transform;
mod xml;

pub use xml::{parse_file, parse_str};
