//! Every bounce (issue 50): the reference's N-bounce and every-bounce paths
//! against closed forms, and its stiff cases.
//!
//! The closed form is the furnace: in a closed space whose surfaces all have
//! albedo ρ, lit by a light inside, the light the walls absorb equals the
//! light's power, so the area-mean radiosity is `B̄ = ρ·Φ / (A·(1 − ρ))`
//! (every bounce), and bounce k alone has area mean `ρ^(k+1)·Φ/A` (the
//! transport from a closed enclosure's radiosity to its irradiance keeps the
//! area mean: reciprocity, and each point's form factors sum to 1). A cube
//! of side 2 with a point light of intensity I at its centre has Φ = 4πI,
//! A = 24, and by symmetry each face has the area mean; an orthographic
//! camera at the centre looking at one face head-on averages exactly over
//! that face. So the mean radiance of that image is `ρ^(k+1)·I/6` for bounce
//! k, `ρI / (6(1 − ρ))` for every bounce, and `(k+1)·I/6` for the first k
//! bounces at ρ = 1 (no finite answer with every bounce: the cap).
//!
//! Also: [`Depth::Direct`] and [`Depth::OneBounce`] render what they always
//! have, bit for bit (fingerprints recorded before every bounce existed);
//! `Bounces(0)` and `Bounces(1)` are those; determinism, scale invariance
//! and finite output for the every-bounce paths.

use crate::common;
use common::draw;
use gibake_image::{Image, rel_mse};
use gibake_reference::scenes::{
    cuboid, directional, material, point, static_scene, validation_corner, validation_corner_multi,
};
use gibake_reference::{
    Depth, MAX_BOUNCES, PathStats, RayScene, ReferenceError, Settings, View, hit_radiance,
    render_view, render_view_with_stats,
};
use gibake_scene::{Mesh, Projection, Scene};
use glam::{DVec3, Vec3};

/// FNV-1a over the bits of every pixel: a fingerprint of an image.
fn fingerprint(img: &Image) -> u64 {
    let mut h = 0xcbf2_9ce4_8422_2325u64;
    for p in &img.pixels {
        for c in p.to_array() {
            for b in c.to_bits().to_le_bytes() {
                h = (h ^ b as u64).wrapping_mul(0x0100_0000_01b3);
            }
        }
    }
    h
}

#[test]
fn direct_and_one_bounce_are_unchanged() {
    // Recorded on main at bc8fc16, before the every-bounce paths.
    let recorded = [
        ("corner", Depth::Direct, 0xa37cfe1732973a7d_u64),
        ("corner", Depth::OneBounce, 0x39a6aa043033be62),
        ("multi", Depth::Direct, 0x3fde915ae007b295),
        ("multi", Depth::OneBounce, 0x560b0a582d0a13bc),
    ];
    let (corner, view) = validation_corner(16);
    let (multi, _) = validation_corner_multi(16);
    for (name, depth, expect) in recorded {
        let scene = if name == "corner" { &corner } else { &multi };
        let st = common::settings_seeded(24, 16, 9, depth, 5);
        let img = draw(scene, &view, &st);
        assert_eq!(
            fingerprint(&img),
            expect,
            "{name} {depth:?} changed: {:#018x}",
            fingerprint(&img)
        );
        // Bounces(0) and Bounces(1) are the same renders.
        let n = depth.max_bounces();
        let same = draw(
            scene,
            &view,
            &Settings {
                depth: Depth::Bounces(n),
                ..st
            },
        );
        assert_eq!(same, img, "{name}: Bounces({n}) differs from {depth:?}");
    }
}

/// A closed cube `[−s, s]³` (two-sided walls, albedo `albedo`) with a point
/// light of intensity `i` at its centre.
fn furnace(albedo: Vec3, i: f32, s: f32) -> Scene {
    let m = vec![material("wall", albedo)];
    let cube = cuboid("cube", Vec3::splat(-s), Vec3::splat(s), 0);
    static_scene("furnace", point(Vec3::ZERO, Vec3::splat(i)), m, vec![cube])
}

/// From the cube's centre, orthographic, looking at its −Z face head-on:
/// the image covers that face exactly, so its mean is the face's area mean.
fn face_view(s: f32) -> View {
    View::look_at(
        Vec3::ZERO,
        Vec3::NEG_Z,
        Vec3::Y,
        Projection::Orthographic {
            xmag: s,
            ymag: s,
            znear: 0.0,
            zfar: 1.0,
        },
    )
}

fn settings(n: u32, spp: u32, depth: Depth, seed: u64) -> Settings {
    common::settings_seeded(n, n, spp, depth, seed)
}

