//! Checkpoint files: the film's f64 sums and weights after a whole number of
//! passes, with what is needed to check that a resumed render is the same
//! render. Written atomically ([`penumbra_scene::atomic`]: `FILE.tmp`, fsync,
//! rename, fsync of the directory), so a kill at any moment leaves the
//! previous checkpoint or the new one, never a mix.
//!
//! Layout (little-endian): magic `PNMBRCKP`, format version u32, then
//! length-prefixed (u32) UTF-8 strings penumbra version and settings, seed
//! u64, passes u32, spp reached u32, render seconds f64, width u32, height
//! u32, the film's layers (string: AOV names, comma-separated; u8: 1 when
//! variance moments follow; string: the integrator's output channels,
//! newline-separated), per pixel R, G, B sums and the weight sum as
//! f64, then the AOV sums (f64, the AOVs' channels per pixel), then the
//! moments (`film::MOMENTS` = 14 f64 per pixel), a u8 that is 1 when the path
//! guide follows and the guide ([`Guide::encode`]), and a CRC-32 of
//! everything before it. Formats 1 (no layers), 2 (7 moments, no Σ w³), 3
//! (no integrator channels), 4 (no guide), 5 (a guide without its
//! pixel estimate and mean records) and 6 (8 moments, none of light paths'
//! splats) are refused with a message.

use crate::settings::{Settings, VERSION};
use anyhow::{bail, Context, Result};
use penumbra_render::film::{channel_count, AovKind};
use penumbra_render::film::{Film, FilmLayers, MOMENTS};
use penumbra_render::guiding::Guide;
use penumbra_scene::atomic;
use std::fs;
use std::io::Write;
use std::path::Path;

const MAGIC: &[u8; 8] = b"PNMBRCKP";
const FORMAT: u32 = 7;

/// A render's state after `passes` whole passes.
#[derive(Debug, Clone)]
pub struct Checkpoint {
    pub version: String,
    pub settings: Settings,
    pub seed: u64,
    pub passes: u32,
    pub spp: u32,
    pub seconds: f64,
    pub film: Film,
    /// The path guide as it was after `passes` (guided renders only).
    pub guide: Option<Guide>,
}

fn put_str(out: &mut Vec<u8>, s: &str) {
    out.extend_from_slice(&(s.len() as u32).to_le_bytes());
    out.extend_from_slice(s.as_bytes());
}

impl Checkpoint {
    pub fn encode(&self) -> Vec<u8> {
        let n = self.film.acc.len();
        let mut out = Vec::with_capacity(128 + n * 32);
        out.extend_from_slice(MAGIC);
        out.extend_from_slice(&FORMAT.to_le_bytes());
        put_str(&mut out, &self.version);
        put_str(&mut out, &self.settings.to_text());
        out.extend_from_slice(&self.seed.to_le_bytes());
        out.extend_from_slice(&self.passes.to_le_bytes());
        out.extend_from_slice(&self.spp.to_le_bytes());
        out.extend_from_slice(&self.seconds.to_le_bytes());
        out.extend_from_slice(&self.film.width.to_le_bytes());
        out.extend_from_slice(&self.film.height.to_le_bytes());
        let names: Vec<&str> = self.film.aov_kinds.iter().map(|k| k.name()).collect();
        put_str(&mut out, &names.join(","));
        out.push(self.film.has_variance() as u8);
        put_str(&mut out, &self.film.channels.join("\n"));
        for a in &self.film.acc {
            for v in a {
                out.extend_from_slice(&v.to_le_bytes());
            }
        }
        for v in self.film.aov.iter().chain(self.film.moments.iter().flatten()) {
            out.extend_from_slice(&v.to_le_bytes());
        }
        out.push(self.guide.is_some() as u8);
        if let Some(g) = &self.guide {
            g.encode(&mut out);
        }
        let crc = crc32fast::hash(&out);
        out.extend_from_slice(&crc.to_le_bytes());
        out
    }

