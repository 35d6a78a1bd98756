//! Mitsuba `sunsky` and `timed_sunsky`: the Hosek–Wilkie sky (2012) and sun
//! (2013) at infinity, as Mitsuba 3.9.1's RGB variants compute them
//! (`include/mitsuba/render/sunsky.h`, `src/emitters/sunsky.cpp`,
//! `src/emitters/timed_sunsky.cpp`).
//!
//! | parameter            | type      | default (`sunsky`)                  |
//! |----------------------|-----------|-------------------------------------|
//! | turbidity            | float     | 3, in [1, 10]                       |
//! | albedo               | colour    | 0.3, each channel in [0, 1]         |
//! | sun_direction        | vector    | — (or the date, time and place)     |
//! | latitude / longitude | float     | 35.6894 / 139.6917 (Tokyo)          |
//! | timezone             | float     | 9                                   |
//! | year / month / day   | integer   | 2010 / 7 / 10                       |
//! | hour / minute / second | float   | 15 / 0 / 0                          |
//! | sun_scale, sky_scale | float     | 1, 1                                |
//! | sun_aperture         | float     | 0.5358 (degrees, full angle)        |
//! | complex_sun          | boolean   | false                               |
//! | to_world             | transform | identity (local +z up, +x north)    |
//!
//! `timed_sunsky` replaces the instant by a range of days (`start_year`
//! 2025, `start_month` 1, `start_day` 1, `end_*` a year later), a daily
//! window (`window_start_time` 7, `window_end_time` 19) and the shutter
//! interval that maps a ray's time to a day and hour (`shutter_open` 0,
//! `shutter_close` 1). Penumbra renders one instant (the sensor's
//! `shutter_open`), so a `timed_sunsky` is the sky of that instant; its
//! tables are interpolated as `timed_sunsky` does (1-D textures over the
//! sun's elevation), which differs slightly from `sunsky`'s.
//!
//! Model, per RGB channel (the `_rgb` tables of `sunsky_datasets.bin`,
//! interpolated linearly on turbidity and albedo, then by a quintic Bézier
//! in x = ∛(2η/π) on the sun's elevation η, Hosek & Wilkie 2012 §5):
//!
//! ```text
//! L_sky = (1 + A exp(B / (cos θ + 0.01))) · (C + D exp(E γ) + F cos²γ + G χ(H, γ) + I √cos θ) · L_M
//! χ(H, γ) = (1 + cos²γ) / (1 + H² − 2 H cos γ)^(3/2)
//! ```
//! (Hosek & Wilkie 2012, eq. 9), θ the view zenith angle and γ the angle to
//! the sun. The sun (inside the cone of half-angle `sun_aperture / 2`) is
//! the tabulated irradiance (`sampling_data.bin`) over the solid angle of
//! the real sun, converted to sRGB, or with `complex_sun` the piecewise
//! polynomial in elevation and cos ψ with limb darkening baked in (Hosek &
//! Wilkie 2013). Both are rescaled by the area ratio of the real sun's cone
//! to the given one. The result times Mitsuba's CIE Y normalisation; zero
//! below the horizon and when the sun is below it.
//!
//! Sampling (as Mitsuba): the sky with probability w (the sky's share of
//! the luminance of sky + sun irradiance), else the sun's cone uniformly.
//! The sky in (cos θ, φ − φ_sun) is a mixture of a warp towards the horizon
//! (cos θ = a u / √(1 + u²(a² − 1))) and a truncated 2-D Gaussian, with
//! the mixture's parameters tabulated per elevation and turbidity.

use super::LightSample;
use crate::bsdf::microfacet::{erf, erfinv};
use crate::math::{luminance, safe_sqrt, Frame, Mat3, Spectrum, INV_2PI, PI};
use crate::sampling::warp;
use glam::{Vec2, Vec3};

/// Wavelengths (nm) of the spectral tables.
pub const WAVELENGTHS: [f32; 11] = [320., 360., 400., 440., 480., 520., 560., 600., 640., 680., 720.];
const TURBIDITY_LVLS: usize = 10;
const SKY_CTRL_PTS: usize = 6;
const SKY_PARAMS: usize = 9;
const SUN_SEGMENTS: usize = 45;
const SUN_CTRL_PTS: usize = 4;
const SUN_LD_PARAMS: usize = 6;
/// Sun elevations of the irradiance and sampling tables.
const ELEVATIONS: usize = 30;
const MPDF_CHANNELS: usize = 5;
/// Half-angle of the real sun's cone (radians), in f32 as Mitsuba uses it.
const SUN_HALF_APERTURE: f32 = (std::f64::consts::PI * (0.5 * 0.5358) / 180.0) as f32;
/// Mitsuba's spectral-to-RGB factor of the sun's radiance.
const SPEC_TO_RGB_SUN_CONV: f32 = 467.069_28;
const CIE_Y_NORMALIZATION: f32 = (1.0 / 106.750_259_399_414_06) as f32;
const MIN_SAMPLING_ETA: f32 = 2.0 * PI / 180.0;
const MAX_SAMPLING_ETA: f32 = 88.0 * PI / 180.0;

/// The model's tables, as Mitsuba reads them (cast to f32), row-major.
#[derive(Debug, Clone)]
pub struct SunskyTables {
    /// `sky_params_rgb`: turbidity (10) × albedo (2) × control point (6) × channel (3) × parameter (9).
    pub sky_params: Vec<f32>,
    /// `sky_rad_rgb`: turbidity × albedo × control point × channel.
    pub sky_rad: Vec<f32>,
    /// `sun_rad_rgb`: turbidity × segment (45) × channel × power of x (4) × power of cos ψ (6).
    pub sun_rad: Vec<f32>,
    /// `sun_irradiance`: turbidity × elevation (30) × wavelength (11).
    pub sun_irradiance: Vec<f32>,
    /// `sky_irradiance`: turbidity × elevation × wavelength.
    pub sky_irradiance: Vec<f32>,
    /// `weights`: elevation × turbidity × mixture parameter (5).
    pub sampling_weights: Vec<f32>,
    /// CIE 1931 x̄, ȳ, z̄ at [`WAVELENGTHS`] (zero outside 360–830 nm).
    pub cie_xyz: [[f32; 3]; 11],
}

