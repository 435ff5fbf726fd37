//! The game-facing API as an engine uses it: the game's own camera on a
//! scene without one, objects moved by handle, resize, a caller-provided
//! output, and each typed error (bad settings, a missing or foreign asset,
//! device limits, wrong transform lists, foreign handles, a bad output
//! target) — none of them a panic, none quoting a command line.

use std::sync::OnceLock;

use gibake_bake::cluster::ClusterTarget;
use gibake_gpu::GpuContext;
use gibake_runtime::glam::{Mat4, Vec3};
use gibake_runtime::{
    Asset, CameraMatrices, FrameInput, Image, Mode, OUTPUT_FORMAT, OutputTarget, RenderSettings,
    Renderer, RuntimeError, Scene, ViewId, wgpu,
};

const TIME: f32 = 0.7;

struct Fixture {
    ctx: GpuContext,
    scene: Scene,
    asset: Asset,
}

/// One bake of corner_bunny (small maps) shared by the tests.
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
        let opts = gibake_bake::BakeOptions {
            rsm_size: 128,
            vpl_map_size: 16,
            shadow_map_size: 256,
            target: ClusterTarget::Count(64),
            // The first bounce alone (what this checks).
            bounces: gibake_bake::later::Bounces::Count(1),
            later_vpls: None,
        };
        let asset = gibake_bake::bake(&ctx, &scene, &opts, &gibake_bake::NoProgress, "test")
            .expect("bake")
            .asset;
        Fixture { ctx, scene, asset }
    })
}

fn settings(width: u32, height: u32) -> RenderSettings {
    RenderSettings {
        width,
        height,
        max_dynamic_vpls: 16,
        ..Default::default()
    }
}

fn renderer(s: &RenderSettings) -> Renderer {
    let f = fixture();
    Renderer::new(&f.ctx.device, &f.ctx.queue, &f.scene, Some(&f.asset), s).expect("renderer")
}

/// Prepares `frame`, records, submits and reads the output back.
fn draw(r: &mut Renderer, frame: &FrameInput<'_>) -> Image {
    let ctx = &fixture().ctx;
    r.prepare(&ctx.device, &ctx.queue, frame).expect("prepare");
    let mut enc = ctx.device.create_command_encoder(&Default::default());
    r.record(&mut enc);
    ctx.queue.submit([enc.finish()]);
    read(r)
}

/// The renderer's output, read back.
fn read(r: &Renderer) -> Image {
    let ctx = &fixture().ctx;
    let out = r.output();
    let data = gibake_gpu::readback::read_texture_f32_on(&ctx.device, &ctx.queue, out, 0, 4)
        .expect("read back");
    Image::from_rgba_f32(out.width(), out.height(), &data)
}

/// The scene's own frame at `time` through `prepare_at_time`.
fn scene_frame(scene: &Scene, s: &RenderSettings, time: f32) -> Result<Image, RuntimeError> {
    let f = fixture();
    let mut r = Renderer::new(&f.ctx.device, &f.ctx.queue, scene, Some(&f.asset), s)?;
    r.prepare_at_time(&f.ctx.device, &f.ctx.queue, scene, time)?;
    let mut enc = f.ctx.device.create_command_encoder(&Default::default());
    r.record(&mut enc);
    f.ctx.queue.submit([enc.finish()]);
    Ok(read(&r))
}

/// The scene's camera at `TIME`, rebuilt the way a game builds its own.
fn games_camera(width: u32, height: u32) -> CameraMatrices {
    let scene = &fixture().scene;
    let cam = scene.camera.as_ref().expect("corner_bunny has a camera");
    let world = scene.camera_transform(TIME).expect("camera transform");
    match cam.projection {
        gibake_runtime::Projection::Perspective { yfov, znear, .. } => {
            CameraMatrices::perspective(world, yfov, width as f32 / height as f32, znear)
        }
        _ => panic!("corner_bunny's camera is a perspective one"),
    }
}

fn no_cli_flag(e: &RuntimeError) {
    let m = e.to_string();
    assert!(!m.contains("--"), "a runtime error quotes a flag: {m}");
}

