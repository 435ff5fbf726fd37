//! GPU foundation shared by gibake's baker and runtime.
//!
//! - [`GpuContext`]: a headless wgpu device on a deterministically chosen
//!   adapter, with its provenance ([`AdapterRecord`]).
//! - [`shaders`]: the shared WGSL (types, radiometry, projections) and how
//!   passes compose it.
//! - [`LightView`]: the primary light's projection (CPU twin of
//!   `projection.wgsl`), and [`light_fit`]: which part of a level a
//!   directional light's maps cover.
//! - [`readback`]: texture/buffer copies to the CPU.
//! - [`mesh`]: scene meshes uploaded as GPU buffers.
//! - [`vpl`]: the GPU's own layout of a static VPL ([`vpl::GpuVpl`]).

mod context;
pub mod hemisphere;
pub mod light_fit;
mod light_view;
pub mod mesh;
pub mod mips;
pub mod passes;
pub mod readback;
pub mod shaders;
pub mod util;
pub mod vpl;

pub use context::{AdapterRecord, GpuContext, GpuError, GpuOptions};
pub use light_view::{
    GpuLightView, GpuPrimaryLight, LightView, MAX_SPOT_HALF_ANGLE, look_to,
    orthographic_reversed_z, orthonormal_basis, perspective_reversed_z,
};
