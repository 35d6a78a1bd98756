//! `--preview`: a window (minifb: X11 or Wayland, loaded at run time) that
//! shows the current image after every pass, tonemapped as the PNG writer
//! does (clamp to [0, 1], sRGB curve). The render never depends on it: with
//! no display, or when the window cannot be opened or is closed, the render
//! goes on without it (one line says so).
//!
//! `PENUMBRA_PREVIEW_HOLD=SECONDS` keeps the window open that long after the
//! last pass (until it is closed), e.g. to look at it or take a screenshot.

use minifb::{Scale, Window, WindowOptions};
use penumbra_scene::image_io::linear_to_srgb;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, Instant};

pub struct Preview {
    window: Option<Window>,
    width: usize,
    height: usize,
    buffer: Vec<u32>,
    name: String,
}

/// The window's scale: the largest of 1, 2, 4, 8 that keeps the window within
/// 768 pixels (small images are shown enlarged).
fn scale_for(width: u32, height: u32) -> Scale {
    let side = width.max(height).max(1);
    match 768 / side {
        0..=1 => Scale::X1,
        2..=3 => Scale::X2,
        4..=7 => Scale::X4,
        _ => Scale::X8,
    }
}

/// One pixel as minifb's 0RGB u32: clamp, sRGB, 8 bits (as the PNG writer rounds).
pub fn pack(p: [f32; 3]) -> u32 {
    let q = |c: f32| {
        let v = if c.is_finite() { linear_to_srgb(c.clamp(0.0, 1.0)) } else { 0.0 };
        (v * 255.0 + 0.5) as u32
    };
    (q(p[0]) << 16) | (q(p[1]) << 8) | q(p[2])
}

/// The window title after `spp` of `target` samples.
pub fn title(name: &str, spp: u32, target: u32) -> String {
    format!("penumbra: {name}, {spp}/{target} spp")
}

impl Preview {
    /// Opens the window, or prints one line saying why not and returns a
    /// preview that does nothing.
    pub fn open(name: &str, width: u32, height: u32) -> Preview {
        let mut p = Preview {
            window: None,
            width: width as usize,
            height: height as usize,
            buffer: vec![0; width as usize * height as usize],
            name: name.to_string(),
        };
        let has_display = |k: &str| std::env::var_os(k).is_some_and(|v| !v.is_empty());
        if !has_display("DISPLAY") && !has_display("WAYLAND_DISPLAY") {
            eprintln!("--preview: no display (DISPLAY and WAYLAND_DISPLAY are unset): rendering without a window");
            return p;
        }
        let opts = WindowOptions { scale: scale_for(width, height), ..WindowOptions::default() };
        // minifb panics on some X11 failures: never let that stop the render.
        let made = std::panic::catch_unwind(|| Window::new(&format!("penumbra: {name}"), p.width, p.height, opts));
        match made {
            Ok(Ok(w)) => p.window = Some(w),
            Ok(Err(e)) => eprintln!("--preview: cannot open a window ({e}): rendering without it"),
            Err(_) => eprintln!("--preview: opening a window failed: rendering without it"),
        }
        p
    }

    /// Shows `pixels` (linear RGB, row by row) after `spp` of `target` samples.
    pub fn show(&mut self, pixels: &[[f32; 3]], spp: u32, target: u32) {
        let Some(w) = &mut self.window else { return };
        if !w.is_open() {
            eprintln!("--preview: the window was closed: rendering goes on without it");
            self.window = None;
            return;
        }
        for (b, &p) in self.buffer.iter_mut().zip(pixels) {
            *b = pack(p);
        }
        // The image first, then the title: the X server handles a client's
        // requests in order, so a title that names this pass's spp means the
        // window already shows this pass (the --preview test relies on it).
        if let Err(e) = w.update_with_buffer(&self.buffer, self.width, self.height) {
            eprintln!("--preview: cannot update the window ({e}): rendering goes on without it");
            self.window = None;
            return;
        }
        w.set_title(&title(&self.name, spp, target));
    }

    /// Keeps the window open for PENUMBRA_PREVIEW_HOLD seconds (if set), or
    /// until it is closed or `cancel` is set (a signal).
    pub fn hold(&mut self, cancel: &AtomicBool) {
        let Some(secs) = std::env::var("PENUMBRA_PREVIEW_HOLD").ok().and_then(|v| v.trim().parse::<f64>().ok()) else {
            return;
        };
        let Some(w) = &mut self.window else { return };
        let end = Instant::now() + Duration::from_secs_f64(secs.clamp(0.0, 86400.0));
        while w.is_open() && Instant::now() < end && !cancel.load(Ordering::Relaxed) {
            // Redraw (cheap): an uncovered window has no backing store.
            if w.update_with_buffer(&self.buffer, self.width, self.height).is_err() {
                break;
            }
            std::thread::sleep(Duration::from_millis(50));
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn pixels_are_clamped_srgb_as_the_png_writer_writes_them() {
        assert_eq!(pack([0.0, 1.0, 7.0]), 0x0000_ffff);
        assert_eq!(pack([f32::NAN, -1.0, 0.18]), 118); // sRGB(0.18) = 0.4613
        assert_eq!(pack([1.0, 0.0, 0.0]), 0xff_0000);
    }

    #[test]
    fn small_images_get_a_larger_window() {
        assert!(matches!(scale_for(64, 64), Scale::X8));
        assert!(matches!(scale_for(256, 256), Scale::X2));
        assert!(matches!(scale_for(683, 512), Scale::X1));
        assert!(matches!(scale_for(4000, 10), Scale::X1));
    }
}
