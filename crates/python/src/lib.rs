//! `penumbra._penumbra`, the native module of the `penumbra` Python package
//! (the Python side, `python/penumbra/`, is the public API and documents
//! it). One file per concept: `scene` (a loaded scene and its parameters),
//! `session` (rendering with the GIL released, Ctrl-C and progress),
//! `images` (reading and writing image files). Everything below is the
//! command line's own code (the `penumbra` crate's library), so an image
//! rendered from Python is bitwise the command line's.

mod images;
mod scene;
mod session;

use pyo3::create_exception;
use pyo3::exceptions::PyException;
use pyo3::prelude::*;

create_exception!(
    _penumbra,
    Error,
    PyException,
    "A scene, image or render error; `file`, `line` and `column` say where, when known."
);

/// A Python `penumbra.Error` from a load error, with its position.
pub(crate) fn load_error(py: Python<'_>, e: &penumbra_scene::LoadError) -> PyErr {
    let err = Error::new_err(e.to_string());
    let value = err.value(py);
    let (file, line, col) = match &e.loc {
        Some(l) => (Some(l.file.display().to_string()), l.line, l.col),
        None => (None, 0, 0),
    };
    let _ = value.setattr("file", file);
    let _ = value.setattr("line", (line > 0).then_some(line));
    let _ = value.setattr("column", (col > 0).then_some(col));
    let _ = value.setattr("message", e.message.clone());
    err
}

/// A `penumbra.Error` from any other error (its whole chain of causes).
pub(crate) fn error(e: impl std::fmt::Display) -> PyErr {
    Error::new_err(e.to_string())
}

/// A `penumbra.Error` from an `anyhow` error, with its causes.
pub(crate) fn anyhow_error(e: anyhow::Error) -> PyErr {
    Error::new_err(format!("{e:#}"))
}

/// The plugin names Penumbra builds, by object kind (`bsdf`, `shape`, ...):
/// what `load_dict` needs to tell a nested object's tag from its `type`.
#[pyfunction]
fn plugins() -> Vec<(&'static str, Vec<&'static str>)> {
    use penumbra_scene::desc::Kind;
    let kinds = [
        Kind::Shape,
        Kind::Bsdf,
        Kind::Texture,
        Kind::Emitter,
        Kind::Sensor,
        Kind::Film,
        Kind::Rfilter,
        Kind::Sampler,
        Kind::Integrator,
        Kind::Medium,
        Kind::Phase,
        Kind::Volume,
    ];
    kinds
        .iter()
        .map(|&k| {
            let names = penumbra_scene::supported_plugins(k)
                .into_iter()
                .map(|e| e.split_once(' ').map_or(e, |(n, _)| n))
                .collect();
            (k.tag(), names)
        })
        .collect()
}

#[pymodule]
fn _penumbra(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add("Error", m.py().get_type::<Error>())?;
    m.add("__version__", penumbra::settings::VERSION)?;
    m.add_class::<scene::Scene>()?;
    m.add_function(wrap_pyfunction!(plugins, m)?)?;
    m.add_function(wrap_pyfunction!(scene::load_file, m)?)?;
    m.add_function(wrap_pyfunction!(scene::load_string, m)?)?;
    m.add_function(wrap_pyfunction!(session::render, m)?)?;
    m.add_function(wrap_pyfunction!(images::read, m)?)?;
    m.add_function(wrap_pyfunction!(images::write, m)?)?;
    Ok(())
}