impl SunskyTables {
    /// (file, field, shape) of every table.
    pub const FIELDS: [(&'static str, &'static str, &'static [usize]); 6] = [
        ("sunsky_datasets.bin", "sky_params_rgb", &[10, 2, 6, 3, 9]),
        ("sunsky_datasets.bin", "sky_rad_rgb", &[10, 2, 6, 3]),
        ("sunsky_datasets.bin", "sun_rad_rgb", &[10, 45, 3, 4, 6]),
        ("sampling_data.bin", "sun_irradiance", &[10, 30, 11]),
        ("sampling_data.bin", "sky_irradiance", &[10, 30, 11]),
        ("sampling_data.bin", "weights", &[30, 10, 5]),
    ];
}

/// Parameters common to both plugins.
#[derive(Debug, Clone, Copy)]
pub struct SunskyParams {
    /// Atmospheric turbidity, [1, 10].
    pub turbidity: f32,
    /// Ground albedo per channel, [0, 1].
    pub albedo: [f32; 3],
    /// Factor on the sun's radiance.
    pub sun_scale: f32,
    /// Factor on the sky's radiance.
    pub sky_scale: f32,
    /// Full angle, degrees.
    pub sun_aperture: f32,
    /// The sun with limb darkening (Hosek & Wilkie 2013) instead of its mean radiance.
    pub complex_sun: bool,
    /// Linear part of `to_world` (a rotation).
    pub world_from_light: Mat3,
}

/// A date and local time (Mitsuba's `DateTimeRecord`).
#[derive(Debug, Clone, Copy)]
pub struct DateTime {
    /// Year.
    pub year: i32,
    /// Month, 1–12.
    pub month: i32,
    /// Day of the month (later days roll over into the next months).
    pub day: i32,
    /// Local hour.
    pub hour: f32,
    /// Minute.
    pub minute: f32,
    /// Second.
    pub second: f32,
}

/// A place (Mitsuba's `LocationRecord`), degrees and hours.
#[derive(Debug, Clone, Copy)]
pub struct Location {
    /// Latitude, degrees north.
    pub latitude: f32,
    /// Longitude, degrees east.
    pub longitude: f32,
    /// Offset of local time from UT, hours.
    pub timezone: f32,
}

impl DateTime {
    /// Days since JD 2451545.0 (noon, 1 January 2000 UT), in f32 as Mitsuba.
    fn elapsed_julian_days(&self, timezone: f32) -> f32 {
        let dec_hours = self.hour - timezone + (self.minute + self.second / 60.0) / 60.0;
        let (y, m, d) = (self.year, self.month, self.day);
        let aux1 = (m - 14) / 12;
        let aux2 =
            (1461 * (y + 4800 + aux1)) / 4 + (367 * (m - 2 - 12 * aux1)) / 12 - (3 * ((y + 4900 + aux1) / 100)) / 4 + d
                - 32075;
        let jd = aux2 as f32 - 0.5 + dec_hours / 24.0;
        jd - 2451545.0
    }
}

/// The sun's zenith angle θ and azimuth φ (radians, local frame: +z up, +x
/// north) seen from `loc` at `t`: Blanco-Muriel et al., "Computing the
/// Solar Vector" (Solar Energy 70(5), 2001), in f32 as Mitsuba.
pub fn sun_coordinates(t: &DateTime, loc: &Location) -> (f32, f32) {
    let dec_hours = t.hour - loc.timezone + (t.minute + t.second / 60.0) / 60.0;
    let n = t.elapsed_julian_days(loc.timezone);
    // Ecliptic coordinates.
    let omega = 2.1429f32 - 0.001_039_459_4 * n;
    let mean_longitude = 4.895_063f32 + 0.017_202_792 * n;
    let anomaly = 6.240_06f32 + 0.017_201_97 * n;
    let ecl_longitude = mean_longitude + 0.033_416_07 * anomaly.sin() + 0.000_348_94 * (2.0 * anomaly).sin()
        - 0.000_113_4
        - 0.000_020_3 * omega.sin();
    let ecl_obliquity = 0.409_092_8f32 - 6.2140e-9 * n + 0.000_039_6 * omega.cos();
    // Celestial coordinates.
    let sin_ecl = ecl_longitude.sin();
    let mut ra = (ecl_obliquity.cos() * sin_ecl).atan2(ecl_longitude.cos());
    if ra < 0.0 {
        ra += 2.0 * PI;
    }
    let declination = (ecl_obliquity.sin() * sin_ecl).asin();
    // Local coordinates.
    let gmst = 6.697_424_3f32 + 0.065_709_83 * n + dec_hours;
    let lmst = (gmst * 15.0 + loc.longitude).to_radians();
    let lat = loc.latitude.to_radians();
    let (sin_lat, cos_lat) = lat.sin_cos();
    let hour_angle = lmst - ra;
    let cos_ha = hour_angle.cos();
    let mut zenith = (cos_lat * cos_ha * declination.cos() + declination.sin() * sin_lat).acos();
    let mut azimuth = (-hour_angle.sin()).atan2(declination.tan() * cos_lat - sin_lat * cos_ha);
    if azimuth < 0.0 {
        azimuth += 2.0 * PI;
    }
    // Parallax.
    zenith += (6371.01f64 / 149_597_890.0) as f32 * zenith.sin();
    (zenith, azimuth - PI)
}

/// `timed_sunsky`'s day range, daily window and shutter interval.
#[derive(Debug, Clone, Copy)]
pub struct TimedRange {
    /// Where.
    pub location: Location,
    /// Start date (the hours of both dates are ignored).
    pub start: DateTime,
    /// End date.
    pub end: DateTime,
    /// First hour of each day's window.
    pub window_start: f32,
    /// Last hour of each day's window.
    pub window_end: f32,
    /// Time mapped to the start of the range.
    pub shutter_open: f32,
    /// Time mapped to its end.
    pub shutter_close: f32,
}

impl TimedRange {
    /// Whole days between the start and end dates, at least 1 (Mitsuba's
    /// `get_days_between`, at midnight of each date); None when the end
    /// comes first.
    pub fn days(&self) -> Option<i32> {
        let at_midnight = |d: &DateTime| DateTime { hour: 0.0, minute: 0.0, second: 0.0, ..*d };
        let s = at_midnight(&self.start).elapsed_julian_days(self.location.timezone);
        let e = at_midnight(&self.end).elapsed_julian_days(self.location.timezone);
        (s <= e).then(|| ((e - s).floor() as i32).max(1))
    }

