//! The GPU clustering of dynamic VPLs against its CPU twin
//! (`gibake_bake::cluster::cluster_cut`) on the bundled corner scene with
//! its moving balls, and with the balls out of the light's reach (unit
//! tests of the crate's own passes).

use gibake_asset::Asset;
use gibake_bake::cluster::{Cluster, ClusterTarget, cluster_cut, cluster_cut_window};
use gibake_bake::rsm::{MIN_AREA_COSINE, Rsm};
use gibake_gpu::mesh::SceneGpu;
use gibake_gpu::{GpuContext, GpuPrimaryLight, LightView, readback};
use gibake_scene::{LightKind, LoadOptions, Scene};
use glam::{Mat4, Vec2, Vec3};
use wgpu::util::DeviceExt;

use super::{DynamicVplPass, GpuDynVpl, slot_count};
use crate::baked::BakedGpu;
use crate::dynamic_rsm::{DynamicRsmPass, OcclusionPass, Window, Windows};
use crate::plan::Pass;
use crate::stats::{FrameStats, Timer};

const MAX_VPLS: u32 = 64;

fn gpu() -> GpuContext {
    GpuContext::new(&Default::default()).unwrap_or_else(|e| {
        panic!(
            "this test needs a GPU adapter ({e}); on Debian/Ubuntu `apt-get install mesa-vulkan-drivers` \
             gives the lavapipe software GPU"
        )
    })
}

fn scene() -> Scene {
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../data/corner_bunny.glb");
    gibake_scene::load(&path, &LoadOptions::default()).expect("load corner_bunny.glb")
}

fn bake(ctx: &GpuContext, scene: &Scene) -> Asset {
    let opts = gibake_bake::BakeOptions {
        rsm_size: 128,
        vpl_map_size: 16,
        shadow_map_size: 256,
        target: ClusterTarget::Count(64),
        // The first bounce alone (what this checks).
        bounces: gibake_bake::later::Bounces::Count(1),
        later_vpls: None,
    };
    gibake_bake::bake(ctx, scene, &opts, &gibake_bake::NoProgress, "test")
        .expect("bake")
        .asset
}

/// Everything one frame of the dynamic VPLs needs.
struct Frame {
    baked: BakedGpu,
    light_buf: wgpu::Buffer,
    scene_gpu: SceneGpu,
    rsm: DynamicRsmPass,
    pass: DynamicVplPass,
    view: LightView,
    static_metric: Vec<f32>,
    threshold: f32,
}

impl Frame {
    /// Another clustering pass over this frame's RSM.
    fn pass(&self, ctx: &GpuContext, threshold: f32, max_vpls: u32) -> DynamicVplPass {
        let r = self.baked.rsm.as_ref().expect("RSM data");
        DynamicVplPass::new(
            &ctx.device,
            &self.rsm,
            &r.static_metric,
            &self.light_buf,
            threshold,
            max_vpls,
            0,
        )
    }
}

fn frame(ctx: &GpuContext, scene: &Scene, asset: &Asset, time: f32) -> Frame {
    let baked = BakedGpu::new(&ctx.device, &ctx.queue, asset).expect("upload the asset");
    let r = baked
        .rsm
        .as_ref()
        .expect("a scene with moving objects stores its RSM");
    let scene_gpu = SceneGpu::new(&ctx.device, &ctx.queue, scene, time);
    let rsm = DynamicRsmPass::new(&ctx.device, &scene_gpu, &r.view);
    let light_buf = ctx
        .device
        .create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some("primary light"),
            contents: bytemuck::bytes_of(&GpuPrimaryLight::new(scene.light())),
            usage: wgpu::BufferUsages::UNIFORM,
        });
    let threshold = asset.manifest.settings.threshold;
    let pass = DynamicVplPass::new(
        &ctx.device,
        &rsm,
        &r.static_metric,
        &light_buf,
        threshold,
        MAX_VPLS,
        0,
    );
    let static_metric = asset.rsm.as_ref().expect("RSM data").metric.clone();
    let view = r.view;
    Frame {
        baked,
        light_buf,
        scene_gpu,
        rsm,
        pass,
        view,
        static_metric,
        threshold,
    }
}

