// mesh.wgsl — vertex input and per-draw data of mesh passes.
// Must match GpuVertex and GpuDrawData in mesh.rs.

struct VertexIn {
    @location(0) position: vec3<f32>,
    @location(1) normal: vec3<f32>,
    @location(2) uv: vec2<f32>,
    @builtin(instance_index) draw: u32,
}

struct DrawData {
    model: mat4x4<f32>,
    normal_matrix: mat4x4<f32>,
    albedo: vec4<f32>,   // rgb baseColorFactor, w = 1 if textured
    extra: vec4<u32>,    // x base vertex, y first index, z triangle count
}
