//! The render's memory, predicted before the film is allocated: the scene
//! as loaded (meshes, textures, acceleration structures: the process's
//! resident memory once loading is done), and the film's f64 sums (and
//! layers and moments), the image developed from it, and a checkpoint's
//! encoding when checkpoints are written. A render whose whole would
//! exceed `--max-memory`, or whose film would exceed the memory the system
//! says is available, is refused with the sizes asked for; a large one is
//! announced.

use anyhow::{bail, Result};
use penumbra_render::film::{channel_count, FilmLayers, MOMENTS};

/// Parses a size: bytes, or a number with K, M, G or T (powers of 1024,
/// an optional trailing `B` or `iB`): `512M`, `8G`, `1.5GiB`.
pub fn parse_size(text: &str) -> Result<u64, String> {
    let t = text.trim();
    let t = t.strip_suffix("iB").or_else(|| t.strip_suffix('B')).unwrap_or(t);
    let (num, unit) = match t.char_indices().last() {
        Some((i, c)) if c.is_ascii_alphabetic() => (&t[..i], c.to_ascii_uppercase()),
        _ => (t, ' '),
    };
    let scale = match unit {
        ' ' => 1u64,
        'K' => 1 << 10,
        'M' => 1 << 20,
        'G' => 1 << 30,
        'T' => 1 << 40,
        _ => return Err(format!("'{text}': unknown unit (use K, M, G or T)")),
    };
    match num.trim().parse::<f64>() {
        Ok(v) if v.is_finite() && v > 0.0 && v * (scale as f64) < u64::MAX as f64 => Ok((v * scale as f64) as u64),
        _ => Err(format!("'{text}' is not a positive size such as 512M or 8G")),
    }
}

/// The memory the system reports as available (Linux `MemAvailable`).
pub fn available() -> Option<u64> {
    let text = std::fs::read_to_string("/proc/meminfo").ok()?;
    let line = text.lines().find(|l| l.starts_with("MemAvailable:"))?;
    let kb: u64 = line.split_whitespace().nth(1)?.parse().ok()?;
    Some(kb * 1024)
}

/// The resident memory of this process (Linux `VmRSS`): once the scene is
/// loaded, what its meshes, textures and acceleration structures take.
pub fn resident() -> Option<u64> {
    let text = std::fs::read_to_string("/proc/self/status").ok()?;
    let line = text.lines().find(|l| l.starts_with("VmRSS:"))?;
    let kb: u64 = line.split_whitespace().nth(1)?.parse().ok()?;
    Some(kb * 1024)
}

/// Bytes the film and what is made from it take for a `width` x `height`
/// render with `layers`: the f64 sums, the developed f32 image with its
/// layers, and (with `checkpoint`) the checkpoint's encoding.
pub fn predict(width: u32, height: u32, layers: &FilmLayers, checkpoint: bool) -> u128 {
    let pixels = width as u128 * height as u128;
    let aov = (channel_count(&layers.aovs) + layers.channels.len()) as u128;
    let moments = if layers.variance { MOMENTS as u128 } else { 0 };
    let film = pixels * (4 + aov + moments) * 8;
    let image = pixels * (3 + aov + if layers.variance { 3 } else { 0 }) * 4;
    film + image + if checkpoint { film } else { 0 }
}

/// Formats bytes for messages: `1.50 GiB`.
pub fn human(bytes: u128) -> String {
    let units = ["bytes", "KiB", "MiB", "GiB", "TiB", "PiB", "EiB"];
    let mut v = bytes as f64;
    let mut u = 0;
    while v >= 1024.0 && u + 1 < units.len() {
        v /= 1024.0;
        u += 1;
    }
    if u == 0 {
        format!("{bytes} bytes")
    } else {
        format!("{v:.2} {}", units[u])
    }
}

/// Refuses a render whose film and `scene` (bytes already taken by the
/// loaded scene) exceed `limit` (`--max-memory`) or, without one, whose
/// film exceeds the memory available (which the scene has already
/// lowered); announces one above 1 GiB in all.
pub fn check(
    width: u32,
    height: u32,
    layers: &FilmLayers,
    checkpoint: bool,
    limit: Option<u64>,
    scene: u64,
) -> Result<()> {
    let film = predict(width, height, layers, checkpoint);
    let parts = format!(
        "the {width} x {height} film needs about {} (its sums, the image{})",
        human(film),
        if checkpoint { " and the checkpoint" } else { "" }
    );
    let fix = "render a smaller film, fewer layers, or parts of it (--crop, --part)";
    match limit {
        Some(limit) if film + scene as u128 > limit as u128 => bail!(
            "{parts} and the scene as loaded {} (meshes, textures, acceleration structures), {} in all, more than \
             the limit set by --max-memory, {}; {fix}, or raise --max-memory",
            human(scene as u128),
            human(film + scene as u128),
            human(limit as u128)
        ),
        None => {
            if let Some(available) = available().filter(|&a| film > a as u128) {
                bail!(
                    "{parts}, more than the memory available (MemAvailable in /proc/meminfo), {}; {fix}, or set \
                     a larger --max-memory",
                    human(available as u128)
                );
            }
        }
        Some(_) => {}
    }
    if film + scene as u128 > 1 << 30 {
        eprintln!(
            "note: the render will take about {} of memory: the scene {}, the {width} x {height} film {}",
            human(film + scene as u128),
            human(scene as u128),
            human(film)
        );
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sizes_parse_with_units() {
        assert_eq!(parse_size("4096").unwrap(), 4096);
        assert_eq!(parse_size("512M").unwrap(), 512 << 20);
        assert_eq!(parse_size("8g").unwrap(), 8 << 30);
        assert_eq!(parse_size("1.5GiB").unwrap(), 3 << 29);
        assert_eq!(parse_size("2KB").unwrap(), 2048);
        for bad in ["", "0", "-1G", "x", "5Q", "nanG", "1e30T"] {
            assert!(parse_size(bad).is_err(), "{bad}");
        }
    }

    #[test]
    fn a_film_past_the_limit_is_refused_with_the_size_asked_for() {
        let layers = FilmLayers::default();
        // 32 bytes of sums and 12 of image per pixel.
        assert_eq!(predict(10, 10, &layers, false), 4400);
        assert_eq!(predict(10, 10, &layers, true), 7600);
        assert_eq!(predict(65536, 65536, &layers, false), 44 << 32);
        check(10, 10, &layers, false, Some(4400), 0).unwrap();
        let e = check(10, 10, &layers, false, Some(4399), 0).unwrap_err().to_string();
        assert!(e.contains("10 x 10 film needs about 4.30 KiB") && e.contains("--max-memory, 4.30 KiB"), "{e}");
        let e = check(65536, 65536, &layers, true, Some(8 << 30), 0).unwrap_err().to_string();
        assert!(e.contains("needs about 304.00 GiB") && e.contains("8.00 GiB"), "{e}");
        // The scene counts against --max-memory: 4400 + 1 bytes is one too many.
        check(10, 10, &layers, false, Some(4400 + 2048), 2048).unwrap();
        let e = check(10, 10, &layers, false, Some(4400 + 2047), 2048).unwrap_err().to_string();
        assert!(e.contains("the scene as loaded 2.00 KiB") && e.contains("6.30 KiB in all"), "{e}");
        // Without a limit, only the film is compared with what is available
        // (the scene's memory is already taken from it).
        check(10, 10, &layers, false, None, u64::MAX / 2).unwrap();
    }
}
