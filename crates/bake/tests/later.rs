//! The later bounces (`gibake_bake::later`, issue 50) on cases with an
//! exact answer: a closed room of uniform albedo `ρ` lit by a point light
//! inside passes on `ρ` of the light at every bounce (nothing escapes), so
//! the light reflected after bounce `k` is `ρ^k` times the directly
//! reflected light and all of it `ρ/(1 − ρ)` times; the same at 1 mm and
//! 1 km. CPU only.

use gibake_bake::later::{Bounces, LaterOptions, later_bounces};
use gibake_raycast::RayScene;
use gibake_reference::scenes::{cuboid, material, point, static_scene};
use gibake_scene::Scene;
use glam::Vec3;

/// A closed room `[-1, 1] × [0, 2] × [-1.5, 1.5] · s` of albedo `a`, a
/// point light inside.
fn closed_room(a: f32, s: f32) -> Scene {
    let room = cuboid(
        "room",
        Vec3::new(-1.0, 0.0, -1.5) * s,
        Vec3::new(1.0, 2.0, 1.5) * s,
        0,
    );
    let i = 5.0 * s * s;
    static_scene(
        "closed_room",
        point(Vec3::new(0.2, 1.3, -0.4) * s, Vec3::splat(i)),
        vec![material("grey", Vec3::splat(a))],
        vec![room],
    )
}

fn options(bounces: Bounces) -> LaterOptions {
    LaterOptions {
        bounces,
        points: 4096,
        rays: 64,
        vpls: 32,
    }
}

#[test]
fn a_closed_room_passes_on_its_albedo_at_every_bounce() {
    for a in [0.5f32, 0.8] {
        let scene = closed_room(a, 1.0);
        let rays = RayScene::build(&scene, 0.0);
        let l = later_bounces(&rays, &options(Bounces::Count(6)), &[]);
        let sum = |v: Vec3| v.x + v.y + v.z;
        let direct = sum(l.direct);
        assert!(direct > 0.0);
        let mut prev = direct;
        for (k, b) in l.per_bounce.iter().enumerate() {
            let r = sum(*b) / prev;
            eprintln!("albedo {a}: bounce {}: ratio {r:.4}", k + 1);
            assert!(
                (r - a).abs() <= 0.02 * a,
                "albedo {a}: bounce {} passes on {r}",
                k + 1
            );
            prev = sum(*b);
        }
    }
}

/// Albedo 0.99 in a closed room: the light dies down only after hundreds of
/// bounces; the steady ratio between them lets the rest be added as a
/// geometric series: all the light the surfaces reflect after the first
/// bounce is `ρ/(1 − ρ)` times the direct light's reflection, 99 times,
/// to a few per cent, in a bounded time.
#[test]
fn albedo_099_converges_to_the_geometric_series() {
    let a = 0.99f32;
    let scene = closed_room(a, 1.0);
    let rays = RayScene::build(&scene, 0.0);
    let t = std::time::Instant::now();
    let l = later_bounces(&rays, &options(Bounces::Every), &[]);
    let took = t.elapsed().as_secs_f64();
    let sum = |v: Vec3| f64::from(v.x + v.y + v.z);
    let all: f64 = l.per_bounce.iter().map(|b| sum(*b)).sum::<f64>() + sum(l.tail);
    let ratio = all / sum(l.direct);
    let expected = f64::from(a) / (1.0 - f64::from(a));
    eprintln!(
        "albedo 0.99: {} bounces followed, tail {:?}, reflected after the first / direct {ratio:.2} (expected {expected:.2}), {took:.2} s",
        l.per_bounce.len(),
        l.tail
    );
    assert!(l.converged);
    assert!(l.tail != Vec3::ZERO, "the series' rest was not added");
    assert!(
        (ratio / expected - 1.0).abs() < 0.05,
        "{ratio} against {expected}"
    );
    assert!(l.vpls.iter().all(|v| v.flux.iter().all(|f| f.is_finite())));
}

/// Albedo 1 in a closed room has no finite answer (every bounce passes on
/// all the light): the bounces are cut at `MAX_BOUNCES`, the result says
/// so, and it stays finite.
#[test]
fn albedo_1_is_cut_at_the_bounce_cap_and_says_so() {
    let scene = closed_room(1.0, 1.0);
    let rays = RayScene::build(&scene, 0.0);
    let l = later_bounces(&rays, &options(Bounces::Every), &[]);
    assert!(!l.converged, "a closed white room converged");
    assert_eq!(
        l.per_bounce.len() as u32,
        gibake_bake::later::radiosity::MAX_BOUNCES
    );
    assert!(l.vpls.iter().all(|v| v.flux.iter().all(|f| f.is_finite())));
    assert!(l.per_bounce.iter().all(|b| b.is_finite()));
}