/// Runs the dynamic RSM and the clustering `pass` over `windows` (the whole
/// map when `None`); returns the slots.
fn run_pass(
    ctx: &GpuContext,
    f: &Frame,
    pass: &DynamicVplPass,
    windows: Option<Windows>,
    mut timer: Option<&mut Timer>,
) -> Vec<GpuDynVpl> {
    let windows = windows.unwrap_or(Windows::one(Window::whole(f.view.size)));
    pass.set_frame(&ctx.queue, pass.own_view(), 0, &windows);
    let mut enc = ctx.device.create_command_encoder(&Default::default());
    f.rsm
        .encode(&mut enc, &f.scene_gpu, &f.scene_gpu.dynamic_draws, None);
    if let Some(t) = timer.as_deref_mut() {
        t.begin(FrameStats::default(), vec![(Pass::DynamicVpls, None)]);
    }
    pass.encode_from(
        &mut enc,
        pass.own_view(),
        &windows,
        timer
            .as_deref()
            .and_then(|t| t.compute(Pass::DynamicVpls, None)),
    );
    if let Some(t) = timer.as_deref() {
        t.finish(&mut enc);
    }
    ctx.queue.submit([enc.finish()]);
    let bytes = readback::read_buffer(ctx, &pass.vpls).expect("read the slots");
    assert_eq!(bytes.len(), 48 * pass.slots() as usize);
    bytemuck::pod_collect_to_vec(&bytes)
}

fn run(ctx: &GpuContext, f: &Frame, timer: Option<&mut Timer>) -> Vec<GpuDynVpl> {
    run_pass(ctx, f, &f.pass, None, timer)
}

fn f16_to_f32(h: u16) -> f32 {
    let sign = if h & 0x8000 != 0 { -1.0 } else { 1.0 };
    let exp = i32::from((h >> 10) & 0x1f);
    let man = f32::from(h & 0x3ff);
    match exp {
        0 => sign * man * 2f32.powi(-24),
        31 if man == 0.0 => sign * f32::INFINITY,
        31 => f32::NAN,
        _ => sign * (1.0 + man / 1024.0) * 2f32.powi(exp - 15),
    }
}

/// CPU twin of `oct_decode` in common.wgsl.
fn oct_decode(e: Vec2) -> Vec3 {
    let mut n = Vec3::new(e.x, e.y, 1.0 - e.x.abs() - e.y.abs());
    let t = (-n.z).max(0.0);
    n.x += if n.x >= 0.0 { -t } else { t };
    n.y += if n.y >= 0.0 { -t } else { t };
    n.normalize()
}

/// The dynamic RSM read back as a CPU [`Rsm`] of the valid moving texels
/// (the rest: infinite metric, zero flux), with the bake's radiometry.
fn cpu_rsm(ctx: &GpuContext, scene: &Scene, f: &Frame) -> Rsm {
    let size = f.rsm.size;
    let pos = readback::read_texture_f32(ctx, &f.rsm.textures[0], 0, 4).expect("read positions");
    let half = |t: &wgpu::Texture| -> Vec<f32> {
        let b = readback::read_texture(ctx, t, 0, 8).expect("read a half-float target");
        b.chunks_exact(2)
            .map(|c| f16_to_f32(u16::from_le_bytes([c[0], c[1]])))
            .collect()
    };
    let albedo = half(&f.rsm.textures[1]);
    let normal = half(&f.rsm.textures[2]);
    let light = scene.light();
    let directional = matches!(light.kind, LightKind::Directional);
    let view = f.view;
    let n = (size * size) as usize;
    let mut rsm = Rsm::empty(size, view);
    for i in 0..n {
        let dm = pos[4 * i + 3];
        let sm = f.static_metric[i];
        // moving_in_front (occlusion.wgsl), in f32.
        let w = if directional {
            view.texel_scale
        } else {
            dm.min(sm) * view.texel_scale
        };
        if !(dm < 1.0e38 && dm < sm - 0.5 * w) {
            continue;
        }
        let p = Vec3::new(pos[4 * i], pos[4 * i + 1], pos[4 * i + 2]);
        let a = Vec3::new(albedo[4 * i], albedo[4 * i + 1], albedo[4 * i + 2]);
        let nrm = oct_decode(Vec2::new(normal[4 * i], normal[4 * i + 1]));
        let ns = oct_decode(Vec2::new(normal[4 * i + 2], normal[4 * i + 3]));
        let (dir, att) = if directional {
            (light.direction.normalize(), 1.0)
        } else {
            let d = (p - light.position).normalize();
            (d, light.spot_attenuation(d))
        };
        let measure = view.texel_measure(dir);
        let cos = nrm.dot(-dir).max(MIN_AREA_COSINE);
        let shading =
            (ns.dot(-dir).max(0.0) / nrm.dot(-dir).max(1.0e-30)).min(1.0 / MIN_AREA_COSINE);
        let flux = a * light.color * (att * measure * shading);
        let area = if directional {
            measure / cos
        } else {
            let d = (p - light.position).length();
            measure * d * d / cos
        };
        rsm.metric[i] = dm;
        rsm.position[i] = p;
        rsm.normal[i] = nrm;
        rsm.flux[i] = if flux.is_finite() { flux } else { Vec3::ZERO };
        rsm.area[i] = if area.is_finite() { area } else { 0.0 };
    }
    rsm
}

