//! Media in scene files: attachment as Mitsuba 3.9.1 does it (shape
//! interior/exterior, the sensor's medium, top-level media by id), and a
//! clear error naming file and line for every malformed medium.

use penumbra_render::integrator::Integrator;
use penumbra_render::medium::{MediumKind, PhaseFunction};
use penumbra_scene::builder::{build, Overrides};
use penumbra_scene::mitsuba::parse_str;
use std::path::Path;

const SENSOR: &str = r#"<sensor type="perspective"><film type="hdrfilm"><integer name="width" value="8"/><integer name="height" value="8"/></film>SENSOR_MEDIUM</sensor>"#;

fn load_in(body: &str, sensor_medium: &str, dir: &Path) -> Result<penumbra_render::render::RenderJob, String> {
    let xml = format!(
        "<scene version=\"3.0.0\">\n<integrator type=\"volpath\"/>\n{}\n{body}\n</scene>",
        SENSOR.replace("SENSOR_MEDIUM", sensor_medium)
    );
    let desc = parse_str(&xml, &dir.join("media.xml"), &[]).map_err(|e| e.to_string())?;
    build(&desc, &Overrides::default()).map_err(|e| e.to_string())
}

fn load(body: &str, sensor_medium: &str) -> Result<penumbra_render::render::RenderJob, String> {
    load_in(body, sensor_medium, Path::new("."))
}

const FOG: &str = r#"<medium type="homogeneous" id="fog"><rgb name="sigma_t" value="0.5, 0.25, 1"/><float name="scale" value="2"/><phase type="hg"><float name="g" value="0.3"/></phase></medium>"#;

