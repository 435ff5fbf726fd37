// unpack_albedo.wgsl — the albedo of Bevy's deferred G-buffer
// (`Rgba32Uint`) as linear RGB for gibake's G-buffer rebuild. Bevy packs
// its base colour as `pack_unorm4x8_(vec4(pow(base_color, 1/2.2),
// perceptual_roughness))` in the first word (bevy_pbr
// `deferred/functions.wesl`) and decodes it with `pow(rgb, 2.2)`: the same
// here. An unlit material keeps its colour in the emissive word: no albedo
// (gibake adds no light to it); nor does a pixel no deferred material
// covered (the cleared G-buffer is zero).

@group(0) @binding(0) var gbuffer: texture_2d<u32>;
@group(0) @binding(1) var albedo: texture_storage_2d<rgba16float, write>;

@compute @workgroup_size(8, 8)
fn main(@builtin(global_invocation_id) id: vec3<u32>) {
    let size = textureDimensions(gbuffer);
    if (any(id.xy >= size)) {
        return;
    }
    let g = textureLoad(gbuffer, vec2<i32>(id.xy), 0);
    // Bevy's unpack_unorm4x8_: x in the low byte, as WGSL's builtin.
    let base = unpack4x8unorm(g.x);
    textureStore(albedo, vec2<i32>(id.xy), vec4<f32>(pow(base.rgb, vec3<f32>(2.2)), 1.0));
}
