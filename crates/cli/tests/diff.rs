//! `penumbra diff`: the printed means, MSE and relMSE of two small EXRs
//! against values worked out by hand, the error image, and bad input.

use penumbra_scene::image_io::{read_image, write_image, RgbImage};
use std::fs;
use std::path::PathBuf;
use std::process::Command;

fn tmpdir(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("penumbra-diff-{}-{name}", std::process::id()));
    fs::create_dir_all(&d).unwrap();
    d
}

/// The number after `label` on the line that starts with it.
fn value(stdout: &str, label: &str) -> Vec<f64> {
    let line = stdout.lines().find(|l| l.starts_with(label)).unwrap_or_else(|| panic!("no '{label}' in:\n{stdout}"));
    line[label.len()..].split_whitespace().map(|v| v.parse().unwrap()).collect()
}

#[test]
fn prints_the_hand_computed_relmse() {
    let d = tmpdir("values");
    // 2x1 images; B is the reference.
    let a = RgbImage { width: 2, height: 1, pixels: vec![[1.0, 0.5, 0.0], [0.2, 0.2, 0.2]] };
    let b = RgbImage { width: 2, height: 1, pixels: vec![[1.0, 1.0, 0.1], [0.0, 0.2, 0.4]] };
    let (pa, pb, perr) = (d.join("a.exr"), d.join("b.exr"), d.join("err.png"));
    write_image(&pa, &a).unwrap();
    write_image(&pb, &b).unwrap();
    let o = Command::new(env!("CARGO_BIN_EXE_penumbra"))
        .args(["diff".as_ref(), pa.as_os_str(), pb.as_os_str(), "--out".as_ref(), perr.as_os_str()])
        .output()
        .unwrap();
    let stdout = String::from_utf8_lossy(&o.stdout);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));

    // (a-b)² per channel: 0, 0.25, 0.01 | 0.04, 0, 0.04.
    // b² + 0.01:          1.01, 1.01, 0.02 | 0.01, 0.05, 0.17.
    // relMSE = (0 + 0.25/1.01 + 0.5 + 4 + 0 + 0.04/0.17) / 6.
    let rel = (0.25 / 1.01 + 0.5 + 4.0 + 0.04 / 0.17) / 6.0;
    assert!((rel - 0.830_469_8_f64).abs() < 1e-6);
    let mse = 0.34 / 6.0;
    let close = |x: f64, y: f64| (x - y).abs() <= 1e-5 * y.abs().max(1e-3);
    let got = value(&stdout, "relMSE:")[0];
    assert!(close(got, rel), "relMSE {got} != {rel}\n{stdout}");
    let got = value(&stdout, "MSE:")[0];
    assert!(close(got, mse), "MSE {got} != {mse}\n{stdout}");
    for (label, want) in [("mean A:", [0.6, 0.35, 0.1]), ("mean B:", [0.5, 0.6, 0.25])] {
        let got = value(&stdout, label);
        assert!(got.len() == 3 && (0..3).all(|k| close(got[k], want[k])), "{label} {got:?} != {want:?}");
    }
    // Swapping the roles changes the reference, hence relMSE but not MSE.
    let o = Command::new(env!("CARGO_BIN_EXE_penumbra")).arg("diff").arg(&pb).arg(&pa).output().unwrap();
    let stdout = String::from_utf8_lossy(&o.stdout);
    let rel_swapped = (0.25 / 0.26 + 0.01 / 0.01 + 0.04 / 0.05 + 0.04 / 0.05) / 6.0;
    assert!(close(value(&stdout, "relMSE:")[0], rel_swapped), "{stdout}");
    assert!(close(value(&stdout, "MSE:")[0], mse), "{stdout}");

    // The error image has the images' size.
    let err = read_image(&perr).unwrap();
    assert_eq!((err.width, err.height), (2, 1));
    fs::remove_dir_all(&d).ok();
}

#[test]
fn rejects_images_of_different_sizes_and_missing_files() {
    let d = tmpdir("bad");
    let a = RgbImage { width: 2, height: 2, pixels: vec![[0.5; 3]; 4] };
    let b = RgbImage { width: 4, height: 1, pixels: vec![[0.5; 3]; 4] };
    let (pa, pb) = (d.join("a.exr"), d.join("b.exr"));
    write_image(&pa, &a).unwrap();
    write_image(&pb, &b).unwrap();
    let o = Command::new(env!("CARGO_BIN_EXE_penumbra")).arg("diff").arg(&pa).arg(&pb).output().unwrap();
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert!(!o.status.success() && stderr.contains("differ in size"), "{stderr}");
    let o = Command::new(env!("CARGO_BIN_EXE_penumbra")).arg("diff").arg(&pa).arg(d.join("none.exr")).output().unwrap();
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert!(!o.status.success() && stderr.contains("none.exr") && !stderr.contains("panicked"), "{stderr}");
    fs::remove_dir_all(&d).ok();
}