fn stats_render(scene: &Scene, view: &View, st: &Settings) -> (Image, PathStats) {
    let rs = RayScene::build(scene, st.time);
    render_view_with_stats(&rs, view, st, &|_| {}).expect("render")
}

/// `I/6 · Σ_{k=0..=n} ρ^(k+1)` per channel: the face mean of the first `n`
/// bounces (`None`: every bounce, `ρI / (6(1−ρ))`).
fn furnace_mean(albedo: Vec3, i: f64, n: Option<u32>) -> DVec3 {
    let a = albedo.as_dvec3();
    match n {
        None => a * i / (6.0 * (DVec3::ONE - a)),
        Some(n) => {
            let mut sum = DVec3::ZERO;
            let mut p = a;
            for _ in 0..=n {
                sum += p;
                p *= a;
            }
            sum * i / 6.0
        }
    }
}

#[test]
fn furnace_bounces_converge_to_the_closed_form() {
    // Three albedos in one render: 0.3 converges in a few bounces, 0.8 in
    // tens, 0.95 in about a hundred (every bounce is 20× the first bounce
    // there, as in a white level; 3.7× the first five bounces).
    let albedo = Vec3::new(0.3, 0.8, 0.95);
    let i = 2.0f32;
    let scene = furnace(albedo, i, 1.0);
    let view = face_view(1.0);
    for (depth, spp, tol) in [
        (Depth::Direct, 4, 2e-3),
        (Depth::OneBounce, 64, 5e-3),
        (Depth::Bounces(5), 64, 5e-3),
        (Depth::Every, 64, 1e-2),
    ] {
        let (img, stats) = stats_render(&scene, &view, &settings(32, spp, depth, 11));
        let got = img.mean().as_dvec3();
        let n = (depth != Depth::Every).then(|| depth.max_bounces());
        let expect = furnace_mean(albedo, i as f64, n);
        let rel = (got - expect).abs() / expect;
        eprintln!(
            "{depth:?}: mean {got:.5} closed form {expect:.5} rel {rel:.5}; {:.1} bounces a path, {} capped",
            stats.mean_bounces(),
            stats.capped
        );
        assert!(
            rel.max_element() < tol,
            "{depth:?}: {got} vs the closed form {expect} (rel {rel})"
        );
        assert_eq!(stats.paths, 32 * 32 * spp as u64);
        assert_eq!(stats.capped, 0);
        assert!(img.all_finite());
    }
}

#[test]
fn furnace_of_albedo_099_converges_to_100_times_the_first_bounce() {
    // The stiff case: ρ = 0.99, the answer is 100× the first bounce's and a
    // path makes about 100 bounces. Four seeds (one render's mean has a
    // standard error of ~0.9% at 32² × 64 spp): their mean within 1.5%
    // (measured −0.5%: the corners' leak, see the white box below, takes
    // ~5·10⁻⁵ of the paths a bounce, ~0.5% of the light at 100 bounces).
    let rho = 0.99f32;
    let scene = furnace(Vec3::splat(rho), 1.0, 1.0);
    let view = face_view(1.0);
    let expect = furnace_mean(Vec3::splat(rho), 1.0, None).x;
    let mut sum = 0.0;
    let mut stats = PathStats::default();
    for seed in 0..4 {
        let (img, st) = stats_render(&scene, &view, &settings(32, 64, Depth::Every, seed));
        assert!(img.all_finite());
        sum += img.mean().as_dvec3().x / 4.0;
        stats.paths += st.paths;
        stats.bounces += st.bounces;
        stats.capped += st.capped;
    }
    let rel = (sum - expect) / expect;
    eprintln!(
        "ρ = 0.99: mean {sum:.4}, closed form {expect:.4} (rel {rel:+.4}); {:.1} bounces a path, {} of {} capped",
        stats.mean_bounces(),
        stats.capped,
        stats.paths
    );
    assert!(rel.abs() < 0.015, "{sum} vs {expect}");
    // Roulette from bounce 3 on keeps ~0.99 of the paths a bounce: ~100
    // bounces a path; 0.99^1021 = 3.5·10⁻⁵ of them reach the cap.
    assert!((95.0..106.0).contains(&stats.mean_bounces()));
    assert!(stats.capped < 40, "{stats:?}");
}

