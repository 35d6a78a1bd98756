//! `penumbra merge`: adds the parts of a render (`--part I/N`: disjoint
//! sample ranges, carrying per-pixel weight sums) and assembles crop windows
//! (`--crop`) into the image one machine would render. The header metadata
//! decides what belongs together: all inputs must share the render hash
//! (scene contents and image-changing settings); within a crop window the
//! parts must share N and none may be duplicated or missing.
//!
//! Pixel values: Σ(RGB·weight) / Σ weight over the parts in f64, i.e. the
//! film's Σ w·L / Σ w up to f32 rounding of the stored RGB and weights; AOV
//! layers the same way, and the variance from the parts' moment channels
//! (layers.rs): each part becomes a film again, and the films add.

use crate::args::MergeArgs;
use crate::exrmeta::{self, ExrImage};
use crate::layers;
use crate::part;
use crate::settings::Settings;
use anyhow::{anyhow, bail, Result};
use penumbra_render::film::Film;
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

struct Input {
    path: PathBuf,
    img: ExrImage,
    settings: Settings,
    /// (index, count), or None for a whole render of its window.
    part: Option<(u32, u32)>,
}

type Window = (u32, u32, u32, u32); // x, y, width, height

fn window(i: &Input) -> Window {
    (i.img.offset.0, i.img.offset.1, i.img.width, i.img.height)
}

fn describe(w: Window) -> String {
    format!("{},{},{},{}", w.0, w.1, w.0 + w.2, w.1 + w.3)
}

fn load(path: &Path) -> Result<Input> {
    let img = exrmeta::read(path)?;
    // The header is not trusted: the window must lie in the full frame.
    let (right, bottom) = (img.offset.0 as u64 + img.width as u64, img.offset.1 as u64 + img.height as u64);
    if right > img.full_size.0 as u64 || bottom > img.full_size.1 as u64 {
        bail!(
            "'{}': its data window {},{},{right},{bottom} reaches outside its display window (0,0,{},{}): \
             the file is damaged or was not written by `penumbra render`",
            path.display(),
            img.offset.0,
            img.offset.1,
            img.full_size.0,
            img.full_size.1
        );
    }
    let meta = |k: &str| {
        img.meta.get(k).cloned().ok_or_else(|| {
            anyhow!("'{}' has no penumbra:{k} attribute: it was not written by `penumbra render`", path.display())
        })
    };
    let settings = Settings::parse(&meta("settings")?);
    let part = match meta("part")?.as_str() {
        "whole" => None,
        p => {
            let p = part::parse_fixed(p).map_err(|e| anyhow!("'{}': {e}", path.display()))?;
            if img.weight.is_none() {
                bail!("'{}' is part {p} but has no {} channel", path.display(), exrmeta::WEIGHT_CHANNEL);
            }
            Some((p.index, p.count))
        }
    };
    Ok(Input { path: path.to_path_buf(), img, settings, part })
}

fn overlap(a: Window, b: Window) -> bool {
    a.0 < b.0 + b.2 && b.0 < a.0 + a.2 && a.1 < b.1 + b.3 && b.1 < a.1 + a.3
}

