//! Mitsuba's `bitmap` texture: an image looked up at the surface uv.
//!
//! Conventions (checked against Mitsuba 3.9.1, see the tests): texel (x, y)
//! covers uv ∈ [x/W, (x+1)/W] × [y/H, (y+1)/H] with its centre at +0.5, and
//! row y = 0 is the *first* row of the file (the top of the picture), so v
//! grows downwards. `to_uv` is applied to the uv first. Data are linear RGB.

use crate::math::luminance;
use crate::math::Spectrum;
use glam::{Affine2, Vec2};

/// Texel lookup (Mitsuba `bitmap`'s `filter_type`).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum FilterType {
    /// The nearest texel.
    Nearest,
    /// Bilinear interpolation of the four nearest texels.
    Bilinear,
}

/// Handling of coordinates outside [0, 1] (Mitsuba `bitmap`'s `wrap_mode`).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum WrapMode {
    /// Tile the image.
    Repeat,
    /// Tile the image, mirroring every other copy.
    Mirror,
    /// Clamp to the edge texels.
    Clamp,
}

impl WrapMode {
    /// Texel index `i` on an axis of `n` texels (or voxels) under this mode.
    #[inline]
    pub fn index(self, i: i32, n: usize) -> usize {
        let r = n as i32;
        (match self {
            WrapMode::Clamp => i.clamp(0, r - 1),
            WrapMode::Repeat => i.rem_euclid(r),
            WrapMode::Mirror => {
                let m = i.rem_euclid(2 * r);
                if m >= r {
                    2 * r - 1 - m
                } else {
                    m
                }
            }
        }) as usize
    }
}

/// An RGB image texture with its lookup settings.
#[derive(Debug, Clone)]
pub struct Bitmap {
    width: usize,
    height: usize,
    /// Linear RGB, row-major, row 0 first (v = 0).
    data: Vec<Spectrum>,
    filter: FilterType,
    wrap: WrapMode,
    to_uv: Affine2,
    /// Mean luminance of the texels (Mitsuba's `mean()` for RGB data).
    mean: f32,
}

impl Bitmap {
    /// Builds a texture from linear RGB texels, row 0 first. Images smaller
    /// than 2×2 are padded to 2×2 by repeating their edge, as Mitsuba's
    /// `pad_to` does for bilinear lookups. Non-finite texels are rejected.
    pub fn new(
        width: usize,
        height: usize,
        data: Vec<Spectrum>,
        filter: FilterType,
        wrap: WrapMode,
        to_uv: Affine2,
    ) -> Result<Bitmap, String> {
        if width == 0 || height == 0 || data.len() != width * height {
            return Err(format!("bitmap of {width}x{height} texels needs as many values, got {}", data.len()));
        }
        if let Some(i) = data.iter().position(|c| !c.is_finite()) {
            return Err(format!("texel ({}, {}) is not finite ({:?})", i % width, i / width, data[i].to_array()));
        }
        let (w2, h2) = (width.max(2), height.max(2));
        let data = if (w2, h2) == (width, height) {
            data
        } else {
            (0..w2 * h2).map(|i| data[(i / w2).min(height - 1) * width + (i % w2).min(width - 1)]).collect()
        };
        // Mitsuba takes the mean after padding.
        let mean = data.iter().map(|&c| luminance(c) as f64).sum::<f64>() / data.len() as f64;
        Ok(Bitmap { width: w2, height: h2, data, filter, wrap, to_uv, mean: mean as f32 })
    }

    /// Width and height in texels.
    pub fn resolution(&self) -> (usize, usize) {
        (self.width, self.height)
    }

    /// Mean luminance of the texels.
    pub fn mean(&self) -> f32 {
        self.mean
    }

    #[inline]
    fn texel(&self, x: i32, y: i32) -> Spectrum {
        self.data[self.wrap.index(y, self.height) * self.width + self.wrap.index(x, self.width)]
    }

    /// Bilinear footprint: the lower texel, the weights of the upper ones,
    /// and the four texels (00, 10, 01, 11).
    #[inline]
    fn fetch(&self, uv: Vec2) -> ([Spectrum; 4], Vec2) {
        let p = uv * Vec2::new(self.width as f32, self.height as f32) - 0.5;
        let f = p.floor();
        let w1 = p - f;
        let (x, y) = (f.x as i32, f.y as i32);
        ([self.texel(x, y), self.texel(x + 1, y), self.texel(x, y + 1), self.texel(x + 1, y + 1)], w1)
    }

    /// The colour at surface coordinates `uv` (before `to_uv`).
    #[inline]
    pub fn eval(&self, uv: Vec2) -> Spectrum {
        let uv = self.to_uv.transform_point2(uv);
        if !uv.is_finite() {
            return Spectrum::ZERO;
        }
        match self.filter {
            FilterType::Nearest => {
                let p = (uv * Vec2::new(self.width as f32, self.height as f32)).floor();
                self.texel(p.x as i32, p.y as i32)
            }
            FilterType::Bilinear => {
                let ([c00, c10, c01, c11], w1) = self.fetch(uv);
                let w0 = 1.0 - w1;
                (c00 * w0.x + c10 * w1.x) * w0.y + (c01 * w0.x + c11 * w1.x) * w1.y
            }
        }
    }

