//! What a game needs of the runtime, through the public API: the frame plan
//! per mode, hot reload of a re-baked asset (handles kept), several views
//! over one upload and one per-frame update, output into the caller's
//! `Rgba16Float` target or added onto its HDR target, a G-buffer rebuilt
//! from the engine's depth and normals, moving objects hidden and removed,
//! and per-frame figures read without waiting.

use std::sync::OnceLock;

use gibake_bake::cluster::ClusterTarget;
use gibake_gpu::GpuContext;
use gibake_runtime::glam::{self, Mat4};
use gibake_runtime::{
    Asset, CameraMatrices, DepthGBuffer, FrameInput, Image, Mode, NormalEncoding, OutputTarget,
    Pass, Reload, RenderSettings, Renderer, RuntimeError, Scene, Timing, ViewId, wgpu,
};

const TIME: f32 = 0.7;
const W: u32 = 40;
const H: u32 = 32;

struct Fixture {
    ctx: GpuContext,
    scene: Scene,
    asset: Asset,
}

fn bake(ctx: &GpuContext, scene: &Scene, vpls: u32) -> Asset {
    let opts = gibake_bake::BakeOptions {
        rsm_size: 128,
        vpl_map_size: 16,
        shadow_map_size: 256,
        target: ClusterTarget::Count(vpls),
        // The first bounce alone (what this checks).
        bounces: gibake_bake::later::Bounces::Count(1),
        later_vpls: None,
    };
    gibake_bake::bake(ctx, scene, &opts, &gibake_bake::NoProgress, "test")
        .expect("bake")
        .asset
}

/// corner_bunny (its balls move) and a small bake of it.
fn fixture() -> &'static Fixture {
    static F: OnceLock<Fixture> = OnceLock::new();
    F.get_or_init(|| {
        let ctx = GpuContext::new(&Default::default()).unwrap_or_else(|e| {
            panic!(
                "this test needs a GPU adapter ({e}); `apt-get install mesa-vulkan-drivers` gives \
                 the lavapipe software GPU"
            )
        });
        let path =
            std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../data/corner_bunny.glb");
        let scene = gibake_runtime::load_scene(&path, &Default::default()).expect("load the scene");
        let asset = bake(&ctx, &scene, 64);
        Fixture { ctx, scene, asset }
    })
}

fn settings(mode: Mode) -> RenderSettings {
    RenderSettings {
        width: W,
        height: H,
        mode,
        max_dynamic_vpls: 16,
        ..Default::default()
    }
}

fn renderer(scene: &Scene, asset: Option<&Asset>, s: &RenderSettings) -> Renderer {
    let ctx = &fixture().ctx;
    Renderer::new(&ctx.device, &ctx.queue, scene, asset, s).expect("renderer")
}

fn camera() -> CameraMatrices {
    CameraMatrices::from_scene(&fixture().scene, TIME, W, H).expect("corner_bunny has a camera")
}

/// Prepares `frame` on each renderer, records them all into one encoder
/// (in order) and submits it.
fn draw_all(rs: &mut [&mut Renderer], frame: &FrameInput<'_>) {
    let ctx = &fixture().ctx;
    let mut enc = ctx.device.create_command_encoder(&Default::default());
    for r in rs.iter_mut() {
        r.prepare(&ctx.device, &ctx.queue, frame).expect("prepare");
        r.record(&mut enc);
    }
    ctx.queue.submit([enc.finish()]);
}

fn read(t: &wgpu::Texture) -> Image {
    let ctx = &fixture().ctx;
    let data = gibake_gpu::readback::read_texture_f32_on(&ctx.device, &ctx.queue, t, 0, 4)
        .expect("read back");
    Image::from_rgba_f32(t.width(), t.height(), &data)
}

