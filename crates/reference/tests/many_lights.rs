//! The reference with many primary lights (issue 19 part 6): superposition
//! (a multi-light render is the sum of the single-light renders, to float
//! rounding), a point light's inverse-square cosine law, glTF's range window
//! with its exact cut-off, and stiff cases: a point light 10⁻⁶ of the scene
//! size from a wall, a point light shut in a closed box, 64 lights, lights
//! twelve orders of magnitude apart, and scales 10⁻³ / 10³.
//!
//! The reference's estimator for many lights is next-event estimation summed
//! over every light (`direct::irradiance`): the random numbers a path uses
//! (pixel position, bounce direction) are drawn whatever the lights are, and
//! the ray caster's power-of-two scale depends on the triangles only, so the
//! renders of a scene with several lights and of its single-light scenes
//! trace exactly the same rays with the same seed. What separates the two is
//! float rounding only, bounded below.

use crate::common;
use common::{draw, ortho};
use gibake_image::{Image, rel_mse};
use gibake_reference::direct::light_irradiance;
use gibake_reference::scenes::{
    cuboid, directional, material, point, quad, spot, static_scene, validation_corner,
    validation_corner_multi,
};
use gibake_reference::{Depth, RayScene, Settings, View, irradiance};
use gibake_scene::{Light, LightKind, Projection, Scene};
use glam::{DVec3, Vec3};

/// Half an f32 ULP at 1, relative (2⁻²⁴): one correctly rounded f32 operation.
const U: f64 = f32::EPSILON as f64 / 2.0;

fn settings(w: u32, h: u32, spp: u32, depth: Depth) -> Settings {
    common::settings_seeded(w, h, spp, depth, 7)
}

/// `scene` with only `lights`.
fn with_lights(scene: &Scene, lights: Vec<Light>) -> Scene {
    let mut s = scene.clone();
    s.lights = lights;
    s
}

/// Looking straight down (−Y) at the floor around `centre` (image right = +X,
/// image up = −Z), half size `half`.
fn top_view(centre: Vec3, half: f32) -> View {
    ortho(centre + Vec3::Y * 5.0, centre, Vec3::NEG_Z, half)
}

/// The floor point at the centre of pixel `(x, y)` of `top_view(centre, half)`.
fn top_pixel_centre(centre: Vec3, half: f32, n: u32, x: u32, y: u32) -> Vec3 {
    let px = ((x as f32 + 0.5) / n as f32 * 2.0 - 1.0) * half;
    let pz = -(1.0 - (y as f32 + 0.5) / n as f32 * 2.0) * half;
    Vec3::new(centre.x + px, 0.0, centre.z + pz)
}

/// A floor (y = 0, x and z in ±half, albedo `a`) lit by `lights`.
fn floor_scene(a: Vec3, half: f32, lights: Vec<Light>) -> Scene {
    let floor = quad(
        "floor",
        Vec3::new(-half, 0.0, half),
        Vec3::new(2.0 * half, 0.0, 0.0),
        Vec3::new(0.0, 0.0, -2.0 * half),
        0,
    );
    with_lights(
        &static_scene(
            "floor",
            lights[0].clone(),
            vec![material("floor", a)],
            vec![floor],
        ),
        lights,
    )
}

/// `I · attenuation · max(0, n·ω) / d²` in f64 from the light's f32 data: the
/// closed form of a point or spot light's irradiance at `p` (normal `n`), no
/// occluders. The spot falloff and the range window are recomputed here in
/// f64 from glTF's formulas, not taken from `gibake_scene`.
fn analytic(light: &Light, p: Vec3, n: Vec3) -> DVec3 {
    let l = light.position.as_dvec3() - p.as_dvec3();
    let d2 = l.length_squared();
    let d = d2.sqrt();
    let w = l / d;
    let cos = n.as_dvec3().dot(w).max(0.0);
    let spot = match light.kind {
        LightKind::Point => 1.0,
        LightKind::Spot {
            inner_cone,
            outer_cone,
        } => {
            let (ci, co) = ((inner_cone as f64).cos(), (outer_cone as f64).cos());
            let scale = 1.0 / (ci - co).max(0.001);
            let cd = light.direction.as_dvec3().dot(-w);
            let a = ((cd - co) * scale).clamp(0.0, 1.0);
            a * a
        }
        LightKind::Directional => unreachable!("analytic() is for point and spot lights"),
    };
    let window = match light.range {
        Some(r) => (1.0 - (d / r as f64).powi(4)).clamp(0.0, 1.0),
        None => 1.0,
    };
    light.color.as_dvec3() * (spot * window * cos / d2)
}

