// gbuffer_layout.wgsl — the lean camera G-buffer, 16 bytes a sample (needs
// common.wgsl): the one definition of how every pass that writes it
// (gbuffer.wgsl, gbuffer_depth.wgsl) or reads it (shade.wgsl,
// interleave.wgsl) stores and rebuilds a surface.
//   depth   `Depth32Float` (the G-buffer pass's own attachment, read as a
//           float) or an engine's depth (`Depth32Float`/`R32Float`); a
//           sample whose depth equals the view's far depth holds no surface
//   normals `Rg32Uint`: x pack2x16snorm(oct(shading normal)),
//           y pack2x16snorm(oct(geometric normal)), both facing the viewer
//   albedo  `R32Uint`: √albedo at 1625 levels a channel (gbuffer_pack_albedo;
//           8-bit sRGB, an Rgba8UnormSrgb target, was 0.6% off on lavapipe)
// The world position is rebuilt from the depth with the view's inverse
// view-projection (gbuffer_position), perspective or orthographic alike.

struct ViewParams {       // GpuViewParams in shade.rs
    size: vec2<u32>,
    interleave: u32,      // N: 1 shades every VPL at every pixel
    far_depth: f32,       // the depth of "no surface" (0: reversed Z, gibake's own)
    eye: vec4<f32>,       // camera position; w: pixel angle, or −pixel size (orthographic)
    inv_view_proj: mat4x4<f32>,   // clip → world of the camera the depth was drawn with
    later_half: u32,      // 1: the later bounces shaded at half resolution (shade.wgsl cs_later)
    pad0: u32,
    pad1: u32,
    pad2: u32,
}

// The world point seen at the centre of pixel px (row 0 at the top) of a
// size-pixel view at this depth (NDC z of the camera whose inverse
// view-projection is inv_view_proj).
fn gbuffer_position(inv_view_proj: mat4x4<f32>, size: vec2<u32>, px: vec2<i32>, depth: f32) -> vec3<f32> {
    let uv = (vec2<f32>(px) + vec2<f32>(0.5)) / vec2<f32>(size);
    let w = inv_view_proj * vec4<f32>(uv.x * 2.0 - 1.0, 1.0 - uv.y * 2.0, depth, 1.0);
    return w.xyz / w.w;
}

// Both unit normals in one Rg32Uint texel (16-bit snorm octahedral: about
// 3e-5 rad).
fn gbuffer_pack_normals(ns: vec3<f32>, ng: vec3<f32>) -> vec2<u32> {
    return vec2<u32>(pack2x16snorm(oct_encode(ns)), pack2x16snorm(oct_encode(ng)));
}

// Linear albedo in [0, 1] as √ rounded to 1625 levels a channel, the three
// digits of one base-1625 number (1625³ < 2³²): a relative step of
// 2/(√a·1624), at most ±0.09% at 0.5 and ±0.28% at 0.05 (the f16 pair
// before: ±0.05%; 8-bit sRGB: ±0.6%).
const ALBEDO_LEVELS: u32 = 1625u;

fn gbuffer_pack_albedo(albedo: vec3<f32>) -> u32 {
    let top = f32(ALBEDO_LEVELS - 1u);
    let s = sqrt(clamp(albedo, vec3<f32>(0.0), vec3<f32>(1.0)));
    let q = vec3<u32>(round(s * top));
    return q.x + ALBEDO_LEVELS * (q.y + ALBEDO_LEVELS * q.z);
}

fn gbuffer_albedo(packed: u32) -> vec3<f32> {
    let n = ALBEDO_LEVELS;
    let q = vec3<u32>(packed % n, (packed / n) % n, packed / (n * n));
    let s = vec3<f32>(q) / f32(n - 1u);
    return s * s;
}

// One unit normal of a texel of gbuffer_pack_normals (x: shading,
// y: geometric).
fn gbuffer_normal(packed: u32) -> vec3<f32> {
    return oct_decode(unpack2x16snorm(packed));
}
