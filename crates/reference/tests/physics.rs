//! Analytic checks of the reference path tracer: direct light from a spot and
//! a directional light, shadows, no light leaks, one bounce between two
//! perpendicular planes against an independent quadrature, scale invariance,
//! determinism across thread counts, and finite output for extreme inputs.

use crate::common;
use common::{draw, ortho};
use std::f64::consts::PI;

use gibake_image::{Image, rel_mse};
use gibake_reference::scenes::{
    cuboid, directional, material, quad, spot, static_scene, validation_corner,
};
use gibake_reference::{Depth, RayScene, ReferenceError, Settings, View, render, render_view};
use gibake_scene::{Light, Projection, Scene};
use glam::Vec3;

fn settings(w: u32, h: u32, spp: u32, depth: Depth) -> Settings {
    common::settings_seeded(w, h, spp, depth, 1)
}

/// A large floor (y = 0, ±half) with albedo `a` under `light`.
fn floor_scene(a: Vec3, half: f32, light: Light) -> Scene {
    let m = vec![material("floor", a)];
    let floor = quad(
        "floor",
        Vec3::new(-half, 0.0, half),
        Vec3::new(2.0 * half, 0.0, 0.0),
        Vec3::new(0.0, 0.0, -2.0 * half),
        0,
    );
    static_scene("floor", light, m, vec![floor])
}

fn close(a: Vec3, b: Vec3, rel: f32) -> bool {
    (a - b)
        .abs()
        .cmple(b.abs() * rel + Vec3::splat(1e-30))
        .all()
}

#[test]
fn spot_straight_down_matches_inverse_square_and_cosine_cubed() {
    let h = 2.0f32;
    let i = Vec3::new(10.0, 20.0, 30.0);
    let a = Vec3::new(0.8, 0.5, 0.25);
    let light = spot(
        Vec3::new(0.0, h, 0.0),
        Vec3::NEG_Y,
        i,
        80f32.to_radians(),
        85f32.to_radians(),
    );
    let scene = floor_scene(a, 100.0, light.clone());
    // Centre: a tiny orthographic footprint straight under the light.
    let view = ortho(Vec3::new(0.0, 5.0, 0.0), Vec3::ZERO, Vec3::NEG_Z, 0.002);
    let img = draw(&scene, &view, &settings(4, 4, 4, Depth::Direct));
    let expect = a / std::f32::consts::PI * i / (h * h);
    for p in &img.pixels {
        assert!(close(*p, expect, 1e-4), "{p} vs {expect}");
    }
    // Off axis: E = I · att · cos³θ / h²; pixel-centre value vs box average (smooth, 16×16 px).
    let half = 2.0 * h;
    let view = ortho(Vec3::new(0.0, 5.0, 0.0), Vec3::ZERO, Vec3::NEG_Z, half);
    let n = 16;
    let img = draw(&scene, &view, &settings(n, n, 64, Depth::Direct));
    for y in 0..n {
        for x in 0..n {
            // camera right = (−Y) × (−Z) = +X, camera up = −Z.
            let px = ((x as f32 + 0.5) / n as f32 * 2.0 - 1.0) * half;
            let pz = -(1.0 - (y as f32 + 0.5) / n as f32 * 2.0) * half;
            let q = Vec3::new(px, 0.0, pz);
            let l = light.position - q;
            let d = l.length();
            let w = l / d;
            let e = i * light.spot_attenuation(-w) * w.y / (d * d);
            let expect = a / std::f32::consts::PI * e;
            let got = img.get(x, y);
            assert!(close(got, expect, 0.02), "pixel {x},{y}: {got} vs {expect}");
        }
    }
}