#[test]
fn white_closed_box_is_cut_at_the_cap_not_a_hang() {
    // Albedo 1 (glTF's default material) in a closed box: each bounce adds
    // the same light again, the answer is infinite. Paths run to the cap,
    // and the image is the first MAX_BOUNCES bounces: (MAX_BOUNCES + 1)·I/6.
    let scene = furnace(Vec3::ONE, 1.0, 1.0);
    let view = face_view(1.0);
    let st = settings(8, 4, Depth::Every, 3);
    let t = std::time::Instant::now();
    let (img, stats) = stats_render(&scene, &view, &st);
    let leaked = stats.paths - stats.capped;
    let expect = (MAX_BOUNCES + 1) as f64 / 6.0;
    let rel = (img.mean().as_dvec3() - DVec3::splat(expect)) / expect;
    eprintln!(
        "white box: mean {} (closed form {expect:.2}, rel {:+.4}) in {:.2} s, {} of {} paths capped, {leaked} ended early",
        img.mean(),
        rel.x,
        t.elapsed().as_secs_f64(),
        stats.capped,
        stats.paths
    );
    assert!(img.all_finite());
    // A path in a closed box ends before the cap only by leaking out of it:
    // a bounce ray that starts within 10⁻⁴ of the scene size of the next
    // wall (in a corner) can miss it, the ray caster's BVH traversal
    // culling boxes nearer than that (docs/reference.md, "Limitations").
    // It costs ~5·10⁻⁵ of the paths a bounce here; a path that leaks at
    // bounce k keeps its first k bounces.
    assert!(stats.capped as f64 >= 0.9 * stats.paths as f64, "{stats:?}");
    assert!(
        (leaked as f64) < 1e-4 * stats.bounces as f64,
        "{leaked} paths leaked in {} bounces",
        stats.bounces
    );
    assert!(stats.bounces <= stats.paths * MAX_BOUNCES as u64);
    assert!(
        rel.max_element() < 0.005 && rel.min_element() > -0.05,
        "{rel}"
    );
    // Bounded by the cap even for a light near f32's largest value.
    let bright = furnace(Vec3::ONE, 1e36, 1.0);
    let img = draw(&bright, &view, &settings(4, 1, Depth::Every, 3));
    assert!(img.all_finite() && img.mean().x > 1e37, "{}", img.mean());
    // Albedo above 1 (glTF allows any non-negative baseColorFactor) gains
    // light at every bounce: 2^1024 overflows f64, the image saturates at
    // f32::MAX, never ∞ or NaN.
    let gain = furnace(Vec3::splat(2.0), 1.0, 1.0);
    let img = draw(&gain, &view, &settings(4, 1, Depth::Every, 3));
    assert!(img.all_finite(), "{}", img.mean());
    assert_eq!(img.mean(), Vec3::splat(f32::MAX));
}

/// A white box (albedo 1, 4 × 4 × 4) with a square hole of side `hole` in
/// its ceiling (centred), a sun straight down through it, everything
/// scaled by `s`: a level of glTF's default material lit through a small
/// opening, whose later bounces carry many times the first.
fn white_room(hole: f32, s: f32) -> Scene {
    let (h, c) = (2.0f32, hole / 2.0);
    let q = |name: &str, corner: Vec3, u: Vec3, v: Vec3| {
        gibake_reference::scenes::quad(name, corner * s, u * s, v * s, 0)
    };
    let mut meshes: Vec<Mesh> = Vec::new();
    // Floor and walls: the cube without its top.
    let mut room = cuboid(
        "room",
        Vec3::new(-h, 0.0, -h) * s,
        Vec3::new(h, 2.0 * h, h) * s,
        0,
    );
    room.indices.truncate(4 * 6); // ±Z, ±X faces…
    let bottom = cuboid(
        "b",
        Vec3::new(-h, 0.0, -h) * s,
        Vec3::new(h, 2.0 * h, h) * s,
        0,
    );
    let mut floor = bottom.clone();
    floor.indices = bottom.indices[30..36].to_vec(); // …and −Y.
    meshes.push(room);
    meshes.push(floor);
    // The ceiling around the hole: four strips.
    let y = 2.0 * h;
    meshes.push(q(
        "n",
        Vec3::new(-h, y, -h),
        Vec3::new(2.0 * h, 0.0, 0.0),
        Vec3::new(0.0, 0.0, h - c),
    ));
    meshes.push(q(
        "s",
        Vec3::new(-h, y, c),
        Vec3::new(2.0 * h, 0.0, 0.0),
        Vec3::new(0.0, 0.0, h - c),
    ));
    meshes.push(q(
        "w",
        Vec3::new(-h, y, -c),
        Vec3::new(h - c, 0.0, 0.0),
        Vec3::new(0.0, 0.0, 2.0 * c),
    ));
    meshes.push(q(
        "e",
        Vec3::new(c, y, -c),
        Vec3::new(h - c, 0.0, 0.0),
        Vec3::new(0.0, 0.0, 2.0 * c),
    ));
    static_scene(
        "white_room",
        directional(Vec3::new(0.05, -1.0, 0.03), Vec3::splat(3.0)),
        vec![material("default", Vec3::ONE)],
        meshes,
    )
}

