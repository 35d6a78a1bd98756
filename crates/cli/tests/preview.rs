//! `--preview` for real: an X server (Xvfb), a render with the window, a
//! screenshot of the window (xwd) taken while it is open, compared with the
//! PNG the render writes (the preview tonemaps as the PNG writer does).
//! Skipped where Xvfb or xwd is missing (apt-get install xvfb x11-apps), and
//! then fails under CI (`common::skip`); .ci/run installs them.
//! PENUMBRA_PREVIEW_SCREENSHOT=FILE.png keeps the screenshot.

use penumbra_scene::image_io::{self, linear_to_srgb, RgbImage};
use std::fs;
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

use crate::common;

fn root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../..")
}

fn have(tool: &str) -> bool {
    std::env::var_os("PATH").is_some_and(|p| std::env::split_paths(&p).any(|d| d.join(tool).is_file()))
}

/// Kills the child on drop (by its PID: this test's own processes only).
struct Guard(Child);
impl Drop for Guard {
    fn drop(&mut self) {
        let _ = self.0.kill();
        let _ = self.0.wait();
    }
}

/// Starts Xvfb on a free display number; returns it and the server.
fn start_xvfb() -> (u32, Guard) {
    for n in (90 + std::process::id() % 50)..400 {
        if Path::new(&format!("/tmp/.X{n}-lock")).exists() || Path::new(&format!("/tmp/.X11-unix/X{n}")).exists() {
            continue;
        }
        let child = Command::new("Xvfb")
            .arg(format!(":{n}"))
            .args(["-screen", "0", "800x600x24", "-nolisten", "tcp", "-noreset"])
            .stdout(Stdio::null())
            .stderr(Stdio::null())
            .spawn()
            .expect("Xvfb starts");
        let mut g = Guard(child);
        let t = Instant::now();
        while t.elapsed() < Duration::from_secs(10) {
            // Ready once it answers (its socket appears before it accepts clients).
            if Path::new(&format!("/tmp/.X11-unix/X{n}")).exists()
                && Command::new("xwd")
                    .args(["-display", &format!(":{n}"), "-root", "-silent", "-out", "/dev/null"])
                    .stderr(Stdio::null())
                    .status()
                    .is_ok_and(|s| s.success())
            {
                return (n, g);
            }
            if g.0.try_wait().unwrap().is_some() {
                break; // lost a race for this display: try the next
            }
            std::thread::sleep(Duration::from_millis(50));
        }
    }
    panic!("no display for Xvfb");
}

/// An XWD (X Window Dump, version 7) of a TrueColor visual as 8-bit RGB.
fn read_xwd(b: &[u8]) -> (usize, usize, Vec<[u8; 3]>) {
    let be = |i: usize| u32::from_be_bytes(b[i * 4..i * 4 + 4].try_into().unwrap());
    let (header_size, version) = (be(0) as usize, be(1));
    assert_eq!(version, 7, "XWD version");
    let (width, height) = (be(4) as usize, be(5) as usize);
    let (byte_order, bits_per_pixel, bytes_per_line) = (be(7), be(11) as usize, be(12) as usize);
    let masks = [be(14), be(15), be(16)];
    let ncolors = be(19) as usize;
    assert_eq!(bits_per_pixel, 32, "expected a 24-bit TrueColor visual with 32-bit pixels");
    let data = &b[header_size + 12 * ncolors..];
    let mut px = Vec::with_capacity(width * height);
    for y in 0..height {
        for x in 0..width {
            let q: [u8; 4] = data[y * bytes_per_line + 4 * x..][..4].try_into().unwrap();
            let v = if byte_order == 0 { u32::from_le_bytes(q) } else { u32::from_be_bytes(q) };
            px.push(masks.map(|m| ((v & m) >> m.trailing_zeros()) as u8));
        }
    }
    (width, height, px)
}