    /// Mitsuba's `eval_1`: the luminance of the colour (grey images give
    /// their value, since the luminance weights sum to one).
    #[inline]
    pub fn eval_1(&self, uv: Vec2) -> f32 {
        luminance(self.eval(uv))
    }

    /// `eval_1` and its gradient with respect to the surface (u, v), as
    /// Mitsuba's `eval_1_grad` computes it: the derivative of the bilinear
    /// interpolant of the texels' luminance, zero for nearest filtering.
    pub fn eval_1_grad(&self, uv_in: Vec2) -> (f32, Vec2) {
        let value = self.eval_1(uv_in);
        if self.filter == FilterType::Nearest {
            return (value, Vec2::ZERO);
        }
        let uv = self.to_uv.transform_point2(uv_in);
        if !uv.is_finite() {
            return (value, Vec2::ZERO);
        }
        let (c, w1) = self.fetch(uv);
        let [f00, f10, f01, f11] = c.map(luminance);
        let w0 = 1.0 - w1;
        let dx = w0.y * (f10 - f00) + w1.y * (f11 - f01);
        let dy = w0.x * (f01 - f00) + w1.x * (f11 - f10);
        // Chain rule through the linear part of to_uv, then (as Mitsuba
        // does) a per-axis scale by the resolution.
        let m = self.to_uv.matrix2;
        let du = m.x_axis.x * dx + m.x_axis.y * dy;
        let dv = m.y_axis.x * dx + m.y_axis.y * dy;
        (value, Vec2::new(du * self.width as f32, dv * self.height as f32))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::{Mat2, Vec3};

    /// The 4×2 test image, row 0 first (the top row of the file).
    fn image() -> Vec<Spectrum> {
        [
            [0.1, 0.2, 0.3],
            [0.4, 0.5, 0.6],
            [0.7, 0.8, 0.9],
            [1.0, 0.0, 0.5],
            [0.0, 0.0, 0.0],
            [0.2, 0.2, 0.2],
            [0.9, 0.1, 0.3],
            [0.3, 0.6, 0.9],
        ]
        .map(Vec3::from_array)
        .to_vec()
    }

    fn bitmap(filter: FilterType, wrap: WrapMode, to_uv: Affine2) -> Bitmap {
        Bitmap::new(4, 2, image(), filter, wrap, to_uv).unwrap()
    }

    const PTS: [(f32, f32); 6] = [(0.1, 0.2), (0.375, 0.25), (0.6, 0.9), (-0.2, 1.3), (1.1, -0.4), (0.0, 0.0)];

    fn check(b: &Bitmap, expect: &[([f32; 3], f32, [f32; 2])]) {
        for (&(u, v), &(rgb, e1, g)) in PTS.iter().zip(expect) {
            let uv = Vec2::new(u, v);
            let c = b.eval(uv);
            assert!((c - Vec3::from_array(rgb)).abs().max_element() < 1e-5, "({u},{v}): {c} vs {rgb:?}");
            assert!((b.eval_1(uv) - e1).abs() < 1e-5, "({u},{v}): eval_1 {} vs {e1}", b.eval_1(uv));
            let (val, grad) = b.eval_1_grad(uv);
            assert!((val - e1).abs() < 1e-5);
            assert!((grad - Vec2::from_array(g)).abs().max_element() < 1e-4, "({u},{v}): grad {grad} vs {g:?}");
        }
    }

    // Values printed by Mitsuba 3.9.1 (scalar_rgb):
    //   img = np.array(<the image above, shape (2, 4, 3)>, dtype=np.float32)
    //   mi.Bitmap(img).write('a.exr')
    //   t = mi.load_dict({'type': 'bitmap', 'filename': 'a.exr', **kw})
    //   si = mi.SurfaceInteraction3f(); si.uv = [u, v]
    //   t.eval(si), t.eval_1(si), t.eval_1_grad(si), t.mean()
    #[test]
    fn bilinear_repeat_matches_mitsuba() {
        let b = bitmap(FilterType::Bilinear, WrapMode::Repeat, Affine2::IDENTITY);
        assert!((b.mean() - 0.3436281085014343).abs() < 1e-6);
        check(
            &b,
            &[
                ([0.174, 0.168, 0.297], 0.17858582735061646, [-0.4492403268814087, 0.2728908658027649]),
                ([0.4, 0.5, 0.6], 0.4859498143196106, [1.1999998092651367, -0.5718996524810791]),
                (
                    [0.7820000648498535, 0.30799996852874756, 0.46399998664855957],
                    0.42006441950798035,
                    [0.5967975854873657, 0.9596723914146423],
                ),
                (
                    [0.8670000433921814, 0.2609999477863312, 0.63],
                    0.4165089726448059,
                    [-1.8245880603790283, 0.13190405070781708],
                ),
                (
                    [0.07799994945526123, 0.09599996358156204, 0.15899991989135742],
                    0.09671852737665176,
                    [-1.637345314025879, -0.27289095520973206],
                ),
                ([0.35, 0.2, 0.425], 0.2481386661529541, [-1.2413102388381958, -0.12314409017562866]),
            ],
        );
    }

    #[test]
    fn nearest_repeat_matches_mitsuba_and_row_zero_is_v_zero() {
        let b = bitmap(FilterType::Nearest, WrapMode::Repeat, Affine2::IDENTITY);
        check(
            &b,
            &[
                ([0.1, 0.2, 0.3], 0.18594980239868164, [0.0, 0.0]),
                ([0.4, 0.5, 0.6], 0.4859498143196106, [0.0, 0.0]),
                ([0.9, 0.1, 0.3], 0.2845706045627594, [0.0, 0.0]),
                ([1.0, 0.0, 0.5], 0.24875549972057343, [0.0, 0.0]),
                ([0.0, 0.0, 0.0], 0.0, [0.0, 0.0]),
                ([0.1, 0.2, 0.3], 0.18594980239868164, [0.0, 0.0]),
            ],
        );
    }

    #[test]
    fn mirror_and_clamp_match_mitsuba() {
        let b = bitmap(FilterType::Bilinear, WrapMode::Mirror, Affine2::IDENTITY);
        check(
            &b,
            &[
                ([0.1, 0.2, 0.3], 0.18594980239868164, [0.0, 0.0]),
                ([0.4, 0.5, 0.6], 0.4859498143196106, [1.1999998092651367, -0.5718996524810791]),
                (
                    [0.8300000429153442, 0.10999998450279236, 0.2900000214576721],
                    0.2761135399341583,
                    [0.33828240633010864, 0.0],
                ),
                (
                    [0.0729999765753746, 0.08299997448921204, 0.09299995750188828],
                    0.08159495145082474,
                    [-0.8399999737739563, 0.4318996071815491],
                ),
                ([0.7900000810623169, 0.17999997735023499, 0.62], 0.3414836823940277, [0.0, -0.6181877851486206]),
                ([0.1, 0.2, 0.3], 0.18594980239868164, [0.0, 0.0]),
            ],
        );
        let b = bitmap(FilterType::Bilinear, WrapMode::Clamp, Affine2::IDENTITY);
        check(
            &b,
            &[
                ([0.1, 0.2, 0.3], 0.18594980239868164, [0.0, 0.0]),
                ([0.4, 0.5, 0.6], 0.4859498143196106, [1.1999998092651367, -0.5718996524810791]),
                (
                    [0.8300000429153442, 0.10999998450279236, 0.2900000214576721],
                    0.2761135399341583,
                    [0.33828240633010864, 0.0],
                ),
                ([0.0, 0.0, 0.0], 0.0, [0.0, 0.0]),
                ([1.0, 0.0, 0.5], 0.24875549972057343, [0.0, 0.0]),
                ([0.1, 0.2, 0.3], 0.18594980239868164, [0.0, 0.0]),
            ],
        );
    }

    // to_uv = mi.ScalarTransform4f().translate([0.25, 0.5, 0]).scale([2, 3, 1])
    #[test]
    fn to_uv_transform_and_gradient_chain_rule_match_mitsuba() {
        let to_uv = Affine2::from_mat2_translation(Mat2::from_diagonal(Vec2::new(2.0, 3.0)), Vec2::new(0.25, 0.5));
        let b = bitmap(FilterType::Bilinear, WrapMode::Repeat, to_uv);
        let expect = [
            (
                (0.1, 0.2),
                [0.4659999907016754, 0.46400001645088196, 0.5519999861717224],
                [1.8829692602157593, 2.1034717559814453],
            ),
            (
                (0.375, 0.25),
                [0.550000011920929, 0.10000000149011612, 0.4000000059604645],
                [-0.5024455785751343, 0.369432270526886],
            ),
            (
                (0.6, 0.9),
                [0.48200005292892456, 0.547999918460846, 0.6439998745918274],
                [2.2276554107666016, 2.1034719944000244],
            ),
        ];
        for ((u, v), rgb, g) in expect {
            let uv = Vec2::new(u, v);
            assert!((b.eval(uv) - Vec3::from_array(rgb)).abs().max_element() < 1e-5, "({u},{v}): {}", b.eval(uv));
            let grad = b.eval_1_grad(uv).1;
            assert!((grad - Vec2::from_array(g)).abs().max_element() < 1e-4, "({u},{v}): {grad}");
        }
    }

    #[test]
    fn tiny_images_are_padded_and_non_finite_texels_rejected() {
        let b = Bitmap::new(1, 1, vec![Vec3::splat(0.25)], FilterType::Bilinear, WrapMode::Repeat, Affine2::IDENTITY)
            .unwrap();
        assert_eq!(b.resolution(), (2, 2));
        assert!((b.eval(Vec2::new(0.3, 0.9)) - Vec3::splat(0.25)).abs().max_element() < 1e-6);
        let mut data = image();
        data[5].y = f32::NAN;
        let err = Bitmap::new(4, 2, data, FilterType::Bilinear, WrapMode::Repeat, Affine2::IDENTITY).unwrap_err();
        assert!(err.contains("(1, 1)") && err.contains("not finite"), "{err}");
    }
}
