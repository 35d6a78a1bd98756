//! glTF 2.0: the test scene `tests/scenes/gltf/boxes.gltf` (written by
//! `tools/make_gltf_scene.py` with its Mitsuba twin `boxes.xml`) renders as
//! the XML does (camera, transforms and hierarchy, diffuse materials,
//! emission, point, spot and directional lights); the same scene as `.glb` and with an embedded
//! data URI loads alike; bad input is an error naming its JSON pointer.

#![cfg(feature = "gltf")]

use crate::common::{assert_agree, compare, estimate, injected_errors, root, Estimate};
use ::gltf::json::Value;
use penumbra_render::film::Film;
use penumbra_render::sampling::Sampler;
use penumbra_scene::{gltf, load_scene, Overrides};
use std::path::{Path, PathBuf};

fn scene(name: &str) -> PathBuf {
    root().join("tests/scenes/gltf").join(name)
}

/// A window of the 512x384 frame (both formats' film) holding both boxes,
/// the floor and the lamp; rendered in independently seeded batches.
const CROP: (u32, u32, u32, u32) = (96, 64, 320, 256);

fn render(path: &Path, spp: u32, batches: u32, seed: u64) -> Estimate {
    let ov = Overrides { spp: Some(spp / batches), ..Default::default() };
    let mut job = load_scene(path, &[], &ov).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(job.full_size, (512, 384), "{}", path.display());
    job.crop_offset = (CROP.0, CROP.1);
    (job.width, job.height) = (CROP.2, CROP.3);
    let imgs: Vec<Vec<[f32; 3]>> = (0..batches)
        .map(|b| {
            job.sampler = Sampler::new(job.sampler.kind, seed * 1000 + b as u64, job.sampler.spp);
            let mut film = Film::new(job.width, job.height);
            job.render_into(&mut film, 0..job.sampler.spp, &|_| {});
            film.develop()
        })
        .collect();
    estimate(job.width, job.height, &imgs)
}

/// The glTF scene and its Mitsuba XML twin render the same image; the
/// comparison catches the usual injected errors (power), among them a
/// mirrored image, which a wrong camera handedness would give.
#[test]
fn gltf_matches_mitsuba_xml_twin() {
    let ours = render(&scene("boxes.gltf"), 64, 8, 1);
    let twin = render(&scene("boxes.xml"), 64, 8, 2);
    let v = assert_agree("boxes.gltf vs boxes.xml", &ours, &twin, 0.02);
    println!("boxes: block chi2 {:?}, largest block z {:?}", v.block_chi2, v.block_max);
    for (error, bad) in injected_errors(&ours) {
        let caught = !compare(&format!("boxes with {error}"), &bad, &twin, 0.02).failures.is_empty();
        println!("boxes: injected error '{error}' caught: {caught}");
        assert!(caught, "the comparison missed an injected error: {error}");
    }
    // The red box is left of the blue one in the image (not mirrored).
    let (w, h) = (ours.width as usize, ours.height as usize);
    let half = |left: bool| {
        let mut s = [0.0f64; 3];
        for y in 0..h {
            for x in 0..w {
                if (x < w / 2) == left {
                    let p = ours.mean[y * w + x];
                    (0..3).for_each(|c| s[c] += p[c]);
                }
            }
        }
        s
    };
    let (l, r) = (half(true), half(false));
    assert!(l[0] / l[2] > r[0] / r[2], "red is not on the left: left {l:?}, right {r:?}");
}

/// `boxes.gltf` as one `.glb` (JSON chunk + BIN chunk).
fn glb() -> Vec<u8> {
    let mut json = doc();
    json["buffers"][0].as_object_mut().unwrap().remove("uri");
    let mut j = json.to_string().into_bytes();
    while !j.len().is_multiple_of(4) {
        j.push(b' ');
    }
    let mut b = std::fs::read(scene("boxes.bin")).unwrap();
    while !b.len().is_multiple_of(4) {
        b.push(0);
    }
    let total = 12 + 8 + j.len() + 8 + b.len();
    let mut out = Vec::new();
    out.extend_from_slice(b"glTF");
    out.extend_from_slice(&2u32.to_le_bytes());
    out.extend_from_slice(&(total as u32).to_le_bytes());
    out.extend_from_slice(&(j.len() as u32).to_le_bytes());
    out.extend_from_slice(b"JSON");
    out.extend_from_slice(&j);
    out.extend_from_slice(&(b.len() as u32).to_le_bytes());
    out.extend_from_slice(b"BIN\0");
    out.extend_from_slice(&b);
    out
}

