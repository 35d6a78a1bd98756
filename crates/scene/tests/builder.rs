//! Scene description → render job: conventions checked against values
//! printed by Mitsuba 3.9.1 (see the comments for the Python used).

use penumbra_scene::builder::{build, Overrides};
use penumbra_scene::mitsuba::parse_str;
use std::path::Path;

fn job(body: &str, film: &str) -> Result<penumbra_render::render::RenderJob, penumbra_scene::LoadError> {
    let xml = format!(
        "<scene version=\"3.0.0\"><sensor type=\"perspective\">{body}<film type=\"hdrfilm\">{film}</film></sensor></scene>"
    );
    build(&parse_str(&xml, Path::new("test.xml"), &[])?, &Overrides::default())
}

const W100_H50: &str = "<integer name=\"width\" value=\"100\"/><integer name=\"height\" value=\"50\"/>";

#[test]
fn focal_length_gives_mitsubas_field_of_view() {
    // mi.load_dict({'type': 'perspective', 'focal_length': '50mm', 'film':
    //   {'type': 'hdrfilm', 'width': 100, 'height': 50}}) -> x_fov = 42.31171417
    for (f, x_fov) in [("50mm", 42.31171417f32), ("35mm", 57.87119293)] {
        let j = job(&format!("<string name=\"focal_length\" value=\"{f}\"/>"), W100_H50).unwrap();
        let expect = (x_fov.to_radians() / 2.0).tan();
        assert!((j.camera.tan_half.x - expect).abs() < 1e-5, "{f}: {} vs {expect}", j.camera.tan_half.x);
    }
    // Neither fov nor focal_length: Mitsuba's default is 50mm.
    let j = job("", W100_H50).unwrap();
    assert!((j.camera.tan_half.x - (42.31171417f32.to_radians() / 2.0).tan()).abs() < 1e-5);
    let both = job("<float name=\"fov\" value=\"30\"/><string name=\"focal_length\" value=\"50mm\"/>", W100_H50);
    assert!(both.unwrap_err().to_string().contains("not both"));
    assert!(job("<string name=\"focal_length\" value=\"fifty\"/>", W100_H50).is_err());
}

#[test]
fn fov_axes_follow_mitsuba() {
    // For a 100x50 film with fov 40 along y, x_fov = 2 atan(2 tan 20°).
    let j = job("<float name=\"fov\" value=\"40\"/><string name=\"fov_axis\" value=\"y\"/>", W100_H50).unwrap();
    assert!((j.camera.tan_half.y - 20f32.to_radians().tan()).abs() < 1e-6);
    assert!((j.camera.tan_half.x - 2.0 * 20f32.to_radians().tan()).abs() < 1e-6);
    let j = job("<float name=\"fov\" value=\"40\"/><string name=\"fov_axis\" value=\"smaller\"/>", W100_H50).unwrap();
    assert!((j.camera.tan_half.y - 20f32.to_radians().tan()).abs() < 1e-6);
    assert!(job("<float name=\"fov\" value=\"40\"/><string name=\"fov_axis\" value=\"z\"/>", W100_H50).is_err());
    assert!(job("<float name=\"fov\" value=\"190\"/>", W100_H50).is_err());
}

#[test]
fn crop_window_must_lie_inside_the_film() {
    let ok =
        format!("{W100_H50}<integer name=\"crop_offset_x\" value=\"10\"/><integer name=\"crop_width\" value=\"20\"/>");
    let j = job("<float name=\"fov\" value=\"40\"/>", &ok).unwrap();
    assert_eq!((j.width, j.height, j.crop_offset, j.full_size), (20, 50, (10, 0), (100, 50)));
    let bad =
        format!("{W100_H50}<integer name=\"crop_offset_x\" value=\"90\"/><integer name=\"crop_width\" value=\"20\"/>");
    assert!(job("<float name=\"fov\" value=\"40\"/>", &bad).unwrap_err().to_string().contains("crop window"));
}

#[test]
fn output_only_film_parameters_are_accepted_and_unknown_ones_rejected() {
    let film = format!("{W100_H50}<string name=\"pixel_format\" value=\"rgba\"/><string name=\"component_format\" value=\"float32\"/><string name=\"file_format\" value=\"openexr\"/>");
    assert!(job("<float name=\"fov\" value=\"40\"/>", &film).is_ok());
    let typo = format!("{W100_H50}<integer name=\"widht\" value=\"3\"/>");
    let e = job("<float name=\"fov\" value=\"40\"/>", &typo).unwrap_err().to_string();
    assert!(e.contains("widht") && e.contains("test.xml:1"), "{e}");
}

#[test]
fn stratified_sample_counts_round_up_to_squares_as_mitsuba() {
    // mi.load_dict({'type': 'stratified', 'sample_count': n}).sample_count()
    for (n, expect) in [(1, 1), (2, 4), (9, 9), (10, 16), (20, 25), (30, 36)] {
        let body = format!(
            "<float name=\"fov\" value=\"40\"/><sampler type=\"stratified\"><integer name=\"sample_count\" value=\"{n}\"/></sampler>"
        );
        let j = job(&body, W100_H50).unwrap();
        assert_eq!(j.sampler.spp, expect, "{n}");
    }
}

#[test]
fn lights_keep_their_order_and_the_directional_light_knows_the_scene_radius() {
    // The directional light comes first, before the geometry that sets the radius.
    let xml = r#"<scene version="3.0.0">
        <emitter type="directional"><vector name="direction" value="0, -2, 0"/></emitter>
        <shape type="sphere"><float name="radius" value="2"/>
            <emitter type="area"><rgb name="radiance" value="1"/></emitter></shape>
        <emitter type="point"><point name="position" value="0, 5, 0"/></emitter>
        <shape type="sphere"><point name="center" value="10, 0, 0"/></shape>
        <sensor type="perspective"><film type="hdrfilm"><integer name="width" value="4"/><integer name="height" value="4"/></film></sensor>
    </scene>"#;
    let job = build(&parse_str(xml, Path::new("test.xml"), &[]).unwrap(), &Overrides::default()).unwrap();
    let scene = &job.scene;
    let names: Vec<&str> = scene.lights.iter().map(|l| l.name()).collect();
    assert_eq!(names, ["directional", "area", "point"]);
    assert_eq!(scene.shape_info[0].light, Some(1));
    let penumbra_render::light::Light::Directional(d) = &scene.lights[0] else { unreachable!() };
    assert_eq!(d.direction, -glam::Vec3::Y);
    assert_eq!(d.scene_radius, scene.bounds().bounding_radius());
    assert!(d.scene_radius > 6.0, "{}", d.scene_radius);
}
