//! Bevy renders the example's level headless on lavapipe (an
//! `Rgba16Float` image target, no tone mapping, no dither, an exposure of
//! 1): the light the plugin adds, Bevy's G-buffer as gibake rebuilds it,
//! Bevy's own sun, and a re-bake reaching the running app, each against
//! gibake itself.

use std::sync::{Arc, Mutex};

use bevy::prelude::*;
use bevy::render::renderer::{RenderDevice, RenderQueue};
use bevy::render::{Render, RenderApp, RenderSystems};
use gibake_bevy::gibake_runtime::{
    self, CameraMatrices, FrameInput, Mode, RenderSettings, Renderer, ViewId, wgpu,
};
use gibake_bevy::{GibakeObject, GibakeRender};

use crate::common::{self, EYE, FOV_DEG, Game, H, Root, TARGET, W};

fn mean(p: &[[f32; 3]]) -> f32 {
    p.iter().map(|c| (c[0] + c[1] + c[2]) / 3.0).sum::<f32>() / p.len() as f32
}

/// How far `got` is from `want`, relative to `want`'s mean: the mean
/// absolute difference, and the 99th percentile of the per-pixel one.
fn difference(got: &[[f32; 3]], want: &[[f32; 3]]) -> (f32, f32) {
    let m = mean(want).max(1e-9);
    let mut d: Vec<f32> = got
        .iter()
        .zip(want)
        .map(|(a, b)| (0..3).map(|c| (a[c] - b[c]).abs()).sum::<f32>() / 3.0 / m)
        .collect();
    let mean_d = d.iter().sum::<f32>() / d.len() as f32;
    d.sort_by(f32::total_cmp);
    (mean_d, d[d.len() * 99 / 100])
}

/// The plugin's GPU time per pass (its renderer's `poll_stats` in Bevy's
/// frame) next to `gibake render`'s for the same view, in the same run,
/// and the wall time of Bevy's whole frame with gibake on and off. The
/// plugin records gibake's own passes and no others (its G-buffer pass is
/// the rebuild from Bevy's prepass), and adds into Bevy's target in place
/// of gibake's composite.
fn frame_cost(root: &Root, plugin: &gibake_runtime::FrameStats, on_ms: f64, off_ms: f64) {
    let (render, render_wall) = root.render_stats("indirect", 3);
    eprintln!("frame cost, {W}x{H} ({}; ms per pass):", plugin.timing);
    eprintln!("  {:<14} {:>10} {:>14}", "pass", "plugin", "gibake render");
    let mut names: Vec<&str> = render.iter().map(|(n, _)| n.as_str()).collect();
    for (p, _) in &plugin.passes {
        if !names.contains(&p.name()) {
            names.push(p.name());
        }
    }
    for n in &names {
        let a: f64 = plugin
            .passes
            .iter()
            .filter(|(p, _)| p.name() == *n)
            .map(|(_, ms)| ms)
            .sum();
        let b: f64 = render
            .iter()
            .filter(|(p, _)| p == n)
            .map(|(_, ms)| ms)
            .sum();
        eprintln!("  {n:<14} {a:>10.2} {b:>14.2}");
    }
    let total: f64 = render.iter().map(|(_, ms)| ms).sum();
    eprintln!(
        "  {:<14} {:>10.2} {:>14.2}",
        "total", plugin.frame_ms, total
    );
    eprintln!(
        "wall: Bevy's whole frame {on_ms:.1} ms with gibake, {off_ms:.1} ms without \
         (the plugin: {:.1} ms); gibake render's frame {render_wall:.1} ms",
        on_ms - off_ms
    );
    // Bevy asks for every feature the adapter has (its default
    // `WgpuSettingsPriority::Functionality`): timestamp queries where
    // `gibake render` has them. The same passes: the plugin does gibake's
    // work (its composite adds into Bevy's target).
    if render.iter().any(|(_, ms)| *ms > 0.0) {
        assert_eq!(plugin.timing, gibake_runtime::Timing::GpuTimestamps);
        let has = |n: &str| plugin.passes.iter().any(|(p, _)| p.name() == n);
        for (n, _) in &render {
            assert!(
                has(n),
                "gibake render's pass {n} is not in the plugin's frame"
            );
        }
    }
}

