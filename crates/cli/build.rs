//! With feature `denoise` and `OIDN_DIR` set (Open Image Denoise from the
//! `pyoidn` wheel, say), records `$OIDN_DIR/lib` as the binaries' rpath, so
//! they run without LD_LIBRARY_PATH.

fn main() {
    println!("cargo:rerun-if-env-changed=OIDN_DIR");
    if std::env::var_os("CARGO_FEATURE_DENOISE").is_none() {
        return;
    }
    if let Some(dir) = std::env::var_os("OIDN_DIR") {
        let lib = std::path::Path::new(&dir).join("lib");
        println!("cargo:rustc-link-arg=-Wl,-rpath,{}", lib.display());
    }
}
