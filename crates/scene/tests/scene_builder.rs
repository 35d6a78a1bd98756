//! The format-neutral scene builder: a scene built from in-memory data
//! (meshes from arrays, a texture from a pixel buffer, an area light, an
//! instanced group, a camera) renders bitwise as the same scene written as
//! Mitsuba XML; bad input is an error at the location given.

use glam::{Affine2, Mat4, Vec2, Vec3};
use penumbra_render::bsdf::DiffuseParams;
use penumbra_render::camera::{Camera, FovAxis};
use penumbra_render::film::{Filter, FilterKind};
use penumbra_render::material::Material;
use penumbra_render::render::RenderJob;
use penumbra_render::sampling::{Sampler, SamplerKind};
use penumbra_render::texture::{FilterType, WrapMode};
use penumbra_scene::image_io::{write_image, RgbImage};
use penumbra_scene::scene_builder::{image_texture, Emission, Film, Location, MeshData, SceneBuilder, ShapeDesc};
use penumbra_scene::{load_scene, Overrides};
use std::path::PathBuf;
use std::sync::Arc;

fn temp_dir(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("penumbra-scene-builder-{}-{name}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

/// A quad of corners `c` (counter-clockwise seen from its front), uv over [0, 1]².
fn quad(c: [[f32; 3]; 4]) -> MeshData {
    MeshData {
        positions: c.iter().map(|&p| Vec3::from(p)).collect(),
        uvs: vec![Vec2::new(0.0, 0.0), Vec2::new(1.0, 0.0), Vec2::new(1.0, 1.0), Vec2::new(0.0, 1.0)],
        indices: vec![[0, 1, 2], [0, 2, 3]],
        ..MeshData::default()
    }
}

/// `m` as a binary little-endian PLY (positions and uvs, exact).
fn ply(m: &MeshData) -> Vec<u8> {
    let head = format!(
        "ply\nformat binary_little_endian 1.0\nelement vertex {}\nproperty float x\nproperty float y\nproperty float z\n\
         property float u\nproperty float v\nelement face {}\nproperty list uchar int vertex_indices\nend_header\n",
        m.positions.len(),
        m.indices.len()
    );
    let mut out = head.into_bytes();
    for (p, uv) in m.positions.iter().zip(&m.uvs) {
        for v in [p.x, p.y, p.z, uv.x, uv.y] {
            out.extend(v.to_le_bytes());
        }
    }
    for t in &m.indices {
        out.push(3);
        for &i in t {
            out.extend((i as i32).to_le_bytes());
        }
    }
    out
}

/// A 4x3 colour ramp.
fn image() -> RgbImage {
    let pixels = (0..12).map(|i| [0.1 + 0.07 * i as f32, 0.8 - 0.05 * i as f32, 0.3 + 0.02 * (i % 4) as f32]).collect();
    RgbImage { width: 4, height: 3, pixels }
}

const CAMERA: [f32; 16] = [-1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, -1.0, 0.0, 0.25, 0.5, 4.0, 1.0];
const TILE_A: [f32; 16] = [0.5, 0.0, 0.0, 0.0, 0.0, 0.5, 0.0, 0.0, 0.0, 0.0, 0.5, 0.0, -1.0, -1.0, 0.5, 1.0];
const TILE_B: [f32; 16] = [0.0, 0.25, 0.0, 0.0, -0.25, 0.0, 0.0, 0.0, 0.0, 0.0, 0.25, 0.0, 1.0, -0.5, 0.75, 1.0];

fn floor() -> MeshData {
    quad([[-2.0, -2.0, 0.0], [2.0, -2.0, 0.0], [2.0, 2.0, 0.0], [-2.0, 2.0, 0.0]])
}
/// Faces -z, towards the floor.
fn lamp() -> MeshData {
    quad([[0.5, 0.5, 2.0], [0.5, 1.25, 2.0], [1.25, 1.25, 2.0], [1.25, 0.5, 2.0]])
}
fn tile() -> MeshData {
    quad([[-1.0, -1.0, 0.0], [1.0, -1.0, 0.0], [1.0, 1.0, 0.0], [-1.0, 1.0, 0.0]])
}

/// A column-major matrix as Mitsuba's `<matrix value>` (row-major).
fn matrix(m: &[f32; 16]) -> String {
    let rows: Vec<String> = (0..4).flat_map(|r| (0..4).map(move |c| m[c * 4 + r].to_string())).collect();
    format!("<matrix value=\"{}\"/>", rows.join(" "))
}

/// The scene as Mitsuba XML, with its mesh and image files in `dir`.
fn xml_scene(dir: &std::path::Path) -> PathBuf {
    std::fs::write(dir.join("floor.ply"), ply(&floor())).unwrap();
    std::fs::write(dir.join("lamp.ply"), ply(&lamp())).unwrap();
    std::fs::write(dir.join("tile.ply"), ply(&tile())).unwrap();
    write_image(&dir.join("ramp.exr"), &image()).unwrap();
    let xml = format!(
        r#"<scene version="3.0.0">
  <sensor type="perspective">
    <float name="fov" value="45"/>
    <transform name="to_world">{camera}</transform>
    <sampler type="independent"><integer name="sample_count" value="4"/></sampler>
    <film type="hdrfilm"><integer name="width" value="32"/><integer name="height" value="24"/></film>
  </sensor>
  <shape type="ply">
    <string name="filename" value="floor.ply"/>
    <bsdf type="diffuse"><texture type="bitmap" name="reflectance"><string name="filename" value="ramp.exr"/></texture></bsdf>
  </shape>
  <shape type="ply">
    <string name="filename" value="lamp.ply"/>
    <emitter type="area"><rgb name="radiance" value="10, 9, 8"/></emitter>
  </shape>
  <shape type="shapegroup" id="tiles">
    <shape type="ply">
      <string name="filename" value="tile.ply"/>
      <bsdf type="diffuse"><rgb name="reflectance" value="0.3, 0.6, 0.2"/></bsdf>
    </shape>
  </shape>
  <shape type="instance"><ref id="tiles"/><transform name="to_world">{a}</transform></shape>
  <shape type="instance"><ref id="tiles"/><transform name="to_world">{b}</transform></shape>
</scene>"#,
        camera = matrix(&CAMERA),
        a = matrix(&TILE_A),
        b = matrix(&TILE_B),
    );
    let path = dir.join("scene.xml");
    std::fs::write(&path, xml).unwrap();
    path
}

/// The same scene through the builder, from memory.
fn built_scene() -> penumbra_scene::Result<RenderJob> {
    let at = Location::new(Arc::new("memory".into()), 0, 0);
    let mut s = SceneBuilder::new(at.clone());
    let texture = image_texture(image(), FilterType::Bilinear, WrapMode::Repeat, Affine2::IDENTITY, &at)?;
    let floor_material = s.add_material(Material::Diffuse(DiffuseParams { reflectance: texture }));
    let id =
        s.add_shape(ShapeDesc::new(floor().into_geometry(&Mat4::IDENTITY, false, false, &at)?, floor_material), &at)?;
    s.place_shape(id);
    // Mitsuba's default for an emitter without a BSDF: black diffuse.
    let black = s.add_material(Material::Diffuse(DiffuseParams { reflectance: Vec3::ZERO.into() }));
    let emission = Some(Emission::Diffuse(Vec3::new(10.0, 9.0, 8.0).into()));
    let lamp = lamp().into_geometry(&Mat4::IDENTITY, false, false, &at)?;
    let id = s.add_shape(ShapeDesc { emission, ..ShapeDesc::new(lamp, black) }, &at)?;
    s.place_shape(id);
    let green = s.add_material(Material::Diffuse(DiffuseParams { reflectance: Vec3::new(0.3, 0.6, 0.2).into() }));
    s.name_material("green", green);
    let tile = s.add_shape(ShapeDesc::new(tile().into_geometry(&Mat4::IDENTITY, false, false, &at)?, green), &at)?;
    let group = s.add_group(vec![tile], &at)?;
    s.add_instance(group, Mat4::from_cols_array(&TILE_A), &at)?;
    s.add_instance(group, Mat4::from_cols_array(&TILE_B), &at)?;
    let camera = Camera::new(Mat4::from_cols_array(&CAMERA), 45.0, FovAxis::X, 32, 24, 0.01f64 as f32, 10000.0);
    s.set_camera(camera, None);
    s.set_film(Film::new(32, 24), Filter::new(FilterKind::Gaussian { stddev: 0.5 }));
    s.set_sampler(Sampler::new(SamplerKind::Independent, 0, 4));
    assert_eq!(s.material("green"), Some(green));
    s.finish()
}

fn render(job: &RenderJob) -> Vec<[f32; 3]> {
    let mut film = penumbra_render::film::Film::new(job.width, job.height);
    job.render_into(&mut film, 0..job.sampler.spp, &|_| {});
    film.develop()
}

#[test]
fn a_scene_built_from_memory_renders_bitwise_as_its_mitsuba_file() {
    let dir = temp_dir("bitwise");
    let from_xml = load_scene(&xml_scene(&dir), &[], &Overrides::default()).unwrap();
    let from_memory = built_scene().unwrap();
    assert_eq!(from_memory.scene.shapes.len(), 3);
    assert_eq!(from_memory.scene.lights.len(), 1);
    let (a, b) = (render(&from_xml), render(&from_memory));
    let bits = |img: &[[f32; 3]]| img.iter().flat_map(|p| p.map(f32::to_bits)).collect::<Vec<_>>();
    assert!(a.iter().any(|p| p[0] > 0.0), "the scene renders black");
    assert_eq!(bits(&a), bits(&b), "the scene built from memory renders differently");
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn bad_input_is_an_error_at_the_location_given() {
    let file = Arc::new(PathBuf::from("scene.gltf"));
    let at = Location::with_place(file.clone(), "/meshes/0/primitives/1");
    let mut bad = tile();
    bad.indices.push([0, 1, 7]);
    let e = bad.into_geometry(&Mat4::IDENTITY, false, false, &at).unwrap_err().to_string();
    assert_eq!(e, "scene.gltf at /meshes/0/primitives/1: face 2 refers to a vertex past the 4 vertices");
    let mut bad = tile();
    bad.colors = vec![Vec3::ONE; 3];
    let e = bad.into_geometry(&Mat4::IDENTITY, false, false, &at).unwrap_err().to_string();
    assert!(e.contains("3 vertex colours for 4 vertices"), "{e}");
    let at = Location::with_place(file.clone(), "byte 1024");
    let small = RgbImage { width: 2, height: 2, pixels: vec![[0.5; 3]; 3] };
    let e = image_texture(small, FilterType::Nearest, WrapMode::Clamp, Affine2::IDENTITY, &at).unwrap_err();
    assert!(e.to_string().starts_with("scene.gltf at byte 1024: bitmap of 2x2 texels"), "{e}");

    let at = Location::new(Arc::new("scene.pbrt".into()), 12, 1);
    let mut s = SceneBuilder::new(at.clone());
    let m = s.add_material(Material::Null);
    let lamp = lamp().into_geometry(&Mat4::IDENTITY, false, false, &at).unwrap();
    let id =
        s.add_shape(ShapeDesc { emission: Some(Emission::Diffuse(Vec3::ONE.into())), ..ShapeDesc::new(lamp, m) }, &at);
    let e = s.add_group(vec![id.unwrap()], &at).unwrap_err().to_string();
    assert!(e.starts_with("scene.pbrt:12:1: a shape in a group cannot emit light"), "{e}");
    let tile = tile().into_geometry(&Mat4::IDENTITY, false, false, &at).unwrap();
    let e = s.add_shape(ShapeDesc::new(tile, 7), &at).unwrap_err().to_string();
    assert_eq!(e, "scene.pbrt:12:1: material 7 does not exist");
    let e = s.add_instance(3, Mat4::IDENTITY, &at).unwrap_err().to_string();
    assert_eq!(e, "scene.pbrt:12:1: group 3 does not exist");
    let light = penumbra_render::light::Light::Area(penumbra_render::light::AreaLight {
        shape: 0,
        radiance: Vec3::ONE.into(),
        two_sided: false,
    });
    let e = s.add_light(light, &at).unwrap_err().to_string();
    assert!(e.contains("an area light is given with its shape"), "{e}");
    let negative = self::tile().into_geometry(&Mat4::IDENTITY, false, false, &at).unwrap();
    let emission = Some(Emission::Diffuse(Vec3::new(1.0, -1.0, 1.0).into()));
    let e = s.add_shape(ShapeDesc { emission, ..ShapeDesc::new(negative, m) }, &at).unwrap_err().to_string();
    assert!(e.contains("must not be negative"), "{e}");
    let e = s.finish().err().unwrap().to_string();
    assert_eq!(e, "scene.pbrt:12:1: the scene has no camera");
}

#[test]
fn the_geometry_cache_reuses_unchanged_shapes_and_the_bvh() {
    use penumbra_scene::builder::{build_cached, GeometryCache};
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../scenes/cornell-box.xml");
    let ov = Overrides { spp: Some(1), ..Overrides::default() };
    let mut cache = GeometryCache::default();
    let parse = || penumbra_scene::mitsuba::parse_file(&path, &[]).unwrap();
    let first = build_cached(&parse(), &ov, &mut cache).unwrap();
    let built = (cache.shapes_built, cache.accels_built);
    assert!(built.0 > 0 && built.1 == 1, "{built:?}");
    let again = build_cached(&parse(), &ov, &mut cache).unwrap();
    assert_eq!((cache.shapes_built, cache.accels_built), built, "nothing changed, nothing rebuilt");
    let bits = |img: Vec<[f32; 3]>| img.iter().flat_map(|p| p.map(f32::to_bits)).collect::<Vec<_>>();
    assert_eq!(bits(render(&first)), bits(render(&again)));

    // Through the builder directly: geometry under a key is built once.
    let at = Location::new(Arc::new("memory".into()), 0, 0);
    let mut cache = GeometryCache::default();
    for _ in 0..2 {
        let mut s = SceneBuilder::with_cache(at.clone(), &mut cache);
        let m = s.add_material(Material::Diffuse(DiffuseParams { reflectance: Vec3::splat(0.5).into() }));
        let (geometry, note) = s
            .cached_geometry("floor", || {
                Ok((floor().into_geometry(&Mat4::IDENTITY, false, false, &at)?, vec!["n".into()]))
            })
            .unwrap();
        assert_eq!(note, ["n"]);
        let id =
            s.add_shape(ShapeDesc { cache_key: Some("floor".into()), ..ShapeDesc::new(geometry, m) }, &at).unwrap();
        s.place_shape(id);
        s.set_camera(Camera::new(Mat4::from_cols_array(&CAMERA), 45.0, FovAxis::X, 8, 6, 0.01, 100.0), None);
        s.set_film(Film::new(8, 6), Filter::new(FilterKind::Box));
        s.finish_cached(&mut cache).unwrap();
    }
    assert_eq!((cache.shapes_built, cache.accels_built), (1, 1));
}