/// Largest `|got − expect| / scale` over channels (`scale` > 0).
fn err(got: Vec3, expect: DVec3, scale: f64) -> f64 {
    (got.as_dvec3() - expect).abs().max_element() / scale
}

/// Per pixel and channel: `|x − Σ parts| ≤ tol · Σ parts` (every part ≥ 0).
/// Returns the largest `|x − Σ| / Σ` seen (0 where both are 0).
fn assert_sum(x: &Image, parts: &[Image], tol: f64, what: &str) -> f64 {
    let mut worst = 0.0f64;
    for (k, p) in x.pixels.iter().enumerate() {
        let sum: DVec3 = parts.iter().map(|i| i.pixels[k].as_dvec3()).sum();
        assert!(parts.iter().all(|i| i.pixels[k].min_element() >= 0.0));
        for c in 0..3 {
            let (got, s) = (p[c] as f64, sum[c]);
            let d = (got - s).abs();
            assert!(
                d <= tol * s,
                "{what}: pixel {k} channel {c}: {got} vs sum of parts {s} (rel {:.2e}, tolerance {tol:.2e})",
                d / s
            );
            if s > 0.0 {
                worst = worst.max(d / s);
            }
        }
    }
    worst
}

#[test]
fn a_multi_light_render_is_the_sum_of_its_single_light_renders() {
    // Directional + point + hard-edged spot, with shadows from the block and
    // the sphere, and one bounce between the walls.
    let (scene, view) = validation_corner_multi(16);
    let kinds: Vec<_> = scene.lights.iter().map(|l| &l.kind).collect();
    assert!(matches!(kinds[0], LightKind::Directional));
    assert!(matches!(kinds[1], LightKind::Point));
    assert!(matches!(kinds[2], LightKind::Spot { .. }));
    for depth in [Depth::Direct, Depth::OneBounce] {
        let st = settings(24, 24, 8, depth);
        let all = draw(&scene, &view, &st);
        let parts: Vec<Image> = scene
            .lights
            .iter()
            .map(|l| draw(&with_lights(&scene, vec![l.clone()]), &view, &st))
            .collect();
        for (i, p) in parts.iter().enumerate() {
            assert!(p.mean().min_element() > 1e-3, "light {i} lights nothing");
        }
        // Every pixel sample traces the same rays for the multi-light scene
        // and for each single-light one (see the module docs); only the order
        // of the float operations differs. Per sample the multi-light path
        // rounds Σ E_i (summed in f64) to f32 once, albedo/π · E once, and for
        // one bounce the f32 product and sum once each; the pixel mean is
        // rounded to f32 once. Each single-light path does the same to its
        // own term, and the parts are then summed in f64. Every term is ≥ 0,
        // so the relative error of the sum is bounded by the largest
        // per-term one: at most 5 roundings on each side, 10 · 2⁻²⁴ ≈ 6·10⁻⁷.
        // Measured: 1.2·10⁻⁷ (Direct) and 1.4·10⁻⁷ (OneBounce), 2–3 roundings.
        let worst = assert_sum(&all, &parts, 10.0 * U, &format!("{depth:?}"));
        eprintln!("superposition {depth:?}: largest relative difference {worst:.2e}");
    }
}

