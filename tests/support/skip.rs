//! The one way a test gives up when something it needs outside the
//! repository (a tool, a Python module) is absent: `return skip(test, why)`.
//!
//! It prints `SKIPPED: <package>/<test binary>::<test>: <reason>` and appends
//! that line to the file named by `PENUMBRA_SKIP_LOG` when set (`.ci/run`
//! prints that file at the end and fails when it is not empty). When the
//! environment variable `CI` is set (to anything but "", "0" or "false") it
//! panics with the same line instead, so a test that cannot run fails CI
//! rather than passing silently.
//!
//! Included by each crate's `tests/common/mod.rs` (`#[path]`), so every test
//! binary reports skips the same way.
#![allow(dead_code)]

use std::io::Write;

/// Whether `CI` is set to a true value.
pub fn in_ci() -> bool {
    std::env::var("CI").is_ok_and(|v| !matches!(v.trim().to_ascii_lowercase().as_str(), "" | "0" | "false"))
}

/// Gives up on `test` (the test function's name) because of `reason`; the
/// caller returns right after (`return skip(..)`). Panics under CI.
pub fn skip(test: &str, reason: &str) {
    let line = format!("SKIPPED: {}/{}::{test}: {reason}", env!("CARGO_PKG_NAME"), env!("CARGO_CRATE_NAME"));
    if let Some(log) = std::env::var_os("PENUMBRA_SKIP_LOG").filter(|v| !v.is_empty()) {
        let appended = std::fs::OpenOptions::new()
            .create(true)
            .append(true)
            .open(&log)
            .and_then(|mut f| f.write_all(format!("{line}\n").as_bytes()));
        if let Err(e) = appended {
            panic!("{line}\n(cannot append to PENUMBRA_SKIP_LOG {}: {e})", log.to_string_lossy());
        }
    }
    if in_ci() {
        panic!("{line}\n(CI is set: a test that cannot run fails instead of being skipped; .ci/run installs what it needs)");
    }
    eprintln!("{line}");
}
