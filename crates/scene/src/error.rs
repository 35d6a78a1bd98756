//! Load errors: every one names the file and, where known, the line.

use std::fmt;
use std::path::PathBuf;
use std::sync::Arc;

/// A position in a scene file.
#[derive(Debug, Clone)]
pub struct FileLoc {
    /// The scene file.
    pub file: Arc<PathBuf>,
    /// Line number, 1-based (0 when unknown).
    pub line: u32,
    /// Column number, 1-based (0 when unknown).
    pub col: u32,
    /// The directories a relative file name given at this position is
    /// looked up in, in order (Mitsuba's file resolver after `<path>`
    /// elements); `None` means the directory of `file` alone.
    pub search: Option<Arc<Vec<PathBuf>>>,
    /// A position that is not a line (when `line` is 0): a glTF JSON
    /// pointer (`/meshes/0/primitives/1`), a byte offset (`byte 1024`).
    pub place: Option<Arc<str>>,
}

impl FileLoc {
    /// A position without search directories.
    pub fn new(file: Arc<PathBuf>, line: u32, col: u32) -> Self {
        FileLoc { file, line, col, search: None, place: None }
    }

    /// A position in `file` given by `place` (a JSON pointer, a byte offset):
    /// shown as `FILE at PLACE`.
    pub fn with_place(file: Arc<PathBuf>, place: impl Into<Arc<str>>) -> Self {
        FileLoc { file, line: 0, col: 0, search: None, place: Some(place.into()) }
    }

    /// The directories searched for a relative file name given here.
    pub fn search_dirs(&self) -> Vec<PathBuf> {
        match &self.search {
            Some(dirs) => dirs.as_ref().clone(),
            None => vec![self.file.parent().unwrap_or(std::path::Path::new("")).to_path_buf()],
        }
    }
}

/// Two positions are equal when file, line, column and place are (search
/// directories are context, not position).
impl PartialEq for FileLoc {
    fn eq(&self, other: &Self) -> bool {
        self.file == other.file && self.line == other.line && self.col == other.col && self.place == other.place
    }
}
impl Eq for FileLoc {}

impl fmt::Display for FileLoc {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match &self.place {
            Some(place) if self.line == 0 => write!(f, "{} at {place}", self.file.display()),
            _ => write!(f, "{}:{}:{}", self.file.display(), self.line, self.col),
        }
    }
}

/// An error while reading a scene or one of the files it refers to.
#[derive(Debug, Clone, thiserror::Error)]
pub struct LoadError {
    /// Where the problem is; `None` for errors about the command line.
    pub loc: Option<FileLoc>,
    /// What went wrong.
    pub message: String,
}

impl LoadError {
    /// An error at `loc`, if any.
    pub fn new(loc: Option<FileLoc>, message: impl Into<String>) -> Self {
        LoadError { loc, message: message.into() }
    }
    /// An error at the position `loc`.
    pub fn at(loc: &FileLoc, message: impl Into<String>) -> Self {
        LoadError { loc: Some(loc.clone()), message: message.into() }
    }
    /// An error about a whole file (line unknown or irrelevant).
    pub fn in_file(file: &std::path::Path, message: impl Into<String>) -> Self {
        LoadError { loc: Some(FileLoc::new(Arc::new(file.to_path_buf()), 0, 0)), message: message.into() }
    }
}

impl fmt::Display for LoadError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match &self.loc {
            Some(l) if l.line > 0 || l.place.is_some() => write!(f, "{l}: {}", self.message),
            Some(l) => write!(f, "{}: {}", l.file.display(), self.message),
            None => write!(f, "{}", self.message),
        }
    }
}

/// Result of scene loading.
pub type Result<T> = std::result::Result<T, LoadError>;

/// `bytes` as UTF-8 text, or a message naming the first byte that is not:
/// "not valid UTF-8 text: line L, column C (byte B)", so a binary file or a
/// file in another encoding is located, not just refused.
pub fn utf8_text(bytes: Vec<u8>) -> std::result::Result<String, String> {
    String::from_utf8(bytes).map_err(|e| {
        let good = &e.as_bytes()[..e.utf8_error().valid_up_to()];
        let line = 1 + good.iter().filter(|&&b| b == b'\n').count();
        let col = 1 + good.iter().rev().take_while(|&&b| b != b'\n').count();
        format!("not valid UTF-8 text: line {line}, column {col} (byte {}); save the file as UTF-8", good.len())
    })
}