#[test]
fn point_light_follows_the_inverse_square_cosine_law() {
    let i = Vec3::new(3.0, 5.0, 7.0);
    let a = Vec3::new(0.8, 0.5, 0.25);
    let pos = Vec3::new(0.25, 1.5, -0.5);
    let light = point(pos, i);
    let mut scene = floor_scene(a, 100.0, vec![light.clone()]);
    // A ceiling above the light: a point light lights every direction.
    scene.static_meshes.push(quad(
        "ceiling",
        Vec3::new(-100.0, 3.0, 100.0),
        Vec3::new(200.0, 0.0, 0.0),
        Vec3::new(0.0, 0.0, -200.0),
        0,
    ));
    let rs = RayScene::build(&scene, 0.0);
    let mut worst = 0.0f64;
    for xi in -8..=8 {
        for zi in -8..=8 {
            let (x, z) = (xi as f32 * 0.625, zi as f32 * 0.625);
            for (p, n) in [
                (Vec3::new(x, 0.0, z), Vec3::Y),
                (Vec3::new(x * 4.0, 3.0, z * 4.0), Vec3::NEG_Y),
            ] {
                let e = irradiance(&rs, p, n, n);
                let expect = analytic(&light, p, n);
                let rel = err(e, expect, expect.max_element());
                worst = worst.max(rel);
                assert!(rel < 1e-5, "at {p}: {e} vs {expect} (rel {rel:.2e})");
                // The back sides face away from the light: exactly 0.
                assert_eq!(irradiance(&rs, p, -n, -n), Vec3::ZERO);
            }
        }
    }
    eprintln!("point light irradiance: largest relative error {worst:.2e}");
    // Rendered: a 2 mm footprint straight under the light (cos³ varies by
    // < 10⁻⁶ over it) shows albedo/π · I/h².
    let foot = Vec3::new(pos.x, 0.0, pos.z);
    let img = draw(
        &scene,
        &ortho(foot + Vec3::Y, foot, Vec3::NEG_Z, 0.001),
        &settings(4, 4, 4, Depth::Direct),
    );
    let h = pos.y as f64;
    let expect = a.as_dvec3() / std::f64::consts::PI * i.as_dvec3() / (h * h);
    for p in &img.pixels {
        let rel = err(*p, expect, expect.max_element());
        assert!(rel < 1e-5, "{p} vs {expect} (rel {rel:.2e})");
    }
}

#[test]
fn range_cuts_light_off_exactly_with_the_gltf_window_inside() {
    let a = Vec3::splat(0.6);
    let range = 2.0f32;
    let mut pt = point(Vec3::new(-1.5, 1.0, 0.0), Vec3::new(4.0, 3.0, 2.0));
    pt.range = Some(range);
    let mut sp = spot(
        Vec3::new(1.5, 1.0, 0.0),
        Vec3::NEG_Y,
        Vec3::new(2.0, 3.0, 4.0),
        50f32.to_radians(),
        70f32.to_radians(),
    );
    sp.range = Some(1.6);
    let scene = floor_scene(a, 50.0, vec![pt.clone(), sp.clone()]);
    let rs = RayScene::build(&scene, 0.0);
    let (mut inside, mut outside) = (0, 0);
    for light in [&pt, &sp] {
        let r = light.range.unwrap() as f64;
        for k in 0..=400 {
            // Floor points along x and along a diagonal from the light's foot.
            let t = k as f32 * 0.01;
            for dir in [Vec3::X, Vec3::NEG_X, Vec3::new(0.6, 0.0, 0.8)] {
                let p = Vec3::new(light.position.x, 0.0, light.position.z) + dir * t;
                let e = light_irradiance(&rs, light, p, Vec3::Y, Vec3::Y);
                let d = (light.position.as_dvec3() - p.as_dvec3()).length();
                if d >= r {
                    outside += 1;
                    assert_eq!(e, Vec3::ZERO, "{} at d = {d} ≥ range {r}", light.name);
                } else {
                    inside += 1;
                    // Relative to the unwindowed value: the window 1 − (d/r)⁴
                    // is computed in f32 (q⁴ to a few ULPs), so near the range
                    // its relative error grows while its absolute one does not.
                    let mut unwindowed = light.clone();
                    unwindowed.range = None;
                    let scale = analytic(&unwindowed, p, Vec3::Y).max_element();
                    let expect = analytic(light, p, Vec3::Y);
                    if scale > 0.0 {
                        let rel = err(e, expect, scale);
                        assert!(rel < 1e-5, "{} at d = {d}: {e} vs {expect}", light.name);
                    }
                }
            }
        }
        // At exactly the range (straight below, d = h = range): exact zero.
        let mut at = light.clone();
        at.range = Some(light.position.y);
        let below = Vec3::new(light.position.x, 0.0, light.position.z);
        assert_eq!(
            light_irradiance(&rs, &at, below, Vec3::Y, Vec3::Y),
            Vec3::ZERO
        );
    }
    assert!(
        inside > 500 && outside > 500,
        "{inside} inside, {outside} outside"
    );
    // Rendered from above: every pixel entirely outside both range disks is
    // exactly black, direct and with one bounce (a plane does not light
    // itself), and the sum of the two lights inside.
    let (centre, half, n) = (Vec3::ZERO, 4.0f32, 32u32);
    let view = top_view(centre, half);
    let pix = 2.0 * half / n as f32;
    for depth in [Depth::Direct, Depth::OneBounce] {
        let img = draw(&scene, &view, &settings(n, n, 4, depth));
        let mut dark = 0;
        for y in 0..n {
            for x in 0..n {
                let c = top_pixel_centre(centre, half, n, x, y);
                // Farthest-from-the-light point of a pixel is within half a
                // diagonal of its centre; the nearest is at least that close.
                let reach = |l: &Light| {
                    let horizontal = Vec3::new(c.x - l.position.x, 0.0, c.z - l.position.z);
                    let rho = horizontal.length() - pix * std::f32::consts::FRAC_1_SQRT_2;
                    let r = l.range.unwrap();
                    rho.max(0.0).powi(2) + l.position.y.powi(2) < r * r
                };
                if !reach(&pt) && !reach(&sp) {
                    dark += 1;
                    assert_eq!(img.get(x, y), Vec3::ZERO, "{depth:?} pixel {x},{y}");
                }
            }
        }
        assert!(dark > (n * n) as usize / 2, "{dark}");
        assert!(img.mean().min_element() > 0.0);
    }
}

