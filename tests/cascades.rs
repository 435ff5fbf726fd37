//! Runtime cascades (issue 16, part 2): on a large level the direct light's
//! shadows come from cascades fitted to the camera and the image is closer
//! to the CPU reference than with the single primary map; a small scene
//! keeps exactly the single map (same passes, same bytes); moving objects
//! cast into the cascades as static ones do; nothing turns NaN at a
//! grazing sun.

use crate::common;

use gibake_image::Image;
use gibake_reference::scenes::{cuboid, directional, material, static_scene};
use gibake_runtime::{
    CameraMatrices, Cascades, FrameInput, Mode, Pass, RenderSettings, Renderer, glam,
};
use gibake_scene::{Aabb, DynamicObject, LoadOptions, Mesh, Projection, Scene};
use glam::{Mat4, Vec3};

const W: u32 = 192;
const H: u32 = 108;
const FOV: f32 = std::f32::consts::FRAC_PI_3;

/// A square ground of `side` metres at y = 0 as a `k × k` grid (terrain is
/// tessellated; its triangles are the level's detail scale).
fn ground(side: f32, k: u32) -> Mesh {
    let mut positions = Vec::new();
    let mut indices = Vec::new();
    let step = side / k as f32;
    for j in 0..=k {
        for i in 0..=k {
            positions.push(Vec3::new(
                -0.5 * side + i as f32 * step,
                0.0,
                -0.5 * side + j as f32 * step,
            ));
        }
    }
    for j in 0..k {
        for i in 0..k {
            let a = j * (k + 1) + i;
            let (b, c, d) = (a + 1, a + k + 1, a + k + 2);
            indices.extend([a, c, b, b, c, d]);
        }
    }
    Mesh {
        name: "ground".into(),
        normals: vec![Vec3::Y; positions.len()],
        positions,
        uvs: None,
        indices,
        material: 0,
    }
}

/// 400 m of ground with a few posts and a low wall a few metres in front
/// of the camera, lit by a low sun.
fn field(sun: Vec3) -> Scene {
    let mut meshes = vec![ground(400.0, 64)];
    for (i, x) in [-1.5f32, -0.5, 0.5, 1.5].iter().enumerate() {
        meshes.push(cuboid(
            &format!("post{i}"),
            Vec3::new(*x - 0.1, 0.0, -6.0),
            Vec3::new(*x + 0.1, 1.2, -5.8),
            1,
        ));
    }
    meshes.push(cuboid(
        "wall",
        Vec3::new(-3.0, 0.0, -10.0),
        Vec3::new(3.0, 0.6, -9.7),
        1,
    ));
    // Something far away, so the single map really spans the field.
    meshes.push(cuboid(
        "far",
        Vec3::new(150.0, 0.0, -150.0),
        Vec3::new(160.0, 8.0, -140.0),
        1,
    ));
    static_scene(
        "field",
        directional(sun, Vec3::splat(3.0)),
        vec![
            material("ground", Vec3::splat(0.6)),
            material("post", Vec3::new(0.7, 0.5, 0.3)),
        ],
        meshes,
    )
}

/// The camera: 1.7 m above the ground, looking down the field.
fn camera_to_world() -> Mat4 {
    let eye = Vec3::new(0.0, 1.7, 0.0);
    let fwd = (Vec3::new(0.0, 0.2, -8.0) - eye).normalize();
    let x = fwd.cross(Vec3::Y).normalize();
    let y = x.cross(fwd);
    Mat4::from_cols(
        x.extend(0.0),
        y.extend(0.0),
        (-fwd).extend(0.0),
        eye.extend(1.0),
    )
}

fn camera() -> CameraMatrices {
    CameraMatrices::perspective(camera_to_world(), FOV, W as f32 / H as f32, 0.05)
}

fn settings(cascades: Cascades) -> RenderSettings {
    RenderSettings {
        width: W,
        height: H,
        mode: Mode::Direct,
        shadow_map_size: 1024,
        cascades,
        ..Default::default()
    }
}

/// Renders `scene` in direct mode from `camera()` with `moved` objects.
fn render(
    ctx: &gibake_gpu::GpuContext,
    scene: &Scene,
    s: &RenderSettings,
    moved: &[Mat4],
) -> (Image, Option<gibake_runtime::CascadeLayout>) {
    let (d, q) = (&ctx.device, &ctx.queue);
    let mut r = Renderer::new(d, q, scene, None, s).unwrap();
    r.prepare(d, q, &FrameInput::new(camera()).transforms(moved))
        .unwrap();
    let mut enc = d.create_command_encoder(&Default::default());
    r.record(&mut enc);
    q.submit([enc.finish()]);
    let img = gibake_eval::frame::read_output(&r, d, q, 1).unwrap();
    (img, r.plan().cascades())
}

