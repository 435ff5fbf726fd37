// other_lights_none.wgsl — shade.wgsl's other lights for a scene with one
// light: none (params.n_other_lights is 0, so nothing here is called), and
// no binding: shading then binds what downlevel devices allow
// (other_lights.wgsl is the real one).

fn other_light(k: u32) -> PrimaryLight {
    return PrimaryLight();
}

fn other_visibility(k: u32, p: vec3<f32>, ng: vec3<f32>, wi: vec3<f32>) -> f32 {
    return 1.0;
}

fn cull_other_lights(lid: u32, surface: bool, x: vec3<f32>) {}

fn other_lights_radiance(p: vec3<f32>, ns: vec3<f32>, ng: vec3<f32>, albedo: vec3<f32>) -> vec3<f32> {
    return vec3<f32>(0.0);
}
