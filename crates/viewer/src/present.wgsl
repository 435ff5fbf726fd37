// The viewer's present pass: the runtime's linear radiance (Rgba32Float,
// read with textureLoad: no filtering needed, and Rgba32Float is not
// filterable everywhere) scaled by the exposure, ACES-fitted and
// sRGB-encoded exactly as gibake-image's PNG previews are, drawn over the
// whole window (nearest texel when the sizes differ).

struct Params {
    exposure: f32,
    // 1: the target is a *Srgb format (the hardware encodes), 0: encode here.
    target_srgb: u32,
    target_size: vec2<u32>,
};

@group(0) @binding(0) var radiance: texture_2d<f32>;
@group(0) @binding(1) var<uniform> params: Params;

@vertex
fn vs(@builtin(vertex_index) i: u32) -> @builtin(position) vec4<f32> {
    // One triangle covering the screen.
    let uv = vec2<f32>(f32((i << 1u) & 2u), f32(i & 2u));
    return vec4<f32>(uv * 2.0 - 1.0, 0.0, 1.0);
}

fn aces(x: vec3<f32>) -> vec3<f32> {
    let v = max(x, vec3<f32>(0.0));
    return clamp((v * (2.51 * v + 0.03)) / (v * (2.43 * v + 0.59) + 0.14), vec3<f32>(0.0), vec3<f32>(1.0));
}

fn to_srgb(c: vec3<f32>) -> vec3<f32> {
    let lo = c * 12.92;
    let hi = 1.055 * pow(c, vec3<f32>(1.0 / 2.4)) - 0.055;
    return select(hi, lo, c <= vec3<f32>(0.0031308));
}

@fragment
fn fs(@builtin(position) p: vec4<f32>) -> @location(0) vec4<f32> {
    let src = textureDimensions(radiance);
    let dst = vec2<f32>(f32(params.target_size.x), f32(params.target_size.y));
    let xy = min(vec2<u32>(floor(p.xy * vec2<f32>(src) / dst)), src - vec2<u32>(1u));
    let c = aces(textureLoad(radiance, xy, 0).rgb * params.exposure);
    if params.target_srgb == 1u {
        return vec4<f32>(c, 1.0);
    }
    return vec4<f32>(to_srgb(c), 1.0);
}
