//! pbrt-v4 scenes rendered through the translator against the same scenes
//! written as Mitsuba XML (independently seeded renders that must agree
//! within noise), the image's orientation, and bad input.

use crate::common;

use crate::common::{assert_agree, compare, injected_errors, render_with_variance};
use penumbra_scene::{load_scene, Overrides};
use std::fmt::Write;
use std::path::{Path, PathBuf};

fn temp_dir(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("penumbra-pbrt-{name}-{}", std::process::id()));
    std::fs::create_dir_all(&d).unwrap();
    d
}

/// Quads (four corners, counter-clockwise seen from the side they face).
type Quad = [[f32; 3]; 4];

/// The box: floor, ceiling, back wall, left (red) and right (green) walls.
const WHITE: &[Quad] = &[
    [[-1.0, 0.0, -1.0], [-1.0, 0.0, 1.0], [1.0, 0.0, 1.0], [1.0, 0.0, -1.0]],
    [[-1.0, 2.0, -1.0], [1.0, 2.0, -1.0], [1.0, 2.0, 1.0], [-1.0, 2.0, 1.0]],
    [[-1.0, 0.0, 1.0], [-1.0, 2.0, 1.0], [1.0, 2.0, 1.0], [1.0, 0.0, 1.0]],
];
const RED: Quad = [[-1.0, 0.0, -1.0], [-1.0, 2.0, -1.0], [-1.0, 2.0, 1.0], [-1.0, 0.0, 1.0]];
const GREEN: Quad = [[1.0, 0.0, -1.0], [1.0, 0.0, 1.0], [1.0, 2.0, 1.0], [1.0, 2.0, -1.0]];
/// The lamp, facing down.
const LAMP: Quad = [[-0.3, 1.98, -0.3], [0.3, 1.98, -0.3], [0.3, 1.98, 0.3], [-0.3, 1.98, 0.3]];

/// An ASCII PLY of quads (two triangles each).
fn ply(quads: &[Quad]) -> String {
    let mut s = format!(
        "ply\nformat ascii 1.0\nelement vertex {}\nproperty float x\nproperty float y\nproperty float z\n\
         element face {}\nproperty list uchar int vertex_indices\nend_header\n",
        4 * quads.len(),
        2 * quads.len()
    );
    for q in quads {
        for v in q {
            writeln!(s, "{} {} {}", v[0], v[1], v[2]).unwrap();
        }
    }
    for i in 0..quads.len() {
        let b = 4 * i;
        writeln!(s, "3 {} {} {}\n3 {} {} {}", b, b + 1, b + 2, b, b + 2, b + 3).unwrap();
    }
    s
}

/// A `trianglemesh` of quads.
fn trianglemesh(quads: &[Quad]) -> String {
    let p: Vec<String> = quads.iter().flatten().map(|v| format!("{} {} {}", v[0], v[1], v[2])).collect();
    let i: Vec<String> =
        (0..quads.len()).map(|q| format!("{0} {1} {2} {0} {2} {3}", 4 * q, 4 * q + 1, 4 * q + 2, 4 * q + 3)).collect();
    format!("Shape \"trianglemesh\" \"point3 P\" [{}] \"integer indices\" [{}]", p.join(" "), i.join(" "))
}

/// An octahedron of radius `r` at the origin (the PLY mesh and the instanced object).
fn octahedron(r: f32) -> String {
    let v = [[r, 0.0, 0.0], [-r, 0.0, 0.0], [0.0, r, 0.0], [0.0, -r, 0.0], [0.0, 0.0, r], [0.0, 0.0, -r]];
    let f = [[0, 2, 4], [2, 1, 4], [1, 3, 4], [3, 0, 4], [2, 0, 5], [1, 2, 5], [3, 1, 5], [0, 3, 5]];
    let mut s = String::from(
        "ply\nformat ascii 1.0\nelement vertex 6\nproperty float x\nproperty float y\nproperty float z\n\
         element face 8\nproperty list uchar int vertex_indices\nend_header\n",
    );
    for p in v {
        writeln!(s, "{} {} {}", p[0], p[1], p[2]).unwrap();
    }
    for t in f {
        writeln!(s, "3 {} {} {}", t[0], t[1], t[2]).unwrap();
    }
    s
}

const SIZE: u32 = 48;

