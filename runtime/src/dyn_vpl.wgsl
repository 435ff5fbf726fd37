// dyn_vpl.wgsl — one dynamic VPL slot: written by dynamic_vpl.wgsl, read
// by shade.wgsl.

struct DynVpl {           // must match GpuDynVpl in dynamic_vpl.rs
    position: vec4<f32>,  // xyz, w = area
    normal: vec4<f32>,    // xyz, w = 1 if the slot holds a VPL
    flux: vec4<f32>,      // rgb, w = far-field lobe coherence |Σw·n| / Σw
}