#[test]
fn point_light_a_millionth_of_the_scene_from_a_wall() {
    // An open corner 2 units across (floor y = 0, back wall z = −1); a point
    // light 2·10⁻⁶ in front of the wall (10⁻⁶ of the scene size). Half its
    // flux lands within a few 10⁻⁶ of its foot on the wall, where E reaches
    // I/h² = 2.5·10¹¹ · I.
    let a = Vec3::splat(0.7);
    let ms = vec![material("floor", a), material("wall", a)];
    let floor = quad(
        "floor",
        Vec3::new(-1.0, 0.0, 1.0),
        Vec3::new(2.0, 0.0, 0.0),
        Vec3::new(0.0, 0.0, -2.0),
        0,
    );
    let wall = quad(
        "wall",
        Vec3::new(-1.0, 0.0, -1.0),
        Vec3::new(2.0, 0.0, 0.0),
        Vec3::new(0.0, 2.0, 0.0),
        1,
    );
    let gap = 2e-6f32;
    let light = point(Vec3::new(0.25, 1.0, -1.0 + gap), Vec3::ONE);
    let scene = static_scene("near_wall", light.clone(), ms, vec![floor, wall]);
    let rs = RayScene::build(&scene, 0.0);
    let h = light.position.z as f64 + 1.0; // the f32 gap, exactly
    // On the wall at distance r from the light's foot: I·h / (r² + h²)^(3/2).
    for r in [0.0f32, 1e-6, 3e-6, 1e-5, 1e-4, 1e-3, 0.0625, 0.5] {
        for dir in [Vec3::X, Vec3::NEG_Y, Vec3::new(-0.6, 0.8, 0.0)] {
            let p = Vec3::new(light.position.x, light.position.y, -1.0) + dir * r;
            let e = irradiance(&rs, p, Vec3::Z, Vec3::Z);
            let expect = analytic(&light, p, Vec3::Z);
            let rel = err(e, expect, expect.max_element());
            assert!(
                e.is_finite() && rel < 1e-5,
                "wall at r = {r}: {e} vs {expect}"
            );
        }
    }
    let peak = 1.0 / (h * h);
    let e0 = irradiance(&rs, Vec3::new(0.25, 1.0, -1.0), Vec3::Z, Vec3::Z);
    assert!((e0.x as f64 - peak).abs() < 1e-6 * peak, "{e0} vs {peak}");
    // The floor sees an ordinary point light.
    for p in [
        Vec3::new(0.0, 0.0, 0.0),
        Vec3::new(0.25, 0.0, -0.999),
        Vec3::new(-0.9, 0.0, 0.9),
    ] {
        let (e, expect) = (
            irradiance(&rs, p, Vec3::Y, Vec3::Y),
            analytic(&light, p, Vec3::Y),
        );
        assert!(
            err(e, expect, expect.max_element()) < 1e-5,
            "floor {p}: {e} vs {expect}"
        );
    }
    // Rendered: finite, non-negative, bounded by the peak (direct) and by the
    // peak plus its bounce (one bounce), and the floor matches the closed
    // form pixel by pixel.
    let corner = View::look_at(
        Vec3::new(0.8, 1.2, 1.8),
        Vec3::new(0.0, 0.5, -1.0),
        Vec3::Y,
        Projection::Perspective {
            yfov: 1.0,
            znear: 0.01,
            zfar: None,
        },
    );
    let bound = 0.7 / std::f64::consts::PI * peak;
    for (depth, limit) in [(Depth::Direct, bound), (Depth::OneBounce, bound * 1.7)] {
        let img = draw(&scene, &corner, &settings(24, 24, 16, depth));
        assert!(img.all_finite(), "{depth:?}: non-finite pixels");
        for p in &img.pixels {
            assert!(p.min_element() >= 0.0 && (p.max_element() as f64) <= limit * (1.0 + 1e-6));
        }
        assert!(img.mean().x > 0.0);
    }
    let (centre, half, n) = (Vec3::new(0.0, 0.0, 0.25), 0.5f32, 16u32);
    let img = draw(
        &scene,
        &top_view(centre, half),
        &settings(n, n, 64, Depth::Direct),
    );
    for y in 0..n {
        for x in 0..n {
            let c = top_pixel_centre(centre, half, n, x, y);
            let expect = a.as_dvec3() / std::f64::consts::PI * analytic(&light, c, Vec3::Y);
            // Pixel-centre value vs the box average of a smooth field: 0.3 %.
            let rel = err(img.get(x, y), expect, expect.x);
            assert!(
                rel < 3e-3,
                "floor pixel {x},{y}: {} vs {expect}",
                img.get(x, y)
            );
        }
    }
}

