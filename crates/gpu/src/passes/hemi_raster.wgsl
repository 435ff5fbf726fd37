// hemi_raster.wgsl — exact rasterization of meshes into VPL hemisphere maps
// (needs common.wgsl, hemisphere.wgsl, mesh.wgsl).
//
// The hemi-octahedral map is the central projection of the hemisphere onto
// the four faces sx·x + sy·y + z = 1 (sx, sy = ±1) of an octahedron, rotated
// 45°. Each face is a plane, so a central projection onto it maps straight
// edges to straight edges: drawing every triangle once per face with
// w = sx·x + sy·y + z (a true perspective divide) and discarding fragments
// whose direction is not in that face's quadrant rasterizes the map exactly,
// whatever the triangle size. The fragment's perspective-correct local
// position is the exact point of the triangle on the texel's ray, so the
// stored distance equals a ray cast through the texel centre.
//
// Alpha-masked surfaces cut holes (alpha_keeps, with the draw's texture
// bound as group 1 per draw call): a moving tree's leaves let light through
// in the merged VPL maps as they do in the baked ones.
//
// Instances: one entry of `instances` (draw, job, face) per instance, built
// on the CPU only for the faces a draw's bounds touch. Vertices are pulled
// from storage so each invocation sees its whole triangle and can reject a
// triangle that misses the face.

struct Job {
    origin: vec4<f32>,     // xyz VPL map origin
    normal: vec4<f32>,     // xyz VPL normal
    tile: vec4<u32>,       // xy tile offset in texels
}

struct RasterParams {
    atlas_size: vec2<f32>,
    tile_size: f32,
    depth_scale: f32,      // 1 / (largest distance stored); frag_depth = d · depth_scale
    _pad3: u32,
    _pad0: u32,
    _pad1: u32,
    _pad2: u32,
}

@group(0) @binding(0) var<storage, read> draws: array<DrawData>;
@group(0) @binding(1) var<storage, read> vertices: array<f32>;
@group(0) @binding(2) var<storage, read> indices: array<u32>;
@group(0) @binding(3) var<storage, read> jobs: array<Job>;
@group(0) @binding(4) var<uniform> params: RasterParams;
@group(0) @binding(5) var<storage, read> instances: array<vec4<u32>>;   // draw, job, face
@group(1) @binding(0) var albedo_tex: texture_2d<f32>;
@group(1) @binding(1) var albedo_smp: sampler;

struct VsOut {
    @builtin(position) clip: vec4<f32>,
    @location(0) local: vec3<f32>,
    @location(1) @interpolate(flat) job_face: u32,
    @location(2) uv: vec2<f32>,
    @location(3) @interpolate(flat) draw: u32,
}

fn vertex_world(d: DrawData, vi: u32) -> vec3<f32> {
    let base = (d.extra.x + indices[vi]) * 8u;
    let p = vec3<f32>(vertices[base], vertices[base + 1u], vertices[base + 2u]);
    return (d.model * vec4<f32>(p, 1.0)).xyz;
}

// TEXCOORD_0 of vertex vi (GpuVertex: position 0..3, normal 3..6, uv 6..8).
fn vertex_uv(d: DrawData, vi: u32) -> vec2<f32> {
    let base = (d.extra.x + indices[vi]) * 8u;
    return vec2<f32>(vertices[base + 6u], vertices[base + 7u]);
}

@vertex
fn vs_main(@builtin(vertex_index) vi: u32, @builtin(instance_index) inst: u32) -> VsOut {
    let entry = instances[inst];
    let draw_id = entry.x;
    let job_i = entry.y;
    let face = entry.z;
    let d = draws[draw_id];
    let job = jobs[job_i];
    let sx = select(-1.0, 1.0, (face & 1u) != 0u);
    let sy = select(-1.0, 1.0, (face & 2u) != 0u);
    let n = job.normal.xyz;
    let tri0 = vi - vi % 3u;
    var l: array<vec3<f32>, 3>;
    for (var k = 0u; k < 3u; k++) {
        l[k] = to_local(n, vertex_world(d, tri0 + k) - job.origin.xyz);
    }
    let me = to_local(n, vertex_world(d, vi) - job.origin.xyz);
    var o: VsOut;
    o.local = me;
    o.job_face = job_i * 4u + face;
    o.uv = vertex_uv(d, vi);
    o.draw = draw_id;
    // Reject the triangle for this face if all corners are on the wrong side
    // of one of the face's bounding planes (sx·x ≥ 0, sy·y ≥ 0, z ≥ 0) or
    // behind the face plane's apex (w ≤ 0).
    var out_x = true;
    var out_y = true;
    var out_z = true;
    var out_w = true;
    for (var k = 0u; k < 3u; k++) {
        out_x = out_x && sx * l[k].x < 0.0;
        out_y = out_y && sy * l[k].y < 0.0;
        out_z = out_z && l[k].z < 0.0;
        out_w = out_w && (sx * l[k].x + sy * l[k].y + l[k].z) <= 0.0;
    }
    if (out_x || out_y || out_z || out_w) {
        o.clip = vec4<f32>(0.0, 0.0, 0.0, 0.0);   // degenerate: culled
        return o;
    }
    let w = sx * me.x + sy * me.y + me.z;
    let t = vec2<f32>(job.tile.xy);
    let s = params.tile_size;
    let a = params.atlas_size;
    let ax = (2.0 * t.x + s) / a.x - 1.0;
    let ay = 1.0 - (2.0 * t.y + s) / a.y;
    // e = (p.x + p.y, p.x − p.y) with p = local.xy / w; texel y grows with e.y.
    o.clip = vec4<f32>(ax * w + (s / a.x) * (me.x + me.y), ay * w - (s / a.y) * (me.x - me.y), 0.5 * w, w);
    return o;
}

struct FsOut {
    @location(0) dist: vec4<f32>,
    @builtin(frag_depth) depth: f32,
}

@fragment
fn fs_main(i: VsOut) -> FsOut {
    // Sampled first, in uniform control flow.
    let texel_alpha = mask_texel_alpha(albedo_tex, albedo_smp, i.uv);
    if (!alpha_keeps(draws[i.draw], texel_alpha)) {
        discard;
    }
    let face = i.job_face % 4u;
    let sx = select(-1.0, 1.0, (face & 1u) != 0u);
    let sy = select(-1.0, 1.0, (face & 2u) != 0u);
    if (sx * i.local.x < 0.0 || sy * i.local.y < 0.0 || i.local.z < 0.0) {
        discard;
    }
    let dist = length(i.local);
    var o: FsOut;
    o.dist = vec4<f32>(dist, 0.0, 0.0, 0.0);
    o.depth = clamp(dist * params.depth_scale, 0.0, 1.0);
    return o;
}
