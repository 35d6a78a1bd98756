//! The readers' entry points as fuzz targets see them: each takes arbitrary
//! bytes, must return (an error is fine) and must never panic, hang or
//! allocate what the data does not back. `fuzz/` drives them with
//! libFuzzer; `tests/fuzz_corpus.rs` replays the committed corpus through
//! them in every test run.

use std::path::Path;

/// A target's entry point.
pub type Target = fn(&[u8]);

/// The targets by name (the directories of `fuzz/corpus/`), with their entry points.
pub const TARGETS: &[(&str, Target)] = &[
    ("xml", xml),
    ("obj", obj),
    ("ply", ply),
    ("serialized", serialized),
    ("vol", vol),
    ("spd", spd),
    ("pfm", pfm),
    ("image", image),
    ("xml_include", xml_include),
    ("pbrt", pbrt),
    ("tensor", tensor),
    #[cfg(feature = "gltf")]
    ("gltf", gltf),
];

/// A glTF file (`.gltf` JSON or `.glb`): parsed, checked and built;
/// external buffers and images are missing-file errors.
#[cfg(feature = "gltf")]
pub fn gltf(data: &[u8]) {
    let _ = crate::gltf::load_bytes(Path::new("/nonexistent-fuzz-dir/scene.glb"), data, &crate::Overrides::default());
}

/// A Mitsuba XML scene: parsed, then built (meshes, textures and includes
/// it names are looked up beside a file that does not exist, so they are
/// missing-file errors).
pub fn xml(data: &[u8]) {
    let Ok(text) = std::str::from_utf8(data) else { return };
    let path = Path::new("/nonexistent-fuzz-dir/scene.xml");
    if let Ok(desc) = crate::mitsuba::parse_str(text, path, &[("res".into(), "4".into())]) {
        let _ = crate::builder::build(&desc, &crate::Overrides::default());
    }
}

/// An OBJ file's bytes.
pub fn obj(data: &[u8]) {
    if crate::obj::check_text(data).is_ok() {
        let _ = crate::obj::parse_obj(&String::from_utf8_lossy(data), Path::new("fuzz.obj"), true);
    }
}

/// A PLY file, as a mesh with attributes and as a table (`ellipsoids`).
pub fn ply(data: &[u8]) {
    let _ = crate::ply::parse_ply_with_attributes(data, Path::new("fuzz.ply"), true);
    let _ = crate::ply::parse_ply_table(data, Path::new("fuzz.ply"));
}

/// A `.serialized` file: its first and second mesh.
pub fn serialized(data: &[u8]) {
    let _ = crate::serialized::parse_serialized(data, 0);
    let _ = crate::serialized::parse_serialized(data, 1);
}

/// A `.vol` grid.
pub fn vol(data: &[u8]) {
    let _ = crate::vol::parse(data);
}

/// An `.spd` spectrum file, converted as an emitter's colour would be.
pub fn spd(data: &[u8]) {
    if let Ok(pairs) = crate::spectrum::parse_spd(data.to_vec()) {
        let _ = crate::spectrum::sampled_to_srgb(&pairs, crate::spectrum::ColorUse::Emission);
    }
}

/// A PFM image.
pub fn pfm(data: &[u8]) {
    with_file(data, "pfm", |p| {
        let _ = crate::image_io::read_pfm(p);
    });
}

/// An image texture or environment map: the first byte chooses the format
/// (EXR, HDR, PNG, JPEG), the rest is the file.
pub fn image(data: &[u8]) {
    let Some((&which, rest)) = data.split_first() else { return };
    let ext = ["exr", "hdr", "png", "jpg"][which as usize % 4];
    with_file(rest, ext, |p| {
        let _ = crate::image_io::read_image(p);
    });
}

/// Two Mitsuba XML files, the bytes before the first NUL and those after
/// it: `scene.xml`, which may include `inc.xml` (or itself, a cycle), and
/// `inc.xml`, which may include either.
pub fn xml_include(data: &[u8]) {
    let cut = data.iter().position(|&b| b == 0).unwrap_or(data.len());
    let (main, inc) = (&data[..cut], data.get(cut + 1..).unwrap_or(&[]));
    let dir = std::env::temp_dir().join(
        format!("penumbra-fuzz-inc-{}-{:?}", std::process::id(), std::thread::current().id()).replace(['(', ')'], ""),
    );
    if std::fs::create_dir_all(&dir).is_ok()
        && std::fs::write(dir.join("scene.xml"), main).is_ok()
        && std::fs::write(dir.join("inc.xml"), inc).is_ok()
    {
        if let Ok(desc) = crate::mitsuba::parse_file(&dir.join("scene.xml"), &[("res".into(), "4".into())]) {
            let _ = crate::builder::build(&desc, &crate::Overrides::default());
        }
    }
    let _ = std::fs::remove_dir_all(&dir);
}

/// A pbrt-v4 scene: tokenized and parsed (files it includes are missing).
pub fn pbrt(data: &[u8]) {
    let Ok(text) = std::str::from_utf8(data) else { return };
    let _ =
        crate::pbrt::parse_str(text, Path::new("/nonexistent-fuzz-dir/scene.pbrt"), Path::new("/nonexistent-fuzz-dir"));
}

/// A tensor file (the `measured` BSDF's `.bsdf`), and its tables when it parses.
pub fn tensor(data: &[u8]) {
    if let Ok(t) = crate::tensor::TensorFile::parse(data.to_vec()) {
        let _ = crate::tensor::measured_tables(&t);
    }
}

/// Runs `f` on a temporary file holding `data` (readers that take paths).
fn with_file(data: &[u8], ext: &str, f: impl FnOnce(&Path)) {
    let path = std::env::temp_dir().join(format!(
        "penumbra-fuzz-{}-{:?}.{ext}",
        std::process::id(),
        std::thread::current().id()
    ));
    if std::fs::write(&path, data).is_ok() {
        f(&path);
    }
    let _ = std::fs::remove_file(&path);
}