#[test]
fn a_point_light_shut_in_a_closed_box_lights_nothing_outside() {
    // A closed box (two-sided walls, 1 unit, its floor 0.5 above the ground)
    // beside a wall, on a large ground; the cameras outside see the ground,
    // the wall and the box's outside, all exactly black, direct and with one
    // bounce. Light positions: the centre, 10⁻³ under the lid, 10⁻³ from two
    // opposite corners. (A light closer to a face than the shadow ray's end
    // margin, 2⁻¹⁴ of its largest coordinate after the ray caster's
    // power-of-two scaling — here 6·10⁻⁵ — counts as lying on that face and
    // is not shadowed by it, `RayScene::end_margin`, so it lights the
    // outside too: measured, 3·10⁻⁵ inside the +X face lights 84 of 100
    // ground points beyond it, 10⁻⁴ inside lights none. That is the
    // documented price of "a light on a surface is not shadowed by it".)
    let m = vec![material("grey", Vec3::splat(0.8))];
    let (lo, hi) = (Vec3::new(-0.5, 0.5, -0.5), Vec3::new(0.5, 1.5, 0.5));
    let meshes = vec![
        cuboid("box", lo, hi, 0),
        quad(
            "ground",
            Vec3::new(-4.0, 0.0, 4.0),
            Vec3::new(8.0, 0.0, 0.0),
            Vec3::new(0.0, 0.0, -8.0),
            0,
        ),
        quad(
            "wall",
            Vec3::new(-4.0, 0.0, -1.5),
            Vec3::new(8.0, 0.0, 0.0),
            Vec3::new(0.0, 3.0, 0.0),
            0,
        ),
    ];
    let outside = [
        View::look_at(
            Vec3::new(2.0, 2.5, 3.0),
            Vec3::new(0.0, 0.5, -0.5),
            Vec3::Y,
            Projection::Perspective {
                yfov: 1.2,
                znear: 0.01,
                zfar: None,
            },
        ),
        // From below the box's floor level, looking at its underside.
        View::look_at(
            Vec3::new(1.5, 0.2, 1.5),
            Vec3::new(0.0, 0.5, 0.0),
            Vec3::Y,
            Projection::Perspective {
                yfov: 1.4,
                znear: 0.01,
                zfar: None,
            },
        ),
    ];
    let inside = View::look_at(
        Vec3::new(0.3, 0.7, 0.3),
        Vec3::new(-0.5, 1.0, -0.5),
        Vec3::Y,
        Projection::Perspective {
            yfov: 1.5,
            znear: 0.001,
            zfar: None,
        },
    );
    let gap = 1e-3f32;
    for pos in [
        Vec3::new(0.0, 1.0, 0.0),
        Vec3::new(0.1, hi.y - gap, -0.2),
        hi - Vec3::splat(gap),
        lo + Vec3::splat(gap),
    ] {
        let scene = static_scene(
            "box",
            point(pos, Vec3::splat(1e3)),
            m.clone(),
            meshes.clone(),
        );
        let rs = RayScene::build(&scene, 0.0);
        // Direct irradiance on the ground and the wall, both sides: zero.
        for k in 0..200 {
            let t = k as f32 / 200.0;
            for (p, n) in [
                (Vec3::new(-3.9 + 7.8 * t, 0.0, 3.9 - 5.0 * t), Vec3::Y),
                (Vec3::new(0.7 - 0.3 * t, 0.0, 0.7 * t), Vec3::Y),
                (Vec3::new(3.9 - 7.8 * t, 2.9 * t, -1.5), Vec3::Z),
            ] {
                assert_eq!(
                    irradiance(&rs, p, n, n),
                    Vec3::ZERO,
                    "light {pos}: {p} is lit"
                );
            }
        }
        for view in &outside {
            for depth in [Depth::Direct, Depth::OneBounce] {
                let img = draw(&scene, view, &settings(16, 16, 8, depth));
                assert!(
                    img.pixels.iter().all(|p| *p == Vec3::ZERO),
                    "light at {pos}: light left the box ({depth:?}, mean {})",
                    img.mean()
                );
            }
        }
        let lit = draw(&scene, &inside, &settings(8, 8, 4, Depth::OneBounce));
        assert!(
            lit.all_finite() && lit.mean().x > 0.0,
            "light at {pos}: box dark inside"
        );
    }
}

