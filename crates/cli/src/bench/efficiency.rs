//! Equal-time error against Mitsuba 3: each renderer gets the same number
//! of render seconds on a scene (Penumbra through `--time`, Mitsuba with as
//! many spp as its warm time per spp says fit), and each image's relMSE is
//! measured against a converged reference rendered by Mitsuba (cached under
//! `target/bench-refs/`). Lower is better; the ratio is Mitsuba's relMSE
//! over Penumbra's, so above 1 means Penumbra is more efficient.
//!
//! A reference is itself noisy, and an error measured against it is the
//! image's own plus the reference's (independent renders: the expected
//! squared differences add). The reference is the mean of
//! [`REFERENCE_CHUNKS`] independent renders, whose spread gives its variance
//! per pixel; its relMSE (the `ref floor` column) is subtracted from every
//! error in the table. Left in, it would cap the ratios: at 2048 spp the
//! floor was a quarter to a half of a 4 s render's error.

use anyhow::{anyhow, Result};
use penumbra_scene::image_io::read_exr;
use std::path::{Path, PathBuf};
use std::process::Command;

/// (scene, -D parameters) at a size that keeps the reference affordable.
const SCENES: &[(&str, &[(&str, &str)])] = &[
    ("scenes/cornell-box.xml", &[("res", "128")]),
    ("tests/scenes/envmap_sun.xml", &[("res", "128")]),
    ("tests/scenes/many_lights.xml", &[("res", "128")]),
    ("scenes/material-showcase.xml", &[("width", "192"), ("height", "80")]),
    ("scenes/door-ajar.xml", &[]),
    ("scenes/glass-caustic.xml", &[]),
];
/// The reference: the mean of this many Mitsuba renders of [`CHUNK_SPP`]
/// each, with distinct seeds (32,768 spp; about 15 minutes for the six
/// scenes on 2 threads, once).
const REFERENCE_CHUNKS: u32 = 16;
const CHUNK_SPP: u32 = 2048;

fn mitsuba(python: &Path, variant: &str, scene: &str, defines: &[(&str, &str)], extra: &[String]) -> Result<String> {
    let mut cmd = Command::new(python);
    cmd.args(["tools/mitsuba_bench.py", "--variant", variant, "--threads", "2"]);
    for (k, v) in defines {
        cmd.arg("-D").arg(format!("{k}={v}"));
    }
    let out = cmd.args(extra).arg(scene).output().map_err(|e| anyhow!("cannot run {}: {e}", python.display()))?;
    if !out.status.success() {
        return Err(anyhow!("Mitsuba failed on {scene}: {}", String::from_utf8_lossy(&out.stderr)));
    }
    Ok(String::from_utf8_lossy(&out.stdout).into_owned())
}

fn field(text: &str, prefix: &str, key: &str) -> Option<f64> {
    text.lines()
        .rfind(|l| l.starts_with(prefix))?
        .split_whitespace()
        .find_map(|kv| kv.strip_prefix(key))
        .and_then(|v| v.parse().ok())
}

fn rel_mse(img: &Path, reference: &Path) -> Result<f64> {
    let a = read_exr(img).map_err(|e| anyhow!(e))?;
    let b = read_exr(reference).map_err(|e| anyhow!(e))?;
    Ok(crate::imgtool::diff(&a, &b)?.rel_mse)
}

/// The reference's own relMSE: E[(a - r)^2] = Var(a) + Var(r) + bias^2 for
/// an independent reference r, so this is what every measured relMSE
/// contains beyond the image's error. Each pixel's variance of the mean is
/// weighted as `diff` weights its squared difference.
fn reference_floor(reference: &Path, variance: &Path) -> Result<f64> {
    let r = read_exr(reference).map_err(|e| anyhow!(e))?;
    let v = read_exr(variance).map_err(|e| anyhow!(e))?;
    if (r.width, r.height) != (v.width, v.height) || r.pixels.is_empty() {
        return Err(anyhow!("{} does not match {}", variance.display(), reference.display()));
    }
    let sum: f64 = r
        .pixels
        .iter()
        .zip(&v.pixels)
        .flat_map(|(pr, pv)| (0..3).map(move |k| pv[k] as f64 / ((pr[k] as f64).powi(2) + crate::imgtool::REL_EPS)))
        .sum();
    Ok(sum / (3.0 * r.pixels.len() as f64))
}