#[test]
fn directional_light_is_uniform_cosine() {
    let a = Vec3::new(0.6, 0.3, 0.9);
    let e0 = Vec3::new(1.0, 2.0, 3.0);
    let theta = 60f32.to_radians();
    let light = directional(Vec3::new(theta.sin(), -theta.cos(), 0.0), e0);
    let scene = floor_scene(a, 50.0, light);
    let view = View::look_at(
        Vec3::new(0.0, 3.0, 4.0),
        Vec3::ZERO,
        Vec3::Y,
        Projection::Perspective {
            yfov: 0.6,
            znear: 0.1,
            zfar: None,
        },
    );
    let img = draw(&scene, &view, &settings(16, 16, 4, Depth::Direct));
    let expect = a / std::f32::consts::PI * e0 * theta.cos();
    for p in &img.pixels {
        assert!(close(*p, expect, 1e-4), "{p} vs {expect}");
    }
    // Seen from below (the back side) the floor is unlit: the light is behind it.
    let below = View::look_at(
        Vec3::new(0.0, -3.0, 4.0),
        Vec3::ZERO,
        Vec3::Y,
        Projection::Perspective {
            yfov: 0.6,
            znear: 0.1,
            zfar: None,
        },
    );
    let img = draw(&scene, &below, &settings(8, 8, 4, Depth::OneBounce));
    assert!(img.pixels.iter().all(|p| *p == Vec3::ZERO));
}

#[test]
fn occluder_casts_an_exact_shadow() {
    let h = 2.0f32;
    let i = Vec3::splat(8.0);
    let a = Vec3::splat(0.5);
    let light = spot(
        Vec3::new(0.0, h, 0.0),
        Vec3::NEG_Y,
        i,
        80f32.to_radians(),
        85f32.to_radians(),
    );
    let mut scene = floor_scene(a, 100.0, light);
    // A 0.48 × 0.48 square at half height: its shadow is the square ±0.48
    // (pixel edges stay clear of the shadow's edges).
    scene.materials.push(material("occluder", Vec3::splat(0.9)));
    let s = 0.24;
    scene.static_meshes.push(quad(
        "occ",
        Vec3::new(-s, h / 2.0, s),
        Vec3::new(2.0 * s, 0.0, 0.0),
        Vec3::new(0.0, 0.0, -2.0 * s),
        1,
    ));
    // Look at the floor from below the occluder (the camera is not geometry).
    let half = 1.0;
    let view = ortho(Vec3::new(0.0, 0.5, 0.0), Vec3::ZERO, Vec3::NEG_Z, half);
    let n = 20;
    let img = draw(&scene, &view, &settings(n, n, 16, Depth::Direct));
    let px = 2.0 * half / n as f32;
    for y in 0..n {
        for x in 0..n {
            let x0 = -half + x as f32 * px;
            let z0 = -half + y as f32 * px;
            let (x1, z1) = (x0 + px, z0 + px);
            let e = 2.0 * s;
            let inside = x0 >= -e && x1 <= e && z0 >= -e && z1 <= e;
            let outside = x1 <= -e || x0 >= e || z1 <= -e || z0 >= e;
            let got = img.get(x, y);
            if inside {
                assert_eq!(got, Vec3::ZERO, "pixel {x},{y} should be in shadow");
            } else if outside {
                assert!(got.x > 0.1, "pixel {x},{y} should be lit: {got}");
            }
        }
    }
}

#[test]
fn closed_box_does_not_leak_light() {
    // A closed room (two-sided walls) with the lights outside: black inside.
    let m = vec![material("wall", Vec3::splat(0.8))];
    let room = cuboid("room", Vec3::splat(-1.0), Vec3::splat(1.0), 0);
    let view = View::look_at(
        Vec3::new(0.3, 0.2, 0.5),
        Vec3::new(-1.0, -0.5, -1.0),
        Vec3::Y,
        Projection::Perspective {
            yfov: 1.5,
            znear: 0.01,
            zfar: None,
        },
    );
    for light in [
        directional(Vec3::new(0.3, -1.0, 0.2), Vec3::splat(100.0)),
        spot(
            Vec3::new(0.0, 3.0, 0.0),
            Vec3::NEG_Y,
            Vec3::splat(100.0),
            0.5,
            1.2,
        ),
        // Just outside the ceiling, by far less than the offsets could hide.
        spot(
            Vec3::new(0.1, 1.0 + 1e-3, 0.1),
            Vec3::NEG_Y,
            Vec3::splat(100.0),
            0.5,
            1.2,
        ),
    ] {
        let scene = static_scene("room", light, m.clone(), vec![room.clone()]);
        let img = draw(&scene, &view, &settings(16, 16, 16, Depth::OneBounce));
        assert!(
            img.pixels.iter().all(|p| *p == Vec3::ZERO),
            "light leaked into the closed box"
        );
    }
}

