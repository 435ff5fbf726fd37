// composite.wgsl — a view's radiance (Rgba32Float) written or added into
// the caller's render target: one full-screen triangle, one texel per pixel
// (the target has the view's size). Blending (replace or add) is the
// pipeline's.

@group(0) @binding(0) var radiance: texture_2d<f32>;

@vertex
fn vs_main(@builtin(vertex_index) i: u32) -> @builtin(position) vec4<f32> {
    let uv = vec2<f32>(f32((i << 1u) & 2u), f32(i & 2u));
    return vec4<f32>(uv * 2.0 - 1.0, 0.0, 1.0);
}

@fragment
fn fs_main(@builtin(position) p: vec4<f32>) -> @location(0) vec4<f32> {
    return vec4<f32>(textureLoad(radiance, vec2<i32>(p.xy), 0).rgb, 1.0);
}
