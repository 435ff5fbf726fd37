//! Moving objects under a mirroring transform (negative determinant: glTF
//! makes their clockwise faces the front ones) or wound clockwise are lit
//! like the original (issue: they rendered black, 0.005 against 1.76).
//!
//! A ball is added to the bundled `sun` scene's static part as a moving
//! object four ways: as is, mirrored (scale −1 on x; a UV sphere is
//! symmetric under it), with its triangles wound clockwise, and both. The
//! `full` renders must agree where the ball is.

use crate::common;

use gibake_eval::EvalSettings;
use gibake_runtime::Mode;
use gibake_scene::{Material, Mesh, Scene};
use glam::{DVec3, Mat4, Vec3};

fn ball(center: Vec3, mirrored: bool, clockwise: bool) -> (Mesh, Material, Mat4) {
    let g = gibake_scenegen::geom::uv_sphere(DVec3::ZERO, 0.45, 24, 16);
    let mut indices = g.idx.clone();
    if clockwise {
        for t in indices.chunks_exact_mut(3) {
            t.swap(1, 2);
        }
    }
    let mesh = Mesh {
        name: "ball".into(),
        positions: g.pos.iter().map(|p| p.as_vec3()).collect(),
        normals: g.nrm.iter().map(|n| n.as_vec3()).collect(),
        uvs: None,
        indices,
        material: 0,
    };
    let material = Material::opaque("ball", Vec3::new(0.8, 0.6, 0.3), None);
    let scale = if mirrored {
        Vec3::new(-1.0, 1.0, 1.0)
    } else {
        Vec3::ONE
    };
    (
        mesh,
        material,
        Mat4::from_translation(center) * Mat4::from_scale(scale),
    )
}

#[test]
fn mirrored_and_clockwise_moving_objects_are_lit_like_the_original() {
    let ctx = common::gpu();
    let base = gibake_eval::load(
        &std::fs::read(common::data("sun.glb")).expect("data/sun.glb"),
        "sun.glb",
    );
    let base: Scene = gibake_bake::static_only(&base);
    let s = EvalSettings {
        size: 64,
        ssaa: 1,
        vpls: 64,
        rsm_size: 128,
        vpl_map_size: 32,
        ..Default::default()
    };
    let asset = gibake_eval::bake(&ctx, &base, &s).expect("bake");
    let render = |mirrored: bool, clockwise: bool| {
        let mut scene = base.clone();
        let (m, mat, w) = ball(Vec3::new(0.0, 0.9, 0.5), mirrored, clockwise);
        scene.add_dynamic_object("ball", vec![(m, mat)], w);
        gibake_eval::render(&ctx, &scene, &asset, Mode::Full, &s).expect("render")
    };
    let without = gibake_eval::render(&ctx, &base, &asset, Mode::Full, &s).expect("render");
    let original = render(false, false);
    // The ball's pixels: where adding it changed the image.
    let mask: Vec<usize> = (0..original.pixels.len())
        .filter(|&i| (original.pixels[i] - without.pixels[i]).abs().max_element() > 1e-4)
        .collect();
    assert!(
        mask.len() > 40,
        "the ball covers only {} pixels",
        mask.len()
    );
    let mean = |img: &gibake_image::Image| {
        mask.iter().map(|&i| img.pixels[i]).sum::<Vec3>() / mask.len() as f32
    };
    let m0 = mean(&original);
    assert!(m0.min_element() > 0.05, "the original ball is dark: {m0}");
    for (mirrored, clockwise) in [(true, false), (false, true), (true, true)] {
        let img = render(mirrored, clockwise);
        let m = mean(&img);
        let rel = ((m - m0).abs() / m0).max_element();
        eprintln!("mirrored {mirrored}, clockwise {clockwise}: ball mean {m} vs {m0} ({rel:.2e})");
        assert!(
            rel < 0.01,
            "mirrored {mirrored}, clockwise {clockwise}: the ball's mean radiance {m} differs from the original's {m0}"
        );
        let diff = gibake_image::rel_mse(&img, &original);
        assert!(
            diff < 1e-3,
            "mirrored {mirrored}, clockwise {clockwise}: image rel MSE {diff:.2e}"
        );
    }
}