/// The RGB of an `Rgba16Float` texture.
fn read_f16(t: &wgpu::Texture) -> Vec<[f32; 3]> {
    let ctx = &fixture().ctx;
    let b =
        gibake_gpu::readback::read_texture_on(&ctx.device, &ctx.queue, t, 0, 8).expect("read back");
    b.chunks_exact(8)
        .map(|p| {
            let h = |k: usize| f16_to_f32(u16::from_le_bytes([p[2 * k], p[2 * k + 1]]));
            [h(0), h(1), h(2)]
        })
        .collect()
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

fn texture(format: wgpu::TextureFormat, usage: wgpu::TextureUsages) -> wgpu::Texture {
    fixture()
        .ctx
        .device
        .create_texture(&wgpu::TextureDescriptor {
            label: Some("game's target"),
            size: wgpu::Extent3d {
                width: W,
                height: H,
                depth_or_array_layers: 1,
            },
            mip_level_count: 1,
            sample_count: 1,
            dimension: wgpu::TextureDimension::D2,
            format,
            usage,
            view_formats: &[],
        })
}

/// A `W × H` `Rgba32Float` texture holding `texels` (four floats each).
fn rgba32f_texture(texels: &[f32]) -> wgpu::Texture {
    let t = texture(
        wgpu::TextureFormat::Rgba32Float,
        wgpu::TextureUsages::TEXTURE_BINDING | wgpu::TextureUsages::COPY_DST,
    );
    fixture().ctx.queue.write_texture(
        t.as_image_copy(),
        bytemuck::cast_slice(texels),
        wgpu::TexelCopyBufferLayout {
            offset: 0,
            bytes_per_row: Some(W * 16),
            rows_per_image: Some(H),
        },
        t.size(),
    );
    t
}

/// An engine may prepare on one thread and record on another.
#[test]
fn a_renderer_is_send_and_sync() {
    fn send_sync<T: Send + Sync>() {}
    send_sync::<Renderer>();
}

/// A game sees the scene's lights, what the asset baked from each, and
/// which the renderer shades.
#[test]
fn the_lights_are_visible_to_a_game() {
    let f = fixture();
    let r = renderer(&f.scene, Some(&f.asset), &settings(Mode::Full));
    let lights = r.lights();
    assert_eq!(lights.len(), 1);
    let l = &lights[0];
    assert_eq!(l.name, f.scene.lights[0].name);
    assert_eq!(l.position, f.scene.lights[0].position);
    assert!(matches!(l.kind, gibake_scene::LightKind::Spot { .. }));
    assert_eq!(l.vpls, Some(f.asset.vpls.len() as u32));
    assert!(l.shaded);
    assert!(
        l.dynamic_bounce,
        "the first light's bounce off moving objects"
    );
    // Without an asset (direct mode) nothing is baked from it.
    let r = renderer(&f.scene, None, &settings(Mode::Direct));
    assert_eq!(r.lights()[0].vpls, None);
}

#[test]
fn the_plan_decides_each_modes_passes() {
    let f = fixture();
    let update = |r: &Renderer| -> Vec<Pass> {
        r.plan().passes().iter().filter(|p| p.is_update()).collect()
    };
    use Pass::*;
    let all = [PrimaryMerge, DynamicRsm, Occlusion, DynamicVpls, VplMaps];
    for (mode, expected) in [
        (Mode::Full, &all[..]),
        (Mode::Indirect, &all[..]),
        (Mode::Naive, &all[..]),
        (Mode::Rsm, &all[..4]),
        (Mode::Direct, &all[..1]),
    ] {
        let r = renderer(&f.scene, Some(&f.asset), &settings(mode));
        assert_eq!(update(&r), expected, "{mode:?}");
    }
    // No moving objects: no update at all, except naive's re-render.
    let still = gibake_bake::static_only(&f.scene);
    for mode in [
        Mode::Full,
        Mode::Indirect,
        Mode::Rsm,
        Mode::Direct,
        Mode::Naive,
    ] {
        let r = renderer(&still, Some(&f.asset), &settings(mode));
        let expected: &[Pass] = if mode == Mode::Naive { &[VplMaps] } else { &[] };
        assert_eq!(update(&r), expected, "{mode:?} without moving objects");
        assert_eq!(r.has_dynamic_resources(), mode == Mode::Naive);
    }
}

/// The plan says whether the later bounces are shaded: none for an asset
/// baked with the first bounce alone (the fixture), the asset's count for
/// one with every bounce in every mode that shades static VPLs, none in
/// `direct`.
#[test]
fn the_plan_says_whether_the_later_bounces_are_shaded() {
    let f = fixture();
    assert_eq!(f.asset.manifest.later_vpls(), 0);
    let first = renderer(&f.scene, Some(&f.asset), &settings(Mode::Full));
    assert_eq!(first.plan().later_vpls(), 0);
    let opts = gibake_bake::BakeOptions {
        rsm_size: 128,
        vpl_map_size: 16,
        shadow_map_size: 256,
        target: ClusterTarget::Count(32),
        bounces: gibake_bake::later::Bounces::Every,
        later_vpls: Some(8),
    };
    let every = gibake_bake::bake(&f.ctx, &f.scene, &opts, &gibake_bake::NoProgress, "test")
        .expect("bake")
        .asset;
    let later = every.manifest.later_vpls();
    assert!(later > 0, "the corner scene keeps its later bounces");
    for (mode, expected) in [
        (Mode::Full, later),
        (Mode::Indirect, later),
        (Mode::Rsm, later),
        (Mode::Direct, 0),
    ] {
        let r = renderer(&f.scene, Some(&every), &settings(mode));
        assert_eq!(r.plan().later_vpls(), expected, "{mode:?}");
    }
}

#[test]
fn hot_reload_keeps_handles_and_equals_a_new_renderer() {
    let f = fixture();
    let d = &f.ctx.device;
    let q = &f.ctx.queue;
    let s = settings(Mode::Full);
    let mut r = renderer(&f.scene, Some(&f.asset), &s);
    let (ball, _) = r.objects().next().expect("corner_bunny has balls");
    let moved = r.transform(ball).unwrap() * Mat4::from_translation([0.0, 0.1, 0.0].into());
    let one_moved = [(ball, moved)];
    draw_all(&mut [&mut r], &FrameInput::new(camera()).moving(&one_moved));
    let before = read(r.output());

    // A re-bake with another VPL budget, hot-reloaded.
    let rebaked = bake(&f.ctx, &f.scene, 24);
    assert_eq!(
        r.set_asset(d, q, &f.scene, Some(&rebaked)).unwrap(),
        Reload::HandlesKept
    );
    assert_eq!(r.transform(ball).unwrap(), moved, "the matrix stays");
    let mut fresh = renderer(&f.scene, Some(&rebaked), &s);
    let fresh_ball = fresh.object(r.objects().next().unwrap().1).unwrap();
    draw_all(
        &mut [&mut r],
        &FrameInput::new(camera()).moving(&[(ball, moved)]),
    );
    draw_all(
        &mut [&mut fresh],
        &FrameInput::new(camera()).moving(&[(fresh_ball, moved)]),
    );
    let after = read(r.output());
    assert_eq!(after, read(fresh.output()), "reloaded = a new renderer");
    assert_ne!(after, before, "the re-bake changes the image");

    // A foreign asset is refused and changes nothing.
    let mut other = f.scene.clone();
    other.static_meshes.pop();
    let e = r.set_asset(d, q, &other, Some(&rebaked)).unwrap_err();
    assert!(matches!(e, RuntimeError::Asset(_)), "{e}");
    draw_all(
        &mut [&mut r],
        &FrameInput::new(camera()).moving(&[(ball, moved)]),
    );
    assert_eq!(read(r.output()), after);

    // Other moving objects: new handles, the old ones refused.
    let mut renamed = f.scene.clone();
    renamed.dynamic_objects[0].name.push_str(" (renamed)");
    assert_eq!(
        r.set_asset(d, q, &renamed, Some(&rebaked)).unwrap(),
        Reload::HandlesRenewed
    );
    assert!(matches!(
        r.transform(ball),
        Err(RuntimeError::UnknownObject(_))
    ));
    assert!(r.objects().any(|(_, n)| n.ends_with("(renamed)")));
}

#[test]
fn two_views_share_one_upload_and_one_update() {
    let f = fixture();
    let (d, q) = (&f.ctx.device, &f.ctx.queue);
    let s = settings(Mode::Full);
    let transforms = gibake_runtime::scene_transforms(&f.scene, TIME);
    let mut one = renderer(&f.scene, Some(&f.asset), &s);
    draw_all(
        &mut [&mut one],
        &FrameInput::new(camera()).transforms(&transforms),
    );
    let single = one.stats(d);
    let expected = read(one.output());

    let mut two = renderer(&f.scene, Some(&f.asset), &s);
    let second = two.add_view(d, q, W, H, 0).unwrap();
    assert_eq!(two.asset_bytes(), one.asset_bytes(), "one upload");
    let cameras = [(second, camera())];
    draw_all(
        &mut [&mut two],
        &FrameInput::new(camera())
            .transforms(&transforms)
            .views(&cameras),
    );
    let stats = two.stats(d);
    assert_eq!(read(two.output()), expected);
    assert_eq!(read(two.view_output(second).unwrap()), expected);
    assert_eq!(stats.views, 2);
    assert_eq!(stats.affected_maps, single.affected_maps);
    assert!(stats.affected_maps > 0, "the balls reach some VPL map");
    // Per object: no object in more maps than get a tile, every map with
    // a tile holds some object, each (object, map) at least one instance.
    let per = &stats.merge_maps_per_object;
    assert_eq!(per.len(), transforms.len(), "one count per moving object");
    assert!(per.iter().all(|&n| n <= stats.affected_maps), "{per:?}");
    let pairs: u32 = per.iter().sum();
    assert!(pairs >= stats.affected_maps, "{pairs} (object, map) pairs");
    assert!(
        stats.merge_instances >= pairs,
        "{} instances",
        stats.merge_instances
    );
    assert_eq!(stats.merge_maps_per_object, single.merge_maps_per_object);
    assert_eq!(
        stats.update_draw_calls, single.update_draw_calls,
        "the update is recorded once"
    );
    assert_eq!(
        stats.draw_calls - stats.update_draw_calls,
        2 * (single.draw_calls - single.update_draw_calls)
    );
    if stats.timing == Timing::GpuTimestamps {
        let count = |p: Pass| stats.passes.iter().filter(|(q, _)| *q == p).count();
        for p in [Pass::PrimaryMerge, Pass::DynamicRsm, Pass::VplMaps] {
            assert_eq!(count(p), 1, "{p}");
        }
        assert_eq!(count(Pass::Shade), 2);
        assert_eq!(count(Pass::GBuffer), 2);
    }
    // A removed view is gone; the main one cannot be removed.
    two.remove_view(second).unwrap();
    assert!(matches!(
        two.view_output(second),
        Err(RuntimeError::UnknownView(_))
    ));
    assert!(two.remove_view(ViewId::MAIN).is_err());
    let e = two
        .prepare(d, q, &FrameInput::new(camera()).views(&cameras))
        .unwrap_err();
    assert!(matches!(e, RuntimeError::UnknownView(_)), "{e}");
}

#[test]
fn rgba16float_output_and_additive_output_match_the_own_within_f16_rounding() {
    let f = fixture();
    let (d, q) = (&f.ctx.device, &f.ctx.queue);
    let transforms = gibake_runtime::scene_transforms(&f.scene, TIME);
    let frame = FrameInput::new(camera()).transforms(&transforms);
    let mut own = renderer(&f.scene, Some(&f.asset), &settings(Mode::Full));
    draw_all(&mut [&mut own], &frame);
    let reference = read(own.output());
    assert!(reference.mean().x > 0.0);

    let usage = wgpu::TextureUsages::RENDER_ATTACHMENT | wgpu::TextureUsages::COPY_SRC;
    let half = texture(wgpu::TextureFormat::Rgba16Float, usage);
    let mut r = renderer(&f.scene, Some(&f.asset), &settings(Mode::Full));
    r.set_output(d, ViewId::MAIN, OutputTarget::Texture(&half))
        .unwrap();
    draw_all(&mut [&mut r], &frame);
    let got = read_f16(&half);
    // f16 has an 11-bit significand: within one unit of the last place,
    // whichever way the GPU rounds.
    let close = |a: f32, b: f32| (a - b).abs() <= b.abs() * 2f32.powi(-10) + 1e-7;
    for (k, (g, e)) in got.iter().zip(&reference.pixels).enumerate() {
        for c in 0..3 {
            assert!(close(g[c], e[c]), "pixel {k}: {g:?} vs {e:?}");
        }
    }
    assert_eq!(read(r.output()), reference, "the view's radiance as before");

    // Added onto the game's own light (here a constant), indirect only.
    let hdr = texture(wgpu::TextureFormat::Rgba16Float, usage);
    let base = [0.25f32, 0.5, 1.0];
    let mut ind = renderer(&f.scene, Some(&f.asset), &settings(Mode::Indirect));
    ind.set_output(d, ViewId::MAIN, OutputTarget::Add(&hdr))
        .unwrap();
    let mut enc = d.create_command_encoder(&Default::default());
    {
        enc.begin_render_pass(&wgpu::RenderPassDescriptor {
            label: Some("the game's own light"),
            color_attachments: &[Some(wgpu::RenderPassColorAttachment {
                view: &hdr.create_view(&Default::default()),
                depth_slice: None,
                resolve_target: None,
                ops: wgpu::Operations {
                    load: wgpu::LoadOp::Clear(wgpu::Color {
                        r: f64::from(base[0]),
                        g: f64::from(base[1]),
                        b: f64::from(base[2]),
                        a: 1.0,
                    }),
                    store: wgpu::StoreOp::Store,
                },
            })],
            ..Default::default()
        });
    }
    q.submit([enc.finish()]);
    draw_all(&mut [&mut ind], &frame);
    let indirect = read(ind.output());
    assert!(indirect.mean().x > 0.0);
    let got = read_f16(&hdr);
    for (k, (g, e)) in got.iter().zip(&indirect.pixels).enumerate() {
        for c in 0..3 {
            let want = base[c] + e[c];
            assert!(
                (g[c] - want).abs() <= want * 2f32.powi(-9),
                "pixel {k}: {g:?} vs {base:?} + {e:?}"
            );
        }
    }
    // A target that fits neither way is refused.
    let bad = texture(wgpu::TextureFormat::Rgba8Unorm, usage);
    let e = r
        .set_output(d, ViewId::MAIN, OutputTarget::Add(&bad))
        .unwrap_err();
    assert!(matches!(e, RuntimeError::OutputTarget(_)), "{e}");
}

#[test]
fn a_gbuffer_from_the_engines_depth_and_normals_equals_the_own() {
    let f = fixture();
    let d = &f.ctx.device;
    let transforms = gibake_runtime::scene_transforms(&f.scene, TIME);
    let frame = FrameInput::new(camera()).transforms(&transforms);
    let s = RenderSettings {
        interleave: 1,
        ..settings(Mode::Full)
    };
    let mut own = renderer(&f.scene, Some(&f.asset), &s);
    let mut engine = renderer(&f.scene, Some(&f.asset), &s);
    // The "engine's" buffers: the first renderer's depth, normals, albedo.
    let (depth, g) = (own.gbuffer_depth().clone(), own.gbuffer_textures().to_vec());
    let src = DepthGBuffer {
        depth: &depth,
        far_depth: 0.0,
        normals: &g[1],
        encoding: NormalEncoding::Packed,
        albedo: &g[2],
    };
    engine.use_depth_gbuffer(d, ViewId::MAIN, &src).unwrap();
    draw_all(&mut [&mut own, &mut engine], &frame);
    let (a, b) = (read(own.output()), read(engine.output()));
    let stats = engine.stats(d);
    assert_eq!(
        stats.draw_calls, stats.update_draw_calls,
        "the scene is not drawn again"
    );
    // Positions rebuilt from a 32-bit depth differ from the interpolated
    // ones by rounding: the image agrees to a fraction of a per cent.
    let (mut worst, mut sum, mut n) = (0f32, 0f64, 0);
    for (p, q) in a.pixels.iter().zip(&b.pixels) {
        for c in 0..3 {
            let rel = (p[c] - q[c]).abs() / p[c].abs().max(1e-3);
            worst = worst.max(rel);
            sum += f64::from(rel);
            n += 1;
        }
    }
    let mean = sum / f64::from(n);
    eprintln!("depth G-buffer against the own: mean rel {mean:.2e}, worst {worst:.2e}");
    assert!(a.mean().x > 0.0);
    assert!(mean < 1e-4, "mean relative difference {mean:.2e}");
    assert!(worst < 1e-2, "worst relative difference {worst:.2e}");
    // The positions shading rebuilds are the engine's depth's, not the
    // renderer's own (undrawn) G-buffer's.
    let q = &f.ctx.queue;
    let (pe, po) = (
        engine.gbuffer_positions(d, q).unwrap(),
        own.gbuffer_positions(d, q).unwrap(),
    );
    assert!(po.iter().filter(|p| p[3] > 0.5).count() > po.len() / 2);
    assert_eq!(pe, po);
    // The packed normals decode (unpack_normals) to unit vectors facing
    // the camera's side of their surface.
    let packed = gibake_gpu::readback::read_texture_on(d, q, &g[1], 0, 8).unwrap();
    let eye = camera().position;
    for (k, t) in packed.chunks_exact(8).enumerate() {
        if po[k][3] < 0.5 {
            continue;
        }
        let w = |i: usize| u32::from_le_bytes([t[i], t[i + 1], t[i + 2], t[i + 3]]);
        let [ns, ng] = gibake_runtime::unpack_normals([w(0), w(4)]);
        assert!((ns.length() - 1.0).abs() < 1e-3 && (ng.length() - 1.0).abs() < 1e-3);
        let to_eye = eye - glam::Vec3::new(po[k][0], po[k][1], po[k][2]);
        assert!(
            ng.dot(to_eye) > -1e-3 * to_eye.length(),
            "texel {k}: {ng} faces away"
        );
    }
    // The engine's normals as float octahedral pairs (an `Rgba32Float`
    // made from the own packed ones): the rebuild pass repacks them, and
    // the frame is the same.
    let snorm = |v: u16| (f32::from(v as i16) / 32767.0).max(-1.0);
    let floats: Vec<f32> = packed
        .chunks_exact(2)
        .map(|b| snorm(u16::from_le_bytes([b[0], b[1]])))
        .collect();
    let oct = rgba32f_texture(&floats);
    // The albedo as linear floats (`Rgba32Float`) from the own packed one.
    let own_albedo = gibake_gpu::readback::read_texture_on(d, &f.ctx.queue, &g[2], 0, 4).unwrap();
    let linear: Vec<f32> = own_albedo
        .chunks_exact(4)
        .flat_map(|b| {
            let [r, g, b] =
                gibake_runtime::unpack_albedo(u32::from_le_bytes([b[0], b[1], b[2], b[3]]));
            [r, g, b, 1.0]
        })
        .collect();
    let alb = rgba32f_texture(&linear);
    let mut rebuilt = renderer(&f.scene, Some(&f.asset), &s);
    rebuilt
        .use_depth_gbuffer(
            d,
            ViewId::MAIN,
            &DepthGBuffer {
                normals: &oct,
                encoding: NormalEncoding::Octahedral,
                albedo: &alb,
                ..src
            },
        )
        .unwrap();
    draw_all(&mut [&mut rebuilt], &frame);
    let c = read(rebuilt.output());
    let worst = a
        .pixels
        .iter()
        .zip(&c.pixels)
        .flat_map(|(p, q)| (0..3).map(move |k| (p[k] - q[k]).abs() / p[k].abs().max(1e-3)))
        .fold(0f32, f32::max);
    // The pass wrote the view's own normals: gibake's packing again, to
    // a code or two.
    let again = gibake_gpu::readback::read_texture_on(
        d,
        &f.ctx.queue,
        &rebuilt.gbuffer_textures()[1],
        0,
        8,
    )
    .unwrap();
    let off = packed
        .chunks_exact(2)
        .zip(again.chunks_exact(2))
        .map(|(p, q)| {
            (i32::from(i16::from_le_bytes([p[0], p[1]]))
                - i32::from(i16::from_le_bytes([q[0], q[1]])))
            .abs()
        })
        .max()
        .unwrap();
    assert!(off <= 2, "repacked normals off by {off} codes");
    assert!(
        worst < 1e-2,
        "repacked normals: worst relative difference {worst:.2e}"
    );
    // Packed normals of another format are refused.
    let e = engine
        .use_depth_gbuffer(
            d,
            ViewId::MAIN,
            &DepthGBuffer {
                normals: &oct,
                ..src
            },
        )
        .unwrap_err();
    assert!(matches!(e, RuntimeError::OutputTarget(_)), "{e}");
    // A depth texture that is not one is refused.
    let bad = texture(
        wgpu::TextureFormat::Rgba8Unorm,
        wgpu::TextureUsages::TEXTURE_BINDING,
    );
    let e = engine
        .use_depth_gbuffer(d, ViewId::MAIN, &DepthGBuffer { depth: &bad, ..src })
        .unwrap_err();
    assert!(matches!(e, RuntimeError::OutputTarget(_)), "{e}");
}

#[test]
fn hidden_and_removed_objects_are_in_no_pass() {
    let f = fixture();
    let d = &f.ctx.device;
    let transforms = gibake_runtime::scene_transforms(&f.scene, TIME);
    let frame = FrameInput::new(camera()).transforms(&transforms);
    let s = settings(Mode::Full);
    let mut r = renderer(&f.scene, Some(&f.asset), &s);
    draw_all(&mut [&mut r], &frame);
    let with_balls = read(r.output());
    // Every ball hidden: the image of the scene without moving objects.
    let handles: Vec<_> = r.objects().map(|(h, _)| h).collect();
    for h in &handles {
        r.set_visible(*h, false).unwrap();
        assert!(!r.is_visible(*h).unwrap());
    }
    draw_all(&mut [&mut r], &frame);
    let hidden = read(r.output());
    let mut still = renderer(&gibake_bake::static_only(&f.scene), Some(&f.asset), &s);
    draw_all(&mut [&mut still], &FrameInput::new(camera()));
    assert_eq!(hidden, read(still.output()));
    assert_ne!(hidden, with_balls);
    assert_eq!(r.stats(d).update_draw_calls, 0);
    // Shown again: as before.
    for h in &handles {
        r.set_visible(*h, true).unwrap();
    }
    draw_all(&mut [&mut r], &frame);
    assert_eq!(read(r.output()), with_balls);
    // Removed: its handle is refused, the others live on.
    r.remove(handles[0]).unwrap();
    assert!(matches!(
        r.transform(handles[0]),
        Err(RuntimeError::UnknownObject(_))
    ));
    assert!(r.set_visible(handles[0], true).is_err());
    assert_eq!(r.objects().count(), handles.len() - 1);
    let e = r
        .prepare(
            d,
            &f.ctx.queue,
            &FrameInput::new(camera()).moving(&[(handles[0], Mat4::IDENTITY)]),
        )
        .unwrap_err();
    assert!(matches!(e, RuntimeError::UnknownObject(_)), "{e}");
    r.transform(handles[1]).unwrap();
}

#[test]
fn stats_of_a_finished_frame_are_read_without_waiting() {
    let f = fixture();
    let d = &f.ctx.device;
    let mut r = renderer(&f.scene, Some(&f.asset), &settings(Mode::Full));
    assert!(r.poll_stats(d).is_none(), "no frame yet");
    let mut last = 0;
    for k in 1..=4u64 {
        if k == 4 {
            // Every earlier frame done: frame 4 gets a free read-back slot.
            let _ = d.poll(wgpu::PollType::wait_indefinitely());
        }
        let t = gibake_runtime::scene_transforms(&f.scene, 0.1 * k as f32);
        draw_all(&mut [&mut r], &FrameInput::new(camera()).transforms(&t));
        if let Some(s) = r.poll_stats(d) {
            assert!(s.frame >= last && s.frame <= k, "frame {} at {k}", s.frame);
            last = s.frame;
        }
    }
    // Once the GPU is done, the newest figures are the last frame's.
    let _ = d.poll(wgpu::PollType::wait_indefinitely());
    let s = r.poll_stats(d).expect("a finished frame");
    assert_eq!(s.frame, 4);
    assert!(s.frame_ms > 0.0);
    assert_eq!(r.stats(d).frame, 4);
}

#[test]
fn what_an_asset_needs_is_known_before_the_renderer() {
    let f = fixture();
    let full = settings(Mode::Full);
    let req = gibake_runtime::Requirements::of(&f.scene, Some(&f.asset), &full).unwrap();
    let r = renderer(&f.scene, Some(&f.asset), &full);
    assert_eq!(req.asset_bytes, r.asset_bytes(), "the upload, exactly");
    assert!(req.gpu_bytes > req.asset_bytes);
    req.check(&f.ctx.device.limits()).unwrap();

    // downlevel_defaults: the VPL-map merge binds five storage buffers in a
    // stage, so the moving scene in full mode is refused, with the reason,
    // before anything is created ...
    let downlevel = wgpu::Limits::downlevel_defaults();
    let e = req.check(&downlevel).unwrap_err();
    assert!(e.to_string().contains("merge"), "{e}");
    let (device, queue) =
        pollster::block_on(f.ctx.adapter.request_device(&wgpu::DeviceDescriptor {
            required_limits: downlevel.clone(),
            ..Default::default()
        }))
        .expect("a downlevel device");
    let e = Renderer::new(&device, &queue, &f.scene, Some(&f.asset), &full)
        .err()
        .expect("refused");
    assert!(
        matches!(
            e,
            RuntimeError::DeviceLimit {
                needed: 5,
                limit: 4,
                ..
            }
        ),
        "{e}"
    );
    // ... while modes and scenes without it render there.
    let still = gibake_bake::static_only(&f.scene);
    for (scene, mode) in [
        (&f.scene, Mode::Rsm),
        (&still, Mode::Full),
        (&f.scene, Mode::Direct),
    ] {
        let s = settings(mode);
        let req = gibake_runtime::Requirements::of(scene, Some(&f.asset), &s).unwrap();
        req.check(&downlevel).unwrap();
        let mut r = Renderer::new(&device, &queue, scene, Some(&f.asset), &s).unwrap();
        r.prepare(&device, &queue, &FrameInput::new(camera()))
            .unwrap();
        let mut enc = device.create_command_encoder(&Default::default());
        r.record(&mut enc);
        queue.submit([enc.finish()]);
        let img = gibake_gpu::readback::read_texture_f32_on(&device, &queue, r.output(), 0, 4)
            .expect("read back");
        let img = Image::from_rgba_f32(W, H, &img);
        assert!(img.mean().x > 0.0 && img.all_finite(), "{mode:?}");
    }
    // An output wider than a device allows is named.
    let wide = RenderSettings {
        width: 3000,
        ..settings(Mode::Direct)
    };
    let e = gibake_runtime::Requirements::of(&f.scene, Some(&f.asset), &wide)
        .unwrap()
        .check(&downlevel)
        .unwrap_err();
    assert!(e.to_string().contains("output width"), "{e}");
}

#[test]
fn a_spawned_copy_renders_like_a_declared_object() {
    let f = fixture();
    let q = &f.ctx.queue;
    let s = RenderSettings {
        max_spawned: 2,
        ..settings(Mode::Full)
    };
    let mut r = renderer(&f.scene, Some(&f.asset), &s);
    let declared = gibake_runtime::scene_transforms(&f.scene, TIME);
    draw_all(
        &mut [&mut r],
        &FrameInput::new(camera()).transforms(&declared),
    );
    let without = read(r.output());
    let (ball, name) = r.objects().next().map(|(h, n)| (h, n.to_string())).unwrap();
    let at = r.transform(ball).unwrap() * Mat4::from_translation([0.25, 0.0, 0.1].into());
    let copy = r.spawn(q, ball, at).unwrap();
    assert_eq!(r.transform(copy).unwrap(), at);
    assert_eq!(r.objects().filter(|(_, n)| *n == name).count(), 2);
    draw_all(
        &mut [&mut r],
        &FrameInput::new(camera()).transforms(&declared),
    );
    let spawned = read(r.output());
    assert_ne!(spawned, without, "the copy is seen");

    // The same scene declaring that copy as one more moving object.
    let mut more = f.scene.clone();
    let mut extra = more.dynamic_objects[0].clone();
    extra.name.push_str(" copy");
    more.dynamic_objects.push(extra);
    let mut all = declared.clone();
    all.push(at);
    let mut b = renderer(&more, Some(&f.asset), &s);
    draw_all(&mut [&mut b], &FrameInput::new(camera()).transforms(&all));
    assert_eq!(spawned, read(b.output()));

    // Room for two: the third is refused; a removed copy leaves the rest.
    r.spawn(q, copy, at).unwrap();
    assert!(matches!(
        r.spawn(q, ball, at),
        Err(RuntimeError::TooManyObjects { max: 2 })
    ));
    r.remove(copy).unwrap();
    assert!(r.transform(copy).is_err());
}

/// What an engine's render graph does (Bevy's, `gibake-bevy`): the update
/// recorded once in its own encoder, each view in its camera's encoder,
/// the timers resolved in a last one, all submitted in that order. The
/// same images, and figures, as one `record`.
#[test]
fn an_update_views_and_finish_recorded_apart_equal_one_record() {
    let f = fixture();
    let (d, q) = (&f.ctx.device, &f.ctx.queue);
    let transforms = gibake_runtime::scene_transforms(&f.scene, TIME);
    let s = settings(Mode::Full);
    let mut whole = renderer(&f.scene, Some(&f.asset), &s);
    let mut apart = renderer(&f.scene, Some(&f.asset), &s);
    let other = CameraMatrices::perspective(
        // From the right of the room, looking left and a little down.
        Mat4::from_rotation_translation(
            glam::Quat::from_rotation_y(1.1) * glam::Quat::from_rotation_x(-0.35),
            glam::Vec3::new(1.5, 1.0, 0.2),
        ),
        0.8,
        W as f32 / H as f32,
        0.05,
    );
    let [second_whole, second_apart] =
        [&mut whole, &mut apart].map(|r| r.add_view(d, q, W, H, 0).expect("a second view"));
    assert_eq!(second_whole, second_apart);
    let cameras = [(second_whole, other)];
    let frame = FrameInput::new(camera())
        .transforms(&transforms)
        .views(&cameras);
    draw_all(&mut [&mut whole], &frame);
    apart.prepare(d, q, &frame).unwrap();
    let mut encoders: Vec<_> = (0..4)
        .map(|_| d.create_command_encoder(&Default::default()))
        .collect();
    apart.record_update(&mut encoders[0]);
    // The views in the order the engine's cameras run (the second first).
    apart.record_view(&mut encoders[1], second_apart).unwrap();
    apart.record_view(&mut encoders[2], ViewId::MAIN).unwrap();
    apart.record_finish(&mut encoders[3]);
    q.submit(encoders.into_iter().map(|e| e.finish()));
    assert_eq!(read(apart.output()), read(whole.output()));
    assert_eq!(
        read(apart.view_output(second_apart).unwrap()),
        read(whole.view_output(second_whole).unwrap())
    );
    assert!(read(apart.output()).mean().x > 0.0);
    let stats = apart.stats(d);
    assert_eq!(stats.views, 2);
    if stats.timing == Timing::GpuTimestamps {
        assert_eq!(
            stats
                .passes
                .iter()
                .filter(|(p, _)| *p == Pass::Shade)
                .count(),
            2
        );
        assert!(stats.pass_ms(Pass::Shade) > 0.0, "{stats:?}");
    }
    // A view the renderer does not have records nothing.
    apart.remove_view(second_apart).unwrap();
    let mut e = d.create_command_encoder(&Default::default());
    let err = apart.record_view(&mut e, second_apart).unwrap_err();
    assert!(matches!(err, RuntimeError::UnknownView(_)), "{err}");
}

/// An engine hands its HDR target every frame (Bevy's view target swaps
/// between two textures; its texture pool may hand out another one) and
/// its exposure: the radiance is added times the exposure into whichever
/// texture is given, and a bad scale is refused.
#[test]
fn radiance_is_added_scaled_into_a_target_given_each_frame() {
    let f = fixture();
    let (d, q) = (&f.ctx.device, &f.ctx.queue);
    let transforms = gibake_runtime::scene_transforms(&f.scene, TIME);
    let frame = FrameInput::new(camera()).transforms(&transforms);
    let mut r = renderer(&f.scene, Some(&f.asset), &settings(Mode::Indirect));
    let usage = wgpu::TextureUsages::RENDER_ATTACHMENT | wgpu::TextureUsages::COPY_SRC;
    let targets = [0, 1].map(|_| texture(wgpu::TextureFormat::Rgba16Float, usage));
    for (i, scale) in [0.5f32, 2.0, 0.25].into_iter().enumerate() {
        let t = &targets[i % 2];
        // The target starts at zero each time: what lands is scale · radiance.
        let mut enc = d.create_command_encoder(&Default::default());
        enc.begin_render_pass(&wgpu::RenderPassDescriptor {
            label: Some("clear"),
            color_attachments: &[Some(wgpu::RenderPassColorAttachment {
                view: &t.create_view(&Default::default()),
                depth_slice: None,
                resolve_target: None,
                ops: wgpu::Operations {
                    load: wgpu::LoadOp::Clear(wgpu::Color::TRANSPARENT),
                    store: wgpu::StoreOp::Store,
                },
            })],
            ..Default::default()
        });
        q.submit([enc.finish()]);
        r.set_output(d, ViewId::MAIN, OutputTarget::AddScaled(t, scale))
            .unwrap();
        draw_all(&mut [&mut r], &frame);
        let radiance = read(r.output());
        assert!(radiance.mean().x > 0.0);
        for (k, (g, e)) in read_f16(t).iter().zip(&radiance.pixels).enumerate() {
            for c in 0..3 {
                let want = scale * e[c];
                assert!(
                    (g[c] - want).abs() <= want * 2f32.powi(-9) + 1e-7,
                    "frame {i}, pixel {k}: {g:?} vs {scale} × {e:?}"
                );
            }
        }
    }
    for bad in [-1.0, f32::NAN, f32::INFINITY] {
        let e = r
            .set_output(d, ViewId::MAIN, OutputTarget::AddScaled(&targets[0], bad))
            .unwrap_err();
        assert!(matches!(e, RuntimeError::InvalidSetting(_)), "{e}");
    }
}

/// An engine's depth and normals may be other textures next frame (a
/// texture pool): given again, even between `prepare` and `record`, the
/// rebuild reads them with the prepared frame's camera.
#[test]
fn a_depth_gbuffer_given_again_between_prepare_and_record_keeps_the_camera() {
    let f = fixture();
    let (d, q) = (&f.ctx.device, &f.ctx.queue);
    let transforms = gibake_runtime::scene_transforms(&f.scene, TIME);
    let frame = FrameInput::new(camera()).transforms(&transforms);
    let s = RenderSettings {
        interleave: 1,
        ..settings(Mode::Full)
    };
    let mut own = renderer(&f.scene, Some(&f.asset), &s);
    draw_all(&mut [&mut own], &frame);
    let reference = read(own.output());
    // Two sets of the engine's buffers, as a pool would hold them: the
    // G-buffers of two renderers of the same frame.
    let mut other = renderer(&f.scene, Some(&f.asset), &s);
    draw_all(&mut [&mut other], &frame);
    let set = |r: &Renderer| -> [wgpu::Texture; 3] {
        let g = r.gbuffer_textures();
        [r.gbuffer_depth().clone(), g[1].clone(), g[2].clone()]
    };
    let pools = [set(&own), set(&other)];
    let mut engine = renderer(&f.scene, Some(&f.asset), &s);
    fn src(p: &[wgpu::Texture; 3]) -> DepthGBuffer<'_> {
        let [depth, normals, albedo] = p.each_ref();
        DepthGBuffer {
            depth,
            far_depth: 0.0,
            normals,
            encoding: NormalEncoding::Packed,
            albedo,
        }
    }
    engine
        .use_depth_gbuffer(d, ViewId::MAIN, &src(&pools[0]))
        .unwrap();
    for p in &pools {
        engine.prepare(d, q, &frame).unwrap();
        engine.use_depth_gbuffer(d, ViewId::MAIN, &src(p)).unwrap();
        let mut enc = d.create_command_encoder(&Default::default());
        engine.record(&mut enc);
        q.submit([enc.finish()]);
        let got = read(engine.output());
        let worst = got
            .pixels
            .iter()
            .zip(&reference.pixels)
            .flat_map(|(a, b)| (0..3).map(move |c| (a[c] - b[c]).abs() / b[c].abs().max(1e-3)))
            .fold(0f32, f32::max);
        assert!(worst < 1e-2, "worst relative difference {worst:.2e}");
    }
}

