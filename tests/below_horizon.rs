//! Issue 49, item 3: the light a VPL sends below its own horizon. Two
//! probe levels built here — a corridor with albedo-1 walls lit through
//! the windows of its west wall (the sills and jambs light the corridor
//! from clusters on the wall's sunlit outer face), and a closed room lit
//! through 16 small holes in its roof (the holes' walls light the room
//! from clusters on the roof's top) — their static part baked at 664 VPLs,
//! the GPU's indirect light at 48² pixel centres against the CPU
//! reference's one bounce there. The first map's rim answered those
//! receivers (open sky along the roof: +4.0% and +7.4%); each such VPL's
//! second map, from its second origin on the texels that send the light
//! (`gibake_bake::horizon`), does now (−2.1% and −1.5%). And the CPU twin
//! of the shader's lookup, second maps included, gives the GPU's image.
//! Item 2: the roof-holes room's hot spots by budget.

use crate::common;

use gibake_scene::{LoadOptions, Scene};
use gibake_scenegen::geom::aabox;
use gibake_scenegen::gltf::Builder;
use glam::{DVec3, Vec3};

/// A box from `lo` to `hi` of albedo `a`.
fn boxed(b: &mut Builder, name: &str, lo: [f64; 3], hi: [f64; 3], a: f32) {
    let g = aabox(DVec3::from_array(lo), DVec3::from_array(hi), 1, true);
    b.static_mesh(name, &g, [a; 3]);
}

/// Adds the sun (azimuth and elevation in degrees: the direction towards
/// it is (cos e sin a, sin e, −cos e cos a)) and a camera, and loads it.
fn finish(
    mut b: Builder,
    name: &str,
    sun: (f64, f64),
    eye: [f64; 3],
    target: [f64; 3],
    fov: f64,
) -> Scene {
    let (az, el) = (sun.0.to_radians(), sun.1.to_radians());
    let toward = DVec3::new(el.cos() * az.sin(), el.sin(), -el.cos() * az.cos());
    b.directional("sun", toward * 50.0, -toward, [1.0; 3], 3.0);
    b.perspective(
        "camera",
        DVec3::from_array(eye),
        DVec3::from_array(target),
        fov.to_radians(),
        0.05,
        200.0,
    );
    let dir = tempfile::tempdir().expect("a temporary directory");
    let path = dir.path().join(format!("{name}.glb"));
    std::fs::write(&path, b.finish()).expect("write the scene");
    gibake_scene::load(&path, &LoadOptions::default()).expect("load the scene")
}

/// A 30 m corridor, 4 m wide and 3 m high, walls and ceiling of albedo 1,
/// its west wall (0.3 m thick) with a 1 m window every 4 m from 1.2 m to
/// 2.4 m, a sun low in the west.
fn corridor() -> Scene {
    let mut b = Builder::new(1.0, "none");
    let t = 0.3;
    boxed(&mut b, "floor", [-2.0, -t, -15.0], [2.0, 0.0, 15.0], 0.5);
    boxed(
        &mut b,
        "ceiling",
        [-2.0, 3.0, -15.0],
        [2.0, 3.0 + t, 15.0],
        1.0,
    );
    boxed(&mut b, "east", [2.0, 0.0, -15.0], [2.0 + t, 3.0, 15.0], 1.0);
    let zs: Vec<f64> = (0..8).map(|k| -15.0 + 4.0 * k as f64).collect();
    for (k, w) in zs.windows(2).enumerate() {
        let (z0, z1) = (w[0], w[1]);
        boxed(
            &mut b,
            &format!("west{k}a"),
            [-2.0 - t, 0.0, z0],
            [-2.0, 3.0, z1 - 1.0],
            1.0,
        );
        boxed(
            &mut b,
            &format!("west{k}b"),
            [-2.0 - t, 0.0, z1 - 1.0],
            [-2.0, 1.2, z1],
            1.0,
        );
        boxed(
            &mut b,
            &format!("west{k}c"),
            [-2.0 - t, 2.4, z1 - 1.0],
            [-2.0, 3.0, z1],
            1.0,
        );
    }
    boxed(
        &mut b,
        "west_end",
        [-2.0 - t, 0.0, 13.0],
        [-2.0, 3.0, 15.0],
        1.0,
    );
    boxed(
        &mut b,
        "north",
        [-2.0 - t, 0.0, -15.0 - t],
        [2.0 + t, 3.0, -15.0],
        1.0,
    );
    boxed(
        &mut b,
        "south",
        [-2.0 - t, 0.0, 15.0],
        [2.0 + t, 3.0, 15.0 + t],
        1.0,
    );
    finish(
        b,
        "corridor",
        (270.0, 35.0),
        [0.5, 1.6, 12.0],
        [0.0, 1.4, -6.0],
        70.0,
    )
}