#[test]
fn sixty_four_lights() {
    let (scene, view) = validation_corner(12);
    // (a) 64 identical co-located copies of a light give exactly 64 times the
    // image of one: 64 equal f32 terms add up exactly in f64 (≤ 30 significant
    // bits), and every later step is a product or sum in which a power of
    // two commutes with rounding. Bit for bit, every kind, both depths.
    let lights = [
        point(Vec3::new(0.6, 1.1, 0.6), Vec3::new(0.3, 0.5, 1.2)),
        spot(
            Vec3::new(-0.7, 1.8, 1.2),
            Vec3::new(0.8, -1.5, -1.8),
            Vec3::new(5.0, 2.5, 0.8),
            0.3,
            0.5,
        ),
        directional(Vec3::new(-0.5, -1.0, -0.7), Vec3::new(2.4, 2.1, 1.6)),
    ];
    for light in &lights {
        for depth in [Depth::Direct, Depth::OneBounce] {
            let st = settings(16, 16, 4, depth);
            let one = draw(&with_lights(&scene, vec![light.clone()]), &view, &st);
            let many = draw(&with_lights(&scene, vec![light.clone(); 64]), &view, &st);
            assert!(one.mean().x > 0.0);
            for (m, o) in many.pixels.iter().zip(&one.pixels) {
                assert_eq!(*m, *o * 64.0, "{:?} {depth:?}", light.kind);
            }
        }
    }
    // (b) 64 distinct point lights of distinct colours on an 8 × 8 grid:
    // over a bare floor, irradiance against the closed-form sum ...
    let grid: Vec<Light> = (0..64)
        .map(|k| {
            let (i, j) = ((k % 8) as f32, (k / 8) as f32);
            let mut l = point(
                Vec3::new(
                    -0.9 + 0.25 * i,
                    1.2 + 0.05 * ((i + j) % 3.0),
                    -0.9 + 0.25 * j,
                ),
                Vec3::new(0.02 + 0.01 * i, 0.02 + 0.01 * j, 0.1 - 0.001 * (i + j)),
            );
            l.name = format!("grid {i},{j}");
            l
        })
        .collect();
    let bare = floor_scene(Vec3::splat(0.5), 10.0, grid.clone());
    let rs = RayScene::build(&bare, 0.0);
    for p in [
        Vec3::new(0.8, 0.0, 0.8),
        Vec3::new(0.6, 0.0, 0.3),
        Vec3::new(-0.9, 0.0, -0.9),
        Vec3::new(5.0, 0.0, -3.0),
    ] {
        let e = irradiance(&rs, p, Vec3::Y, Vec3::Y);
        let expect: DVec3 = grid.iter().map(|l| analytic(l, p, Vec3::Y)).sum();
        let rel = err(e, expect, expect.max_element());
        assert!(rel < 1e-5, "{p}: {e} vs {expect} (rel {rel:.2e})");
    }
    // ... and over the corner (shadows, one bounce) the render is the sum of
    // the 64 single-light renders, with the same rounding bound as for three
    // lights (each part ≥ 0).
    let multi = with_lights(&scene, grid.clone());
    for depth in [Depth::Direct, Depth::OneBounce] {
        let st = settings(12, 12, 2, depth);
        let all = draw(&multi, &view, &st);
        let parts: Vec<Image> = grid
            .iter()
            .map(|l| draw(&with_lights(&scene, vec![l.clone()]), &view, &st))
            .collect();
        let worst = assert_sum(&all, &parts, 10.0 * U, &format!("64 lights {depth:?}"));
        eprintln!("64 lights {depth:?}: largest relative difference {worst:.2e}");
    }
}