/// Inside the white room, looking at a corner (floor and two walls, some in
/// the sun's patch), everything scaled by `s`.
fn white_room_view(s: f32) -> View {
    View::look_at(
        Vec3::new(1.5, 2.5, 1.5) * s,
        Vec3::new(-2.0, 0.5, -2.0) * s,
        Vec3::Y,
        Projection::Perspective {
            yfov: 1.3,
            znear: 0.01 * s,
            zfar: None,
        },
    )
}

#[test]
fn white_room_through_a_small_opening_converges() {
    let scene = white_room(2.0, 1.0);
    let view = white_room_view(1.0);
    let direct = draw(&scene, &view, &settings(24, 64, Depth::Direct, 4));
    let one = draw(&scene, &view, &settings(24, 64, Depth::OneBounce, 4));
    let (every, stats) = stats_render(&scene, &view, &settings(24, 64, Depth::Every, 4));
    assert!(every.all_finite());
    let (one_ind, every_ind) = (one.mean() - direct.mean(), every.mean() - direct.mean());
    let ratio = every_ind / one_ind;
    eprintln!(
        "white room, 2×2 opening in a 4×4 ceiling: every ÷ one bounce indirect {ratio}, {:.1} bounces a path, {} capped",
        stats.mean_bounces(),
        stats.capped
    );
    // The hole is 1/24 of the room's inside area: about 1/24 of the light
    // leaving the walls escapes at each bounce, so a path makes ~24 bounces
    // and the later bounces carry ~25× the first; no path nears the cap.
    assert!(
        ratio.min_element() > 15.0 && ratio.max_element() < 40.0,
        "{ratio}"
    );
    assert!((15.0..35.0).contains(&stats.mean_bounces()));
    assert_eq!(stats.capped, 0, "{stats:?}");
    // Nothing is absorbed: what enters through the hole (E = 3 W/m² on
    // 4 m²) leaves through it. Were the walls' radiosity B uniform, what
    // leaves would be B times the hole's area, so B = E and the radiance
    // E/π = 0.95 everywhere; the sun's patch and the corners make it
    // uneven, not unbounded.
    let m = every.mean().max_element();
    assert!(m > 0.8 && m < 1.3, "{m}");
}

#[test]
fn every_bounce_is_scale_invariant() {
    // 1 mm and 1 km: the same image to float noise; a power of two: bit for
    // bit. A hit that moves by a rounding error near an edge sends the rest
    // of its path elsewhere, and the longer the paths the more of them do:
    // in the furnace (ρ ≤ 0.9, ~10 bounces a path) the images still agree
    // to rel MSE 2·10⁻⁴ (two independent renders: ~3·10⁻²); in the white
    // room (~24 bounces) the means agree to their noise, not the pixels.
    type Build = fn(f32) -> (Scene, View);
    let cases: [(&str, Build, bool, Settings, f32); 2] = [
        (
            "furnace 0.9",
            |s| (furnace(Vec3::new(0.5, 0.7, 0.9), s * s, s), face_view(s)),
            true,
            settings(16, 16, Depth::Every, 9),
            0.005,
        ),
        (
            "white room",
            |s| (white_room(2.0, s), white_room_view(s)),
            false,
            // One render's mean has a standard error of ~0.8%; four seeds
            // averaged, 0.4%.
            settings(24, 64, Depth::Every, 9),
            0.02,
        ),
    ];
    for (name, build, per_pixel, st, tol) in cases {
        let seeds = if per_pixel { 1 } else { 4 };
        let render = |s: f32| -> Vec<Image> {
            let (scene, view) = build(s);
            (0..seeds)
                .map(|k| {
                    draw(
                        &scene,
                        &view,
                        &Settings {
                            seed: st.seed + k,
                            ..st.clone()
                        },
                    )
                })
                .collect()
        };
        let mean = |imgs: &[Image]| imgs.iter().map(Image::mean).sum::<Vec3>() / imgs.len() as f32;
        let base = render(1.0);
        assert!(mean(&base).x > 0.01);
        for s in [1e-3f32, 1e3, 1.0 / 1024.0] {
            let imgs = render(s);
            let e = rel_mse(&imgs[0], &base[0]);
            let ratio = mean(&imgs) / mean(&base);
            eprintln!("{name}, scale {s}: rel MSE {e:.2e}, mean ratio {ratio}");
            assert!(imgs.iter().all(Image::all_finite));
            if per_pixel {
                assert!(e < 1e-3, "{name}, scale {s}: rel MSE {e}");
            }
            assert!(
                (ratio - Vec3::ONE).abs().max_element() < tol,
                "{name}, scale {s}: mean ratio {ratio}"
            );
            if s == 1.0 / 1024.0 {
                assert_eq!(imgs, base, "{name}: a power-of-two scale is exact");
            }
        }
    }
}

