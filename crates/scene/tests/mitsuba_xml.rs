//! Tests of the Mitsuba 3 XML reader: values, transforms, parameters,
//! references, includes, and that errors name the file and line.

use glam::{DMat4, DVec3};
use penumbra_scene::desc::{Kind, Node, SceneDesc, Value};
use penumbra_scene::mitsuba::{parse_file, parse_str};
use penumbra_scene::LoadError;
use std::path::{Path, PathBuf};
use std::rc::Rc;

const FILE: &str = "/virtual/dir/scene.xml";

fn parse(text: &str) -> Result<SceneDesc, LoadError> {
    parse_str(text, Path::new(FILE), &[])
}

fn parse_with(text: &str, defines: &[(&str, &str)]) -> Result<SceneDesc, LoadError> {
    let d: Vec<(String, String)> = defines.iter().map(|(k, v)| (k.to_string(), v.to_string())).collect();
    parse_str(text, Path::new(FILE), &d)
}

/// Wraps object XML in a scene; the body starts on line 2.
fn scene(body: &str) -> String {
    format!("<scene version=\"3.0.0\">\n{body}\n</scene>")
}

fn err(text: &str) -> LoadError {
    parse(text).expect_err("expected an error")
}

/// Asserts the error is located at `line` of `file` and mentions `words`.
#[track_caller]
fn assert_err(e: &LoadError, file: &str, line: u32, words: &[&str]) {
    let loc = e.loc.as_ref().unwrap_or_else(|| panic!("no location in {e}"));
    assert_eq!(loc.file.as_path(), Path::new(file), "wrong file in: {e}");
    assert_eq!(loc.line, line, "wrong line in: {e}");
    let shown = e.to_string();
    assert!(shown.contains(&format!("{file}:{line}:")), "display lacks file:line: {shown}");
    for w in words {
        assert!(shown.contains(w), "{shown:?} does not mention {w:?}");
    }
}

fn first(desc: &SceneDesc) -> &Node {
    &desc.root.children[0].node
}

fn value<'a>(node: &'a Node, name: &str) -> &'a Value {
    &node.props.iter().find(|p| p.name == name).unwrap_or_else(|| panic!("no {name}")).value
}

fn transform_of(text: &str) -> DMat4 {
    let desc =
        parse(&scene(&format!("<shape type=\"sphere\"><transform name=\"to_world\">{text}</transform></shape>")))
            .unwrap();
    match value(first(&desc), "to_world") {
        Value::Transform(m) => *m,
        v => panic!("not a transform: {v:?}"),
    }
}

fn close(a: DVec3, b: DVec3) -> bool {
    (a - b).abs().max_element() < 1e-9
}

