//! The stream integrator (paths in flight per tile, rays traced in packets)
//! against the one-path-at-a-time loop it replaces: on every scene of
//! tests/scenes and the bundled scenes, the film (beauty, every AOV layer,
//! variance moments) and the ray counts must be bitwise equal, for a first
//! pass and for a later sample range, with packets of every lane width the
//! build has (16 with AVX-512, 8 with AVX2, and 1, scalar, on any CPU).

use crate::common::root;
use penumbra_render::film::{AovKind, Film, FilmLayers};
use penumbra_render::render::LANE_WIDTHS;
use penumbra_scene::{load_scene, Overrides};
use std::path::Path;

fn bits(v: impl IntoIterator<Item = f32>) -> Vec<u32> {
    v.into_iter().map(f32::to_bits).collect()
}

/// Renders `scene` both ways; panics at the first difference. Returns
/// whether the scene's integrator is `path` (the others render one way),
/// and how many vertices the packets of more than one lane shaded in lanes.
fn check(scene: &Path, defines: &[(String, String)], spp: u32) -> (bool, u64) {
    let (is_path, lane_vertices, _) = check_counting(scene, defines, spp);
    (is_path, lane_vertices)
}

/// [`check`], also returning the closest-hit rays those packets traced.
fn check_counting(scene: &Path, defines: &[(String, String)], spp: u32) -> (bool, u64, u64) {
    check_integrator(scene, defines, spp, None)
}

/// [`check_counting`] with the scene's integrator replaced by `integrator`
/// (as `--integrator`).
fn check_integrator(
    scene: &Path,
    defines: &[(String, String)],
    spp: u32,
    integrator: Option<&str>,
) -> (bool, u64, u64) {
    let ov = Overrides { spp: Some(spp), integrator: integrator.map(str::to_string), ..Default::default() };
    let mut job = load_scene(scene, defines, &ov).unwrap_or_else(|e| panic!("{e}"));
    let layers = FilmLayers { aovs: AovKind::ALL.to_vec(), variance: true, ..Default::default() };
    let name = scene.file_name().unwrap().to_string_lossy();
    let is_path = matches!(job.integrator, penumbra_render::integrator::Integrator::Path(_));
    let (mut lane_vertices, mut rays) = (0, 0);
    for range in [0..spp, 3..spp] {
        let render = |job: &penumbra_render::render::RenderJob| {
            let mut film = Film::with_layers(job.width, job.height, &layers);
            let stats = job.render_into(&mut film, range.clone(), &|_| {});
            (film, stats)
        };
        job.stream = false;
        let (a, sa) = render(&job);
        for &lanes in LANE_WIDTHS {
            job.stream = true;
            job.packet_lanes = lanes;
            let (b, sb) = render(&job);
            if lanes > 1 {
                lane_vertices += sb.rays.lane_vertices;
                rays += sb.rays.rays;
            }
            let (a, sa, b, sb) = (&a, &sa, &b, &sb);
            let what = format!("{name}, samples {range:?}, packets of {lanes}");
            assert_eq!(
                (sa.samples, sa.rays.rays, sa.rays.shadow_rays, sa.non_finite),
                (sb.samples, sb.rays.rays, sb.rays.shadow_rays, sb.non_finite),
                "{what}: ray counts"
            );
            assert!(bits(a.develop().concat()) == bits(b.develop().concat()), "{what}: beauty differs");
            for k in AovKind::ALL {
                assert!(
                    bits(a.develop_aov(k).unwrap()) == bits(b.develop_aov(k).unwrap()),
                    "{what}: AOV {} differs",
                    k.name()
                );
            }
            assert!(
                bits(a.develop_variance().unwrap().concat()) == bits(b.develop_variance().unwrap().concat()),
                "{what}: variance differs"
            );
            assert!(a.develop().iter().flatten().any(|&c| c > 0.0), "{what}: a black image proves little");
        }
    }
    (is_path, lane_vertices, rays)
}

