//! `penumbra.Scene`: a scene file (or text) with its `-D` definitions and the
//! parameter values set from Python. Each render builds the render job from
//! the parsed description with those values applied, reusing the geometry
//! and BVH of the previous build where the shapes did not change
//! (`builder::GeometryCache`), so a parameter sweep does not reload meshes.

use crate::load_error;
use numpy::{PyArray2, PyArrayMethods, PyReadonlyArray2, PyUntypedArrayMethods};
use penumbra_render::material::Material;
use penumbra_render::render::RenderJob;
use penumbra_scene::builder::{self, GeometryCache};
use penumbra_scene::desc::{Node, Override, SceneDesc, Value};
use penumbra_scene::scene_builder::{Emission, MeshData, ShapeDesc};
use penumbra_scene::{mitsuba, LoadError, Overrides};
use pyo3::exceptions::{PyKeyError, PyTypeError, PyValueError};
use pyo3::prelude::*;
use pyo3::types::{PyBool, PyDict, PyFloat, PyInt, PyString};
use std::path::PathBuf;

/// Where the scene's text comes from.
#[derive(Clone)]
enum Source {
    File(PathBuf),
    /// Text parsed as if it were the file `path` (relative names resolve
    /// from its directory).
    Text {
        text: String,
        path: PathBuf,
    },
    /// A pbrt-v4 or glTF 2.0 file, rendered as it is: no definitions,
    /// `set` or `add_mesh` (those work on Mitsuba's object model).
    Other(PathBuf),
}

impl Source {
    /// `path` as a source, its format chosen by extension as `penumbra render` does.
    fn file(path: PathBuf) -> Source {
        let ext = path.extension().and_then(|e| e.to_str()).map(str::to_ascii_lowercase);
        if penumbra_scene::is_pbrt(&path) || matches!(ext.as_deref(), Some("gltf" | "glb")) {
            Source::Other(path)
        } else {
            Source::File(path)
        }
    }

    /// The file the scene comes from (or that its text stands for).
    fn path(&self) -> &PathBuf {
        match self {
            Source::File(p) | Source::Other(p) => p,
            Source::Text { path, .. } => path,
        }
    }
}

/// A loaded scene (`penumbra.load_file`, `load_string`, `load_dict`).
#[pyclass(module = "penumbra")]
pub struct Scene {
    source: Source,
    defines: Vec<(String, String)>,
    /// Values set with `set`, in order.
    overrides: Vec<Override>,
    cache: GeometryCache,
    /// Meshes added from arrays (`add_mesh`), placed after the file's shapes.
    meshes: Vec<ArrayMesh>,
    /// The job with the scene's own spp, seed and integrator, for the
    /// attributes below.
    job: RenderJob,
}

/// A mesh given as arrays (`Scene.add_mesh`), with what it is made of.
#[derive(Clone)]
struct ArrayMesh {
    data: MeshData,
    /// The id of a top-level `<bsdf>` of the scene; `None`: Mitsuba's default
    /// diffuse (reflectance 0.5).
    bsdf: Option<String>,
    /// Diffuse emitted radiance (an area light), if any.
    emission: Option<[f32; 3]>,
    to_world: glam::Mat4,
    /// Where errors point: `add_mesh #k` of the scene's file.
    loc: penumbra_scene::FileLoc,
}

impl ArrayMesh {
    /// Adds the mesh to the scene being built.
    fn add(&self, b: &mut penumbra_scene::SceneBuilder) -> penumbra_scene::Result<()> {
        use penumbra_render::bsdf::DiffuseParams;
        use penumbra_render::math::Spectrum;
        let material = match &self.bsdf {
            Some(id) => b.material(id).ok_or_else(|| {
                penumbra_scene::LoadError::at(
                    &self.loc,
                    format!("no top-level <bsdf id=\"{id}\"> in the scene for this mesh; declare it at the top level"),
                )
            })?,
            None => b.add_material(Material::Diffuse(DiffuseParams { reflectance: Spectrum::splat(0.5).into() })),
        };
        let geometry = self.data.clone().into_geometry(&self.to_world, false, false, &self.loc)?;
        let mut desc = ShapeDesc::new(geometry, material);
        desc.emission = self.emission.map(|e| Emission::Diffuse(Spectrum::from_array(e).into()));
        let id = b.add_shape(desc, &self.loc)?;
        b.place_shape(id);
        Ok(())
    }
}

