//! Volume data: Mitsuba 3's `constvolume` and `gridvolume`. A volume maps
//! world points to RGB values through its `to_world` transform, which
//! places the unit cube [0, 1]³ of the data in the scene. Media read them
//! (re-exported as `medium::volume`), and so does the `volume` texture.

use crate::geometry::Aabb;
use crate::math::luminance;
use crate::math::Spectrum;
pub use crate::texture::WrapMode;
use glam::{Mat4, Vec3};
use std::sync::Arc;

/// Lookup between voxels (Mitsuba's `filter_type`).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum VolumeFilter {
    /// The voxel that contains the point.
    Nearest,
    /// Trilinear interpolation between voxel centres.
    Trilinear,
}

/// A voxel grid with 1, 3 or 6 channels, x fastest (Mitsuba's `.vol` order).
#[derive(Debug, Clone, PartialEq)]
pub struct Grid {
    /// Voxels along x, y and z.
    pub res: [u32; 3],
    /// Values per voxel: 1 (broadcast to RGB), 3 (RGB) or 6 (the `sggx`
    /// phase function's S_xx, S_yy, S_zz, S_xy, S_xz, S_yz).
    pub channels: u32,
    /// `res[0] · res[1] · res[2] · channels` values.
    pub data: Vec<f32>,
}

impl Grid {
    /// The largest value over all voxels and channels (0 for none).
    pub fn max(&self) -> f32 {
        self.data.iter().copied().fold(0.0, f32::max)
    }

    /// The first N channels of a voxel; a 1-channel grid broadcasts its value.
    #[inline]
    fn voxel<const N: usize>(&self, x: usize, y: usize, z: usize) -> [f32; N] {
        let i = ((z * self.res[1] as usize + y) * self.res[0] as usize + x) * self.channels as usize;
        if self.channels == 1 {
            [self.data[i]; N]
        } else {
            std::array::from_fn(|c| self.data[i + c])
        }
    }
}

/// A placed grid: Mitsuba's `gridvolume`.
#[derive(Debug, Clone, PartialEq)]
pub struct GridVolume {
    /// The voxels.
    pub grid: Arc<Grid>,
    /// World → [0, 1]³ of the grid.
    pub to_local: Mat4,
    /// How values are looked up.
    pub filter: VolumeFilter,
    /// How points outside the unit cube are mapped into it (Mitsuba's
    /// `wrap_mode`, as for bitmaps).
    pub wrap: WrapMode,
    /// The largest value the volume takes (Mitsuba's `max_value`, or the grid's maximum).
    pub max: f32,
}

impl GridVolume {
    /// The value at world point `p` (a grid of 1 or 3 channels), looked up
    /// as Dr.Jit's textures do: voxel centres at (i + ½) / res.
    pub fn eval(&self, p: Vec3) -> Spectrum {
        Spectrum::from_array(self.lookup::<3>(p))
    }

    /// The six values at world point `p` of a 6-channel grid (Mitsuba's
    /// `eval_6`, which the `sggx` phase function reads).
    pub fn eval6(&self, p: Vec3) -> [f32; 6] {
        self.lookup::<6>(p)
    }

    /// The first N channels at `p`, nearest or trilinear.
    fn lookup<const N: usize>(&self, p: Vec3) -> [f32; N] {
        let q = self.to_local.transform_point3(p);
        let g = &*self.grid;
        let res = Vec3::new(g.res[0] as f32, g.res[1] as f32, g.res[2] as f32);
        match self.filter {
            VolumeFilter::Nearest => {
                let v = (q * res).floor();
                g.voxel(
                    self.wrap.index(v.x as i32, g.res[0] as usize),
                    self.wrap.index(v.y as i32, g.res[1] as usize),
                    self.wrap.index(v.z as i32, g.res[2] as usize),
                )
            }
            VolumeFilter::Trilinear => {
                let pos = q * res - Vec3::splat(0.5);
                let base = pos.floor();
                let f = pos - base;
                let (bx, by, bz) = (base.x as i32, base.y as i32, base.z as i32);
                let xs =
                    [self.wrap.index(bx, g.res[0] as usize), self.wrap.index(bx.saturating_add(1), g.res[0] as usize)];
                let ys =
                    [self.wrap.index(by, g.res[1] as usize), self.wrap.index(by.saturating_add(1), g.res[1] as usize)];
                let zs =
                    [self.wrap.index(bz, g.res[2] as usize), self.wrap.index(bz.saturating_add(1), g.res[2] as usize)];
                let wx = [1.0 - f.x, f.x];
                let wy = [1.0 - f.y, f.y];
                let wz = [1.0 - f.z, f.z];
                let mut acc = [0.0f32; N];
                for (k, &z) in zs.iter().enumerate() {
                    for (j, &y) in ys.iter().enumerate() {
                        for (i, &x) in xs.iter().enumerate() {
                            let w = wx[i] * wy[j] * wz[k];
                            let v = g.voxel::<N>(x, y, z);
                            for (a, v) in acc.iter_mut().zip(v) {
                                *a += v * w;
                            }
                        }
                    }
                }
                acc
            }
        }
    }
}