/// The box as pbrt-v4 and as Mitsuba XML, in `dir`.
fn write_box(dir: &Path) -> (PathBuf, PathBuf) {
    std::fs::write(dir.join("white.ply"), ply(WHITE)).unwrap();
    std::fs::write(dir.join("red.ply"), ply(&[RED])).unwrap();
    std::fs::write(dir.join("green.ply"), ply(&[GREEN])).unwrap();
    std::fs::write(dir.join("lamp.ply"), ply(&[LAMP])).unwrap();
    std::fs::write(dir.join("octa.ply"), octahedron(0.25)).unwrap();
    let pbrt = format!(
        r#"# A Cornell-like box: diffuse walls, a conductor and a dielectric sphere,
# an area light, a point light, an instanced object and a PLY mesh.
LookAt 0 1 -3.2  0 1 0  0 1 0
Camera "perspective" "float fov" 45
Film "rgb" "integer xresolution" {SIZE} "integer yresolution" {SIZE}
Sampler "independent" "integer pixelsamples" 16
Integrator "path" "integer maxdepth" 5
WorldBegin
LightSource "point" "point3 from" [0.5 1.6 -0.8] "rgb I" [0.6 0.6 0.6]
MakeNamedMaterial "white" "string type" "diffuse" "rgb reflectance" [0.7 0.7 0.7]
NamedMaterial "white"
{white}
AttributeBegin
  Material "diffuse" "rgb reflectance" [0.7 0.1 0.1]
  {red}
AttributeEnd
AttributeBegin
  Material "diffuse" "rgb reflectance" [0.1 0.6 0.1]
  {green}
AttributeEnd
AttributeBegin
  AreaLightSource "diffuse" "rgb L" [8 8 8]
  Material "diffuse" "rgb reflectance" [0.5 0.5 0.5]
  {lamp}
AttributeEnd
AttributeBegin
  Material "conductor" "spectrum eta" "metal-Au-eta" "spectrum k" "metal-Au-k"
  Translate -0.45 0.35 0.3
  Shape "sphere" "float radius" 0.35
AttributeEnd
AttributeBegin
  Material "dielectric" "float eta" 1.5
  Translate 0.45 0.3 -0.2
  Shape "sphere" "float radius" 0.3
AttributeEnd
ObjectBegin "octa"
  Material "diffuse" "rgb reflectance" [0.2 0.3 0.7]
  Shape "plymesh" "string filename" "octa.ply"
ObjectEnd
AttributeBegin
  Translate 0.5 1.3 0.6
  ObjectInstance "octa"
AttributeEnd
AttributeBegin
  Translate -0.5 1.4 0.5
  Scale 0.8 0.8 0.8
  ObjectInstance "octa"
AttributeEnd
AttributeBegin
  Material "diffuse" "rgb reflectance" [0.8 0.7 0.2]
  Translate 0 0.25 0.5
  Shape "plymesh" "string filename" "octa.ply"
AttributeEnd
"#,
        white = trianglemesh(WHITE),
        red = trianglemesh(&[RED]),
        green = trianglemesh(&[GREEN]),
        lamp = trianglemesh(&[LAMP]),
    );
    let diffuse = |r: f32, g: f32, b: f32| {
        format!(
            r#"<bsdf type="twosided"><bsdf type="diffuse"><rgb name="reflectance" value="{r} {g} {b}"/></bsdf></bsdf>"#
        )
    };
    let ply_shape = |file: &str, bsdf: String, extra: &str| {
        format!(r#"<shape type="ply"><string name="filename" value="{file}"/>{bsdf}{extra}</shape>"#)
    };
    // Gold as the pbrt side converts pbrt-v4's metal-Au tables.
    let xml = format!(
        r#"<scene version="3.0.0">
<integrator type="path"><integer name="max_depth" value="6"/></integrator>
<sensor type="perspective">
  <float name="fov" value="45"/><string name="fov_axis" value="smaller"/>
  <transform name="to_world"><scale x="-1"/><lookat origin="0 1 -3.2" target="0 1 0" up="0 1 0"/></transform>
  <sampler type="independent"><integer name="sample_count" value="16"/></sampler>
  <film type="hdrfilm"><integer name="width" value="{SIZE}"/><integer name="height" value="{SIZE}"/></film>
</sensor>
<emitter type="point"><point name="position" value="0.5 1.6 -0.8"/><rgb name="intensity" value="0.6"/></emitter>
{white}
{red}
{green}
{lamp}
<shape type="sphere"><point name="center" value="-0.45 0.35 0.3"/><float name="radius" value="0.35"/>
  <bsdf type="twosided"><bsdf type="conductor">
    <rgb name="eta" value="0.07987072 0.40465155 1.558967"/><rgb name="k" value="3.386737 2.5007045 1.768913"/>
  </bsdf></bsdf></shape>
<shape type="sphere"><point name="center" value="0.45 0.3 -0.2"/><float name="radius" value="0.3"/>
  <bsdf type="dielectric"><float name="int_ior" value="1.5"/><float name="ext_ior" value="1"/></bsdf></shape>
<shape type="shapegroup" id="octa">{octa}</shape>
<shape type="instance"><ref id="octa"/><transform name="to_world"><translate x="0.5" y="1.3" z="0.6"/></transform></shape>
<shape type="instance"><ref id="octa"/><transform name="to_world"><scale value="0.8"/><translate x="-0.5" y="1.4" z="0.5"/></transform></shape>
{octa2}
</scene>"#,
        white = ply_shape("white.ply", diffuse(0.7, 0.7, 0.7), ""),
        red = ply_shape("red.ply", diffuse(0.7, 0.1, 0.1), ""),
        green = ply_shape("green.ply", diffuse(0.1, 0.6, 0.1), ""),
        lamp = ply_shape(
            "lamp.ply",
            diffuse(0.5, 0.5, 0.5),
            r#"<emitter type="area"><rgb name="radiance" value="8"/></emitter>"#
        ),
        octa = ply_shape("octa.ply", diffuse(0.2, 0.3, 0.7), ""),
        octa2 = ply_shape(
            "octa.ply",
            diffuse(0.8, 0.7, 0.2),
            r#"<transform name="to_world"><translate x="0" y="0.25" z="0.5"/></transform>"#
        ),
    );
    let (p, x) = (dir.join("box.pbrt"), dir.join("box.xml"));
    std::fs::write(&p, pbrt).unwrap();
    std::fs::write(&x, xml).unwrap();
    (p, x)
}

/// The box rendered from its pbrt-v4 file and from its XML twin: the same
/// image within noise; and the comparison catches the injected errors (a
/// wider lobe, a mirrored image, a brighter region).
#[test]
fn pbrt_box_matches_its_mitsuba_xml_twin() {
    let dir = temp_dir("box");
    let (pbrt, xml) = write_box(&dir);
    let a = render_with_variance(&pbrt, 512, 16, None, 1);
    let b = render_with_variance(&xml, 512, 16, None, 2);
    assert_agree("pbrt box vs XML", &a, &b, 0.02);
    for (what, bad) in injected_errors(&a) {
        let v = compare(&format!("injected {what}"), &bad, &b, 0.02);
        assert!(!v.failures.is_empty(), "the comparison misses an injected error: {what}");
    }
    if std::env::var_os("PENUMBRA_KEEP_PBRT_BOX").is_none() {
        std::fs::remove_dir_all(&dir).unwrap();
    } else {
        eprintln!("kept {}", dir.display());
    }
}

/// pbrt-v4's camera puts world +x at the right of the image when it looks
/// along +z with +y up (left-handed screen space): a red sphere at +x lands
/// in the image's right half.
#[test]
fn pbrt_image_is_not_mirrored() {
    let dir = temp_dir("orient");
    let scene = r#"LookAt 0 0 -4  0 0 0  0 1 0
Camera "perspective" "float fov" 50
Film "rgb" "integer xresolution" 32 "integer yresolution" 16
Sampler "independent" "integer pixelsamples" 4
WorldBegin
LightSource "infinite" "rgb L" [1 1 1]
Material "diffuse" "rgb reflectance" [0.9 0 0]
Translate 1.2 0.6 0
Shape "sphere" "float radius" 0.5
"#;
    let path = dir.join("o.pbrt");
    std::fs::write(&path, scene).unwrap();
    let mut job = load_scene(&path, &[], &Overrides::default()).unwrap();
    let mut film = penumbra_render::film::Film::new(job.width, job.height);
    job.stream = false;
    job.render_into(&mut film, 0..4, &|_| {});
    let img = film.develop();
    // Red minus green per quadrant: the sphere (red, green 0) against the white sky.
    let redness = |x0: u32, x1: u32, y0: u32, y1: u32| {
        let mut s = 0.0;
        for y in y0..y1 {
            for x in x0..x1 {
                let p = img[(y * 32 + x) as usize];
                s += (p[0] - p[1]) as f64;
            }
        }
        s
    };
    let (top_right, top_left) = (redness(16, 32, 0, 8), redness(0, 16, 0, 8));
    let bottom = redness(0, 32, 8, 16);
    assert!(top_right > 10.0 * (top_left.abs() + bottom.abs() + 1e-3), "{top_right} {top_left} {bottom}");
    std::fs::remove_dir_all(&dir).unwrap();
}

/// Bad input: an error naming the file, line and column, never a panic.
#[test]
fn bad_pbrt_input_is_an_error_at_its_position() {
    let dir = temp_dir("bad");
    let head = "Film \"rgb\" \"integer xresolution\" 8 \"integer yresolution\" 8\nWorldBegin\n";
    let cases = [
        ("Shape \"curve\" \"point3 P\" [0 0 0]", "b.pbrt:3:1", "shape \"curve\" is not supported"),
        ("Material \"hair\"\nShape \"sphere\"", "b.pbrt:3:1", "material \"hair\" is not supported"),
        ("Shape \"sphere\" \"float zmax\" 0.5", "b.pbrt:3:1", "partial shape"),
        ("Shape \"sphere\" \"float radiu\" 1", "b.pbrt:3:", "\"float radiu\""),
        ("Material \"conductor\" \"spectrum eta\" \"metal-Zz-eta\"\nShape \"sphere\"", "b.pbrt:3:", "metal-Cu-eta"),
        ("LightSource \"laser\"", "b.pbrt:3:1", "light \"laser\" is not supported"),
        ("LightSource \"goniometric\"", "b.pbrt:3:1", "\"filename\" is required"),
        ("LightSource \"projection\" \"string filename\" \"missing.exr\"", "b.pbrt:3:1", "projection light image"),
        (
            "AreaLightSource \"diffuse\"\nShape \"sphere\" \"float alpha\" 0.5",
            "b.pbrt:4:1",
            "\"alpha\" on an area light",
        ),
        (
            "MakeNamedMedium \"fog\" \"string type\" \"homogeneous\" \"string preset\" \"Wholemilk\"\n",
            "b.pbrt:3:1",
            "\"preset\" \"Wholemilk\"",
        ),
        (
            "MakeNamedMedium \"fog\" \"string type\" \"homogeneous\" \"float g\" 1\n",
            "b.pbrt:3:1",
            "\"g\" 1 must lie in (-1, 1)",
        ),
        ("LightSource \"spot\" \"float conedeltaangle\" 40", "b.pbrt:3:1", "conedeltaangle"),
        ("AreaLightSource \"diffuse\" \"string filename\" \"e.exr\"\nShape \"sphere\"", "b.pbrt:3:1", "\"filename\""),
        ("NamedMaterial \"nope\"\nShape \"sphere\"", "b.pbrt:3:15", "no material named \"nope\""),
        (
            "Material \"diffuse\" \"texture reflectance\" \"t\"\nShape \"sphere\"",
            "b.pbrt:3:",
            "no spectrum texture named \"t\"",
        ),
        ("Shape \"plymesh\" \"string filename\" \"missing.ply\"", "b.pbrt:3:1", "cannot read PLY file"),
        (
            "Shape \"trianglemesh\" \"point3 P\" [0 0 0 1 0 0 0 1 0] \"integer indices\" [0 1 5]",
            "b.pbrt:3:1",
            "out of range",
        ),
        ("Material \"diffuse\" \"rgb reflectance\" [2 0 0]\nShape \"sphere\"", "b.pbrt:3:", "above 1"),
        ("LightSource \"infinite\" \"string filename\" \"sky.png\"", "b.pbrt:3:1", "infinite light image"),
    ];
    for (body, at, what) in cases {
        let path = dir.join("b.pbrt");
        std::fs::write(&path, format!("{head}{body}\n")).unwrap();
        let e = match load_scene(&path, &[], &Overrides::default()) {
            Ok(_) => panic!("accepted: {body}"),
            Err(e) => e.to_string(),
        };
        assert!(e.contains(at) && e.contains(what), "{body:?}: {e}");
    }
    // Options the translator refuses before the world block.
    for (pre, at, what) in [
        ("Integrator \"ambientocclusion\"\n", "b.pbrt:1:1", "Integrator \"ambientocclusion\" is not supported"),
        ("Integrator \"bdpt\" \"integer maxdepth\" -1\n", "b.pbrt:1:", "maxdepth must not be negative"),
        ("Integrator \"path\" \"bool regularize\" true\n", "b.pbrt:1:1", "regularize"),
        ("PixelFilter \"sinc\"\n", "b.pbrt:1:1", "PixelFilter \"sinc\""),
        ("Camera \"realistic\"\n", "b.pbrt:1:1", "Camera \"realistic\""),
        ("Sampler \"lowdiscrepancy\"\n", "b.pbrt:1:1", "Sampler \"lowdiscrepancy\" is not supported"),
    ] {
        let path = dir.join("b.pbrt");
        std::fs::write(&path, format!("{pre}{head}Shape \"sphere\"\n")).unwrap();
        let e = load_scene(&path, &[], &Overrides::default()).map(|_| ()).unwrap_err().to_string();
        assert!(e.contains(at) && e.contains(what), "{pre:?}: {e}");
    }
    std::fs::remove_dir_all(&dir).unwrap();
}

/// pbrt-v4's other unbiased (or consistent) integrators render as `path`
/// with the same maxdepth, with a note naming the parameters set aside.
#[test]
fn pbrt_bdpt_and_sppm_render_as_path() {
    let dir = temp_dir("pbrt-integrators");
    let body = "WorldBegin\nLightSource \"infinite\" \"rgb L\" [1 1 1]\nShape \"sphere\"\n";
    let load = |integrator: &str| {
        let path = dir.join("i.pbrt");
        std::fs::write(&path, format!("LookAt 0 0 5 0 0 0 0 1 0\nCamera \"perspective\"\n{integrator}{body}")).unwrap();
        let s = penumbra_scene::pbrt::parse_file(&path).unwrap();
        penumbra_scene::pbrt::translate::translate(&s, &path, &Overrides::default()).unwrap()
    };
    let (path_job, _) = load("Integrator \"path\" \"integer maxdepth\" 7\n");
    for other in ["bdpt", "sppm", "mlt"] {
        let (job, notes) =
            load(&format!("Integrator \"{other}\" \"integer maxdepth\" 7 \"bool visualizestrategies\" false\n"));
        assert_eq!(format!("{:?}", job.integrator), format!("{:?}", path_job.integrator), "{other}");
        let note = notes.iter().find(|n| n.contains(other)).unwrap_or_else(|| panic!("{other}: {notes:?}"));
        assert!(note.contains("path tracing") && note.contains("bool visualizestrategies"), "{note}");
    }
    std::fs::remove_dir_all(&dir).unwrap();
}

/// A scene of the other features, as pbrt-v4 and as Mitsuba XML: a
/// non-square image (pbrt's fov spans the shorter axis), a checkerboard and
/// an image texture (pbrt looks images up at (s, 1 - t)), rough conductor
/// and dielectric (α = √roughness, GGX), a mix of two materials, a
/// bilinear patch with constant alpha, a cylinder, a disk area light, a
/// mirrored area light (pbrt-v4's handedness rule), a distant light and a uniform infinite light.
fn write_features(dir: &Path) -> (PathBuf, PathBuf) {
    // An asymmetric 4x3 image, so that a flipped lookup shows.
    let pixels =
        (0..12).map(|i| [(i % 4) as f32 / 3.0, (i / 4) as f32 / 2.0, if i == 0 { 1.0 } else { 0.1 }]).collect();
    let img = penumbra_scene::image_io::RgbImage { width: 4, height: 3, pixels };
    penumbra_scene::image_io::write_image(&dir.join("tex.png"), &img).unwrap();
    // The floor (with uv) and the textured back wall, as PLY for the XML side.
    let floor_ply = "ply\nformat ascii 1.0\nelement vertex 4\nproperty float x\nproperty float y\nproperty float z\n\
        property float u\nproperty float v\nelement face 2\nproperty list uchar int vertex_indices\nend_header\n\
        -2 0 -2 0 0\n-2 0 2 0 1\n2 0 2 1 1\n2 0 -2 1 0\n3 0 1 2\n3 0 2 3\n";
    let wall_ply = "ply\nformat ascii 1.0\nelement vertex 4\nproperty float x\nproperty float y\nproperty float z\n\
        property float u\nproperty float v\nelement face 2\nproperty list uchar int vertex_indices\nend_header\n\
        -1.5 0 1.5 1 0\n-1.5 2 1.5 1 1\n1.5 2 1.5 0 1\n1.5 0 1.5 0 0\n3 0 1 2\n3 0 2 3\n";
    let quad_ply = "ply\nformat ascii 1.0\nelement vertex 4\nproperty float x\nproperty float y\nproperty float z\n\
        element face 2\nproperty list uchar int vertex_indices\nend_header\n\
        -0.3 0.1 -0.6\n0.3 0.1 -0.6\n0.3 0.7 -0.6\n-0.3 0.7 -0.6\n3 0 1 2\n3 0 2 3\n";
    // Facing up (+y); ReverseOrientation (XML: flip_normals) turns it down.
    let lamp_ply = "ply\nformat ascii 1.0\nelement vertex 4\nproperty float x\nproperty float y\nproperty float z\n\
        element face 2\nproperty list uchar int vertex_indices\nend_header\n\
        0.6 1.9 -0.2\n0.6 1.9 0.2\n1.0 1.9 0.2\n1.0 1.9 -0.2\n3 0 1 2\n3 0 2 3\n";
    for (n, s) in [("floor.ply", floor_ply), ("wall.ply", wall_ply), ("quad.ply", quad_ply), ("lamp.ply", lamp_ply)] {
        std::fs::write(dir.join(n), s).unwrap();
    }
    let pbrt = r#"LookAt 0 1.1 -3.5  0 0.8 0  0 1 0
Camera "perspective" "float fov" 40
Film "rgb" "integer xresolution" 56 "integer yresolution" 40
Sampler "independent" "integer pixelsamples" 16
Integrator "path" "integer maxdepth" 4
WorldBegin
LightSource "distant" "point3 from" [1 3 -2] "point3 to" [0 0 0] "rgb L" [0.8 0.7 0.6]
LightSource "infinite" "rgb L" [0.15 0.2 0.3]
Texture "checks" "spectrum" "checkerboard" "float uscale" 4 "float vscale" 4
  "rgb tex1" [0.8 0.8 0.8] "rgb tex2" [0.2 0.3 0.2]
Texture "img" "spectrum" "imagemap" "string filename" "tex.png"
Material "diffuse" "texture reflectance" "checks"
Shape "trianglemesh" "point3 P" [-2 0 -2  -2 0 2  2 0 2  2 0 -2] "integer indices" [0 1 2 0 2 3]
  "point2 uv" [0 0  0 1  1 1  1 0]
Material "diffuse" "texture reflectance" "img"
Shape "trianglemesh" "point3 P" [-1.5 0 1.5  -1.5 2 1.5  1.5 2 1.5  1.5 0 1.5] "integer indices" [0 1 2 0 2 3]
  "point2 uv" [1 0  1 1  0 1  0 0]
AttributeBegin
  Material "conductor" "rgb eta" [0.2 0.9 1.1] "rgb k" [3.9 2.4 2.2] "float roughness" 0.1
  Translate -0.8 0.4 0.4
  Shape "sphere" "float radius" 0.4
AttributeEnd
AttributeBegin
  Material "dielectric" "float eta" 1.4 "float roughness" 0.05
  Translate 0.2 0.35 -0.1
  Shape "sphere" "float radius" 0.35
AttributeEnd
MakeNamedMaterial "a" "string type" "diffuse" "rgb reflectance" [0.9 0.2 0.1]
MakeNamedMaterial "b" "string type" "diffuse" "rgb reflectance" [0.1 0.3 0.9]
MakeNamedMaterial "ab" "string type" "mix" "string materials" ["a" "b"] "float amount" 0.3
AttributeBegin
  NamedMaterial "ab"
  Translate 0.9 0 0.6
  Rotate -90 1 0 0
  Shape "cylinder" "float radius" 0.25 "float zmin" 0 "float zmax" 0.8
AttributeEnd
AttributeBegin
  Material "diffuse" "rgb reflectance" [0.3 0.8 0.3]
  Shape "bilinearmesh" "point3 P" [-0.3 0.1 -0.6  0.3 0.1 -0.6  -0.3 0.7 -0.6  0.3 0.7 -0.6]
    "integer indices" [0 1 2 3] "float alpha" 0.5
AttributeEnd
AttributeBegin
  AreaLightSource "diffuse" "rgb L" [6 5 4]
  Material "diffuse" "rgb reflectance" [0 0 0]
  Translate -0.5 1.9 0
  Rotate 90 1 0 0
  Shape "disk" "float radius" 0.25
AttributeEnd
AttributeBegin
  AreaLightSource "diffuse" "rgb L" [3 4 6]
  Material "diffuse" "rgb reflectance" [0 0 0]
  # Mirrored, the world-space winding faces up; pbrt-v4 reverses the
  # orientation of a shape whose transform swaps handedness: it emits down.
  Scale -1 1 1
  Shape "trianglemesh" "point3 P" [-0.6 1.9 -0.2  -0.6 1.9 0.2  -1.0 1.9 0.2  -1.0 1.9 -0.2] "integer indices" [0 1 2 0 2 3]
AttributeEnd
"#;
    let ts = |bsdf: &str| format!(r#"<bsdf type="twosided">{bsdf}</bsdf>"#);
    let xml = format!(
        r#"<scene version="3.0.0">
<integrator type="path"><integer name="max_depth" value="5"/></integrator>
<sensor type="perspective">
  <float name="fov" value="40"/><string name="fov_axis" value="smaller"/>
  <transform name="to_world"><scale x="-1"/><lookat origin="0 1.1 -3.5" target="0 0.8 0" up="0 1 0"/></transform>
  <sampler type="independent"><integer name="sample_count" value="16"/></sampler>
  <film type="hdrfilm"><integer name="width" value="56"/><integer name="height" value="40"/></film>
</sensor>
<emitter type="directional"><vector name="direction" value="-1 -3 2"/><rgb name="irradiance" value="0.8 0.7 0.6"/></emitter>
<emitter type="constant"><rgb name="radiance" value="0.15 0.2 0.3"/></emitter>
<shape type="ply"><string name="filename" value="floor.ply"/>{floor}</shape>
<shape type="ply"><string name="filename" value="wall.ply"/>{wall}</shape>
<shape type="sphere"><point name="center" value="-0.8 0.4 0.4"/><float name="radius" value="0.4"/>
  {conductor}</shape>
<shape type="sphere"><point name="center" value="0.2 0.35 -0.1"/><float name="radius" value="0.35"/>
  <bsdf type="roughdielectric"><string name="distribution" value="ggx"/><float name="alpha" value="0.2236068"/>
    <float name="int_ior" value="1.4"/><float name="ext_ior" value="1"/></bsdf></shape>
<shape type="cylinder"><point name="p0" value="0 0 0"/><point name="p1" value="0 0 0.8"/><float name="radius" value="0.25"/>
  <transform name="to_world"><rotate x="1" angle="-90"/><translate x="0.9" y="0" z="0.6"/></transform>
  {mix}</shape>
<shape type="ply"><string name="filename" value="quad.ply"/>
  <bsdf type="mask"><float name="opacity" value="0.5"/>{green}</bsdf></shape>
<shape type="disk"><transform name="to_world"><scale x="0.25" y="0.25"/><rotate x="1" angle="90"/><translate x="-0.5" y="1.9" z="0"/></transform>
  {black}<emitter type="area"><rgb name="radiance" value="6 5 4"/></emitter></shape>
<shape type="ply"><string name="filename" value="lamp.ply"/><boolean name="flip_normals" value="true"/>
  {black}<emitter type="area"><rgb name="radiance" value="3 4 6"/></emitter></shape>
</scene>"#,
        floor = ts(r#"<bsdf type="diffuse"><texture type="checkerboard" name="reflectance">
            <rgb name="color0" value="0.8"/><rgb name="color1" value="0.2 0.3 0.2"/>
            <transform name="to_uv"><scale x="2" y="2"/></transform></texture></bsdf>"#),
        // pbrt looks the image up at (u, 1 - v).
        wall = ts(r#"<bsdf type="diffuse"><texture type="bitmap" name="reflectance">
            <string name="filename" value="tex.png"/>
            <transform name="to_uv"><scale y="-1"/><translate y="1"/></transform></texture></bsdf>"#),
        conductor = ts(r#"<bsdf type="roughconductor"><string name="distribution" value="ggx"/>
            <float name="alpha" value="0.31622777"/><rgb name="eta" value="0.2 0.9 1.1"/><rgb name="k" value="3.9 2.4 2.2"/></bsdf>"#),
        mix = ts(r#"<bsdf type="blendbsdf"><float name="weight" value="0.3"/>
            <bsdf type="diffuse"><rgb name="reflectance" value="0.9 0.2 0.1"/></bsdf>
            <bsdf type="diffuse"><rgb name="reflectance" value="0.1 0.3 0.9"/></bsdf></bsdf>"#),
        green = ts(r#"<bsdf type="diffuse"><rgb name="reflectance" value="0.3 0.8 0.3"/></bsdf>"#),
        black = ts(r#"<bsdf type="diffuse"><rgb name="reflectance" value="0"/></bsdf>"#),
    );
    let (p, x) = (dir.join("features.pbrt"), dir.join("features.xml"));
    std::fs::write(&p, pbrt).unwrap();
    std::fs::write(&x, xml).unwrap();
    (p, x)
}

#[test]
fn pbrt_features_match_their_mitsuba_xml_twin() {
    let dir = temp_dir("features");
    let (pbrt, xml) = write_features(&dir);
    let a = render_with_variance(&pbrt, 512, 32, None, 3);
    let b = render_with_variance(&xml, 512, 32, None, 4);
    assert_agree("pbrt features vs XML", &a, &b, 0.02);
    for (what, bad) in injected_errors(&a) {
        let v = compare(&format!("injected {what}"), &bad, &b, 0.02);
        assert!(!v.failures.is_empty(), "the comparison misses an injected error: {what}");
    }
    if std::env::var_os("PENUMBRA_KEEP_PBRT_BOX").is_none() {
        std::fs::remove_dir_all(&dir).unwrap();
    } else {
        eprintln!("kept {}", dir.display());
    }
}

/// pbrt-v4's spot light: placed at `from`, aimed at `to`, pbrt's
/// smoothstep falloff, `power` as pbrt-v4 normalises it.
#[test]
fn pbrt_spot_light_is_pbrts() {
    use penumbra_render::light::Light;
    let dir = temp_dir("spot");
    let path = dir.join("s.pbrt");
    std::fs::write(
        &path,
        "Film \"rgb\" \"integer xresolution\" 4 \"integer yresolution\" 4\nWorldBegin\n\
         LightSource \"spot\" \"point3 from\" [0 2 0] \"point3 to\" [0 0 0] \"float coneangle\" 30 \
         \"float conedeltaangle\" 10 \"rgb I\" [1 1 1] \"float power\" 100\nShape \"sphere\"\n",
    )
    .unwrap();
    let job = load_scene(&path, &[], &Overrides::default()).unwrap();
    let Light::Spot(s) = &job.scene.lights[0] else { panic!("not a spot light") };
    assert!((s.position - glam::Vec3::new(0.0, 2.0, 0.0)).length() < 1e-6);
    // Flux as asked for: pbrt-v4's k_e is the smoothstep falloff's exact flux.
    assert!((s.power().y - 100.0).abs() < 0.2, "{}", s.power());
    // Straight down: full intensity; 25 degrees off the axis: the smoothstep's middle.
    let below = s.sample_li(glam::Vec3::new(0.0, 1.0, 0.0)).unwrap();
    let side = 25f32.to_radians().tan();
    let off = s.sample_li(glam::Vec3::new(side, 1.0, 0.0)).unwrap();
    let ratio = off.li.y * (1.0 + side * side) / below.li.y;
    let (a, b) = (30f32.to_radians().cos(), 20f32.to_radians().cos());
    let t = (25f32.to_radians().cos() - a) / (b - a);
    assert!((ratio - t * t * (3.0 - 2.0 * t)).abs() < 1e-4, "{ratio}");
    std::fs::remove_dir_all(&dir).unwrap();
}

/// The box seen by an orthographic camera through a crop window, and by a
/// thin lens, against the same cameras in XML.
#[test]
fn pbrt_cameras_match_their_mitsuba_xml_twins() {
    let dir = temp_dir("cameras");
    let (pbrt, xml) = write_box(&dir);
    let (p, x) = (std::fs::read_to_string(&pbrt).unwrap(), std::fs::read_to_string(&xml).unwrap());
    let pbrt_cam = "Camera \"perspective\" \"float fov\" 45";
    let xml_cam = r#"<sensor type="perspective">
  <float name="fov" value="45"/><string name="fov_axis" value="smaller"/>"#;
    let film = format!(
        r#"<film type="hdrfilm"><integer name="width" value="{SIZE}"/><integer name="height" value="{SIZE}"/></film>"#
    );
    let cases = [
        (
            "orthographic, cropped",
            "Camera \"orthographic\"\nFilm \"rgb\" \"float cropwindow\" [0.25 0.75 0 0.5]",
            r#"<sensor type="orthographic">"#.to_string(),
            format!(
                r#"<film type="hdrfilm"><integer name="width" value="{SIZE}"/><integer name="height" value="{SIZE}"/>
                <integer name="crop_offset_x" value="12"/><integer name="crop_width" value="24"/>
                <integer name="crop_offset_y" value="0"/><integer name="crop_height" value="24"/></film>"#
            ),
        ),
        (
            "thin lens",
            "Camera \"perspective\" \"float fov\" 45 \"float lensradius\" 0.1 \"float focaldistance\" 2.5",
            r#"<sensor type="thinlens"><float name="aperture_radius" value="0.1"/><float name="focus_distance" value="2.5"/>
  <float name="fov" value="45"/><string name="fov_axis" value="smaller"/>"#
                .to_string(),
            film.clone(),
        ),
    ];
    for (i, (name, pc, xc, xf)) in cases.into_iter().enumerate() {
        // The first Film line of the box is replaced where the case sets its own.
        let mut pp = p.replace(pbrt_cam, pc);
        if pc.contains("Film") {
            pp = pp.replacen(
                &format!("Film \"rgb\" \"integer xresolution\" {SIZE} \"integer yresolution\" {SIZE}\n"),
                "",
                1,
            );
            pp = pp.replace(
                "Film \"rgb\" \"float cropwindow\"",
                &format!(
                    "Film \"rgb\" \"integer xresolution\" {SIZE} \"integer yresolution\" {SIZE} \"float cropwindow\""
                ),
            );
        }
        let xx = x.replace(xml_cam, &xc).replace(&film, &xf);
        assert!(pp != p && xx != x, "{name}: the cameras were not replaced");
        let (pf, xf) = (dir.join(format!("c{i}.pbrt")), dir.join(format!("c{i}.xml")));
        std::fs::write(&pf, pp).unwrap();
        std::fs::write(&xf, xx).unwrap();
        let a = render_with_variance(&pf, 256, 16, None, 10 + 2 * i as u64);
        let b = render_with_variance(&xf, 256, 16, None, 11 + 2 * i as u64);
        assert_agree(&format!("pbrt {name} vs XML"), &a, &b, 0.03);
    }
    std::fs::remove_dir_all(&dir).unwrap();
}

/// An `infinite` light from a uniform equal-area image renders as the
/// uniform `L` of the same colour (pbrt-v4 normalises both the same way).
#[test]
fn pbrt_image_infinite_light_matches_uniform_l() {
    let dir = temp_dir("env");
    let img = penumbra_scene::image_io::RgbImage { width: 8, height: 8, pixels: vec![[0.5, 0.6, 0.7]; 64] };
    penumbra_scene::image_io::write_image(&dir.join("sky.exr"), &img).unwrap();
    let scene = |light: &str| {
        format!(
            "LookAt 0 0 -4  0 0 0  0 1 0\nCamera \"perspective\" \"float fov\" 40\n\
             Film \"rgb\" \"integer xresolution\" 24 \"integer yresolution\" 24\n\
             Sampler \"independent\" \"integer pixelsamples\" 16\nWorldBegin\n{light}\n\
             AttributeBegin\nRotate -90 1 0 0\n{light}\nAttributeEnd\n\
             Material \"diffuse\" \"rgb reflectance\" [0.8 0.8 0.8]\nShape \"sphere\"\n"
        )
    };
    let (a, b) = (dir.join("img.pbrt"), dir.join("uni.pbrt"));
    std::fs::write(&a, scene("LightSource \"infinite\" \"string filename\" \"sky.exr\" \"float scale\" 0.5")).unwrap();
    std::fs::write(&b, scene("LightSource \"infinite\" \"rgb L\" [0.5 0.6 0.7] \"float scale\" 0.5")).unwrap();
    let ea = render_with_variance(&a, 2048, 32, None, 20);
    let eb = render_with_variance(&b, 2048, 32, None, 21);
    assert_agree("equal-area image vs uniform L", &ea, &eb, 0.02);
    std::fs::remove_dir_all(&dir).unwrap();
}

/// The shapes and materials without an XML twin load as pbrt-v4 defines
/// them: Loop subdivision's triangle count, bilinear patches as two
/// triangles each, a gzipped PLY, thindielectric, diffusetransmission.
#[test]
fn pbrt_other_kinds_load() {
    use penumbra_render::geometry::Shape;
    use penumbra_render::material::Material;
    use std::io::Write as _;
    let dir = temp_dir("kinds");
    let mut z = flate2::write::GzEncoder::new(Vec::new(), flate2::Compression::default());
    z.write_all(octahedron(0.5).as_bytes()).unwrap();
    std::fs::write(dir.join("o.ply.gz"), z.finish().unwrap()).unwrap();
    let path = dir.join("k.pbrt");
    std::fs::write(
        &path,
        "Film \"gbuffer\" \"integer xresolution\" 4 \"integer yresolution\" 4\nWorldBegin\n\
         Material \"thindielectric\" \"float eta\" 1.3\n\
         Shape \"loopsubdiv\" \"integer levels\" 2 \"point3 P\" [0 0 0 1 0 0 0 1 0 0 0 1] \
         \"integer indices\" [0 2 1 0 1 3 0 3 2 1 2 3]\n\
         Material \"diffusetransmission\" \"rgb transmittance\" [0.5 0.5 0.5]\n\
         Shape \"bilinearmesh\" \"point3 P\" [0 0 2 1 0 2 0 1 2 1 1 2  2 0 2 3 0 2 2 1 2 3 1 2] \
         \"integer indices\" [0 1 2 3 4 5 6 7]\n\
         Shape \"plymesh\" \"string filename\" \"o.ply.gz\"\n",
    )
    .unwrap();
    let job = load_scene(&path, &[], &Overrides::default()).unwrap();
    let tris: Vec<usize> = job
        .scene
        .shapes
        .iter()
        .map(|s| match s {
            Shape::Mesh(m) => m.mesh.indices.len(),
            _ => 0,
        })
        .collect();
    // Each level quadruples the 4 triangles.
    assert_eq!(tris, vec![64, 4, 8]);
    assert!(matches!(job.scene.materials[0], Material::ThinDielectric(_)));
    assert!(matches!(job.scene.materials[1], Material::DiffuseTransmission(_)));
    std::fs::remove_dir_all(&dir).unwrap();
}

/// A `twosided` area light renders as two one-sided lights back to back
/// (a gap of 10⁻⁴ between them): light on both sides of it, none lost.
#[test]
fn pbrt_two_sided_area_light_is_two_back_to_back() {
    let dir = temp_dir("twosided");
    let scene = |light: &str| {
        format!(
            "LookAt 0 1.5 -3  0 0.6 0  0 1 0\nCamera \"perspective\" \"float fov\" 50\n\
             Film \"rgb\" \"integer xresolution\" 32 \"integer yresolution\" 24\n\
             Sampler \"independent\" \"integer pixelsamples\" 16\nPixelFilter \"box\"\nWorldBegin\n\
             Material \"diffuse\" \"rgb reflectance\" [0.6 0.6 0.6]\n\
             Shape \"trianglemesh\" \"point3 P\" [-2 0 -2  -2 0 2  2 0 2  2 0 -2] \"integer indices\" [0 1 2 0 2 3]\n\
             Material \"diffuse\" \"rgb reflectance\" [0.2 0.2 0.2]\n{light}\n"
        )
    };
    // A vertical quad in the plane x = c, its front towards +x (or -x when reversed).
    let quad = |c: f32| {
        format!(
            "Shape \"trianglemesh\" \"point3 P\" [{c} 0.3 -0.4  {c} 1.1 -0.4  {c} 1.1 0.4  {c} 0.3 0.4] \
             \"integer indices\" [0 1 2 0 2 3]"
        )
    };
    let two = format!("AreaLightSource \"diffuse\" \"rgb L\" [3 3 3] \"bool twosided\" true\n{}", quad(0.0));
    let pair = format!(
        "AttributeBegin\nAreaLightSource \"diffuse\" \"rgb L\" [3 3 3]\n{}\nAttributeEnd\n\
         AttributeBegin\nAreaLightSource \"diffuse\" \"rgb L\" [3 3 3]\nReverseOrientation\n{}\nAttributeEnd",
        quad(0.00005),
        quad(-0.00005)
    );
    let (a, b) = (dir.join("two.pbrt"), dir.join("pair.pbrt"));
    std::fs::write(&a, scene(&two)).unwrap();
    std::fs::write(&b, scene(&pair)).unwrap();
    let ea = render_with_variance(&a, 4096, 32, None, 30);
    let eb = render_with_variance(&b, 4096, 32, None, 31);
    assert_agree("two-sided vs back to back", &ea, &eb, 0.02);
    // The particle tracer emits from both sides too (a box filter: a
    // particle tracer's splats near the border are not normalised by the
    // filter's weights, as in Mitsuba).
    let ep = common::render_with_variance(&a, 4096, 32, Some("ptracer"), 32);
    assert_agree("two-sided: ptracer vs path", &ep, &ea, 0.02);
    std::fs::remove_dir_all(&dir).unwrap();
}

/// An image on a sphere: pbrt-v4's (u, v) (v from the -z pole to the +z
/// pole, the image's top row at +z), against Mitsuba's sphere, whose v runs
/// the other way and whose bitmap puts its top row at v = 0: the same image.
#[test]
fn pbrt_textured_sphere_matches_xml() {
    let dir = temp_dir("sphere");
    let pixels =
        (0..12).map(|i| [(i % 4) as f32 / 3.0, (i / 4) as f32 / 2.0, if i == 0 { 1.0 } else { 0.1 }]).collect();
    let img = penumbra_scene::image_io::RgbImage { width: 4, height: 3, pixels };
    penumbra_scene::image_io::write_image(&dir.join("tex.png"), &img).unwrap();
    let pbrt = "LookAt 0 0 -4  0 0 0  0 1 0\nCamera \"perspective\" \"float fov\" 40\n\
        Film \"rgb\" \"integer xresolution\" 32 \"integer yresolution\" 32\n\
        Sampler \"independent\" \"integer pixelsamples\" 16\nWorldBegin\n\
        LightSource \"infinite\" \"rgb L\" [1 1 1]\n\
        Texture \"img\" \"spectrum\" \"imagemap\" \"string filename\" \"tex.png\"\n\
        Material \"diffuse\" \"texture reflectance\" \"img\"\n\
        Rotate 30 0 1 0\nRotate -70 1 0 0\nShape \"sphere\" \"float radius\" 1.2\n";
    let xml = r#"<scene version="3.0.0">
<integrator type="path"><integer name="max_depth" value="6"/></integrator>
<sensor type="perspective">
  <float name="fov" value="40"/><string name="fov_axis" value="smaller"/>
  <transform name="to_world"><scale x="-1"/><lookat origin="0 0 -4" target="0 0 0" up="0 1 0"/></transform>
  <sampler type="independent"><integer name="sample_count" value="16"/></sampler>
  <film type="hdrfilm"><integer name="width" value="32"/><integer name="height" value="32"/></film>
</sensor>
<emitter type="constant"><rgb name="radiance" value="1"/></emitter>
<shape type="sphere"><float name="radius" value="1.2"/>
  <transform name="to_world"><rotate x="1" angle="-70"/><rotate y="1" angle="30"/></transform>
  <bsdf type="twosided"><bsdf type="diffuse"><texture type="bitmap" name="reflectance">
    <string name="filename" value="tex.png"/></texture></bsdf></bsdf></shape>
</scene>"#;
    let (p, x) = (dir.join("s.pbrt"), dir.join("s.xml"));
    std::fs::write(&p, pbrt).unwrap();
    std::fs::write(&x, xml).unwrap();
    let a = render_with_variance(&p, 256, 16, None, 40);
    let b = render_with_variance(&x, 256, 16, None, 41);
    assert_agree("textured sphere vs XML", &a, &b, 0.02);
    for (what, bad) in injected_errors(&a) {
        let v = compare(&format!("injected {what}"), &bad, &b, 0.02);
        assert!(!v.failures.is_empty(), "the comparison misses an injected error: {what}");
    }
    std::fs::remove_dir_all(&dir).unwrap();
}

/// A film Penumbra does not render is an error at its directive.
#[test]
fn pbrt_spectral_film_is_refused() {
    let dir = temp_dir("film");
    let path = dir.join("f.pbrt");
    std::fs::write(&path, "Film \"spectral\"\nWorldBegin\nShape \"sphere\"\n").unwrap();
    let e = load_scene(&path, &[], &Overrides::default()).map(|_| ()).unwrap_err().to_string();
    assert!(e.contains("f.pbrt:1:1") && e.contains("Film \"spectral\" is not supported"), "{e}");
    std::fs::remove_dir_all(&dir).unwrap();
}

/// Materials that use the same image texture share one bitmap.
#[test]
fn pbrt_shared_image_texture_is_built_once() {
    use penumbra_render::material::Material;
    use penumbra_render::texture::Texture;
    let dir = temp_dir("share");
    let img = penumbra_scene::image_io::RgbImage { width: 2, height: 2, pixels: vec![[0.5, 0.2, 0.1]; 4] };
    penumbra_scene::image_io::write_image(&dir.join("t.png"), &img).unwrap();
    let path = dir.join("s.pbrt");
    std::fs::write(
        &path,
        "Film \"rgb\" \"integer xresolution\" 4 \"integer yresolution\" 4\nWorldBegin\n\
         Texture \"t\" \"spectrum\" \"imagemap\" \"string filename\" \"t.png\"\n\
         Material \"diffuse\" \"texture reflectance\" \"t\"\nShape \"sphere\"\n\
         Material \"diffusetransmission\" \"texture reflectance\" \"t\"\nShape \"disk\"\n",
    )
    .unwrap();
    let job = load_scene(&path, &[], &Overrides::default()).unwrap();
    let bitmap = |m: &Material| match m {
        Material::TwoSided(front, _) => match front.as_ref() {
            Material::Diffuse(d) => d.reflectance.clone(),
            _ => panic!("not diffuse"),
        },
        Material::DiffuseTransmission(d) => d.reflectance.clone(),
        _ => panic!("unexpected material"),
    };
    let (Texture::Bitmap(a), Texture::Bitmap(b)) = (bitmap(&job.scene.materials[0]), bitmap(&job.scene.materials[1]))
    else {
        panic!("not bitmaps")
    };
    assert!(std::sync::Arc::ptr_eq(&a, &b));
    std::fs::remove_dir_all(&dir).unwrap();
}

/// A homogeneous medium (chromatic σ_a, forward-scattering g) inside a
/// sphere bounded by an `interface` surface, and the camera in a thin haze
/// filling a larger interface sphere around the scene, under `volpath`: the same as the Mitsuba XML twin
/// (homogeneous media, a null BSDF, `volpath`). With `path`, pbrt-v4
/// ignores the media, and so does the translation (with a note).
#[test]
fn pbrt_media_match_their_mitsuba_xml_twin() {
    let dir = temp_dir("media");
    let pbrt = |integrator: &str| {
        format!(
            "LookAt 0 0 -4  0 0 0  0 1 0\nMakeNamedMedium \"haze\" \"string type\" \"homogeneous\" \
             \"rgb sigma_a\" [0.02 0.02 0.02] \"rgb sigma_s\" [0.05 0.05 0.05]\nMediumInterface \"haze\"\n\
             Camera \"perspective\" \"float fov\" 40\n\
             Film \"rgb\" \"integer xresolution\" 32 \"integer yresolution\" 32\n\
             Sampler \"independent\" \"integer pixelsamples\" 16\n\
             Integrator \"{integrator}\" \"integer maxdepth\" 20\nWorldBegin\n\
             LightSource \"infinite\" \"rgb L\" [1 1 1]\n\
             MakeNamedMedium \"ink\" \"string type\" \"homogeneous\" \"rgb sigma_a\" [0.1 0.5 1.0] \
             \"rgb sigma_s\" [1 1 1] \"float scale\" 2 \"float g\" 0.6\n\
             AttributeBegin\nMaterial \"interface\"\nMediumInterface \"ink\" \"haze\"\n\
             Translate 0.6 0 0\nShape \"sphere\" \"float radius\" 1\nAttributeEnd\n\
             AttributeBegin\nMediumInterface \"haze\" \"haze\"\nMaterial \"diffuse\" \"rgb reflectance\" [0.5 0.5 0.5]\n\
             Translate 0 -1.2 0\nRotate 90 1 0 0\nShape \"disk\" \"float radius\" 3\nAttributeEnd\n\
             AttributeBegin\nMaterial \"interface\"\nMediumInterface \"haze\" \"\"\n\
             Shape \"sphere\" \"float radius\" 8\nAttributeEnd\n"
        )
    };
    let xml = r#"<scene version="3.0.0">
<integrator type="volpath"><integer name="max_depth" value="21"/></integrator>
<medium type="homogeneous" id="haze"><rgb name="sigma_t" value="0.07"/><rgb name="albedo" value="0.7142857"/></medium>
<sensor type="perspective">
  <float name="fov" value="40"/><string name="fov_axis" value="smaller"/>
  <transform name="to_world"><scale x="-1"/><lookat origin="0 0 -4" target="0 0 0" up="0 1 0"/></transform>
  <sampler type="independent"><integer name="sample_count" value="16"/></sampler>
  <film type="hdrfilm"><integer name="width" value="32"/><integer name="height" value="32"/></film>
  <ref id="haze"/>
</sensor>
<emitter type="constant"><rgb name="radiance" value="1"/></emitter>
<shape type="sphere"><float name="radius" value="1"/><point name="center" value="0.6, 0, 0"/><bsdf type="null"/>
  <medium type="homogeneous" name="interior"><rgb name="sigma_t" value="0.55, 0.75, 1"/><float name="scale" value="4"/>
    <rgb name="albedo" value="0.9090909, 0.6666667, 0.5"/><phase type="hg"><float name="g" value="0.6"/></phase></medium>
  <ref name="exterior" id="haze"/></shape>
<shape type="disk">
  <transform name="to_world"><scale value="3"/><rotate x="1" angle="-90"/><translate y="-1.2"/></transform>
  <bsdf type="twosided"><bsdf type="diffuse"><rgb name="reflectance" value="0.5"/></bsdf></bsdf>
  <ref name="exterior" id="haze"/><ref name="interior" id="haze"/></shape>
<shape type="sphere"><float name="radius" value="8"/><bsdf type="null"/><ref name="interior" id="haze"/></shape>
</scene>"#;
    let (p, x) = (dir.join("m.pbrt"), dir.join("m.xml"));
    std::fs::write(&p, pbrt("volpath")).unwrap();
    std::fs::write(&x, xml).unwrap();
    let a = render_with_variance(&p, 256, 16, None, 50);
    let b = render_with_variance(&x, 256, 16, None, 51);
    assert_agree("media vs XML", &a, &b, 0.02);
    for (what, bad) in injected_errors(&a) {
        let v = compare(&format!("injected {what}"), &bad, &b, 0.02);
        assert!(!v.failures.is_empty(), "the comparison misses an injected error: {what}");
    }
    // `path`: the media are ignored, with a note.
    std::fs::write(&p, pbrt("path")).unwrap();
    let s = penumbra_scene::pbrt::parse_file(&p).unwrap();
    let (job, notes) = penumbra_scene::pbrt::translate::translate(&s, &p, &Overrides::default()).unwrap();
    assert!(matches!(job.integrator, penumbra_render::integrator::Integrator::Path(_)));
    assert!(notes.iter().any(|n| n.contains("ignores them")), "{notes:?}");
    // Unknown media and unsupported kinds are errors at their line.
    let bad = pbrt("volpath").replace("MediumInterface \"ink\" \"haze\"", "MediumInterface \"inc\" \"haze\"");
    std::fs::write(&p, bad).unwrap();
    let e = load_scene(&p, &[], &Overrides::default()).map(|_| ()).unwrap_err().to_string();
    assert!(e.contains("m.pbrt:") && e.contains("\"inc\""), "{e}");
    let bad = pbrt("volpath").replace("\"homogeneous\" \"rgb sigma_a\" [0.1", "\"uniformgrid\" \"rgb sigma_a\" [0.1");
    std::fs::write(&p, bad).unwrap();
    let e = load_scene(&p, &[], &Overrides::default()).map(|_| ()).unwrap_err().to_string();
    assert!(e.contains("m.pbrt:10:") && e.contains("uniformgrid"), "{e}");
    std::fs::remove_dir_all(&dir).unwrap();
}

/// `coateddiffuse` with an index-matched coat (eta 1) over a vanishing slab
/// is its base, `diffuse`; a real coat (eta 1.5) darkens it. Bad walk
/// settings are errors at the material's line.
#[test]
fn pbrt_coateddiffuse_without_a_coat_is_diffuse() {
    let dir = temp_dir("coated");
    let scene = |material: &str| {
        format!(
            "LookAt 0 0 -4  0 0 0  0 1 0\nCamera \"perspective\" \"float fov\" 40\n\
             Film \"rgb\" \"integer xresolution\" 24 \"integer yresolution\" 24\n\
             Sampler \"independent\" \"integer pixelsamples\" 16\nWorldBegin\n\
             LightSource \"infinite\" \"rgb L\" [1 1 1]\nLightSource \"distant\" \"point3 from\" [1 2 -3] \"rgb L\" [2 2 2]\n\
             {material}\nShape \"sphere\" \"float radius\" 1.2\n"
        )
    };
    let (a, b, c) = (dir.join("a.pbrt"), dir.join("b.pbrt"), dir.join("c.pbrt"));
    std::fs::write(&a, scene("Material \"diffuse\" \"rgb reflectance\" [0.7 0.4 0.2]")).unwrap();
    let coated = |eta: f64| {
        format!(
            "Material \"coateddiffuse\" \"rgb reflectance\" [0.7 0.4 0.2] \"float eta\" {eta} \
             \"float thickness\" 1e-6 \"integer maxdepth\" 50"
        )
    };
    std::fs::write(&b, scene(&coated(1.0))).unwrap();
    std::fs::write(&c, scene(&coated(1.5))).unwrap();
    let ea = render_with_variance(&a, 128, 16, None, 60);
    let eb = render_with_variance(&b, 128, 16, None, 61);
    assert_agree("coateddiffuse eta 1 vs diffuse", &eb, &ea, 0.02);
    let ec = render_with_variance(&c, 128, 16, None, 62);
    let v = compare("coateddiffuse eta 1.5 vs diffuse", &ec, &ea, 0.02);
    assert!(!v.failures.is_empty(), "a real coat must change the image");
    let bad = scene("Material \"coatedconductor\" \"integer maxdepth\" 0");
    std::fs::write(&c, bad).unwrap();
    let e = load_scene(&c, &[], &Overrides::default()).map(|_| ()).unwrap_err().to_string();
    assert!(e.contains("c.pbrt:8:1") && e.contains("maxdepth 0"), "{e}");
    let ok = scene("Material \"coatedconductor\" \"float interface.roughness\" 0.1 \"rgb reflectance\" [0.9 0.6 0.3]");
    std::fs::write(&c, ok).unwrap();
    load_scene(&c, &[], &Overrides::default()).unwrap();
    std::fs::remove_dir_all(&dir).unwrap();
}

/// The lights of one pbrt-v4 scene file, translated.
fn lights_of(dir: &Path, text: &str) -> Vec<penumbra_render::light::Light> {
    let path = dir.join("l.pbrt");
    std::fs::write(
        &path,
        format!("Film \"rgb\" \"integer xresolution\" 8 \"integer yresolution\" 8\nWorldBegin\n{text}\n"),
    )
    .unwrap();
    load_scene(&path, &[], &Overrides::default()).unwrap().scene.lights.clone()
}

/// `goniometric`: a uniform image gives a point light's I / d² bit for bit
/// (pbrt-v4's I times the image's grey value); the y-z swap puts the image's
/// centre (the octahedral +z) at the light's +y: an image lit only in its
/// centre diamond (the upper hemisphere) lights a point above the light and
/// not one below, also through the light's own rotation.
#[test]
fn pbrt_goniometric_light_is_pbrts() {
    let dir = temp_dir("gonio");
    let n = 16;
    let img = |f: &dyn Fn(f32, f32) -> f32| penumbra_scene::image_io::RgbImage {
        width: n,
        height: n,
        pixels: (0..n * n)
            .map(|k| {
                let (u, v) = (((k % n) as f32 + 0.5) / n as f32, ((k / n) as f32 + 0.5) / n as f32);
                let g = f(u, v);
                [g, g, g]
            })
            .collect(),
    };
    penumbra_scene::image_io::write_image(&dir.join("flat.exr"), &img(&|_, _| 0.5)).unwrap();
    penumbra_scene::image_io::write_image(
        &dir.join("up.exr"),
        &img(&|u, v| ((u - 0.5).abs() + (v - 0.5).abs() < 0.5) as u8 as f32),
    )
    .unwrap();
    let g = lights_of(&dir, "Translate 1 2 3\nLightSource \"goniometric\" \"string filename\" \"flat.exr\" \"rgb I\" [2 4 6] \"float scale\" 3");
    let pt = lights_of(&dir, "Translate 1 2 3\nLightSource \"point\" \"rgb I\" [1 2 3] \"float scale\" 3");
    assert_eq!(g[0].name(), "goniometric");
    for p in [glam::Vec3::new(-2.0, 0.5, 1.0), glam::Vec3::new(4.0, 9.0, -3.0)] {
        let (a, b) =
            (g[0].sample_li(p, glam::Vec2::ZERO, &[]).unwrap(), pt[0].sample_li(p, glam::Vec2::ZERO, &[]).unwrap());
        assert_eq!((a.wi, a.dist, a.li), (b.wi, b.dist, b.li), "at {p}");
    }
    let up = |rot: &str| lights_of(&dir, &format!("{rot}\nLightSource \"goniometric\" \"string filename\" \"up.exr\""));
    let lit = |l: &penumbra_render::light::Light, p: glam::Vec3| l.sample_li(p, glam::Vec2::ZERO, &[]).is_some();
    let l = up("");
    assert!(lit(&l[0], glam::Vec3::new(0.1, 3.0, 0.2)) && !lit(&l[0], glam::Vec3::new(0.1, -3.0, 0.2)));
    // Rotated 90 degrees about z: the light's +y now points along world -x.
    let l = up("Rotate 90 0 0 1");
    assert!(lit(&l[0], glam::Vec3::new(-3.0, 0.1, 0.2)) && !lit(&l[0], glam::Vec3::new(3.0, 0.1, 0.2)));
    std::fs::remove_dir_all(&dir).unwrap();
}

/// `projection`: the image lands as pbrt-v4's screen bounds and y flip put
/// it (light-space +x to the image's right, +y to its top row), with I =
/// scale · RGB / d² and no cos³ factor; fov spans the image's shorter side;
/// nothing behind the light or outside the frustum.
#[test]
fn pbrt_projection_light_is_pbrts() {
    let dir = temp_dir("proj");
    // 4x2: top row red | green | blue | white, bottom row all grey.
    let mut pixels = vec![[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0], [1.0, 1.0, 1.0]];
    pixels.extend([[0.25; 3]; 4]);
    penumbra_scene::image_io::write_image(
        &dir.join("p.exr"),
        &penumbra_scene::image_io::RgbImage { width: 4, height: 2, pixels },
    )
    .unwrap();
    let l =
        lights_of(&dir, "LightSource \"projection\" \"string filename\" \"p.exr\" \"float fov\" 90 \"float scale\" 2");
    assert_eq!(l[0].name(), "projection");
    // fov 90 along y (the shorter side): the image spans x in [-2z, 2z], y in [-z, z].
    let li = |x: f32, y: f32, z: f32| {
        let p = glam::Vec3::new(x, y, z);
        l[0].sample_li(p, glam::Vec2::ZERO, &[]).map(|s| s.li * p.length_squared())
    };
    let near = |a: Option<glam::Vec3>, b: [f32; 3]| {
        let a = a.expect("lit");
        assert!((a - glam::Vec3::from_array(b)).abs().max_element() < 1e-4, "{a} against {b:?}");
    };
    near(li(-3.0, 0.5, 2.0), [2.0, 0.0, 0.0]); // left column, top row
    near(li(-1.0, 0.5, 2.0), [0.0, 2.0, 0.0]);
    near(li(1.0, 0.5, 2.0), [0.0, 0.0, 2.0]);
    near(li(3.0, 0.5, 2.0), [2.0, 2.0, 2.0]); // right column
    near(li(3.0, -0.5, 2.0), [0.5, 0.5, 0.5]); // bottom row
    assert!(li(0.0, 0.5, -2.0).is_none() && li(4.5, 0.0, 2.0).is_none() && li(0.0, 2.5, 2.0).is_none());
    std::fs::remove_dir_all(&dir).unwrap();
}

/// `infinite` from a 2:1 latitude-longitude image (pbrt-v3's map: +z up,
/// u = φ / 2π from +x towards +y, v = θ / π): the radiance from world
/// directions, through a rotated light frame and `scale`, is the
/// environment's value in light space, within the map's interpolation
/// error; a map mirrored in u is caught.
#[test]
fn pbrt_latlong_infinite_light_is_pbrt_v3s_map() {
    use std::f32::consts::PI;
    let dir = temp_dir("latlong");
    // A smooth environment in light space, brighter towards +z and +y.
    let f = |d: glam::Vec3| glam::Vec3::new(1.0 + 0.8 * d.z + 0.3 * d.y, 0.6 + 0.4 * d.x, 0.5 + 0.45 * d.z * d.z);
    let (w, h) = (512, 256);
    let map = |mirror: bool| penumbra_scene::image_io::RgbImage {
        width: w,
        height: h,
        pixels: (0..w * h)
            .map(|k| {
                let j = if mirror { w - 1 - k % w } else { k % w };
                // Mitsuba's envmap places row i at θ = π i / (H - 1), column j at φ = 2π (j + ½) / W.
                let (theta, phi) = (PI * (k / w) as f32 / (h - 1) as f32, 2.0 * PI * (j as f32 + 0.5) / w as f32);
                f(glam::Vec3::new(theta.sin() * phi.cos(), theta.sin() * phi.sin(), theta.cos())).to_array()
            })
            .collect(),
    };
    let light = |mirror: bool| {
        penumbra_scene::image_io::write_image(&dir.join("ll.exr"), &map(mirror)).unwrap();
        lights_of(
            &dir,
            "Rotate -70 1 0.3 0\nLightSource \"infinite\" \"string filename\" \"ll.exr\" \"float scale\" 0.7",
        )
    };
    let l = light(false);
    assert_eq!(l[0].name(), "envmap");
    let rot = glam::Mat3::from_axis_angle(glam::Vec3::new(1.0, 0.3, 0.0).normalize(), (-70.0f32).to_radians());
    let dirs: Vec<glam::Vec3> = (0..200)
        .map(|k| {
            // A spiral over the sphere.
            let z = 1.0 - 2.0 * (k as f32 + 0.5) / 200.0;
            let phi = k as f32 * 2.399_963;
            let r = (1.0 - z * z).sqrt();
            glam::Vec3::new(r * phi.cos(), r * phi.sin(), z)
        })
        .collect();
    let worst = |l: &penumbra_render::light::Light| {
        dirs.iter()
            .map(|&wi| (l.environment_radiance(wi) - 0.7 * f(rot.transpose() * wi)).abs().max_element())
            .fold(0.0, f32::max)
    };
    // Bilinear interpolation of this f over texels of 0.7° errs by < 1e-3.
    assert!(worst(&l[0]) < 2e-3, "largest deviation {}", worst(&l[0]));
    assert!(worst(&light(true)[0]) > 0.1, "a mirrored map agreed");
    std::fs::remove_dir_all(&dir).unwrap();
}