    /// Decodes a checkpoint; `what` names the file in errors.
    pub fn decode(bytes: &[u8], what: &str) -> Result<Checkpoint> {
        let corrupt =
            |why: &str| anyhow::anyhow!("checkpoint '{what}' is not usable: {why}; use --fresh to start over");
        if bytes.len() < 12 || &bytes[..8] != MAGIC {
            return Err(corrupt("it is not a penumbra checkpoint"));
        }
        let (body, crc) = bytes.split_at(bytes.len() - 4);
        if crc32fast::hash(body) != u32::from_le_bytes(crc.try_into().unwrap()) {
            return Err(corrupt("its checksum is wrong (truncated or damaged)"));
        }
        let mut r = Reader { b: body, at: 8 };
        let format = r.u32()?;
        if format != FORMAT {
            return Err(corrupt(&format!("it has format version {format}, this penumbra reads {FORMAT}")));
        }
        let version = r.string()?;
        let settings = Settings::parse(&r.string()?);
        let seed = r.u64()?;
        let passes = r.u32()?;
        let spp = r.u32()?;
        let seconds = f64::from_bits(r.u64()?);
        let (width, height) = (r.u32()?, r.u32()?);
        let n = width as usize * height as usize;
        let names = r.string()?;
        let variance = r.u8()? != 0;
        let channels = r.string()?.split('\n').filter(|s| !s.is_empty()).map(str::to_string).collect();
        let mut layers = FilmLayers { aovs: Vec::new(), variance, channels };
        for name in names.split(',').filter(|s| !s.is_empty()) {
            layers.aovs.push(AovKind::from_name(name).ok_or_else(|| corrupt(&format!("unknown AOV '{name}'")))?);
        }
        // The size is checked before the film is allocated: a damaged (or
        // hostile) header must not ask for memory its data does not hold.
        let per_pixel = 4 + channel_count(&layers.aovs) + layers.channels.len() + if variance { MOMENTS } else { 0 };
        let values = n as u128 * per_pixel as u128;
        // The film's data, then the guide's flag (and the guide).
        let have = (r.b.len() - r.at) as u128;
        if have < values * 8 + 1 || (have > values * 8 + 1 && r.b[r.at + values as usize * 8] != 1) {
            return Err(corrupt(&format!(
                "its size does not match its resolution ({width} x {height} pixels of {per_pixel} values need \
                 {} bytes of data, it has {have})",
                values * 8
            )));
        }
        let mut film = Film::with_layers(width, height, &layers);
        for i in 0..n {
            for c in 0..3 {
                film.acc[i][c] = f64::from_bits(r.u64()?);
            }
            film.acc[i][3] = f64::from_bits(r.u64()?);
        }
        for v in film.aov.iter_mut().chain(film.moments.iter_mut().flatten()) {
            *v = f64::from_bits(r.u64()?);
        }
        let guide = match r.u8()? {
            0 => None,
            _ => Some(Guide::decode(r.b, &mut r.at).map_err(|e| corrupt(&format!("its path guide is damaged: {e}")))?),
        };
        if r.at != r.b.len() {
            return Err(corrupt("it has bytes after its data"));
        }
        Ok(Checkpoint { version, settings, seed, passes, spp, seconds, film, guide })
    }

    /// The path guide a render resumed from this checkpoint goes on with,
    /// given `fresh`, the render's new guide (`None` without guiding): the
    /// one saved, or `fresh` if no pass was rendered.
    pub fn resume_guide(&mut self, fresh: Option<Guide>) -> std::result::Result<Option<Guide>, String> {
        match (fresh, self.guide.take()) {
            (None, _) => Ok(None),
            (Some(_), Some(g)) => Ok(Some(g)),
            (Some(fresh), None) if self.spp == 0 => Ok(Some(fresh)),
            (Some(_), None) => Err("it has no path guide, which this render needs".into()),
        }
    }

    /// Writes atomically: temporary file, fsync, rename, fsync directory.
    pub fn save(&self, path: &Path) -> Result<()> {
        let bytes = self.encode();
        atomic::write_file(path, |w| w.write_all(&bytes))
            .with_context(|| format!("cannot write checkpoint '{}'", path.display()))
    }