#[test]
fn a_scene_without_a_camera_renders_with_the_games_camera() {
    let f = fixture();
    let s = settings(48, 40);
    let expected = scene_frame(&f.scene, &s, TIME).unwrap();
    let mut camless = f.scene.clone();
    camless.camera = None;
    let mut r = Renderer::new(&f.ctx.device, &f.ctx.queue, &camless, Some(&f.asset), &s)
        .expect("no camera needed to create a renderer");
    let transforms = gibake_runtime::scene_transforms(&camless, TIME);
    let img = draw(
        &mut r,
        &FrameInput::new(games_camera(48, 40)).transforms(&transforms),
    );
    assert!(img.mean().x > 0.0, "black frame");
    assert_eq!(img, expected);
    // Only a tool that wants the scene's camera needs one.
    let e = scene_frame(&camless, &s, TIME).unwrap_err();
    assert!(matches!(e, RuntimeError::NoCamera(_)), "{e}");
    no_cli_flag(&e);
}

#[test]
fn objects_move_by_handle_like_by_the_full_list() {
    let f = fixture();
    let s = settings(40, 40);
    let transforms = gibake_runtime::scene_transforms(&f.scene, TIME);
    assert!(transforms.len() > 1, "corner_bunny has moving balls");
    let camera = games_camera(40, 40);

    let mut by_list = renderer(&s);
    let a = draw(
        &mut by_list,
        &FrameInput::new(camera).transforms(&transforms),
    );

    let mut by_handle = renderer(&s);
    let names: Vec<String> = by_handle.objects().map(|(_, n)| n.to_string()).collect();
    assert_eq!(names.len(), transforms.len());
    let moved: Vec<_> = names
        .iter()
        .map(|n| {
            let h = by_handle.object(n).expect("lookup by name");
            (h, transforms[h.index()])
        })
        .collect();
    assert!(by_handle.object("no such object").is_none());
    let b = draw(&mut by_handle, &FrameInput::new(camera).moving(&moved));
    assert_eq!(a, b);
    // Moving one object changes the frame; putting it back restores it.
    let (h, m) = moved[0];
    let away = [(h, Mat4::from_translation(Vec3::new(0.0, 0.3, 0.0)) * m)];
    let c = draw(&mut by_handle, &FrameInput::new(camera).moving(&away));
    assert_ne!(a, c, "moving {} changed nothing", names[0]);
    assert_eq!(by_handle.transform(h).unwrap(), away[0].1);
    let back = draw(&mut by_handle, &FrameInput::new(camera).moving(&[(h, m)]));
    assert_eq!(a, back);
}

#[test]
fn a_transform_list_of_the_wrong_length_is_an_error() {
    let f = fixture();
    let mut r = renderer(&settings(16, 16));
    let n = r.objects().count();
    let short = vec![Mat4::IDENTITY; n - 1];
    let e = r
        .prepare(
            &f.ctx.device,
            &f.ctx.queue,
            &FrameInput::new(games_camera(16, 16)).transforms(&short),
        )
        .unwrap_err();
    match &e {
        RuntimeError::TransformCount { expected, got } => assert_eq!((*expected, *got), (n, n - 1)),
        other => panic!("wrong error: {other}"),
    }
    no_cli_flag(&e);
    // Nothing moved: the objects keep their matrices.
    let h = r.objects().next().unwrap().0;
    assert_eq!(
        r.transform(h).unwrap(),
        gibake_runtime::scene_transforms(&f.scene, 0.0)[0]
    );
}

#[test]
fn a_handle_of_another_renderer_is_an_error() {
    let f = fixture();
    let s = settings(16, 16);
    let mut mine = renderer(&s);
    let other = renderer(&s);
    let foreign = other.objects().next().unwrap().0;
    assert_eq!(foreign.index(), 0);
    let e = mine
        .prepare(
            &f.ctx.device,
            &f.ctx.queue,
            &FrameInput::new(games_camera(16, 16)).moving(&[(foreign, Mat4::IDENTITY)]),
        )
        .unwrap_err();
    assert!(
        matches!(e, RuntimeError::UnknownObject(h) if h == foreign),
        "{e}"
    );
    no_cli_flag(&e);
    assert!(matches!(
        mine.transform(foreign),
        Err(RuntimeError::UnknownObject(_))
    ));
}