fn assert_all_finite(slots: &[GpuDynVpl]) {
    for (s, v) in slots.iter().enumerate() {
        for x in v.position.iter().chain(&v.normal).chain(&v.flux) {
            assert!(x.is_finite(), "slot {s}: {v:?}");
        }
    }
}

fn rel_close(a: f32, b: f32, rel: f32) -> bool {
    (a - b).abs() <= rel * a.abs().max(b.abs()) + 1e-30
}

fn compare(gpu: &[GpuDynVpl], cpu: &[Cluster], diagonal: f32) {
    let used: Vec<&GpuDynVpl> = gpu.iter().filter(|v| v.normal[3] > 0.5).collect();
    assert_eq!(
        used.len(),
        cpu.len(),
        "GPU and CPU cuts differ in VPL count"
    );
    let cos_1deg = 1f32.to_radians().cos();
    for (k, (g, c)) in used.iter().zip(cpu).enumerate() {
        let gp = Vec3::from_slice(&g.position[..3]);
        let gn = Vec3::from_slice(&g.normal[..3]);
        let gf = Vec3::from_slice(&g.flux[..3]);
        assert!(
            (gp - c.position).length() <= 1e-3 * diagonal,
            "VPL {k}: position {gp} vs {}",
            c.position
        );
        assert!(
            gn.dot(c.normal) >= cos_1deg,
            "VPL {k}: normal {gn} vs {}",
            c.normal
        );
        for ch in 0..3 {
            assert!(
                rel_close(gf[ch], c.flux[ch], 1e-3),
                "VPL {k}: flux {gf} vs {}",
                c.flux
            );
        }
        assert!(
            rel_close(g.position[3], c.area, 1e-3),
            "VPL {k}: area {} vs {}",
            g.position[3],
            c.area
        );
    }
}

