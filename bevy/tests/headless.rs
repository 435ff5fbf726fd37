//! Bevy renders the example's level headless on lavapipe (an
//! `Rgba16Float` image target, no tone mapping, no dither, an exposure of
//! 1): the light the plugin adds, Bevy's G-buffer as gibake rebuilds it,
//! Bevy's own sun, and a re-bake reaching the running app, each against
//! gibake itself.

use std::sync::{Arc, Mutex};

use bevy::prelude::*;
use bevy::render::renderer::{RenderDevice, RenderQueue};
use bevy::render::{Render, RenderApp, RenderSystems};
use gibake_bevy::GibakeRender;
use gibake_bevy::gibake_runtime::{
    self, CameraMatrices, FrameInput, Mode, RenderSettings, Renderer, ViewId, wgpu,
};

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

/// [`difference`]'s 99th percentile, with each pixel of `got` compared
/// with the closest of `want`'s 3×3 pixels around it: an edge that two
/// rasterizations put a pixel apart (Bevy's prepass and gibake's own
/// G-buffer pass cover a silhouette's pixels by their own rules) is not a
/// difference in the light.
fn difference_one_pixel_apart(got: &[[f32; 3]], want: &[[f32; 3]]) -> f32 {
    let m = mean(want).max(1e-9);
    let (w, h) = (W as i32, H as i32);
    let mut d: Vec<f32> = (0..w * h)
        .map(|i| {
            let (x, y) = (i % w, i / w);
            let a = got[i as usize];
            let mut best = f32::INFINITY;
            for (dx, dy) in (-1..=1).flat_map(|dx| (-1..=1).map(move |dy| (dx, dy))) {
                let (u, v) = (x + dx, y + dy);
                if u < 0 || v < 0 || u >= w || v >= h {
                    continue;
                }
                let b = want[(v * w + u) as usize];
                best = best.min((0..3).map(|c| (a[c] - b[c]).abs()).sum::<f32>() / 3.0);
            }
            best / m
        })
        .collect();
    d.sort_by(f32::total_cmp);
    d[d.len() * 99 / 100]
}

fn sub(a: &[[f32; 3]], b: &[[f32; 3]]) -> Vec<[f32; 3]> {
    a.iter()
        .zip(b)
        .map(|(x, y)| [x[0] - y[0], x[1] - y[1], x[2] - y[2]])
        .collect()
}

/// Bevy's frame with gibake off, then on: the difference is the light the
/// plugin added. It is `gibake render --mode indirect` of the same camera
/// and time, to within what two renderers of the same level may differ
/// by: Bevy's depth and normal prepass (normals in 10 bits) and its
/// deferred albedo (8-bit sRGB-like) in place of gibake's own G-buffer,
/// and the `Rgba16Float` target. The added light is most of the
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
    game.settings().enabled = true;
    let on = game.settle("gibake on", |r| r.frames > 2);
    let added = sub(&on, &off);
    common::picture("bevy_off.png", &off, 1.0);
    common::picture("bevy_on.png", &on, 1.0);
    common::picture("bevy_added.png", &added, 4.0);
    common::picture("gibake_indirect.png", &reference, 4.0);
    common::picture("gibake_direct.png", &direct, 1.0);

    let (ma, mr) = (mean(&added), mean(&reference));
    eprintln!("mean added {ma:.5}, mean gibake render --mode indirect {mr:.5}");
    assert!(mr > 0.0, "the reference has indirect light");
    assert!(
        (ma / mr - 1.0).abs() < 0.03,
        "the plugin added {ma:.5} on average, gibake renders {mr:.5}"
    );
    let (d, p99) = difference(&added, &reference);
    common::picture(
        "difference.png",
        &added
            .iter()
            .zip(&reference)
            .map(|(a, b)| [(a[0] - b[0]).abs(), (a[1] - b[1]).abs(), (a[2] - b[2]).abs()])
            .collect::<Vec<_>>(),
        4.0,
    );
    let p99_shifted = difference_one_pixel_apart(&added, &reference);
    eprintln!(
        "added vs indirect: mean |difference| {d:.4}, 99th percentile {p99:.4}, \
         {p99_shifted:.4} a pixel apart (of the mean)"
    );
    assert!(d < 0.05, "mean difference {d:.4} of the mean");
    // Silhouettes a pixel apart aside, every pixel is close.
    assert!(p99_shifted < 0.2, "99th percentile {p99_shifted:.4} of the mean (a pixel apart)");

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
        .map(|&i| (off[i][0] + off[i][1] + off[i][2]) / (direct[i][0] + direct[i][1] + direct[i][2]))
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
    assert!((q10 - 1.0).abs() < 0.05, "10th percentile of the ratio {q10:.3}");
    assert!((1.0..1.2).contains(&median), "median ratio {median:.3}");
}

