//! Issue 2's acceptance check: on every bundled scene at 256×256 and two
//! animation times, the GPU's direct light agrees with the CPU reference's
//! direct-only path tracing (256 spp): relative MSE ≤ 0.02. And issue 49's
//! narrow shadows: a groove about one shadow-map texel deep under a low sun
//! keeps its shadow at the default map (2048²).

use crate::common;

use gibake_gpu::LightView;
use gibake_reference::scenes::{cuboid, directional, material, static_scene};
use gibake_runtime::glam::{Mat4, Vec3};
use gibake_runtime::{CameraMatrices, FrameInput, Mode, RenderSettings, Renderer};
use gibake_scene::{LoadOptions, Projection, Scene};

#[test]
fn gpu_direct_matches_reference_direct_on_bundled_scenes() {
    let ctx = common::gpu();
    let mut report = Vec::new();
    for name in ["corner_bunny.glb", "occluded.glb", "sun.glb"] {
        let scene = gibake_scene::load(&common::data(name), &LoadOptions::default()).unwrap();
        for time in [0.0f32, 1.3] {
            let settings = gibake_runtime::RenderSettings {
                width: 256,
                height: 256,
                shadow_map_size: 2048,
                mode: gibake_runtime::Mode::Direct,
                ..Default::default()
            };
            let gpu = gibake_eval::frame::render_image(
                &ctx.device,
                &ctx.queue,
                &scene,
                None,
                &settings,
                time,
                2,
            )
            .unwrap();
            let reference = gibake_reference::render(
                &scene,
                &gibake_reference::Settings {
                    width: 256,
                    height: 256,
                    spp: 256,
                    time,
                    depth: gibake_reference::Depth::Direct,
                    seed: 7,
                },
                &|_| {},
            )
            .unwrap();
            assert!(gpu.all_finite(), "{name} t={time}: non-finite pixels");
            let mean = reference.mean();
            assert!(
                mean.max_element() > 0.0,
                "{name} t={time}: the reference is black"
            );
            let e = gibake_image::rel_mse(&gpu, &reference);
            report.push(format!("{name} t={time}: rel MSE {e:.5}"));
            assert!(
                e <= 0.02,
                "{name} t={time}: rel MSE {e} > 0.02\n{}",
                report.join("\n")
            );
        }
    }
    eprintln!("{}", report.join("\n"));
}

/// Width and depth of the groove (m), cut across a 1 m slab whose top is
/// at y = 0: at the default 2048² map over the slab (a texel of 0.60 mm,
/// the fitted light view's) it is 6.7 texels wide and 1.3 deep.
const GROOVE_WIDTH: f32 = 0.004;
const GROOVE_DEPTH: f32 = 0.0008;

/// The sun's direction of travel: from azimuth 80°, 15° above the horizon,
/// across the groove (which runs along z), so that the groove's sun-side
/// wall shadows three quarters of its floor (0.8 mm / tan 15° = 3.0 mm of
/// 4 mm).
fn low_sun() -> Vec3 {
    let (az, el) = (80f32.to_radians(), 15f32.to_radians());
    -Vec3::new(az.sin() * el.cos(), el.sin(), -az.cos() * el.cos())
}

/// A 1 m slab (three blocks) with a shallow groove along z at x = 0.
fn grooved_slab() -> Scene {
    let (w, d) = (0.5 * GROOVE_WIDTH, GROOVE_DEPTH);
    static_scene(
        "grooved slab",
        directional(low_sun(), Vec3::splat(3.0)),
        vec![material("stone", Vec3::splat(0.6))],
        vec![
            cuboid(
                "base",
                Vec3::new(-0.5, -d - 0.1, -0.5),
                Vec3::new(0.5, -d, 0.5),
                0,
            ),
            cuboid(
                "left",
                Vec3::new(-0.5, -d, -0.5),
                Vec3::new(-w, 0.0, 0.5),
                0,
            ),
            cuboid("right", Vec3::new(w, -d, -0.5), Vec3::new(0.5, 0.0, 0.5), 0),
        ],
    )
}

