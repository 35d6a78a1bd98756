//! `penumbra.Scene`: a scene file (or text) with its `-D` definitions and the
//! parameter values set from Python. Each render builds the render job from
//! the parsed description with those values applied, reusing the geometry
//! and BVH of the previous build where the shapes did not change
//! (`builder::GeometryCache`), so a parameter sweep does not reload meshes.

use crate::load_error;
use numpy::{PyArray2, PyReadonlyArray2};
use penumbra_render::render::RenderJob;
use penumbra_scene::builder::{self, GeometryCache};
use penumbra_scene::desc::{Node, Override, SceneDesc, Value};
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
}

/// A loaded scene (`penumbra.load_file`, `load_string`, `load_dict`).
#[pyclass(module = "penumbra")]
pub struct Scene {
    source: Source,
    defines: Vec<(String, String)>,
    /// Values set with `set`, in order.
    overrides: Vec<Override>,
    cache: GeometryCache,
    /// The job with the scene's own spp, seed and integrator, for the
    /// attributes below.
    job: RenderJob,
}

/// The description of `source` with `overrides` applied.
fn parse(source: &Source, defines: &[(String, String)], overrides: &[Override]) -> Result<SceneDesc, LoadError> {
    let desc = match source {
        Source::File(p) => mitsuba::parse_file(p, defines)?,
        Source::Text { text, path } => mitsuba::parse_str(text, path, defines)?,
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
        let desc = self.parse()?;
        builder::build_cached(&desc, ov, &mut self.cache).map_err(|e| desc.explain(e))
    }

    /// The bytes that identify the scene's text (checkpoint identity).
    pub(crate) fn source_bytes(&self) -> Vec<u8> {
        match &self.source {
            Source::File(p) => std::fs::read(p).unwrap_or_default(),
            Source::Text { text, .. } => text.as_bytes().to_vec(),
        }
    }

    /// The definitions, for the checkpoint identity.
    pub(crate) fn defines(&self) -> &[(String, String)] {
        &self.defines
    }

    /// The values set, as text (checkpoint identity).
    pub(crate) fn overrides_text(&self) -> String {
        self.overrides.iter().map(|o| format!("{}.{}={:?}", o.id, o.name, o.value)).collect::<Vec<_>>().join(" ")
    }

    fn load(py: Python<'_>, source: Source, defines: Vec<(String, String)>) -> PyResult<Scene> {
        let mut cache = GeometryCache::default();
        let job = parse(&source, &defines, &[])
            .and_then(|desc| builder::build_cached(&desc, &Overrides::default(), &mut cache))
            .map_err(|e| load_error(py, &e))?;
        Ok(Scene { source, defines, overrides: Vec::new(), cache, job })
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

/// Reads a Mitsuba 3 XML file, `params` as its `-D name=value` definitions.
#[pyfunction]
#[pyo3(signature = (path, params=None))]
pub fn load_file(py: Python<'_>, path: PathBuf, params: Option<&Bound<'_, PyDict>>) -> PyResult<Scene> {
    Scene::load(py, Source::File(path), defines_of(params)?)
}

/// Parses Mitsuba 3 XML text; relative file names resolve from `base_dir`
/// (default: the working directory), and messages name the text `name`.
#[pyfunction]
#[pyo3(signature = (text, params=None, base_dir=None, name="<string>"))]
pub fn load_string(
    py: Python<'_>,
    text: String,
    params: Option<&Bound<'_, PyDict>>,
    base_dir: Option<PathBuf>,
    name: &str,
) -> PyResult<Scene> {
    let path = base_dir.unwrap_or_default().join(name);
    Scene::load(py, Source::Text { text, path }, defines_of(params)?)
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
        let (id, name) = split_key(key)?;
        let value = to_value(value)?;
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
            Source::File(p) => format!("'{}'", p.display()),
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
