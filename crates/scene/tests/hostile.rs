//! Hostile numbers in scene parameters: NaN, infinities and values past the
//! single-precision range, whether written in the scene, in a spectrum file,
//! produced by a spectrum plugin or set by id, are errors naming the file and
//! line; spectrum plugins that would allocate without bound are refused.

use penumbra_scene::builder::{build, Overrides};
use penumbra_scene::desc::{Override, Value};
use penumbra_scene::mitsuba::parse_str;
use std::path::Path;

const SENSOR: &str = r#"<sensor type="perspective"><film type="hdrfilm"><integer name="width" value="2"/><integer name="height" value="2"/></film></sensor>"#;

/// Builds a scene whose third line is `body` (inside `<scene>`, after the
/// sensor); `Ok` or the error's text.
fn build_scene(body: &str, overrides: &[Override], dir: &Path) -> Result<(), String> {
    let xml = format!("<scene version=\"3.0.0\">\n{SENSOR}\n{body}\n</scene>");
    let desc = parse_str(&xml, &dir.join("hostile.xml"), &[]).map_err(|e| e.to_string())?;
    let desc = desc.with_overrides(overrides)?;
    build(&desc, &Overrides::default()).map(|_| ()).map_err(|e| e.to_string())
}

fn temp_dir(test: &str) -> std::path::PathBuf {
    let d = std::env::temp_dir().join(format!("penumbra-hostile-{test}-{}", std::process::id()));
    std::fs::create_dir_all(&d).unwrap();
    d
}

#[test]
fn non_finite_and_out_of_range_parameters_name_file_and_line() {
    let d = temp_dir("params");
    std::fs::write(d.join("nan.spd"), "# wavelength value\n400 0.5\n500 nan\n600 0.5\n").unwrap();
    std::fs::write(d.join("inf.spd"), "400 0.5\n500 0.5\n1e400 0.5\n").unwrap();
    let emitter = |spectrum: &str| format!(r#"<emitter type="constant">{spectrum}</emitter>"#);
    let cases = [
        // Past the single-precision range: infinite once built.
        (emitter(r#"<rgb name="radiance" value="1, 1e39, 1"/>"#), "hostile.xml:3:", "\"1e39\""),
        (
            r#"<shape type="sphere"><float name="radius" value="-4e38"/></shape>"#.to_string(),
            "hostile.xml:3:",
            "\"-4e38\"",
        ),
        (
            r#"<shape type="sphere"><transform name="to_world"><scale value="1e40"/></transform></shape>"#.to_string(),
            "hostile.xml:3:",
            "\"1e40\"",
        ),
        (emitter(r#"<spectrum name="radiance" value="400:1, 500:1e300"/>"#), "hostile.xml:3:", "500:1e300"),
        // Finite numbers whose product overflows single precision.
        (
            emitter(
                r#"<spectrum type="d65" name="radiance"><float name="scale" value="3e38"/><rgb name="color" value="10"/></spectrum>"#,
            ),
            "hostile.xml:3:",
            "not finite in single precision",
        ),
        // Finite coordinates and transforms whose product overflows.
        (
            r#"<shape type="cube"><transform name="to_world"><scale value="3e38"/><translate x="3e38"/></transform></shape>"#
                .to_string(),
            "hostile.xml:3:",
            "beyond single precision in world space",
        ),
        (
            r#"<shape type="sphere"><float name="radius" value="3e38"/><point name="center" x="3e38" y="0" z="0"/></shape>"#
                .to_string(),
            "hostile.xml:3:",
            "beyond single precision in world space",
        ),
        // A spectrum file with NaN or an overflowing number: its line.
        (emitter(r#"<spectrum name="radiance" filename="nan.spd"/>"#), "hostile.xml:3:", "line 3: \"500 nan\""),
        (emitter(r#"<spectrum name="radiance" filename="inf.spd"/>"#), "hostile.xml:3:", "line 3: \"1e400 0.5\""),
        // A blackbody so hot that Planck's law overflows.
        (
            emitter(
                r#"<spectrum type="blackbody" name="radiance"><float name="temperature" value="3e38"/></spectrum>"#,
            ),
            "hostile.xml:3:",
            "not finite",
        ),
        // One sample per nm over 10^12 nm would allocate terabytes.
        (
            emitter(
                r#"<spectrum type="blackbody" name="radiance"><float name="temperature" value="3000"/><float name="wavelength_max" value="1e12"/></spectrum>"#,
            ),
            "hostile.xml:3:",
            "at most 100000",
        ),
    ];
    for (body, at, want) in cases {
        let e = build_scene(&body, &[], &d).err().unwrap_or_else(|| panic!("accepted: {body}"));
        assert!(e.contains(at) && e.contains(want), "{body}: {e:?} lacks {at} or {want:?}");
    }
    std::fs::remove_dir_all(&d).ok();
}

/// Values set by id (the Python API's `Scene.set`) bypass the XML reader:
/// the builder's typed access refuses their NaN floats and colours.
#[test]
fn non_finite_values_set_by_id_are_refused() {
    let d = temp_dir("overrides");
    let body = r#"<shape type="sphere" id="ball"><float name="radius" value="1"/><bsdf type="diffuse" id="paint"><rgb name="reflectance" value="0.5"/></bsdf></shape>"#;
    build_scene(body, &[], &d).unwrap();
    let set = |id: &str, name: &str, value: Value| Override { id: id.into(), name: name.into(), value };
    for (o, want) in [
        (set("ball", "radius", Value::Float(f64::NAN)), "parameter 'radius' of shape 'sphere' is NaN"),
        (set("ball", "radius", Value::Float(f64::INFINITY)), "is inf, which is not a finite number"),
        (set("paint", "reflectance", Value::Rgb([0.5, f64::NAN, 0.5])), "is the colour (0.5, NaN, 0.5)"),
        (set("paint", "reflectance", Value::Rgb([0.5, 1e39, 0.5])), "not finite in single precision"),
    ] {
        let e = build_scene(body, std::slice::from_ref(&o), &d).err().unwrap_or_else(|| panic!("accepted {o:?}"));
        assert!(e.contains("hostile.xml:3:") && e.contains(want), "{e:?} lacks {want:?}");
    }
    std::fs::remove_dir_all(&d).ok();
}