#[test]
fn light_on_a_surface_is_not_shadowed_by_it() {
    // A spot exactly in the ceiling plane of a room, pointing down.
    let m = vec![material("wall", Vec3::splat(0.8))];
    let room = cuboid(
        "room",
        Vec3::new(-2.0, 0.0, -2.0),
        Vec3::new(2.0, 2.0, 2.0),
        0,
    );
    let light = spot(
        Vec3::new(0.0, 2.0, 0.0),
        Vec3::NEG_Y,
        Vec3::splat(4.0),
        1.0,
        1.2,
    );
    let scene = static_scene("room", light, m, vec![room]);
    let view = ortho(Vec3::new(0.0, 1.0, 0.0), Vec3::ZERO, Vec3::NEG_Z, 0.01);
    let img = draw(&scene, &view, &settings(4, 4, 4, Depth::Direct));
    let expect = 0.8 / std::f32::consts::PI * 4.0 / 4.0;
    for p in &img.pixels {
        assert!((p.x - expect).abs() < 1e-3 * expect, "{p} vs {expect}");
    }
}

/// ∫ over the floor x ∈ [0, lx], z ∈ [−lz, lz] of x·y0 / (x² + y0² + z²)² dA,
/// the z integral in closed form, the x integral by composite Simpson.
fn floor_to_wall_integral(y0: f64, lx: f64, lz: f64) -> f64 {
    let inner = |x: f64| {
        let a2 = x * x + y0 * y0;
        let a = a2.sqrt();
        // ∫_{−lz}^{lz} dz / (a² + z²)² = 2·[z/(2a²(a²+z²)) + atan(z/a)/(2a³)] at z = lz
        let f = lz / (2.0 * a2 * (a2 + lz * lz)) + (lz / a).atan() / (2.0 * a2 * a);
        x * y0 * 2.0 * f
    };
    let n = 200_000; // even
    let hstep = lx / n as f64;
    let mut s = inner(0.0) + inner(lx);
    for k in 1..n {
        s += inner(k as f64 * hstep) * if k % 2 == 1 { 4.0 } else { 2.0 };
    }
    s * hstep / 3.0
}