/// The lane tests' scene around `body`: `path` (max_depth 6), a 48x32
/// camera of fov `camera.0` at `camera.1` looking at `camera.2`, 8 spp, the
/// environment map `env` at half strength and a down-facing rectangle light
/// translated by `light` (attributes of `translate`).
fn lit_scene(env: &Path, camera: (&str, &str, &str), light: &str, body: &str) -> String {
    let (fov, origin, target) = camera;
    format!(
        r#"<scene version="3.0.0">
    <integrator type="path"><integer name="max_depth" value="6"/></integrator>
    <sensor type="perspective">
        <float name="fov" value="{fov}"/>
        <transform name="to_world"><lookat origin="{origin}" target="{target}" up="0, 1, 0"/></transform>
        <sampler type="independent"><integer name="sample_count" value="8"/></sampler>
        <film type="hdrfilm"><integer name="width" value="48"/><integer name="height" value="32"/></film>
    </sensor>
    <emitter type="envmap"><string name="filename" value="{}"/><float name="scale" value="0.5"/></emitter>
    <shape type="rectangle">
        <transform name="to_world"><scale value="0.5"/><rotate x="1" angle="90"/><translate {light}/></transform>
        <emitter type="area"><rgb name="radiance" value="6, 6, 5"/></emitter>
    </shape>
    {body}
</scene>"#,
        env.display()
    )
}

#[test]
fn stream_is_bitwise_the_scalar_loop_on_every_test_scene() {
    let mut scenes: Vec<_> = std::fs::read_dir(root().join("tests/scenes"))
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|e| e == "xml"))
        .collect();
    scenes.sort();
    assert!(scenes.len() >= 15, "tests/scenes has {} scenes", scenes.len());
    let res = |n: &str| vec![("res".to_string(), n.to_string())];
    let (mut path_scenes, mut lane_scenes) = (0, 0);
    let mut tally = |(is_path, lane_vertices): (bool, u64)| {
        path_scenes += is_path as usize;
        lane_scenes += (lane_vertices > 0) as usize;
    };
    for s in &scenes {
        tally(check(s, &[], 8));
    }
    for s in ["scenes/cornell-box.xml", "scenes/material-showcase.xml"] {
        tally(check(&root().join(s), &res("48"), 8));
    }
    eprintln!(
        "{} scenes, {path_scenes} rendered by `path` both ways (packets of {LANE_WIDTHS:?}), \
         {lane_scenes} with vertices shaded in lanes: bitwise equal",
        scenes.len() + 2
    );
    assert!(path_scenes >= 10);
    // Diffuse vertices (the Cornell boxes') run in lanes where packets are wider than 1.
    assert!(LANE_WIDTHS.len() == 1 || lane_scenes >= 3, "{lane_scenes} scenes had lane vertices");
}

/// Resampled light selection: bitwise the one-path loop, with each light
/// selection and with a guide. Vertices whose candidates are all area
/// lights on meshes and spheres run in lanes (many_lights, glass_caustic);
/// the others (the light BVH's, more than `MAX_LANE_CANDIDATES`, point
/// lights) run the scalar vertex inside the stream.
#[test]
fn resampled_light_selection_is_bitwise_the_scalar_loop() {
    let scenes = root().join("tests/scenes");
    for (scene, integrator, in_lanes) in [
        ("many_lights.xml", "path:max_depth=4,light_candidates=4", true),
        ("many_lights.xml", "path:max_depth=4,light_candidates=8,guiding=true", true),
        ("many_lights.xml", "path:max_depth=4,light_candidates=9", false),
        ("many_lights.xml", "path:max_depth=4,light_candidates=3,light_selection=bvh,guiding=true", false),
        ("glass_caustic.xml", "path:max_depth=8,light_candidates=2,light_selection=power", true),
        ("point_light.xml", "path:max_depth=4,light_candidates=5", false),
    ] {
        let (_, lane_vertices, rays) = check_integrator(&scenes.join(scene), &[], 8, Some(integrator));
        eprintln!("{scene} {integrator}: {lane_vertices} of {rays} hits shaded in lanes");
        if LANE_WIDTHS.len() > 1 && scene == "many_lights.xml" {
            // Its materials are all diffuse: lit vertices or none in lanes.
            // (Emitters hit and escapes stay scalar.)
            let share = lane_vertices as f64 / rays as f64;
            assert!(if in_lanes { share > 0.25 } else { share < 0.05 }, "{scene} {integrator}: {share} in lanes");
        }
    }
}

