//! Load errors: every one names the file and, where known, the line.

use std::fmt;
use std::path::PathBuf;
use std::sync::Arc;

/// A position in a scene file.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct FileLoc {
    pub file: Arc<PathBuf>,
    pub line: u32,
    pub col: u32,
}

impl fmt::Display for FileLoc {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}:{}:{}", self.file.display(), self.line, self.col)
    }
}

/// An error while reading a scene or one of the files it refers to.
#[derive(Debug, Clone, thiserror::Error)]
pub struct LoadError {
    /// Where the problem is; `None` for errors about the command line.
    pub loc: Option<FileLoc>,
    pub message: String,
}

impl LoadError {
    pub fn new(loc: Option<FileLoc>, message: impl Into<String>) -> Self {
        LoadError { loc, message: message.into() }
    }
    pub fn at(loc: &FileLoc, message: impl Into<String>) -> Self {
        LoadError { loc: Some(loc.clone()), message: message.into() }
    }
    /// An error about a whole file (line unknown or irrelevant).
    pub fn in_file(file: &std::path::Path, message: impl Into<String>) -> Self {
        LoadError {
            loc: Some(FileLoc { file: Arc::new(file.to_path_buf()), line: 0, col: 0 }),
            message: message.into(),
        }
    }
}

impl fmt::Display for LoadError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match &self.loc {
            Some(l) if l.line > 0 => write!(f, "{l}: {}", self.message),
            Some(l) => write!(f, "{}: {}", l.file.display(), self.message),
            None => write!(f, "{}", self.message),
        }
    }
}

pub type Result<T> = std::result::Result<T, LoadError>;