/// A texture far finer than the pixels (a one-texel checker tiled some
/// hundred times a pixel): the G-buffer's albedo is its mean (linear 0.5,
/// sRGB 188) from the mip chain, not whichever texel the pixel's centre
/// hits (0 or 1, changing with every step of the camera). Measured: 0.017
/// off with the chain, 0.137 with the finest level alone.
#[test]
fn a_minified_texture_gives_the_gbuffer_its_mean_albedo() {
    let f = fixture();
    let d = &f.ctx.device;
    let mut scene = f.scene.clone();
    let mut px = Vec::new();
    for i in 0..64 * 64 {
        let v = if (i % 64 + i / 64) % 2 == 0 { 255 } else { 0 };
        px.extend_from_slice(&[v, v, v, 255]);
    }
    scene.textures.push(gibake_scene::Texture {
        width: 64,
        height: 64,
        rgba8_srgb: px,
    });
    scene.materials.push(gibake_scene::Material::opaque(
        "checker",
        glam::Vec3::ONE,
        Some(scene.textures.len() - 1),
    ));
    let m = scene.materials.len() - 1;
    for mesh in &mut scene.static_meshes {
        mesh.material = m;
        mesh.uvs = Some(
            mesh.positions
                .iter()
                .map(|p| glam::Vec2::new(p.x + p.z, p.y + p.z) * 2000.0)
                .collect(),
        );
    }
    let s = RenderSettings {
        interleave: 1,
        ..settings(Mode::Direct)
    };
    let mut r = renderer(&scene, None, &s);
    let transforms = gibake_runtime::scene_transforms(&scene, TIME);
    draw_all(
        &mut [&mut r],
        &FrameInput::new(camera()).transforms(&transforms),
    );
    let albedo =
        gibake_gpu::readback::read_texture_on(d, &f.ctx.queue, &r.gbuffer_textures()[2], 0, 4)
            .unwrap();
    let depth = gibake_gpu::readback::read_texture_f32_on(d, &f.ctx.queue, r.gbuffer_depth(), 0, 1)
        .unwrap();
    // The red channel of gibake's packed albedo.
    let covered: Vec<f32> = (0..(W * H) as usize)
        .filter(|&i| depth[i] > 0.0)
        .map(|i| {
            let b = &albedo[4 * i..4 * i + 4];
            gibake_runtime::unpack_albedo(u32::from_le_bytes([b[0], b[1], b[2], b[3]]))[0]
        })
        .collect();
    assert!(
        covered.len() > (W * H / 2) as usize,
        "{} covered",
        covered.len()
    );
    let off = covered.iter().map(|a| (a - 0.5).abs()).sum::<f32>() / covered.len() as f32;
    eprintln!(
        "{} covered samples, mean |albedo − 0.5| = {off:.3}",
        covered.len()
    );
    assert!(off < 0.03, "mean albedo off its texture's mean by {off:.3}");
}