#[test]
fn device_limits_are_errors_not_panics() {
    let f = fixture();
    let limit = f.ctx.device.limits().max_texture_dimension_2d;
    // An output over the largest texture.
    let big = Renderer::new(
        &f.ctx.device,
        &f.ctx.queue,
        &f.scene,
        Some(&f.asset),
        &settings(limit + 1, 8),
    );
    match big {
        Err(RuntimeError::DeviceLimit {
            needed, limit: l, ..
        }) => {
            assert_eq!((needed, l), (u64::from(limit) + 1, u64::from(limit)))
        }
        Err(e) => panic!("wrong error: {e}"),
        Ok(_) => panic!("an output over the device limit was accepted"),
    }
    // Resizing past it, likewise; the renderer keeps working at its size.
    let mut r = renderer(&settings(24, 24));
    let e = r
        .resize(&f.ctx.device, &f.ctx.queue, 24, limit + 1)
        .unwrap_err();
    assert!(matches!(e, RuntimeError::DeviceLimit { .. }), "{e}");
    no_cli_flag(&e);
    assert_eq!(r.size(), (24, 24));
    let img = draw(&mut r, &FrameInput::new(games_camera(24, 24)));
    assert!(img.mean().x > 0.0);

    // A device whose textures cannot hold the asset's 64 maps of 16² (8×8
    // tiles need 128²), or whose storage bindings cannot hold its VPLs.
    for (what, limits) in [
        (
            "texture size",
            wgpu::Limits {
                max_texture_dimension_2d: 64,
                ..f.ctx.adapter.limits()
            },
        ),
        (
            "storage binding",
            wgpu::Limits {
                max_storage_buffer_binding_size: 256,
                ..f.ctx.adapter.limits()
            },
        ),
    ] {
        let (device, queue) =
            pollster::block_on(f.ctx.adapter.request_device(&wgpu::DeviceDescriptor {
                required_limits: limits,
                ..Default::default()
            }))
            .expect("a device with lower limits");
        match Renderer::new(&device, &queue, &f.scene, Some(&f.asset), &settings(16, 16)) {
            Err(RuntimeError::DeviceLimit { needed, limit, .. }) => {
                assert!(needed > limit, "{what}: {needed} ≤ {limit}")
            }
            Err(e) => panic!("{what}: wrong error: {e}"),
            Ok(_) => panic!("{what}: an asset over the device's limits was accepted"),
        }
    }
}

#[test]
fn bad_settings_and_a_missing_or_foreign_asset_are_errors() {
    let f = fixture();
    let (d, q) = (&f.ctx.device, &f.ctx.queue);
    let mut errors = Vec::new();
    let zero = Renderer::new(d, q, &f.scene, Some(&f.asset), &settings(0, 8));
    errors.push(zero.err().expect("zero width accepted"));
    let il = RenderSettings {
        interleave: 3,
        ..settings(8, 8)
    };
    errors.push(
        Renderer::new(d, q, &f.scene, Some(&f.asset), &il)
            .err()
            .expect("interleave 3 accepted"),
    );
    for descent in [0, 3, 33] {
        let nf = RenderSettings {
            near_field_descent: descent,
            ..settings(8, 8)
        };
        let e = Renderer::new(d, q, &f.scene, Some(&f.asset), &nf)
            .err()
            .unwrap_or_else(|| panic!("near-field descent {descent} accepted"));
        assert!(e.to_string().contains("near-field descent"), "{e}");
        errors.push(e);
    }
    let later = RenderSettings {
        later_near_field_descent: 33,
        ..settings(8, 8)
    };
    let e = Renderer::new(d, q, &f.scene, Some(&f.asset), &later)
        .err()
        .expect("later-bounce descent 33 accepted");
    assert!(
        e.to_string().contains("later bounces' near-field descent"),
        "{e}"
    );
    errors.push(e);
    for e in &errors {
        assert!(matches!(e, RuntimeError::InvalidSetting(_)), "{e}");
    }
    let full = Renderer::new(d, q, &f.scene, None, &settings(8, 8))
        .err()
        .expect("full mode without an asset accepted");
    assert!(matches!(full, RuntimeError::NeedsAsset("full")), "{full}");
    // Direct mode needs none.
    let direct = RenderSettings {
        mode: Mode::Direct,
        ..settings(8, 8)
    };
    assert!(Renderer::new(d, q, &f.scene, None, &direct).is_ok());
    // An asset baked from other static geometry.
    let mut moved = f.scene.clone();
    moved.static_meshes[0].positions[0] += Vec3::splat(0.01);
    let foreign = Renderer::new(d, q, &moved, Some(&f.asset), &settings(8, 8))
        .err()
        .expect("an asset of another scene accepted");
    assert!(matches!(foreign, RuntimeError::Asset(_)), "{foreign}");
    errors.extend([full, foreign]);
    for e in &errors {
        no_cli_flag(e);
    }
}