/// A camera 1.2 cm from the groove, looking into it from the sun's side.
fn groove_camera() -> Mat4 {
    let eye = Vec3::new(0.006, 0.006, 0.01);
    let fwd = (Vec3::new(-0.0005, -0.0008, 0.0) - eye).normalize();
    let x = fwd.cross(Vec3::Y).normalize();
    let y = x.cross(fwd);
    Mat4::from_cols(
        x.extend(0.0),
        y.extend(0.0),
        (-fwd).extend(0.0),
        eye.extend(1.0),
    )
}

/// Issue 49, item 4: "sunlight inside a groove" at the default map. The
/// old test (a normal offset of sinθ texel footprints and a depth bias of
/// one) looked the floor up about a footprint above it, over the groove's
/// rim: the shadowed band lost most of its shadow (mean +25.0%, rel MSE
/// 0.45 on lavapipe; at 8192² still +5.6%, 0.087). The receiver-plane
/// test keeps it (mean −1.1%, rel MSE 0.053, what is left being the
/// shadow edge's texel staircase; 0.0088 at 8192²): docs/method.md,
/// "Narrow shadows".
#[test]
fn a_groove_one_texel_deep_keeps_its_shadow_at_the_default_map() {
    let ctx = common::gpu();
    let scene = grooved_slab();
    // What the test is about: a groove about one texel of the default map
    // deep (the slab's fitted view decides the texel).
    let texel = LightView::for_scene(&scene, 2048).texel_scale;
    let depth_texels = GROOVE_DEPTH / texel;
    assert!(
        (0.8..1.6).contains(&depth_texels),
        "the groove is {depth_texels} texels deep (texel {texel} m)"
    );
    let (size, ssaa) = (96u32, 2u32);
    let fov = 30f32.to_radians();
    let settings = RenderSettings {
        width: size * ssaa,
        height: size * ssaa,
        mode: Mode::Direct,
        shadow_map_size: 2048,
        ..Default::default()
    };
    let (d, q) = (&ctx.device, &ctx.queue);
    let mut r = Renderer::new(d, q, &scene, None, &settings).unwrap();
    let camera = CameraMatrices::perspective(groove_camera(), fov, 1.0, 1e-4);
    r.prepare(d, q, &FrameInput::new(camera)).unwrap();
    let mut enc = d.create_command_encoder(&Default::default());
    r.record(&mut enc);
    q.submit([enc.finish()]);
    let gpu = gibake_eval::frame::read_output(&r, d, q, ssaa).unwrap();
    let rs = gibake_reference::RayScene::build(&scene, 0.0);
    let view = gibake_reference::View::from_matrix(
        groove_camera(),
        Projection::Perspective {
            yfov: fov,
            znear: 1e-4,
            zfar: None,
        },
    );
    let reference = gibake_reference::render_view(
        &rs,
        &view,
        &gibake_reference::Settings {
            width: size,
            height: size,
            spp: 64,
            time: 0.0,
            depth: gibake_reference::Depth::Direct,
            seed: 11,
        },
        &|_| {},
    )
    .unwrap();
    assert!(gpu.all_finite(), "non-finite pixels");
    let (mg, mr) = (gpu.mean(), reference.mean());
    assert!(mr.max_element() > 0.0, "the reference is black");
    let bias = (mg.x + mg.y + mg.z) / (mr.x + mr.y + mr.z) - 1.0;
    let e = gibake_image::rel_mse(&gpu, &reference);
    eprintln!(
        "groove {depth_texels:.2} texels deep: direct mean {:+.1}% against the reference, rel MSE {e:.4}",
        100.0 * bias
    );
    assert!(
        bias.abs() <= 0.06,
        "the groove's direct light is {:+.1}% off the reference (light through its shadow)",
        100.0 * bias
    );
    assert!(e <= 0.1, "direct rel MSE {e} > 0.1 in the groove");
}
