//! Shapes read from scene files: `serialized` meshes, `cylinder`, and
//! `shapegroup` / `instance`, checked against values printed by Mitsuba 3.9.1.

use glam::{Vec2, Vec3};
use penumbra_render::geometry::{Aabb, Shape, TriangleMesh};
use penumbra_scene::builder::{build, Overrides};
use penumbra_scene::mitsuba::parse_str;
use penumbra_scene::serialized::{load_serialized, write_serialized, WriteOptions};
use std::path::{Path, PathBuf};

fn temp_dir() -> PathBuf {
    let dir = std::env::temp_dir().join(format!("penumbra-shapes-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

fn scene_xml(shapes: &str) -> String {
    format!(
        r#"<scene version="3.0.0">
<sensor type="perspective"><float name="fov" value="40"/>
  <transform name="to_world"><lookat origin="0, 0, 6" target="0, 0, 0" up="0, 1, 0"/></transform>
  <film type="hdrfilm"><integer name="width" value="8"/><integer name="height" value="8"/></film>
</sensor>
{shapes}
</scene>"#
    )
}

fn load(shapes: &str, dir: &Path) -> Result<penumbra_render::render::RenderJob, penumbra_scene::LoadError> {
    let path = dir.join("scene.xml");
    build(&parse_str(&scene_xml(shapes), &path, &[])?, &Overrides::default())
}

fn bounds(m: &TriangleMesh) -> Aabb {
    Aabb::from_points(&m.positions)
}

/// tests/scenes/shapes/three.serialized (written by
/// tools/make_serialized_fixture.py from meshes Mitsuba 3.9.1 builds; Mitsuba
/// reads it back bit for bit and renders it as it renders the source meshes)
/// against what Mitsuba 3.9.1 reads from it:
///   s = mi.load_dict({'type': 'serialized', 'filename': F, 'shape_index': i})
///       (index 2 with 'face_normals': True)
///   s.vertex_count(), s.face_count(), s.has_vertex_normals(),
///   s.has_vertex_texcoords(), s.bbox(), and the column sums of
///   s.vertex_positions_buffer() in float64
/// Index 3 is past the last mesh (Mitsuba refuses it too).
#[test]
fn serialized_multi_shape_fixture_matches_mitsuba() {
    let path = common::root().join("tests/scenes/shapes/three.serialized");
    struct Want {
        name: &'static str,
        counts: (usize, usize),
        normals: bool,
        uvs: bool,
        face_normals: bool,
        lo: [f32; 3],
        hi: [f32; 3],
        sum: [f64; 3],
    }
    let want = [
        Want {
            name: "cube",
            counts: (24, 12),
            normals: true,
            uvs: true,
            face_normals: false,
            lo: [-1.5330127477645874, -0.30000001192092896, -0.5964101552963257],
            hi: [-0.26698726415634155, 0.30000001192092896, 0.5964101552963257],
            sum: [-21.59999978542328, 0.0, 0.0],
        },
        // Double precision in the file (flag 0x2000), read as f32.
        Want {
            name: "panel",
            counts: (4, 2),
            normals: true,
            uvs: true,
            face_normals: false,
            lo: [-1.399999976158142, -0.8736161589622498, -0.5517541170120239],
            hi: [1.399999976158142, -0.32638388872146606, 0.951754093170166],
            sum: [0.0, -2.4000000953674316, 0.7999999523162842],
        },
        // Positions only, file flag 0x0010 set.
        Want {
            name: "icosahedron",
            counts: (12, 20),
            normals: false,
            uvs: false,
            face_normals: true,
            lo: [0.41720718145370483, -0.2827928364276886, -0.3827928304672241],
            hi: [1.1827929019927979, 0.48279285430908203, 0.3827928304672241],
            sum: [9.600000262260437, 1.2000000774860382, 0.0],
        },
    ];
    for (i, w) in want.iter().enumerate() {
        let s = load_serialized(&path, i).unwrap();
        let m = &s.mesh;
        assert_eq!(s.name, w.name, "mesh {i}");
        assert_eq!((m.positions.len(), m.indices.len()), w.counts, "mesh {i}");
        assert_eq!(
            (!m.normals.is_empty(), !m.uvs.is_empty(), s.face_normals),
            (w.normals, w.uvs, w.face_normals),
            "mesh {i}"
        );
        let b = bounds(m);
        // The same f32 values, so the same bounds.
        assert_eq!((b.min.to_array(), b.max.to_array()), (w.lo, w.hi), "mesh {i}");
        let sum =
            m.positions.iter().fold([0.0f64; 3], |a, p| [a[0] + p.x as f64, a[1] + p.y as f64, a[2] + p.z as f64]);
        for k in 0..3 {
            assert!((sum[k] - w.sum[k]).abs() < 1e-9, "mesh {i}: sum of positions {sum:?} vs {:?}", w.sum);
        }
    }
    let e = load_serialized(&path, 3).unwrap_err().to_string();
    assert!(e.contains("out of range") && e.contains("three.serialized"), "{e}");
}

fn quad(z: f32, with_normals: bool) -> TriangleMesh {
    TriangleMesh {
        positions: vec![
            Vec3::new(-1.0, -1.0, z),
            Vec3::new(1.0, -1.0, z),
            Vec3::new(1.0, 1.0, z),
            Vec3::new(-1.0, 1.0, z),
        ],
        normals: if with_normals { vec![Vec3::new(0.0, 0.6, 0.8); 4] } else { Vec::new() },
        uvs: vec![Vec2::ZERO, Vec2::X, Vec2::ONE, Vec2::Y],
        indices: vec![[0, 1, 2], [2, 3, 0]],
    }
}

#[test]
fn serialized_shape_reads_index_transform_and_normals() {
    let dir = temp_dir();
    let (a, b) = (quad(0.0, true), quad(0.5, false));
    std::fs::write(
        dir.join("two.serialized"),
        write_serialized(&[("a", &a), ("b", &b)], WriteOptions { version: 3, ..Default::default() }),
    )
    .unwrap();
    let job = load(
        r#"<shape type="serialized"><string name="filename" value="two.serialized"/>
             <integer name="shape_index" value="1"/>
             <transform name="to_world"><translate x="2"/></transform></shape>
           <shape type="serialized"><string name="filename" value="two.serialized"/></shape>
           <shape type="serialized"><string name="filename" value="two.serialized"/>
             <boolean name="flip_normals" value="true"/></shape>"#,
        &dir,
    )
    .unwrap();
    let meshes: Vec<_> = job
        .scene
        .shapes
        .iter()
        .map(|s| match s {
            Shape::Mesh(m) => m,
            _ => panic!("not a mesh"),
        })
        .collect();
    // Mesh 1, translated; its missing normals recomputed from the faces (+z).
    assert_eq!(meshes[0].mesh.positions[0], Vec3::new(1.0, -1.0, 0.5));
    assert!(meshes[0].mesh.normals.iter().all(|n| (*n - Vec3::Z).length() < 1e-6));
    // Mesh 0 keeps its stored normals; flip_normals negates them.
    assert_eq!(meshes[1].mesh.normals[0], Vec3::new(0.0, 0.6, 0.8));
    assert_eq!(meshes[2].mesh.normals[0], Vec3::new(0.0, -0.6, -0.8));

    for (shape, words) in [
        (
            r#"<shape type="serialized"><string name="filename" value="two.serialized"/><integer name="shape_index" value="2"/></shape>"#,
            &["out of range", "0..1"][..],
        ),
        (r#"<shape type="serialized"><string name="filename" value="none.serialized"/></shape>"#, &["not found"][..]),
        (
            r#"<shape type="serialized"><string name="filename" value="two.serialized"/><float name="max_smooth_angle" value="30"/></shape>"#,
            &["max_smooth_angle"][..],
        ),
    ] {
        let e = load(shape, &dir).err().expect("must fail").to_string();
        assert!(words.iter().all(|w| e.contains(w)), "{e}");
    }
}

#[test]
fn cylinder_parameters_are_read() {
    let dir = temp_dir();
    let job = load(
        r#"<shape type="cylinder"><point name="p0" x="0" y="0" z="-1"/><point name="p1" x="0" y="0" z="2"/>
             <float name="radius" value="0.5"/><emitter type="area"><rgb name="radiance" value="1"/></emitter></shape>"#,
        &dir,
    )
    .unwrap();
    let s = &job.scene.shapes[0];
    assert!((s.area() - 2.0 * std::f32::consts::PI * 0.5 * 3.0).abs() < 1e-5);
    let e = load(
        r#"<shape type="cylinder"><transform name="to_world"><scale x="2" y="1" z="1"/></transform></shape>"#,
        &dir,
    )
    .err()
    .unwrap()
    .to_string();
    assert!(e.contains("scene.xml:") && e.contains("cylinder"), "{e}");
}

use crate::common;

/// Instanced geometry renders as the same geometry written out: the same
/// random numbers follow the same paths, so the images agree to rounding
/// (a path may branch differently where rounding moves a hit across an edge).
#[test]
fn instances_render_like_flattened_geometry() {
    let dir = common::root().join("tests/scenes/shapes");
    let a = common::render_with_variance(&dir.join("instanced.xml"), 16, 2, None, 5);
    let b = common::render_with_variance(&dir.join("flattened.xml"), 16, 2, None, 5);
    let n = a.mean.len();
    let close =
        a.mean.iter().zip(&b.mean).filter(|(x, y)| (0..3).all(|c| (x[c] - y[c]).abs() < 1e-3 * (1.0 + y[c]))).count();
    assert!(close as f64 >= 0.97 * n as f64, "{close} of {n} pixels agree");
    for c in 0..3 {
        let ma = a.mean.iter().map(|p| p[c]).sum::<f64>() / n as f64;
        let mb = b.mean.iter().map(|p| p[c]).sum::<f64>() / n as f64;
        assert!((ma - mb).abs() < 1e-2 * mb, "channel {c}: {ma} vs {mb}");
    }
    // And the instances are really there: the image differs from an empty floor.
    assert!(a.mean.iter().any(|p| p[0] > 1.5 * p[2]), "no red box visible");
}

#[test]
fn instancing_errors_name_the_problem() {
    let dir = temp_dir();
    let group = |inner: &str| format!(r#"<shape type="shapegroup" id="g">{inner}</shape>"#);
    let cases = [
        (
            group(r#"<shape type="sphere"><emitter type="area"><rgb name="radiance" value="1"/></emitter></shape>"#),
            "emitters inside a shapegroup",
        ),
        (group(r#"<shape type="sphere"/>"#) + r#"<shape type="instance"/>"#, "needs one shapegroup"),
        (group(""), "holds no shapes"),
        (group(r#"<shape type="instance"><ref id="x"/></shape>"#), "x"),
    ];
    for (xml, want) in cases {
        let e = load(&xml, &dir).err().expect("must fail").to_string();
        assert!(e.contains(want) && e.contains("scene.xml:"), "{e}");
    }
}

/// `merge` places its shapes as they are: the image is bitwise the one of
/// the same shapes listed directly (Mitsuba joins meshes that share a BSDF
/// into one, which changes memory, not the image).
#[test]
fn merge_renders_its_shapes_as_they_are() {
    let dir = temp_dir();
    let shapes = r#"<emitter type="constant"/>
<shape type="sphere"><float name="radius" value="0.7"/><bsdf type="diffuse"><rgb name="reflectance" value="0.8, 0.2, 0.2"/></bsdf></shape>
<shape type="cube"><transform name="to_world"><scale value="0.5"/><translate x="1.2"/></transform></shape>
<shape type="rectangle"><transform name="to_world"><scale value="3"/><translate z="-1"/></transform></shape>"#;
    let render = |job: &penumbra_render::render::RenderJob| {
        let mut film = penumbra_render::film::Film::new(job.width, job.height);
        job.render_into(&mut film, 0..16, &|_| {});
        film.develop()
    };
    let plain = load(shapes, &dir).unwrap();
    let merged_xml =
        format!("<shape type=\"merge\">{}</shape>", shapes.replacen("<emitter type=\"constant\"/>", "", 1));
    let merged = load(&format!("<emitter type=\"constant\"/>{merged_xml}"), &dir).unwrap();
    assert_eq!(merged.scene.shapes.len(), 3);
    let (a, b) = (render(&plain), render(&merged));
    assert_eq!(a, b);
    assert!(a.iter().any(|p| p[0] > 2.0 * p[1]), "the red sphere is not in the image");
    // merge takes shapes only, and no parameters.
    let e = load("<shape type=\"merge\"><float name=\"scale\" value=\"2\"/></shape>", &dir).unwrap_err().to_string();
    assert!(e.contains("parameter 'scale'"), "{e}");
    let e = load("<shape type=\"merge\"><bsdf type=\"diffuse\"/></shape>", &dir).unwrap_err().to_string();
    assert!(e.contains("a nested bsdf is not supported"), "{e}");
}

/// A binary little-endian PLY of ellipsoids in Mitsuba's layout with the
/// given extra columns; rows: (centre, log radii, quaternion r i j k).
fn ellipsoid_ply(extras: &[&str], rows: &[([f32; 3], [f32; 3], [f32; 4], Vec<f32>)]) -> Vec<u8> {
    let mut names = vec!["x", "y", "z", "nx", "ny", "nz"];
    names.extend_from_slice(extras);
    names.extend_from_slice(&["scale_0", "scale_1", "scale_2", "rot_0", "rot_1", "rot_2", "rot_3"]);
    let mut out = format!("ply\nformat binary_little_endian 1.0\nelement vertex {}\n", rows.len());
    for n in &names {
        out += &format!("property float {n}\n");
    }
    out += "end_header\n";
    let mut bytes = out.into_bytes();
    for (c, s, q, extra) in rows {
        let row: Vec<f32> = c.iter().chain(&[0.0; 3]).chain(extra).chain(s).chain(q).copied().collect();
        bytes.extend(row.iter().flat_map(|v| v.to_le_bytes()));
    }
    bytes
}

#[test]
fn ellipsoids_are_read_as_mitsuba_reads_them() {
    let dir = temp_dir().join("ellipsoids");
    std::fs::create_dir_all(&dir).unwrap();
    // Radius e^ln(0.1) * extent 3 = 0.3 along x; a 90 degree turn about z in the file.
    let h = std::f32::consts::FRAC_1_SQRT_2;
    let rows = vec![
        ([1.0, 0.0, 0.0], [0.1f32.ln(), 0.2f32.ln(), 0.05f32.ln()], [h, 0.0, 0.0, h], vec![0.5]),
        ([0.0, 0.0, 0.0], [0.1f32.ln(); 3], [2.0, 0.0, 0.0, 0.0], vec![0.02]),
    ];
    std::fs::write(dir.join("e.ply"), ellipsoid_ply(&["opacities"], &rows)).unwrap();
    let shape = |extra: &str, plugin: &str| {
        format!(
            r#"<shape type="{plugin}"><string name="filename" value="e.ply"/>{extra}
               <transform name="to_world"><scale value="2"/><rotate y="1" angle="90"/><translate z="1"/></transform></shape>"#
        )
    };
    let job = load(&shape("", "ellipsoids"), &dir).unwrap();
    let Shape::Ellipsoids(e) = &job.scene.shapes[0] else { panic!("not ellipsoids") };
    assert_eq!(e.items.len(), 2);
    let a = &e.items[0];
    // Centre (1,0,0) → scale 2 → rotate y 90 → (0,0,-2) → translate → (0,0,-1).
    assert!((a.center - Vec3::new(0.0, 0.0, -1.0)).length() < 1e-5, "{}", a.center);
    // Radii × extent 3 × to_world's scale 2.
    assert!((a.scale - Vec3::new(0.6, 1.2, 0.3)).abs().max_element() < 1e-5, "{}", a.scale);
    // Local x → (file: about z by 90) y → (to_world: about y) y.
    assert!((a.rot * Vec3::X - Vec3::Y).length() < 1e-5, "{}", a.rot * Vec3::X);
    assert!((a.rot * Vec3::Y - Vec3::Z).length() < 1e-5, "{}", a.rot * Vec3::Y);
    // An unnormalised quaternion is normalised, as Mitsuba does.
    assert!((e.items[1].rot - glam::Mat3::from_rotation_y(90f32.to_radians())).abs_diff_eq(glam::Mat3::ZERO, 1e-5));
    // extent and scale_factor multiply; adaptive clamping uses the opacities
    // (0.5: sqrt(2 ln 50) / 3 times; 0.02 is nearly invisible: kept, small).
    let job = load(
        &shape(
            r#"<float name="extent" value="2"/><boolean name="extent_adaptive_clamping" value="true"/>"#,
            "ellipsoids",
        ),
        &dir,
    )
    .unwrap();
    let Shape::Ellipsoids(e) = &job.scene.shapes[0] else { panic!("not ellipsoids") };
    let k = (2.0f32 * 50f32.ln()).sqrt() / 3.0;
    assert!((e.items[0].scale.x - 0.1 * 2.0 * 2.0 * k).abs() < 1e-5, "{}", e.items[0].scale);
    let k2 = (2.0f32 * 2f32.ln()).sqrt() / 3.0;
    assert!((e.items[1].scale.x - 0.1 * 2.0 * 2.0 * k2).abs() < 1e-5, "{}", e.items[1].scale);
    // ellipsoidsmesh: 20 culled triangles per ellipsoid (12 with the box shell).
    let job = load(&shape("", "ellipsoidsmesh"), &dir).unwrap();
    let Shape::CulledMesh(m) = &job.scene.shapes[0] else { panic!("not a culled mesh") };
    assert_eq!(m.mesh.indices.len(), 40);
    let job = load(&shape(r#"<string name="shell" value="box"/>"#, "ellipsoidsmesh"), &dir).unwrap();
    assert_eq!(job.scene.shapes[0].prim_count(), 24);
}

#[test]
fn ellipsoid_errors_name_the_problem() {
    let dir = temp_dir().join("ellipsoid_errors");
    std::fs::create_dir_all(&dir).unwrap();
    let good = ([0.0f32; 3], [0.0f32; 3], [1.0f32, 0.0, 0.0, 0.0], vec![]);
    std::fs::write(dir.join("ok.ply"), ellipsoid_ply(&[], std::slice::from_ref(&good))).unwrap();
    let mut truncated = ellipsoid_ply(&[], &[good.clone(), good.clone()]);
    truncated.truncate(truncated.len() - 6);
    std::fs::write(dir.join("short.ply"), &truncated).unwrap();
    // A header claiming a billion rows: refused before allocating them.
    let mut huge = ellipsoid_ply(&[], std::slice::from_ref(&good));
    let at = huge.windows(16).position(|w| w == b"element vertex 1").unwrap() + 16;
    huge.splice(at..at, *b"000000000");
    std::fs::write(dir.join("huge.ply"), &huge).unwrap();
    let nan = ([0.0f32, f32::NAN, 0.0], [0.0f32; 3], [1.0f32, 0.0, 0.0, 0.0], vec![]);
    std::fs::write(dir.join("nan.ply"), ellipsoid_ply(&[], &[good.clone(), nan])).unwrap();
    // An extra column is fine; a misnamed one is not.
    let mut cols = ellipsoid_ply(&["a"], &[(good.0, good.1, good.2, vec![1.0])]);
    let at = cols.windows(8).position(|w| w == b"float nz").unwrap();
    cols[at + 7] = b'w';
    std::fs::write(dir.join("cols.ply"), &cols).unwrap();
    let mut ascii = String::from("ply\nformat ascii 1.0\nelement vertex 2\n");
    for n in ["x", "y", "z", "nx", "ny", "nz", "scale_0", "scale_1", "scale_2", "rot_0", "rot_1", "rot_2", "rot_3"] {
        ascii += &format!("property float {n}\n");
    }
    ascii += "end_header\n0 0 0 0 0 0 0 0 0 1 0 0 0\n0 zero 0 0 0 0 0 0 0 1 0 0 0\n";
    std::fs::write(dir.join("bad.ply"), ascii).unwrap();
    let zero_q = ([0.0f32; 3], [0.0f32; 3], [0.0f32; 4], vec![]);
    std::fs::write(dir.join("zeroq.ply"), ellipsoid_ply(&[], &[zero_q])).unwrap();
    std::fs::write(
        dir.join("double.ply"),
        "ply\nformat ascii 1.0\nelement vertex 1\nproperty double x\nend_header\n1\n",
    )
    .unwrap();
    let err = |body: &str| load(body, &dir).err().unwrap_or_else(|| panic!("loaded: {body}")).to_string();
    let e = |file: &str, extra: &str| {
        err(&format!(r#"<shape type="ellipsoids"><string name="filename" value="{file}"/>{extra}</shape>"#))
    };
    assert!(load(r#"<shape type="ellipsoids"><string name="filename" value="ok.ply"/></shape>"#, &dir).is_ok());
    let m = e("short.ply", "");
    assert!(m.contains("truncated") && m.contains("need 104 bytes") && m.contains("has 98"), "{m}");
    let m = e("bad.ply", "");
    assert!(m.contains("bad.ply:19:3: vertex 1 of 2, property 'y': "), "{m}");
    let m = e("huge.ply", "");
    assert!(m.contains("truncated") && m.contains("1000000000"), "{m}");
    let m = e("nan.ply", "");
    assert!(m.contains("ellipsoid 1") && m.contains("'y'"), "{m}");
    let m = e("cols.ply", "");
    assert!(m.contains("columns must be") && m.contains("found x y z nx ny nw a scale_0"), "{m}");
    let m = e("zeroq.ply", "");
    assert!(m.contains("quaternion"), "{m}");
    let m = e("double.ply", "");
    assert!(m.contains("property 'x'") && m.contains("float32"), "{m}");
    let m = e("ok.ply", r#"<float name="extent" value="-1"/>"#);
    assert!(m.contains("extent must be positive") && m.contains("scene.xml:"), "{m}");
    let m = e("ok.ply", r#"<boolean name="extent_adaptive_clamping" value="true"/>"#);
    assert!(m.contains("needs opacities"), "{m}");
    let m = e("ok.ply", r#"<float name="no_such" value="1"/>"#);
    assert!(m.contains("parameter 'no_such'") && m.contains("scene.xml:"), "{m}");
    let m = e("ok.ply", r#"<transform name="to_world"><scale x="1" y="2" z="1"/></transform>"#);
    assert!(m.contains("uniformly"), "{m}");
    let m = e("ok.ply", r#"<string name="data" value="x"/>"#);
    assert!(m.contains("tensor"), "{m}");
    let m = e("ok.ply", r#"<emitter type="area"/>"#);
    assert!(m.contains("ellipsoids cannot carry an area emitter"), "{m}");
    // ellipsoidsmesh is a mesh in Mitsuba: it can.
    let job = load(
        r#"<shape type="ellipsoidsmesh"><string name="filename" value="ok.ply"/>
            <emitter type="area"><rgb name="radiance" value="1, 1, 1"/></emitter></shape>"#,
        &dir,
    )
    .unwrap();
    assert_eq!(job.scene.lights.len(), 1);
    assert!(job.scene.shapes[0].area() > 0.0);
    let m = err(
        r#"<shape type="ellipsoidsmesh"><string name="filename" value="ok.ply"/><string name="shell" value="cone"/></shape>"#,
    );
    assert!(m.contains("shell type 'cone'"), "{m}");
    let m = err(r#"<shape type="ellipsoids"/>"#);
    assert!(m.contains("needs a 'filename'"), "{m}");
}

#[test]
fn sdfgrid_is_read_and_its_errors_name_the_problem() {
    use penumbra_render::medium::Grid;
    let dir = temp_dir().join("sdfgrid");
    std::fs::create_dir_all(&dir).unwrap();
    let unit = Aabb { min: Vec3::ZERO, max: Vec3::ONE };
    // z - 0.5 on a 3³ grid: the plane z = 0.5, 4 voxels touching it from each side.
    let plane: Vec<f32> = (0..27).map(|i| (i / 9) as f32 * 0.5 - 0.5).collect();
    let write = |name: &str, res: [u32; 3], channels: u32, data: Vec<f32>| {
        let bytes = penumbra_scene::vol::encode(&Grid { res, channels, data }, &unit);
        std::fs::write(dir.join(name), bytes).unwrap();
    };
    write("plane.vol", [3, 3, 3], 1, plane.clone());
    write("rgb.vol", [3, 3, 3], 3, plane.iter().flat_map(|v| [*v; 3]).collect());
    write("flat.vol", [3, 3, 1], 1, vec![1.0; 9]);
    write("empty.vol", [3, 3, 3], 1, vec![1.0; 27]);
    let mut truncated = std::fs::read(dir.join("plane.vol")).unwrap();
    truncated.truncate(60);
    std::fs::write(dir.join("short.vol"), truncated).unwrap();
    let shape = |file: &str, extra: &str| {
        format!(r#"<shape type="sdfgrid"><string name="filename" value="{file}"/>{extra}</shape>"#)
    };
    let job = load(
        &shape("plane.vol", r#"<transform name="to_world"><scale x="2" y="3" z="4"/><translate x="1"/></transform>"#),
        &dir,
    )
    .unwrap();
    let Shape::SdfGrid(g) = &job.scene.shapes[0] else { panic!("not an SDF grid") };
    // Only the voxels whose corners change sign or are zero: the 8 around z = 0.5.
    assert_eq!(g.voxel_count(), 8);
    assert!(g.smooth);
    let b = (0..8).fold(Aabb::EMPTY, |b, i| b.union(g.bounds(i)));
    assert!((b.min - Vec3::new(1.0, 0.0, 2.0)).abs().max_element() < 1e-4, "{b:?}");
    assert!((b.max - Vec3::new(3.0, 3.0, 2.0)).abs().max_element() < 1e-4, "{b:?}");
    let job = load(&shape("plane.vol", r#"<string name="normals" value="analytic"/>"#), &dir).unwrap();
    let Shape::SdfGrid(g) = &job.scene.shapes[0] else { panic!("not an SDF grid") };
    assert!(!g.smooth);
    let err = |body: &str| load(body, &dir).err().unwrap_or_else(|| panic!("loaded: {body}")).to_string();
    let m = err(&shape("rgb.vol", ""));
    assert!(m.contains("3 channels"), "{m}");
    let m = err(&shape("flat.vol", ""));
    assert!(m.contains("at least 2 values"), "{m}");
    let m = err(&shape("empty.vol", ""));
    assert!(m.contains("no voxel holds a surface"), "{m}");
    let m = err(&shape("short.vol", ""));
    assert!(m.contains("truncated"), "{m}");
    let m = err(&shape("plane.vol", r#"<string name="normals" value="flat"/>"#));
    assert!(m.contains("invalid normals mode 'flat'") && m.contains("scene.xml:"), "{m}");
    let m = err(&shape("plane.vol", r#"<transform name="to_world"><rotate y="1" angle="30"/></transform>"#));
    assert!(m.contains("must not rotate"), "{m}");
    let m = err(&shape("plane.vol", r#"<emitter type="area"/>"#));
    assert!(m.contains("sdfgrid cannot carry an area emitter"), "{m}");
    let m = err(&shape("plane.vol", r#"<boolean name="flip_normals" value="true"/>"#));
    assert!(m.contains("no parameter 'flip_normals'"), "{m}");
    let m = err(&shape("plane.vol", r#"<string name="grid" value="x"/>"#));
    assert!(m.contains("tensor"), "{m}");
    let m = err(&shape("nowhere.vol", ""));
    assert!(m.contains("nowhere.vol") && m.contains("not found"), "{m}");
    let m = err(r#"<shape type="sdfgrid"/>"#);
    assert!(m.contains("needs a 'filename'"), "{m}");
}

#[test]
fn linearcurve_is_read_and_its_errors_name_the_problem() {
    let dir = temp_dir().join("linearcurve");
    std::fs::create_dir_all(&dir).unwrap();
    let files = [
        ("ok.txt", "0 0 0 0.1\n1 0 0 0.2\n2 1 0 0.1\n \t\r\n5 5 5 0.3\n6 5 5 0\n"),
        ("short.txt", "0 0 0 0.1\n1 0 0 0.2\n\n\n5 5 5 0.3\n"),
        ("three.txt", "0 0 0 0.1 7\n"),
        ("word.txt", "0 0 0 0.1\n1 zero 0 0.2\n"),
        ("nan.txt", "0 0 0 0.1\n1 nan 0 0.2\n"),
        ("negative.txt", "0 0 0 0.1\n1 0 0 -0.2\n"),
        ("empty.txt", "\n\n"),
    ];
    for (name, text) in files {
        std::fs::write(dir.join(name), text).unwrap();
    }
    std::fs::write(dir.join("binary.txt"), b"0 0 0 0.1\n\xff\xfe").unwrap();
    let shape = |file: &str, extra: &str| {
        format!(r#"<shape type="linearcurve"><string name="filename" value="{file}"/>{extra}</shape>"#)
    };
    let job =
        load(&shape("ok.txt", r#"<transform name="to_world"><scale value="2"/><translate x="1"/></transform>"#), &dir)
            .unwrap();
    let Shape::Curves(c) = &job.scene.shapes[0] else { panic!("not curves") };
    // Two curves (3 and 2 points, a blank line of spaces between): 3 segments;
    // positions placed by to_world, radii as written.
    assert_eq!(c.segments, [0, 1, 3]);
    assert_eq!(c.points.len(), 5);
    assert!((c.points[2] - glam::Vec4::new(5.0, 2.0, 0.0, 0.1)).abs().max_element() < 1e-6, "{}", c.points[2]);
    let err = |body: &str| load(body, &dir).err().unwrap_or_else(|| panic!("loaded: {body}")).to_string();
    let m = err(&shape("short.txt", ""));
    assert!(m.contains("line 5: the curve starting here has 1 control point;"), "{m}");
    let m = err(&shape("three.txt", ""));
    assert!(m.contains("line 1: expected 4 numbers"), "{m}");
    let m = err(&shape("word.txt", ""));
    assert!(m.contains("line 2: expected 4 numbers") && m.contains("'1 zero 0 0.2'"), "{m}");
    let m = err(&shape("nan.txt", ""));
    assert!(m.contains("line 2") && m.contains("NaN"), "{m}");
    let m = err(&shape("negative.txt", ""));
    assert!(m.contains("line 2: the radius -0.2 is negative"), "{m}");
    let m = err(&shape("empty.txt", ""));
    assert!(m.contains("no control points"), "{m}");
    let m = err(&shape("binary.txt", ""));
    assert!(m.contains("not valid UTF-8 text: line 2"), "{m}");
    let m = err(&shape("ok.txt", r#"<emitter type="area"/>"#));
    assert!(m.contains("linearcurve cannot carry an area emitter"), "{m}");
    let m = err(&shape("ok.txt", r#"<integer name="control_point_count" value="5"/>"#));
    assert!(m.contains("parameter 'control_point_count'") && m.contains("scene.xml:"), "{m}");
    let m = err(r#"<shape type="linearcurve"/>"#);
    assert!(m.contains("needs a 'filename'"), "{m}");
}

#[test]
fn bsplinecurve_is_read_and_needs_four_points_per_curve() {
    let dir = temp_dir().join("bsplinecurve");
    std::fs::create_dir_all(&dir).unwrap();
    std::fs::write(
        dir.join("ok.txt"),
        "0 0 0 0.1\n1 0 0 0.2\n2 1 0 0.1\n3 1 1 0.1\n4 0 0 0.1\n\n5 5 5 0.3\n6 5 5 0\n7 5 5 0\n8 5 5 0\n",
    )
    .unwrap();
    std::fs::write(dir.join("three.txt"), "0 0 0 0.1\n1 0 0 0.2\n2 1 0 0.1\n").unwrap();
    let shape = |file: &str| format!(r#"<shape type="bsplinecurve"><string name="filename" value="{file}"/></shape>"#);
    let job = load(&shape("ok.txt"), &dir).unwrap();
    let Shape::Curves(c) = &job.scene.shapes[0] else { panic!("not curves") };
    // Five points make two segments, four make one.
    assert_eq!(c.segments, [0, 1, 5]);
    assert_eq!(c.basis, penumbra_render::geometry::curves::Basis::BSpline);
    let m = load(&shape("three.txt"), &dir).err().unwrap().to_string();
    assert!(m.contains("line 1: the curve starting here has 3 control points; a bsplinecurve needs at least 4"), "{m}");
}

/// The multi-part shapes inside a shapegroup, placed twice by instances,
/// render as the same shapes written out with the instances' translations.
#[test]
fn multi_part_shapes_render_alike_instanced_and_flattened() {
    let dir = temp_dir().join("multipart_instances");
    std::fs::create_dir_all(&dir).unwrap();
    let data = common::root().join("tests/scenes/shapes");
    let shapes = |to_world: &str| {
        let f = |name: &str| data.join(name).display().to_string();
        format!(
            r#"<shape type="ellipsoids"><string name="filename" value="{}"/>{to_world}
                 <bsdf type="diffuse"><rgb name="reflectance" value="0.8, 0.3, 0.2"/></bsdf></shape>
               <shape type="ellipsoidsmesh"><string name="filename" value="{}"/>
                 <transform name="to_world"><translate x="1.5"/>{}</transform></shape>
               <shape type="sdfgrid"><string name="filename" value="{}"/>
                 <transform name="to_world"><translate x="-1.5" y="-0.2"/>{}</transform></shape>
               <shape type="linearcurve"><string name="filename" value="{}"/>{to_world}</shape>
               <shape type="bsplinecurve"><string name="filename" value="{}"/>
                 <transform name="to_world"><translate z="0.8"/>{}</transform></shape>"#,
            f("ellipsoids.ply"),
            f("ellipsoids.ply"),
            to_world.replace("<transform name=\"to_world\">", "").replace("</transform>", ""),
            f("torus.sdf.vol"),
            to_world.replace("<transform name=\"to_world\">", "").replace("</transform>", ""),
            f("curves.txt"),
            f("bspline.txt"),
            to_world.replace("<transform name=\"to_world\">", "").replace("</transform>", ""),
        )
    };
    let scene = |body: String| {
        format!(
            r#"<scene version="3.0.0">
  <integrator type="path"><integer name="max_depth" value="3"/></integrator>
  <sensor type="perspective"><float name="fov" value="50"/>
    <transform name="to_world"><lookat origin="0, 3, 6" target="0, 0.3, 0" up="0, 1, 0"/></transform>
    <sampler type="independent"><integer name="sample_count" value="16"/></sampler>
    <film type="hdrfilm"><integer name="width" value="24"/><integer name="height" value="24"/><rfilter type="box"/></film>
  </sensor>
  <emitter type="constant"><rgb name="radiance" value="0.6, 0.7, 0.8"/></emitter>
  <shape type="rectangle"><transform name="to_world"><scale value="6"/><rotate x="1" angle="-90"/></transform></shape>
  {body}
</scene>"#
        )
    };
    let place = ["<translate x=\"-0.5\" z=\"-1\"/>", "<translate x=\"0.6\" y=\"0.1\" z=\"0.7\"/>"];
    let instanced = scene(format!(
        r#"<shape type="shapegroup" id="g">{}</shape>
           <shape type="instance"><ref id="g"/><transform name="to_world">{}</transform></shape>
           <shape type="instance"><ref id="g"/><transform name="to_world">{}</transform></shape>"#,
        shapes(""),
        place[0],
        place[1]
    ));
    let flattened = scene(
        place.iter().map(|p| shapes(&format!("<transform name=\"to_world\">{p}</transform>"))).collect::<String>(),
    );
    std::fs::write(dir.join("instanced.xml"), instanced).unwrap();
    std::fs::write(dir.join("flattened.xml"), flattened).unwrap();
    let a = common::render_with_variance(&dir.join("instanced.xml"), 16, 2, None, 5);
    let b = common::render_with_variance(&dir.join("flattened.xml"), 16, 2, None, 5);
    let n = a.mean.len();
    let close =
        a.mean.iter().zip(&b.mean).filter(|(x, y)| (0..3).all(|c| (x[c] - y[c]).abs() < 1e-3 * (1.0 + y[c]))).count();
    assert!(close as f64 >= 0.97 * n as f64, "{close} of {n} pixels agree");
    // The shapes are really there: the image differs from the floor alone.
    let floor = common::render_with_variance(
        &{
            let p = dir.join("floor.xml");
            std::fs::write(&p, scene(String::new())).unwrap();
            p
        },
        16,
        2,
        None,
        5,
    );
    let differ = a.mean.iter().zip(&floor.mean).filter(|(x, y)| (x[0] - y[0]).abs() > 0.02).count();
    assert!(differ > n / 10, "only {differ} of {n} pixels show the shapes");
}