    /// The sun's (θ, φ) at ray time `time`: the shutter interval spans the
    /// days, each day the window from `window_start` to `window_end` hours.
    pub fn sun_angles(&self, time: f32) -> (f32, f32) {
        let days = self.days().unwrap_or(1);
        let t = (time - self.shutter_open) * (1.0 / (self.shutter_close - self.shutter_open));
        let day = t * (days as f32 - f32::EPSILON / 2.0).max(0.0);
        let int_day = day.floor() as i32;
        let dt = DateTime {
            year: self.start.year,
            month: self.start.month,
            day: self.start.day + int_day,
            hour: self.window_start + (self.window_end - self.window_start) * (day - int_day as f32),
            minute: 0.0,
            second: 0.0,
        };
        sun_coordinates(&dt, &self.location)
    }
}

/// Direction of spherical angles (θ, φ): (sin θ cos φ, sin θ sin φ, cos θ).
pub fn sph_to_dir(theta: f32, phi: f32) -> Vec3 {
    let (st, ct) = theta.sin_cos();
    let (sp, cp) = phi.sin_cos();
    Vec3::new(cp * st, sp * st, ct)
}

/// (θ, φ) of a unit direction (Dr.Jit's `unit_angle_z`, `atan2`).
pub fn dir_to_sph(d: Vec3) -> (f32, f32) {
    (unit_angle(Vec3::Z, d), d.y.atan2(d.x))
}

/// The angle between unit vectors, accurate near 0 and π (Dr.Jit's `unit_angle`).
fn unit_angle(a: Vec3, b: Vec3) -> f32 {
    let dot = a.dot(b);
    if dot >= 0.0 {
        2.0 * (0.5 * (a - b).length()).min(1.0).asin()
    } else {
        PI - 2.0 * (0.5 * (a + b).length()).min(1.0).asin()
    }
}

/// Dr.Jit's `take_interp` along the first axis of a table of `n` slices of
/// `len` values: linear in `pos`, extrapolated outside [0, n − 1].
fn take_interp(data: &[f32], n: usize, pos: f32) -> Vec<f32> {
    let len = data.len() / n;
    let i0 = (pos.floor().max(0.0) as usize).min(n - 2);
    let w = pos - i0 as f32;
    let (a, b) = (&data[i0 * len..(i0 + 1) * len], &data[(i0 + 1) * len..(i0 + 2) * len]);
    a.iter().zip(b).map(|(&a, &b)| (1.0 - w) * a + w * b).collect()
}

/// A 1-D linear, clamped Dr.Jit texture of `n` texels of `len` values at
/// coordinate `u` (texel i centred at (i + ½) / n).
fn texture_1d(data: &[f32], n: usize, u: f32) -> Vec<f32> {
    let len = data.len() / n;
    let pos = u * n as f32 - 0.5;
    let f = pos.floor();
    let w = pos - f;
    let idx = |i: f32| (i.max(0.0) as usize).min(n - 1);
    let (i0, i1) = (idx(f), idx(f + 1.0));
    (0..len).map(|k| (1.0 - w) * data[i0 * len + k] + w * data[i1 * len + k]).collect()
}

/// Mitsuba's `bilinear_interp`: turbidity, then albedo per channel (the
/// channel of element e is (e / params) mod 3).
fn turbidity_albedo(data: &[f32], turbidity: f32, albedo: [f32; 3], params: usize) -> Vec<f32> {
    let t = take_interp(data, TURBIDITY_LVLS, turbidity - 1.0);
    let len = t.len() / 2;
    (0..len)
        .map(|e| {
            // Two albedo levels, 0 and 1: the position is the albedo itself.
            let w = albedo[(e / params) % 3];
            (1.0 - w) * t[e] + w * t[len + e]
        })
        .collect()
}

/// The quintic Bézier over the 6 control points (first axis) at elevation
/// η: Σ C(5,k) x^k (1 − x)^{5−k} P_k with x = min(∛(2η/π), 1 − ε).
fn bezier(data: &[f32], eta: f32) -> Vec<f32> {
    let len = data.len() / SKY_CTRL_PTS;
    let x = (2.0 / PI * eta).cbrt().min(1.0 - f32::EPSILON / 2.0);
    const COEFS: [f32; SKY_CTRL_PTS] = [1., 5., 10., 10., 5., 1.];
    let mut res = vec![0.0; len];
    for (k, c) in COEFS.iter().enumerate() {
        let b = c * x.powi(k as i32) * (1.0 - x).powi((SKY_CTRL_PTS - 1 - k) as i32);
        for (r, v) in res.iter_mut().zip(&data[k * len..(k + 1) * len]) {
            *r += b * v;
        }
    }
    res
}

/// Mean of ȳ · s over the 11 wavelengths (Mitsuba's spectral `luminance`).
fn spectral_luminance(s: &[f32], cie: &[[f32; 3]; 11]) -> f32 {
    s.iter().zip(cie).map(|(v, c)| c[1] * v).sum::<f32>() / 11.0
}

/// sRGB of a spectrum at the 11 wavelengths, without Mitsuba's CIE Y
/// normalisation (`spectrum_to_srgb(s) / MI_CIE_Y_NORMALIZATION`).
fn spectral_srgb(s: &[f32], cie: &[[f32; 3]; 11]) -> [f32; 3] {
    let mut xyz = [0.0f32; 3];
    for (v, c) in s.iter().zip(cie) {
        for k in 0..3 {
            xyz[k] += c[k] * v;
        }
    }
    let xyz = xyz.map(|x| x / 11.0);
    // Mitsuba's `xyz_to_srgb`, digits as it writes them.
    #[allow(clippy::excessive_precision)]
    const M: [[f32; 3]; 3] =
        [[3.240479, -1.537150, -0.498535], [-0.969256, 1.875991, 0.041556], [0.055648, -0.204043, 1.057311]];
    M.map(|r| r[0] * xyz[0] + r[1] * xyz[1] + r[2] * xyz[2])
}

/// 1 − cos x in f32, as Mitsuba computes it.
fn one_minus_cos(x: f32) -> f32 {
    1.0 - x.cos()
}

/// Mitsuba's `sunsky` / `timed_sunsky` (model and sampling in the module docs).
#[derive(Debug, Clone)]
pub struct SunskyLight {
    world_from_light: Mat3,
    light_from_world: Mat3,
    /// Sun zenith angle and azimuth, local frame.
    sun_theta: f32,
    sun_phi: f32,
    sun_dir: Vec3,
    sky_scale: f32,
    sun_scale: f32,
    cos_half_aperture: f32,
    sin_half_aperture: f32,
    /// (1 − cos of the real sun's half-angle) / (1 − cos of the given one).
    area_ratio: f32,
    /// Uniform density on the sun's cone.
    sun_cone_pdf: f32,
    /// Per channel, the 9 parameters A..I and the mean radiance L_M.
    sky_params: [[f32; SKY_PARAMS]; 3],
    sky_rad: [f32; 3],
    /// The simple sun's radiance (irradiance over the real sun's solid angle), sRGB.
    sun_radiance: [f32; 3],
    /// `complex_sun`: `sun_rad_rgb` at the turbidity (segment × channel × x^k × cos^j ψ).
    complex_sun: Option<Vec<f32>>,
    /// Probability of sampling the sky.
    sky_weight: f32,
    /// Mixture weight of the Gaussian, horizon warp's a, Gaussian mean of
    /// cos θ, σ of cos θ and of φ.
    mpdf: [f32; MPDF_CHANNELS],
    /// Hemispherical integral of the radiance without the sun, and the sun's
    /// radiance × its solid angle: for the power.
    sky_integral: Spectrum,
    sun_integral: Spectrum,
}

impl SunskyLight {
    /// The parts both plugins share; `sun_theta`, `sun_phi` in the local frame.
    fn base(p: &SunskyParams, t: &SunskyTables, sun_theta: f32, sun_phi: f32) -> SunskyLight {
        let half = (0.5 * p.sun_aperture).to_radians();
        let complex_sun = p.complex_sun.then(|| take_interp(&t.sun_rad, TURBIDITY_LVLS, p.turbidity - 1.0));
        SunskyLight {
            world_from_light: p.world_from_light,
            light_from_world: p.world_from_light.inverse(),
            sun_theta,
            sun_phi,
            sun_dir: sph_to_dir(sun_theta, sun_phi),
            sky_scale: p.sky_scale,
            sun_scale: p.sun_scale,
            cos_half_aperture: half.cos(),
            sin_half_aperture: half.sin(),
            area_ratio: one_minus_cos(SUN_HALF_APERTURE) / one_minus_cos(half),
            sun_cone_pdf: INV_2PI / one_minus_cos(half),
            sky_params: [[0.0; SKY_PARAMS]; 3],
            sky_rad: [0.0; 3],
            sun_radiance: [0.0; 3],
            complex_sun,
            sky_weight: 0.0,
            mpdf: [0.0; MPDF_CHANNELS],
            sky_integral: Spectrum::ZERO,
            sun_integral: Spectrum::ZERO,
        }
    }