fn reference(scene: &Scene) -> Image {
    let rs = gibake_reference::RayScene::build(scene, 0.0);
    let view = gibake_reference::View::from_matrix(
        camera_to_world(),
        Projection::Perspective {
            yfov: FOV,
            znear: 0.05,
            zfar: None,
        },
    );
    let s = gibake_reference::Settings {
        width: W,
        height: H,
        spp: 16,
        time: 0.0,
        depth: gibake_reference::Depth::Direct,
        seed: 3,
    };
    gibake_reference::render_view(&rs, &view, &s, &|_| {}).unwrap()
}

#[test]
fn a_large_level_gets_cascades_and_is_closer_to_the_reference() {
    let ctx = common::gpu();
    let scene = field(Vec3::new(0.45, -0.6, 0.35));
    let (auto, layout) = render(&ctx, &scene, &settings(Cascades::Auto), &[]);
    let layout = layout.expect("auto turns cascades on for a 400 m field");
    assert!((2..=4).contains(&layout.count), "{layout:?}");
    let (off, none) = render(&ctx, &scene, &settings(Cascades::Off), &[]);
    assert!(none.is_none());
    let reference = reference(&scene);
    let (e_auto, e_off) = (
        gibake_image::rel_mse(&auto, &reference),
        gibake_image::rel_mse(&off, &reference),
    );
    eprintln!("direct rel MSE: cascades {e_auto:.5}, single map {e_off:.5}, {layout:?}");
    assert!(auto.all_finite() && off.all_finite());
    assert!(
        e_auto < 0.5 * e_off,
        "cascades {e_auto} not clearly closer to the reference than the single map {e_off}"
    );
}

#[test]
fn a_small_scene_keeps_the_single_map_bit_for_bit() {
    let ctx = common::gpu();
    for name in ["corner_bunny.glb", "sun.glb"] {
        let scene = gibake_scene::load(&common::data(name), &LoadOptions::default()).unwrap();
        let mut images = Vec::new();
        for c in [Cascades::Auto, Cascades::Off] {
            let s = RenderSettings {
                width: 96,
                height: 96,
                mode: Mode::Direct,
                cascades: c,
                ..Default::default()
            };
            let (d, q) = (&ctx.device, &ctx.queue);
            let mut r = Renderer::new(d, q, &scene, None, &s).unwrap();
            assert!(
                r.plan().cascades().is_none(),
                "{name}: {c:?} planned cascades"
            );
            assert!(!r.plan().has(Pass::Cascades), "{name}");
            r.prepare_at_time(d, q, &scene, 0.5).unwrap();
            let mut enc = d.create_command_encoder(&Default::default());
            r.record(&mut enc);
            q.submit([enc.finish()]);
            let stats = r.stats(d);
            assert!(stats.passes.iter().all(|(p, _)| *p != Pass::Cascades));
            images.push(gibake_eval::frame::read_output(&r, d, q, 1).unwrap());
        }
        assert_eq!(
            images[0].pixels, images[1].pixels,
            "{name}: auto changed the image"
        );
        // Forced on, the same scene renders (and stays finite).
        let s = RenderSettings {
            width: 96,
            height: 96,
            mode: Mode::Direct,
            cascades: Cascades::On,
            ..Default::default()
        };
        let img =
            gibake_eval::frame::render_image(&ctx.device, &ctx.queue, &scene, None, &s, 0.5, 1)
                .unwrap();
        assert!(img.all_finite(), "{name}: forced cascades gave NaN");
    }
}

#[test]
fn moving_objects_cast_into_the_cascades_like_static_ones() {
    let ctx = common::gpu();
    let sun = Vec3::new(0.45, -0.6, 0.35);
    let min = Vec3::new(-0.4, 0.0, -0.4);
    let max = Vec3::new(0.4, 1.0, 0.4);
    let at = Mat4::from_translation(Vec3::new(0.8, 0.0, -4.5));
    // The same box, static at `at`...
    let mut fixed = field(sun);
    let mut b = cuboid("box", min, max, 1);
    for p in &mut b.positions {
        *p = at.transform_point3(*p);
    }
    fixed.static_meshes.push(b);
    // ... or moving, drawn at `at` by the frame's transform.
    let mut moving = field(sun);
    moving.dynamic_meshes.push(cuboid("box", min, max, 1));
    moving.dynamic_objects.push(DynamicObject {
        name: "box".into(),
        node: usize::MAX,
        meshes: vec![0],
        local_bounds: Aabb { min, max },
    });
    let on = settings(Cascades::On);
    let (a, la) = render(&ctx, &fixed, &on, &[]);
    let (b, lb) = render(&ctx, &moving, &on, &[at]);
    assert!(la.is_some() && lb.is_some());
    let (empty, _) = render(
        &ctx,
        &moving,
        &on,
        &[Mat4::from_translation(Vec3::Y * -50.0)],
    );
    let e = gibake_image::rel_mse(&b, &a);
    let shadow = gibake_image::rel_mse(&empty, &a);
    eprintln!("moving vs static box: rel MSE {e:.6}; without the box {shadow:.6}");
    assert!(shadow > 1e-3, "the box casts no visible shadow ({shadow})");
    assert!(
        e < 0.05 * shadow,
        "the moving box's shadow differs from the static one's: {e} (its shadow alone {shadow})"
    );
}

