//! Helpers shared by the binary's end-to-end tests: running `penumbra`,
//! temporary directories, and reading EXRs with their `penumbra:*` metadata.
#![allow(dead_code)]

use std::collections::HashMap;
use std::fs;
use std::path::{Path, PathBuf};
use std::process::{Command, Output};

#[path = "../../../../tests/support/skip.rs"]
mod skip;
#[allow(unused_imports)]
pub use skip::{in_ci, skip};

pub fn bin() -> Command {
    Command::new(env!("CARGO_BIN_EXE_penumbra"))
}

/// The bundled Cornell box.
pub fn cornell() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../scenes/cornell-box.xml")
}

/// A fresh directory for one test (`kind` keeps test files apart).
pub fn tmpdir(kind: &str, name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("penumbra-{kind}-{}-{name}", std::process::id()));
    let _ = fs::remove_dir_all(&d);
    fs::create_dir_all(&d).unwrap();
    d
}

pub fn ok(o: Output) -> Output {
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    o
}

/// The channels (name → values) and `penumbra:*` attributes of an EXR.
pub struct Exr {
    pub channels: HashMap<String, Vec<f32>>,
    pub meta: HashMap<String, String>,
    pub size: (usize, usize),
}

impl Exr {
    pub fn ch(&self, name: &str) -> &[f32] {
        self.channels.get(name).unwrap_or_else(|| panic!("no channel {name}: {:?}", self.channels.keys()))
    }
}

pub fn read_exr(path: &Path) -> Exr {
    use exr::prelude::*;
    let img = read()
        .no_deep_data()
        .largest_resolution_level()
        .all_channels()
        .first_valid_layer()
        .all_attributes()
        .from_file(path)
        .unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    let l = &img.layer_data;
    let channels =
        l.channel_data.list.iter().map(|c| (c.name.to_string(), c.sample_data.values_as_f32().collect())).collect();
    let mut meta = HashMap::new();
    for (k, v) in &l.attributes.other {
        if let (Some(k), AttributeValue::Text(t)) = (k.to_string().strip_prefix("penumbra:"), v) {
            meta.insert(k.to_string(), t.to_string());
        }
    }
    Exr { channels, meta, size: (l.size.0, l.size.1) }
}