    fn set_sky(&mut self, p: &SunskyParams, t: &SunskyTables, eta: f32) {
        let params = bezier(&turbidity_albedo(&t.sky_params, p.turbidity, p.albedo, SKY_PARAMS), eta);
        let rad = bezier(&turbidity_albedo(&t.sky_rad, p.turbidity, p.albedo, 1), eta);
        for c in 0..3 {
            self.sky_params[c].copy_from_slice(&params[c * SKY_PARAMS..(c + 1) * SKY_PARAMS]);
            self.sky_rad[c] = rad[c];
        }
    }

    fn set_sun_irradiance(&mut self, irradiance_rgb: [f32; 3]) {
        let solid_angle = 2.0 * PI * one_minus_cos(SUN_HALF_APERTURE);
        self.sun_radiance = irradiance_rgb.map(|e| e / solid_angle);
    }

    /// Mitsuba's `sunsky` with the sun at local (θ, φ).
    pub fn sunsky(p: &SunskyParams, t: &SunskyTables, sun_theta: f32, sun_phi: f32) -> SunskyLight {
        let mut l = Self::base(p, t, sun_theta, sun_phi);
        let eta = 0.5 * PI - sun_theta;
        l.set_sky(p, t, eta);
        // Mixture parameters: elevation index 29 (η − 2°) / 86°, then turbidity.
        let eta_idx = (ELEVATIONS - 1) as f32
            * ((eta - MIN_SAMPLING_ETA) / (MAX_SAMPLING_ETA - MIN_SAMPLING_ETA)).clamp(0.0, 1.0);
        let w = take_interp(&t.sampling_weights, ELEVATIONS, eta_idx);
        let w = take_interp(&w, TURBIDITY_LVLS, (p.turbidity - 1.0).clamp(0.0, (TURBIDITY_LVLS - 1) as f32));
        l.mpdf.copy_from_slice(&w);
        // Irradiance tables: elevation index (η° − 2) / 3.
        let angle = ((eta.to_degrees() - 2.0) / 3.0).clamp(0.0, ELEVATIONS as f32 - (1.0 - f32::EPSILON / 2.0));
        let at = |table: &[f32]| take_interp(&take_interp(table, TURBIDITY_LVLS, p.turbidity - 1.0), ELEVATIONS, angle);
        let (sky_irr, sun_irr) = (at(&t.sky_irradiance), at(&t.sun_irradiance));
        let sky_lum = p.sky_scale * spectral_luminance(&sky_irr, &t.cie_xyz);
        let sun_lum = p.sun_scale * spectral_luminance(&sun_irr, &t.cie_xyz) * l.area_ratio;
        let w = sky_lum / (sky_lum + sun_lum);
        l.sky_weight = if w.is_nan() { 0.0 } else { w };
        l.set_sun_irradiance(spectral_srgb(&sun_irr, &t.cie_xyz));
        l.integrate();
        l
    }