#[test]
fn every_bounce_is_deterministic_across_thread_counts() {
    let (scene, view) = validation_corner(12);
    let st = settings(16, 8, Depth::Every, 2);
    let run = |threads: usize| {
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap();
        pool.install(|| stats_render(&scene, &view, &st))
    };
    let (a, sa) = run(1);
    let (b, sb) = run(2);
    assert_eq!(fingerprint(&a), fingerprint(&b));
    assert_eq!(sa, sb);
    let other = draw(&scene, &view, &Settings { seed: 3, ..st });
    assert_ne!(fingerprint(&a), fingerprint(&other));
}

#[test]
fn more_bounces_add_light_and_every_bounce_bounds_them() {
    // The open validation corner: each bounce adds light; every bounce ≥ three.
    // With one sample per pixel, Bounces(3) and Every trace the same first
    // three bounces (no roulette before bounce 3), so per pixel Every only adds.
    let (scene, view) = validation_corner(12);
    let mut prev = draw(&scene, &view, &settings(16, 1, Depth::Direct, 8));
    for depth in [
        Depth::OneBounce,
        Depth::Bounces(2),
        Depth::Bounces(3),
        Depth::Every,
    ] {
        let img = draw(&scene, &view, &settings(16, 1, depth, 8));
        for (k, (p, q)) in img.pixels.iter().zip(&prev.pixels).enumerate() {
            assert!(
                (*p - *q).min_element() >= -1e-6 * q.max_element(),
                "{depth:?}, pixel {k}: {p} < {q}"
            );
        }
        prev = img;
    }
}

#[test]
fn hit_radiance_is_the_paths_radiance() {
    let scene = furnace(Vec3::splat(0.8), 1.0, 1.0);
    let rs = RayScene::build(&scene, 0.0);
    let hit = rs
        .intersect(Vec3::new(0.3, 0.2, 0.0), Vec3::NEG_Z, f32::INFINITY)
        .expect("the −Z face");
    let mut stats = PathStats::default();
    // Direct only: exactly the direct radiance.
    assert_eq!(
        hit_radiance(&rs, &hit, Depth::Direct, 1, &mut stats),
        gibake_reference::direct_radiance(&rs, &hit)
    );
    // Every bounce, averaged over seeds, against the rendered pixel there
    // (a tiny orthographic footprint around the same point).
    let n = 20_000u64;
    let mut sum = DVec3::ZERO;
    for seed in 0..n {
        sum += hit_radiance(&rs, &hit, Depth::Every, seed, &mut stats).as_dvec3();
    }
    let mean = sum / n as f64;
    let view = View::look_at(
        Vec3::new(0.3, 0.2, 0.0),
        Vec3::new(0.3, 0.2, -1.0),
        Vec3::Y,
        Projection::Orthographic {
            xmag: 1e-4,
            ymag: 1e-4,
            znear: 0.0,
            zfar: 1.0,
        },
    );
    let img = draw(&scene, &view, &settings(2, 4096, Depth::Every, 5));
    let rel = (mean - img.mean().as_dvec3()).abs() / mean;
    eprintln!(
        "hit_radiance {mean:.4}, render {}, rel {rel:.5}",
        img.mean()
    );
    assert!(rel.max_element() < 0.02, "{mean} vs {}", img.mean());
    assert_eq!(stats.paths, 0);
    assert!(stats.bounces > n);
}

#[test]
fn too_many_bounces_is_an_error() {
    let scene = furnace(Vec3::splat(0.5), 1.0, 1.0);
    let rs = RayScene::build(&scene, 0.0);
    let e = render_view(
        &rs,
        &face_view(1.0),
        &settings(4, 1, Depth::Bounces(MAX_BOUNCES + 1), 0),
        &|_| {},
    )
    .unwrap_err();
    assert!(matches!(e, ReferenceError::TooManyBounces { .. }), "{e}");
    assert!(e.to_string().contains("at most 1024"), "{e}");
    render_view(
        &rs,
        &face_view(1.0),
        &settings(4, 1, Depth::Bounces(MAX_BOUNCES), 0),
        &|_| {},
    )
    .expect("the cap itself is allowed");
}