fn sub(a: &[[f32; 3]], b: &[[f32; 3]]) -> Vec<[f32; 3]> {
    a.iter()
        .zip(b)
        .map(|(x, y)| [x[0] - y[0], x[1] - y[1], x[2] - y[2]])
        .collect()
}

/// Bevy's frame with gibake off, then on: the difference is the light the
/// plugin added. It is `gibake render --mode indirect --ssaa 1` of the
/// same camera and time (Bevy's tone mapping and dither off, an exposure
/// of 1), to within what two renderers of the same level may differ by:
/// Bevy's depth and normal prepass (normals in 10 bits) and its deferred
/// albedo (8-bit sRGB-like) in place of gibake's own G-buffer, and the
/// `Rgba16Float` target. The added light is all of the
/// reference (a plugin adding nothing fails), and Bevy's own frame with
/// gibake off is its sun, which is `gibake render --mode direct` on the
/// surfaces it lights (units and direction of the light the plugin
/// spawned: a wrong one is off by far more; Bevy's specular term, which
/// gibake's Lambertian materials lack, is what differs).
#[test]
fn the_light_the_plugin_adds_is_gibake_renders_indirect() {
    let _gpu = common::serial();
    let root = Root::new("indirect");
    let reference = root.render("indirect", "indirect.exr");
    let direct = root.render("direct", "direct.exr");
    let mut game = Game::new(&root);
    game.settings().enabled = false;
    let off = game.settle("gibake off", |_| true);
    let off_ms = game.frame_wall_ms(4);
    game.settings().enabled = true;
    let on = game.settle("gibake on", |r| r.frames > 2);
    let added = sub(&on, &off);
    let plugin_stats = game.report().stats.expect("the plugin's per-pass times");
    let on_ms = game.frame_wall_ms(4);
    common::picture("bevy_off.png", &off, 1.0);
    common::picture("bevy_on.png", &on, 1.0);
    common::picture("bevy_added.png", &added, 4.0);
    common::picture("gibake_indirect.png", &reference, 4.0);
    common::picture("gibake_direct.png", &direct, 1.0);

    frame_cost(&root, &plugin_stats, on_ms, off_ms);

    let (ma, mr) = (mean(&added), mean(&reference));
    eprintln!("mean added {ma:.5}, mean gibake render --mode indirect {mr:.5}");
    assert!(mr > 0.0, "the reference has indirect light");
    assert!(
        (ma / mr - 1.0).abs() < 0.01,
        "the plugin added {ma:.5} on average, gibake renders {mr:.5}"
    );
    let (d, p99) = difference(&added, &reference);
    common::picture(
        "difference.png",
        &added
            .iter()
            .zip(&reference)
            .map(|(a, b)| {
                [
                    (a[0] - b[0]).abs(),
                    (a[1] - b[1]).abs(),
                    (a[2] - b[2]).abs(),
                ]
            })
            .collect::<Vec<_>>(),
        4.0,
    );
    eprintln!(
        "added vs indirect: mean |difference| {d:.4}, 99th percentile {p99:.4} (of the mean)"
    );
    // Silhouettes that the two rasterizations (Bevy's prepass, gibake's
    // G-buffer pass) cover differently are the largest differences.
    assert!(d < 0.01, "mean difference {d:.4} of the mean");
    assert!(p99 < 0.1, "99th percentile {p99:.4} of the mean");

    // Bevy's sun against gibake's direct light, on the pixels gibake's
    // lights (and well inside: not at a shadow's edge).
    let lit: Vec<usize> = (0..direct.len())
        .filter(|&i| {
            let (x, y) = (i as u32 % W, i as u32 / W);
            direct[i][0] > 0.05
                && x > 0
                && y > 0
                && x + 1 < W
                && y + 1 < H
                && [i - 1, i + 1, i - W as usize, i + W as usize]
                    .iter()
                    .all(|&j| direct[j][0] > 0.05)
        })
        .collect();
    assert!(lit.len() > 200, "{} lit pixels", lit.len());
    let mut ratio: Vec<f32> = lit
        .iter()
        .map(|&i| {
            (off[i][0] + off[i][1] + off[i][2]) / (direct[i][0] + direct[i][1] + direct[i][2])
        })
        .collect();
    ratio.sort_by(f32::total_cmp);
    let q = |f: f32| ratio[((ratio.len() - 1) as f32 * f) as usize];
    let (q10, q25, median, q90) = (q(0.1), q(0.25), q(0.5), q(0.9));
    eprintln!(
        "Bevy's sun / gibake's direct on {} lit pixels: 10% {q10:.3}, 25% {q25:.3}, median {median:.3}, 90% {q90:.3}",
        lit.len()
    );
    // Bevy's diffuse (Burley's: at roughness 0.5, with the sun high and
    // the camera not grazing, within a few % of Lambert's) is gibake's
    // Lambert where Bevy's GGX specular adds little (the low end); the specular term of the floor's roughness 0.5, F0 0.04
    // (the sun's reflection off the floor towards the camera) only adds.
    // A unit slip (π, 4π, lux against W/m²) is off by 3× or more.
    assert!(
        (q10 - 1.0).abs() < 0.05,
        "10th percentile of the ratio {q10:.3}"
    );
    assert!((1.0..1.2).contains(&median), "median ratio {median:.3}");
    // The camera's exposure: Bevy writes its lights exposed, and the plugin
    // adds gibake's light times the same exposure (`OutputTarget::AddScaled`):
    // half the exposure, half of both.
    game.app
        .world_mut()
        .entity_mut(game.camera)
        .insert(bevy::camera::Exposure {
            ev100: -(0.6f32).log2(),
        });
    game.skip(4);
    let on_half = game.settle("exposure 1/2, gibake on", |r| r.frames > 2);
    game.settings().enabled = false;
    game.skip(4);
    let off_half = game.settle("exposure 1/2, gibake off", |_| true);
    let added_half = mean(&sub(&on_half, &off_half)) / ma;
    let sun_half = mean(&off_half) / mean(&off);
    eprintln!("at half the exposure: gibake's light x{added_half:.4}, Bevy's sun x{sun_half:.4}");
    assert!(
        (added_half - 0.5).abs() < 0.01,
        "gibake's light x{added_half:.4}"
    );
    assert!((sun_half - 0.5).abs() < 0.01, "Bevy's sun x{sun_half:.4}");
}