/// A closed 12 m room of albedo 0.8, 4 m high, lit only through 16 holes
/// of 0.4 m in its 0.4 m roof, a block on its floor.
fn roof_holes() -> Scene {
    let mut b = Builder::new(1.0, "none");
    let (a, t) = (0.8, 0.3);
    boxed(&mut b, "floor", [-6.0, -t, -6.0], [6.0, 0.0, 6.0], a);
    boxed(
        &mut b,
        "wall_n",
        [-6.0 - t, 0.0, -6.0 - t],
        [6.0 + t, 4.0, -6.0],
        a,
    );
    boxed(
        &mut b,
        "wall_s",
        [-6.0 - t, 0.0, 6.0],
        [6.0 + t, 4.0, 6.0 + t],
        a,
    );
    boxed(&mut b, "wall_w", [-6.0 - t, 0.0, -6.0], [-6.0, 4.0, 6.0], a);
    boxed(&mut b, "wall_e", [6.0, 0.0, -6.0], [6.0 + t, 4.0, 6.0], a);
    let mut xs = vec![-6.0];
    for c in [-4.5, -1.5, 1.5, 4.5] {
        xs.extend([c - 0.2, c + 0.2]);
    }
    xs.push(6.0);
    for i in 0..xs.len() - 1 {
        for j in 0..xs.len() - 1 {
            if i % 2 == 1 && j % 2 == 1 {
                continue; // a hole
            }
            boxed(
                &mut b,
                &format!("roof{i}_{j}"),
                [xs[i], 4.0, xs[j]],
                [xs[i + 1], 4.4, xs[j + 1]],
                a,
            );
        }
    }
    let g = aabox(
        DVec3::new(-1.0, 0.0, -1.0),
        DVec3::new(1.0, 1.2, 1.0),
        1,
        true,
    );
    b.static_mesh("block", &g, [0.6, 0.5, 0.4]);
    finish(
        b,
        "roof_holes",
        (40.0, 70.0),
        [4.5, 1.6, 4.5],
        [-3.0, 2.5, -3.0],
        75.0,
    )
}

/// The GPU's indirect light of `scene` baked as `asset`, `size²` pixels,
/// every VPL at every pixel.
fn indirect(
    ctx: &gibake_gpu::GpuContext,
    scene: &Scene,
    asset: &gibake_asset::Asset,
    size: u32,
    time: f32,
) -> gibake_image::Image {
    let settings = gibake_runtime::RenderSettings {
        width: size,
        height: size,
        mode: gibake_runtime::Mode::Indirect,
        interleave: 1,
        ..Default::default()
    };
    gibake_eval::frame::render_image(
        &ctx.device,
        &ctx.queue,
        scene,
        Some(asset),
        &settings,
        time,
        1,
    )
    .expect("render")
}

/// (GPU, the CPU twin of its lookup, the reference's one bounce): the
/// indirect radiance summed over the channels of the `size²` pixel centres.
fn judge(scene: &Scene) -> (f64, f64, f64, usize) {
    let ctx = common::gpu();
    let asset = gibake_eval::bake(&ctx, scene, &Default::default()).expect("bake");
    let (size, time) = (48u32, 0.5);
    let gpu = indirect(&ctx, scene, &asset, size, time);
    let rays = gibake_reference::RayScene::build(scene, time);
    let view = gibake_reference::View::from_scene(scene, time).expect("a camera");
    let twin = gibake_eval::transport::TwinVpls::of_asset(&asset);
    let maps = gibake_eval::transport::TwinMaps::of_asset(&asset);
    let (mut g, mut m, mut r) = (0.0f64, 0.0f64, 0.0f64);
    for y in 0..size {
        for x in 0..size {
            let (o, d, t0) = view.primary_ray(size, size, x as f32 + 0.5, y as f32 + 0.5);
            let Some(h) = rays.intersect_range(o, d, t0, f32::INFINITY) else {
                continue;
            };
            let (p, ns, ng) = (h.position, h.shading_normal, h.geometric_normal);
            let e: Vec3 = twin
                .terms(p, ns, ng)
                .map(|(i, t)| t.with_visibility(maps.visibility(&twin, i, p, ng)))
                .sum();
            m += f64::from((h.albedo / std::f32::consts::PI * e).element_sum());
            g += f64::from(gpu.get(x, y).element_sum());
            let mut l = Vec3::ZERO;
            gibake_eval::bounce::one_bounce_samples(&rays, &h, y * size + x, 16, |_, s| l += s);
            r += f64::from((h.albedo * l / 256.0).element_sum());
        }
    }
    let second = asset.vpl_lower.iter().filter(|l| l.is_some()).count();
    (g, m, r, second)
}

