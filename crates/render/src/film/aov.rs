//! The AOV channels a film stores beside the beauty image: which kinds
//! exist, their EXR channel names, and one camera ray's values, packed in
//! the order of the film's layers. What each kind means and how it is
//! measured is [`crate::integrator::aov`]'s.

/// One kind of AOV and its channels.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum AovKind {
    /// Surface albedo (RGB).
    Albedo,
    /// Normal of the first hit (XYZ).
    Normal,
    /// Depth of the first hit (one channel).
    Depth,
    /// Position of the first hit (XYZ).
    Position,
}

impl AovKind {
    /// Every kind, in the film's channel order.
    pub const ALL: [AovKind; 4] = [AovKind::Albedo, AovKind::Normal, AovKind::Depth, AovKind::Position];

    /// The layer name in EXR output and on the command line.
    pub fn name(self) -> &'static str {
        match self {
            AovKind::Albedo => "albedo",
            AovKind::Normal => "normal",
            AovKind::Depth => "depth",
            AovKind::Position => "position",
        }
    }

    /// The kind named `s`, if any.
    pub fn from_name(s: &str) -> Option<AovKind> {
        AovKind::ALL.into_iter().find(|k| k.name() == s)
    }

    /// EXR channel suffixes (the layer is the name): `albedo.R`, `normal.X`, `depth.Z`.
    pub fn channels(self) -> &'static [&'static str] {
        match self {
            AovKind::Albedo => &["R", "G", "B"],
            AovKind::Normal | AovKind::Position => &["X", "Y", "Z"],
            AovKind::Depth => &["Z"],
        }
    }
}

/// The values of every AOV kind for one camera ray.
#[derive(Debug, Clone, Copy, Default)]
pub struct AovSample {
    /// Albedo of the first hit (RGB).
    pub albedo: [f32; 3],
    /// Normal of the first hit.
    pub normal: [f32; 3],
    /// Depth of the first hit.
    pub depth: f32,
    /// Position of the first hit.
    pub position: [f32; 3],
}

impl AovSample {
    /// Appends the values of `kinds` in order.
    #[inline]
    pub fn write(&self, kinds: &[AovKind], out: &mut [f32]) {
        let mut i = 0;
        for k in kinds {
            let v: &[f32] = match k {
                AovKind::Albedo => &self.albedo,
                AovKind::Normal => &self.normal,
                AovKind::Depth => std::slice::from_ref(&self.depth),
                AovKind::Position => &self.position,
            };
            out[i..i + v.len()].copy_from_slice(v);
            i += v.len();
        }
    }
}

/// Total channels of `kinds`.
pub fn channel_count(kinds: &[AovKind]) -> usize {
    kinds.iter().map(|k| k.channels().len()).sum()
}
