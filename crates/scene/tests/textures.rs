//! Textures in scenes: the builder's `bitmap` and `checkerboard`, their
//! parameters and errors, and the uv conventions they are evaluated with.

use glam::{Vec2, Vec3};
use penumbra_render::geometry::SurfaceInteraction;
use penumbra_render::material::Material;
use penumbra_render::texture::Texture;
use penumbra_scene::builder::{build, Overrides};
use penumbra_scene::mitsuba::parse_str;
use std::path::{Path, PathBuf};

/// A scene file path in a fresh temporary directory (files it names are
/// resolved relative to it).
fn temp_scene(tag: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("penumbra-textures-{tag}-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    dir.join("scene.xml")
}

/// A 4×2 8-bit sRGB PNG; row 0 (top) holds the bytes 0, 64, 128, 255 in red.
fn write_png(dir: &Path) {
    let mut px = Vec::new();
    for y in 0..2u8 {
        for x in [0u8, 64, 128, 255] {
            px.extend_from_slice(&[x, 100 * y, 30]);
        }
    }
    image::save_buffer(dir.join("tex.png"), &px, 4, 2, image::ColorType::Rgb8).unwrap();
}

/// Builds a scene with one rectangle whose diffuse reflectance is `texture`.
fn job(scene: &Path, texture: &str) -> Result<penumbra_render::render::RenderJob, penumbra_scene::LoadError> {
    let xml = format!(
        r#"<scene version="3.0.0">
<sensor type="perspective"><film type="hdrfilm"><integer name="width" value="8"/><integer name="height" value="8"/></film></sensor>
<shape type="rectangle">
  <bsdf type="diffuse">
    {texture}
  </bsdf>
</shape>
</scene>"#
    );
    build(&parse_str(&xml, scene, &[])?, &Overrides::default())
}

fn reflectance(j: &penumbra_render::render::RenderJob) -> Texture {
    match &j.scene.materials[j.scene.shape_info[0].material as usize] {
        Material::Diffuse(penumbra_render::bsdf::DiffuseParams { reflectance }) => reflectance.clone(),
        m => panic!("unexpected material {m:?}"),
    }
}

fn si(u: f32, v: f32) -> SurfaceInteraction {
    SurfaceInteraction::at_uv(Vec2::new(u, v))
}

fn srgb(b: u8) -> f32 {
    penumbra_scene::image_io::srgb_to_linear(b as f32 / 255.0)
}

#[test]
fn png_bitmap_is_decoded_from_srgb_unless_raw() {
    let scene = temp_scene("png");
    write_png(scene.parent().unwrap());
    let tex = |extra: &str| {
        reflectance(
            &job(
                &scene,
                &format!(
                    r#"<texture type="bitmap" name="reflectance"><string name="filename" value="tex.png"/>
                       <string name="filter_type" value="nearest"/>{extra}</texture>"#
                ),
            )
            .unwrap(),
        )
    };
    // Texel (1, 0) is at uv (0.375, 0.25): v = 0 is the top row of the file.
    let t = tex("");
    let c = t.eval(&si(0.375, 0.25));
    assert!((c - Vec3::new(srgb(64), srgb(0), srgb(30))).abs().max_element() < 1e-6, "{c}");
    let c = t.eval(&si(0.875, 0.75));
    assert!((c - Vec3::new(srgb(255), srgb(100), srgb(30))).abs().max_element() < 1e-6, "{c}");
    let t = tex(r#"<boolean name="raw" value="true"/>"#);
    let c = t.eval(&si(0.375, 0.25));
    assert!((c - Vec3::new(64.0, 0.0, 30.0) / 255.0).abs().max_element() < 1e-6, "{c}");
    // Bilinear (the default) interpolates the decoded texels; the mean is the mean luminance.
    let t = reflectance(
        &job(
            &scene,
            r#"<texture type="bitmap" name="reflectance"><string name="filename" value="tex.png"/></texture>"#,
        )
        .unwrap(),
    );
    let c = t.eval(&si(0.25, 0.25));
    assert!((c.x - 0.5 * (srgb(0) + srgb(64))).abs() < 1e-6, "{c}");
    assert!(t.mean() > 0.0 && t.mean() < 1.0);
    std::fs::remove_dir_all(scene.parent().unwrap()).ok();
}

#[test]
fn checkerboard_with_nested_texture_and_to_uv() {
    let scene = temp_scene("checker");
    write_png(scene.parent().unwrap());
    let j = job(
        &scene,
        r#"<texture type="checkerboard" name="reflectance">
             <rgb name="color0" value="0.9, 0.1, 0.1"/>
             <texture type="bitmap" name="color1"><string name="filename" value="tex.png"/>
               <string name="filter_type" value="nearest"/></texture>
             <transform name="to_uv"><scale x="2" y="2"/></transform>
           </texture>"#,
    )
    .unwrap();
    let t = reflectance(&j);
    assert!((t.eval(&si(0.1, 0.1)) - Vec3::new(0.9, 0.1, 0.1)).length() < 1e-6);
    let c = t.eval(&si(0.3, 0.1));
    assert!((c - Vec3::new(srgb(64), srgb(0), srgb(30))).abs().max_element() < 1e-6, "{c}");
    // Defaults: 0.4 and 0.2.
    let t = reflectance(&job(&scene, r#"<texture type="checkerboard" name="reflectance"/>"#).unwrap());
    assert!((t.eval(&si(0.1, 0.1)) - Vec3::splat(0.4)).length() < 1e-6);
    assert!((t.eval(&si(0.6, 0.1)) - Vec3::splat(0.2)).length() < 1e-6);
    std::fs::remove_dir_all(scene.parent().unwrap()).ok();
}

#[test]
fn texture_errors_name_file_and_line() {
    let scene = temp_scene("errors");
    write_png(scene.parent().unwrap());
    let err = |texture: &str| job(&scene, texture).map(|_| ()).unwrap_err().to_string();
    let file = scene.display().to_string();

    let e = err(r#"<texture type="bitmap" name="reflectance"><string name="filename" value="missing.png"/></texture>"#);
    assert!(e.contains("missing.png") && e.contains(&format!("{file}:5")), "{e}");

    let e = err(r#"<texture type="marble" name="reflectance"/>"#);
    assert!(e.contains("marble") && e.contains("bitmap") && e.contains("checkerboard"), "{e}");
    assert!(e.contains(&format!("{file}:5")), "{e}");

    let e = err(r#"<texture type="bitmap" name="reflectance"><string name="filename" value="tex.png"/>
<string name="wrap_mode" value="wrap"/></texture>"#);
    assert!(e.contains("wrap_mode") && e.contains("'wrap'") && e.contains(&format!("{file}:6")), "{e}");

    let e = err(r#"<texture type="bitmap" name="reflectance"><string name="filename" value="tex.png"/>
<string name="filter_type" value="cubic"/></texture>"#);
    assert!(e.contains("filter_type") && e.contains(&format!("{file}:6")), "{e}");

    // Parameters Mitsuba only knows on bitmap are flagged on checkerboard.
    let e = err(r#"<texture type="checkerboard" name="reflectance">
<boolean name="raw" value="true"/></texture>"#);
    assert!(e.contains("'raw'") && e.contains(&format!("{file}:6")), "{e}");

    std::fs::write(scene.with_file_name("tex.bmp"), b"not an image").unwrap();
    let e = err(r#"<texture type="bitmap" name="reflectance"><string name="filename" value="tex.bmp"/></texture>"#);
    assert!(e.contains("tex.bmp") && e.contains("unsupported"), "{e}");

    // Non-finite texels are rejected with the file named.
    let hdr = scene.with_file_name("nan.exr");
    penumbra_scene::image_io::write_image(
        &hdr,
        &penumbra_scene::image_io::RgbImage { width: 2, height: 2, pixels: vec![[0.5, f32::NAN, 0.5]; 4] },
    )
    .unwrap();
    let e = err(r#"<texture type="bitmap" name="reflectance"><string name="filename" value="nan.exr"/></texture>"#);
    assert!(e.contains("nan.exr") && e.contains("not finite"), "{e}");
    std::fs::remove_dir_all(scene.parent().unwrap()).ok();
}

/// Builds a scene with `shape` (inner XML of a ply shape or another shape).
fn attr_job(scene: &Path, shape: &str) -> Result<penumbra_render::render::RenderJob, penumbra_scene::LoadError> {
    let xml = format!(
        r#"<scene version="3.0.0">
<sensor type="perspective"><film type="hdrfilm"><integer name="width" value="8"/><integer name="height" value="8"/></film></sensor>
{shape}
</scene>"#
    );
    build(&parse_str(&xml, scene, &[])?, &Overrides::default())
}

/// A PLY with two triangles, float vertex colours and a one-component face value.
const ATTR_PLY: &str = "ply\nformat ascii 1.0\nelement vertex 4\nproperty float x\nproperty float y\n\
    property float z\nproperty float r\nproperty float g\nproperty float b\nelement face 2\n\
    property list uchar int vertex_indices\nproperty float id_x\nend_header\n\
    0 0 0 1 0 0\n1 0 0 0 1 0\n0 1 0 0 0 1\n1 1 0 1 1 1\n3 0 1 2 0.25\n3 2 1 3 0.75\n";

#[test]
fn mesh_attributes_interpolate_per_vertex_and_hold_per_face() {
    let scene = temp_scene("attributes");
    std::fs::write(scene.with_file_name("m.ply"), ATTR_PLY).unwrap();
    let diffuse = |name: &str, extra: &str| {
        format!(
            r#"<shape type="ply"><string name="filename" value="m.ply"/>
<bsdf type="diffuse"><texture type="mesh_attribute" name="reflectance"><string name="name" value="{name}"/>{extra}</texture></bsdf>
</shape>"#
        )
    };
    let at = |prim: u32, b1: f32, b2: f32| SurfaceInteraction { prim, bary: Vec2::new(b1, b2), ..si(0.0, 0.0) };

    let j = attr_job(&scene, &diffuse("vertex_color", r#"<float name="scale" value="2"/>"#)).unwrap();
    let t = reflectance(&j);
    let c = t.eval(&at(0, 0.25, 0.5));
    assert!((c - Vec3::new(0.5, 0.5, 1.0)).abs().max_element() < 1e-6, "{c}");
    let c = t.eval(&at(1, 0.0, 1.0));
    assert_eq!(c, Vec3::splat(2.0));

    let j = attr_job(&scene, &diffuse("face_id", "")).unwrap();
    let t = reflectance(&j);
    assert_eq!(t.eval(&at(1, 0.1, 0.2)), Vec3::splat(0.75));
    assert_eq!(t.eval_1(&at(0, 0.6, 0.2)), 0.25);

    // Errors: unknown attribute (listing those the mesh has), a bad name, a
    // shape without attributes, a colour used as a scalar.
    let file = scene.display().to_string();
    let e = attr_job(&scene, &diffuse("vertex_colour", "")).map(|_| ()).unwrap_err().to_string();
    assert!(e.contains("vertex_colour") && e.contains("vertex_color (3 components)") && e.contains("face_id"), "{e}");
    assert!(e.contains(&format!("{file}:4")), "{e}");
    let e = attr_job(&scene, &diffuse("color", "")).map(|_| ()).unwrap_err().to_string();
    assert!(e.contains("vertex_") && e.contains(&format!("{file}:4")), "{e}");
    let sphere = r#"<shape type="sphere"><bsdf type="diffuse"><texture type="mesh_attribute" name="reflectance">
<string name="name" value="vertex_color"/></texture></bsdf></shape>"#;
    let e = attr_job(&scene, sphere).map(|_| ()).unwrap_err().to_string();
    assert!(e.contains("only meshes carry attributes"), "{e}");
    let rough = r#"<shape type="ply"><string name="filename" value="m.ply"/>
<bsdf type="roughconductor"><texture type="mesh_attribute" name="alpha"><string name="name" value="vertex_color"/></texture></bsdf>
</shape>"#;
    let e = attr_job(&scene, rough).map(|_| ()).unwrap_err().to_string();
    assert!(e.contains("3 components") && e.contains("scalar"), "{e}");
    std::fs::remove_dir_all(scene.parent().unwrap()).ok();
}

/// A spot light's `texture` must be a bitmap named `texture` (Mitsuba needs
/// a spatially varying one); anything else is an error at its line.
#[test]
fn spot_texture_errors_name_the_line() {
    let spot = |inner: &str| {
        let xml = format!(
            "<scene version=\"3.0.0\"><sensor type=\"perspective\"><film type=\"hdrfilm\"/></sensor>\n<emitter type=\"spot\">\n{inner}\n</emitter></scene>"
        );
        let dir = penumbra_scene::mitsuba::parse_str(&xml, std::path::Path::new("spot.xml"), &[]).unwrap();
        penumbra_scene::builder::build(&dir, &penumbra_scene::Overrides::default())
            .map(|_| ())
            .map_err(|e| e.to_string())
    };
    let e = spot(r#"<texture type="checkerboard" name="texture"/>"#).unwrap_err();
    assert!(e.contains("spot.xml:3") && e.contains("give a bitmap"), "{e}");
    let e = spot(r#"<texture type="checkerboard" name="pattern"/>"#).unwrap_err();
    assert!(e.contains("spot.xml:3") && e.contains("named 'texture'"), "{e}");
    let e = spot(r#"<texture type="bitmap" name="texture"><string name="filename" value="nowhere.png"/></texture>"#)
        .unwrap_err();
    assert!(e.contains("not found"), "{e}");
}

/// An area emitter's `radiance` may be a checkerboard or bitmap (named
/// `radiance`); a mesh_attribute, a negative colour, a `to_world` or an
/// unknown parameter is an error at its line; without `radiance` it is 1.
#[test]
fn area_radiance_textures_and_errors() {
    let area = |inner: &str| {
        let xml = format!(
            "<scene version=\"3.0.0\"><sensor type=\"perspective\"><film type=\"hdrfilm\"/></sensor>\n<shape type=\"rectangle\"><emitter type=\"area\">\n{inner}\n</emitter></shape></scene>"
        );
        let desc = parse_str(&xml, Path::new("area.xml"), &[]).map_err(|e| e.to_string())?;
        build(&desc, &Overrides::default()).map_err(|e| e.to_string())
    };
    let radiance = |j: &penumbra_render::render::RenderJob| match &j.scene.lights[0] {
        penumbra_render::light::Light::Area(a) => a.radiance.clone(),
        l => panic!("unexpected light {l:?}"),
    };
    let j = area(r#"<texture type="checkerboard" name="radiance"><rgb name="color0" value="0.9"/></texture>"#).unwrap();
    let t = radiance(&j);
    assert!(matches!(t, Texture::Checkerboard(_)));
    assert_eq!(t.eval(&si(0.25, 0.25)), Vec3::splat(0.9));
    assert_eq!(t.eval(&si(0.75, 0.25)), Vec3::splat(0.2));
    assert!(j.scene.shape_info.iter().all(|i| i.light.is_some()));
    assert_eq!(radiance(&area("").unwrap()).constant(), Some(Vec3::ONE));
    let e =
        area(r#"<texture type="mesh_attribute" name="radiance"><string name="name" value="vertex_color"/></texture>"#)
            .unwrap_err();
    assert!(e.contains("area.xml:3") && e.contains("mesh_attribute"), "{e}");
    let e = area(r#"<texture type="checkerboard" name="emission"/>"#).unwrap_err();
    assert!(e.contains("area.xml:3") && e.contains("named 'radiance'"), "{e}");
    let e = area(r#"<rgb name="radiance" value="1, -1, 1"/>"#).unwrap_err();
    assert!(e.contains("area.xml:3") && e.contains("negative"), "{e}");
    let e = area(r#"<float name="scale" value="2"/>"#).unwrap_err();
    assert!(e.contains("area.xml:3") && e.contains("scale"), "{e}");
    let e = area(r#"<transform name="to_world"><translate x="1"/></transform>"#).unwrap_err();
    assert!(e.contains("area.xml:3") && e.contains("to_world"), "{e}");
}

/// A projector's image is a colour or a bitmap named `irradiance`; other
/// textures, negative values and unknown parameters are errors at their
/// line. The image's aspect ratio sets the vertical field of view.
#[test]
fn projector_parameters_and_errors() {
    let projector = |inner: &str| {
        let xml = format!(
            "<scene version=\"3.0.0\"><sensor type=\"perspective\"><film type=\"hdrfilm\"/></sensor>\n<emitter type=\"projector\">\n{inner}\n</emitter></scene>"
        );
        let desc = parse_str(&xml, Path::new("projector.xml"), &[]).map_err(|e| e.to_string())?;
        build(&desc, &Overrides::default()).map_err(|e| e.to_string())
    };
    let j = projector(r#"<float name="fov" value="90"/><float name="scale" value="2"/>"#).unwrap();
    let penumbra_render::light::Light::Projector(p) = &j.scene.lights[0] else { panic!("a projector") };
    // On the axis at distance 2: L = π scale E / z².
    let s = p.sample_li(Vec3::new(0.0, 0.0, 2.0)).unwrap();
    assert!((s.li - Vec3::splat(std::f32::consts::PI * 2.0 / 4.0)).abs().max_element() < 1e-5, "{}", s.li);
    // fov 90 along x: the image ends at |x| = z.
    assert!(p.sample_li(Vec3::new(1.9, 0.0, 2.0)).is_some() && p.sample_li(Vec3::new(2.1, 0.0, 2.0)).is_none());
    let dir = temp_scene("projector");
    write_png(dir.parent().unwrap());
    let bitmap = format!(
        r#"<float name="fov" value="90"/><texture type="bitmap" name="irradiance"><string name="filename" value="{}"/></texture>"#,
        dir.parent().unwrap().join("tex.png").display()
    );
    let j = projector(&bitmap).unwrap();
    let penumbra_render::light::Light::Projector(p) = &j.scene.lights[0] else { panic!("a projector") };
    // A 4x2 image: tan(fov_y / 2) = 1/2.
    assert!(p.sample_li(Vec3::new(0.0, 0.9, 2.0)).is_some() && p.sample_li(Vec3::new(0.0, 1.1, 2.0)).is_none());
    let e = projector(r#"<texture type="checkerboard" name="irradiance"/>"#).unwrap_err();
    assert!(e.contains("projector.xml:3") && e.contains("give a bitmap"), "{e}");
    let e = projector(r#"<texture type="bitmap" name="image"/>"#).unwrap_err();
    assert!(e.contains("projector.xml:3") && e.contains("named 'irradiance'"), "{e}");
    let e = projector(r#"<float name="scale" value="-1"/>"#).unwrap_err();
    assert!(e.contains("projector.xml:3") && e.contains("negative"), "{e}");
    let e = projector(r#"<float name="fov" value="180"/>"#).unwrap_err();
    assert!(e.contains("projector.xml:3") && e.contains("fov"), "{e}");
    let e = projector(r#"<float name="cutoff_angle" value="20"/>"#).unwrap_err();
    assert!(e.contains("projector.xml:3") && e.contains("cutoff_angle"), "{e}");
    std::fs::remove_dir_all(dir.parent().unwrap()).ok();
}

/// `directionalarea` sits inside a shape with a colour `radiance` (default
/// 1); at the top level, with a texture, a negative radiance or an unknown
/// parameter it is an error at its line.
#[test]
fn directionalarea_parameters_and_errors() {
    let scene = |shape_inner: &str, top: &str| {
        let xml = format!(
            "<scene version=\"3.0.0\"><sensor type=\"perspective\"><film type=\"hdrfilm\"/></sensor>\n<shape type=\"rectangle\">\n{shape_inner}\n</shape>\n{top}</scene>"
        );
        let desc = parse_str(&xml, Path::new("da.xml"), &[]).map_err(|e| e.to_string())?;
        build(&desc, &Overrides::default()).map_err(|e| e.to_string())
    };
    let j = scene(r#"<emitter type="directionalarea"/>"#, "").unwrap();
    let penumbra_render::light::Light::DirectionalArea(d) = &j.scene.lights[0] else { panic!("directionalarea") };
    assert_eq!((d.shape, d.radiance), (0, Vec3::ONE));
    assert_eq!(j.scene.shape_info[0].light, Some(0));
    let j = scene(r#"<emitter type="directionalarea"><rgb name="radiance" value="2, 3, 4"/></emitter>"#, "").unwrap();
    let penumbra_render::light::Light::DirectionalArea(d) = &j.scene.lights[0] else { panic!("directionalarea") };
    assert_eq!(d.radiance, Vec3::new(2.0, 3.0, 4.0));
    let e = scene("", r#"<emitter type="directionalarea"/>"#).unwrap_err();
    assert!(e.contains("da.xml:5") && e.contains("nested inside a shape"), "{e}");
    let e = scene(r#"<emitter type="directionalarea"><rgb name="radiance" value="-1"/></emitter>"#, "").unwrap_err();
    assert!(e.contains("da.xml:3") && e.contains("negative"), "{e}");
    let e = scene(r#"<emitter type="directionalarea"><texture type="checkerboard" name="radiance"/></emitter>"#, "")
        .unwrap_err();
    assert!(e.contains("da.xml:3") && e.contains("textured"), "{e}");
    let e = scene(r#"<emitter type="directionalarea"><float name="scale" value="2"/></emitter>"#, "").unwrap_err();
    assert!(e.contains("da.xml:3") && e.contains("scale"), "{e}");
    let e = scene(r#"<emitter type="point"/>"#, "").unwrap_err();
    assert!(e.contains("only 'area' and 'directionalarea'"), "{e}");
}

/// Mitsuba's `volume` texture: a volume looked up at the world-space
/// surface point (constvolume, gridvolume of 1 or 3 channels; eval_1 the
/// luminance of a colour grid), and its errors at file:line.
#[test]
fn volume_texture_looks_up_the_surface_point() {
    let scene = temp_scene("volume");
    let dir = scene.parent().unwrap();
    let bbox = penumbra_render::geometry::Aabb { min: Vec3::ZERO, max: Vec3::ONE };
    // 2 × 1 × 1 RGB voxels: red, then blue; and a 6-channel grid.
    let rgb = penumbra_render::medium::Grid { res: [2, 1, 1], channels: 3, data: vec![1.0, 0.0, 0.0, 0.0, 0.0, 1.0] };
    std::fs::write(dir.join("rgb.vol"), penumbra_scene::vol::encode(&rgb, &bbox)).unwrap();
    let six = penumbra_render::medium::Grid { res: [1, 1, 1], channels: 6, data: vec![1.0; 6] };
    std::fs::write(dir.join("six.vol"), penumbra_scene::vol::encode(&six, &bbox)).unwrap();
    let at = |x: f32| SurfaceInteraction { p: Vec3::new(x, 0.0, 0.0), ..si(0.5, 0.5) };
    // Placed over [-1, 1] along x: voxel centres at x = -0.5 and 0.5.
    let j = job(
        &scene,
        r#"<texture type="volume" name="reflectance"><volume type="gridvolume" name="volume">
<string name="filename" value="rgb.vol"/><string name="filter_type" value="nearest"/>
<transform name="to_world"><scale x="2" y="1" z="1"/><translate x="-1" y="-0.5" z="-0.5"/></transform></volume></texture>"#,
    )
    .unwrap();
    let t = reflectance(&j);
    assert_eq!(t.eval(&at(-0.5)).to_array(), [1.0, 0.0, 0.0]);
    assert_eq!(t.eval(&at(0.5)).to_array(), [0.0, 0.0, 1.0]);
    assert!((t.eval_1(&at(0.5)) - penumbra_render::math::luminance(Vec3::Z)).abs() < 1e-7);
    assert!(!t.has_mean() && !t.has_gradient());
    let j = job(
        &scene,
        r#"<texture type="volume" name="reflectance"><volume type="constvolume" name="volume"><rgb name="value" value="0.1, 0.2, 0.6"/></volume></texture>"#,
    )
    .unwrap();
    let t = reflectance(&j);
    assert_eq!(t.eval(&at(3.0)).to_array(), [0.1, 0.2, 0.6]);
    assert!((t.eval_1(&at(3.0)) - 0.3).abs() < 1e-7, "a constant's channel mean");

    let file = scene.display().to_string();
    let err = |texture: &str| job(&scene, texture).map(|_| ()).unwrap_err().to_string();
    let e = err(r#"<texture type="volume" name="reflectance"><float name="volume" value="0.5"/></texture>"#);
    assert!(e.contains("nested <volume name=\"volume\">") && e.contains(&format!("{file}:5")), "{e}");
    let e = err(r#"<texture type="volume" name="reflectance"/>"#);
    assert!(e.contains("nested <volume") && e.contains(&format!("{file}:5")), "{e}");
    let e = err(r#"<texture type="volume" name="reflectance">
<volume type="gridvolume" name="volume"><string name="filename" value="six.vol"/></volume></texture>"#);
    assert!(e.contains("6-channel") && e.contains(&format!("{file}:6")), "{e}");
    let e = err(r#"<texture type="volume" name="reflectance">
<volume type="constvolume" name="volume"><float name="scale" value="2"/></volume></texture>"#);
    assert!(e.contains("'scale'") && e.contains(&format!("{file}:6")), "{e}");
    std::fs::remove_dir_all(dir).ok();
}