/// The description of `source` with `overrides` applied.
fn parse(source: &Source, defines: &[(String, String)], overrides: &[Override]) -> Result<SceneDesc, LoadError> {
    let desc = match source {
        Source::File(p) => mitsuba::parse_file(p, defines)?,
        Source::Text { text, path } => mitsuba::parse_str(text, path, defines)?,
        Source::Other(p) => return Err(LoadError::in_file(
            p,
            "parameters, set and add_mesh work on Mitsuba XML scenes only; this pbrt-v4 or glTF scene renders as it is",
        )),
    };
    if overrides.is_empty() {
        return Ok(desc);
    }
    desc.with_overrides(overrides).map_err(|m| LoadError::new(None, m))
}

impl Scene {
    fn parse(&self) -> Result<SceneDesc, LoadError> {
        parse(&self.source, &self.defines, &self.overrides)
    }

    /// The render job for `ov`, with the values set so far.
    pub(crate) fn job(&mut self, ov: &Overrides) -> Result<RenderJob, LoadError> {
        if let Source::Other(p) = &self.source {
            return penumbra_scene::load_scene(p, &[], ov);
        }
        let desc = self.parse()?;
        let meshes = &self.meshes;
        builder::build_cached_with(&desc, ov, &mut self.cache, &mut |b| meshes.iter().try_for_each(|m| m.add(b)))
            .map_err(|e| desc.explain(e))
    }

    /// The bytes that identify the scene's text (checkpoint identity).
    pub(crate) fn source_bytes(&self) -> Vec<u8> {
        match &self.source {
            Source::File(p) | Source::Other(p) => std::fs::read(p).unwrap_or_default(),
            Source::Text { text, .. } => text.as_bytes().to_vec(),
        }
    }

    /// The definitions, for the checkpoint identity.
    pub(crate) fn defines(&self) -> &[(String, String)] {
        &self.defines
    }

    /// The values set, as text (checkpoint identity).
    pub(crate) fn overrides_text(&self) -> String {
        let value = |v: &Value| match v {
            // An image by its size and a hash of its bits, not pixel by pixel.
            Value::Image(img) => {
                let mut h = 0xcbf2_9ce4_8422_2325u64;
                for c in img.pixels.iter().flatten() {
                    h = (h ^ c.to_bits() as u64).wrapping_mul(0x100_0000_01b3);
                }
                format!("image({}x{} {h:016x})", img.width, img.height)
            }
            v => format!("{v:?}"),
        };
        let mut text = self
            .overrides
            .iter()
            .map(|o| format!("{}.{}={}", o.id, o.name, value(&o.value)))
            .collect::<Vec<_>>()
            .join(" ");
        // Meshes from arrays: their whole content (a checkpoint resumes only the same scene).
        for m in &self.meshes {
            text.push_str(&format!(
                " mesh({:?} {:?} {:?} {:?} {:?} {:?} {:?} {:?})",
                m.data.positions,
                m.data.indices,
                m.data.normals,
                m.data.uvs,
                m.data.colors,
                m.bsdf,
                m.emission,
                m.to_world
            ));
        }
        text
    }

    fn load(
        py: Python<'_>,
        source: Source,
        defines: Vec<(String, String)>,
        overrides: Vec<Override>,
    ) -> PyResult<Scene> {
        let mut cache = GeometryCache::default();
        let job = match &source {
            Source::Other(p) => {
                if let Some((name, _)) = defines.first() {
                    return Err(PyValueError::new_err(format!(
                        "{name}=...: definitions apply to Mitsuba XML scenes only, not to '{}'",
                        p.display()
                    )));
                }
                penumbra_scene::load_scene(p, &[], &Overrides::default())
            }
            _ => parse(&source, &defines, &overrides).and_then(|desc| {
                builder::build_cached(&desc, &Overrides::default(), &mut cache).map_err(|e| desc.explain(e))
            }),
        }
        .map_err(|e| load_error(py, &e))?;
        Ok(Scene { source, defines, overrides, cache, meshes: Vec::new(), job })
    }
}