    /// Mitsuba's `timed_sunsky` at the instant whose sun is at local (θ, φ).
    pub fn timed(p: &SunskyParams, t: &SunskyTables, sun_theta: f32, sun_phi: f32) -> SunskyLight {
        let mut l = Self::base(p, t, sun_theta, sun_phi);
        let eta = 0.5 * PI - sun_theta;
        if eta >= 0.0 {
            l.set_sky(p, t, eta);
        }
        let valid = sun_theta <= 0.5 * PI;
        // Mixture parameters: a texture over 30 elevations at (η − 2°) / 86°.
        let turb = (p.turbidity - 1.0).clamp(0.0, (TURBIDITY_LVLS - 1) as f32);
        let by_elevation: Vec<f32> = (0..ELEVATIONS)
            .flat_map(|e| {
                let row =
                    &t.sampling_weights[e * TURBIDITY_LVLS * MPDF_CHANNELS..(e + 1) * TURBIDITY_LVLS * MPDF_CHANNELS];
                take_interp(row, TURBIDITY_LVLS, turb)
            })
            .collect();
        if valid {
            let u = (eta - MIN_SAMPLING_ETA) / (MAX_SAMPLING_ETA - MIN_SAMPLING_ETA);
            l.mpdf.copy_from_slice(&texture_1d(&by_elevation, ELEVATIONS, u));
        }
        // Sky weight and sun irradiance: textures at ((η° − 2) / 3) / 30.
        let sky_irr = take_interp(&t.sky_irradiance, TURBIDITY_LVLS, p.turbidity - 1.0);
        let sun_irr = take_interp(&t.sun_irradiance, TURBIDITY_LVLS, p.turbidity - 1.0);
        let n = WAVELENGTHS.len();
        let mut weights = Vec::with_capacity(ELEVATIONS);
        let mut sun_rgb = Vec::with_capacity(3 * ELEVATIONS);
        for e in 0..ELEVATIONS {
            let (sky, sun) = (&sky_irr[e * n..(e + 1) * n], &sun_irr[e * n..(e + 1) * n]);
            let sky_lum = p.sky_scale * spectral_luminance(sky, &t.cie_xyz);
            let sun_lum = p.sun_scale * spectral_luminance(sun, &t.cie_xyz);
            let w = sky_lum / (sky_lum + sun_lum);
            weights.push(if w.is_finite() { w } else { 0.0 });
            sun_rgb.extend(spectral_srgb(sun, &t.cie_xyz));
        }
        let u = (eta.to_degrees() - 2.0) / 3.0 / ELEVATIONS as f32;
        let w = if valid { texture_1d(&weights, ELEVATIONS, u)[0] } else { 0.0 };
        l.sky_weight = if w == 0.0 { 1.0 } else { w };
        if valid {
            let rgb = texture_1d(&sun_rgb, ELEVATIONS, u);
            l.set_sun_irradiance([rgb[0], rgb[1], rgb[2]]);
        }
        l.integrate();
        l
    }

    /// The integrals behind [`Self::power`]: the sky by a midpoint rule in
    /// (cos θ, φ), the sun as its centre's radiance times its solid angle.
    fn integrate(&mut self) {
        let (nz, np) = (32, 64);
        let mut sky = Spectrum::ZERO;
        for i in 0..nz {
            for j in 0..np {
                let z = (i as f32 + 0.5) / nz as f32;
                let phi = (j as f32 + 0.5) / np as f32 * 2.0 * PI;
                let r = safe_sqrt(1.0 - z * z);
                let d = Vec3::new(r * phi.cos(), r * phi.sin(), z);
                sky += self.eval_local(d, false);
            }
        }
        self.sky_integral = sky * (2.0 * PI / (nz * np) as f32);
        self.sun_integral = (self.eval_local(self.sun_dir, true) - self.eval_local(self.sun_dir, false))
            * (2.0 * PI * (1.0 - self.cos_half_aperture));
    }

    /// Whether the sun is above the horizon (else the emitter is black).
    pub fn sun_up(&self) -> bool {
        self.sun_theta <= 0.5 * PI
    }

    /// The sun's direction in world space.
    pub fn sun_direction(&self) -> Vec3 {
        (self.world_from_light * self.sun_dir).normalize()
    }

    fn hit_sun(&self, d: Vec3) -> bool {
        self.sun_dir.dot(d) >= self.cos_half_aperture
    }

