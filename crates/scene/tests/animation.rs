//! Animation sampling through the importer: LINEAR, STEP, CUBICSPLINE, slerp,
//! per-animation clamping, node matrices decomposed to TRS.

use crate::common;

use common::basic;
use glam::{Quat, Vec3};
use serde_json::json;

fn close(a: Vec3, b: Vec3) -> bool {
    (a - b).length() < 1e-5
}

#[test]
fn linear_step_cubic_and_own_range_clamping() {
    let mut b = basic();
    let n_lin = b.node(json!({ "name": "Lin" }));
    let n_step = b.node(json!({ "name": "Step" }));
    let n_cub = b.node(json!({ "name": "Cub", "translation": [0.0, 9.0, 0.0] }));
    for n in [n_lin, n_step, n_cub] {
        b.root(n);
    }
    let t_lin = b.floats(&[1.0, 3.0], "SCALAR");
    let v_lin = b.floats(&[0.0, 0.0, 0.0, 4.0, 0.0, 0.0], "VEC3");
    let t_step = b.floats(&[1.0, 2.0, 3.0], "SCALAR");
    let v_step = b.floats(&[0.0, 0.0, 0.0, 5.0, 0.0, 0.0, 7.0, 0.0, 0.0], "VEC3");
    // Animation B has its own range [10, 12].
    let t_cub = b.floats(&[10.0, 12.0], "SCALAR");
    #[rustfmt::skip]
    let v_cub = b.floats(&[
        0.0, 0.0, 0.0,   0.0, 0.0, 0.0,   2.0, 0.0, 0.0, // key 0: in, value, out
        0.0, 0.0, 0.0,   4.0, 0.0, 0.0,   0.0, 0.0, 0.0, // key 1
    ], "VEC3");
    b.animation(json!({ "name": "A",
        "samplers": [
            { "input": t_lin, "output": v_lin },
            { "input": t_step, "output": v_step, "interpolation": "STEP" } ],
        "channels": [
            { "sampler": 0, "target": { "node": n_lin, "path": "translation" } },
            { "sampler": 1, "target": { "node": n_step, "path": "translation" } } ] }));
    b.animation(json!({ "name": "B",
        "samplers": [ { "input": t_cub, "output": v_cub, "interpolation": "CUBICSPLINE" } ],
        "channels": [ { "sampler": 0, "target": { "node": n_cub, "path": "scale" } } ] }));
    let s = b.load().unwrap();
    let a = &s.animator;
    let pos = |n: usize, t: f32| a.world_matrix(n, t).transform_point3(Vec3::ZERO);
    assert!(close(pos(n_lin, 2.0), Vec3::new(2.0, 0.0, 0.0)));
    assert!(close(pos(n_lin, 1.5), Vec3::new(1.0, 0.0, 0.0)));
    assert!(close(pos(n_lin, -3.0), Vec3::ZERO), "clamped before");
    assert!(
        close(pos(n_lin, 11.0), Vec3::new(4.0, 0.0, 0.0)),
        "clamped after"
    );
    assert!(close(pos(n_step, 1.5), Vec3::ZERO));
    assert!(close(pos(n_step, 2.5), Vec3::new(5.0, 0.0, 0.0)));
    assert!(close(pos(n_step, 3.0), Vec3::new(7.0, 0.0, 0.0)));
    assert!(close(pos(n_step, 0.0), Vec3::ZERO));
    // Cubic (scale.x): h00=.5, h10=.125, h01=.5, h11=-.125, td=2:
    // 0·.5 + 2·2·.125 + 4·.5 + 2·0·(-.125) = 2.5.
    let sx = |t: f32| a.local_trs(n_cub, t).scale.x;
    assert!((sx(11.0) - 2.5).abs() < 1e-5, "{}", sx(11.0));
    assert_eq!(sx(2.0), 0.0, "B clamped to its own start while A runs");
    assert_eq!(sx(50.0), 4.0);
    // Untouched parts of the node keep their rest values.
    assert_eq!(
        a.local_trs(n_cub, 11.0).translation,
        Vec3::new(0.0, 9.0, 0.0)
    );
    assert_eq!(a.time_range(), Some((1.0, 12.0)));
    let times = a.sample_times(16);
    for k in [1.0, 2.0, 3.0, 10.0, 12.0] {
        assert!(times.contains(&k), "{times:?} lacks {k}");
    }
    assert!(times.len() >= 16);
    assert!(times.windows(2).all(|w| w[0] < w[1]));
}