fn defines_of(params: Option<&Bound<'_, PyDict>>) -> PyResult<Vec<(String, String)>> {
    let mut out = Vec::new();
    if let Some(d) = params {
        for (k, v) in d.iter() {
            let k: String = k.extract()?;
            // As `-D name=value` text: booleans as Mitsuba writes them.
            let v = if v.is_instance_of::<PyBool>() {
                if v.extract::<bool>()? { "true" } else { "false" }.to_string()
            } else {
                v.str()?.to_string()
            };
            out.push((k, v));
        }
    }
    Ok(out)
}

/// Reads a scene file, its format chosen by extension as `penumbra render`
/// does: Mitsuba 3 XML (`params` as its `-D name=value` definitions),
/// pbrt-v4 (`.pbrt`, `.pbrt.gz`) or glTF 2.0 (`.gltf`, `.glb`).
#[pyfunction]
#[pyo3(signature = (path, params=None))]
pub fn load_file(py: Python<'_>, path: PathBuf, params: Option<&Bound<'_, PyDict>>) -> PyResult<Scene> {
    Scene::load(py, Source::file(path), defines_of(params)?, Vec::new())
}

/// Parses Mitsuba 3 XML text; relative file names resolve from `base_dir`
/// (default: the working directory), and messages name the text `name`.
/// `images`: `(object id, parameter, array)` set before the first build,
/// as `Scene.set` would (how `load_dict` passes `data` arrays).
#[pyfunction]
#[pyo3(signature = (text, params=None, base_dir=None, name="<string>", images=None))]
pub fn load_string(
    py: Python<'_>,
    text: String,
    params: Option<&Bound<'_, PyDict>>,
    base_dir: Option<PathBuf>,
    name: &str,
    images: Option<Vec<(String, String, Bound<'_, PyAny>)>>,
) -> PyResult<Scene> {
    let path = base_dir.unwrap_or_default().join(name);
    let mut overrides = Vec::new();
    for (id, name, a) in images.unwrap_or_default() {
        let value = to_image(&a, &format!("{id}.{name}"))?;
        overrides.push(Override { id, name, value });
    }
    Scene::load(py, Source::Text { text, path }, defines_of(params)?, overrides)
}

/// A numpy image as a scene value: `(H, W, 3)` linear RGB, or `(H, W)` /
/// `(H, W, 1)` grey, any float dtype; every value finite. Row 0 is the
/// image's top row, as in an image file.
fn to_image(a: &Bound<'_, PyAny>, what: &str) -> PyResult<Value> {
    let np = a.py().import("numpy")?;
    let arr = np
        .call_method1("asarray", (a, "float32"))
        .map_err(|e| PyTypeError::new_err(format!("{what}: not an array of numbers ({e})")))?;
    let shape: Vec<usize> = arr.getattr("shape")?.extract()?;
    let (h, w, c) = match shape[..] {
        [h, w] => (h, w, 1),
        [h, w, c] if c == 1 || c == 3 => (h, w, c),
        _ => {
            return Err(PyValueError::new_err(format!(
                "{what}: an image is an (H, W, 3) or (H, W) array, not {shape:?}"
            )))
        }
    };
    if h == 0 || w == 0 || h > u32::MAX as usize || w > u32::MAX as usize {
        return Err(PyValueError::new_err(format!("{what}: an image of {w}x{h} pixels")));
    }
    let flat: Vec<f32> = np.call_method1("ascontiguousarray", (arr,))?.call_method0("ravel")?.extract()?;
    if let Some(k) = flat.iter().position(|x| !x.is_finite()) {
        let (y, x) = (k / c / w, k / c % w);
        return Err(PyValueError::new_err(format!(
            "{what}: pixel (row {y}, column {x}) is {}, not a finite number",
            flat[k]
        )));
    }
    let pixels = flat.chunks_exact(c).map(|p| if c == 1 { [p[0]; 3] } else { [p[0], p[1], p[2]] }).collect();
    Ok(Value::Image(std::sync::Arc::new(penumbra_scene::image_io::RgbImage {
        width: w as u32,
        height: h as u32,
        pixels,
    })))
}

/// The rows of a `(rows, N)` array, each finite; `what` names it in errors.
/// `a` as a 2D array of `dtype` (any array-like numpy converts; integer
/// arrays only for `int64`, so that float indices are not truncated).
fn as_array<'py, T: numpy::Element>(
    a: &Bound<'py, PyAny>,
    dtype: &str,
    what: &str,
) -> PyResult<PyReadonlyArray2<'py, T>> {
    let np = a.py().import("numpy")?;
    let arr = np.call_method1("asarray", (a,))?;
    let kind: String = arr.getattr("dtype")?.getattr("kind")?.extract()?;
    let ok =
        if dtype == "int64" { matches!(kind.as_str(), "i" | "u") } else { matches!(kind.as_str(), "f" | "i" | "u") };
    let ndim: usize = arr.getattr("ndim")?.extract()?;
    if !ok || ndim != 2 {
        let shape = arr.getattr("shape")?.str()?.to_string();
        return Err(PyValueError::new_err(format!(
            "{what}: a 2D array of {} numbers, not shape {shape} of dtype kind '{kind}'",
            if dtype == "int64" { "integer" } else { "real" }
        )));
    }
    let kw = PyDict::new(a.py());
    kw.set_item("dtype", dtype)?;
    let out = np.call_method("ascontiguousarray", (arr,), Some(&kw))?;
    out.extract::<PyReadonlyArray2<'py, T>>().map_err(|e| PyValueError::new_err(format!("{what}: {e}")))
}

