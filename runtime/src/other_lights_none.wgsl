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
