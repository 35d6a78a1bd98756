//! Mitsuba's binary grid-volume format (`.vol`, version 3): the bytes
//! `VOL`, a version byte (3), then little-endian: encoding i32 (1 =
//! float32), sizes x, y, z (i32), channels (i32), the bounding box as six
//! f32 (min xyz, max xyz), and x·y·z·channels f32 values, x fastest,
//! channels interleaved (Mitsuba 3's `VolumeGrid::read`).

use penumbra_render::geometry::Aabb;
use penumbra_render::medium::Grid;
use std::path::Path;

/// A grid read from a `.vol` file, with the bounding box its header gives.
#[derive(Debug)]
pub struct VolFile {
    /// The voxels.
    pub grid: Grid,
    /// The header's bounding box (used with `use_grid_bbox`).
    pub bbox: Aabb,
}

const HEADER: usize = 3 + 1 + 4 * 5 + 4 * 6;

/// Parses `.vol` bytes; errors name the byte offset and what was wrong.
pub fn parse(bytes: &[u8]) -> Result<VolFile, String> {
    if bytes.len() < HEADER {
        return Err(format!("the file has {} bytes, fewer than the 48-byte header of a .vol file", bytes.len()));
    }
    if &bytes[..3] != b"VOL" {
        return Err("byte 0: not a Mitsuba .vol file (it does not start with 'VOL')".to_string());
    }
    if bytes[3] != 3 {
        return Err(format!("byte 3: version {} is not supported; Mitsuba 3 reads version 3 only", bytes[3]));
    }
    let i32_at = |o: usize| i32::from_le_bytes(bytes[o..o + 4].try_into().expect("4 bytes"));
    let f32_at = |o: usize| f32::from_le_bytes(bytes[o..o + 4].try_into().expect("4 bytes"));
    let encoding = i32_at(4);
    if encoding != 1 {
        return Err(format!("byte 4: encoding {encoding} is not supported; only 1 (float32) is, as in Mitsuba 3"));
    }
    let mut res = [0u32; 3];
    for (k, r) in res.iter_mut().enumerate() {
        let v = i32_at(8 + 4 * k);
        if v <= 0 {
            return Err(format!("byte {}: size along {} is {v}; it must be positive", 8 + 4 * k, ["x", "y", "z"][k]));
        }
        *r = v as u32;
    }
    let channels = i32_at(20);
    if channels != 1 && channels != 3 && channels != 6 {
        return Err(format!(
            "byte 20: {channels} channels; Mitsuba 3 and Penumbra read volumes with 1, 3 or 6 channels"
        ));
    }
    let b: Vec<f32> = (0..6).map(|k| f32_at(24 + 4 * k)).collect();
    if b.iter().any(|v| !v.is_finite()) {
        return Err("byte 24: the bounding box holds a NaN or infinite value".to_string());
    }
    // In u128: three i32 sizes and the channels cannot overflow it.
    let count = res.iter().map(|&r| r as u128).product::<u128>() * channels as u128;
    let expected = HEADER as u128 + 4 * count;
    if (bytes.len() as u128) < expected {
        return Err(format!(
            "the header claims {}x{}x{} voxels of {channels} channel(s), {expected} bytes in all, but the file has {} bytes (truncated?)",
            res[0],
            res[1],
            res[2],
            bytes.len()
        ));
    }
    let mut data = Vec::with_capacity(count as usize);
    for (i, chunk) in bytes[HEADER..expected as usize].chunks_exact(4).enumerate() {
        let v = f32::from_le_bytes(chunk.try_into().expect("4 bytes"));
        if !v.is_finite() {
            let voxel = i / channels as usize;
            return Err(format!(
                "byte {}: value {v} of voxel {voxel} (channel {}) is not finite",
                HEADER + 4 * i,
                i % channels as usize
            ));
        }
        data.push(v);
    }
    let bbox = Aabb { min: glam::Vec3::new(b[0], b[1], b[2]), max: glam::Vec3::new(b[3], b[4], b[5]) };
    Ok(VolFile { grid: Grid { res, channels: channels as u32, data }, bbox })
}

/// Reads a `.vol` file.
pub fn read(path: &Path) -> Result<VolFile, String> {
    let bytes = std::fs::read(path).map_err(|e| format!("cannot read: {e}"))?;
    parse(&bytes)
}

/// Writes `grid` as a `.vol` file's bytes with bounding box `bbox` (for
/// generators and tests).
pub fn encode(grid: &Grid, bbox: &Aabb) -> Vec<u8> {
    let mut out = Vec::with_capacity(HEADER + 4 * grid.data.len());
    out.extend_from_slice(b"VOL");
    out.push(3);
    for v in [1, grid.res[0] as i32, grid.res[1] as i32, grid.res[2] as i32, grid.channels as i32] {
        out.extend_from_slice(&v.to_le_bytes());
    }
    for v in [bbox.min.x, bbox.min.y, bbox.min.z, bbox.max.x, bbox.max.y, bbox.max.z] {
        out.extend_from_slice(&v.to_le_bytes());
    }
    for v in &grid.data {
        out.extend_from_slice(&v.to_le_bytes());
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    fn sample() -> (Grid, Aabb) {
        let grid = Grid { res: [2, 3, 1], channels: 3, data: (0..18).map(|i| i as f32 * 0.5).collect() };
        (grid, Aabb { min: glam::Vec3::ZERO, max: glam::Vec3::new(1.0, 2.0, 3.0) })
    }

    #[test]
    fn round_trips() {
        let (grid, bbox) = sample();
        let v = parse(&encode(&grid, &bbox)).unwrap();
        assert_eq!(v.grid.res, [2, 3, 1]);
        assert_eq!(v.grid.channels, 3);
        assert_eq!(v.grid.data, grid.data);
        assert_eq!(v.bbox.max, bbox.max);
    }

    /// Every malformed file is an error naming what is wrong, never a panic.
    #[test]
    fn malformed_files_are_errors_with_offsets() {
        let (grid, bbox) = sample();
        let good = encode(&grid, &bbox);
        let cases: Vec<(Vec<u8>, &str)> = vec![
            (good[..10].to_vec(), "fewer than the 48-byte header"),
            (good[..good.len() - 1].to_vec(), "truncated"),
            ([b"VOX".as_slice(), &good[3..]].concat(), "byte 0"),
            ([&good[..3], &[2u8], &good[4..]].concat(), "byte 3: version 2"),
            ([&good[..4], &2i32.to_le_bytes(), &good[8..]].concat(), "byte 4: encoding 2"),
            ([&good[..8], &(-1i32).to_le_bytes(), &good[12..]].concat(), "byte 8: size along x"),
            ([&good[..20], &2i32.to_le_bytes(), &good[24..]].concat(), "byte 20: 2 channels"),
            ([&good[..24], &f32::NAN.to_le_bytes(), &good[28..]].concat(), "byte 24"),
            (
                [&good[..52], &f32::INFINITY.to_le_bytes(), &good[56..]].concat(),
                "byte 52: value inf of voxel 0 (channel 1)",
            ),
            // Billions of voxels claimed: refused before allocating.
            ([&good[..8], &i32::MAX.to_le_bytes(), &good[12..]].concat(), "truncated"),
        ];
        for (bytes, want) in cases {
            let e = parse(&bytes).unwrap_err();
            assert!(e.contains(want), "{e:?} lacks {want:?}");
        }
    }
}