#[test]
fn resize_renders_at_the_new_size_like_a_new_renderer() {
    let f = fixture();
    let mut r = renderer(&settings(32, 32));
    let _ = draw(&mut r, &FrameInput::new(games_camera(32, 32)));
    r.resize(&f.ctx.device, &f.ctx.queue, 40, 24).unwrap();
    assert_eq!(r.size(), (40, 24));
    assert_eq!((r.output().width(), r.output().height()), (40, 24));
    let transforms = gibake_runtime::scene_transforms(&f.scene, TIME);
    let frame = FrameInput::new(games_camera(40, 24)).transforms(&transforms);
    let resized = draw(&mut r, &frame);
    let fresh = draw(&mut renderer(&settings(40, 24)), &frame);
    assert!(resized.mean().x > 0.0);
    assert_eq!(resized, fresh);
}

#[test]
fn a_caller_provided_output_gets_the_frame_and_a_bad_one_is_an_error() {
    let f = fixture();
    let d = &f.ctx.device;
    let texture = |w, h, format, usage| {
        d.create_texture(&wgpu::TextureDescriptor {
            label: Some("game's target"),
            size: wgpu::Extent3d {
                width: w,
                height: h,
                depth_or_array_layers: 1,
            },
            mip_level_count: 1,
            sample_count: 1,
            dimension: wgpu::TextureDimension::D2,
            format,
            usage,
            view_formats: &[],
        })
    };
    let good_usage = wgpu::TextureUsages::STORAGE_BINDING
        | wgpu::TextureUsages::TEXTURE_BINDING
        | wgpu::TextureUsages::COPY_SRC;
    let mut r = renderer(&settings(32, 32));
    for bad in [
        texture(32, 32, wgpu::TextureFormat::Rgba8Unorm, good_usage),
        texture(32, 16, OUTPUT_FORMAT, good_usage),
        texture(32, 32, OUTPUT_FORMAT, wgpu::TextureUsages::TEXTURE_BINDING),
    ] {
        let e = r
            .set_output(d, ViewId::MAIN, OutputTarget::Texture(&bad))
            .unwrap_err();
        assert!(matches!(e, RuntimeError::OutputTarget(_)), "{e}");
        no_cli_flag(&e);
    }
    let frame = FrameInput::new(games_camera(32, 32));
    let own = draw(&mut r, &frame);
    let target = texture(32, 32, OUTPUT_FORMAT, good_usage);
    r.set_output(d, ViewId::MAIN, OutputTarget::Texture(&target))
        .unwrap();
    let theirs = draw(&mut r, &frame);
    let data = gibake_gpu::readback::read_texture_f32_on(d, &f.ctx.queue, &target, 0, 4).unwrap();
    assert_eq!(Image::from_rgba_f32(32, 32, &data), own);
    assert_eq!(theirs, own);
}