/// The same room in millimetres and in kilometres: the same bounces (light
/// per bounce over the direct light's), as many later VPLs, and the same
/// light from them at points of the room (each VPL a disk, no visibility),
/// scaled. (The VPLs themselves may part differently: a room this
/// symmetric scores many nodes the same, and rounding in other units
/// breaks such ties another way.)
#[test]
fn the_later_bounces_are_scale_invariant() {
    let run = |s: f32| {
        let scene = closed_room(0.8, s);
        let rays = RayScene::build(&scene, 0.0);
        later_bounces(&rays, &options(Bounces::Count(5)), &[])
    };
    // Irradiance at `x` (normal `n`, unit) from every VPL as a disk.
    let light = |l: &gibake_bake::later::Later, x: Vec3, n: Vec3| -> f32 {
        l.vpls
            .iter()
            .map(|v| {
                let (p, nv) = (Vec3::from_array(v.position), Vec3::from_array(v.normal));
                let d = x - p;
                let d2 = d.length_squared();
                let w = d / d2.sqrt();
                let (ce, cr) = (nv.dot(w).max(0.0), n.dot(-w).max(0.0));
                let r2 = v.area / std::f32::consts::PI;
                (v.flux[0] + v.flux[1] + v.flux[2]) / std::f32::consts::PI * ce * cr
                    / (d2 * d2 + r2 * r2).sqrt()
            })
            .sum()
    };
    let points = [
        (Vec3::new(0.3, 0.0, 0.2), Vec3::Y),
        (Vec3::new(-0.7, 0.0, -1.1), Vec3::Y),
        (Vec3::new(0.0, 2.0, 0.5), Vec3::NEG_Y),
        (Vec3::new(-1.0, 1.0, 0.0), Vec3::X),
        (Vec3::new(1.0, 0.5, 1.2), Vec3::NEG_X),
        (Vec3::new(0.2, 1.2, -1.5), Vec3::Z),
    ];
    let base = run(1.0);
    let sum = |v: Vec3| v.x + v.y + v.z;
    for s in [1e-3f32, 1e3] {
        let l = run(s);
        assert_eq!(l.surfels, base.surfels, "×{s}: surfels");
        assert_eq!(l.vpls.len(), base.vpls.len(), "×{s}: VPLs");
        for (k, (a, b)) in l.per_bounce.iter().zip(&base.per_bounce).enumerate() {
            let (ra, rb) = (sum(*a) / sum(l.direct), sum(*b) / sum(base.direct));
            assert!(
                (ra / rb - 1.0).abs() < 1e-3,
                "×{s}: bounce {}: {ra} against {rb}",
                k + 1
            );
        }
        for (x, n) in points {
            // Irradiance scales as flux over area: the direct light's flux
            // scales with s² (the light's intensity with s², as W/sr),
            // so the irradiance is the same.
            let (ea, eb) = (light(&l, x * s, n), light(&base, x, n));
            assert!(
                (ea / eb - 1.0).abs() < 0.03,
                "×{s}: at {x}: {ea} against {eb}"
            );
        }
    }
}

/// A closed dark room beside a lit one, one thin wall between them (the
/// floors coplanar, continuous under the wall): the later bounces put no
/// VPL in the dark room and none of its surfels receives light.
#[test]
fn no_later_light_leaks_through_a_thin_wall() {
    use gibake_reference::scenes::quad;
    // Lit room: x in [0, 4]; dark room: x in [-4, 0]; the wall at x = 0 is
    // a box 1 cm thick; one floor plane under both; a point light in the
    // lit room; everything closed.
    let mut meshes = vec![
        cuboid(
            "outer",
            Vec3::new(-4.0, -0.1, -2.0),
            Vec3::new(4.0, 2.5, 2.0),
            0,
        ),
        cuboid(
            "wall",
            Vec3::new(-0.005, 0.0, -2.0),
            Vec3::new(0.005, 2.5, 2.0),
            0,
        ),
    ];
    meshes.push(quad(
        "floor",
        Vec3::new(-4.0, 0.0, -2.0),
        Vec3::new(0.0, 0.0, 4.0),
        Vec3::new(8.0, 0.0, 0.0),
        0,
    ));
    let scene = static_scene(
        "two_rooms",
        point(Vec3::new(2.0, 1.5, 0.3), Vec3::splat(20.0)),
        vec![material("grey", Vec3::splat(0.7))],
        meshes,
    );
    let rays = RayScene::build(&scene, 0.0);
    let l = later_bounces(&rays, &options(Bounces::Every), &[]);
    assert!(!l.vpls.is_empty());
    let dark: Vec<_> = l.vpls.iter().filter(|v| v.position[0] < -0.01).collect();
    assert!(
        dark.is_empty(),
        "{} later VPLs in the dark room: {:?}",
        dark.len(),
        dark.iter().map(|v| v.position).collect::<Vec<_>>()
    );
}