    /// Radiance from the local unit direction `d`, `hit` telling whether it
    /// is inside the sun's cone (Mitsuba's protected `eval`).
    fn eval_local(&self, d: Vec3, hit: bool) -> Spectrum {
        let cos_theta = d.z;
        if !(cos_theta >= 0.0 && self.sun_dir.z >= 0.0) {
            return Spectrum::ZERO;
        }
        let gamma = unit_angle(self.sun_dir, d);
        let mut res = Spectrum::ZERO;
        if self.sky_scale > 0.0 {
            let cos_gamma = gamma.cos();
            let cg2 = cos_gamma * cos_gamma;
            let mut sky = [0.0; 3];
            for (c, s) in sky.iter_mut().enumerate() {
                let [a, b, cc, dd, e, f, g, i, h] = self.sky_params[c]; // stored A..G, I, H
                                                                        // Hosek & Wilkie 2012, eq. 9.
                let c1 = 1.0 + a * (b / (cos_theta + 0.01)).exp();
                let chi = (1.0 + cg2) / (1.0 + h * h - 2.0 * h * cos_gamma).powf(1.5);
                let c2 = cc + dd * (e * gamma).exp() + f * cg2 + g * chi + i * safe_sqrt(cos_theta);
                *s = c1 * c2 * self.sky_rad[c];
            }
            res = self.sky_scale * Spectrum::from(sky);
        }
        if self.sun_scale > 0.0 && hit {
            let sun = match &self.complex_sun {
                None => Spectrum::from(self.sun_radiance),
                Some(table) => self.complex_sun_radiance(table, cos_theta, gamma),
            };
            res += self.sun_scale * sun * (self.area_ratio * SPEC_TO_RGB_SUN_CONV);
        }
        res * CIE_Y_NORMALIZATION
    }

    /// Hosek & Wilkie 2013's sun, RGB: Σ_k Σ_j x^k cos^j ψ c_{s,k,j} over the
    /// segment s of the view elevation e (breaks at π/2 (s/45)³, x = e − break),
    /// cos ψ = √(1 − sin²γ / sin²α) for the half-angle α.
    fn complex_sun_radiance(&self, table: &[f32], cos_theta: f32, gamma: f32) -> Spectrum {
        let elevation = 0.5 * PI - cos_theta.clamp(-1.0, 1.0).acos();
        let pos =
            (((2.0 * elevation / PI).cbrt() * SUN_SEGMENTS as f32).floor().max(0.0) as usize).min(SUN_SEGMENTS - 1);
        let break_x = 0.5 * PI * (pos as f32 / SUN_SEGMENTS as f32).powi(3);
        let x = elevation - break_x;
        let sin_gamma = gamma.sin();
        let cos_psi = safe_sqrt(1.0 - sin_gamma * sin_gamma / (self.sin_half_aperture * self.sin_half_aperture));
        let seg = &table[pos * 3 * SUN_CTRL_PTS * SUN_LD_PARAMS..(pos + 1) * 3 * SUN_CTRL_PTS * SUN_LD_PARAMS];
        let mut rgb = [0.0f32; 3];
        for (c, out) in rgb.iter_mut().enumerate() {
            let mut xk = 1.0;
            for k in 0..SUN_CTRL_PTS {
                let mut cj = 1.0;
                for j in 0..SUN_LD_PARAMS {
                    *out += xk * cj * seg[(c * SUN_CTRL_PTS + k) * SUN_LD_PARAMS + j];
                    cj *= cos_psi;
                }
                xk *= x;
            }
        }
        Spectrum::from(rgb)
    }

    fn to_local(&self, wi: Vec3) -> Vec3 {
        (self.light_from_world * wi).normalize()
    }

    /// Radiance arriving from world direction `wi`.
    pub fn eval(&self, wi: Vec3) -> Spectrum {
        let d = self.to_local(wi);
        self.eval_local(d, self.hit_sun(d))
    }

    /// `(eval(wi), pdf(wi))`.
    pub fn eval_pdf(&self, wi: Vec3) -> (Spectrum, f32) {
        let d = self.to_local(wi);
        let hit = self.hit_sun(d);
        (self.eval_local(d, hit), self.pdf_local(d, hit))
    }

    /// Solid-angle density with which `sample_li` produces `wi`.
    pub fn pdf(&self, wi: Vec3) -> f32 {
        let d = self.to_local(wi);
        self.pdf_local(d, self.hit_sun(d))
    }

    fn pdf_local(&self, d: Vec3, hit: bool) -> f32 {
        if !self.sun_up() || d.z < 0.0 {
            return 0.0;
        }
        let sky = self.sky_pdf(d);
        let sun = if hit { self.sun_cone_pdf } else { 0.0 };
        sun + self.sky_weight * (sky - sun)
    }

    /// The Gaussian's (cos θ, φ) mean, σ and the normalisation over
    /// [0, 1] × [−π, π]: Π (Φ(max) − Φ(min)) σ.
    fn gaussian(&self) -> (Vec2, Vec2, [f64; 2], [f64; 2]) {
        let mu = Vec2::new(self.mpdf[2], 0.0);
        let sigma = Vec2::new(self.mpdf[3], self.mpdf[4]);
        let cdf = |x: f32, m: f32, s: f32| 0.5 * (1.0 + erf(std::f64::consts::FRAC_1_SQRT_2 * ((x - m) / s) as f64));
        let min = [cdf(0.0, mu.x, sigma.x), cdf(-PI, mu.y, sigma.y)];
        let max = [cdf(1.0, mu.x, sigma.x), cdf(PI, mu.y, sigma.y)];
        (mu, sigma, min, max)
    }

