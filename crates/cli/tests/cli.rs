//! End-to-end tests of the `penumbra` binary: output formats, determinism
//! across thread counts, and clear errors for bad input.

use std::fs;
use std::path::{Path, PathBuf};
use std::process::{Command, Output};

fn bin() -> Command {
    Command::new(env!("CARGO_BIN_EXE_penumbra"))
}

fn root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../..")
}

fn tmpdir(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("penumbra-cli-{}-{name}", std::process::id()));
    fs::create_dir_all(&d).unwrap();
    d
}

fn render(scene: &Path, out: &Path, extra: &[&str]) -> Output {
    bin().arg("render").arg(scene).arg("-o").arg(out).args(extra).output().unwrap()
}

#[test]
fn renders_the_bundled_box_identically_with_one_and_two_threads() {
    let d = tmpdir("threads");
    let scene = root().join("scenes/cornell-box.xml");
    let (a, b) = (d.join("a.pfm"), d.join("b.pfm"));
    let small = ["--spp", "4", "-D", "res=48"];
    let o1 = render(&scene, &a, &[&small[..], &["--threads", "1"]].concat());
    assert!(o1.status.success(), "{}", String::from_utf8_lossy(&o1.stderr));
    let o2 = render(&scene, &b, &[&small[..], &["--threads", "2"]].concat());
    assert!(o2.status.success(), "{}", String::from_utf8_lossy(&o2.stderr));
    let (ba, bb) = (fs::read(&a).unwrap(), fs::read(&b).unwrap());
    assert!(ba.len() > 48 * 48 * 12);
    assert_eq!(ba, bb, "1 and 2 threads must give bitwise identical images");
    // A different seed gives a different image.
    let c = d.join("c.pfm");
    assert!(render(&scene, &c, &[&small[..], &["--seed", "8"]].concat()).status.success());
    assert_ne!(fs::read(&c).unwrap(), ba);
    let stderr = String::from_utf8_lossy(&o1.stderr);
    assert!(stderr.contains("samples/s") && stderr.contains("rays/s"), "summary line: {stderr}");
    fs::remove_dir_all(&d).ok();
}

#[test]
fn writes_every_output_format() {
    let d = tmpdir("formats");
    let scene = root().join("scenes/cornell-box.xml");
    for ext in ["exr", "png", "pfm", "hdr"] {
        let out = d.join(format!("img.{ext}"));
        let o = render(&scene, &out, &["--spp", "1", "-D", "res=16"]);
        assert!(o.status.success(), "{ext}: {}", String::from_utf8_lossy(&o.stderr));
        assert!(fs::metadata(&out).unwrap().len() > 0);
    }
    fs::remove_dir_all(&d).ok();
}

/// Writes `xml` as a scene, renders it, and expects a failure whose message
/// names the file and `line`, and no output image.
fn expect_error(name: &str, xml: &str, line: u32, needle: &str) {
    let d = tmpdir(name);
    let scene = d.join("scene.xml");
    fs::write(&scene, xml).unwrap();
    let out = d.join("out.png");
    let o = render(&scene, &out, &[]);
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert!(!o.status.success(), "{name}: should fail");
    assert!(stderr.contains(&format!("scene.xml:{line}")), "{name}: no file:line {line} in: {stderr}");
    assert!(stderr.to_lowercase().contains(&needle.to_lowercase()), "{name}: '{needle}' not in: {stderr}");
    assert!(!stderr.contains("panicked"), "{name}: panic: {stderr}");
    assert!(!out.exists(), "{name}: output left behind");
    let leftovers: Vec<_> = fs::read_dir(&d).unwrap().map(|e| e.unwrap().file_name()).collect();
    assert_eq!(leftovers.len(), 1, "{name}: stray files {leftovers:?}");
    fs::remove_dir_all(&d).ok();
}

const SENSOR: &str = r#"<sensor type="perspective"><float name="fov" value="40"/>
    <film type="hdrfilm"><integer name="width" value="8"/><integer name="height" value="8"/></film></sensor>"#;

#[test]
fn malformed_xml_is_reported_with_its_line() {
    expect_error("malformed", "<scene version=\"3.0.0\">\n<shape type=\"sphere\">\n</scene>\n", 3, "");
}

#[test]
fn missing_mesh_file_is_reported() {
    let xml = format!("<scene version=\"3.0.0\">\n{SENSOR}\n<shape type=\"obj\">\n  <string name=\"filename\" value=\"nope.obj\"/>\n</shape>\n</scene>\n");
    expect_error("missing-mesh", &xml, 5, "nope.obj");
}

#[test]
fn unknown_plugin_lists_the_supported_ones() {
    let xml = format!("<scene version=\"3.0.0\">\n{SENSOR}\n<shape type=\"teapot\"/>\n</scene>\n");
    expect_error("unknown-plugin", &xml, 4, "rectangle");
}

#[test]
fn bad_number_is_reported() {
    let xml = format!(
        "<scene version=\"3.0.0\">\n{SENSOR}\n<shape type=\"sphere\">\n  <float name=\"radius\" value=\"1.0x\"/>\n</shape>\n</scene>\n"
    );
    expect_error("bad-number", &xml, 5, "radius");
}

#[test]
fn undefined_reference_is_reported() {
    let xml = format!(
        "<scene version=\"3.0.0\">\n{SENSOR}\n<shape type=\"sphere\">\n  <ref id=\"gold\"/>\n</shape>\n</scene>\n"
    );
    expect_error("undefined-ref", &xml, 5, "gold");
}