trait Finite: numpy::Element + Copy + std::fmt::Display {
    fn finite(self) -> bool;
}
impl Finite for f64 {
    fn finite(self) -> bool {
        self.is_finite()
    }
}
impl Finite for i64 {
    fn finite(self) -> bool {
        true
    }
}

fn rows<const N: usize, T: Finite>(a: &PyReadonlyArray2<'_, T>, what: &str) -> PyResult<Vec<[T; N]>> {
    let shape = a.shape();
    if shape[1] != N {
        return Err(PyValueError::new_err(format!("{what}: shape ({}, {}), expected (n, {N})", shape[0], shape[1])));
    }
    let a = a.as_array();
    let mut out = Vec::with_capacity(shape[0]);
    for (i, row) in a.rows().into_iter().enumerate() {
        let mut r = [row[0]; N];
        for (j, &v) in row.iter().enumerate() {
            if !v.finite() {
                return Err(PyValueError::new_err(format!("{what}: row {i} holds {v}")));
            }
            r[j] = v;
        }
        out.push(r);
    }
    Ok(out)
}

/// A Python value as a scene value: bool, int, float, str, a 3-sequence
/// (rgb), or a 4x4 matrix (transform). NaN, infinities and numbers past
/// the single-precision range are refused, as the scene reader refuses them.
fn to_value(v: &Bound<'_, PyAny>) -> PyResult<Value> {
    let value = to_value_unchecked(v)?;
    let numbers: Vec<f64> = match &value {
        Value::Float(x) => vec![*x],
        Value::Rgb(c) => c.to_vec(),
        Value::Transform(m) => m.to_cols_array().to_vec(),
        _ => Vec::new(),
    };
    if let Some(x) = numbers.iter().find(|x| !x.is_finite() || x.abs() > f32::MAX as f64) {
        return Err(PyValueError::new_err(format!(
            "cannot set a parameter to {x}: scene values must be finite numbers (at most {:e} in magnitude)",
            f32::MAX
        )));
    }
    Ok(value)
}

fn to_value_unchecked(v: &Bound<'_, PyAny>) -> PyResult<Value> {
    if v.is_instance_of::<PyBool>() {
        return Ok(Value::Boolean(v.extract()?));
    }
    if v.is_instance_of::<PyInt>() {
        return Ok(Value::Integer(v.extract()?));
    }
    if v.is_instance_of::<PyFloat>() {
        return Ok(Value::Float(v.extract()?));
    }
    if v.is_instance_of::<PyString>() {
        return Ok(Value::String(v.extract()?));
    }
    if let Ok(m) = v.extract::<PyReadonlyArray2<f64>>() {
        let a = m.as_array();
        if a.shape() != [4, 4] {
            return Err(PyValueError::new_err(format!("a transform is a 4x4 matrix, not {:?}", a.shape())));
        }
        // Row-major as written; glam stores columns.
        let cols: Vec<f64> = (0..16).map(|i| a[[i % 4, i / 4]]).collect();
        return Ok(Value::Transform(glam::DMat4::from_cols_slice(&cols)));
    }
    if let Ok(m) = v.extract::<Vec<Vec<f64>>>() {
        if m.len() == 4 && m.iter().all(|r| r.len() == 4) {
            let cols: Vec<f64> = (0..16).map(|i| m[i % 4][i / 4]).collect();
            return Ok(Value::Transform(glam::DMat4::from_cols_slice(&cols)));
        }
    }
    if let Ok(c) = v.extract::<Vec<f64>>() {
        if c.len() == 3 {
            return Ok(Value::Rgb([c[0], c[1], c[2]]));
        }
    }
    Err(PyTypeError::new_err(format!(
        "cannot set a parameter to {}: give a bool, int, float, str, 3 numbers (rgb) or a 4x4 matrix",
        v.get_type().name()?
    )))
}

