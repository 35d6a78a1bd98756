//! Damaged or hostile files given to `penumbra merge`: headers claiming
//! images larger than any film, or a data window outside the frame, are
//! refused with a message naming the file, before the pixels are allocated.

use crate::common;

use crate::common::bin;
use penumbra::exrmeta::{self, ExrImage};
use std::collections::BTreeMap;

fn exr(path: &std::path::Path, offset: (u32, u32), full_size: (u32, u32)) {
    let mut meta = BTreeMap::new();
    meta.insert("settings".to_string(), "spp=1".to_string());
    meta.insert("part".to_string(), "whole".to_string());
    let img = ExrImage {
        width: 4,
        height: 4,
        offset,
        full_size,
        rgb: vec![[0.5; 3]; 16],
        weight: None,
        layers: Vec::new(),
        meta,
    };
    exrmeta::write(path, &img).unwrap();
}

#[test]
fn merge_refuses_parts_whose_header_claims_too_much() {
    let d = common::tmpdir("hostile", "merge");
    // Two crops of a frame, the second damaged; --allow-missing lets the
    // merge go as far as pasting them.
    let cases = [
        ("outside.exr", (6, 6), (8, 8), "data window 6,6,10,10 reaches outside its display window (0,0,8,8)"),
        ("huge.exr", (8, 8), (100_000, 70_000), "claims a 4 x 4 image in a 100000 x 70000 frame"),
    ];
    for (name, offset, full, want) in cases {
        let (good, bad) = (d.join(format!("good-{name}")), d.join(name));
        exr(&good, (0, 0), full);
        exr(&bad, offset, full);
        let o = bin()
            .arg("merge")
            .args([&good, &bad])
            .arg("--allow-missing")
            .arg("-o")
            .arg(d.join("out.exr"))
            .output()
            .unwrap();
        let err = String::from_utf8_lossy(&o.stderr);
        assert_eq!(o.status.code(), Some(1), "{name}: {err}");
        assert!(err.contains(name) && err.contains(want), "{name}: {err}");
        assert!(!d.join("out.exr").exists());
    }
    std::fs::remove_dir_all(&d).ok();
}
