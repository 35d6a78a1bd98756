//! Scale benchmark: a procedural mesh of many millions of triangles (the
//! ray benchmark's displaced sphere, seen from outside) written as a binary
//! PLY with a Mitsuba scene around it, then loaded and rendered by a child
//! `penumbra render` whose peak memory (VmHWM) and times are reported: the
//! whole user path (file reading, BVH build, render), nothing held back.

use super::rays::cave_mesh;
use anyhow::{anyhow, Context, Result};
use penumbra_render::geometry::TriangleMesh;
use std::io::Write;
use std::path::Path;
use std::process::Command;
use std::time::Instant;

/// Writes `m` as a binary little-endian PLY (float positions, int indices).
fn write_ply(path: &Path, m: &TriangleMesh) -> Result<()> {
    let f = std::fs::File::create(path).with_context(|| format!("cannot create {}", path.display()))?;
    let mut w = std::io::BufWriter::with_capacity(1 << 20, f);
    write!(
        w,
        "ply\nformat binary_little_endian 1.0\nelement vertex {}\nproperty float x\nproperty float y\nproperty float z\n\
         element face {}\nproperty list uchar int vertex_indices\nend_header\n",
        m.positions.len(),
        m.indices.len()
    )?;
    for p in &m.positions {
        for c in p.to_array() {
            w.write_all(&c.to_le_bytes())?;
        }
    }
    for t in &m.indices {
        w.write_all(&[3u8])?;
        for i in t {
            w.write_all(&(*i as i32).to_le_bytes())?;
        }
    }
    w.flush()?;
    Ok(())
}

const SCENE: &str = r#"<scene version="3.0.0">
    <integrator type="path"><integer name="max_depth" value="4"/></integrator>
    <sensor type="perspective">
        <float name="fov" value="35"/>
        <transform name="to_world"><lookat origin="0, 1.2, 4" target="0, 0, 0" up="0, 1, 0"/></transform>
        <sampler type="independent"><integer name="sample_count" value="16"/></sampler>
        <film type="hdrfilm"><integer name="width" value="256"/><integer name="height" value="256"/></film>
    </sensor>
    <emitter type="constant"><rgb name="radiance" value="0.8, 0.85, 1.0"/></emitter>
    <emitter type="directional">
        <vector name="direction" value="-1, -1, -0.5"/>
        <rgb name="irradiance" value="3, 2.8, 2.5"/>
    </emitter>
    <shape type="ply">
        <string name="filename" value="mesh.ply"/>
        <bsdf type="diffuse"><rgb name="reflectance" value="0.6, 0.5, 0.4"/></bsdf>
    </shape>
</scene>
"#;

/// Generates, writes and renders the mesh; prints one table row.
pub fn run(triangles: usize, threads: usize) -> Result<()> {
    let dir = std::env::temp_dir().join(format!("penumbra-scale-{}", std::process::id()));
    std::fs::create_dir_all(&dir)?;
    let result = (|| {
        let t = Instant::now();
        let mesh = cave_mesh(triangles);
        let n_tris = mesh.indices.len();
        write_ply(&dir.join("mesh.ply"), &mesh)?;
        drop(mesh);
        let gen_s = t.elapsed().as_secs_f64();
        let scene = dir.join("scene.xml");
        std::fs::write(&scene, SCENE)?;
        let exe = std::env::current_exe()?;
        let out = dir.join("scale.png");
        let t = Instant::now();
        let run = Command::new(exe)
            .args(["render", "--quiet", "--threads", &threads.to_string(), "-o"])
            .arg(&out)
            .arg(&scene)
            .output()?;
        let wall = t.elapsed().as_secs_f64();
        let err = String::from_utf8_lossy(&run.stderr);
        if !run.status.success() {
            return Err(anyhow!("the scale render failed: {err}"));
        }
        let field = |key: &str| -> Option<f64> {
            err.split([',', ':', '\n'])
                .find_map(|s| s.trim().strip_prefix(key))
                .and_then(|v| v.split_whitespace().next())
                .and_then(|v| v.parse().ok())
        };
        let peak_mb = field("peak memory").ok_or_else(|| anyhow!("no peak memory in: {err}"))?;
        let render_s = err
            .split_once(") in ")
            .and_then(|(_, v)| v.split_whitespace().next())
            .and_then(|v| v.parse().ok())
            .unwrap_or(f64::NAN);
        println!("\nscale: {n_tris} triangles (binary PLY written in {gen_s:.1} s), 256x256, 16 spp, max_depth 4");
        println!(
            "{:>12} {:>14} {:>10} {:>14} {:>16}",
            "triangles", "load+render s", "render s", "peak memory MB", "bytes/triangle"
        );
        println!(
            "{n_tris:>12} {wall:>14.2} {render_s:>10.2} {peak_mb:>14.0} {:>16.0}",
            peak_mb * 1024.0 * 1024.0 / n_tris as f64
        );
        println!(
            "(peak memory is the render process's VmHWM: mesh, file buffer, BVH and film; image: {})",
            out.display()
        );
        Ok(())
    })();
    if std::env::var_os("PENUMBRA_KEEP_SCALE").is_none() {
        let _ = std::fs::remove_file(dir.join("mesh.ply"));
    }
    result
}