#[test]
fn unknown_parameter_is_an_error() {
    let xml = format!(
        "<scene version=\"3.0.0\">\n{SENSOR}\n<shape type=\"sphere\">\n  <float name=\"radius_typo\" value=\"1\"/>\n</shape>\n</scene>\n"
    );
    expect_error("unknown-param", &xml, 5, "radius_typo");
}

#[test]
fn missing_scene_file_is_a_clear_error() {
    let o = render(Path::new("/nonexistent/scene.xml"), Path::new("/tmp/never.png"), &[]);
    assert!(!o.status.success());
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert!(stderr.contains("/nonexistent/scene.xml"), "{stderr}");
}

fn read_pfm(path: &Path) -> (usize, usize, Vec<f32>) {
    let bytes = fs::read(path).unwrap();
    let text = String::from_utf8_lossy(&bytes[..32]).to_string();
    let mut it = text.split_ascii_whitespace();
    assert_eq!(it.next(), Some("PF"));
    let w: usize = it.next().unwrap().parse().unwrap();
    let h: usize = it.next().unwrap().parse().unwrap();
    let data = &bytes[bytes.len() - w * h * 12..];
    let v = data.chunks(4).map(|c| f32::from_le_bytes([c[0], c[1], c[2], c[3]])).collect();
    (w, h, v)
}

#[test]
fn a_crop_window_renders_exactly_its_part_of_the_full_image() {
    let d = tmpdir("crop");
    let base = fs::read_to_string(root().join("scenes/cornell-box.xml")).unwrap();
    let cropped = base.replace(
        "<film type=\"hdrfilm\">",
        "<film type=\"hdrfilm\">\n<integer name=\"crop_offset_x\" value=\"5\"/><integer name=\"crop_offset_y\" value=\"9\"/>\
         <integer name=\"crop_width\" value=\"7\"/><integer name=\"crop_height\" value=\"4\"/>",
    );
    assert_ne!(base, cropped, "the bundled scene has an hdrfilm");
    // The bundled scene refers to no other files, so it can move.
    let scene = d.join("crop.xml");
    fs::write(&scene, cropped).unwrap();
    let (full, crop) = (d.join("full.pfm"), d.join("crop.pfm"));
    let args = ["--spp", "2", "-D", "res=24"];
    let o1 = render(&root().join("scenes/cornell-box.xml"), &full, &args);
    let o2 = render(&scene, &crop, &args);
    assert!(o1.status.success() && o2.status.success(), "{}", String::from_utf8_lossy(&o2.stderr));
    let (fw, fh, fv) = read_pfm(&full);
    let (cw, ch, cv) = read_pfm(&crop);
    assert_eq!((fw, fh, cw, ch), (24, 24, 7, 4));
    // PFM rows run bottom to top.
    for y in 0..4 {
        for x in 0..7 {
            let (fy, cy) = (fh - 1 - (9 + y), ch - 1 - y);
            for c in 0..3 {
                assert_eq!(cv[(cy * cw + x) * 3 + c], fv[(fy * fw + 5 + x) * 3 + c], "pixel ({x}, {y})");
            }
        }
    }
    fs::remove_dir_all(&d).ok();
}

#[test]
fn bench_prints_its_table() {
    let o = bin()
        .current_dir(root())
        .args([
            "bench",
            "--suite",
            "scenes",
            "--spp",
            "1",
            "--rounds",
            "1",
            "--mitsuba",
            "/nonexistent/python",
            "scenes/cornell-box.xml",
        ])
        .output()
        .unwrap();
    let stdout = String::from_utf8_lossy(&o.stdout);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    assert!(stdout.contains("Msamples/s") && stdout.contains("cornell-box.xml"), "{stdout}");
    // The trace-only column: the render's own rays replayed through the BVH.
    let row = stdout.lines().find(|l| l.starts_with("cornell-box.xml")).unwrap();
    let trace: f64 = row.split_whitespace().nth(9).and_then(|v| v.parse().ok()).unwrap_or(-1.0);
    assert!(trace > 0.0, "no trace-only time in: {row}");
    // The whole process timed with the stream integrator and with --no-stream.
    let secs = |i: usize| row.split_whitespace().nth(i).and_then(|v| v.trim_end_matches('x').parse::<f64>().ok());
    assert!(secs(3).is_some_and(|t| t > 0.0) && secs(5).is_some_and(|t| t > 0.0), "{row}");
    assert!(secs(6).is_some_and(|g| g > 0.0), "no stream gain in: {row}");
    // Mitsuba could not be run: its column is empty and a note says why.
    assert!(String::from_utf8_lossy(&o.stderr).contains("Mitsuba timing skipped"));
}

#[test]
fn sampler_override_is_deterministic_and_validated() {
    let d = tmpdir("sampler");
    let scene = root().join("scenes/cornell-box.xml");
    let small = ["--spp", "4", "-D", "res=24", "--sampler", "sobol"];
    let outs: Vec<Vec<u8>> = ["1", "2"]
        .iter()
        .map(|t| {
            let out = d.join(format!("sobol{t}.pfm"));
            let o = render(&scene, &out, &[&small[..], &["--threads", t]].concat());
            assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
            fs::read(&out).unwrap()
        })
        .collect();
    assert_eq!(outs[0], outs[1], "sobol: 1 and 2 threads must give identical images");
    let indep = d.join("indep.pfm");
    assert!(render(&scene, &indep, &small[..4]).status.success());
    assert_ne!(fs::read(&indep).unwrap(), outs[0], "--sampler must change the samples");
    let bad = render(&scene, &d.join("bad.pfm"), &["--sampler", "halton"]);
    assert!(!bad.status.success());
    let err = String::from_utf8_lossy(&bad.stderr);
    assert!(err.contains("halton") && err.contains("sobol"), "{err}");
}