/// The G-buffer gibake rebuilds from Bevy's prepass normals and deferred
/// albedo (the plugin's main view) against the one gibake draws itself for
/// the same camera (a renderer of its own on another device): the same
/// normals (Bevy's `n · 0.5 + 0.5` in `Rgb10a2Unorm`, repacked) and the
/// same albedo (Bevy's 8-bit `rgb^(1/2.2)`, repacked) wherever gibake's
/// own G-buffer has a surface. Shading reads Bevy's depth itself (its
/// prepass depth has no `COPY_SRC`: `gbuffer_positions` refuses it, checked
/// here); that the positions it rebuilds are gibake's own is what the
/// light the plugin adds equalling `gibake render`'s shows
/// (`the_light_the_plugin_adds_is_gibake_renders_indirect`).
#[test]
fn bevys_gbuffer_rebuilt_is_gibakes_own() {
    let _gpu = common::serial();
    let root = Root::new("gbuffer");
    let mut game = Game::new(&root);
    let slot: Arc<Mutex<Option<GBuffer>>> = Arc::default();
    let s = slot.clone();
    game.app.sub_app_mut(RenderApp).add_systems(
        Render,
        (move |r: Res<GibakeRender>, device: Res<RenderDevice>, queue: Res<RenderQueue>| {
            let Some(renderer) = r.renderer().filter(|_| r.active()) else {
                return;
            };
            let q: &wgpu::Queue = &queue;
            *s.lock().unwrap() = Some(gbuffer_of(renderer, device.wgpu_device(), q));
        })
        .in_set(RenderSystems::Cleanup),
    );
    game.settle("gibake on", |r| r.frames > 2);
    let bevy = slot.lock().unwrap().take().expect("the rebuilt G-buffer");

    // gibake's own G-buffer of the same view.
    let ctx = gibake_gpu::GpuContext::new(&Default::default()).expect("a GPU adapter");
    let asset = gibake_runtime::load_asset(&root.dir.join("living_room.gibake")).unwrap();
    let scene =
        gibake_runtime::load_scene_for(&root.dir.join(common::LEVEL), &asset, &Default::default())
            .unwrap();
    let settings = RenderSettings {
        width: W,
        height: H,
        mode: Mode::Indirect,
        interleave: 1,
        ..Default::default()
    };
    let mut r = Renderer::new(&ctx.device, &ctx.queue, &scene, Some(&asset), &settings).unwrap();
    let eye = Transform::from_translation(EYE.into()).looking_at(TARGET.into(), Vec3::Y);
    let camera = CameraMatrices::perspective(
        eye.to_matrix(),
        FOV_DEG.to_radians(),
        W as f32 / H as f32,
        0.05,
    );
    let transforms = gibake_runtime::scene_transforms(&scene, 0.0);
    r.prepare(
        &ctx.device,
        &ctx.queue,
        &FrameInput::new(camera).transforms(&transforms),
    )
    .unwrap();
    let mut enc = ctx.device.create_command_encoder(&Default::default());
    r.record(&mut enc);
    ctx.queue.submit([enc.finish()]);
    let own = gbuffer_of(&r, &ctx.device, &ctx.queue);
    let _ = ViewId::MAIN;

    let n = (W * H) as usize;
    // Bevy's depth cannot be read back: refused, with the reason.
    let refused = bevy.positions.as_ref().expect_err("Bevy's depth read back");
    assert!(refused.contains("COPY_SRC"), "{refused}");
    let own_positions = own
        .positions
        .as_ref()
        .expect("gibake's own depth reads back");
    let (mut covered, mut bad_normal, mut bad_albedo) = (0, 0, 0);
    let mut worst_albedo = 0f32;
    for i in 0..n {
        if own_positions[i][3] <= 0.5 {
            continue;
        }
        covered += 1;
        let (nb, ng) = (bevy.normals[i][0], own.normals[i][0]);
        if nb.dot(ng) < 0.995 {
            bad_normal += 1;
        }
        let d = (0..3)
            .map(|c| (bevy.albedo[i][c] - own.albedo[i][c]).abs())
            .fold(0f32, f32::max);
        worst_albedo = worst_albedo.max(d);
        if d > 0.01 {
            bad_albedo += 1;
        }
    }
    eprintln!(
        "{covered} pixels with a surface in gibake's own G-buffer; normals off by > 5.7°: {bad_normal}; albedo off by > 0.01: {bad_albedo} (worst {worst_albedo:.4})"
    );
    assert!(covered > n / 2, "{covered} of {n} pixels covered");
    // Silhouettes may rasterize a pixel apart; nothing else.
    assert!(bad_normal * 100 < covered, "{bad_normal} normals differ");
    assert!(bad_albedo * 100 < covered, "{bad_albedo} albedos differ");
}

