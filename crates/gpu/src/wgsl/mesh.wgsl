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
    alpha: vec4<f32>,    // x alphaCutoff, y baseColorFactor alpha, z = 1 if masked
    extra: vec4<u32>,    // x base vertex, y first index, z triangle count
}

// Varyings of passes that shade scene meshes (G-buffer, dynamic RSM).
struct MeshVarying {
    @builtin(position) clip: vec4<f32>,
    @location(0) world: vec3<f32>,
    @location(1) normal: vec3<f32>,
    @location(2) uv: vec2<f32>,
    @location(3) @interpolate(flat) draw: u32,
}

fn mesh_vertex(v: VertexIn, d: DrawData, view_proj: mat4x4<f32>) -> MeshVarying {
    let world = (d.model * vec4<f32>(v.position, 1.0)).xyz;
    var o: MeshVarying;
    o.clip = view_proj * vec4<f32>(world, 1.0);
    o.world = world;
    o.normal = (d.normal_matrix * vec4<f32>(v.normal, 0.0)).xyz;
    o.uv = v.uv;
    o.draw = v.draw;
    return o;
}

// baseColorFactor × baseColorTexture (the texel is sampled by the caller, in
// uniform control flow; it is used only if the draw is textured).
fn draw_albedo(d: DrawData, texel: vec3<f32>) -> vec3<f32> {
    if (d.albedo.w > 0.5) {
        return d.albedo.rgb * texel;
    }
    return d.albedo.rgb;
}

// The texel alpha the glTF alpha test reads, in every pass: the finest mip
// level, bilinear (albedo textures carry a mip chain for the camera's
// G-buffer; the holes stay those of the texture at every distance and
// every map sees the same ones).
fn mask_texel_alpha(t: texture_2d<f32>, s: sampler, uv: vec2<f32>) -> f32 {
    return textureSampleLevel(t, s, uv, 0.0).a;
}

// The glTF alpha test, the one GPU definition (the CPU's is
// gibake_scene::Material::keeps, which the bake's and the reference's ray
// casts use): a fragment of a masked draw (alphaMode MASK, or BLEND read as
// a mask at 0.5) exists only where baseColorFactor alpha × texture alpha
// (linear; sampled by the caller in uniform control flow, used only if the
// draw is textured) reaches the cutoff. Every pass that draws scene meshes
// discards where this is false, so every map sees the same holes.
fn alpha_keeps(d: DrawData, texel_alpha: f32) -> bool {
    if (d.alpha.z < 0.5) {
        return true;
    }
    var a = d.alpha.y;
    if (d.albedo.w > 0.5) {
        a = a * texel_alpha;
    }
    return a >= d.alpha.x;
}