/// Resampled light selection in lanes on every lane material: the
/// lane-kinds scene without its environment map (which has no resampled
/// lane kernel), so that every candidate is an area light on a mesh or a
/// sphere, mixed within a batch; bitwise the scalar vertex, with uniform
/// selection (its lights and triangles picked in the kernel, from the
/// scene's `LaneLightTable`) and power selection (picked per vertex), 1 to
/// 8 candidates and a guide (each lobe guided or not by its roughness).
#[test]
fn resampled_lane_vertices_are_bitwise_the_scalar_vertex() {
    let env = root().join("tests/scenes/textures/sunsky.exr");
    let xml = lane_kinds_xml(&env);
    let envmap = xml.lines().find(|l| l.contains(r#"<emitter type="envmap">"#)).unwrap();
    let xml = xml.replace(envmap, "");
    let dir = std::env::temp_dir().join(format!("penumbra-lane-kinds-ris-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let scene = dir.join("lane_kinds_ris.xml");
    std::fs::write(&scene, xml).unwrap();
    for integrator in [
        "path:max_depth=6,light_candidates=3",
        "path:max_depth=6,light_candidates=8,light_selection=power",
        "path:max_depth=6,light_candidates=2,guiding=true,guiding_budget=0.25",
        // Every rough lobe guided; and a batch's lanes guided or not by
        // their roughness (GGX conductors 0.25 against 0.05-0.08, dielectrics 0.2 against 0.05).
        "path:max_depth=6,light_candidates=2,guiding=true,guiding_budget=0.25,guiding_min_roughness=0",
        "path:max_depth=6,light_candidates=1,guiding=true,guiding_budget=0.25,guiding_min_roughness=0.1",
        "path:max_depth=6,light_candidates=1",
        "path:max_depth=6,light_candidates=1,light_selection=power",
    ] {
        let (is_path, lane_vertices, rays) = check_integrator(&scene, &[], 8, Some(integrator));
        eprintln!("{integrator}: {lane_vertices} of {rays} hits shaded in lanes");
        assert!(is_path);
        assert!(LANE_WIDTHS.len() == 1 || lane_vertices * 3 > rays, "{integrator}: {lane_vertices} of {rays}");
    }
    std::fs::remove_dir_all(&dir).ok();
}

/// Every kind of lane vertex at once: spheres, rectangles (meshes) and
/// disks with diffuse (on a checkerboard-textured floor too), smooth conductor, smooth dielectric, rough
/// conductor and dielectric (GGX and Beckmann, isotropic and anisotropic: the latter in lanes on spheres)
/// plastic (linear and nonlinear) and rough plastic (GGX and Beckmann) materials, lit by a rectangle area light, a small sphere area
/// light (sampled by its cone), a large sphere area light around everything
/// (sampled by area from inside) and an environment map, each picked a
/// quarter of the time, so that every bin of the lane kernels runs and must
/// match the scalar vertex bit for bit.
#[test]
fn every_lane_vertex_kind_is_bitwise_the_scalar_vertex() {
    let env = root().join("tests/scenes/textures/sunsky.exr");
    let xml = lane_kinds_xml(&env);
    let dir = std::env::temp_dir().join(format!("penumbra-lane-kinds-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let scene = dir.join("lane_kinds.xml");
    std::fs::write(&scene, xml).unwrap();
    let (is_path, lane_vertices) = check(&scene, &[], 8);
    std::fs::remove_dir_all(&dir).ok();
    eprintln!("{lane_vertices} lane vertices");
    assert!(is_path);
    assert!(LANE_WIDTHS.len() == 1 || lane_vertices > 10_000, "{lane_vertices} lane vertices");
}

/// The scene of [`every_lane_vertex_kind_is_bitwise_the_scalar_vertex`].
fn lane_kinds_xml(env: &Path) -> String {
    let materials = [
        r#"<bsdf type="diffuse"><rgb name="reflectance" value="0.7, 0.5, 0.3"/></bsdf>"#,
        r#"<bsdf type="conductor"><string name="material" value="Cu"/></bsdf>"#,
        r#"<bsdf type="dielectric"><float name="int_ior" value="1.5"/></bsdf>"#,
        r#"<bsdf type="roughconductor"><string name="material" value="Au"/><string name="distribution" value="ggx"/><float name="alpha" value="0.25"/></bsdf>"#,
        r#"<bsdf type="roughdielectric"><string name="distribution" value="ggx"/><float name="alpha" value="0.2"/><float name="int_ior" value="1.5"/></bsdf>"#,
        r#"<bsdf type="roughdielectric"><string name="distribution" value="ggx"/><float name="alpha" value="0.05"/><float name="int_ior" value="1.33"/><rgb name="specular_transmittance" value="0.9, 0.7, 0.5"/></bsdf>"#,
        r#"<bsdf type="roughconductor"><string name="material" value="Cu"/><string name="distribution" value="beckmann"/><float name="alpha" value="0.3"/></bsdf>"#,
        r#"<bsdf type="roughconductor"><string name="material" value="Al"/><float name="alpha_u" value="0.05"/><float name="alpha_v" value="0.35"/></bsdf>"#,
        r#"<bsdf type="roughconductor"><string name="material" value="Ag"/><string name="distribution" value="ggx"/><float name="alpha_u" value="0.3"/><float name="alpha_v" value="0.08"/></bsdf>"#,
        r#"<bsdf type="roughdielectric"><string name="distribution" value="beckmann"/><float name="alpha" value="0.15"/><float name="int_ior" value="1.5"/></bsdf>"#,
        r#"<bsdf type="roughdielectric"><string name="distribution" value="ggx"/><float name="alpha_u" value="0.05"/><float name="alpha_v" value="0.3"/><float name="int_ior" value="1.4"/></bsdf>"#,
        r#"<bsdf type="plastic"><rgb name="diffuse_reflectance" value="0.2, 0.4, 0.7"/></bsdf>"#,
        r#"<bsdf type="plastic"><rgb name="diffuse_reflectance" value="0.6, 0.3, 0.1"/><float name="int_ior" value="1.7"/><boolean name="nonlinear" value="true"/></bsdf>"#,
        r#"<bsdf type="roughplastic"><string name="distribution" value="ggx"/><float name="alpha" value="0.2"/><rgb name="diffuse_reflectance" value="0.3, 0.6, 0.2"/></bsdf>"#,
        r#"<bsdf type="roughplastic"><string name="distribution" value="beckmann"/><float name="alpha" value="0.3"/><float name="int_ior" value="1.6"/><rgb name="diffuse_reflectance" value="0.7, 0.2, 0.2"/><boolean name="nonlinear" value="true"/></bsdf>"#,
        r#"<bsdf type="roughplastic"><string name="distribution" value="ggx"/><float name="alpha" value="0.08"/><float name="int_ior" value="1.33"/><rgb name="specular_reflectance" value="0.8, 0.9, 1.0"/></bsdf>"#,
    ];
    let mut shapes = String::new();
    for (k, m) in materials.iter().enumerate() {
        // Two rows; the second's rectangles and disks shifted. The disks
        // are coplanar and overlap their neighbours, so rays tie between
        // two of them (decided by shape id in both traversals).
        let row = (k / 7) as f32;
        let (x, z) = ((k % 7) as f32 * 0.58 - 1.74, 0.6 * row);
        let (xr, yd) = (x + 0.29 * row, 0.001);
        shapes += &format!(
            r#"<shape type="sphere"><point name="center" x="{x}" y="0.24" z="{z}"/><float name="radius" value="0.24"/>{m}</shape>
            <shape type="rectangle"><transform name="to_world"><scale value="0.24"/><rotate y="1" angle="20"/><translate x="{xr}" y="1.1" z="-0.6"/></transform>{m}</shape>
            <shape type="disk"><transform name="to_world"><scale value="0.24"/><rotate x="1" angle="-90"/><translate x="{xr}" y="{yd}" z="0.9"/></transform>{m}</shape>
"#
        );
    }
    lit_scene(
        env,
        ("50", "0, 1.6, 4.5", "0, 0.5, 0"),
        r#"y="2.5""#,
        &format!(
            r#"<shape type="sphere">
        <point name="center" x="1.5" y="2.2" z="1"/><float name="radius" value="0.2"/>
        <emitter type="area"><rgb name="radiance" value="9, 7, 5"/></emitter>
    </shape>
    <shape type="sphere">
        <float name="radius" value="30"/><boolean name="flip_normals" value="true"/>
        <emitter type="area"><rgb name="radiance" value="0.05, 0.06, 0.08"/></emitter>
    </shape>
    <shape type="rectangle">
        <transform name="to_world"><scale value="4"/><rotate x="1" angle="-90"/><rotate y="1" angle="30"/></transform>
        <bsdf type="diffuse">
            <texture type="checkerboard" name="reflectance">
                <rgb name="color0" value="0.8, 0.7, 0.6"/><rgb name="color1" value="0.2, 0.3, 0.4"/>
                <transform name="to_uv"><scale x="6" y="6"/></transform>
            </texture>
        </bsdf>
    </shape>
    {shapes}"#
        ),
    )
}

/// An open bowl (the half of a UV sphere below z = 0, the opening facing
/// +z) as an OBJ with vertex normals (outwards) and texture coordinates:
/// a smooth mesh whose inside is seen from below its normals.
fn bowl_obj() -> String {
    let (rings, segments) = (5, 12);
    let mut obj = String::new();
    for i in 0..=rings {
        let theta = std::f32::consts::FRAC_PI_2 * (1.0 + i as f32 / rings as f32);
        for j in 0..=segments {
            let phi = std::f32::consts::TAU * j as f32 / segments as f32;
            let n = [theta.sin() * phi.cos(), theta.sin() * phi.sin(), theta.cos()];
            obj += &format!("v {} {} {}\nvn {} {} {}\n", n[0], n[1], n[2], n[0], n[1], n[2]);
            obj += &format!("vt {} {}\n", j as f32 / segments as f32, i as f32 / rings as f32);
        }
    }
    let at = |i: usize, j: usize| i * (segments + 1) + j + 1;
    for i in 0..rings {
        for j in 0..segments {
            let (a, b, c, d) = (at(i, j), at(i, j + 1), at(i + 1, j + 1), at(i + 1, j));
            obj += &format!("f {a}/{a}/{a} {b}/{b}/{b} {c}/{c}/{c}\nf {a}/{a}/{a} {c}/{c}/{c} {d}/{d}/{d}\n");
        }
    }
    obj
}

/// Smooth meshes (vertex normals, so the shading normal is interpolated)
/// and two-sided materials in lanes: bowls seen inside and out, each
/// material of the lane kernels one-sided and in `twosided`, and a
/// checkerboard-textured bowl, under an area light and an environment map.
/// Bitwise the scalar vertex, and most hits shaded in lanes (without the
/// smooth-mesh kinds, none of these would be).
#[test]
fn smooth_and_two_sided_meshes_are_bitwise_the_scalar_vertex_in_lanes() {
    let env = root().join("tests/scenes/textures/sunsky.exr");
    let materials = [
        r#"<bsdf type="diffuse"><rgb name="reflectance" value="0.7, 0.5, 0.3"/></bsdf>"#,
        r#"<bsdf type="conductor"><string name="material" value="Cu"/></bsdf>"#,
        r#"<bsdf type="dielectric"><float name="int_ior" value="1.5"/></bsdf>"#,
        r#"<bsdf type="roughconductor"><string name="material" value="Au"/><float name="alpha" value="0.25"/></bsdf>"#,
        r#"<bsdf type="roughdielectric"><string name="distribution" value="beckmann"/><float name="alpha" value="0.2"/><float name="int_ior" value="1.5"/></bsdf>"#,
        r#"<bsdf type="plastic"><rgb name="diffuse_reflectance" value="0.2, 0.4, 0.7"/></bsdf>"#,
        r#"<bsdf type="roughplastic"><float name="alpha" value="0.2"/><rgb name="diffuse_reflectance" value="0.3, 0.6, 0.2"/></bsdf>"#,
    ];
    let textured = r#"<bsdf type="diffuse"><texture type="checkerboard" name="reflectance">
        <rgb name="color0" value="0.8, 0.7, 0.6"/><rgb name="color1" value="0.2, 0.3, 0.4"/>
        <transform name="to_uv"><scale x="4" y="4"/></transform></texture></bsdf>"#
        .to_string();
    let mut bsdfs: Vec<String> = materials.iter().map(|m| m.to_string()).collect();
    bsdfs.extend(materials.iter().map(|m| format!(r#"<bsdf type="twosided">{m}</bsdf>"#)));
    bsdfs.push(textured);
    let dir = std::env::temp_dir().join(format!("penumbra-lane-bowls-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    std::fs::write(dir.join("bowl.obj"), bowl_obj()).unwrap();
    let mut shapes = String::new();
    for (k, m) in bsdfs.iter().enumerate() {
        // Three rows of five, tilted towards the camera, some turned away.
        let (x, y) = ((k % 5) as f32 * 0.62 - 1.24, (k / 5) as f32 * 0.62 - 0.3);
        let turn = if k % 3 == 2 { 150 } else { 25 };
        shapes += &format!(
            r#"<shape type="obj"><string name="filename" value="bowl.obj"/>
            <transform name="to_world"><scale value="0.3"/><rotate x="1" angle="-{turn}"/><translate x="{x}" y="{y}"/></transform>{m}</shape>
"#
        );
    }
    let xml = lit_scene(
        &env,
        ("45", "0, 0.3, 4", "0, 0.3, 0"),
        r#"y="2.5" z="1""#,
        &format!(
            r#"<shape type="rectangle">
        <transform name="to_world"><scale value="5"/><translate z="-1"/></transform>
        <bsdf type="diffuse"/>
    </shape>
    {shapes}"#
        ),
    );
    let scene = dir.join("bowls.xml");
    std::fs::write(&scene, &xml).unwrap();
    let (is_path, lane_vertices, rays) = check_counting(&scene, &[], 8);
    eprintln!("{lane_vertices} of {rays} hits shaded in lanes");
    assert!(is_path);
    assert!(LANE_WIDTHS.len() == 1 || lane_vertices * 2 > rays, "{lane_vertices} of {rays} hits in lanes");
    // Guided: the passes after training shade their vertices in lanes with
    // the guide (its density mixed into every MIS weight, its directions
    // drawn where picked), bitwise `vertex_guided`.
    let plain = r#"<integrator type="path"><integer name="max_depth" value="6"/></integrator>"#;
    let guided = r#"<integrator type="path"><integer name="max_depth" value="6"/><boolean name="guiding" value="true"/><float name="guiding_budget" value="0.25"/></integrator>"#;
    assert!(xml.contains(plain));
    let scene = dir.join("bowls_guided.xml");
    std::fs::write(&scene, xml.replace(plain, guided)).unwrap();
    let (_, lane_vertices, rays) = check_counting(&scene, &[], 16);
    std::fs::remove_dir_all(&dir).ok();
    eprintln!("guided: {lane_vertices} of {rays} hits shaded in lanes");
    assert!(LANE_WIDTHS.len() == 1 || lane_vertices * 3 > rays, "guided: {lane_vertices} of {rays} hits in lanes");
}