/// A view's G-buffer read back: the positions shading rebuilds from the
/// depth it reads (Bevy's, or gibake's own), both normals and the linear
/// albedo decoded from gibake's packed layout.
struct GBuffer {
    /// `Err`: the depth cannot be read back (Bevy's prepass depth).
    positions: Result<Vec<[f32; 4]>, String>,
    normals: Vec<[Vec3; 2]>,
    albedo: Vec<[f32; 3]>,
}

fn gbuffer_of(r: &Renderer, device: &wgpu::Device, queue: &wgpu::Queue) -> GBuffer {
    let t = r.gbuffer_textures();
    let words = |t: &wgpu::Texture, bytes: u32| -> Vec<u32> {
        gibake_gpu::readback::read_texture_on(device, queue, t, 0, bytes)
            .expect("read back")
            .chunks_exact(4)
            .map(|b| u32::from_le_bytes([b[0], b[1], b[2], b[3]]))
            .collect()
    };
    GBuffer {
        positions: r
            .gbuffer_positions(device, queue)
            .map_err(|e| e.to_string()),
        normals: words(&t[1], 8)
            .chunks_exact(2)
            .map(|w| gibake_runtime::unpack_normals([w[0], w[1]]))
            .collect(),
        albedo: words(&t[2], 4)
            .into_iter()
            .map(gibake_runtime::unpack_albedo)
            .collect(),
    }
}