fn from_value<'py>(py: Python<'py>, v: &Value) -> PyResult<Bound<'py, PyAny>> {
    Ok(match v {
        Value::Float(x) | Value::SpectrumConstant(x) => x.into_pyobject(py)?.into_any(),
        Value::Integer(k) => k.into_pyobject(py)?.into_any(),
        Value::Boolean(b) => b.into_pyobject(py)?.to_owned().into_any(),
        Value::String(s) => s.into_pyobject(py)?.into_any(),
        Value::Rgb(c) => c.to_vec().into_pyobject(py)?.into_any(),
        Value::Point(p) | Value::Vector(p) => p.to_array().to_vec().into_pyobject(py)?.into_any(),
        Value::SpectrumSampled(s) => s.clone().into_pyobject(py)?.into_any(),
        Value::Transform(m) => matrix(py, m)?.into_any(),
        Value::Image(img) => {
            let flat: Vec<f32> = img.pixels.iter().flatten().copied().collect();
            numpy::PyArray1::from_vec(py, flat).reshape([img.height as usize, img.width as usize, 3])?.into_any()
        }
    })
}

/// A transform as a row-major 4x4 numpy array.
fn matrix<'py>(py: Python<'py>, m: &glam::DMat4) -> PyResult<Bound<'py, PyArray2<f64>>> {
    let rows: Vec<Vec<f64>> = (0..4).map(|r| m.row(r).to_array().to_vec()).collect();
    Ok(PyArray2::from_vec2(py, &rows).expect("4x4"))
}

/// `"id.name"` (or Mitsuba's `"id.name.value"`) split into id and name.
fn split_key(key: &str) -> PyResult<(String, String)> {
    let key = key.strip_suffix(".value").unwrap_or(key);
    match key.rsplit_once('.') {
        Some((id, name)) if !id.is_empty() && !name.is_empty() => Ok((id.to_string(), name.to_string())),
        _ => Err(PyKeyError::new_err(format!(
            "'{key}': name a parameter as 'object_id.parameter', e.g. 'red.reflectance'"
        ))),
    }
}

/// Every property of every object with an id (and of an unnamed sensor, as
/// `sensor.*`), in document order.
fn parameters(node: &Node, out: &mut Vec<(String, Value)>, seen: &mut Vec<*const Node>) {
    if seen.contains(&(node as *const Node)) {
        return;
    }
    seen.push(node);
    let id = node.id.clone().or_else(|| (node.kind == penumbra_scene::desc::Kind::Sensor).then(|| "sensor".into()));
    if let Some(id) = id {
        for p in &node.props {
            out.push((format!("{id}.{}", p.name), p.value.clone()));
        }
    }
    for c in &node.children {
        parameters(&c.node, out, seen);
    }
}

#[pymethods]
impl Scene {
    /// Film width in pixels (the crop window's, if the scene has one).
    #[getter]
    fn width(&self) -> u32 {
        self.job.width
    }

    /// Film height in pixels.
    #[getter]
    fn height(&self) -> u32 {
        self.job.height
    }

    /// The sampler's samples per pixel.
    #[getter]
    fn spp(&self) -> u32 {
        self.job.sampler.spp
    }

    /// The sampler's seed.
    #[getter]
    fn seed(&self) -> u64 {
        self.job.sampler.seed
    }