/// The test scene's JSON, to edit.
fn doc() -> Value {
    ::gltf::json::deserialize::from_str(&std::fs::read_to_string(scene("boxes.gltf")).unwrap()).unwrap()
}

/// `doc` edited by `edit`, as bytes.
fn edited(edit: impl FnOnce(&mut Value)) -> Vec<u8> {
    let mut d = doc();
    edit(&mut d);
    d.to_string().into_bytes()
}

fn load(name: &str, bytes: &[u8]) -> Result<penumbra_render::render::RenderJob, String> {
    gltf::load_bytes(&scene(name), bytes, &Overrides::default()).map(|(j, _)| j).map_err(|e| e.to_string())
}

fn triangles(job: &penumbra_render::render::RenderJob) -> usize {
    job.scene.shapes.iter().map(|s| s.prim_count()).sum()
}

fn gltf_text() -> String {
    doc().to_string()
}

#[test]
fn glb_and_data_uri_load_as_the_gltf() {
    let base = load("boxes.gltf", gltf_text().as_bytes()).unwrap();
    assert_eq!(triangles(&base), 2 + 12 + 12 + 2);
    let mut names: Vec<&str> = base.scene.lights.iter().map(|l| l.name()).collect();
    names.sort();
    assert_eq!(names, ["area", "directional", "point", "spot"]);
    let g = load("boxes.glb", &glb()).unwrap();
    assert_eq!(triangles(&g), triangles(&base));
    use base64::Engine;
    let bin = std::fs::read(scene("boxes.bin")).unwrap();
    let uri = format!("data:application/octet-stream;base64,{}", base64::engine::general_purpose::STANDARD.encode(bin));
    let text = edited(|d| d["buffers"][0]["uri"] = uri.into());
    // Loaded from elsewhere: the buffer cannot come from beside the file.
    let job = gltf::load_bytes(Path::new("/nonexistent/x.gltf"), &text, &Overrides::default()).unwrap().0;
    assert_eq!(triangles(&job), triangles(&base));
    assert_eq!(job.scene.shapes[1].prim_bounds(0).min, base.scene.shapes[1].prim_bounds(0).min);
}