#[test]
fn media_attach_to_shapes_and_the_sensor_as_in_mitsuba() {
    let body = format!(
        r#"{FOG}
<shape type="sphere"><bsdf type="null"/><ref name="interior" id="fog"/></shape>
<shape type="cube"><bsdf type="dielectric"/>
  <medium type="homogeneous" name="interior"><float name="sigma_t" value="3"/><boolean name="sample_emitters" value="false"/></medium>
  <ref name="exterior" id="fog"/></shape>
<shape type="rectangle"/>"#
    );
    let job = load(&body, r#"<ref id="fog"/>"#).unwrap();
    assert!(matches!(job.integrator, Integrator::VolPath(_)));
    let scene = &job.scene;
    assert_eq!(scene.media.len(), 2, "the shared fog is built once");
    assert_eq!(scene.camera_medium, Some(0));
    let m = |i: u32| scene.shape_media(i);
    assert_eq!((m(0).interior, m(0).exterior), (Some(0), None));
    assert_eq!((m(1).interior, m(1).exterior), (Some(1), Some(0)));
    assert!(!m(2).is_transition(), "a shape without media changes nothing");
    match &scene.media[0].kind {
        MediumKind::Homogeneous { sigma_t, albedo } => {
            assert_eq!(sigma_t.to_array(), [1.0, 0.5, 2.0], "scale multiplies sigma_t");
            assert_eq!(albedo.to_array(), [0.75; 3], "Mitsuba's default albedo");
        }
        k => panic!("{k:?}"),
    }
    assert_eq!(scene.media[0].phase, PhaseFunction::HenyeyGreenstein { g: 0.3 });
    assert!(scene.media[0].sample_emitters && !scene.media[1].sample_emitters);
    assert_eq!(scene.media[1].phase, PhaseFunction::Isotropic, "the default phase");
    // Without the sensor's medium the camera sits in vacuum.
    let job = load(&body, "").unwrap();
    assert_eq!(job.scene.camera_medium, None);
}

#[test]
fn grid_volumes_load_and_place_their_unit_cube() {
    let dir = std::env::temp_dir().join(format!("penumbra-media-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let grid = penumbra_render::medium::Grid {
        res: [2, 2, 2],
        channels: 1,
        data: vec![0.0, 1.0, 2.0, 3.0, 4.0, 5.0, 6.0, 8.0],
    };
    let bbox = penumbra_render::geometry::Aabb { min: glam::Vec3::ZERO, max: glam::Vec3::ONE };
    std::fs::write(dir.join("g.vol"), penumbra_scene::vol::encode(&grid, &bbox)).unwrap();
    let body = r#"<shape type="cube"><bsdf type="null"/><medium type="heterogeneous" name="interior">
  <volume type="gridvolume" name="sigma_t"><string name="filename" value="g.vol"/><string name="filter_type" value="nearest"/>
    <transform name="to_world"><scale value="2"/><translate x="-1" y="-1" z="-1"/></transform></volume>
  <float name="scale" value="0.5"/></medium></shape>"#;
    let job = load_in(body, "", &dir).unwrap();
    match &job.scene.media[0].kind {
        MediumKind::Heterogeneous { sigma_t, majorant, .. } => {
            assert_eq!(*majorant, 4.0, "scale times the grid's maximum");
            assert_eq!(sigma_t.bounds().min.to_array(), [-1.0; 3]);
            assert_eq!(sigma_t.bounds().max.to_array(), [1.0; 3]);
            // Voxel (1, 1, 1) is the corner at +x +y +z.
            assert_eq!(sigma_t.eval(glam::Vec3::splat(0.5)).x, 8.0);
            assert_eq!(sigma_t.eval(glam::Vec3::new(0.5, -0.5, -0.5)).x, 1.0);
        }
        k => panic!("{k:?}"),
    }
    // A truncated file: the error names the scene line and what is wrong.
    let bytes = std::fs::read(dir.join("g.vol")).unwrap();
    std::fs::write(dir.join("g.vol"), &bytes[..bytes.len() - 3]).unwrap();
    let e = load_in(body, "", &dir).unwrap_err();
    assert!(e.contains("media.xml") && e.contains("g.vol") && e.contains("truncated"), "{e}");
    std::fs::remove_dir_all(&dir).ok();
}

/// The phase functions of Mitsuba 3.9.1 with their parameters: rayleigh,
/// tabphase's string of values, sggx's 6-channel grid.
#[test]
fn rayleigh_tabphase_and_sggx_load() {
    let dir = std::env::temp_dir().join(format!("penumbra-phase-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let bbox = penumbra_render::geometry::Aabb { min: glam::Vec3::ZERO, max: glam::Vec3::ONE };
    // One voxel: S = [[1, 0.2, -0.1], [0.2, 0.5, 0], [-0.1, 0, 0.3]] (off-diagonals may be negative).
    let s = vec![1.0, 0.5, 0.3, 0.2, -0.1, 0.0];
    let grid = penumbra_render::medium::Grid { res: [1, 1, 1], channels: 6, data: s.clone() };
    std::fs::write(dir.join("s.vol"), penumbra_scene::vol::encode(&grid, &bbox)).unwrap();
    let grey = penumbra_render::medium::Grid { res: [1, 1, 1], channels: 1, data: vec![1.0] };
    std::fs::write(dir.join("grey.vol"), penumbra_scene::vol::encode(&grey, &bbox)).unwrap();
    let body = r#"<medium type="homogeneous" id="a"><phase type="rayleigh"/></medium>
<medium type="homogeneous" id="b"><phase type="tabphase"><string name="values" value="0.5, 1,2 4"/></phase></medium>
<medium type="homogeneous" id="c"><phase type="sggx"><volume type="gridvolume" name="S"><string name="filename" value="s.vol"/><string name="filter_type" value="nearest"/></volume></phase></medium>
<shape type="sphere"><bsdf type="null"/><ref name="interior" id="a"/></shape>
<shape type="sphere"><bsdf type="null"/><ref name="interior" id="b"/></shape>
<shape type="sphere"><bsdf type="null"/><ref name="interior" id="c"/></shape>"#;
    let job = load_in(body, "", &dir).unwrap();
    let media = &job.scene.media;
    assert_eq!(media[0].phase, PhaseFunction::Rayleigh);
    let (wi, o) = (glam::Vec3::Z, glam::Vec3::ZERO);
    match &media[1].phase {
        // Values at cos = -1, -1/3, 1/3, 1; ∫ = (2/3)·(0.75 + 1.5 + 3) = 3.5.
        PhaseFunction::Tabulated(t) => {
            let forward = t.eval(wi, -wi);
            assert!((forward - 4.0 / 3.5 / (2.0 * std::f32::consts::PI)).abs() < 1e-6, "{forward}");
        }
        p => panic!("{p:?}"),
    }
    match &media[2].phase {
        PhaseFunction::Sggx(g) => assert_eq!(g.s.eval6(o).to_vec(), s),
        p => panic!("{p:?}"),
    }
    // A 6-channel grid is no colour; a 1-channel grid is no S.
    let e = load_in(
        r#"<medium type="heterogeneous" id="m"><volume type="gridvolume" name="sigma_t"><string name="filename" value="s.vol"/></volume></medium>"#,
        "",
        &dir,
    )
    .unwrap_err();
    assert!(e.contains("media.xml:4:") && e.contains("6-channel"), "{e}");
    let e = load_in(
        r#"<medium type="homogeneous" id="m"><phase type="sggx"><volume type="gridvolume" name="S"><string name="filename" value="grey.vol"/></volume></phase></medium>"#,
        "",
        &dir,
    )
    .unwrap_err();
    assert!(e.contains("media.xml:4:") && e.contains("1 channel(s)"), "{e}");
    std::fs::remove_dir_all(&dir).ok();
}

/// Each malformed medium is refused with its file, line and the reason.
#[test]
fn malformed_media_are_errors_naming_the_position() {
    let cases: &[(&str, &str)] = &[
        (
            r#"<shape type="sphere"><medium type="homogeneous"/></shape>"#,
            "needs name=\"interior\" or name=\"exterior\"",
        ),
        (
            r#"<shape type="sphere"><medium type="homogeneous" name="interior"/><medium type="homogeneous" name="interior"/></shape>"#,
            "\"interior\" is specified more than once",
        ),
        (
            r#"<medium type="homogeneous" id="m"><phase type="hg"><float name="g" value="1"/></phase></medium>"#,
            "(-1, 1)",
        ),
        (r#"<medium type="homogeneous" id="m"><rgb name="sigma_t" value="2, 1, 1"/></medium>"#, "'scale'"),
        (r#"<medium type="homogeneous" id="m"><float name="sigma_t" value="-1"/></medium>"#, "not negative"),
        (r#"<medium type="homogeneous" id="m"><float name="density" value="1"/></medium>"#, "parameter 'density'"),
        (r#"<medium type="fog" id="m"/>"#, "supported medium plugins: homogeneous, heterogeneous"),
        (r#"<medium type="homogeneous" id="m"><phase type="mie"/></medium>"#, "supported phase plugins"),
        (
            r#"<medium type="homogeneous" id="m"><phase type="rayleigh"><float name="g" value="0.5"/></phase></medium>"#,
            "parameter 'g'",
        ),
        (r#"<medium type="homogeneous" id="m"><phase type="tabphase"/></medium>"#, "tabphase needs 'values'"),
        (
            r#"<medium type="homogeneous" id="m"><phase type="tabphase"><string name="values" value="1, 2, x"/></phase></medium>"#,
            "'x' (entry 2) is not a number",
        ),
        (
            r#"<medium type="homogeneous" id="m"><phase type="tabphase"><string name="values" value="1, -2"/></phase></medium>"#,
            "value 1 (-2)",
        ),
        (
            r#"<medium type="homogeneous" id="m"><phase type="tabphase"><string name="values" value="3"/></phase></medium>"#,
            "at least two",
        ),
        (
            r#"<medium type="homogeneous" id="m"><phase type="tabphase"><string name="values" value="0, 0, 0"/></phase></medium>"#,
            "no mass",
        ),
        (r#"<medium type="homogeneous" id="m"><phase type="sggx"/></medium>"#, "sggx needs 'S'"),
        (
            r#"<medium type="homogeneous" id="m"><phase type="sggx"><volume type="constvolume" name="S"/></phase></medium>"#,
            "6-channel gridvolume",
        ),
        (
            r#"<medium type="homogeneous" id="m"><volume type="gridvolume" name="sigma_t"><string name="filename" value="nowhere.vol"/></volume></medium>"#,
            "not found",
        ),
        (
            r#"<medium type="heterogeneous" id="m"><volume type="constvolume" name="sigma_t"><string name="filter_type" value="cubic"/></volume></medium>"#,
            "parameter 'filter_type'",
        ),
        (
            r#"<medium type="homogeneous" id="m"><phase type="blendphase"><phase type="isotropic"/></phase></medium>"#,
            "exactly two",
        ),
    ];
    for (body, want) in cases {
        let e = load(body, "").unwrap_err();
        assert!(e.contains("media.xml:"), "{body}: no position in {e}");
        assert!(e.contains(want), "{body}: {e:?} lacks {want:?}");
    }
}