#[test]
fn a_dim_light_beside_a_bright_one() {
    // A 10⁶ W/sr spot (30° cone) and a 10⁻⁶ W/sr point light side by side
    // over a floor with a wall; ratio 10¹².
    let a = Vec3::new(0.7, 0.6, 0.5);
    let bright = spot(
        Vec3::new(-1.0, 1.0, 0.0),
        Vec3::NEG_Y,
        Vec3::splat(1e6),
        25f32.to_radians(),
        30f32.to_radians(),
    );
    let dim = point(Vec3::new(1.0, 1.0, 0.0), Vec3::new(1e-6, 2e-6, 3e-6));
    let mut scene = floor_scene(a, 3.0, vec![bright.clone(), dim.clone()]);
    scene.static_meshes.push(quad(
        "wall",
        Vec3::new(-3.0, 0.0, -1.0),
        Vec3::new(6.0, 0.0, 0.0),
        Vec3::new(0.0, 2.0, 0.0),
        0,
    ));
    let view = View::look_at(
        Vec3::new(0.0, 2.5, 3.0),
        Vec3::new(0.0, 0.3, -0.5),
        Vec3::Y,
        Projection::Perspective {
            yfov: 1.1,
            znear: 0.01,
            zfar: None,
        },
    );
    for depth in [Depth::Direct, Depth::OneBounce] {
        let st = settings(24, 24, 8, depth);
        let both = draw(&scene, &view, &st);
        let b = draw(&with_lights(&scene, vec![bright.clone()]), &view, &st);
        let d = draw(&with_lights(&scene, vec![dim.clone()]), &view, &st);
        assert!(both.all_finite() && d.mean().x > 0.0);
        // Where the bright light contributes nothing (outside its cone, and
        // for one bounce also nothing it lit in view of the bounce ray), the
        // image of both is the dim one's bit for bit: adding an exact 0
        // changes no rounding.
        let mut exact = 0;
        for k in 0..both.pixels.len() {
            if b.pixels[k] == Vec3::ZERO {
                exact += 1;
                assert_eq!(both.pixels[k], d.pixels[k], "{depth:?} pixel {k}");
            }
        }
        assert!(
            exact > 50,
            "{depth:?}: only {exact} pixels without the bright light"
        );
        // Elsewhere both − bright recovers the dim light's contribution only
        // to within the f32 rounding of the bright one: the bound of the
        // superposition test, 10 · 2⁻²⁴ of (bright + dim). Where both light a
        // pixel the dim part is ~10⁻¹² of it, below f32's 6·10⁻⁸ resolution,
        // so it cannot be recovered there — in f32 or by summing in f64, since
        // each sample's radiance is an f32. Where the bright light's share is
        // small (the edge of its cone, bounce-only pixels) the difference
        // recovers the dim part to that same absolute bound.
        assert_sum(
            &both,
            &[b.clone(), d.clone()],
            10.0 * U,
            &format!("{depth:?}"),
        );
    }
    // The dim light's image is the 1 W/sr light's image times 10⁻⁶, to the
    // rounding of a non-power-of-two scale (a few ULPs): nothing flushes to
    // zero or loses precision at 10⁻⁶.
    let mut unit = dim.clone();
    unit.color = Vec3::new(1.0, 2.0, 3.0);
    let st = settings(16, 16, 4, Depth::OneBounce);
    let d = draw(&with_lights(&scene, vec![dim.clone()]), &view, &st);
    let u = draw(&with_lights(&scene, vec![unit]), &view, &st);
    for (x, y) in d.pixels.iter().zip(&u.pixels) {
        let expect = y.as_dvec3() * 1e-6;
        assert!(
            err(*x, expect, expect.max_element().max(1e-300)) < 1e-6,
            "{x} vs {expect}"
        );
    }
}