    /// The camera's to_world (row-major 4x4; set it with
    /// `set("sensor.to_world", m)` or the sensor's id).
    #[getter]
    fn camera_to_world<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArray2<f64>>> {
        matrix(py, &self.job.camera.world_from_camera.as_dmat4())
    }

    /// Shapes whose geometry was built (meshes read) and top-level BVHs
    /// built, over the scene's life: a parameter change that leaves the
    /// shapes alone adds to neither.
    #[getter]
    fn geometry_builds(&self) -> (u64, u64) {
        (self.cache.shapes_built, self.cache.accels_built)
    }

    /// The scene's parameters as `{"id.name": value}`: every property of
    /// every object with an id, values set with `set` included.
    fn parameters<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let desc = self.parse().map_err(|e| load_error(py, &e))?;
        let mut list = Vec::new();
        parameters(&desc.root, &mut list, &mut Vec::new());
        let d = PyDict::new(py);
        for (k, v) in list {
            d.set_item(k, from_value(py, &v)?)?;
        }
        Ok(d)
    }

    /// Sets parameter `key` (`"red.reflectance"`, `"light.radiance"`,
    /// `"sensor.to_world"`; Mitsuba's `".value"` suffix is accepted) and
    /// rebuilds what depends on it; geometry is rebuilt only for a shape
    /// whose own parameters change.
    fn set(&mut self, py: Python<'_>, key: &str, value: &Bound<'_, PyAny>) -> PyResult<()> {
        if matches!(self.source, Source::Other(_)) {
            return Err(load_error(py, &self.parse().expect_err("not Mitsuba XML")));
        }
        let (id, name) = split_key(key)?;
        // `data`: a bitmap texture's or an environment map's image, as in Mitsuba.
        let value = if name == "data" { to_image(value, key)? } else { to_value(value)? };
        self.overrides.push(Override { id, name, value });
        match self.job(&Overrides::default()) {
            Ok(job) => {
                self.job = job;
                Ok(())
            }
            Err(e) => {
                self.overrides.pop();
                Err(load_error(py, &e))
            }
        }
    }

    /// Adds a triangle mesh given as arrays (float64 `(N, 3)` positions,
    /// `(M, 3)` vertex indices, optional `(N, 3)` normals, `(N, 2)` uvs and
    /// `(N, 3)` linear RGB colours, the latter read as the `vertex_color`
    /// mesh attribute), made of the scene's top-level `<bsdf id=...>` `bsdf`
    /// (default: diffuse 0.5), emitting `emission` (RGB radiance) if given,
    /// placed by `to_world` (4x4). It goes straight into the scene builder,
    /// as a PLY file's mesh would, and stays in every later render.
    #[pyo3(signature = (positions, indices, normals=None, uvs=None, colors=None, bsdf=None, emission=None, to_world=None))]
    #[allow(clippy::too_many_arguments)]
    fn add_mesh(
        &mut self,
        py: Python<'_>,
        positions: &Bound<'_, PyAny>,
        indices: &Bound<'_, PyAny>,
        normals: Option<&Bound<'_, PyAny>>,
        uvs: Option<&Bound<'_, PyAny>>,
        colors: Option<&Bound<'_, PyAny>>,
        bsdf: Option<String>,
        emission: Option<[f64; 3]>,
        to_world: Option<&Bound<'_, PyAny>>,
    ) -> PyResult<()> {
        if let Source::Other(p) = &self.source {
            return Err(PyValueError::new_err(format!(
                "add_mesh works on Mitsuba XML scenes only; '{}' is a pbrt-v4 or glTF scene",
                p.display()
            )));
        }
        let k = self.meshes.len();
        let what = |name: &str| format!("add_mesh #{k}: {name}");
        let positions = as_array::<f64>(positions, "float64", &what("positions"))?;
        let indices = as_array::<i64>(indices, "int64", &what("indices"))?;
        let normals = normals.map(|a| as_array::<f64>(a, "float64", &what("normals"))).transpose()?;
        let uvs = uvs.map(|a| as_array::<f64>(a, "float64", &what("uvs"))).transpose()?;
        let colors = colors.map(|a| as_array::<f64>(a, "float64", &what("colors"))).transpose()?;
        let to_world = to_world.map(|a| as_array::<f64>(a, "float64", &what("to_world"))).transpose()?;
        let positions = rows::<3, _>(&positions, &what("positions"))?;
        let n = positions.len();
        let mut idx = Vec::with_capacity(indices.shape()[0]);
        for (f, t) in rows::<3, _>(&indices, &what("indices"))?.into_iter().enumerate() {
            let mut tri = [0u32; 3];
            for (j, &i) in t.iter().enumerate() {
                if i < 0 || i as usize >= n {
                    return Err(PyValueError::new_err(format!(
                        "{}: triangle {f} has vertex index {i}, outside 0..{n}",
                        what("indices")
                    )));
                }
                tri[j] = i as u32;
            }
            idx.push(tri);
        }
        let v3 = |r: [f64; 3]| glam::Vec3::new(r[0] as f32, r[1] as f32, r[2] as f32);
        let per_vertex = |a: &Option<PyReadonlyArray2<'_, f64>>, name: &str| -> PyResult<()> {
            match a {
                Some(a) if a.shape()[0] != n => {
                    Err(PyValueError::new_err(format!("{}: {} rows for {n} vertices", what(name), a.shape()[0])))
                }
                _ => Ok(()),
            }
        };
        per_vertex(&normals, "normals")?;
        per_vertex(&uvs, "uvs")?;
        per_vertex(&colors, "colors")?;
        let normals = match &normals {
            Some(a) => rows::<3, _>(a, &what("normals"))?.into_iter().map(v3).collect(),
            None => Vec::new(),
        };
        let uvs = match &uvs {
            Some(a) => {
                rows::<2, _>(a, &what("uvs"))?.into_iter().map(|r| glam::Vec2::new(r[0] as f32, r[1] as f32)).collect()
            }
            None => Vec::new(),
        };
        let colors = match &colors {
            Some(a) => rows::<3, _>(a, &what("colors"))?.into_iter().map(v3).collect(),
            None => Vec::new(),
        };
        let to_world = match &to_world {
            Some(m) => {
                let r = rows::<4, _>(m, &what("to_world"))?;
                if r.len() != 4 {
                    return Err(PyValueError::new_err(format!(
                        "{}: a 4x4 matrix, not {}x4",
                        what("to_world"),
                        r.len()
                    )));
                }
                // Rows as written; glam is column-major.
                glam::DMat4::from_cols_array_2d(&[r[0], r[1], r[2], r[3]]).transpose().as_mat4()
            }
            None => glam::Mat4::IDENTITY,
        };
        if let Some(e) = emission {
            if e.iter().any(|c| !c.is_finite() || *c < 0.0) {
                return Err(PyValueError::new_err(format!(
                    "{}: {e:?} is not a finite radiance >= 0",
                    what("emission")
                )));
            }
        }
        let file = self.source.path().clone();
        self.meshes.push(ArrayMesh {
            data: MeshData {
                positions: positions.into_iter().map(v3).collect(),
                indices: idx,
                normals,
                uvs,
                colors,
                ..Default::default()
            },
            bsdf,
            emission: emission.map(|e| e.map(|c| c as f32)),
            to_world,
            loc: penumbra_scene::FileLoc::with_place(std::sync::Arc::new(file), format!("add_mesh #{k}")),
        });
        match self.job(&Overrides::default()) {
            Ok(job) => {
                self.job = job;
                Ok(())
            }
            Err(e) => {
                self.meshes.pop();
                Err(load_error(py, &e))
            }
        }
    }

    /// The value of parameter `key`.
    fn get<'py>(&self, py: Python<'py>, key: &str) -> PyResult<Bound<'py, PyAny>> {
        let params = self.parameters(py)?;
        let (id, name) = split_key(key)?;
        params
            .get_item(format!("{id}.{name}"))?
            .ok_or_else(|| PyKeyError::new_err(format!("no parameter '{id}.{name}'")))
    }

    fn __repr__(&self) -> String {
        let what = match &self.source {
            Source::File(p) | Source::Other(p) => format!("'{}'", p.display()),
            Source::Text { path, .. } => format!("text '{}'", path.display()),
        };
        format!(
            "Scene({what}, {}x{}, {} spp, {} shapes, {} lights)",
            self.job.width,
            self.job.height,
            self.job.sampler.spp,
            self.job.scene.shapes.len(),
            self.job.scene.lights.len()
        )
    }
}