#[test]
fn one_bounce_between_perpendicular_planes_matches_quadrature() {
    // Floor A (y = 0, x ∈ [0, 20], z ∈ [−10, 10]) lit straight down; wall B
    // (x = 0) gets no direct light, only the floor's bounce.
    let (aa, ab, e) = (0.6f64, 0.5f64, 2.0f64);
    let (lx, lz) = (20.0f32, 10.0f32);
    let m = vec![
        material("A", Vec3::splat(aa as f32)),
        material("B", Vec3::new(ab as f32, 0.25, 1.0)),
    ];
    let floor = quad(
        "A",
        Vec3::new(0.0, 0.0, lz),
        Vec3::new(lx, 0.0, 0.0),
        Vec3::new(0.0, 0.0, -2.0 * lz),
        0,
    );
    let wall = quad(
        "B",
        Vec3::new(0.0, 0.0, -lz),
        Vec3::new(0.0, 0.0, 2.0 * lz),
        Vec3::new(0.0, lx, 0.0),
        1,
    );
    let scene = static_scene(
        "planes",
        directional(Vec3::NEG_Y, Vec3::splat(e as f32)),
        m,
        vec![floor, wall],
    );
    let y0 = 1.0f32;
    let view = ortho(
        Vec3::new(3.0, y0, 0.0),
        Vec3::new(0.0, y0, 0.0),
        Vec3::Y,
        0.01,
    );

    let direct = draw(&scene, &view, &settings(2, 2, 4, Depth::Direct));
    assert!(direct.pixels.iter().all(|p| *p == Vec3::ZERO));

    let img = draw(&scene, &view, &settings(4, 4, 4096, Depth::OneBounce));
    let got = img.mean().as_dvec3();
    let integral = floor_to_wall_integral(y0 as f64, lx as f64, lz as f64);
    let expect = ab / PI * (aa / PI * e) * integral;
    // Infinite planes would give π/2; the 20 × 20 floor gives a little less.
    assert!(
        integral < PI / 2.0 && integral > 0.9 * PI / 2.0,
        "{integral}"
    );
    let rel = (got.x - expect).abs() / expect;
    eprintln!("one bounce: traced {got}, quadrature {expect}, rel error {rel:.2e}");
    assert!(
        rel < 0.02,
        "one bounce {got} vs quadrature {expect} (rel {rel})"
    );
    // Channel ratios follow the wall albedo exactly (same paths).
    assert!((got.y / got.x - 0.25 / ab).abs() < 1e-4 && (got.z / got.x - 1.0 / ab).abs() < 1e-4);
}

/// The validation corner with a spot light, everything scaled by `s`.
fn scaled_corner(s: f32, spot_light: bool) -> (Scene, View) {
    let (mut scene, view) = validation_corner(16);
    for m in &mut scene.static_meshes {
        for p in &mut m.positions {
            *p *= s;
        }
    }
    if spot_light {
        scene.lights[0] = spot(
            Vec3::new(0.3, 1.8, 0.6) * s,
            Vec3::new(-0.2, -1.0, -0.3),
            Vec3::splat(6.0 * s * s),
            0.6,
            0.9,
        );
    }
    (scene, view.scaled(s))
}

#[test]
fn scale_invariance() {
    let st = settings(24, 24, 16, Depth::OneBounce);
    for spot_light in [true, false] {
        let (scene, view) = scaled_corner(1.0, spot_light);
        let base = draw(&scene, &view, &st);
        assert!(base.mean().x > 0.01);
        for s in [1e-3f32, 1e3, 1.0 / 1024.0] {
            let (scene, view) = scaled_corner(s, spot_light);
            let img = draw(&scene, &view, &st);
            let e = rel_mse(&img, &base);
            let ratio = img.mean() / base.mean();
            eprintln!("spot {spot_light}, scale {s}: rel MSE {e:.2e}, mean ratio {ratio}");
            assert!(e < 1e-4, "scale {s}: rel MSE {e}");
            assert!(
                (ratio - Vec3::ONE).abs().max_element() < 1e-3,
                "scale {s}: mean ratio {ratio}"
            );
            if s == 1.0 / 1024.0 {
                // A power-of-two scale is exact: the same image bit for bit.
                assert_eq!(img, base);
            }
        }
    }
}

#[test]
fn deterministic_across_thread_counts() {
    let (scene, view) = validation_corner(12);
    let st = settings(20, 12, 8, Depth::OneBounce);
    let run = |threads: usize| {
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap();
        pool.install(|| draw(&scene, &view, &st))
    };
    let a = run(1);
    let b = run(2);
    let c = run(2);
    let bits = |i: &Image| {
        i.pixels
            .iter()
            .flat_map(|p| p.to_array().map(f32::to_bits))
            .collect::<Vec<_>>()
    };
    assert_eq!(bits(&a), bits(&b));
    assert_eq!(bits(&b), bits(&c));
    // A different seed gives a different (noisy) image.
    let other = draw(
        &scene,
        &view,
        &Settings {
            seed: 2,
            ..st.clone()
        },
    );
    assert_ne!(bits(&a), bits(&other));
}

