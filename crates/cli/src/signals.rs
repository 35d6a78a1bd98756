//! SIGINT and SIGTERM stop a render cleanly: the first sets a flag that the
//! render checks before each tile (the caller then writes its checkpoint and
//! partial image and exits 130 or 143); a second one exits at once.
//!
//! SIGXFSZ, which a write past the file-size limit (`ulimit -f`, `prlimit
//! --fsize`) raises, is ignored ([`ignore_file_size_limit_signal`]), so that
//! the write fails with "File too large" and is reported like a full disk
//! (the temporary file removed, the previous file kept) instead of killing
//! the process mid-write.

use anyhow::{Context, Result};
use signal_hook::consts::{SIGINT, SIGTERM};
use signal_hook::flag;
use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};
use std::sync::Arc;

pub struct Signals {
    pub cancel: Arc<AtomicBool>,
    which: Arc<AtomicUsize>,
}

impl Signals {
    pub fn install() -> Result<Signals> {
        let cancel = Arc::new(AtomicBool::new(false));
        let which = Arc::new(AtomicUsize::new(0));
        for sig in [SIGINT, SIGTERM] {
            // Registered first, so it sees the flag as the previous signal left it.
            flag::register_conditional_shutdown(sig, 128 + sig, cancel.clone())
                .and_then(|_| flag::register(sig, cancel.clone()))
                .and_then(|_| flag::register_usize(sig, which.clone(), sig as usize))
                .context("cannot install the signal handlers")?;
        }
        Ok(Signals { cancel, which })
    }

    /// The signal received, if any.
    pub fn received(&self) -> Option<i32> {
        match self.which.load(Ordering::SeqCst) {
            0 => None,
            s => Some(s as i32),
        }
    }
}

/// Ignores SIGXFSZ for the whole process: a write past the file-size limit
/// then returns an error (EFBIG) that the atomic writer handles, instead of
/// the signal's default action, which kills the process and leaves a
/// half-written temporary file.
pub fn ignore_file_size_limit_signal() {
    // SAFETY: setting a signal's disposition to SIG_IGN has no handler to run
    // and is async-signal-safe; nothing else in the process handles SIGXFSZ.
    unsafe {
        libc::signal(libc::SIGXFSZ, libc::SIG_IGN);
    }
}
