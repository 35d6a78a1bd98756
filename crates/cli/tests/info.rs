//! `penumbra info`: a scene described without rendering.

use std::path::{Path, PathBuf};
use std::process::Command;

fn root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../..")
}

fn info(scene: &Path, extra: &[&str]) -> (bool, String, String) {
    let o = Command::new(env!("CARGO_BIN_EXE_penumbra")).arg("info").arg(scene).args(extra).output().unwrap();
    (
        o.status.success(),
        String::from_utf8_lossy(&o.stdout).into_owned(),
        String::from_utf8_lossy(&o.stderr).into_owned(),
    )
}

#[test]
fn describes_plugins_counts_and_approximations() {
    let scene = root().join("tests/scenes/format/spectral_quad.xml");
    let (ok, out, err) = info(&scene, &["-D", "res=20"]);
    assert!(ok, "{err}");
    for needle in [
        "format version 3.0.0",
        "integrator path",
        "rfilter    gaussian",
        "shape      obj, rectangle",
        "bsdf       diffuse",
        "emitter    area",
        "integrator: path (max_depth=4)",
        "path: max_depth=4, rr_depth=5, mis=true, light_selection=uniform, light_candidates=1, caustics=true (caustic_paths 0.03125, caustic_bounces -1), guiding=false",
        "geometry: 4 triangles in 2 meshes",
        "emitters: 1 (1 area)",
        "image: 20x20, 16 samples per pixel",
        "2 wavelength-sampled spectra converted to linear sRGB",
        "status: ready to render",
    ] {
        assert!(out.contains(needle), "'{needle}' not in:\n{out}");
    }
    // Nothing is rendered: no image appears.
    assert!(!err.contains("rendered"), "{err}");
    // The path integrator's defaults as resolved: 100 lights resample 4 candidates.
    let (ok, out, err) = info(&root().join("tests/scenes/many_lights.xml"), &[]);
    assert!(ok, "{err}");
    assert!(
        out.contains(
            "light_selection=uniform, light_candidates=4, caustics=true (caustic_paths 0.03125, caustic_bounces -1), guiding=false"
        ),
        "{out}"
    );
    // sggx: sampled exactly, unlike Mitsuba 3.9.1.
    let (ok, out, err) = info(&root().join("tests/scenes/phase_sggx.xml"), &[]);
    assert!(ok, "{err}");
    assert!(out.contains("phase      sggx") && out.contains("1 sggx phase functions sampled exactly"), "{out}");
}

#[test]
fn lists_what_it_can_and_fails_on_unsupported_plugins() {
    let dir = std::env::temp_dir().join(format!("penumbra-info-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let scene = dir.join("scene.xml");
    std::fs::write(
        &scene,
        "<scene version=\"3.0.0\">\n<sensor type=\"perspective\"><film type=\"hdrfilm\"/></sensor>\n\
         <shape type=\"sphere\"><bsdf type=\"nosuchbsdf\"/></shape>\n</scene>",
    )
    .unwrap();
    let (ok, out, err) = info(&scene, &[]);
    assert!(!ok);
    assert!(out.contains("bsdf       nosuchbsdf") && out.contains("shape      sphere"), "{out}");
    assert!(err.contains("scene.xml:3") && err.contains("nosuchbsdf"), "{err}");
    assert!(!err.contains("panicked"), "{err}");
    std::fs::remove_dir_all(&dir).ok();
}

/// A pbrt-v4 scene (chosen by its extension): its translation and notes;
/// an unsupported directive fails with its position.
#[test]
fn describes_a_pbrt_scene() {
    let (ok, out, err) = info(&root().join("scenes/pbrt/cornell.pbrt"), &[]);
    assert!(ok, "{err}");
    for needle in [
        "(pbrt-v4)",
        "integrator: path (Mitsuba's max_depth = 6: pbrt's maxdepth + 1)",
        "2 analytic spheres, 2 instances",
        "emitters: 2 (1 area, 1 point)",
        "image: 160x160, 256 samples per pixel (Sobol sampler",
        "rendered with Owen-scrambled Sobol'",
        "status: ready to render",
    ] {
        assert!(out.contains(needle), "'{needle}' not in:\n{out}");
    }
    let dir = std::env::temp_dir().join(format!("penumbra-info-pbrt-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let bad = dir.join("bad.pbrt");
    std::fs::write(&bad, "WorldBegin\nMaterial \"hair\"\nShape \"sphere\"\n").unwrap();
    let (ok, _, err) = info(&bad, &[]);
    assert!(!ok && err.contains("bad.pbrt:2:1") && err.contains("hair"), "{err}");
    std::fs::remove_dir_all(&dir).unwrap();
}

/// glTF: `info` describes the built scene; `render` writes the image; a bad
/// file fails naming its JSON pointer.
#[test]
fn gltf_info_and_render() {
    let scene = root().join("tests/scenes/gltf/boxes.gltf");
    let (ok, out, err) = info(&scene, &[]);
    assert!(ok, "{err}");
    for needle in [
        "geometry: 28 triangles in 4 meshes",
        "emitters: 4 (1 area, 1 directional, 1 point, 1 spot)",
        "image: 512x384, 64 samples",
    ] {
        assert!(out.contains(needle), "'{needle}' not in:\n{out}");
    }
    let dir = std::env::temp_dir().join(format!("penumbra-info-gltf-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let png = dir.join("boxes.png");
    let o = Command::new(env!("CARGO_BIN_EXE_penumbra"))
        .args(["render", "--spp", "1", "--quiet", "-o"])
        .arg(&png)
        .arg(&scene)
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    assert!(png.exists());
    let bad = dir.join("bad.gltf");
    std::fs::write(
        &bad,
        r#"{"asset": {"version": "2.0"}, "scenes": [{"nodes": [0]}], "nodes": [{"mesh": 0}],
            "meshes": [{"primitives": [{"attributes": {"POSITION": 5}}]}]}"#,
    )
    .unwrap();
    let (ok, _, err) = info(&bad, &[]);
    assert!(!ok);
    assert!(err.contains("bad.gltf at /meshes/0/primitives/0/attributes/POSITION"), "{err}");
    assert!(!err.contains("panicked"), "{err}");
    std::fs::remove_dir_all(&dir).ok();
}