#[test]
fn rotation_slerp_and_cubic_rotation_normalized() {
    let mut b = basic();
    let n = b.node(json!({ "name": "Spin" }));
    b.root(n);
    let half = std::f32::consts::FRAC_PI_4; // half of 90°
    let t = b.floats(&[0.0, 1.0], "SCALAR");
    let r = b.floats(
        &[0.0, 0.0, 0.0, 1.0, 0.0, half.sin(), 0.0, half.cos()],
        "VEC4",
    );
    let n2 = b.node(json!({ "name": "Spin2" }));
    b.root(n2);
    #[rustfmt::skip]
    let rc = b.floats(&[
        0.0, 0.0, 0.0, 0.0,   0.0, 0.0, 0.0, 1.0,   0.0, 0.0, 0.0, 0.0,
        0.0, 0.0, 0.0, 0.0,   0.0, 1.0, 0.0, 0.0,   0.0, 0.0, 0.0, 0.0,
    ], "VEC4");
    b.animation(json!({
        "samplers": [ { "input": t, "output": r }, { "input": t, "output": rc, "interpolation": "CUBICSPLINE" } ],
        "channels": [ { "sampler": 0, "target": { "node": n, "path": "rotation" } },
                      { "sampler": 1, "target": { "node": n2, "path": "rotation" } } ] }));
    let s = b.load().unwrap();
    let q = s.animator.local_trs(n, 0.5).rotation;
    let expected = Quat::from_rotation_y(std::f32::consts::FRAC_PI_4);
    assert!(q.angle_between(expected) < 1e-4, "{q:?}");
    let x = s.animator.world_matrix(n, 0.5).transform_vector3(Vec3::X);
    let c = std::f32::consts::FRAC_1_SQRT_2;
    assert!(close(x, Vec3::new(c, 0.0, -c)), "{x}");
    let q2 = s.animator.local_trs(n2, 0.5).rotation;
    assert!((q2.length() - 1.0).abs() < 1e-5);
}

#[test]
fn node_matrix_decomposed_for_animated_node() {
    let mut b = basic();
    let m = glam::Mat4::from_scale_rotation_translation(
        Vec3::new(2.0, 2.0, 2.0),
        Quat::from_rotation_z(0.3),
        Vec3::new(1.0, 2.0, 3.0),
    );
    let n = b.node(json!({ "name": "M", "matrix": m.to_cols_array() }));
    b.root(n);
    let t = b.floats(&[0.0, 1.0], "SCALAR");
    let v = b.floats(&[5.0, 0.0, 0.0, 6.0, 0.0, 0.0], "VEC3");
    b.animation(json!({ "samplers": [ { "input": t, "output": v } ],
        "channels": [ { "sampler": 0, "target": { "node": n, "path": "translation" } } ] }));
    let s = b.load().unwrap();
    let trs = s.animator.local_trs(n, 0.0);
    assert!(close(trs.scale, Vec3::splat(2.0)));
    assert!(trs.rotation.angle_between(Quat::from_rotation_z(0.3)) < 1e-4);
    assert!(close(trs.translation, Vec3::new(5.0, 0.0, 0.0)));
}

#[test]
fn morph_weight_channels_are_ignored_with_a_warning() {
    let mut b = basic();
    let t = b.floats(&[0.0, 1.0], "SCALAR");
    let w = b.floats(&[0.0, 1.0], "SCALAR");
    b.animation(json!({ "samplers": [ { "input": t, "output": w } ],
        "channels": [ { "sampler": 0, "target": { "node": 0, "path": "weights" } } ] }));
    let s = b.load().unwrap();
    assert!(
        s.warnings.iter().any(|x| x.contains("weight")),
        "{:?}",
        s.warnings
    );
    assert!(
        s.dynamic_objects.is_empty(),
        "a weights channel does not make a node dynamic"
    );
    assert_eq!(s.animator.time_range(), None);
}