#[test]
fn extreme_inputs_stay_finite() {
    let st = settings(12, 12, 4, Depth::OneBounce);
    let check = |scene: &Scene, view: &View, what: &str| {
        let img = draw(scene, view, &st);
        assert!(img.all_finite(), "{what}: non-finite pixels");
        img
    };
    // Bright and dim lights, spot and directional.
    for i in [1e30f32, 1e-30] {
        for spot_light in [true, false] {
            let (mut scene, view) = scaled_corner(1.0, spot_light);
            scene.lights[0].color = Vec3::splat(i);
            let img = check(&scene, &view, "bright/dim light");
            assert!(img.mean().x > 0.0 || i < 1e-20, "bright light gave black");
        }
    }
    // Huge and tiny scales.
    for s in [1e-12f32, 1e12] {
        for spot_light in [true, false] {
            let (scene, view) = scaled_corner(s, spot_light);
            let img = check(&scene, &view, "scale");
            assert!(img.mean().x > 0.0);
        }
    }
    // Grazing directional light, and a light exactly on / extremely close to the floor.
    let (mut scene, view) = scaled_corner(1.0, false);
    scene.lights[0] = directional(Vec3::new(1.0, -1e-7, 0.3), Vec3::splat(5.0));
    check(&scene, &view, "grazing");
    for y in [0.0f32, 1e-30, 1e-7] {
        for dir in [Vec3::NEG_Y, Vec3::X] {
            scene.lights[0] = spot(Vec3::new(0.2, y, 0.6), dir, Vec3::splat(1e10), 0.5, 1.5);
            check(&scene, &view, "light on the floor");
        }
    }
    // A degenerate (zero-area) triangle and a zero vertex normal next to normal geometry.
    let (mut scene, view) = scaled_corner(1.0, true);
    let mut bad = quad("bad", Vec3::ZERO, Vec3::X, Vec3::X * 2.0, 0);
    bad.normals = vec![Vec3::ZERO; 4];
    scene.static_meshes.push(bad);
    let mut zero_n = quad(
        "zn",
        Vec3::new(0.5, 0.01, 0.5),
        Vec3::X * 0.3,
        Vec3::NEG_Z * 0.3,
        0,
    );
    zero_n.normals = vec![Vec3::ZERO; 4];
    scene.static_meshes.push(zero_n);
    check(&scene, &view, "degenerate");
}

#[test]
fn ray_queries() {
    let (scene, _) = validation_corner(8);
    let rs = RayScene::build(&scene, 0.0);
    assert_eq!(rs.triangle_count(), 2 + 2 + 2 + 12 + 2 * 8 * 3);
    // Straight down onto the floor, from above: t, position, normals up.
    let h = rs
        .intersect(Vec3::new(0.7, 1.5, 0.7), Vec3::NEG_Y, f32::INFINITY)
        .unwrap();
    assert!((h.t - 1.5).abs() < 1e-6 && (h.position - Vec3::new(0.7, 0.0, 0.7)).length() < 1e-6);
    assert_eq!(h.geometric_normal, Vec3::Y);
    assert!((h.shading_normal - Vec3::Y).length() < 1e-6);
    assert_eq!(h.albedo, Vec3::splat(0.7));
    // From below: the normals flip to face the origin.
    let h = rs
        .intersect(Vec3::new(0.7, -1.0, 0.7), Vec3::Y, f32::INFINITY)
        .unwrap();
    assert_eq!(h.geometric_normal, Vec3::NEG_Y);
    assert!(
        rs.intersect(Vec3::new(0.7, -1.0, 0.7), Vec3::Y, 0.99)
            .is_none()
    );
    assert!(rs.occluded(Vec3::new(0.7, -1.0, 0.7), Vec3::Y, 1.01));
    assert!(!rs.occluded(Vec3::new(0.7, -1.0, 0.7), Vec3::Y, 0.99));
    // Visibility between points on the floor and on the back wall, around the block.
    assert!(rs.visible(
        Vec3::new(0.8, 0.0, 0.8),
        Vec3::Y,
        Vec3::new(0.8, 1.0, -1.0),
        Vec3::Z
    ));
    assert!(!rs.visible(
        Vec3::new(0.2, 0.0, 0.8),
        Vec3::Y,
        Vec3::new(0.2, 0.3, -1.0),
        Vec3::Z
    ));
    // Points in a concave corner see each other (offsets do not cross the other wall).
    assert!(rs.visible(
        Vec3::new(-1.0, 1e-6, 0.9),
        Vec3::X,
        Vec3::new(-1.0 + 1e-6, 0.0, 0.9),
        Vec3::Y
    ));
}