#[test]
fn dynamic_vpls_match_the_cpu_cut() {
    let ctx = gpu();
    let scene = scene();
    assert!(!scene.dynamic_objects.is_empty());
    let asset = bake(&ctx, &scene);
    let f = frame(&ctx, &scene, &asset, 0.0);
    assert_eq!(f.pass.max_depth(), 3);
    assert_eq!(f.pass.slots(), 85);

    let mut timer = Timer::new(&ctx.device, &ctx.queue);
    let slots = run(&ctx, &f, Some(&mut timer));
    assert_all_finite(&slots);
    let st = timer.wait(&ctx.device);
    if st.timing == crate::Timing::GpuTimestamps {
        assert_eq!(st.passes.len(), 1);
        assert_eq!(st.passes[0].0, Pass::DynamicVpls);
        eprintln!("dynamic vpls: {:.3} ms (GPU timestamps)", st.passes[0].1);
    }
    // Empty slots are all zero.
    for v in slots.iter().filter(|v| v.normal[3] <= 0.5) {
        assert_eq!(*v, GpuDynVpl::default());
    }

    let rsm = cpu_rsm(&ctx, &scene, &f);
    let lit = (0..rsm.flux.len())
        .filter(|&i| rsm.metric[i].is_finite() && rsm.flux[i].max_element() > 0.0)
        .count();
    let cpu = cluster_cut(&rsm, f.threshold, f.pass.max_depth());
    let used = slots.iter().filter(|v| v.normal[3] > 0.5).count();
    eprintln!(
        "threshold {:e}: {lit} lit moving texels of {}², {used} dynamic VPLs in {} slots (CPU: {})",
        f.threshold,
        rsm.size,
        slots.len(),
        cpu.len()
    );
    assert!(lit > 0, "the balls reach the light at t = 0");
    assert!(used >= 2, "the balls make several VPLs");
    compare(&slots, &cpu, scene.full_bounds().diagonal());

    // All the moving flux is in the VPLs.
    let total: Vec3 = (0..rsm.flux.len())
        .filter(|&i| rsm.metric[i].is_finite())
        .map(|i| rsm.flux[i])
        .sum();
    let got: Vec3 = slots.iter().map(|v| Vec3::from_slice(&v.flux[..3])).sum();
    for ch in 0..3 {
        assert!(rel_close(got[ch], total[ch], 1e-3), "{got} vs {total}");
    }

    // Deterministic: the same bytes again.
    assert_eq!(run(&ctx, &f, Some(&mut timer)), slots);
    let st = timer.wait(&ctx.device);
    eprintln!("dynamic vpls, again: {:.3} ms ({})", st.frame_ms, st.timing);
}

#[test]
fn dynamic_vpls_match_the_cpu_cut_at_every_depth() {
    // Other times, thresholds and slot depths, down to single texels
    // (16384 = 4^7 slots of the last level: the whole 128² map).
    let ctx = gpu();
    let scene = scene();
    let asset = bake(&ctx, &scene);
    let diagonal = scene.full_bounds().diagonal();
    for time in [0.9f32, 2.6] {
        let f = frame(&ctx, &scene, &asset, time);
        run(&ctx, &f, None);
        let rsm = cpu_rsm(&ctx, &scene, &f);
        for max_vpls in [1u32, 16, 1000, 16384] {
            for t in [0.0f32, 1e-5, 1e-3, f.threshold, 0.1, 0.5, f32::INFINITY] {
                let pass = f.pass(&ctx, t, max_vpls);
                let slots = run_pass(&ctx, &f, &pass, None, None);
                assert_all_finite(&slots);
                let cpu = cluster_cut(&rsm, t, pass.max_depth());
                eprintln!(
                    "t = {time}: threshold {t:e}, max depth {}: {} VPLs",
                    pass.max_depth(),
                    cpu.len()
                );
                compare(&slots, &cpu, diagonal);
            }
        }
    }
}

#[test]
fn dynamic_vpls_are_empty_without_moving_surfaces_in_view() {
    let ctx = gpu();
    let scene = scene();
    let asset = bake(&ctx, &scene);
    let mut f = frame(&ctx, &scene, &asset, 0.0);
    let base: Vec<Mat4> = scene.dynamic_transforms(0.0);
    // Far outside the light view; then just under the floor (behind the
    // static surface, as seen from the light).
    for offset in [Vec3::splat(1.0e3), Vec3::new(0.0, -1.5, 0.0)] {
        let moved: Vec<Mat4> = base
            .iter()
            .map(|m| Mat4::from_translation(offset) * *m)
            .collect();
        f.scene_gpu.set_dynamic_transforms(&ctx.queue, &moved);
        let slots = run(&ctx, &f, None);
        assert_all_finite(&slots);
        assert!(
            slots.iter().all(|v| *v == GpuDynVpl::default()),
            "offset {offset}: a slot holds a VPL"
        );
        assert!(
            cpu_rsm(&ctx, &scene, &f)
                .metric
                .iter()
                .all(|m| m.is_infinite())
        );
    }
}

