//! The GPU's own layout of a static VPL ([`GpuVpl`], `Vpl` in
//! [`VPL_WGSL`]): what shading reads, independent of how an asset file
//! stores VPLs. The runtime fills it from the asset's records; the two
//! layouts happen to have the same size today, but nothing ties them.

use glam::Vec3;

/// [`GpuVpl::map`] of a VPL without a baked hemisphere map.
pub const NO_MAP: u32 = u32::MAX;

/// One static VPL, or one node of its near-field tree, as shading reads it
/// (`Vpl` in [`VPL_WGSL`]; 48 bytes, std430).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, bytemuck::Pod, bytemuck::Zeroable)]
pub struct GpuVpl {
    /// Where it emits from: a VPL's map origin
    /// ([`crate::hemisphere::vpl_origin`]), a node's centroid.
    pub position: [f32; 3],
    /// Area its texels cover (world units²).
    pub area: f32,
    /// Unit normal.
    pub normal: [f32; 3],
    /// A level-3 near-field node: its RSM texels (0: an empty node). A
    /// static VPL's own record: its far-field lobe coherence in fixed
    /// point ([`LOBE_ONE`] = 1, [`lobe_fixed`]), which shading reads where
    /// it draws the VPL as one disk; a level-1 or level-2 node's: its own
    /// ([`gibake_asset::node_lobe_coherence`]), at least 1 (0: an empty
    /// node). No pass needs those records' texel counts, and a fifth
    /// storage buffer would refuse downlevel devices.
    pub texels: u32,
    /// Flux (W, linear RGB).
    pub flux: [f32; 3],
    /// Tile of its baked map in the map atlas, or [`NO_MAP`].
    pub map: u32,
}

/// Fixed-point one of a static VPL's far-field lobe coherence in
/// [`GpuVpl::texels`] (`LOBE_ONE` in [`VPL_WGSL`], the same number).
pub const LOBE_ONE: f32 = 16_777_216.0;

/// A lobe coherence `c ∈ [0, 1]` in fixed point (anything else clamped;
/// NaN: 1, one cosine lobe).
pub fn lobe_fixed(c: f32) -> u32 {
    let c = if c.is_nan() { 1.0 } else { c.clamp(0.0, 1.0) };
    (c * LOBE_ONE).round() as u32
}

impl GpuVpl {
    /// The emission point.
    pub fn position(&self) -> Vec3 {
        Vec3::from_array(self.position)
    }

    /// The normal.
    pub fn normal(&self) -> Vec3 {
        Vec3::from_array(self.normal)
    }
}

/// WGSL of [`GpuVpl`].
pub const VPL_WGSL: &str = "\
struct Vpl {              // gibake_gpu::vpl::GpuVpl (48 bytes)
    position: vec3<f32>,  // emission point: a VPL's map origin, a node's centroid
    area: f32,
    normal: vec3<f32>,
    texels: u32,          // a node's texels; a VPL's own record: lobe coherence × LOBE_ONE
    flux: vec3<f32>,
    map: u32,             // baked map tile or 0xffffffff
}
const LOBE_ONE: f32 = 16777216.0;   // gibake_gpu::vpl::LOBE_ONE
";

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn lobe_fixed_point_round_trips_and_clamps() {
        assert!(VPL_WGSL.contains(&format!("const LOBE_ONE: f32 = {}.0;", LOBE_ONE as u32)));
        for c in [0.0f32, 0.25, std::f32::consts::FRAC_1_SQRT_2, 1.0] {
            assert!((lobe_fixed(c) as f32 / LOBE_ONE - c).abs() < 1e-7);
        }
        assert_eq!(lobe_fixed(2.0), lobe_fixed(1.0));
        assert_eq!(lobe_fixed(-1.0), 0);
        assert_eq!(lobe_fixed(f32::NAN), lobe_fixed(1.0));
    }

    /// The WGSL struct's layout (from naga) is the Rust struct's.
    #[test]
    fn wgsl_layout_matches_rust() {
        let src = format!(
            "{VPL_WGSL}\n@group(0) @binding(0) var<storage, read> v: array<Vpl>;\n\
             @compute @workgroup_size(1) fn main() {{ _ = v[0].map; }}"
        );
        let module = crate::shaders::validate(&src).expect("valid WGSL");
        let (_, ty) = module
            .types
            .iter()
            .find(|(_, t)| t.name.as_deref() == Some("Vpl"))
            .expect("struct Vpl");
        let naga::TypeInner::Struct { members, span } = &ty.inner else {
            panic!("Vpl is not a struct");
        };
        assert_eq!(*span as usize, std::mem::size_of::<GpuVpl>());
        let rust = [
            ("position", std::mem::offset_of!(GpuVpl, position)),
            ("area", std::mem::offset_of!(GpuVpl, area)),
            ("normal", std::mem::offset_of!(GpuVpl, normal)),
            ("texels", std::mem::offset_of!(GpuVpl, texels)),
            ("flux", std::mem::offset_of!(GpuVpl, flux)),
            ("map", std::mem::offset_of!(GpuVpl, map)),
        ];
        let wgsl: Vec<_> = members
            .iter()
            .map(|m| (m.name.clone().unwrap_or_default(), m.offset as usize))
            .collect();
        let rust: Vec<_> = rust.iter().map(|(n, o)| (n.to_string(), *o)).collect();
        assert_eq!(wgsl, rust);
    }
}
