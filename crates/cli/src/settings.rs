//! The identity of a render: a hash of the scene file's contents and every
//! setting that changes the image's bits. Checkpoints and EXR headers carry it
//! as `key=value` lines, so a mismatch can be reported key by key.

use crate::part::Part;

pub const VERSION: &str = env!("CARGO_PKG_VERSION");

/// Keys left out of [`Settings::render_hash`]: they tell the pieces of one
/// render apart (parts, crops) rather than the render itself.
const PIECE_KEYS: [&str; 2] = ["crop", "part"];

/// Ordered `key=value` settings.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Settings {
    pub entries: Vec<(String, String)>,
}

/// 64-bit FNV-1a.
pub fn fnv1a(bytes: &[u8]) -> u64 {
    let mut h: u64 = 0xcbf2_9ce4_8422_2325;
    for &b in bytes {
        h ^= b as u64;
        h = h.wrapping_mul(0x0100_0000_01b3);
    }
    h
}

/// What identifies a render besides the scene file.
pub struct RenderIdentity<'a> {
    pub scene_bytes: &'a [u8],
    pub spp: u32,
    pub seed: u64,
    pub integrator: Option<&'a str>,
    pub defines: &'a [(String, String)],
    pub full_size: (u32, u32),
    /// x0,y0,x1,y1 in full-frame pixels when only a window is rendered.
    pub crop: Option<[u32; 4]>,
    pub part: Option<Part>,
    pub max_pass_spp: u32,
}

impl Settings {
    pub fn new(id: &RenderIdentity) -> Settings {
        let defines: Vec<String> = id.defines.iter().map(|(k, v)| format!("{k}={v}")).collect();
        let mut e = vec![
            ("version", VERSION.to_string()),
            ("scene", format!("{:016x}", fnv1a(id.scene_bytes))),
            ("spp", id.spp.to_string()),
            ("seed", id.seed.to_string()),
            ("integrator", id.integrator.unwrap_or("(scene)").to_string()),
            ("defines", defines.join(" ")),
            ("size", format!("{}x{}", id.full_size.0, id.full_size.1)),
            ("max_pass_spp", id.max_pass_spp.to_string()),
        ];
        e.push(("crop", id.crop.map_or("full".into(), |c| format!("{},{},{},{}", c[0], c[1], c[2], c[3]))));
        e.push(("part", id.part.map_or("whole".into(), |p| p.to_string())));
        Settings { entries: e.into_iter().map(|(k, v)| (k.to_string(), v.replace('\n', " "))).collect() }
    }

    pub fn get(&self, key: &str) -> Option<&str> {
        self.entries.iter().find(|(k, _)| k == key).map(|(_, v)| v.as_str())
    }

    pub fn set(&mut self, key: &str, value: &str) {
        match self.entries.iter_mut().find(|(k, _)| k == key) {
            Some(e) => e.1 = value.to_string(),
            None => self.entries.push((key.to_string(), value.to_string())),
        }
    }

    pub fn to_text(&self) -> String {
        self.entries.iter().map(|(k, v)| format!("{k}={v}\n")).collect()
    }

    pub fn parse(text: &str) -> Settings {
        let entries =
            text.lines().filter_map(|l| l.split_once('=')).map(|(k, v)| (k.to_string(), v.to_string())).collect();
        Settings { entries }
    }

    /// Hash of everything, pieces included: equal for the same command.
    pub fn hash(&self) -> String {
        format!("{:016x}", fnv1a(self.to_text().as_bytes()))
    }

    /// Hash without crop and part: equal for all pieces of one render, and
    /// equal to the hash of the whole render made on one machine.
    pub fn render_hash(&self) -> String {
        let whole = Settings {
            entries: self.entries.iter().filter(|(k, _)| !PIECE_KEYS.contains(&k.as_str())).cloned().collect(),
        };
        whole.hash()
    }

    /// The keys whose values differ, as "key: A here, B there".
    pub fn differences(&self, other: &Settings, here: &str, there: &str, pieces: bool) -> Vec<String> {
        let mut keys: Vec<&str> = self.entries.iter().map(|(k, _)| k.as_str()).collect();
        for (k, _) in &other.entries {
            if !keys.contains(&k.as_str()) {
                keys.push(k);
            }
        }
        keys.into_iter()
            .filter(|k| pieces || !PIECE_KEYS.contains(k))
            .filter(|k| self.get(k) != other.get(k))
            .map(|k| {
                let name = if k == "scene" { "scene file contents (hash)" } else { k };
                format!(
                    "{name}: {} {here}, {} {there}",
                    self.get(k).unwrap_or("(none)"),
                    other.get(k).unwrap_or("(none)")
                )
            })
            .collect()
    }
}