/// Clustered over the moving objects' footprint (the window of their boxes
/// in the light view, as the runtime picks it each frame), the GPU's cut is
/// the CPU twin's over the same window; the window holds all the moving
/// flux, is smaller than the map, and reaches deeper with the same slots.
#[test]
fn dynamic_vpls_over_the_moving_objects_window_match_the_cpu_cut() {
    let ctx = gpu();
    let scene = scene();
    let asset = bake(&ctx, &scene);
    let diagonal = scene.full_bounds().diagonal();
    for time in [0.0f32, 0.9, 2.6] {
        let f = frame(&ctx, &scene, &asset, time);
        let rect = (0..scene.dynamic_objects.len())
            .filter_map(|i| f.view.texel_rect(&scene.dynamic_bounds(i, time)))
            .reduce(|a, c| {
                [
                    a[0].min(c[0]),
                    a[1].min(c[1]),
                    a[2].max(c[2]),
                    a[3].max(c[3]),
                ]
            })
            .expect("the view sees the balls");
        let window = Window::around(rect, f.view.size);
        let whole = Window::whole(f.view.size);
        assert!(
            window.levels < whole.levels,
            "t = {time}: {rect:?} gives {window:?}"
        );
        run(&ctx, &f, None);
        let rsm = cpu_rsm(&ctx, &scene, &f);
        for (max_vpls, t) in [(MAX_VPLS, f.threshold), (16, f.threshold), (1000, 1e-5)] {
            let pass = f.pass(&ctx, t, max_vpls);
            let slots = run_pass(&ctx, &f, &pass, Some(Windows::one(window)), None);
            assert_all_finite(&slots);
            let depth = pass.max_depth().min(window.levels);
            let cpu = cluster_cut_window(&rsm, t, depth, window.origin, window.levels);
            let used = slots.iter().filter(|v| v.normal[3] > 0.5).count();
            let full = cluster_cut(&rsm, t, pass.max_depth()).len();
            eprintln!(
                "t = {time}: window {window:?} of {}², max depth {depth}: {used} VPLs (whole map: {full})",
                f.view.size
            );
            // Slots past this frame's depth are empty.
            let in_depth = slot_count(depth) as usize;
            assert!(slots[in_depth..].iter().all(|v| *v == GpuDynVpl::default()));
            compare(&slots[..in_depth], &cpu, diagonal);
            let total: Vec3 = (0..rsm.flux.len())
                .filter(|&i| rsm.metric[i].is_finite())
                .map(|i| rsm.flux[i])
                .sum();
            let got: Vec3 = slots.iter().map(|v| Vec3::from_slice(&v.flux[..3])).sum();
            for ch in 0..3 {
                assert!(rel_close(got[ch], total[ch], 1e-3), "{got} vs {total}");
            }
        }
    }
}

/// The two rectangles whose centres lie farthest apart.
fn farthest_apart(rects: &[[u32; 4]]) -> (usize, usize) {
    let centre = |r: &[u32; 4]| Vec2::new((r[0] + r[2]) as f32, (r[1] + r[3]) as f32);
    (0..rects.len())
        .flat_map(|i| (i + 1..rects.len()).map(move |j| (i, j)))
        .max_by(|&(i, j), &(k, l)| {
            let d = |p: usize, q: usize| centre(&rects[p]).distance(centre(&rects[q]));
            d(i, j).total_cmp(&d(k, l))
        })
        .expect("two balls")
}