/// A volume: a constant or a grid, each placed by its `to_world`.
#[derive(Debug, Clone, PartialEq)]
pub enum Volume {
    /// Mitsuba `constvolume` (and a plain float or colour given for a volume).
    Constant {
        /// The value everywhere.
        value: Spectrum,
        /// The placed unit cube's bounds (what a heterogeneous medium with
        /// this volume as `sigma_t` fills).
        bounds: Aabb,
    },
    /// Mitsuba `gridvolume`.
    Grid {
        /// The placed grid.
        grid: GridVolume,
        /// The placed unit cube's bounds.
        bounds: Aabb,
    },
}

/// The world bounds of the unit cube placed by `to_world`.
pub fn unit_cube_bounds(to_world: Mat4) -> Aabb {
    let corners: Vec<Vec3> = (0..8)
        .map(|i| to_world.transform_point3(Vec3::new((i & 1) as f32, ((i >> 1) & 1) as f32, ((i >> 2) & 1) as f32)))
        .collect();
    Aabb::from_points(&corners)
}

impl Volume {
    /// A constant volume over the unit cube placed by the identity.
    pub fn constant(value: Spectrum) -> Volume {
        Volume::Constant { value, bounds: unit_cube_bounds(Mat4::IDENTITY) }
    }

    /// The value at world point `p`.
    #[inline]
    pub fn eval(&self, p: Vec3) -> Spectrum {
        match self {
            Volume::Constant { value, .. } => *value,
            Volume::Grid { grid, .. } => grid.eval(p),
        }
    }

    /// The largest value over the volume (all channels).
    pub fn max(&self) -> f32 {
        match self {
            Volume::Constant { value, .. } => value.max_element(),
            Volume::Grid { grid, .. } => grid.max,
        }
    }

    /// The world bounds of the placed unit cube.
    pub fn bounds(&self) -> Aabb {
        match self {
            Volume::Constant { bounds, .. } | Volume::Grid { bounds, .. } => *bounds,
        }
    }

    /// A scalar at `p` (Mitsuba's `eval_1`): the mean of a constant's
    /// channels, a 1-channel grid's value, a 3-channel grid's luminance.
    #[inline]
    pub fn eval_1(&self, p: Vec3) -> f32 {
        match self {
            Volume::Constant { value, .. } => (value.x + value.y + value.z) / 3.0,
            Volume::Grid { grid, .. } if grid.grid.channels == 1 => grid.eval(p).x,
            Volume::Grid { grid, .. } => luminance(grid.eval(p)),
        }
    }

    /// The constant value, when the volume is one.
    pub fn as_constant(&self) -> Option<Spectrum> {
        match self {
            Volume::Constant { value, .. } => Some(*value),
            Volume::Grid { .. } => None,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn grid(filter: VolumeFilter, wrap: WrapMode) -> GridVolume {
        // 2 × 1 × 1 voxels: 1 and 3.
        let grid = Arc::new(Grid { res: [2, 1, 1], channels: 1, data: vec![1.0, 3.0] });
        GridVolume { grid, to_local: Mat4::IDENTITY, filter, wrap, max: 3.0 }
    }

    /// Voxel centres hold the voxel values; between them values are
    /// linear; outside, the wrap mode decides.
    #[test]
    fn lookups_follow_voxel_centres_and_wrap_modes() {
        let v = grid(VolumeFilter::Trilinear, WrapMode::Clamp);
        let at = |x: f32| v.eval(Vec3::new(x, 0.5, 0.5)).x;
        assert_eq!(at(0.25), 1.0);
        assert_eq!(at(0.75), 3.0);
        assert_eq!(at(0.5), 2.0);
        assert_eq!(at(0.0), 1.0, "clamped below the first centre");
        assert_eq!(at(1.2), 3.0);
        let n = grid(VolumeFilter::Nearest, WrapMode::Clamp);
        assert_eq!(n.eval(Vec3::new(0.49, 0.5, 0.5)).x, 1.0);
        assert_eq!(n.eval(Vec3::new(0.51, 0.5, 0.5)).x, 3.0);
        let r = grid(VolumeFilter::Nearest, WrapMode::Repeat);
        assert_eq!(r.eval(Vec3::new(1.25, 0.5, 0.5)).x, 1.0);
        let m = grid(VolumeFilter::Nearest, WrapMode::Mirror);
        assert_eq!(m.eval(Vec3::new(1.25, 0.5, 0.5)).x, 3.0);
        // Trilinear with repeat blends the last and first voxels across the seam.
        let t = grid(VolumeFilter::Trilinear, WrapMode::Repeat);
        assert_eq!(t.eval(Vec3::new(1.0, 0.5, 0.5)).x, 2.0);
    }
}
