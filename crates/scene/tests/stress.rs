//! Degenerate and grazing geometry: scenes full of zero-area triangles,
//! coincident vertices, zero-scale shapes, grazing cameras and near-delta
//! roughness render with zero non-finite samples, and degenerate emitters
//! are refused with a message naming file and line.

use penumbra_render::film::Film;
use penumbra_scene::{load_scene, Overrides};
use std::path::PathBuf;

fn dir(test: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("penumbra-stress-{test}-{}", std::process::id()));
    std::fs::create_dir_all(&d).unwrap();
    // A zero-area triangle (collinear), one with three coincident vertices, and a good one.
    std::fs::write(
        d.join("degen.ply"),
        "ply\nformat ascii 1.0\nelement vertex 6\nproperty float x\nproperty float y\nproperty float z\n\
         element face 3\nproperty list uchar int vertex_indices\nend_header\n\
         0 0 0\n1 0 0\n2 0 0\n0 1 0\n0 1 0\n0 1 0\n3 0 1 2\n3 3 4 5\n3 0 1 3\n",
    )
    .unwrap();
    d
}

fn scene(camera_y: f32, shapes: &str) -> String {
    format!(
        r#"<scene version="3.0.0">
    <integrator type="path"><integer name="max_depth" value="8"/></integrator>
    <sensor type="perspective">
        <float name="fov" value="60"/>
        <transform name="to_world"><lookat origin="0, {camera_y}, 4" target="0, 0, 0" up="0, 1, 0"/></transform>
        <sampler type="independent"><integer name="sample_count" value="32"/></sampler>
        <film type="hdrfilm"><integer name="width" value="32"/><integer name="height" value="32"/></film>
    </sensor>
    <emitter type="constant"><rgb name="radiance" value="0.5"/></emitter>
    <emitter type="point"><point name="position" x="0" y="0" z="0"/><rgb name="intensity" value="3"/></emitter>
{shapes}
</scene>"#
    )
}

const DEGENERATE: &str = r#"
    <shape type="rectangle"><transform name="to_world"><rotate x="1" angle="-90"/><scale value="10"/></transform>
        <bsdf type="roughconductor"><float name="alpha" value="0.001"/></bsdf></shape>
    <shape type="ply"><string name="filename" value="degen.ply"/>
        <bsdf type="roughdielectric"><float name="alpha" value="0.5"/></bsdf></shape>
    <shape type="ply"><string name="filename" value="degen.ply"/><boolean name="face_normals" value="true"/>
        <transform name="to_world"><translate x="-1.5"/></transform><emitter type="area"><rgb name="radiance" value="2"/></emitter></shape>
    <shape type="sphere"><float name="radius" value="0.3"/><transform name="to_world"><scale value="0"/></transform><bsdf type="diffuse"/></shape>
    <shape type="disk"><transform name="to_world"><translate y="0.5"/></transform><bsdf type="dielectric"/></shape>
    <shape type="cube"><transform name="to_world"><scale value="0.2"/><translate x="-1" y="0.2"/></transform><bsdf type="plastic"/></shape>
    <shape type="sphere"><point name="center" x="1" y="0.3" z="0"/><float name="radius" value="0.3"/>
        <bsdf type="roughplastic"><float name="alpha" value="1e-6"/></bsdf></shape>
    <shape type="sphere"><point name="center" x="0" y="0.3" z="1"/><float name="radius" value="1e-7"/><bsdf type="conductor"/></shape>
"#;

#[test]
fn degenerate_and_grazing_scenes_have_no_non_finite_samples() {
    let d = dir("render");
    // Cameras above the ground plane, barely above it, and exactly in it.
    for (i, y) in [1.0f32, 1e-3, 0.0].into_iter().enumerate() {
        let path = d.join(format!("stress{i}.xml"));
        std::fs::write(&path, scene(y, DEGENERATE)).unwrap();
        let job = load_scene(&path, &[], &Overrides::default()).unwrap_or_else(|e| panic!("{e}"));
        let mut film = Film::new(job.width, job.height);
        let stats = job.render_into(&mut film, 0..job.sampler.spp, &|_| {});
        assert_eq!(stats.non_finite, 0, "camera at y = {y}: {} non-finite samples", stats.non_finite);
        assert!(stats.samples > 0);
        assert!(film.develop().iter().flatten().all(|v| v.is_finite() && *v >= 0.0), "camera at y = {y}");
    }
    std::fs::remove_dir_all(&d).ok();
}

#[test]
fn degenerate_emitters_are_refused_with_file_and_line() {
    let d = dir("emitters");
    for (i, shape) in [
        r#"<shape type="sphere"><float name="radius" value="0"/><emitter type="area"><rgb name="radiance" value="5"/></emitter></shape>"#,
        r#"<shape type="rectangle"><transform name="to_world"><scale x="0" y="1" z="1"/></transform><emitter type="area"><rgb name="radiance" value="5"/></emitter></shape>"#,
    ]
    .into_iter()
    .enumerate()
    {
        let path = d.join(format!("emitter{i}.xml"));
        std::fs::write(&path, scene(1.0, shape)).unwrap();
        let e = load_scene(&path, &[], &Overrides::default()).err().expect("a zero-area emitter must be refused").to_string();
        assert!(e.contains(&format!("emitter{i}.xml:11:")) && e.contains("zero area"), "{e}");
    }
    std::fs::remove_dir_all(&d).ok();
}
