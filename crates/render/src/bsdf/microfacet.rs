//! Microfacet distributions (Beckmann, GGX), anisotropic, with sampling of
//! visible normals. Placeholder API: implemented in the microfacet change.

/// Which normal distribution function.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum MicrofacetType {
    Beckmann,
    Ggx,
}

/// A microfacet distribution in the local shading frame (normal = +z);
/// `alpha_u` is the roughness along the frame's `s` axis, `alpha_v` along `t`.
#[derive(Debug, Clone, Copy)]
pub struct Microfacet {
    pub kind: MicrofacetType,
    pub alpha_u: f32,
    pub alpha_v: f32,
}