/// Prints the equal-time table for `budget` render seconds per renderer.
pub fn table(python: Option<&Path>, variant: &str, budget: f64, threads: usize) -> Result<()> {
    let Some(py) = python else {
        println!("\nequal-time error: skipped (needs Mitsuba 3: pass --mitsuba PYTHON)");
        return Ok(());
    };
    let dir = PathBuf::from("target/bench-refs");
    std::fs::create_dir_all(&dir)?;
    let tmp = std::env::temp_dir().join(format!("penumbra-eff-{}", std::process::id()));
    std::fs::create_dir_all(&tmp)?;
    println!(
        "\nequal-time error: {budget} s of rendering each, relMSE against Mitsuba at {} spp ({variant}), \
         less the reference's own (ref floor)",
        REFERENCE_CHUNKS * CHUNK_SPP
    );
    println!(
        "(pen: the scene's sampler, as Mitsuba; sobol: Penumbra with --sampler sobol; guided: with path guiding)\n\
         {:<22} {:>9} {:>10} {:>9} {:>13} {:>9} {:>13} {:>10} {:>9} {:>13} {:>10} {:>10} {:>13} {:>11}",
        "scene",
        "size",
        "ref floor",
        "mi spp",
        "mi relMSE",
        "pen spp",
        "pen relMSE",
        "mi / pen",
        "sobol spp",
        "sobol relMSE",
        "mi / sobol",
        "guided spp",
        "guided relMSE",
        "mi / guided"
    );
    for (scene, defines) in SCENES {
        let stem = Path::new(scene).file_stem().unwrap().to_string_lossy().into_owned();
        let tag: String = defines.iter().map(|(k, v)| format!("-{k}{v}")).collect();
        let ref_spp = REFERENCE_CHUNKS * CHUNK_SPP;
        let reference = dir.join(format!("{stem}{tag}-{ref_spp}.exr"));
        let ref_var = dir.join(format!("{stem}{tag}-{ref_spp}-var.exr"));
        if !reference.exists() || !ref_var.exists() {
            eprintln!("rendering the reference {} with Mitsuba (once)", reference.display());
            let extra = [
                "--spp".into(),
                CHUNK_SPP.to_string(),
                "--reference".into(),
                REFERENCE_CHUNKS.to_string(),
                "--out".into(),
                reference.display().to_string(),
                "--out-var".into(),
                ref_var.display().to_string(),
            ];
            mitsuba(py, variant, scene, defines, &extra)?;
        }
        let floor = reference_floor(&reference, &ref_var)?;
        let mi_out = tmp.join(format!("{stem}-mitsuba.exr"));
        let extra = [
            "--spp".into(),
            "16".into(),
            "--runs".into(),
            "3".into(),
            "--budget".into(),
            budget.to_string(),
            "--out".into(),
            mi_out.display().to_string(),
        ];
        let text = mitsuba(py, variant, scene, defines, &extra)?;
        let mi_spp = field(&text, "mitsuba_budget", "spp=").unwrap_or(f64::NAN);
        let mi_secs = field(&text, "mitsuba_budget", "seconds=").unwrap_or(f64::NAN);

        // Penumbra with the scene's sampler, with `--sampler sobol`, and guided.
        let penumbra = |sampler: Option<&str>, guided: bool| -> Result<(f64, f64)> {
            let out = tmp.join(format!("{stem}-penumbra-{}-{guided}.exr", sampler.unwrap_or("scene")));
            let mut cmd = Command::new(std::env::current_exe()?);
            cmd.args(["render", "--quiet", "--spp", "1000000", "--seed", "1000", "--threads", &threads.to_string()])
                .args(["--time", &budget.to_string(), "-o"])
                .arg(&out)
                .arg(scene);
            if let Some(s) = sampler {
                cmd.args(["--sampler", s]);
            }
            if guided {
                cmd.args(["--integrator", "path:guiding=true"]);
            }
            for (k, v) in *defines {
                cmd.arg("-D").arg(format!("{k}={v}"));
            }
            let run = cmd.output()?;
            let err = String::from_utf8_lossy(&run.stderr);
            if !run.status.success() {
                return Err(anyhow!("penumbra failed on {scene}: {err}"));
            }
            // "... rendered N of 1000000 spp to ..."
            let spp: f64 = err
                .split_once("rendered ")
                .and_then(|(_, r)| r.split_whitespace().next())
                .and_then(|v| v.parse().ok())
                .unwrap_or(f64::NAN);
            Ok((spp, rel_mse(&out, &reference)? - floor))
        };
        let (pen_spp, pen_err) = penumbra(None, false)?;
        let (sobol_spp, sobol_err) = penumbra(Some("sobol"), false)?;
        let (guided_spp, guided_err) = penumbra(None, true)?;
        let mi_err = rel_mse(&mi_out, &reference)? - floor;
        let size = read_exr(&reference).map(|i| format!("{}x{}", i.width, i.height)).unwrap_or_default();
        println!(
            "{stem:<22} {size:>9} {floor:>10.2e} {mi_spp:>9.0} {mi_err:>13.4e} {pen_spp:>9.0} {pen_err:>13.4e} {:>9.2}x {sobol_spp:>9.0} \
             {sobol_err:>13.4e} {:>9.2}x {guided_spp:>10.0} {guided_err:>13.4e} {:>10.2}x",
            mi_err / pen_err,
            mi_err / sobol_err,
            mi_err / guided_err
        );
        if (mi_secs - budget).abs() > 0.25 * budget {
            println!("  (Mitsuba's budget render took {mi_secs:.2} s, not {budget} s: its time per spp varied)");
        }
    }
    let _ = std::fs::remove_dir_all(&tmp);
    Ok(())
}
