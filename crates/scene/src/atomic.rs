//! Atomic file writes, for every output file: images, partial images and
//! checkpoints. The content goes to a temporary file in the same directory
//! (`FILE.tmp`), which is flushed, fsynced and renamed over `FILE`; then
//! the directory is fsynced so that the rename itself is on disk. A reader
//! sees the old file or the new one, never part of one, and a kill at any
//! moment (SIGKILL and power loss included) leaves one of the two.

use std::fs::{self, File};
use std::io::{self, BufWriter};
use std::path::{Path, PathBuf};

/// The temporary file [`write_file`] fills before renaming it to `path`:
/// `path` with `.tmp` appended. A run killed mid-write leaves it behind;
/// the next write to `path` replaces it.
pub fn temp_path(path: &Path) -> PathBuf {
    let mut name = path.file_name().map(|n| n.to_os_string()).unwrap_or_default();
    name.push(".tmp");
    path.with_file_name(name)
}

/// Writes `path` atomically: `write` fills a buffered temporary file beside
/// it ([`temp_path`]), which is flushed, fsynced and renamed to `path`, and
/// the directory is fsynced. On an error the temporary file is removed and
/// `path` is left as it was. The error is the cause alone: callers say
/// which file could not be written.
pub fn write_file(path: &Path, write: impl FnOnce(&mut BufWriter<File>) -> io::Result<()>) -> io::Result<()> {
    let tmp = temp_path(path);
    let result = fill(&tmp, write).and_then(|()| fs::rename(&tmp, path));
    if result.is_err() {
        let _ = fs::remove_file(&tmp);
        return result;
    }
    // Best effort: some file systems cannot open or fsync a directory, and
    // the rename has happened by now.
    let dir = path.parent().filter(|p| !p.as_os_str().is_empty()).unwrap_or(Path::new("."));
    if let Ok(d) = File::open(dir) {
        let _ = d.sync_all();
    }
    Ok(())
}

fn fill(tmp: &Path, write: impl FnOnce(&mut BufWriter<File>) -> io::Result<()>) -> io::Result<()> {
    let mut w = BufWriter::new(File::create(tmp)?);
    write(&mut w)?;
    let file = w.into_inner().map_err(io::IntoInnerError::into_error)?;
    file.sync_all()
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::io::Write;

    #[test]
    fn replaces_the_file_or_leaves_it_as_it_was() {
        let dir = std::env::temp_dir().join(format!("penumbra-atomic-{}", std::process::id()));
        fs::create_dir_all(&dir).unwrap();
        let path = dir.join("out.bin");
        write_file(&path, |w| w.write_all(b"first")).unwrap();
        write_file(&path, |w| w.write_all(b"second")).unwrap();
        assert_eq!(fs::read(&path).unwrap(), b"second");
        // A failing writer: the old content stays, the temporary file goes.
        let err = write_file(&path, |w| {
            w.write_all(b"half")?;
            Err(io::Error::other("encoder failed"))
        })
        .unwrap_err();
        assert_eq!(err.to_string(), "encoder failed");
        assert_eq!(fs::read(&path).unwrap(), b"second");
        assert!(!temp_path(&path).exists());
        // A leftover temporary file (a killed run) is replaced.
        fs::write(temp_path(&path), b"stale stale stale").unwrap();
        write_file(&path, |w| w.write_all(b"third")).unwrap();
        assert_eq!(fs::read(&path).unwrap(), b"third");
        assert!(!temp_path(&path).exists());
        // No directory: nothing is created.
        let missing = dir.join("no-such-dir").join("out.bin");
        assert!(write_file(&missing, |w| w.write_all(b"x")).is_err());
        assert!(!missing.exists());
        fs::remove_dir_all(&dir).ok();
    }

    #[test]
    fn the_temporary_file_sits_beside_the_target() {
        assert_eq!(temp_path(Path::new("a.exr")), Path::new("a.exr.tmp"));
        assert_eq!(temp_path(Path::new("d/a.ck")), Path::new("d/a.ck.tmp"));
    }
}