/// Moving objects far apart in the view get a window each
/// ([`Windows::around`]): each window's slot range (a quarter of the
/// view's, one depth less; the last one the remainder) holds the CPU twin's
/// cut over that window, the rest of each range is empty, and the windows
/// together hold all the moving flux of their texels. (The test scene's
/// balls stand together; the windows are those of the two balls farthest
/// apart in the view, which is what the rule splits.)
#[test]
fn dynamic_vpls_over_windows_far_apart_match_the_cpu_cut() {
    let ctx = gpu();
    let scene = scene();
    let asset = bake(&ctx, &scene);
    let diagonal = scene.full_bounds().diagonal();
    for time in [0.0f32, 1.7] {
        let f = frame(&ctx, &scene, &asset, time);
        let rects: Vec<[u32; 4]> = (0..scene.dynamic_objects.len())
            .filter_map(|i| f.view.texel_rect(&scene.dynamic_bounds(i, time)))
            .collect();
        let (a, b) = farthest_apart(&rects);
        let windows = Windows::around(&[rects[a], rects[b]], f.view.size);
        eprintln!("t = {time}: {:?} {:?} -> {windows:?}", rects[a], rects[b]);
        assert_eq!(windows.as_slice().len(), 2, "t = {time}: {windows:?}");
        run(&ctx, &f, None);
        let rsm = cpu_rsm(&ctx, &scene, &f);
        let inside = |i: usize| {
            let (x, y) = ((i as u32) % rsm.size, (i as u32) / rsm.size);
            windows.as_slice().iter().any(|w| {
                let side = 1u32 << w.levels;
                (w.origin[0]..w.origin[0] + side).contains(&x)
                    && (w.origin[1]..w.origin[1] + side).contains(&y)
            })
        };
        let total: Vec3 = (0..rsm.flux.len())
            .filter(|&i| rsm.metric[i].is_finite() && inside(i))
            .map(|i| rsm.flux[i])
            .sum();
        assert!(total.max_element() > 0.0, "t = {time}: the balls are lit");
        for (max_vpls, t) in [(MAX_VPLS, f.threshold), (1000, 1e-5)] {
            let pass = f.pass(&ctx, t, max_vpls);
            let slots = run_pass(&ctx, &f, &pass, Some(windows), None);
            assert_all_finite(&slots);
            let n = windows.as_slice().len();
            let each = slot_count(pass.max_depth() - 1) as usize;
            let (mut at, mut got, mut used) = (0, Vec3::ZERO, 0);
            for (k, w) in windows.as_slice().iter().enumerate() {
                let range = if k + 1 == n { slots.len() - at } else { each };
                let mine = &slots[at..at + range];
                let depth = (pass.max_depth() - 1).min(w.levels);
                let in_depth = slot_count(depth) as usize;
                assert!(mine[in_depth..].iter().all(|v| *v == GpuDynVpl::default()));
                let cpu = cluster_cut_window(&rsm, t, depth, w.origin, w.levels);
                compare(&mine[..in_depth], &cpu, diagonal);
                got += mine
                    .iter()
                    .map(|v| Vec3::from_slice(&v.flux[..3]))
                    .sum::<Vec3>();
                used += cpu.len();
                at += range;
            }
            eprintln!("t = {time}, {max_vpls} VPLs: {used} in {n} windows");
            for ch in 0..3 {
                assert!(
                    rel_close(got[ch], total[ch], 1e-3),
                    "t = {time}: {got} vs {total}"
                );
            }
        }
    }
}

/// The occlusion test over the moving objects' windows gives the same sums
/// as over the whole map (no texel outside them has a moving surface), and
/// over two disjoint windows in one dispatch the sums of each window alone.
#[test]
fn occlusion_over_windows_matches_the_whole_map() {
    let ctx = gpu();
    let scene = scene();
    let asset = bake(&ctx, &scene);
    let time = 0.9;
    let f = frame(&ctx, &scene, &asset, time);
    run(&ctx, &f, None);
    let r = f.baked.rsm.as_ref().expect("RSM data");
    let vpl_count = f.baked.vpls.len() as u32;
    let occ = OcclusionPass::new(
        &ctx.device,
        &r.static_metric,
        &f.rsm,
        &r.texel_info,
        (vpl_count, 0),
    );
    let sums = |windows: &Windows| -> Vec<u32> {
        occ.set_window(&ctx.queue, occ.own_view(), windows);
        let mut enc = ctx.device.create_command_encoder(&Default::default());
        enc.clear_buffer(&occ.occluded, 0, None);
        occ.encode_from(&mut enc, occ.own_view(), windows, None);
        ctx.queue.submit([enc.finish()]);
        bytemuck::pod_collect_to_vec(&readback::read_buffer(&ctx, &occ.occluded).expect("read"))
    };
    let rects: Vec<[u32; 4]> = (0..scene.dynamic_objects.len())
        .filter_map(|i| f.view.texel_rect(&scene.dynamic_bounds(i, time)))
        .collect();
    let whole = sums(&Windows::one(Window::whole(f.view.size)));
    assert!(whole.iter().any(|&s| s > 0), "the balls occlude some VPL");
    assert_eq!(sums(&Windows::around(&rects, f.view.size)), whole);
    // The two balls farthest apart: two windows in one dispatch.
    let (a, b) = farthest_apart(&rects);
    let two = Windows::around(&[rects[a], rects[b]], f.view.size);
    assert_eq!(two.as_slice().len(), 2, "{two:?}");
    let both = sums(&two);
    let one = sums(&Windows::one(two.as_slice()[0]));
    let other = sums(&Windows::one(two.as_slice()[1]));
    let added: Vec<u32> = one.iter().zip(&other).map(|(x, y)| x + y).collect();
    assert_eq!(both, added);
    assert!(both.iter().any(|&s| s > 0) && both != whole);
}