/// The G-buffer gibake rebuilds from Bevy's prepass depth, prepass normals
/// and deferred albedo (the plugin's main view) against the one gibake
/// draws itself for the same camera (a renderer of its own on another
/// device): the same world positions (Bevy's reversed-Z depth and
/// projection, its coordinate system and units are gibake's), the same
/// normals (Bevy's `n · 0.5 + 0.5` in `Rgb10a2Unorm`), the same albedo
/// (Bevy's 8-bit `rgb^(1/2.2)`).
#[test]
fn bevys_gbuffer_rebuilt_is_gibakes_own() {
    let _gpu = common::serial();
    let root = Root::new("gbuffer");
    let mut game = Game::new(&root);
    let slot: Arc<Mutex<Option<Vec<Vec<[f32; 4]>>>>> = Arc::default();
    let s = slot.clone();
    game.app.sub_app_mut(RenderApp).add_systems(
        Render,
        (move |r: Res<GibakeRender>, device: Res<RenderDevice>, queue: Res<RenderQueue>| {
            let Some(renderer) = r.renderer().filter(|_| r.active()) else {
                return;
            };
            let q: &wgpu::Queue = &queue;
            let g = renderer
                .gbuffer_textures()
                .iter()
                .map(|t| read(device.wgpu_device(), q, t))
                .collect();
            *s.lock().unwrap() = Some(g);
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
    let camera =
        CameraMatrices::perspective(eye.to_matrix(), FOV_DEG.to_radians(), W as f32 / H as f32, 0.05);
    let transforms = gibake_runtime::scene_transforms(&scene, 0.0);
    r.prepare(&ctx.device, &ctx.queue, &FrameInput::new(camera).transforms(&transforms))
        .unwrap();
    let mut enc = ctx.device.create_command_encoder(&Default::default());
    r.record(&mut enc);
    ctx.queue.submit([enc.finish()]);
    let own: Vec<Vec<[f32; 4]>> = r
        .gbuffer_textures()
        .iter()
        .map(|t| read(&ctx.device, &ctx.queue, t))
        .collect();
    let _ = ViewId::MAIN;

    let n = (W * H) as usize;
    let (mut both, mut one, mut far_pos, mut bad_normal, mut bad_albedo) = (0, 0, 0, 0, 0);
    let (mut worst_pos, mut worst_albedo) = (0f32, 0f32);
    let eye_pos = Vec3::from(EYE);
    for i in 0..n {
        let (pb, pg) = (bevy[0][i], own[0][i]);
        match (pb[3] > 0.5, pg[3] > 0.5) {
            (true, true) => both += 1,
            (false, false) => continue,
            _ => {
                one += 1;
                continue;
            }
        }
        let (xb, xg) = (Vec3::new(pb[0], pb[1], pb[2]), Vec3::new(pg[0], pg[1], pg[2]));
        let rel = (xb - xg).length() / (xg - eye_pos).length();
        worst_pos = worst_pos.max(rel);
        if rel > 1e-3 {
            far_pos += 1;
        }
        let nb = oct_decode(bevy[1][i][0], bevy[1][i][1]);
        let ng = oct_decode(own[1][i][0], own[1][i][1]);
        if nb.dot(ng) < 0.995 {
            bad_normal += 1;
        }
        let d = (0..3)
            .map(|c| (bevy[2][i][c] - own[2][i][c]).abs())
            .fold(0f32, f32::max);
        worst_albedo = worst_albedo.max(d);
        if d > 0.01 {
            bad_albedo += 1;
        }
    }
    eprintln!(
        "{both} pixels covered in both, {one} in one; positions off by > 1e-3 of the distance: {far_pos} (worst {worst_pos:.2e}); normals off by > 5.7°: {bad_normal}; albedo off by > 0.01: {bad_albedo} (worst {worst_albedo:.4})"
    );
    assert!(both > n / 2, "{both} of {n} pixels covered");
    // Silhouettes may rasterize a pixel apart; nothing else.
    assert!(one * 100 < both, "{one} pixels covered in one G-buffer only");
    assert!(far_pos * 100 < both, "{far_pos} positions differ");
    assert!(bad_normal * 100 < both, "{bad_normal} normals differ");
    assert!(bad_albedo * 100 < both, "{bad_albedo} albedos differ");
}

/// The octahedral decoding of gibake's `common.wgsl`.
fn oct_decode(x: f32, y: f32) -> Vec3 {
    let mut n = Vec3::new(x, y, 1.0 - x.abs() - y.abs());
    let t = (-n.z).max(0.0);
    n.x += if n.x >= 0.0 { -t } else { t };
    n.y += if n.y >= 0.0 { -t } else { t };
    n.normalize()
}

/// An `Rgba32Float` or `Rgba16Float` texture's texels.
fn read(device: &wgpu::Device, queue: &wgpu::Queue, t: &wgpu::Texture) -> Vec<[f32; 4]> {
    match t.format() {
        wgpu::TextureFormat::Rgba32Float => {
            gibake_gpu::readback::read_texture_f32_on(device, queue, t, 0, 4)
                .expect("read back")
                .chunks_exact(4)
                .map(|c| [c[0], c[1], c[2], c[3]])
                .collect()
        }
        wgpu::TextureFormat::Rgba16Float => {
            gibake_gpu::readback::read_texture_on(device, queue, t, 0, 8)
                .expect("read back")
                .chunks_exact(8)
                .map(|p| {
                    let h = |k: usize| common::f16(u16::from_le_bytes([p[2 * k], p[2 * k + 1]]));
                    [h(0), h(1), h(2), h(3)]
                })
                .collect()
        }
        f => panic!("unexpected G-buffer format {f:?}"),
    }
}

/// A re-bake while the app runs (the sun twice as bright, written by
/// `gibake bake` beside the old asset and swapped in): the plugin reloads
/// it through the asset server, the renderer takes it with `set_asset`
/// (the moving lamp's handle kept) and the next frames add the new
/// asset's light, which is `gibake render --mode indirect` of the new
/// asset (and not of the old one).
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
    eprintln!("after the re-bake: mean |difference| {d_new:.4} from the new asset's render, {d_old:.4} from the old one's");
    assert!(d_new < 0.05, "{d_new:.4}");
    assert!(d_old > 0.3, "{d_old:.4}: the old asset's light");
}