#[test]
fn bad_input_names_the_json_pointer() {
    // Truncated GLB: every cut is an error, never a panic.
    let full = glb();
    for cut in [0, 5, 12, 19, 40, full.len() / 2, full.len() - 1] {
        let e = load("boxes.glb", &full[..cut]).expect_err("a truncated GLB must fail");
        assert!(!e.is_empty(), "cut {cut}");
        if cut >= 20 && cut < full.len() - 8 {
            println!("truncated at {cut}: {e}");
        }
    }
    let e = load("boxes.glb", &full[..full.len() - 100]).unwrap_err();
    assert!(e.contains("boxes.glb"), "{e}");
    // An accessor reading past its view.
    let e = load("boxes.gltf", &edited(|d| d["accessors"][0]["count"] = 400.into())).unwrap_err();
    assert!(e.contains("at /accessors/0") && e.contains("POSITION") && e.contains("/meshes/0/primitives/0"), "{e}");
    // A missing buffer file.
    let e = load("boxes.gltf", &edited(|d| d["buffers"][0]["uri"] = "missing.bin".into())).unwrap_err();
    assert!(e.contains("at /buffers/0") && e.contains("missing.bin"), "{e}");
    // A buffer shorter than its byteLength.
    let e = load("boxes.glb", &{
        let mut g = glb();
        let n = g.len();
        // BIN chunk length field shortened, the file with it.
        let json_len = u32::from_le_bytes(g[12..16].try_into().unwrap()) as usize;
        let at = 20 + json_len;
        let bin_len = u32::from_le_bytes(g[at..at + 4].try_into().unwrap()) - 64;
        g[at..at + 4].copy_from_slice(&bin_len.to_le_bytes());
        g.truncate(n - 64);
        let total = g.len() as u32;
        g[8..12].copy_from_slice(&total.to_le_bytes());
        g
    })
    .unwrap_err();
    assert!(e.contains("at /buffers/0") && e.contains("byteLength"), "{e}");
    // Lines instead of triangles.
    let e = load("boxes.gltf", &edited(|d| d["meshes"][0]["primitives"][0]["mode"] = 1.into())).unwrap_err();
    assert!(e.contains("at /meshes/0/primitives/0") && e.contains("triangles"), "{e}");
    // A scene naming a node that does not exist (the crate's validation).
    let e =
        load("boxes.gltf", &edited(|d| d["scenes"][0]["nodes"].as_array_mut().unwrap().push(99.into()))).unwrap_err();
    assert!(e.contains("/scenes/0/nodes"), "{e}");
    // A node hierarchy with a cycle.
    let e = load("boxes.gltf", &edited(|d| d["nodes"][2]["children"] = vec![1].into())).unwrap_err();
    assert!(e.contains("/nodes/") && e.contains("cycle"), "{e}");
    // Parameters the gltf crate's accessors unwrap: refused, not a panic.
    let e = load("boxes.gltf", &edited(|d| d["cameras"][0] = serde_value(r#"{"type": "perspective"}"#))).unwrap_err();
    assert!(e.contains("/cameras/0/perspective"), "{e}");
    let e = load(
        "boxes.gltf",
        &edited(|d| d["extensions"]["KHR_lights_punctual"]["lights"][1] = serde_value(r#"{"type": "spot"}"#)),
    )
    .unwrap_err();
    assert!(e.contains("/extensions/KHR_lights_punctual/lights/1/spot"), "{e}");
    // JSON syntax: line and column.
    let e = load("boxes.gltf", b"{\n \"asset\": {\"version\": \"2.0\"},\n oops\n}").unwrap_err();
    assert!(e.contains("boxes.gltf:3:"), "{e}");
}

/// Without camera and lights: the default view frames the scene from +z,
/// and a white environment lights it.
#[test]
fn defaults_without_camera_or_lights() {
    // Only the floor and the two boxes.
    let doc = edited(|d| d["scenes"][0]["nodes"] = vec![0, 1, 3].into());
    let (job, notes) = gltf::load_bytes(&scene("boxes.gltf"), &doc, &Overrides::default()).unwrap();
    assert_eq!(job.full_size, (gltf::DEFAULT_FILM_SIZE, gltf::DEFAULT_FILM_SIZE));
    assert_eq!(job.sampler.spp, gltf::DEFAULT_SPP);
    assert_eq!(job.scene.lights.len(), 1);
    assert_eq!(job.scene.lights[0].name(), "constant");
    assert!(notes.iter().any(|n| n.contains("white environment")), "{notes:?}");
    let eye = job.camera.world_from_camera.transform_point3(glam::Vec3::ZERO);
    let fwd = job.camera.world_from_camera.transform_vector3(glam::Vec3::Z).normalize();
    assert!(eye.z > 2.0 && eye.x.abs() < 0.5, "camera at {eye}");
    assert!((fwd - glam::Vec3::NEG_Z).length() < 1e-5, "looking along {fwd}");
}

/// `materials.gltf`: the floor's checker (an sRGB PNG in a bufferView,
/// repeated 4x by KHR_texture_transform, nearest filter) is decoded to
/// linear values at the right texels; the spot and directional lights and
/// the three material kinds are built.
#[test]
fn textures_lights_and_materials() {
    use penumbra_render::material::Material;
    use penumbra_render::texture::Texture;
    use penumbra_scene::image_io::srgb_to_linear;
    let (job, notes) = gltf::load(&scene("materials.gltf"), &Overrides::default()).unwrap();
    assert!(notes.is_empty(), "{notes:?}");
    let mut names: Vec<&str> = job.scene.lights.iter().map(|l| l.name()).collect();
    names.sort();
    assert_eq!(names, ["directional", "spot"]);
    let Material::GltfPbr(floor) = &job.scene.materials[0] else { panic!("{:?}", job.scene.materials[0]) };
    let Texture::Bitmap(b) = &floor.base_color else { panic!("the floor has no texture") };
    // Texel (x, y) of the 8x8 checker is light when x + y is even; with the
    // 4x repetition its centre is at uv = ((x + 0.5) / 8, (y + 0.5) / 8) / 4.
    let (light, dark) = (srgb_to_linear(200.0 / 255.0), srgb_to_linear(60.0 / 255.0));
    for (x, y) in [(0, 0), (1, 0), (0, 1), (5, 2), (7, 7)] {
        let uv = glam::Vec2::new((x as f32 + 0.5) / 32.0, (y as f32 + 0.5) / 32.0);
        let expect = if (x + y) % 2 == 0 { light } else { dark };
        let got = b.eval(uv);
        assert!((got - glam::Vec3::splat(expect)).abs().max_element() < 1e-5, "texel ({x}, {y}): {got} vs {expect}");
        // The next repetition (uv + 1/4) is the same texel.
        assert!((b.eval(uv + glam::Vec2::splat(0.25)) - got).abs().max_element() < 1e-6);
    }
    assert!(
        matches!(&job.scene.materials[1], Material::GltfPbr(p) if p.metallic_roughness.constant() == Some(glam::Vec3::new(0.0, 0.35, 1.0)))
    );
    // Transmission: a blend with a rough dielectric.
    assert!(
        matches!(&job.scene.materials[3], Material::Blend { second, .. } if matches!(**second, Material::RoughDielectric(_)))
    );
}

/// `--envmap`: added to a glTF scene's lights, in place of the white
/// environment of a scene without lights; added to a Mitsuba scene too.
#[test]
fn envmap_option() {
    let env = root().join("tests/scenes/textures/sunsky.exr");
    let ov = Overrides { envmap: Some(env.clone()), ..Default::default() };
    let no_lights = edited(|d| d["scenes"][0]["nodes"] = vec![0, 1, 3, 6].into());
    let (job, _) = gltf::load_bytes(&scene("boxes.gltf"), &no_lights, &ov).unwrap();
    let names: Vec<&str> = job.scene.lights.iter().map(|l| l.name()).collect();
    assert_eq!(names, ["envmap"]);
    let job = load_scene(&scene("boxes.xml"), &[], &ov).unwrap();
    assert!(job.scene.lights.iter().any(|l| l.name() == "envmap"));
    assert_eq!(job.scene.lights.len(), 5);
    let bad = Overrides { envmap: Some(root().join("missing.exr")), ..Default::default() };
    let e = load_scene(&scene("boxes.gltf"), &[], &bad).unwrap_err().to_string();
    assert!(e.contains("--envmap") && e.contains("missing.exr"), "{e}");
}

/// alphaMode, doubleSided, normalTexture and unsupported extensions.
#[test]
fn alpha_sides_normal_maps_and_extensions() {
    use penumbra_render::material::Material;
    let build = |edit: &dyn Fn(&mut Value)| {
        let doc = edited(|d| edit(d));
        gltf::load_bytes(&scene("boxes.gltf"), &doc, &Overrides::default()).unwrap()
    };
    let opacity = |m: &Material| match m {
        Material::Mask { opacity, .. } => opacity.constant().map(|c| c.x),
        _ => None,
    };
    let (job, _) = build(&|d| {
        d["materials"][0]["alphaMode"] = "BLEND".into();
        d["materials"][0]["pbrMetallicRoughness"]["baseColorFactor"] = vec![0.7, 0.7, 0.7, 0.3].into();
    });
    assert_eq!(opacity(&job.scene.materials[0]), Some(0.3));
    let (job, _) = build(&|d| {
        d["materials"][0]["alphaMode"] = "MASK".into();
        d["materials"][0]["pbrMetallicRoughness"]["baseColorFactor"] = vec![0.7, 0.7, 0.7, 0.3].into();
    });
    assert_eq!(opacity(&job.scene.materials[0]), Some(0.0), "0.3 is below the default cut-off 0.5");
    let (job, _) = build(&|d| d["materials"][0]["doubleSided"] = true.into());
    assert!(matches!(job.scene.materials[0], Material::TwoSided(..)));
    assert!(matches!(job.scene.materials[1], Material::GltfPbr(_)));
    let (job, notes) = build(&|d| d["extensionsUsed"].as_array_mut().unwrap().push("KHR_materials_clearcoat".into()));
    assert!(notes.iter().any(|n| n.contains("KHR_materials_clearcoat")), "{notes:?}");
    assert_eq!(job.scene.materials.len(), 4);
    // A required extension that is not supported is refused.
    let e =
        load("boxes.gltf", &edited(|d| d["extensionsRequired"] = vec!["KHR_materials_clearcoat"].into())).unwrap_err();
    assert!(e.contains("/extensionsRequired") && e.contains("KHR_materials_clearcoat"), "{e}");
}

/// A mesh used by two nodes is stored once and placed by instances; it
/// renders as two copies of the mesh do.
#[test]
fn shared_meshes_are_instanced() {
    let bin = scene("boxes.bin").to_str().unwrap().to_string();
    let write = |name: &str, edit: &dyn Fn(&mut Value)| {
        let path = std::env::temp_dir().join(format!("penumbra-gltf-test-{}-{name}", std::process::id()));
        let doc = edited(|d| {
            d["buffers"][0]["uri"] = bin.clone().into();
            edit(d);
        });
        std::fs::write(&path, doc).unwrap();
        path
    };
    // The blue box's node shows the red box's mesh (mesh 1) ...
    let shared = write("shared.gltf", &|d| d["nodes"][3]["mesh"] = 1.into());
    // ... or a copy of it (mesh 4).
    let copied = write("copied.gltf", &|d| {
        let m = d["meshes"][1].clone();
        d["meshes"].as_array_mut().unwrap().push(m);
        d["nodes"][3]["mesh"] = 4.into();
    });
    let job = load_scene(&shared, &[], &Overrides::default()).unwrap();
    assert_eq!(job.scene.instances.len(), 2);
    assert_eq!(triangles(&job), 2 + 12 + 12 + 2 - 12, "the cube's triangles stored once");
    let job = load_scene(&copied, &[], &Overrides::default()).unwrap();
    assert_eq!(job.scene.instances.len(), 0);
    let a = render(&shared, 32, 8, 3);
    let b = render(&copied, 32, 8, 4);
    let _ = (std::fs::remove_file(&shared), std::fs::remove_file(&copied));
    assert_agree("instanced vs copied mesh", &a, &b, 0.02);
}

/// Corrupted files (seeded byte changes in the GLB's JSON and binary chunks,
/// and in the JSON's numbers) are errors or scenes, never panics.
#[test]
fn corrupted_files_never_panic() {
    let base = glb();
    let mut state = 0x9E37_79B9_7F4A_7C15u64;
    let mut next = || {
        state ^= state << 13;
        state ^= state >> 7;
        state ^= state << 17;
        state
    };
    let (mut errors, mut loaded) = (0, 0);
    let json_end = 20 + u32::from_le_bytes(base[12..16].try_into().unwrap()) as usize;
    for k in 0..20_000 {
        let mut g = base.clone();
        for _ in 0..1 + next() % 4 {
            // Half the runs change the JSON chunk, half the binary one.
            let (lo, hi) = if k % 2 == 0 { (0, json_end) } else { (json_end, g.len()) };
            let i = lo + (next() % (hi - lo) as u64) as usize;
            g[i] = match next() % 3 {
                0 => next() as u8,
                1 => b"0123456789"[(next() % 10) as usize],
                _ => g[i] ^ (1 << (next() % 8)),
            };
        }
        match std::panic::catch_unwind(|| load("fuzz.glb", &g)) {
            Ok(Ok(_)) => loaded += 1,
            Ok(Err(_)) => errors += 1,
            Err(_) => {
                panic!("a corrupted GLB panicked the reader: {:?}", String::from_utf8_lossy(&g[20..g.len().min(400)]))
            }
        }
    }
    println!("corrupted GLBs: {errors} errors, {loaded} loaded");
    assert!(errors > 100 && loaded > 100);
}

/// COLOR_0 multiplies the base colour: the red box with vertex colours
/// (0.5, 1, 1) renders as the XML twin with reflectance (0.4, 0.1, 0.1).
#[test]
fn vertex_colours_multiply_the_base_colour() {
    use base64::Engine;
    let dir = std::env::temp_dir().join(format!("penumbra-gltf-colours-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let colours: Vec<u8> = (0..24).flat_map(|_| [0.5f32, 1.0, 1.0]).flat_map(f32::to_le_bytes).collect();
    let uri =
        format!("data:application/octet-stream;base64,{}", base64::engine::general_purpose::STANDARD.encode(&colours));
    let bin = scene("boxes.bin").to_str().unwrap().to_string();
    let doc = edited(|d| {
        d["buffers"][0]["uri"] = bin.into();
        let n = colours.len();
        d["buffers"].as_array_mut().unwrap().push(serde_value(&format!(r#"{{"uri": "{uri}", "byteLength": {n}}}"#)));
        let views = d["bufferViews"].as_array_mut().unwrap();
        views.push(serde_value(&format!(r#"{{"buffer": 1, "byteLength": {n}}}"#)));
        let view = views.len() - 1;
        let accs = d["accessors"].as_array_mut().unwrap();
        accs.push(serde_value(&format!(
            r#"{{"bufferView": {view}, "componentType": 5126, "count": 24, "type": "VEC3"}}"#
        )));
        let acc = accs.len() - 1;
        d["meshes"][1]["primitives"][0]["attributes"]["COLOR_0"] = acc.into();
    });
    let gltf_path = dir.join("colours.gltf");
    std::fs::write(&gltf_path, doc).unwrap();
    let xml = std::fs::read_to_string(scene("boxes.xml")).unwrap().replace("0.8, 0.1, 0.1", "0.4, 0.1, 0.1");
    assert!(xml.contains("0.4, 0.1, 0.1"));
    let xml_path = dir.join("colours.xml");
    std::fs::write(&xml_path, xml).unwrap();
    let a = render(&gltf_path, 32, 8, 5);
    let b = render(&xml_path, 32, 8, 6);
    // Power: the unchanged twin (vertex colours ignored) differs.
    let c = render(&scene("boxes.xml"), 32, 8, 7);
    let _ = std::fs::remove_dir_all(&dir);
    assert_agree("vertex colours vs XML", &a, &b, 0.02);
    assert!(!compare("without vertex colours", &a, &c, 0.02).failures.is_empty());
}

fn serde_value(s: &str) -> Value {
    ::gltf::json::deserialize::from_str(s).unwrap()
}

/// KHR_texture_transform's rotation turns uv counter-clockwise;
/// `normalTexture` becomes a normal map whose texels carry `scale`
/// (scale 0: the unperturbed normal (0, 0, 1), stored as (0.5, 0.5, 1));
/// an orthographic camera sets the film's aspect from xmag / ymag.
#[test]
fn normal_maps_and_orthographic_cameras() {
    use penumbra_render::camera::Projection;
    use penumbra_render::material::Material;
    use penumbra_render::texture::Texture;
    let text = std::fs::read_to_string(scene("materials.gltf")).unwrap();
    let mut d: Value = ::gltf::json::deserialize::from_str(&text).unwrap();
    d["materials"][0]["normalTexture"] = serde_value(r#"{"index": 0, "scale": 0}"#);
    d["materials"][0]["pbrMetallicRoughness"]["baseColorTexture"]["extensions"]["KHR_texture_transform"] =
        serde_value(r#"{"rotation": 0.7853982}"#);
    d["cameras"][0] =
        serde_value(r#"{"type": "orthographic", "orthographic": {"xmag": 2, "ymag": 1, "znear": 0.1, "zfar": 50}}"#);
    let (job, _) = gltf::load_bytes(&scene("materials.gltf"), d.to_string().as_bytes(), &Overrides::default()).unwrap();
    let Material::NormalMap { normals: Texture::Bitmap(b), inner } = &job.scene.materials[0] else {
        panic!("{:?}", job.scene.materials[0])
    };
    assert!(matches!(**inner, Material::GltfPbr(_)));
    // (The checker as a normal map: light texels (2c − 1 > 0) give +z, dark ones −z.)
    for (uv, z) in [(glam::Vec2::new(0.01, 0.01), 1.0), (glam::Vec2::new(0.3, 0.7), 0.0)] {
        assert!((b.eval(uv) - glam::Vec3::new(0.5, 0.5, z)).abs().max_element() < 1e-6, "{}", b.eval(uv));
    }
    // KHR_texture_transform's rotation, counter-clockwise as the extension's
    // GLSL: uv (0.3, 0) turned by 45° is (0.212, 0.212), texel (1, 1), light;
    // turned the other way (0.212, −0.212) it would be texel (1, 6), dark.
    let Material::GltfPbr(p) = &**inner else { unreachable!() };
    let Texture::Bitmap(base) = &p.base_color else { panic!("no base colour texture") };
    assert!(base.eval(glam::Vec2::new(0.3, 0.0)).x > 0.5, "{}", base.eval(glam::Vec2::new(0.3, 0.0)));
    assert!(matches!(job.camera.projection, Projection::Orthographic { .. }));
    assert_eq!(job.full_size, (512, 256));
    // The view spans ±xmag: the camera's x axis has length xmag.
    let x = job.camera.world_from_camera.transform_vector3(glam::Vec3::X).length();
    assert!((x - 2.0).abs() < 1e-5, "{x}");
}

/// emissiveFactor × sRGB emissiveTexture × emissive strength becomes the
/// floor's area light, texel by texel (the texture's transform applies).
#[test]
fn emissive_textures() {
    use penumbra_render::light::Light;
    use penumbra_render::texture::Texture;
    use penumbra_scene::image_io::srgb_to_linear;
    let text = std::fs::read_to_string(scene("materials.gltf")).unwrap();
    let mut d: Value = ::gltf::json::deserialize::from_str(&text).unwrap();
    d["materials"][0]["emissiveTexture"] = serde_value(r#"{"index": 0}"#);
    d["materials"][0]["emissiveFactor"] = serde_value("[1, 0.5, 0.25]");
    d["materials"][0]["extensions"] = serde_value(r#"{"KHR_materials_emissive_strength": {"emissiveStrength": 3}}"#);
    d["extensionsUsed"].as_array_mut().unwrap().push("KHR_materials_emissive_strength".into());
    let (job, notes) =
        gltf::load_bytes(&scene("materials.gltf"), d.to_string().as_bytes(), &Overrides::default()).unwrap();
    assert!(notes.is_empty(), "{notes:?}");
    let area: Vec<&Texture> = job
        .scene
        .lights
        .iter()
        .filter_map(|l| match l {
            Light::Area(a) => Some(&a.radiance),
            _ => None,
        })
        .collect();
    assert_eq!(area.len(), 1, "the floor emits");
    let Texture::Bitmap(b) = area[0] else { panic!("an untextured emission") };
    let scale = glam::Vec3::new(1.0, 0.5, 0.25) * 3.0;
    for (x, y, byte) in [(0, 0, 200.0), (1, 0, 60.0)] {
        let uv = glam::Vec2::new((x as f32 + 0.5) / 8.0, (y as f32 + 0.5) / 8.0);
        let expect = scale * srgb_to_linear(byte / 255.0);
        assert!((b.eval(uv) - expect).abs().max_element() < 1e-5, "{} vs {expect}", b.eval(uv));
    }
}

/// `KHR_materials_volume` on a transmitting material fills its mesh with
/// the absorbing medium of the specification's Beer–Lambert law, σ_a =
/// −ln(attenuationColor) / attenuationDistance, σ_s = 0, and the scene
/// renders with `volpath`; thin-walled (thickness 0) and non-transmitting
/// materials get no medium.
#[test]
fn volume_materials_fill_their_meshes_with_an_absorbing_medium() {
    use penumbra_render::integrator::Integrator;
    use penumbra_render::medium::MediumKind;
    let volume = |thickness: f64, transmission: f64| {
        edited(|d| {
            d["materials"][2]["extensions"] = serde_value(&format!(
                r#"{{"KHR_materials_transmission": {{"transmissionFactor": {transmission}}},
                    "KHR_materials_volume": {{"thicknessFactor": {thickness}, "attenuationDistance": 0.5,
                                               "attenuationColor": [0.5, 0.25, 1.0]}}}}"#
            ));
        })
    };
    let job = load("boxes.gltf", &volume(0.2, 1.0)).unwrap();
    assert!(matches!(job.integrator, Integrator::VolPath(_)), "{:?}", job.integrator);
    let s = &job.scene;
    let filled: Vec<usize> = (0..s.shape_media.len()).filter(|&i| s.shape_media[i].interior.is_some()).collect();
    assert!(!filled.is_empty() && s.shape_media.iter().all(|m| m.exterior.is_none()));
    let m = &s.media[s.shape_media[filled[0]].interior.unwrap() as usize];
    let MediumKind::Homogeneous { sigma_t, albedo } = m.kind else { panic!("{:?}", m.kind) };
    let want = glam::Vec3::new(-(0.5f32.ln()) / 0.5, -(0.25f32.ln()) / 0.5, 0.0);
    assert!((sigma_t - want).abs().max_element() < 1e-6 && albedo == glam::Vec3::ZERO, "{sigma_t} {albedo}");
    for (thickness, transmission) in [(0.0, 1.0), (0.2, 0.0)] {
        let job = load("boxes.gltf", &volume(thickness, transmission)).unwrap();
        assert!(job.scene.shape_media.iter().all(|m| m.interior.is_none()), "{thickness} {transmission}");
        assert!(!matches!(job.integrator, Integrator::VolPath(_)));
    }
    let bad = edited(|d| {
        d["materials"][2]["extensions"] = serde_value(
            r#"{"KHR_materials_transmission": {"transmissionFactor": 1},
                "KHR_materials_volume": {"thicknessFactor": 1, "attenuationDistance": -1}}"#,
        );
    });
    let e = load("boxes.gltf", &bad).unwrap_err();
    assert!(e.contains("/materials/2/extensions/KHR_materials_volume") && e.contains("attenuationDistance"), "{e}");
}

/// Finite node transforms whose product with the mesh overflows single
/// precision are an error at the node or primitive, for a mesh placed once
/// (transformed into world space) and for one shared by two nodes
/// (instanced; found by fuzzing: the BVH was built over infinite boxes).
#[test]
fn world_space_overflow_is_an_error_at_the_node() {
    for shared in [false, true] {
        let bad = edited(|d| {
            d["nodes"][0]["translation"] = serde_value("[3e38, 0, 0]");
            d["nodes"][0]["scale"] = serde_value("[3e38, 1, 1]");
            if shared {
                d["nodes"][3]["mesh"] = serde_value("0");
                d["nodes"][3].as_object_mut().unwrap().remove("matrix");
            }
        });
        let e = load("boxes.gltf", &bad).unwrap_err();
        if shared {
            assert!(e.contains("/nodes/0") && e.contains("beyond single precision in world space"), "{e}");
        } else {
            assert!(e.contains("/meshes/0/primitives/0") && e.contains("not finite"), "{e}");
        }
    }
}
