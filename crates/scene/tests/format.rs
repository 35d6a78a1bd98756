//! The scene format as Mitsuba 3.9.1 reads it: spectra converted to sRGB
//! as its RGB variants do, `<path>` search directories, scene versions.
//! Expected values were printed by Mitsuba 3.9.1 (`scalar_rgb`); the Python
//! is in the comments.

use penumbra_render::light::Light;
use penumbra_render::material::Material;
use penumbra_render::texture::Texture;
use penumbra_scene::builder::{build, Overrides};
use penumbra_scene::desc::{Kind, Node, SceneDesc, Value};
use penumbra_scene::mitsuba::{parse_file, parse_str};
use std::path::{Path, PathBuf};

fn root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../..")
}

fn temp_dir(name: &str) -> PathBuf {
    let dir = Path::new(env!("CARGO_TARGET_TMPDIR")).join("format").join(name);
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

fn parse(xml: &str) -> SceneDesc {
    parse_str(xml, Path::new("test.xml"), &[]).unwrap_or_else(|e| panic!("{e}"))
}

/// The first object of `kind` below the root (depth first).
fn find(node: &Node, kind: Kind) -> Option<&Node> {
    for c in &node.children {
        if c.node.kind == kind {
            return Some(&c.node);
        }
        if let Some(n) = find(&c.node, kind) {
            return Some(n);
        }
    }
    None
}

fn assert_close(name: &str, got: [f64; 3], want: [f64; 3], rel: f64) {
    for i in 0..3 {
        let tol = rel * want[i].abs().max(1e-3);
        assert!((got[i] - want[i]).abs() <= tol, "{name}: got {got:?}, Mitsuba {want:?}");
    }
}

/// The colour `param` of the first object of `kind` in a scene holding `body`.
fn color(body: &str, kind: Kind, param: &str) -> [f64; 3] {
    let desc = parse(&format!("<scene version=\"3.0.0\">{body}</scene>"));
    let node = find(&desc.root, kind).expect("object");
    node.get_rgb(param).unwrap_or_else(|e| panic!("{e}")).expect("parameter")
}

// Mitsuba (reflectances):
//   b = mi.load_string('<bsdf version="3.0.0" type="diffuse"><spectrum name="reflectance" VALUE/></bsdf>')
//   si = mi.SurfaceInteraction3f(); si.wi = [0,0,1]; si.sh_frame = mi.Frame3f([0,0,1])
//   print([float(x) * pi for x in b.eval(mi.BSDFContext(), si, [0,0,1])])
const REFLECTANCES: &[(&str, [f64; 3])] = &[
    (
        "400:0.04, 500:0.058, 600:0.287, 650:0.62, 700:0.642",
        [0.4721374527514509, 0.14213905163346185, 0.031126200759770708],
    ),
    ("0.5", [0.5, 0.5, 0.5]),
    // A flat unit spectrum over part of the visible range is nearly white.
    ("400:1.0, 700:1.0", [0.9953419348667959, 0.9997563428360354, 0.994909098368847]),
    // Beyond the CIE range [360, 830] nm.
    ("300:0.5, 900:0.5", [0.4994926164323907, 0.4994368148851751, 0.49940076858370197]),
    // Out of gamut: clamped to [0, 1] (mi.spectrum_list_to_srgb([450, 550], [2.0, 0.1], True, True)).
    ("450:2.0, 550:0.1", [0.0, 0.405318, 0.998313]),
];

// Mitsuba (emission):
//   s = mi.load_string('<shape version="3.0.0" type="rectangle"><emitter type="area">'
//                      '<spectrum name="radiance" VALUE/></emitter></shape>')
//   si = mi.SurfaceInteraction3f(); si.wi = [0,0,1]; si.sh_frame = mi.Frame3f([0,0,1]); si.n = [0,0,1]
//   print([float(x) for x in s.emitter().eval(si)])
const EMISSIONS: &[(&str, [f64; 3])] = &[
    ("400:0, 500:8, 600:15.6, 700:18.4", [20.71083641052246, 10.854634284973145, 2.7711520195007324]),
    // A constant spectrum is an equal-energy emitter: 5 * xyz_to_srgb(1, 1, 1).
    ("5", [6.023969650268555, 4.741455078125, 4.544580459594727]),
    ("400:1, 700:1", [1.1996935606002808, 0.9495203495025635, 0.9034433364868164]),
    // Negative components are clamped to 0, values above 1 kept
    // (mi.spectrum_list_to_srgb([450, 550], [2.0, 0.1], False, False)).
    ("450:2.0, 550:0.1", [0.0, 0.375208, 0.851997]),
];

#[test]
fn reflectance_spectra_convert_as_mitsubas_rgb_variants() {
    for (value, want) in REFLECTANCES {
        let bsdf = format!("<bsdf type=\"diffuse\"><spectrum name=\"reflectance\" value=\"{value}\"/></bsdf>");
        assert_close(value, color(&bsdf, Kind::Bsdf, "reflectance"), *want, 2e-5);
    }
    // Textures read their colours as reflectances too.
    let checker = "<texture type=\"checkerboard\"><spectrum name=\"color0\" value=\"400:1.0, 700:1.0\"/></texture>";
    assert_close("color0", color(checker, Kind::Texture, "color0"), REFLECTANCES[2].1, 2e-5);
}

#[test]
fn emission_spectra_convert_without_d65_and_unclamped_above() {
    for (value, want) in EMISSIONS {
        let shape = format!(
            "<shape type=\"rectangle\"><emitter type=\"area\"><spectrum name=\"radiance\" value=\"{value}\"/></emitter></shape>"
        );
        assert_close(value, color(&shape, Kind::Emitter, "radiance"), *want, 2e-5);
    }
    // <rgb> and <float> emission stay as given (Mitsuba's 'srgb' texture).
    let shape =
        "<shape type=\"rectangle\"><emitter type=\"area\"><float name=\"radiance\" value=\"5\"/></emitter></shape>";
    assert_eq!(color(shape, Kind::Emitter, "radiance"), [5.0; 3]);
    let light = "<emitter type=\"point\"><spectrum name=\"intensity\" value=\"5\"/></emitter>";
    assert_close("point intensity", color(light, Kind::Emitter, "intensity"), EMISSIONS[1].1, 2e-5);
}

#[test]
fn unbounded_parameters_keep_values_above_one() {
    // mi.spectrum_list_to_srgb([400, 500, 600, 700], [0.6, 2.7, 1.2, 4.5], False, True) -> [1.46604, 2.11775, 1.70035]
    // (bounded=True gives [1, 1, 1]).
    let spec = "400:0.6, 500:2.7, 600:1.2, 700:4.5";
    let bsdf = format!(
        "<bsdf type=\"conductor\"><spectrum name=\"k\" value=\"{spec}\"/><spectrum name=\"specular_reflectance\" value=\"{spec}\"/></bsdf>"
    );
    assert_close("k", color(&bsdf, Kind::Bsdf, "k"), [1.46604, 2.11775, 1.70035], 2e-5);
    assert_eq!(color(&bsdf, Kind::Bsdf, "specular_reflectance"), [1.0; 3]);
}

#[test]
fn spectrum_files_are_read_through_the_search_path() {
    // The same spectrum as tests/scenes/format/assets/paint.spd:
    // mi.spectrum_list_to_srgb([400,500,600,700], [0.2,0.9,0.4,1.5], True, True) -> [0.488679, 0.705918, 0.566785]
    // mi.spectrum_list_to_srgb(..., False, False) -> [0.63066, 0.663511, 0.50414] (emission)
    let path = root().join("tests/scenes/format/spectral_quad.xml");
    let desc = parse_file(&path, &[("spp".into(), "1".into())]).unwrap_or_else(|e| panic!("{e}"));
    let job = build(&desc, &Overrides::default()).unwrap_or_else(|e| panic!("{e}"));
    let scene = &job.scene;
    assert_eq!(scene.shapes.len(), 2);
    let Material::Diffuse(penumbra_render::bsdf::DiffuseParams { reflectance: Texture::Constant(r) }) =
        &scene.materials[scene.shape_info[0].material as usize]
    else {
        panic!("diffuse with a constant reflectance expected");
    };
    assert_close("paint.spd", [r.x as f64, r.y as f64, r.z as f64], [0.488679, 0.705918, 0.566785], 2e-5);
    let Light::Area(area) = &scene.lights[0] else { panic!("area light expected") };
    let e = area.radiance.constant().expect("a constant radiance");
    assert_close("radiance", [e.x as f64, e.y as f64, e.z as f64], EMISSIONS[0].1, 2e-5);

    // As an emission spectrum, and with comments and blank lines.
    let dir = temp_dir("spd");
    std::fs::write(dir.join("e.spd"), "# comment\n\n400 0.2\n500 0.9\r\n600 0.4\n700 1.5\n").unwrap();
    let scene = dir.join("scene.xml");
    std::fs::write(
        &scene,
        "<scene version=\"3.0.0\"><emitter type=\"constant\"><spectrum name=\"radiance\" filename=\"e.spd\"/></emitter></scene>",
    )
    .unwrap();
    let desc = parse_file(&scene, &[]).unwrap_or_else(|e| panic!("{e}"));
    let rgb = find(&desc.root, Kind::Emitter).unwrap().get_rgb("radiance").unwrap().unwrap();
    assert_close("e.spd", rgb, [0.63066, 0.663511, 0.50414], 2e-5);

    // Bad files name the file and the line.
    std::fs::write(dir.join("bad.spd"), "400 0.2\n500 x\n").unwrap();
    std::fs::write(
        &scene,
        "<scene version=\"3.0.0\">\n<emitter type=\"constant\"><spectrum name=\"radiance\" filename=\"bad.spd\"/></emitter></scene>",
    )
    .unwrap();
    let e = parse_file(&scene, &[]).unwrap_err().to_string();
    assert!(e.contains("scene.xml:2") && e.contains("bad.spd") && e.contains("line 2"), "{e}");
    std::fs::write(
        &scene,
        "<scene version=\"3.0.0\">\n<emitter type=\"constant\"><spectrum name=\"radiance\" filename=\"none.spd\"/></emitter></scene>",
    )
    .unwrap();
    let e = parse_file(&scene, &[]).unwrap_err().to_string();
    assert!(e.contains("scene.xml:2") && e.contains("none.spd") && e.contains("not found"), "{e}");
}

/// A directory with `a/m.obj` (one triangle), `b/m.obj` (two triangles)
/// and `b/only_b.obj`.
fn mesh_dirs(name: &str) -> PathBuf {
    let dir = temp_dir(name);
    std::fs::create_dir_all(dir.join("a")).unwrap();
    std::fs::create_dir_all(dir.join("b")).unwrap();
    let one = "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n";
    let two = "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 1 1 0\nf 1 2 3\nf 2 4 3\n";
    std::fs::write(dir.join("a/m.obj"), one).unwrap();
    std::fs::write(dir.join("b/m.obj"), two).unwrap();
    std::fs::write(dir.join("b/only_b.obj"), two).unwrap();
    dir
}

const SENSOR: &str = "<sensor type=\"perspective\"><film type=\"hdrfilm\"><integer name=\"width\" value=\"4\"/><integer name=\"height\" value=\"4\"/></film></sensor>";

/// Loads `body` as dir/scene.xml; the triangle count of each shape.
fn triangles(dir: &Path, body: &str) -> Result<Vec<usize>, String> {
    let scene = dir.join("scene.xml");
    std::fs::write(&scene, format!("<scene version=\"3.0.0\">\n{SENSOR}\n{body}\n</scene>")).unwrap();
    let job = penumbra_scene::load_scene(&scene, &[], &Overrides::default()).map_err(|e| e.to_string())?;
    Ok(job.scene.shapes.iter().map(|s| s.prim_count()).collect())
}

fn obj(name: &str) -> String {
    format!("<shape type=\"obj\"><string name=\"filename\" value=\"{name}\"/></shape>")
}

#[test]
fn path_adds_search_directories_latest_first() {
    let dir = mesh_dirs("path");
    // Without <path>, names are relative to the scene file.
    let e = triangles(&dir, &obj("m.obj")).unwrap_err();
    assert!(
        e.contains("scene.xml:") && e.contains("'m.obj' not found") && e.contains(&dir.display().to_string()),
        "{e}"
    );
    assert_eq!(triangles(&dir, &format!("<path value=\"a\"/>{}", obj("m.obj"))).unwrap(), [1]);
    // The latest <path> is searched first.
    assert_eq!(triangles(&dir, &format!("<path value=\"a\"/><path value=\"b\"/>{}", obj("m.obj"))).unwrap(), [2]);
    assert_eq!(triangles(&dir, &format!("<path value=\"b\"/><path value=\"a\"/>{}", obj("m.obj"))).unwrap(), [1]);
    // Earlier directories stay searched.
    assert_eq!(triangles(&dir, &format!("<path value=\"b\"/><path value=\"a\"/>{}", obj("only_b.obj"))).unwrap(), [2]);
    // As in Mitsuba, a <path> also serves the names written before it
    // (Mitsuba resolves names when it builds the objects, after reading the file).
    assert_eq!(triangles(&dir, &format!("{}<path value=\"a\"/>", obj("m.obj"))).unwrap(), [1]);
    // The scene's own directory comes after the <path>s.
    std::fs::copy(dir.join("a/m.obj"), dir.join("m.obj")).unwrap();
    assert_eq!(triangles(&dir, &format!("<path value=\"b\"/>{}", obj("m.obj"))).unwrap(), [2]);
    std::fs::remove_file(dir.join("m.obj")).unwrap();
    // Not found: the message lists every directory searched.
    let e = triangles(&dir, &format!("<path value=\"a\"/>{}", obj("none.obj"))).unwrap_err();
    assert!(e.contains("'none.obj' not found") && e.contains(&dir.join("a").display().to_string()), "{e}");
    // $parameters work in <path>.
    let scene = dir.join("scene.xml");
    std::fs::write(&scene, format!("<scene version=\"3.0.0\">{SENSOR}<path value=\"$d\"/>{}</scene>", obj("m.obj")))
        .unwrap();
    let job = penumbra_scene::load_scene(&scene, &[("d".into(), "b".into())], &Overrides::default()).unwrap();
    assert_eq!(job.scene.shapes[0].prim_count(), 2);
}

#[test]
fn path_errors_name_the_line() {
    let dir = mesh_dirs("path_errors");
    let e = triangles(&dir, "<path value=\"nowhere\"/>").unwrap_err();
    assert!(e.contains("scene.xml:3") && e.contains("nowhere") && e.contains("not found"), "{e}");
    let e = triangles(&dir, "<shape type=\"sphere\"><path value=\"a\"/></shape>").unwrap_err();
    assert!(e.contains("scene.xml:3") && e.contains("directly inside <scene>"), "{e}");
    let e = triangles(&dir, "<path/>").unwrap_err();
    assert!(e.contains("scene.xml:3") && e.contains("value"), "{e}");
}

#[test]
fn includes_and_their_files_use_the_search_path() {
    let dir = mesh_dirs("include");
    std::fs::create_dir_all(dir.join("parts")).unwrap();
    // An include found through <path>.
    std::fs::write(dir.join("parts/shape.xml"), format!("<scene version=\"3.0.0\">{}</scene>", obj("m.obj"))).unwrap();
    assert_eq!(
        triangles(&dir, "<path value=\"parts\"/><path value=\"b\"/><include filename=\"shape.xml\"/>").unwrap(),
        [2]
    );
    // Names inside an included file: Mitsuba searches the main scene's
    // directories only; Penumbra then also tries the included file's directory.
    std::fs::copy(dir.join("a/m.obj"), dir.join("parts/m.obj")).unwrap();
    assert_eq!(triangles(&dir, "<path value=\"b\"/><include filename=\"parts/shape.xml\"/>").unwrap(), [2]);
    assert_eq!(triangles(&dir, "<include filename=\"parts/shape.xml\"/>").unwrap(), [1]);
}

#[test]
fn every_version_loads_older_ones_upgraded() {
    for v in ["2.0.0", "2.1.0", "3.0.0", "3.6.1"] {
        assert!(parse(&format!("<scene version=\"{v}\"><bsdf type=\"diffuse\"/></scene>")).upgraded.is_empty());
    }
    // Older files are upgraded as Mitsuba 3 upgrades them (tests in mitsuba_xml.rs).
    for v in ["0.5.0", "0.6.0", "1.0.0"] {
        let xml = format!("<scene version=\"{v}\"><integrator type=\"path\"><integer name=\"maxDepth\" value=\"3\"/></integrator></scene>");
        let desc = parse_str(&xml, Path::new("old.xml"), &[]).unwrap();
        let note = desc.upgrade_notes().join("\n");
        for needle in [v, "old.xml", "maxDepth -> max_depth (line 1)"] {
            assert!(note.contains(needle), "'{needle}' not in: {note}");
        }
    }
}

#[test]
fn parameters_substitute_in_every_attribute() {
    // $name in type, id, name and value attributes; -D beats <default>;
    // <point>/<vector> from value= (one or three numbers) or x/y/z.
    let xml = "<scene version=\"3.0.0\">
        <default name=\"kind\" value=\"sphere\"/>
        <default name=\"r\" value=\"1\"/>
        <shape type=\"$kind\" id=\"s_$kind\">
            <float name=\"$param\" value=\"$r\"/>
            <point name=\"center\" value=\"$r\"/>
            <vector name=\"v3\" x=\"1\" y=\"$r\" z=\"3\"/>
            <rgb name=\"c\" value=\"$r, 0.5 0.25\"/>
        </shape>
    </scene>";
    let defines = [("param".to_string(), "radius".to_string()), ("r".to_string(), "2".to_string())];
    let desc = parse_str(xml, Path::new("t.xml"), &defines).unwrap_or_else(|e| panic!("{e}"));
    let shape = find(&desc.root, Kind::Shape).unwrap();
    assert_eq!((shape.plugin.as_str(), shape.id.as_deref()), ("sphere", Some("s_sphere")));
    let get = |n: &str| shape.props.iter().find(|p| p.name == n).map(|p| p.value.clone()).unwrap();
    assert_eq!(get("radius"), Value::Float(2.0));
    assert_eq!(get("center"), Value::Point(glam::DVec3::splat(2.0)));
    assert_eq!(get("v3"), Value::Vector(glam::DVec3::new(1.0, 2.0, 3.0)));
    assert_eq!(get("c"), Value::Rgb([2.0, 0.5, 0.25]));
}

#[test]
fn top_level_declarations_used_through_ref() {
    // Mitsuba's docs scenes declare the area emitter and the sampler at the
    // top level and reference them (integrator_depth_*.xml, sampler_*.xml).
    let xml = "<scene version=\"3.0.0\">
        <sampler type=\"independent\" id=\"smp\"><integer name=\"sample_count\" value=\"7\"/></sampler>
        <sensor type=\"perspective\"><ref id=\"smp\"/><film type=\"hdrfilm\"><integer name=\"width\" value=\"4\"/><integer name=\"height\" value=\"4\"/></film></sensor>
        <shape type=\"rectangle\"><ref id=\"lamp\"/></shape>
        <emitter type=\"area\" id=\"lamp\"><rgb name=\"radiance\" value=\"2\"/></emitter>
    </scene>";
    let job = build(&parse(xml), &Overrides::default()).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(job.sampler.spp, 7);
    assert_eq!(job.scene.lights.len(), 1);
    // Unreferenced, they are still errors.
    let xml = "<scene version=\"3.0.0\">
        <sensor type=\"perspective\"><film type=\"hdrfilm\"/></sensor>
        <emitter type=\"area\" id=\"lamp\"><rgb name=\"radiance\" value=\"2\"/></emitter>
    </scene>";
    let e = build(&parse(xml), &Overrides::default()).unwrap_err().to_string();
    assert!(e.contains("nested inside a shape"), "{e}");
    let xml = "<scene version=\"3.0.0\"><sensor type=\"perspective\"><film type=\"hdrfilm\"/></sensor><sampler type=\"independent\"/></scene>";
    assert!(build(&parse(xml), &Overrides::default()).is_err());
}