#[test]
fn a_rebake_reaches_the_running_app() {
    let _gpu = common::serial();
    let root = Root::new("rebake");
    let mut game = Game::new(&root);
    let before = game.settle("before the re-bake", |r| r.frames > 2);
    let old_reference = root.render("indirect", "old.exr");
    root.bake("6");
    let new_reference = root.render("indirect", "new.exr");
    let after = game.settle("after the re-bake", |r| r.reloads >= 1 && r.frames > 2);
    let report = game.report();
    assert_eq!(report.reloads, 1);
    assert_eq!(report.handles_kept, Some(true), "the lamp's handle is kept");
    assert_ne!(before, after, "the frame changed");
    // What gibake adds now: the frame less Bevy's own (its sun, re-spawned
    // from the new bake: twice as bright too).
    game.settings().enabled = false;
    let off = game.settle("gibake off after the re-bake", |_| true);
    let added = sub(&after, &off);
    let (d_new, _) = difference(&added, &new_reference);
    let (d_old, _) = difference(&added, &old_reference);
    eprintln!(
        "after the re-bake: mean |difference| {d_new:.4} from the new asset's render, {d_old:.4} from the old one's"
    );
    assert!(d_new < 0.01, "{d_new:.4}");
    assert!(d_old > 0.3, "{d_old:.4}: the old asset's light");
}

/// The runtime's objects as the plugin left them this frame: name,
/// shown, matrix.
type Objects = Arc<Mutex<Vec<(String, bool, Mat4)>>>;

fn watch_objects(game: &mut Game) -> Objects {
    let objects: Objects = Arc::default();
    let o = objects.clone();
    game.app.sub_app_mut(RenderApp).add_systems(
        Render,
        (move |r: Res<GibakeRender>| {
            let Some(renderer) = r.renderer() else {
                return;
            };
            *o.lock().unwrap() = renderer
                .objects()
                .map(|(h, name)| {
                    (
                        name.to_string(),
                        renderer.is_visible(h).unwrap(),
                        renderer.transform(h).unwrap(),
                    )
                })
                .collect();
        })
        .in_set(RenderSystems::Cleanup),
    );
    objects
}

fn matrix_of(game: &Game, e: Entity) -> Mat4 {
    game.app
        .world()
        .get::<GlobalTransform>(e)
        .expect("a GlobalTransform")
        .to_matrix()
}

/// Whether two frames are the same light (to 0.1% of the mean).
fn same_light(a: &[[f32; 3]], b: &[[f32; 3]]) -> bool {
    difference(a, b).0 < 1e-3
}