    /// Mitsuba's `eval_sky_pdf` for a local direction with cos θ ≥ 0.
    fn sky_pdf(&self, d: Vec3) -> f32 {
        // cos θ in (0, 1]: at the exact horizon Mitsuba's cos(unit_angle_z(d))
        // rounds below 0 and its density is 0 there too.
        let c = d.z;
        if !(c > 0.0 && c <= 1.0) {
            return 0.0;
        }
        let phi = d.y.atan2(d.x);
        let mut p = phi - self.sun_phi;
        if p < -PI {
            p += 2.0 * PI;
        }
        if p > PI {
            p -= 2.0 * PI;
        }
        let a = self.mpdf[1];
        let warp = INV_2PI / (a * (1.0 + c * c * (1.0 / (a * a) - 1.0)).powf(1.5));
        let (mu, sigma, min, max) = self.gaussian();
        let norm = ((max[0] - min[0]) * (max[1] - min[1])) as f32 * sigma.x * sigma.y;
        let z = (Vec2::new(c, p) - mu) / sigma;
        let gauss = INV_2PI * (-0.5 * z.length_squared()).exp() / norm;
        warp + self.mpdf[0] * (gauss - warp)
    }

    /// Mitsuba's `sample_sky`: a local direction.
    fn sample_sky(&self, mut u: Vec2) -> Vec3 {
        let w0 = self.mpdf[0];
        let gaussian = u.x < w0;
        u.x = if gaussian { u.x / w0 } else { (u.x - w0) / (1.0 - w0) };
        let mut uv = if gaussian {
            let (mu, sigma, min, max) = self.gaussian();
            let s = [min[0] + (max[0] - min[0]) * u.x as f64, min[1] + (max[1] - min[1]) * u.y as f64];
            let s = s.map(|s| s.clamp(f32::EPSILON as f64 / 2.0, 1.0 - f32::EPSILON as f64 / 2.0));
            let g = s.map(|s| std::f64::consts::SQRT_2 * erfinv(2.0 * s - 1.0));
            Vec2::new(g[0] as f32 * sigma.x + mu.x, g[1] as f32 * sigma.y + mu.y)
        } else {
            // Towards the horizon: cos θ = a u / √(1 + u² (a² − 1)).
            let a = self.mpdf[1];
            let phi = (u.y - 0.5) * 2.0 * PI;
            let denom = 1.0 + u.x * u.x * (a * a - 1.0);
            Vec2::new(a * u.x / denom.sqrt(), phi)
        };
        uv.x = uv.x.max(0.0);
        uv.y += self.sun_phi;
        let (sp, cp) = uv.y.sin_cos();
        let st = safe_sqrt(1.0 - uv.x * uv.x);
        Vec3::new(st * cp, st * sp, uv.x)
    }

    /// Samples the sky or the sun (see the module docs); None when the sun
    /// is below the horizon or the sample falls below it.
    #[allow(clippy::neg_cmp_op_on_partial_ord)] // `!(x > y)` is also true for NaN, on purpose
    pub fn sample_li(&self, u: Vec2) -> Option<LightSample> {
        if !self.sun_up() {
            return None;
        }
        let w = self.sky_weight;
        let pick_sky = u.x < w;
        let d = if pick_sky {
            self.sample_sky(Vec2::new(u.x / w, u.y))
        } else {
            let local = cone_mitsuba(Vec2::new((u.x - w) / (1.0 - w), u.y), self.cos_half_aperture);
            Frame::from_normal(self.sun_dir).to_world(local)
        };
        if d.z < 0.0 {
            return None;
        }
        let hit = !pick_sky || self.hit_sun(d);
        let pdf = self.pdf_local(d, hit);
        if !(pdf > 0.0) {
            return None;
        }
        let li = self.eval_local(d, hit);
        let wi = (self.world_from_light * d).normalize();
        Some(LightSample { wi, dist: f32::INFINITY, pdf, li, delta: false })
    }

    /// Flux through the scene's bounding disk: π r² (∫ L_sky dω + L_sun Ω_sun).
    pub fn power(&self, scene_radius: f32) -> Spectrum {
        PI * scene_radius * scene_radius * (self.sky_integral + self.sun_integral)
    }