#[test]
fn watertight_along_shared_edges_and_vertices() {
    // A quad split along its diagonal, rays aimed exactly at the diagonal and the corner.
    let m = vec![material("m", Vec3::ONE)];
    let q = quad(
        "q",
        Vec3::new(-1.0, -1.0, 0.0),
        Vec3::new(2.0, 0.0, 0.0),
        Vec3::new(0.0, 2.0, 0.0),
        0,
    );
    let scene = static_scene("q", directional(Vec3::NEG_Z, Vec3::ONE), m, vec![q]);
    let rs = RayScene::build(&scene, 0.0);
    for k in 1..1000 {
        let x = -1.0 + 2.0 * k as f32 / 1000.0;
        let o = Vec3::new(x, x, 1.0) + Vec3::new(0.3, -0.7, 0.0) * 1e-3;
        let target = Vec3::new(x, x, 0.0);
        let d = (target - o).normalize();
        assert!(
            rs.intersect(o, d, f32::INFINITY).is_some(),
            "ray through the diagonal at {x} missed"
        );
        assert!(rs.intersect(o, -d, f32::INFINITY).is_none());
    }
}

#[test]
fn errors_are_clear() {
    let (scene, view) = validation_corner(8);
    let e = render(&scene, &settings(8, 8, 1, Depth::Direct), &|_| {}).unwrap_err();
    assert!(matches!(e, ReferenceError::NoCamera { .. }));
    assert!(e.to_string().contains("has no camera; add one"), "{e}");
    let rs = RayScene::build(&scene, 0.0);
    for (s, what) in [
        (settings(0, 8, 1, Depth::Direct), "empty"),
        (settings(8, 8, 0, Depth::Direct), "spp"),
        (
            Settings {
                time: f32::NAN,
                ..settings(8, 8, 1, Depth::Direct)
            },
            "time",
        ),
    ] {
        let e = render_view(&rs, &view, &s, &|_| {}).unwrap_err();
        assert!(!e.to_string().is_empty(), "{what}");
    }
    assert!(matches!(
        render_view(&rs, &view, &settings(0, 8, 1, Depth::Direct), &|_| {}),
        Err(ReferenceError::EmptyImage { .. })
    ));
    assert!(matches!(
        render_view(&rs, &view, &settings(8, 8, 0, Depth::Direct), &|_| {}),
        Err(ReferenceError::ZeroSpp)
    ));
}

#[test]
fn progress_reports_every_row() {
    let (scene, view) = validation_corner(8);
    let rs = RayScene::build(&scene, 0.0);
    let max = std::sync::atomic::AtomicU64::new(0);
    let calls = std::sync::atomic::AtomicU64::new(0);
    render_view(&rs, &view, &settings(5, 7, 1, Depth::Direct), &|r| {
        max.fetch_max(r, std::sync::atomic::Ordering::Relaxed);
        calls.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
    })
    .unwrap();
    assert_eq!(max.into_inner(), 7);
    assert_eq!(calls.into_inner(), 7);
}
