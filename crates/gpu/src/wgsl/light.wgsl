// light.wgsl — the primary light's radiometry (needs common.wgsl).
// Must match GpuPrimaryLight in light_view.rs and Light::spot_attenuation,
// Light::range_window, Light::attenuation in gibake-scene; the CPU
// reference implements the same formulas.

struct PrimaryLight {
    position: vec4<f32>,   // xyz position; w = 1 directional, 0 spot or point
    direction: vec4<f32>,  // xyz unit direction the light points to
    color: vec4<f32>,      // rgb W/sr (spot, point) or W/m² (directional)
    spot: vec4<f32>,       // x scale, y offset of glTF's spot falloff (0, 1 for
                           // a point light); z range (0: none)
}

// glTF's recommended spot falloff; dir_from_light is unit, light → receiver.
fn spot_attenuation(light: PrimaryLight, dir_from_light: vec3<f32>) -> f32 {
    let cd = dot(light.direction.xyz, dir_from_light);
    let a = clamp(cd * light.spot.x + light.spot.y, 0.0, 1.0);
    return a * a;
}

// glTF's recommended range window saturate(1 − (d/range)⁴); 1 without a range.
fn range_window(light: PrimaryLight, d: f32) -> f32 {
    if (light.spot.z <= 0.0) {
        return 1.0;
    }
    let q = d / light.spot.z;
    let q2 = q * q;
    return clamp(1.0 - q2 * q2, 0.0, 1.0);
}

// Spot falloff times range window, at distance d in unit direction
// dir_from_light (spot and point lights).
fn light_attenuation(light: PrimaryLight, dir_from_light: vec3<f32>, d: f32) -> f32 {
    return spot_attenuation(light, dir_from_light) * range_window(light, d);
}

struct Incident {
    wi: vec3<f32>,        // unit direction receiver → light
    irradiance: vec3<f32> // before the cosine and visibility: I·att/d² or E
}

fn light_incident(light: PrimaryLight, p: vec3<f32>) -> Incident {
    var r: Incident;
    if (light.position.w > 0.5) {
        r.wi = -light.direction.xyz;
        r.irradiance = light.color.rgb;
    } else {
        let to_light = light.position.xyz - p;
        let d2 = dot(to_light, to_light);
        let inv_d = inverseSqrt(d2);
        r.wi = to_light * inv_d;
        r.irradiance = finite_or_zero3(light.color.rgb * (light_attenuation(light, -r.wi, d2 * inv_d) / d2));
        if (d2 <= 0.0) {
            r.wi = vec3<f32>(0.0);
            r.irradiance = vec3<f32>(0.0);
        }
    }
    return r;
}