pub fn run(a: &MergeArgs) -> Result<()> {
    if !a.output.extension().is_some_and(|e| e.eq_ignore_ascii_case("exr")) {
        bail!("merge writes EXR only: name the output '*.exr', not '{}'", a.output.display());
    }
    let inputs: Vec<Input> = a.inputs.iter().map(|p| load(p)).collect::<Result<_>>()?;
    let first = &inputs[0];
    let hash = first.settings.render_hash();
    for i in &inputs[1..] {
        if i.settings.render_hash() != hash {
            let d = i.settings.differences(&first.settings, "there", &format!("in '{}'", first.path.display()), false);
            bail!("'{}' belongs to another render than '{}': {}", i.path.display(), first.path.display(), d.join("; "));
        }
        if i.img.full_size != first.img.full_size {
            bail!("'{}' has another full image size than '{}'", i.path.display(), first.path.display());
        }
    }
    // Group by window; check parts within each.
    let mut groups: BTreeMap<Window, Vec<&Input>> = BTreeMap::new();
    for i in &inputs {
        groups.entry(window(i)).or_default().push(i);
    }
    let mut missing_notes = Vec::new();
    for (w, members) in &groups {
        let whole: Vec<_> = members.iter().filter(|i| i.part.is_none()).collect();
        if let Some(x) = whole.first() {
            if let Some(y) = members.iter().find(|i| !std::ptr::eq(**i, **x)) {
                bail!(
                    "'{}' is a whole render of window {}, and '{}' covers the same window again: duplicate",
                    x.path.display(),
                    describe(*w),
                    y.path.display()
                );
            }
            continue;
        }
        let n = members[0].part.unwrap().1;
        let mut seen: BTreeMap<u32, &Path> = BTreeMap::new();
        for i in members {
            let (idx, cnt) = i.part.unwrap();
            if cnt != n {
                bail!(
                    "'{}' is part {idx}/{cnt} but '{}' is part of {n}: all parts must use the same N",
                    i.path.display(),
                    members[0].path.display()
                );
            }
            if let Some(prev) = seen.insert(idx, &i.path) {
                bail!("'{}' and '{}' are both part {idx}/{n}: duplicate", prev.display(), i.path.display());
            }
        }
        let missing: Vec<String> = (0..n).filter(|k| !seen.contains_key(k)).map(|k| format!("{k}/{n}")).collect();
        if !missing.is_empty() {
            let note = format!(
                "part{} {} of window {} missing",
                if missing.len() > 1 { "s" } else { "" },
                missing.join(", "),
                describe(*w)
            );
            if !a.allow_missing {
                bail!("{note} (have {} of {n}); render it, or merge with --allow-missing", seen.len());
            }
            missing_notes.push(note);
        }
    }
    let windows: Vec<Window> = groups.keys().copied().collect();
    for (k, x) in windows.iter().enumerate() {
        for y in &windows[k + 1..] {
            if overlap(*x, *y) {
                let name = |w: &Window| groups[w][0].path.display().to_string();
                bail!("windows {} ('{}') and {} ('{}') overlap", describe(*x), name(x), describe(*y), name(y));
            }
        }
    }
    // The output window: the single window, or the full frame.
    let full = first.img.full_size;
    let out_w: Window = if windows.len() == 1 { windows[0] } else { (0, 0, full.0, full.1) };
    let covered: u64 = windows.iter().map(|w| w.2 as u64 * w.3 as u64).sum();
    if covered < out_w.2 as u64 * out_w.3 as u64 {
        let note = format!(
            "{} of {} pixels are covered by no input",
            out_w.2 as u64 * out_w.3 as u64 - covered,
            out_w.2 as u64 * out_w.3 as u64
        );
        if !a.allow_missing {
            bail!("{note}: crop windows are missing; render them, or merge with --allow-missing");
        }
        missing_notes.push(note);
    }

    let n = out_w.2 as usize * out_w.3 as usize;
    let mut rgb = vec![[0f32; 3]; n];
    let mut layers: Vec<(String, Vec<f32>)> = Vec::new();
    let mut spp_min = u32::MAX;
    let mut seconds = 0.0;
    let mut complete = missing_notes.is_empty();
    for (w, members) in &groups {
        let mut spp = 0;
        for i in members {
            spp += i.img.meta.get("spp").and_then(|s| s.parse::<u32>().ok()).unwrap_or(0);
            seconds += i.img.meta.get("renderTime").and_then(|s| s.parse::<f64>().ok()).unwrap_or(0.0);
            complete &= i.img.meta.get("complete").map(String::as_str) == Some("yes");
        }
        spp_min = spp_min.min(spp);
        // The window's pixels and layers: a whole render as it is; parts
        // added as films (Σ w·L, Σ w, AOV sums, moments) and developed.
        let (win_rgb, win_layers) = if members[0].part.is_none() {
            (members[0].img.rgb.clone(), members[0].img.layers.clone())
        } else {
            let mut film: Option<Film> = None;
            for i in members {
                let f = layers::film_of_part(&i.img, &i.path.display().to_string())?;
                match &mut film {
                    None => film = Some(f),
                    Some(acc) => {
                        if acc.layers() != f.layers() {
                            bail!("'{}' has other layers than '{}'", i.path.display(), members[0].path.display());
                        }
                        acc.merge(&f);
                    }
                }
            }
            let film = film.unwrap();
            (film.develop(), layers::channels(&film, false))
        };
        for (name, _) in &win_layers {
            if !layers.iter().any(|(n, _)| n == name) {
                layers.push((name.clone(), vec![0f32; n]));
            }
        }
        for y in 0..w.3 {
            for x in 0..w.2 {
                let k = (y * w.2 + x) as usize;
                let dst = ((w.1 - out_w.1 + y) * out_w.2 + (w.0 - out_w.0 + x)) as usize;
                rgb[dst] = win_rgb[k];
                for (name, v) in &win_layers {
                    layers.iter_mut().find(|(n, _)| n == name).unwrap().1[dst] = v[k];
                }
            }
        }
    }
    // The merged image's settings: those of the whole render of its window.
    let mut settings = first.settings.clone();
    settings.set("part", "whole");
    let is_full = (out_w.2, out_w.3) == full;
    settings.set("crop", &if is_full { "full".to_string() } else { describe(out_w) });
    let mut meta = BTreeMap::new();
    for k in ["seed", "version", "sppTarget"] {
        if let Some(v) = first.img.meta.get(k) {
            meta.insert(k.to_string(), v.clone());
        }
    }
    if let Some(t) = settings.get("spp") {
        meta.insert("sppTarget".into(), t.to_string());
    }
    meta.insert("spp".into(), spp_min.to_string());
    meta.insert("complete".into(), if complete { "yes" } else { "no" }.into());
    meta.insert("renderTime".into(), format!("{seconds:.3}"));
    meta.insert("commandLine".into(), crate::render_cmd::command_line());
    meta.insert("settings".into(), settings.to_text());
    meta.insert("settingsHash".into(), settings.hash());
    meta.insert("renderHash".into(), settings.render_hash());
    meta.insert("part".into(), "whole".into());
    meta.insert("crop".into(), settings.get("crop").unwrap_or("full").into());
    let names: Vec<String> = inputs.iter().map(|i| i.path.display().to_string()).collect();
    meta.insert("mergedFrom".into(), names.join(" "));
    if !missing_notes.is_empty() {
        meta.insert("missing".into(), missing_notes.join("; "));
    }
    let img = ExrImage {
        width: out_w.2,
        height: out_w.3,
        offset: (out_w.0, out_w.1),
        full_size: full,
        rgb,
        weight: None,
        layers,
        meta,
    };
    exrmeta::write(&a.output, &img)?;
    eprintln!(
        "merged {} inputs into {} ({}x{}, {} spp{})",
        inputs.len(),
        a.output.display(),
        out_w.2,
        out_w.3,
        spp_min,
        if missing_notes.is_empty() { String::new() } else { format!("; {}", missing_notes.join("; ")) }
    );
    Ok(())
}