/// A fresh directory for tests that need real files.
fn temp_dir(name: &str) -> PathBuf {
    let dir = Path::new(env!("CARGO_TARGET_TMPDIR")).join("mitsuba_xml").join(name);
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

// ---------------------------------------------------------------- values

#[test]
fn objects_and_properties() {
    let desc = parse(&scene(
        r#"<integrator type="path" id="integ">
    <integer name="max_depth" value="-1"/>
</integrator>
<shape type="sphere" name="ignored">
    <float name="radius" value=" 2.5 "/>
    <boolean name="flip_normals" value="TRUE"/>
    <string name="filename" value="a b.obj"/>
    <point name="center" value="1, 2 3"/>
    <vector name="dir" x="1" y="0" z="-1"/>
    <point name="p" value="4"/>
    <bsdf type="diffuse" name="my_bsdf">
        <rgb name="reflectance" value="0.1, 0.2, 0.3"/>
        <rgb name="grey" value="0.5"/>
        <rgb name="spaces" value="0.1 0.2  0.3"/>
        <spectrum name="const" value="0.25"/>
        <spectrum name="sampled" value="400:0.1, 500:0.2 600:0.3"/>
    </bsdf>
</shape>"#,
    ))
    .unwrap();
    assert_eq!(desc.version, "3.0.0");
    let root = &desc.root;
    assert_eq!(root.kind, Kind::Scene);
    assert_eq!(root.plugin, "");
    assert_eq!(root.children.len(), 2);

    let integ = first(&desc);
    assert_eq!((integ.kind, integ.plugin.as_str()), (Kind::Integrator, "path"));
    assert_eq!(integ.id.as_deref(), Some("integ"));
    assert_eq!(integ.loc.line, 2);
    assert_eq!(*value(integ, "max_depth"), Value::Integer(-1));

    let shape = &root.children[1].node;
    assert_eq!(root.children[1].name.as_deref(), Some("ignored"));
    assert_eq!(shape.name.as_deref(), Some("ignored"));
    assert_eq!(*value(shape, "radius"), Value::Float(2.5));
    assert_eq!(*value(shape, "flip_normals"), Value::Boolean(true));
    assert_eq!(*value(shape, "filename"), Value::String("a b.obj".into()));
    assert_eq!(*value(shape, "center"), Value::Point(DVec3::new(1.0, 2.0, 3.0)));
    assert_eq!(*value(shape, "dir"), Value::Vector(DVec3::new(1.0, 0.0, -1.0)));
    assert_eq!(*value(shape, "p"), Value::Point(DVec3::splat(4.0)));
    let radius = shape.props.iter().find(|p| p.name == "radius").unwrap();
    assert_eq!((radius.loc.line, radius.loc.col), (6, 5));
    assert_eq!(radius.loc.file.as_path(), Path::new(FILE));
    assert!(!radius.used.get());

    let bsdf_child = &shape.children[0];
    assert_eq!(bsdf_child.name.as_deref(), Some("my_bsdf"));
    assert_eq!(bsdf_child.loc.line, 12);
    let bsdf = &bsdf_child.node;
    assert_eq!((bsdf.kind, bsdf.plugin.as_str()), (Kind::Bsdf, "diffuse"));
    assert_eq!(*value(bsdf, "reflectance"), Value::Rgb([0.1, 0.2, 0.3]));
    assert_eq!(*value(bsdf, "grey"), Value::Rgb([0.5; 3]));
    assert_eq!(*value(bsdf, "spaces"), Value::Rgb([0.1, 0.2, 0.3]));
    assert_eq!(*value(bsdf, "const"), Value::SpectrumConstant(0.25));
    assert_eq!(*value(bsdf, "sampled"), Value::SpectrumSampled(vec![(400.0, 0.1), (500.0, 0.2), (600.0, 0.3)]));
}

#[test]
fn all_object_kinds() {
    let tags = [
        "shape",
        "bsdf",
        "emitter",
        "sensor",
        "film",
        "sampler",
        "rfilter",
        "integrator",
        "texture",
        "medium",
        "phase",
        "volume",
    ];
    let body: String = tags.iter().map(|t| format!("<{t} type=\"x\"/>\n")).collect();
    let desc = parse(&scene(&body)).unwrap();
    let kinds: Vec<&str> = desc.root.children.iter().map(|c| c.node.kind.tag()).collect();
    assert_eq!(kinds, tags);
    // A spectrum with a type is a spectrum plugin: a value of its parent
    // (d65 is white in Mitsuba's RGB variants).
    let desc = parse(&scene("<bsdf type=\"diffuse\"><spectrum type=\"d65\" name=\"reflectance\"/></bsdf>")).unwrap();
    let bsdf = first(&desc);
    assert!(bsdf.children.is_empty());
    assert_eq!((bsdf.props[0].name.as_str(), &bsdf.props[0].value), ("reflectance", &Value::Rgb([1.0; 3])));
    // Any other typed spectrum is a texture (and an error where built).
    let desc = parse(&scene("<bsdf type=\"diffuse\"><spectrum type=\"bitmap\" name=\"reflectance\"/></bsdf>")).unwrap();
    let tex = &first(&desc).children[0].node;
    assert_eq!((tex.kind, tex.plugin.as_str()), (Kind::Texture, "bitmap"));
}

#[test]
fn number_errors_name_file_line_and_parameter() {
    let e = err(&scene("<shape type=\"sphere\">\n  <float name=\"radius\" value=\"1.0abc\"/>\n</shape>"));
    assert_err(&e, FILE, 3, &["radius", "1.0abc"]);
    let e = err(&scene("<integrator type=\"path\">\n<integer name=\"max_depth\" value=\"3.5\"/></integrator>"));
    assert_err(&e, FILE, 3, &["max_depth", "3.5", "integer"]);
    let e = err(&scene("<shape type=\"sphere\"><boolean name=\"flip\" value=\"yes\"/></shape>"));
    assert_err(&e, FILE, 2, &["flip", "yes", "true"]);
    let e = err(&scene("<bsdf type=\"diffuse\"><rgb name=\"reflectance\" value=\"0.1, 0.2\"/></bsdf>"));
    assert_err(&e, FILE, 2, &["reflectance", "one or three"]);
    let e = err(&scene("<bsdf type=\"diffuse\"><rgb name=\"reflectance\" value=\"0.1, x, 0.2\"/></bsdf>"));
    assert_err(&e, FILE, 2, &["reflectance", "\"x\""]);
    let e = err(&scene("<shape type=\"sphere\"><point name=\"center\" x=\"1\" y=\"2\"/></shape>"));
    assert_err(&e, FILE, 2, &["center", "\"z\""]);
    let e = err(&scene("<shape type=\"sphere\"><point name=\"center\" value=\"1 2\"/></shape>"));
    assert_err(&e, FILE, 2, &["center", "1 or 3"]);
    let e = err(&scene("<shape type=\"sphere\"><point name=\"c\" value=\"1\" x=\"2\"/></shape>"));
    assert_err(&e, FILE, 2, &["cannot mix"]);
}

#[test]
fn spectrum_errors() {
    let e = err(&scene("<bsdf type=\"x\">\n<spectrum name=\"eta\" filename=\"Au.spd\"/></bsdf>"));
    assert_err(&e, FILE, 3, &["eta", "Au.spd", "not found"]);
    let e = err(&scene("<bsdf type=\"x\"><spectrum name=\"eta\" value=\"500:1\"/></bsdf>"));
    assert_err(&e, FILE, 2, &["eta", "two"]);
    let e = err(&scene("<bsdf type=\"x\"><spectrum name=\"eta\" value=\"500:1, 400:2\"/></bsdf>"));
    assert_err(&e, FILE, 2, &["increasing"]);
    let e = err(&scene("<bsdf type=\"x\"><spectrum name=\"eta\" value=\"500:1, 600\"/></bsdf>"));
    assert_err(&e, FILE, 2, &["\"600\"", "wavelength:value"]);
    let e = err(&scene("<bsdf type=\"x\"><spectrum name=\"eta\"/></bsdf>"));
    assert_err(&e, FILE, 2, &["value", "filename"]);
}

#[test]
fn duplicate_properties() {
    let e = err(&scene(
        "<shape type=\"sphere\">\n<float name=\"radius\" value=\"1\"/>\n<float name=\"radius\" value=\"2\"/>\n</shape>",
    ));
    assert_err(&e, FILE, 4, &["radius", "more than once", &format!("{FILE}:3:1")]);
    // A named nested object and a property cannot share a name either.
    let e = err(&scene(
        "<bsdf type=\"diffuse\">\n<rgb name=\"reflectance\" value=\"1\"/>\n<texture type=\"checkerboard\" name=\"reflectance\"/>\n</bsdf>",
    ));
    assert_err(&e, FILE, 4, &["reflectance", "more than once"]);
    // Unnamed nested objects do not clash.
    parse(&scene("<shape type=\"sphere\"><bsdf type=\"a\"/><bsdf type=\"b\"/></shape>")).unwrap();
}

// ---------------------------------------------------------------- structure

#[test]
fn structural_errors() {
    // Unknown tag: the message lists what is supported.
    let e = err(&scene("<shape type=\"sphere\">\n<flaot name=\"radius\" value=\"1\"/></shape>"));
    assert_err(&e, FILE, 3, &["<flaot>", "float", "integer", "shape", "include", "ref"]);
    // Unknown and missing attributes.
    let e = err(&scene("<shape type=\"sphere\" kind=\"x\"/>"));
    assert_err(&e, FILE, 2, &["unexpected attribute \"kind\"", "<shape>"]);
    let e = err(&scene("<shape id=\"s\"/>"));
    assert_err(&e, FILE, 2, &["missing required attribute \"type\""]);
    let e = err(&scene("<shape type=\"s\"><float name=\"r\" value=\"1\" unit=\"m\"/></shape>"));
    assert_err(&e, FILE, 2, &["unexpected attribute \"unit\""]);
    let e = err(&scene("<shape type=\"s\"><float value=\"1\"/></shape>"));
    assert_err(&e, FILE, 2, &["missing required attribute \"name\""]);
    // Properties belong to objects, not directly to the scene.
    let e = err(&scene("<float name=\"x\" value=\"1\"/>"));
    assert_err(&e, FILE, 2, &["directly inside <scene>"]);
    // Transform operations only inside <transform>.
    let e = err(&scene("<shape type=\"s\"><translate x=\"1\"/></shape>"));
    assert_err(&e, FILE, 2, &["<translate>", "<transform>"]);
    // Properties have no element children.
    let e = err(&scene(
        "<shape type=\"s\"><float name=\"r\" value=\"1\">\n<float name=\"q\" value=\"1\"/></float></shape>",
    ));
    assert_err(&e, FILE, 2, &["<float>", "cannot appear inside"]);
    // <scene> only as the root.
    let e = err(&scene("<shape type=\"s\"><scene version=\"3.0.0\"/></shape>"));
    assert_err(&e, FILE, 2, &["root"]);
    // <path> must name an existing folder (more in tests/format.rs).
    let e = err(&scene("<path value=\"meshes\"/>"));
    assert_err(&e, FILE, 2, &["<path>", "meshes", "not found"]);
    // Comments and text are ignored.
    parse(&scene("<!-- c --> text <shape type=\"s\"><!-- <float/> --></shape>")).unwrap();
}

#[test]
fn root_and_version() {
    let e = err("<shape type=\"sphere\" version=\"3.0.0\"/>");
    assert_err(&e, FILE, 1, &["<shape>", "<scene"]);
    assert!(parse("\n<scene version=\"0.6.0\"/>").unwrap().upgraded[0].renames.is_empty());
    let e = err("<scene/>");
    assert_err(&e, FILE, 1, &["version"]);
    let e = err("<scene version=\"3.0\"/>");
    assert_err(&e, FILE, 1, &["invalid version", "3.0"]);
    assert_eq!(parse("<scene version=\"2.1.0\"/>").unwrap().version, "2.1.0");
    let desc = parse("<?xml version=\"1.0\" encoding=\"utf-8\"?>\n<scene version=\"3.5.2\" id=\"s\"/>").unwrap();
    assert_eq!((desc.version.as_str(), desc.root.id.as_deref()), ("3.5.2", Some("s")));
    assert_eq!(desc.root.loc.line, 2);
}

#[test]
fn malformed_xml_has_line_and_column() {
    let e = err("<scene version=\"3.0.0\">\n  <shape type=\"sphere\">\n  </shap>\n</scene>");
    assert_err(&e, FILE, 3, &["malformed XML"]);
    assert!(e.loc.unwrap().col > 1);
    let e = err("<scene version=\"3.0.0\">\n<shape type=\"sphere\" id=\"a\" id=\"b\"/>\n</scene>");
    assert_err(&e, FILE, 2, &["malformed XML", "id"]);
}

// ---------------------------------------------------------------- transforms

#[test]
fn transform_operations() {
    let m = transform_of(r#"<translate x="1" z="3"/>"#);
    assert!(close(m.transform_point3(DVec3::ZERO), DVec3::new(1.0, 0.0, 3.0)));
    let m = transform_of(r#"<translate value="1, 2, 3"/>"#);
    assert!(close(m.transform_point3(DVec3::ZERO), DVec3::new(1.0, 2.0, 3.0)));
    let m = transform_of(r#"<scale value="2"/>"#);
    assert!(close(m.transform_point3(DVec3::ONE), DVec3::splat(2.0)));
    let m = transform_of(r#"<scale x="2"/>"#);
    assert!(close(m.transform_point3(DVec3::ONE), DVec3::new(2.0, 1.0, 1.0)));
    let m = transform_of(r#"<scale value="2 3 4"/>"#);
    assert!(close(m.transform_point3(DVec3::ONE), DVec3::new(2.0, 3.0, 4.0)));
    let m = transform_of(r#"<rotate z="1" angle="90"/>"#);
    assert!(close(m.transform_vector3(DVec3::X), DVec3::Y));
    let m = transform_of(r#"<rotate value="0 0 2" angle="-90"/>"#);
    assert!(close(m.transform_vector3(DVec3::X), -DVec3::Y));
    let m = transform_of(r#"<matrix value="1 0 0 5  0 1 0 6  0 0 1 7  0 0 0 1"/>"#);
    assert!(close(m.transform_point3(DVec3::ZERO), DVec3::new(5.0, 6.0, 7.0)));
    let m = transform_of(r#"<lookat origin="0, 0, 5" target="0, 0, 0" up="0, 1, 0"/>"#);
    assert!(close(m.transform_point3(DVec3::ZERO), DVec3::new(0.0, 0.0, 5.0)));
    assert!(close(m.transform_vector3(DVec3::Z), -DVec3::Z));
    assert!(close(m.transform_vector3(DVec3::Y), DVec3::Y));
    // Without an up vector, one perpendicular to the view is made up.
    let m = transform_of(r#"<lookat origin="1 1 1" target="2 1 1"/>"#);
    assert!(close(m.transform_vector3(DVec3::Z), DVec3::X));
    assert!(m.transform_vector3(DVec3::Y).dot(DVec3::X).abs() < 1e-12);
    // An empty transform is the identity.
    assert_eq!(transform_of(""), DMat4::IDENTITY);
}

#[test]
fn transform_order_is_as_written() {
    // Operations apply in the order written: translate, then scale.
    let m = transform_of(r#"<translate x="1"/><scale value="2"/>"#);
    assert!(close(m.transform_point3(DVec3::ZERO), DVec3::new(2.0, 0.0, 0.0)));
    let m = transform_of(r#"<scale value="2"/><translate x="1"/>"#);
    assert!(close(m.transform_point3(DVec3::ZERO), DVec3::X));
    let m = transform_of(r#"<rotate z="1" angle="90"/><translate x="1"/>"#);
    assert!(close(m.transform_point3(DVec3::X), DVec3::new(1.0, 1.0, 0.0)));
}

#[test]
fn transform_errors() {
    let t = |ops: &str| {
        err(&scene(&format!("<shape type=\"s\">\n<transform name=\"to_world\">\n{ops}\n</transform></shape>")))
    };
    assert_err(&t("<rotate angle=\"90\"/>"), FILE, 4, &["axis", "zero"]);
    assert_err(&t("<rotate x=\"1\"/>"), FILE, 4, &["\"angle\""]);
    assert_err(&t("<rotate x=\"1\" angle=\"ninety\"/>"), FILE, 4, &["ninety"]);
    assert_err(&t("<matrix value=\"1 2 3\"/>"), FILE, 4, &["16", "got 3"]);
    assert_err(&t("<lookat origin=\"0 0 0\" target=\"0 0 0\"/>"), FILE, 4, &["<lookat>"]);
    assert_err(&t("<lookat origin=\"0 0\" target=\"0 0 1\"/>"), FILE, 4, &["origin", "3 numbers"]);
    assert_err(&t("<lookat origin=\"0 0 0\" target=\"0 0 1\" up=\"0 0 1\"/>"), FILE, 4, &["parallel"]);
    assert_err(&t("<translate x=\"1cm\"/>"), FILE, 4, &["1cm"]);
    assert_err(&t("<translate x=\"1\" w=\"1\"/>"), FILE, 4, &["\"w\""]);
    assert_err(&t("<float name=\"a\" value=\"1\"/>"), FILE, 4, &["<float>", "inside <transform>"]);
}

// ---------------------------------------------------------------- parameters

#[test]
fn defaults_and_defines() {
    let text = scene(
        r#"<default name="spp" value="16"/>
<default name="res" value="64"/>
<sampler type="$sampler_type">
    <integer name="sample_count" value="$spp"/>
    <integer name="width" value="$res$res"/>
    <string name="price" value="\$5"/>
</sampler>"#,
    );
    let desc = parse_with(&text, &[("sampler_type", "independent")]).unwrap();
    let s = first(&desc);
    assert_eq!(s.plugin, "independent");
    assert_eq!(*value(s, "sample_count"), Value::Integer(16));
    assert_eq!(*value(s, "width"), Value::Integer(6464));
    assert_eq!(*value(s, "price"), Value::String("$5".into()));
    // -D wins over <default>; unused defines are fine.
    let desc = parse_with(&text, &[("spp", "4"), ("sampler_type", "x"), ("unused", "1")]).unwrap();
    assert_eq!(*value(first(&desc), "sample_count"), Value::Integer(4));
    // Longest names are substituted first, as in Mitsuba.
    let desc = parse_with(&scene("<sampler type=\"$a$ab\"/>"), &[("a", "1"), ("ab", "2")]).unwrap();
    assert_eq!(first(&desc).plugin, "12");
    // A default can use earlier parameters.
    let desc =
        parse(&scene("<default name=\"a\" value=\"x\"/><default name=\"b\" value=\"$a-y\"/><film type=\"$b\"/>"))
            .unwrap();
    assert_eq!(first(&desc).plugin, "x-y");
}

#[test]
fn undefined_parameter() {
    let e = parse_with(
        &scene("<sampler type=\"independent\">\n  <integer name=\"sample_count\" value=\"$spp\"/>\n</sampler>"),
        &[("sp", "1x")],
    )
    .expect_err("undefined");
    // `$sp` matches the prefix of `$spp` (Mitsuba's plain substitution), so
    // the value becomes "1xp", which is not an integer.
    assert_err(&e, FILE, 3, &["1xp"]);
    let e =
        err(&scene("<sampler type=\"independent\">\n  <integer name=\"sample_count\" value=\"$spp\"/>\n</sampler>"));
    assert_err(&e, FILE, 3, &["$spp", "-D spp=", "<default name=\"spp\""]);
    let e = err(&scene("<film type=\"a$\"/>"));
    assert_err(&e, FILE, 2, &["stray '$'", "\\$"]);
    // A default only applies after it is declared.
    let e = err(&scene("<film type=\"$f\"/>\n<default name=\"f\" value=\"hdrfilm\"/>"));
    assert_err(&e, FILE, 2, &["$f"]);
}

// ---------------------------------------------------------------- references

#[test]
fn references_share_nodes() {
    let desc = parse(&scene(
        r#"<bsdf type="diffuse" id="white"/>
<shape type="sphere"><ref id="white"/></shape>
<shape type="cube">
    <ref name="bsdf" id="white"/>
</shape>"#,
    ))
    .unwrap();
    let root = &desc.root;
    let white = &root.children[0].node;
    let a = &root.children[1].node.children[0];
    let b = &root.children[2].node.children[0];
    assert!(Rc::ptr_eq(white, &a.node) && Rc::ptr_eq(white, &b.node));
    assert_eq!(a.name, None);
    assert_eq!(b.name.as_deref(), Some("bsdf"));
    assert_eq!((a.loc.line, b.loc.line), (3, 5));
    assert_eq!(white.id.as_deref(), Some("white"));
}

#[test]
fn forward_and_nested_references() {
    // Mitsuba resolves references after reading the whole file, so an id
    // declared later, or nested inside another object, can be referenced.
    let desc = parse(&scene(
        r#"<shape type="sphere"><ref id="later"/></shape>
<shape type="cube"><bsdf type="diffuse" id="later"><texture type="bitmap" id="tex"/></bsdf></shape>
<shape type="disk"><bsdf type="x"><ref name="reflectance" id="tex"/></bsdf></shape>"#,
    ))
    .unwrap();
    let root = &desc.root;
    assert!(Rc::ptr_eq(&root.children[0].node.children[0].node, &root.children[1].node.children[0].node));
    let tex = &root.children[1].node.children[0].node.children[0].node;
    assert!(Rc::ptr_eq(tex, &root.children[2].node.children[0].node.children[0].node));
}

#[test]
fn reference_errors() {
    let e = err(&scene("<bsdf type=\"diffuse\" id=\"white\"/>\n<shape type=\"s\">\n<ref id=\"whit\"/></shape>"));
    assert_err(&e, FILE, 4, &["\"whit\""]);
    let e = err(&scene("<bsdf type=\"diffuse\" id=\"white\"/>\n<shape type=\"s\" id=\"white\"/>"));
    assert_err(&e, FILE, 3, &["duplicate id \"white\"", &format!("{FILE}:2:1")]);
    let e = err(&scene("<bsdf type=\"a\" id=\"a\">\n<bsdf type=\"b\"><ref id=\"a\"/></bsdf></bsdf>"));
    assert_err(&e, FILE, 3, &["cycle"]);
    let e = err(&scene("<shape type=\"s\"><ref/></shape>"));
    assert_err(&e, FILE, 2, &["\"id\""]);
    let e = err(&scene("<shape type=\"s\"><ref id=\"x\" type=\"y\"/></shape>"));
    assert_err(&e, FILE, 2, &["\"type\""]);
}

#[test]
fn aliases() {
    let desc = parse(&scene(
        "<bsdf type=\"diffuse\" id=\"a\"/><alias id=\"a\" as=\"b\"/><shape type=\"s\"><ref id=\"b\"/></shape>",
    ))
    .unwrap();
    assert!(Rc::ptr_eq(&desc.root.children[0].node, &desc.root.children[1].node.children[0].node));
    let e = err(&scene("<alias id=\"nope\" as=\"b\"/>"));
    assert_err(&e, FILE, 2, &["nope"]);
}

// ---------------------------------------------------------------- includes and files

#[test]
fn includes_are_spliced_with_their_own_locations() {
    let dir = temp_dir("splice");
    std::fs::create_dir_all(dir.join("parts")).unwrap();
    std::fs::write(
        dir.join("parts/bsdfs.xml"),
        "<scene version=\"3.0.0\">\n<default name=\"refl\" value=\"0.5\"/>\n<bsdf type=\"diffuse\" id=\"grey\">\n  <rgb name=\"reflectance\" value=\"$refl\"/>\n</bsdf>\n<include filename=\"mesh.xml\"/>\n</scene>",
    )
    .unwrap();
    std::fs::write(
        dir.join("parts/mesh.xml"),
        "<shape type=\"obj\" version=\"3.0.0\">\n<string name=\"filename\" value=\"bunny.obj\"/>\n</shape>",
    )
    .unwrap();
    let main = dir.join("main.xml");
    std::fs::write(
        &main,
        "<scene version=\"3.0.0\">\n<include filename=\"parts/bsdfs.xml\"/>\n<shape type=\"sphere\"><ref id=\"grey\"/></shape>\n<film type=\"hdr$refl\"/>\n</scene>",
    )
    .unwrap();
    let desc = parse_file(&main, &[]).unwrap();
    let root = &desc.root;
    let kinds: Vec<Kind> = root.children.iter().map(|c| c.node.kind).collect();
    assert_eq!(kinds, [Kind::Bsdf, Kind::Shape, Kind::Shape, Kind::Film]);
    let bsdf = &root.children[0].node;
    assert_eq!(bsdf.loc.file.as_path(), dir.join("parts/bsdfs.xml"));
    assert_eq!(bsdf.loc.line, 3);
    assert_eq!(*value(bsdf, "reflectance"), Value::Rgb([0.5; 3]));
    // A file whose root is an object adds that object; its properties carry
    // its own path, against which the builder resolves file names.
    let mesh = &root.children[1];
    assert_eq!(mesh.node.plugin, "obj");
    assert_eq!(mesh.loc.file.as_path(), dir.join("parts/bsdfs.xml"));
    let filename = &mesh.node.props[0];
    assert_eq!(filename.loc.file.parent().unwrap(), dir.join("parts"));
    assert!(Rc::ptr_eq(bsdf, &root.children[2].node.children[0].node));
    assert_eq!(root.children[3].node.loc.file.as_path(), main);
    // Defaults from an include remain visible afterwards (one parameter set).
    assert_eq!(root.children[3].node.plugin, "hdr0.5");
}

#[test]
fn include_errors() {
    let dir = temp_dir("errors");
    std::fs::write(
        dir.join("bad.xml"),
        "<scene version=\"3.0.0\">\n<shape type=\"sphere\">\n\n<float name=\"radius\" value=\"x\"/>\n</shape>\n</scene>",
    )
    .unwrap();
    let main = dir.join("main.xml");
    std::fs::write(&main, "<scene version=\"3.0.0\">\n\n<include filename=\"bad.xml\"/>\n</scene>").unwrap();
    let e = parse_file(&main, &[]).unwrap_err();
    let bad = dir.join("bad.xml");
    assert_err(&e, bad.to_str().unwrap(), 4, &["radius", &format!("included at {}:3:", main.display())]);

    // Missing include: at the including line, naming the resolved path.
    std::fs::write(&main, "<scene version=\"3.0.0\">\n<include filename=\"sub/none.xml\"/>\n</scene>").unwrap();
    let e = parse_file(&main, &[]).unwrap_err();
    assert_err(&e, main.to_str().unwrap(), 2, &["not found", &dir.join("sub/none.xml").display().to_string()]);

    // Cycles.
    std::fs::write(dir.join("a.xml"), "<scene version=\"3.0.0\">\n<include filename=\"b.xml\"/>\n</scene>").unwrap();
    std::fs::write(dir.join("b.xml"), "<scene version=\"3.0.0\">\n\n<include filename=\"a.xml\"/>\n</scene>").unwrap();
    let e = parse_file(&dir.join("a.xml"), &[]).unwrap_err();
    assert_err(&e, dir.join("b.xml").to_str().unwrap(), 3, &["include cycle"]);
    std::fs::write(&main, "<scene version=\"3.0.0\">\n<include filename=\"main.xml\"/>\n</scene>").unwrap();
    let e = parse_file(&main, &[]).unwrap_err();
    assert_err(&e, main.to_str().unwrap(), 2, &["include cycle"]);

    // Duplicate ids across files.
    std::fs::write(dir.join("ids.xml"), "<scene version=\"3.0.0\">\n<bsdf type=\"x\" id=\"m\"/>\n</scene>").unwrap();
    std::fs::write(
        &main,
        "<scene version=\"3.0.0\">\n<bsdf type=\"x\" id=\"m\"/>\n<include filename=\"ids.xml\"/>\n</scene>",
    )
    .unwrap();
    let e = parse_file(&main, &[]).unwrap_err();
    assert_err(&e, dir.join("ids.xml").to_str().unwrap(), 2, &["duplicate id \"m\""]);

    // Included files are parsed as XML with their own positions.
    std::fs::write(dir.join("broken.xml"), "<scene version=\"3.0.0\">\n<shape>\n</scene>").unwrap();
    std::fs::write(&main, "<scene version=\"3.0.0\"><include filename=\"broken.xml\"/></scene>").unwrap();
    let e = parse_file(&main, &[]).unwrap_err();
    assert_err(&e, dir.join("broken.xml").to_str().unwrap(), 3, &["malformed XML"]);
}

#[test]
fn missing_scene_file() {
    let path = Path::new("/nonexistent/dir/scene.xml");
    let e = parse_file(path, &[]).unwrap_err();
    assert!(e.to_string().contains("/nonexistent/dir/scene.xml"), "{e}");
    assert!(e.to_string().contains("not found"), "{e}");
}

/// NaN and infinity, which Rust's float parser accepts, are refused in every
/// kind of number (floats, colours, vectors, transforms, spectra) with the
/// file and line.
#[test]
fn non_finite_numbers_are_errors_naming_file_and_line() {
    let bodies = [
        r#"<shape type="sphere"><float name="radius" value="nan"/></shape>"#,
        r#"<shape type="sphere"><float name="radius" value="inf"/></shape>"#,
        r#"<emitter type="constant"><rgb name="radiance" value="1, NaN, 1"/></emitter>"#,
        r#"<emitter type="point"><point name="position" x="0" y="-infinity" z="0"/></emitter>"#,
        r#"<shape type="sphere"><transform name="to_world"><translate x="inf"/></transform></shape>"#,
        r#"<shape type="sphere"><transform name="to_world"><matrix value="1 0 0 0 0 1 0 0 0 0 1 0 0 0 0 nan"/></transform></shape>"#,
        r#"<emitter type="constant"><spectrum name="radiance" value="400:1, 500:inf"/></emitter>"#,
    ];
    for body in bodies {
        let e = err(&scene(body));
        assert_err(&e, FILE, 2, &[]);
        let shown = e.to_string();
        assert!(shown.contains("finite") || shown.contains("spectrum"), "{body}: {shown}");
    }
    // Finite spellings still parse.
    parse(&scene(r#"<shape type="sphere"><float name="radius" value=" 1e-3 "/></shape>"#)).unwrap();
}

/// A scene file that is not UTF-8 (binary, or saved as Latin-1) is refused
/// at the position of its first bad byte.
#[test]
fn non_utf8_scene_names_the_first_bad_byte() {
    let dir = temp_dir("latin1");
    let path = dir.join("scene.xml");
    std::fs::write(&path, b"<scene version=\"3.0.0\">\n<!-- caf\xe9 -->\n</scene>\n").unwrap();
    let e = parse_file(&path, &[]).unwrap_err().to_string();
    assert!(e.contains("scene.xml") && e.contains("line 2, column 9 (byte 32)"), "{e}");
    std::fs::remove_dir_all(&dir).ok();
}

// ---------------------------------------------------------------- old versions

/// Names and values of every object's parameters, depth first, for
/// comparing two descriptions.
fn flatten(node: &Node, out: &mut Vec<String>) {
    out.push(format!("{} {}", node.kind.tag(), node.plugin));
    let mut props: Vec<String> = node.props.iter().map(|p| format!("  {} = {:?}", p.name, p.value)).collect();
    props.sort();
    out.extend(props);
    for c in &node.children {
        out.push(format!("  child {:?}", c.name));
        flatten(&c.node, out);
    }
}

/// A version 0.5.0 file reads as its Mitsuba 3 spelling (Mitsuba's
/// `upgrade_from_v1`): camelCase names to snake_case (runs of capitals
/// stay one word), diffuse's diffuseReflectance to reflectance, and the
/// texture offsets folded into to_uv = scale · translate.
#[test]
fn old_versions_are_upgraded_as_mitsuba_3_does() {
    let old = r#"<scene version="0.5.0">
<integrator type="path"><integer name="maxDepth" value="4"/><integer name="rrDepth" value="2"/></integrator>
<bsdf type="dielectric" id="glass"><float name="intIOR" value="1.5"/><string name="extIOR" value="air"/></bsdf>
<bsdf type="diffuse" id="d"><texture type="checkerboard" name="diffuseReflectance">
  <float name="uoffset" value="0.25"/><float name="uscale" value="4"/><integer name="vscale" value="2"/>
</texture></bsdf>
<shape type="sphere"><transform name="toWorld"><translate x="1"/></transform><ref name="bsdf" id="d"/></shape>
</scene>"#;
    let new = r#"<scene version="3.0.0">
<integrator type="path"><integer name="max_depth" value="4"/><integer name="rr_depth" value="2"/></integrator>
<bsdf type="dielectric" id="glass"><float name="int_ior" value="1.5"/><string name="ext_ior" value="air"/></bsdf>
<bsdf type="diffuse" id="d"><texture type="checkerboard" name="reflectance">
  <transform name="to_uv"><translate x="0.25"/><scale x="4" y="2"/></transform>
</texture></bsdf>
<shape type="sphere"><transform name="to_world"><translate x="1"/></transform><ref name="bsdf" id="d"/></shape>
</scene>"#;
    let (a, b) = (parse(old).unwrap(), parse(new).unwrap());
    let (mut fa, mut fb) = (Vec::new(), Vec::new());
    flatten(&a.root, &mut fa);
    flatten(&b.root, &mut fb);
    assert_eq!(fa, fb);
    assert!(b.upgraded.is_empty() && b.upgrade_notes().is_empty());
    let renames: Vec<(u32, &str, &str)> =
        a.upgraded[0].renames.iter().map(|r| (r.loc.line, r.from.as_str(), r.to.as_str())).collect();
    assert_eq!(
        renames,
        [
            (2, "maxDepth", "max_depth"),
            (2, "rrDepth", "rr_depth"),
            (3, "intIOR", "int_ior"),
            (3, "extIOR", "ext_ior"),
            (4, "diffuseReflectance", "reflectance"),
            (5, "uoffset", "to_uv"),
            (5, "uscale", "to_uv"),
            (5, "vscale", "to_uv"),
            (7, "toWorld", "to_world"),
        ]
    );
    let note = &a.upgrade_notes()[0];
    assert!(note.contains("0.5.0") && note.contains("maxDepth -> max_depth (line 2)"), "{note}");
    // diffuse_reflectance stays itself outside diffuse (e.g. plastic's).
    let p = parse(
        "<scene version=\"0.6.0\"><bsdf type=\"plastic\"><rgb name=\"diffuseReflectance\" value=\"0.5\"/></bsdf></scene>",
    )
    .unwrap();
    value(first(&p), "diffuse_reflectance");
}

/// Only files older than 2.0.0 are upgraded, each by its own version: a
/// 3.0.0 file included from a 0.5.0 one keeps its names (and camelCase
/// there is the error it always was); two spellings of one name collide.
#[test]
fn upgrades_follow_each_files_version() {
    let dir = temp_dir("upgrade_includes");
    std::fs::write(
        dir.join("new.xml"),
        "<scene version=\"3.0.0\">\n<integrator type=\"path\"><integer name=\"maxDepth\" value=\"3\"/></integrator>\n</scene>",
    )
    .unwrap();
    std::fs::write(
        dir.join("old.xml"),
        "<scene version=\"0.5.0\">\n<include filename=\"new.xml\"/>\n\
         <shape type=\"sphere\"><float name=\"radiusScale\" value=\"2\"/></shape>\n</scene>",
    )
    .unwrap();
    let desc = parse_file(&dir.join("old.xml"), &[]).unwrap();
    let integrator = desc.root.children_of(Kind::Integrator).next().unwrap();
    value(&integrator.node, "maxDepth");
    value(desc.root.children_of(Kind::Shape).next().unwrap().node.as_ref(), "radius_scale");
    let e = err("<scene version=\"0.5.0\">\n<shape type=\"sphere\"><transform name=\"toWorld\"/>\n<transform name=\"to_world\"/></shape></scene>");
    assert_err(&e, FILE, 3, &["to_world", "more than once"]);
    let e = err(
        "<scene version=\"0.5.0\">\n<texture type=\"bitmap\"><string name=\"uscale\" value=\"2\"/></texture></scene>",
    );
    assert_err(&e, FILE, 2, &["uscale", "number"]);
}

/// A parameter that Mitsuba 3 no longer has is an error at its line,
/// naming the old spelling; another error in an old file says what the
/// upgrade does.
#[test]
fn errors_in_upgraded_files_name_the_old_spelling() {
    let dir = temp_dir("upgrade_errors");
    let path = dir.join("old.xml");
    std::fs::write(
        &path,
        "<scene version=\"0.5.0\">\n<integrator type=\"path\">\n<boolean name=\"strictNormals\" value=\"true\"/>\n</integrator>\n<sensor type=\"perspective\"><film type=\"hdrfilm\"/></sensor>\n</scene>",
    )
    .unwrap();
    let file = path.to_str().unwrap();
    let e = penumbra_scene::load_scene(&path, &[], &Default::default()).map(|_| ()).unwrap_err();
    assert_err(&e, file, 3, &["strict_normals", "written \"strictNormals\"", "0.5.0"]);
    std::fs::write(
        &path,
        "<scene version=\"0.5.0\">\n<sensor type=\"perspective\"><film type=\"ldrfilm\"/></sensor>\n</scene>",
    )
    .unwrap();
    let e = penumbra_scene::load_scene(&path, &[], &Default::default()).map(|_| ()).unwrap_err();
    assert_err(&e, file, 2, &["ldrfilm", "scene version 0.5.0", "no longer has"]);
}