/// The same closed room, its walls once as two triangles a face and once
/// as a 48 × 48 grid of squares a face (27 648 triangles, each given a
/// point with chance about 0.15 at 4096 points): the surfels stand for
/// the same area and pass on the same light. Each point of a triangle
/// smaller than a point's share used to stand for that triangle's area
/// alone, so a finely tessellated level lost most of its light (the city
/// diorama 23% of its sunlit reflection; here 85% of it); with the
/// points rounded triangle by triangle the area came within 1.5%, with
/// systematic sampling exactly.
#[test]
fn a_finely_tessellated_room_passes_on_what_a_coarse_one_does() {
    use gibake_reference::scenes::quad;
    let room = |k: u32| {
        let c = cuboid(
            "room",
            Vec3::new(-1.0, 0.0, -1.5),
            Vec3::new(1.0, 2.0, 1.5),
            0,
        );
        if k == 1 {
            return c;
        }
        // Each face (two triangles, corner at its first vertex) as k × k
        // quads.
        let mut mesh = c.clone();
        mesh.positions.clear();
        mesh.normals.clear();
        mesh.indices.clear();
        for f in c.indices.chunks_exact(6) {
            let p = |i: u32| c.positions[i as usize];
            // quad(): vertices corner, corner + u, corner + u + v, corner + v.
            let corner = p(f[0]);
            let (u, v) = (p(f[1]) - corner, p(f[2]) - p(f[1]));
            for j in 0..k {
                for i in 0..k {
                    let at = corner + u * (i as f32 / k as f32) + v * (j as f32 / k as f32);
                    let q = quad("cell", at, u / k as f32, v / k as f32, 0);
                    let base = mesh.positions.len() as u32;
                    mesh.positions.extend(q.positions);
                    mesh.normals.extend(q.normals);
                    mesh.indices.extend(q.indices.iter().map(|i| i + base));
                }
            }
        }
        mesh
    };
    let light = |l: &gibake_bake::later::Later| l.direct.x + l.direct.y + l.direct.z;
    let mut out = Vec::new();
    for k in [1u32, 48] {
        let mesh = room(k);
        let triangles = mesh.indices.len() / 3;
        let scene = static_scene(
            "closed_room",
            point(Vec3::new(0.2, 1.3, -0.4), Vec3::splat(5.0)),
            vec![material("grey", Vec3::splat(0.5))],
            vec![mesh],
        );
        let rays = RayScene::build(&scene, 0.0);
        let surfels = gibake_bake::later::surfels::place(&rays, 4096);
        let area: f32 = surfels.area.iter().sum();
        let l = later_bounces(&rays, &options(Bounces::Count(3)), &[]);
        eprintln!(
            "{triangles} triangles: {} surfels, area {area:.2}, direct reflection {:.4}, later {:?}",
            surfels.len(),
            light(&l),
            l.per_bounce
        );
        out.push((area, light(&l), l.per_bounce[0]));
    }
    // Inside and outside: twice the room's 32 m² of walls.
    for (area, _, _) in &out {
        assert!(
            (area / 64.0 - 1.0).abs() < 0.005,
            "surfels stand for {area} m²"
        );
    }
    let (coarse, fine) = (out[0], out[1]);
    assert!(
        (fine.1 / coarse.1 - 1.0).abs() < 0.02,
        "direct reflection {} finely tessellated against {}",
        fine.1,
        coarse.1
    );
    let (a, b) = (fine.2.element_sum(), coarse.2.element_sum());
    assert!((a / b - 1.0).abs() < 0.03, "second bounce {a} against {b}");
}