    /// Luminance share of the sun in [`Self::power`] (for tests).
    pub fn sun_share(&self) -> f32 {
        luminance(self.sun_integral) / luminance(self.sky_integral + self.sun_integral)
    }
}

/// Mitsuba's `square_to_uniform_cone` (the concentric-disk form).
fn cone_mitsuba(u: Vec2, cos_cutoff: f32) -> Vec3 {
    let one_minus = 1.0 - cos_cutoff;
    let p = warp::sample_concentric_disk(u);
    let pn = p.length_squared();
    let z = cos_cutoff + one_minus * (1.0 - pn);
    let p = p * safe_sqrt(one_minus * (2.0 - one_minus * pn));
    Vec3::new(p.x, p.y, z)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::testing::chi2::{alpha, chi2_test};

    /// A sunsky with the sampling state given directly (the sky's radiance
    /// parameters play no part in sampling): sun at local (θ, φ), full
    /// aperture in degrees, sky-sampling probability, mixture parameters.
    fn synthetic(theta: f32, phi: f32, aperture: f32, sky_weight: f32, mpdf: [f32; 5], to_world: Mat3) -> SunskyLight {
        let half = (0.5 * aperture).to_radians();
        SunskyLight {
            world_from_light: to_world,
            light_from_world: to_world.inverse(),
            sun_theta: theta,
            sun_phi: phi,
            sun_dir: sph_to_dir(theta, phi),
            sky_scale: 1.0,
            sun_scale: 1.0,
            cos_half_aperture: half.cos(),
            sin_half_aperture: half.sin(),
            area_ratio: one_minus_cos(SUN_HALF_APERTURE) / one_minus_cos(half),
            sun_cone_pdf: INV_2PI / one_minus_cos(half),
            sky_params: [[0.5, -0.2, 1.0, 2.0, -3.0, 0.8, 0.1, 0.6, 0.7]; 3],
            sky_rad: [1.0, 2.0, 3.0],
            sun_radiance: [1e3, 9e2, 8e2],
            complex_sun: None,
            sky_weight,
            mpdf,
            sky_integral: Spectrum::ZERO,
            sun_integral: Spectrum::ZERO,
        }
    }

    /// Mixture parameters of the tables (turbidity 8 at the 5th elevation;
    /// turbidity 8 at the 15th): a narrow Gaussian near the horizon, a wide one higher up.
    const LOW: [f32; 5] = [0.48, 0.661, 0.143, 0.2606, 0.3221];
    const HIGH: [f32; 5] = [0.345, 0.651, 0.577, 0.2717, 0.4285];

    fn rotation() -> Mat3 {
        Mat3::from_rotation_x(-0.5 * PI) * Mat3::from_rotation_z(0.4)
    }

    #[test]
    fn sampling_matches_pdf_chi_square() {
        // The sun's cone widened to 20° so that the harness's cells resolve it.
        let cases = [
            ("sky only, low sun", synthetic(1.45, 0.3, 0.5358, 1.0, LOW, Mat3::IDENTITY)),
            ("sky only, high sun, phi wrapping", synthetic(0.5, 3.0, 0.5358, 1.0, HIGH, Mat3::IDENTITY)),
            ("sky and a 20 degree sun, rotated", synthetic(0.9, -2.0, 20.0, 0.4, HIGH, rotation())),
        ];
        let a = alpha(cases.len() + 1);
        for (k, (name, light)) in cases.iter().enumerate() {
            let p = chi2_test(400_000, 70 + k as u64, |_, u| light.sample_li(u).map(|s| s.wi), |w| light.pdf(w) as f64);
            eprintln!("sunsky chi-square, {name}: p = {p}");
            assert!(p > a, "{name}: p = {p}");
        }
        // The test has power: the Gaussian's density without its truncation
        // to cos θ ∈ [0, 1] (Φ((1 − μ)/σ) − Φ(−μ/σ) ≈ 0.71 here) is rejected.
        let light = synthetic(1.45, 0.3, 0.5358, 1.0, LOW, Mat3::IDENTITY);
        let untruncated = |w: Vec3| {
            let (mu, sigma, min, max) = light.gaussian();
            let cut = (max[0] - min[0]) as f32;
            let c = w.z;
            if c <= 0.0 {
                return 0.0;
            }
            let mut p = w.y.atan2(w.x) - light.sun_phi;
            p -= 2.0 * PI * (p / (2.0 * PI)).round();
            let z = (Vec2::new(c, p) - mu) / sigma;
            let gauss = cut * INV_2PI * (-0.5 * z.length_squared()).exp()
                / ((max[0] - min[0]) as f32 * (max[1] - min[1]) as f32 * sigma.x * sigma.y);
            let a = light.mpdf[1];
            let warp = INV_2PI / (a * (1.0 + c * c * (1.0 / (a * a) - 1.0)).powf(1.5));
            (warp + light.mpdf[0] * (gauss - warp)) as f64
        };
        let p = chi2_test(400_000, 80, |_, u| light.sample_li(u).map(|s| s.wi), untruncated);
        eprintln!("sunsky chi-square, untruncated Gaussian: p = {p}");
        assert!(p < a, "a wrong pdf passed (p = {p})");
    }

    #[test]
    fn pdf_integrates_to_one_and_samples_carry_eval() {
        let light = synthetic(0.9, -2.0, 20.0, 0.4, HIGH, rotation());
        // Midpoint rule in (cos θ, φ) of the world sphere.
        let (nz, np) = (800, 1600);
        let mut sum = 0.0f64;
        for i in 0..nz {
            for j in 0..np {
                let z = -1.0 + 2.0 * (i as f64 + 0.5) / nz as f64;
                let phi = 2.0 * std::f64::consts::PI * (j as f64 + 0.5) / np as f64;
                let r = (1.0 - z * z).sqrt();
                sum += light.pdf(Vec3::new((r * phi.cos()) as f32, (r * phi.sin()) as f32, z as f32)) as f64;
            }
        }
        let integral = sum * 4.0 * std::f64::consts::PI / (nz * np) as f64;
        assert!((integral - 1.0).abs() < 2e-3, "∫ pdf = {integral}");
        for k in 0..256 {
            let u = Vec2::new((k % 16) as f32 + 0.5, (k / 16) as f32 + 0.5) / 16.0;
            let Some(s) = light.sample_li(u) else { continue };
            let (li, pdf) = light.eval_pdf(s.wi);
            assert!((pdf - s.pdf).abs() <= 1e-3 * s.pdf, "{u}: {pdf} vs {}", s.pdf);
            assert!((li - s.li).abs().max_element() <= 1e-3 * s.li.max_element(), "{u}: {li} vs {}", s.li);
        }
    }

    #[test]
    fn sun_below_the_horizon_is_black() {
        let light = synthetic(1.7, 0.0, 0.5358, 0.5, HIGH, Mat3::IDENTITY);
        assert!(light.sample_li(Vec2::splat(0.3)).is_none());
        assert_eq!(light.eval_pdf(Vec3::Z), (Spectrum::ZERO, 0.0));
    }

    #[test]
    fn julian_days_and_sun_position() {
        // 1 January 2000, 12:00 UT is JD 2451545.0.
        let t = DateTime { year: 2000, month: 1, day: 1, hour: 12.0, minute: 0.0, second: 0.0 };
        assert_eq!(t.elapsed_julian_days(0.0), 0.0);
        // Day overflow rolls into the next month, as Mitsuba's formula does.
        let a = DateTime { year: 2025, month: 1, day: 32, ..t };
        let b = DateTime { year: 2025, month: 2, day: 1, ..t };
        assert_eq!(a.elapsed_julian_days(1.0), b.elapsed_julian_days(1.0));
        // Equinox noon at the equator, Greenwich: the sun is near the zenith.
        let eq = DateTime { year: 2025, month: 3, day: 20, hour: 12.0, minute: 7.0, second: 0.0 };
        let (zenith, _) = sun_coordinates(&eq, &Location { latitude: 0.0, longitude: 0.0, timezone: 0.0 });
        assert!(zenith.to_degrees() < 1.0, "{}", zenith.to_degrees());
    }
}
