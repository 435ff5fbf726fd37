// common.wgsl — constants and small helpers shared by every gibake shader.
// Composed (concatenated) before the shaders that use it; see shaders.rs.

const PI: f32 = 3.14159265358979;
const INV_PI: f32 = 0.318309886183791;
const F32_MAX: f32 = 3.40282e38;

// True when v is neither NaN nor ±Inf.
fn is_finite_f32(v: f32) -> bool {
    return v == v && abs(v) <= F32_MAX;
}

fn finite_or_zero3(v: vec3<f32>) -> vec3<f32> {
    if (is_finite_f32(v.x) && is_finite_f32(v.y) && is_finite_f32(v.z)) {
        return v;
    }
    return vec3<f32>(0.0);
}

// Octahedral normal encoding (Cigolle et al. 2014), unit vector <-> [-1,1]².
fn oct_wrap(v: vec2<f32>) -> vec2<f32> {
    return (1.0 - abs(v.yx)) * select(vec2<f32>(-1.0), vec2<f32>(1.0), v.xy >= vec2<f32>(0.0));
}

fn oct_encode(n: vec3<f32>) -> vec2<f32> {
    let p = n.xy / (abs(n.x) + abs(n.y) + abs(n.z));
    return select(oct_wrap(p), p, n.z >= 0.0);
}

fn oct_decode(e: vec2<f32>) -> vec3<f32> {
    var n = vec3<f32>(e.x, e.y, 1.0 - abs(e.x) - abs(e.y));
    let t = max(-n.z, 0.0);
    n.x = n.x + select(t, -t, n.x >= 0.0);
    n.y = n.y + select(t, -t, n.y >= 0.0);
    return normalize(n);
}