/// The moving objects' RSM holds, per texel, the normal of the triangle the
/// light sees (which the texel emits about) and the interpolated shading
/// normal (which sets its flux), both facing the light, as the bake's RSM
/// does (`gibake_bake::rsm::Rsm::normal`): checked against rays cast
/// through the texel centres at the frame's time. The balls of the corner
/// scene are smooth-shaded, so the two normals differ.
#[test]
fn dynamic_rsm_holds_the_facet_and_the_shading_normal() {
    let ctx = gpu();
    let scene = scene();
    let asset = bake(&ctx, &scene);
    let f = frame(&ctx, &scene, &asset, 0.0);
    run(&ctx, &f, None);
    let size = f.rsm.size;
    let pos = readback::read_texture_f32(&ctx, &f.rsm.textures[0], 0, 4).expect("read positions");
    let b = readback::read_texture(&ctx, &f.rsm.textures[2], 0, 8).expect("read normals");
    let normal: Vec<f32> = b
        .chunks_exact(2)
        .map(|c| f16_to_f32(u16::from_le_bytes([c[0], c[1]])))
        .collect();
    let rays = gibake_raycast::RayScene::build(&scene, 0.0);
    let (mut texels, mut facet_ok, mut shading_ok, mut differ) = (0, 0, 0, 0);
    for i in 0..(size * size) as usize {
        if pos[4 * i + 3] >= 1.0e38 || pos[4 * i + 3].is_nan() {
            continue;
        }
        let (x, y) = (i as u32 % size, i as u32 / size);
        let (o, d) = f.view.texel_ray(x, y);
        let Some(h) = rays.intersect(o, d, f32::INFINITY) else {
            continue;
        };
        let p = Vec3::new(pos[4 * i], pos[4 * i + 1], pos[4 * i + 2]);
        // The same surface point (not a texel on a silhouette edge).
        if (h.position - p).length() > 1e-3 * scene.full_bounds().diagonal() {
            continue;
        }
        let ng = oct_decode(Vec2::new(normal[4 * i], normal[4 * i + 1]));
        let ns = oct_decode(Vec2::new(normal[4 * i + 2], normal[4 * i + 3]));
        texels += 1;
        // Half-float octahedral normals: within ~0.5°.
        facet_ok += usize::from(ng.dot(h.geometric_normal) > 0.9995);
        shading_ok += usize::from(ns.dot(h.shading_normal) > 0.9995);
        differ += usize::from(h.geometric_normal.dot(h.shading_normal) < 0.9995);
    }
    eprintln!(
        "{texels} moving texels: facet normal right on {facet_ok}, shading normal on {shading_ok}, \
         the two differ on {differ}"
    );
    assert!(texels > 50, "the balls are in the light's view at t = 0");
    assert!(differ * 2 > texels, "the balls are smooth-shaded");
    assert!(
        facet_ok * 100 >= texels * 98,
        "facet normals: {facet_ok} of {texels}"
    );
    assert!(
        shading_ok * 100 >= texels * 98,
        "shading normals: {shading_ok} of {texels}"
    );
}