/// The level's moving lamp (the glTF node `Cylinder`) is its Bevy entity:
/// moved by its `Transform`, hidden by its `Visibility` (`set_visible`:
/// gibake's light without it, and back again when shown), and a copy the
/// game spawns (`GibakeObject::copy_of`) is a new runtime object
/// (`spawn`), gone when its entity is despawned (`remove`).
#[test]
fn moving_objects_follow_their_entities() {
    let _gpu = common::serial();
    let root = Root::new("objects");
    let mut game = Game::new(&root);
    let objects = watch_objects(&mut game);
    let start = game.settle("the lamp where the level has it", |r| r.frames > 2);
    let world = game.app.world_mut();
    let lamps: Vec<(Entity, GibakeObject)> = world
        .query::<(Entity, &GibakeObject)>()
        .iter(world)
        .map(|(e, o)| (e, o.clone()))
        .collect();
    assert_eq!(lamps.len(), 1, "{lamps:?}");
    let (lamp, tag) = lamps[0].clone();
    assert_eq!((tag.name(), tag.is_declared()), ("Cylinder", true));
    let seen = objects.lock().unwrap().clone();
    assert_eq!(seen.len(), 1);
    assert_eq!((seen[0].0.as_str(), seen[0].1), ("Cylinder", true));
    assert!(seen[0].2.abs_diff_eq(matrix_of(&game, lamp), 1e-5));

    // Moved: its new GlobalTransform is the runtime's, and the light changes.
    game.app
        .world_mut()
        .get_mut::<Transform>(lamp)
        .unwrap()
        .translation += Vec3::new(0.6, 0.0, 0.4);
    game.skip(4);
    let moved = game.settle("the lamp moved", |_| true);
    let seen = objects.lock().unwrap().clone();
    assert!(
        seen[0].2.abs_diff_eq(matrix_of(&game, lamp), 1e-5),
        "{seen:?}"
    );
    assert!(
        !same_light(&moved, &start),
        "moving the lamp changes the frame"
    );

    // Hidden, then shown again.
    game.app
        .world_mut()
        .entity_mut(lamp)
        .insert(Visibility::Hidden);
    game.skip(4);
    let hidden = game.settle("the lamp hidden", |_| true);
    assert!(!objects.lock().unwrap()[0].1, "hidden in the runtime");
    assert!(
        !same_light(&hidden, &moved),
        "hiding the lamp changes the frame"
    );
    game.app
        .world_mut()
        .entity_mut(lamp)
        .insert(Visibility::Inherited);
    game.skip(4);
    let shown = game.settle("the lamp shown again", |_| true);
    assert!(objects.lock().unwrap()[0].1, "shown in the runtime");
    assert!(
        same_light(&shown, &moved),
        "shown again: the frame before hiding"
    );

    // A copy spawned by the game, then despawned.
    let at = Transform::from_xyz(-1.5, 0.0, 1.0);
    let copy = game
        .app
        .world_mut()
        .spawn((GibakeObject::copy_of("Cylinder"), at))
        .id();
    game.skip(4);
    let with_copy = game.settle("a copy of the lamp", |_| true);
    let seen = objects.lock().unwrap().clone();
    assert_eq!(seen.len(), 2, "{seen:?}");
    assert!(seen[1].2.abs_diff_eq(at.to_matrix(), 1e-5), "{seen:?}");
    assert!(
        !same_light(&with_copy, &moved),
        "the copy changes the frame"
    );
    game.app.world_mut().despawn(copy);
    game.skip(4);
    let without = game.settle("the copy despawned", |_| true);
    assert_eq!(objects.lock().unwrap().len(), 1, "removed from the runtime");
    assert!(
        same_light(&without, &moved),
        "despawned: the frame before it"
    );
}

/// `GibakeMode::Everything` with Bevy's own lights hidden: the frame is
/// gibake's alone, direct light and shadows included, and it is `gibake
/// render --mode full --ssaa 1` of the same camera.
#[test]
fn everything_mode_is_gibake_renders_full() {
    let _gpu = common::serial();
    let root = Root::new("full");
    let reference = root.render("full", "full.exr");
    let mut game = Game::new(&root);
    game.settings().mode = gibake_bevy::GibakeMode::Everything;
    // Bevy's lights (the ones the plugin spawned) hidden, once they exist.
    let start = std::time::Instant::now();
    loop {
        game.skip(1);
        let world = game.app.world_mut();
        let lights: Vec<Entity> = world
            .query_filtered::<Entity, With<gibake_bevy::GibakeLight>>()
            .iter(world)
            .collect();
        if !lights.is_empty() {
            for l in lights {
                world.entity_mut(l).insert(Visibility::Hidden);
            }
            break;
        }
        assert!(
            start.elapsed().as_secs() < 300,
            "the level's lights never came"
        );
    }
    game.skip(4);
    let frame = game.settle("everything", |r| r.frames > 2);
    common::picture("bevy_everything.png", &frame, 1.0);
    let (mf, mr) = (mean(&frame), mean(&reference));
    let (d, p99) = difference(&frame, &reference);
    eprintln!(
        "everything: mean {mf:.5} against gibake render --mode full {mr:.5}; mean |difference| {d:.4}, 99th percentile {p99:.4} (of the mean)"
    );
    assert!((mf / mr - 1.0).abs() < 0.01, "{mf:.5} against {mr:.5}");
    assert!(d < 0.01, "mean difference {d:.4} of the mean");
    assert!(p99 < 0.1, "99th percentile {p99:.4} of the mean");
}