#[test]
fn light_below_a_vpls_horizon_is_within_3_5_percent_of_the_reference_on_white_walls() {
    for (name, scene) in [("corridor", corridor()), ("roof holes", roof_holes())] {
        let (gpu, twin, reference, second) = judge(&scene);
        let bias = gpu / reference - 1.0;
        eprintln!(
            "{name}: GPU indirect {gpu:.4e}, its lookup on the CPU {twin:.4e}, reference one bounce {reference:.4e}: {:+.1}% ({second} VPLs with a second origin)",
            bias * 100.0
        );
        assert!(second > 0, "{name}: no VPL has a second origin");
        assert!(
            bias.abs() < 0.035,
            "{name}: the GPU's indirect light is {:+.1}% against the reference",
            bias * 100.0
        );
        assert!(
            (gpu / twin - 1.0).abs() < 1e-3,
            "{name}: the GPU {gpu} and its lookup on the CPU {twin} differ"
        );
    }
}

/// Per pixel of the `size²` centres (row-major; `None` where no surface):
/// the GPU's indirect radiance and the reference's one bounce, summed over
/// the channels, for `scene` baked at `vpls`.
fn per_pixel(scene: &Scene, vpls: u32, size: u32) -> Vec<Option<(f64, f64)>> {
    let ctx = common::gpu();
    let s = gibake_eval::EvalSettings {
        vpls,
        ..Default::default()
    };
    let asset = gibake_eval::bake(&ctx, scene, &s).expect("bake");
    let time = 0.5;
    let gpu = indirect(&ctx, scene, &asset, size, time);
    let rays = gibake_reference::RayScene::build(scene, time);
    let view = gibake_reference::View::from_scene(scene, time).expect("a camera");
    (0..size * size)
        .map(|p| {
            let (x, y) = (p % size, p / size);
            let (o, d, t0) = view.primary_ray(size, size, x as f32 + 0.5, y as f32 + 0.5);
            let h = rays.intersect_range(o, d, t0, f32::INFINITY)?;
            let mut l = Vec3::ZERO;
            gibake_eval::bounce::one_bounce_samples(&rays, &h, p, 16, |_, s| l += s);
            let r = f64::from((h.albedo * l / 256.0).element_sum());
            Some((f64::from(gpu.get(x, y).element_sum()), r))
        })
        .collect()
}

/// Issue 49, item 2: hot spots round small openings. The room lit through
/// 16 roof holes put radiance up to 9.4 where the reference has 0.15 at
/// the default budget (a VPL beside the receivers round an opening). At
/// the default budget (256) and at 664 VPLs the brightest pixel is now
/// within 2× the reference's brightest (0.12 and 0.19 against 0.21). At 64
/// VPLs it was 0.68, 3.3×, until the finest near-field nodes whose texels
/// lie on two surfaces a step apart (a roof's top and the floor seen
/// through its hole: a VPL four times the area spans both) moved onto the
/// surface carrying most of their light (`gibake_bake::near_field::
/// Anchors`; docs/method.md, "Finest nodes across a step"): 0.055, 0.3×.
/// Every budget is held to 2×.
#[test]
fn hot_spots_round_small_openings_by_budget() {
    let scene = roof_holes();
    let mut failed = Vec::new();
    for (vpls, bound) in [(64, 2.0), (256, 2.0), (664, 2.0)] {
        let px: Vec<(f64, f64)> = per_pixel(&scene, vpls, 40).into_iter().flatten().collect();
        let max_gpu = px.iter().map(|p| p.0).fold(0.0, f64::max);
        let max_ref = px.iter().map(|p| p.1).fold(0.0, f64::max);
        let mean = |f: fn(&(f64, f64)) -> f64| px.iter().map(f).sum::<f64>() / px.len() as f64;
        eprintln!(
            "{vpls} VPLs: brightest pixel {max_gpu:.3} against the reference's {max_ref:.3} ({:.1}×); mean {:.4} against {:.4}",
            max_gpu / max_ref,
            mean(|p| p.0),
            mean(|p| p.1),
        );
        if max_gpu >= bound * max_ref {
            failed.push(format!(
                "{vpls} VPLs: a hot spot of {max_gpu:.3} where the reference's brightest is {max_ref:.3} (bound {bound}×)"
            ));
        }
    }
    assert!(failed.is_empty(), "{}", failed.join("; "));
}