#[test]
fn preview_window_shows_the_image_under_xvfb() {
    if !have("Xvfb") || !have("xwd") {
        return common::skip(
            "preview_window_shows_the_image_under_xvfb",
            "needs Xvfb and xwd on PATH (apt-get install xvfb x11-apps)",
        );
    }
    let (display, _xvfb) = start_xvfb();
    let d = std::env::temp_dir().join(format!("penumbra-preview-{}", std::process::id()));
    let _ = fs::remove_dir_all(&d);
    fs::create_dir_all(&d).unwrap();
    let png = d.join("box.png");
    let render = Command::new(env!("CARGO_BIN_EXE_penumbra"))
        .arg("render")
        .arg(root().join("scenes/cornell-box.xml"))
        .arg("-o")
        .arg(&png)
        .args(["-D", "res=64", "--spp", "16", "--seed", "3", "--quiet", "--preview"])
        .env("DISPLAY", format!(":{display}"))
        .env_remove("WAYLAND_DISPLAY")
        .env("PENUMBRA_PREVIEW_HOLD", "30")
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let mut render = Guard(render);

    // The window's final title (16 of 16 spp): screenshot it while it is held open.
    let xwd = d.join("shot.xwd");
    let t = Instant::now();
    let shot = loop {
        let o = Command::new("xwd")
            .args([
                "-display",
                &format!(":{display}"),
                "-silent",
                "-name",
                "penumbra: cornell-box.xml, 16/16 spp",
                "-out",
            ])
            .arg(&xwd)
            .output()
            .unwrap();
        if o.status.success() {
            break fs::read(&xwd).unwrap();
        }
        if let Some(st) = render.0.try_wait().unwrap() {
            let mut err = String::new();
            std::io::Read::read_to_string(render.0.stderr.as_mut().unwrap(), &mut err).unwrap();
            panic!("the render ended ({st}) before a screenshot was taken: {err}");
        }
        assert!(t.elapsed() < Duration::from_secs(60), "no preview window after 60 s");
        std::thread::sleep(Duration::from_millis(100));
    };
    // Ends the hold: SIGTERM is handled (the image is already written).
    let _ = Command::new("kill").arg("-TERM").arg(render.0.id().to_string()).status();
    let st = render.0.wait().unwrap();
    let mut err = String::new();
    std::io::Read::read_to_string(render.0.stderr.as_mut().unwrap(), &mut err).unwrap();
    assert!(st.success(), "{st}: {err}");
    assert!(!err.contains("--preview:"), "the window should have opened: {err}");

    let (w, h, px) = read_xwd(&shot);
    assert_eq!((w, h), (512, 512), "64x64 shown at 8x");
    if let Some(out) = std::env::var_os("PENUMBRA_PREVIEW_SCREENSHOT") {
        let pixels = px.iter().map(|p| p.map(|c| image_io::srgb_to_linear(c as f32 / 255.0))).collect();
        image_io::write_image(Path::new(&out), &RgbImage { width: w as u32, height: h as u32, pixels }).unwrap();
    }
    // Not blank: the red wall on the left, the green wall on the right.
    let mean = |x0: usize, x1: usize| {
        let mut m = [0f64; 3];
        for y in 128..384 {
            for x in x0..x1 {
                for k in 0..3 {
                    m[k] += px[y * w + x][k] as f64 / ((x1 - x0) * 256) as f64;
                }
            }
        }
        m
    };
    let (left, right) = (mean(8, 88), mean(424, 504));
    assert!(left[0] > 60.0 && left[0] > 1.3 * left[1] && left[0] > 2.0 * left[2], "left wall {left:?}");
    assert!(right[1] > 60.0 && right[1] > 1.3 * right[0] && right[1] > 2.0 * right[2], "right wall {right:?}");
    // And it is the rendered image: every 8x8 block is the PNG's pixel.
    let img = image_io::read_image(&png).unwrap();
    let mut worst = 0;
    for y in 0..64 {
        for x in 0..64 {
            let want = img.pixels[y * 64 + x].map(|c| (linear_to_srgb(c) * 255.0 + 0.5) as i32);
            for (dy, dx) in [(0, 0), (7, 7), (3, 4)] {
                let got = px[(y * 8 + dy) * w + x * 8 + dx];
                for k in 0..3 {
                    worst = worst.max((got[k] as i32 - want[k]).abs());
                }
            }
        }
    }
    eprintln!(
        "preview screenshot: {w}x{h}, left wall mean sRGB {left:.0?}, right wall {right:.0?}, \
         largest 8-bit difference from the PNG {worst}"
    );
    assert!(worst <= 1, "the window shows another image: difference {worst}");
    fs::remove_dir_all(&d).ok();
}

#[test]
fn preview_without_a_display_says_so_once_and_renders() {
    let d = std::env::temp_dir().join(format!("penumbra-nopreview-{}", std::process::id()));
    fs::create_dir_all(&d).unwrap();
    for (display, want) in [(None, "no display"), (Some(":4077"), "cannot open a window")] {
        let mut c = Command::new(env!("CARGO_BIN_EXE_penumbra"));
        c.arg("render").arg(root().join("scenes/cornell-box.xml")).arg("-o").arg(d.join("a.png"));
        c.args(["-D", "res=16", "--spp", "4", "--quiet", "--preview"]).env_remove("WAYLAND_DISPLAY");
        match display {
            Some(v) => c.env("DISPLAY", v),
            None => c.env_remove("DISPLAY"),
        };
        let o = c.output().unwrap();
        let err = String::from_utf8_lossy(&o.stderr);
        assert!(o.status.success(), "{err}");
        assert_eq!(err.matches("--preview:").count(), 1, "{err}");
        assert!(err.contains(want) && err.contains("rendering without"), "{err}");
        assert!(d.join("a.png").exists());
        fs::remove_file(d.join("a.png")).unwrap();
    }
    fs::remove_dir_all(&d).ok();
}