#[test]
fn no_nan_at_a_grazing_sun() {
    let ctx = common::gpu();
    for sun in [
        Vec3::new(1.0, -1e-4, 0.0),
        Vec3::new(0.3, -0.02, -1.0),
        Vec3::new(0.0, -1.0, 0.0),
    ] {
        let scene = field(sun);
        let (img, layout) = render(&ctx, &scene, &settings(Cascades::On), &[]);
        assert!(layout.is_some());
        assert!(img.all_finite(), "sun {sun}: non-finite pixels");
    }
}

/// The automatic rule on the bundled scenes and a real level: the small
/// scenes stay below the threshold, the 98 m arena is above it.
#[test]
fn the_automatic_rule_on_bundled_scenes_and_the_arena() {
    use gibake_runtime::cascades::{COARSE, coarseness};
    let mut seen = Vec::new();
    for name in ["corner_bunny.glb", "sun.glb", "occluded.glb"] {
        let scene = gibake_scene::load(&common::data(name), &LoadOptions::default()).unwrap();
        let view = gibake_gpu::LightView::for_scene(&scene, 2048);
        let r = coarseness(&scene, &view, 270);
        seen.push(format!("{name}: {r:?}"));
        if view.directional {
            assert!(r.is_some_and(|r| r <= COARSE), "{}", seen.join("; "));
        }
    }
    let list = gibake_eval::levels::bundled_list();
    let specs = gibake_eval::levels::read_specs(&list).unwrap();
    let arena = specs.iter().find(|l| l.name == "arena").unwrap();
    let scene = arena.load(list.parent().unwrap()).unwrap();
    let view = gibake_gpu::LightView::for_scene(&scene, 2048);
    let r = coarseness(&scene, &view, 270);
    seen.push(format!("arena: {r:?}"));
    eprintln!("{}", seen.join("; "));
    assert!(r.is_some_and(|r| r > COARSE), "{}", seen.join("; "));
}

/// A still camera draws the static cascades once; a moving camera again;
/// `Requirements` counts the cascades' memory.
#[test]
fn a_still_camera_redraws_nothing_and_the_memory_is_counted() {
    let ctx = common::gpu();
    let scene = field(Vec3::new(0.45, -0.6, 0.35));
    let (d, q) = (&ctx.device, &ctx.queue);
    let s = settings(Cascades::On);
    let mut r = Renderer::new(d, q, &scene, None, &s).unwrap();
    let layout = r.plan().cascades().unwrap();
    let frame = |r: &mut Renderer, cam: CameraMatrices| {
        r.prepare(d, q, &FrameInput::new(cam)).unwrap();
        let mut enc = d.create_command_encoder(&Default::default());
        r.record(&mut enc);
        q.submit([enc.finish()]);
        let st = r.stats(d);
        (
            st.passes.iter().any(|(p, _)| *p == Pass::Cascades),
            st.update_draw_calls,
        )
    };
    let statics = scene.static_meshes.len() as u32;
    assert_eq!(frame(&mut r, camera()), (true, layout.count * statics));
    assert_eq!(frame(&mut r, camera()), (false, 0), "a still camera redrew");
    let moved = CameraMatrices::perspective(
        Mat4::from_translation(Vec3::new(3.0, 0.0, -2.0)) * camera_to_world(),
        FOV,
        W as f32 / H as f32,
        0.05,
    );
    let (drawn, calls) = frame(&mut r, moved);
    assert!(
        drawn && calls >= statics,
        "a moved camera drew {calls} static draws"
    );
    let bytes = |c| {
        gibake_runtime::Requirements::of(&scene, None, &settings(c))
            .unwrap()
            .gpu_bytes
    };
    let size = u64::from(layout.size);
    assert_eq!(
        bytes(Cascades::On) - bytes(Cascades::Off),
        u64::from(layout.count) * 8 * size * size
    );
}