/// [`validation_corner_multi`] scaled by `s`: vertices, light positions,
/// ranges and the camera by `s`; point and spot intensities by `s²` (the
/// inverse-square law then gives the same irradiance at the scaled point;
/// directional irradiance does not depend on distance), so every pixel has
/// the same radiance. The point light gets a range (scaled too).
fn scaled_multi(s: f32) -> (Scene, View) {
    let (mut scene, view) = validation_corner_multi(16);
    for m in &mut scene.static_meshes {
        for p in &mut m.positions {
            *p *= s;
        }
    }
    scene.lights[1].range = Some(1.5);
    for l in &mut scene.lights {
        l.position *= s;
        l.range = l.range.map(|r| r * s);
        if !matches!(l.kind, LightKind::Directional) {
            l.color *= s * s;
        }
    }
    (scene, view.scaled(s))
}

#[test]
fn many_lights_are_scale_invariant() {
    let st = settings(24, 24, 8, Depth::OneBounce);
    let (scene, view) = scaled_multi(1.0);
    let base = draw(&scene, &view, &st);
    assert!(base.mean().min_element() > 0.01);
    for s in [1e-3f32, 1e3, 1.0 / 1024.0, 1024.0] {
        let (scene, view) = scaled_multi(s);
        let img = draw(&scene, &view, &st);
        assert!(img.all_finite());
        let e = rel_mse(&img, &base);
        let ratio = img.mean() / base.mean();
        eprintln!("many lights, scale {s}: rel MSE {e:.2e}, mean ratio {ratio}");
        if s.log2().fract() == 0.0 {
            // A power-of-two scale is exact everywhere (positions, s² on the
            // intensities, the ray caster's own power-of-two normalisation):
            // the same image bit for bit.
            assert_eq!(img, base, "scale {s}");
        } else {
            // Decimal scales round every position: a handful of pixels on
            // silhouettes and shadow edges change (same bound as the
            // one-light test in physics.rs).
            assert!(e < 1e-4, "scale {s}: rel MSE {e}");
            assert!(
                (ratio - Vec3::ONE).abs().max_element() < 1e-3,
                "scale {s}: {ratio}"
            );
        }
    }
}