    /// Loads `path` if it exists and checks that it belongs to this render:
    /// same penumbra version and settings, else an error naming what differs.
    pub fn load_matching(path: &Path, settings: &Settings) -> Result<Option<Checkpoint>> {
        let bytes = match fs::read(path) {
            Ok(b) => b,
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(None),
            Err(e) => return Err(e).with_context(|| format!("cannot read checkpoint '{}'", path.display())),
        };
        let what = path.display().to_string();
        let ck = Checkpoint::decode(&bytes, &what)?;
        if ck.version != VERSION {
            bail!(
                "checkpoint '{what}' was written by penumbra {}, this is penumbra {VERSION}: it cannot be resumed \
                 (the image could differ); use --fresh to start over",
                ck.version
            );
        }
        let diff = settings.differences(&ck.settings, "now", "in the checkpoint", true);
        if !diff.is_empty() {
            bail!(
                "checkpoint '{what}' belongs to another render: {}; run the same command as before, \
                 or use --fresh to start over",
                diff.join("; ")
            );
        }
        Ok(Some(ck))
    }
}

struct Reader<'a> {
    b: &'a [u8],
    at: usize,
}

impl Reader<'_> {
    fn take(&mut self, n: usize) -> Result<&[u8]> {
        if self.at + n > self.b.len() {
            bail!("checkpoint is truncated");
        }
        let s = &self.b[self.at..self.at + n];
        self.at += n;
        Ok(s)
    }
    fn u8(&mut self) -> Result<u8> {
        Ok(self.take(1)?[0])
    }
    fn u32(&mut self) -> Result<u32> {
        Ok(u32::from_le_bytes(self.take(4)?.try_into().unwrap()))
    }
    fn u64(&mut self) -> Result<u64> {
        Ok(u64::from_le_bytes(self.take(8)?.try_into().unwrap()))
    }
    fn string(&mut self) -> Result<String> {
        let n = self.u32()? as usize;
        Ok(String::from_utf8_lossy(self.take(n)?).into_owned())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A checkpoint of `film` after 3 passes, 4 spp and 1.5 s (seed 9), unguided.
    fn checkpoint_of(film: Film) -> Checkpoint {
        let settings = Settings { entries: vec![("spp".into(), "8".into())] };
        Checkpoint { version: VERSION.into(), settings, seed: 9, passes: 3, spp: 4, seconds: 1.5, film, guide: None }
    }

    #[test]
    fn round_trips_and_detects_damage() {
        let layers = FilmLayers {
            aovs: vec![AovKind::Depth, AovKind::Albedo],
            variance: true,
            channels: vec!["dd.y.T".into(), "m2_a.X".into()],
        };
        let mut film = Film::with_layers(3, 2, &layers);
        film.acc[4] = [1.5, 0.1 + 0.2, -0.0, 7.25];
        film.aov[4 * 4 + 1] = 0.375;
        film.moments[5][6] = 1e-300;
        let ck = checkpoint_of(film);
        let bytes = ck.encode();
        let back = Checkpoint::decode(&bytes, "x").unwrap();
        assert_eq!(back.film.acc, ck.film.acc);
        assert_eq!(back.film.aov, ck.film.aov);
        assert_eq!(back.film.moments, ck.film.moments);
        assert_eq!(back.film.layers(), layers);
        assert_eq!((back.seed, back.passes, back.spp, back.seconds), (9, 3, 4, 1.5));
        assert_eq!(back.settings, ck.settings);
        let mut bad = bytes.clone();
        bad[40] ^= 1;
        assert!(Checkpoint::decode(&bad, "x").unwrap_err().to_string().contains("checksum"));
        assert!(Checkpoint::decode(&bytes[..bytes.len() - 9], "x").is_err());
    }

    /// A header claiming a film of 65536 x 65536 pixels (with a valid
    /// checksum) is refused before the film (about 720 GB) is allocated.
    #[test]
    fn a_huge_resolution_is_refused_before_allocating() {
        let layers = FilmLayers { aovs: vec![AovKind::Albedo], variance: true, channels: Vec::new() };
        let film = Film::with_layers(2, 1, &layers);
        let ck = checkpoint_of(film);
        let mut bytes = ck.encode();
        bytes.truncate(bytes.len() - 4);
        let at = bytes.windows(8).position(|w| w == [2, 0, 0, 0, 1, 0, 0, 0]).unwrap();
        bytes[at..at + 8].copy_from_slice(&[0, 0, 1, 0, 0, 0, 1, 0]);
        let crc = crc32fast::hash(&bytes);
        bytes.extend_from_slice(&crc.to_le_bytes());
        let e = Checkpoint::decode(&bytes, "x").unwrap_err().to_string();
        assert!(e.contains("65536 x 65536 pixels of 21 values need 721554505728 bytes"), "{e}");
    }
}
