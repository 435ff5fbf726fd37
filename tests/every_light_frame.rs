//! Every light at frame level (issue 19): the bake of every light (asset
//! format 4) rendered by the runtime — each light's direct light with its
//! shadow maps, moving objects merged into the views they touch, the VPLs
//! of every light in one list — against the CPU reference lit by every
//! light, on the bundled multi-light room (`data/lamps.glb`: a spot and two
//! point lamps, three moving balls) and on the seeded random multi-light
//! generator's first seeds (nothing chosen: seeds 0–2; seed 2 is a single
//! point light, which has no primary map and is shaded by its six faces).
//!
//! Per scene: image rel MSE ≤ 0.06, direct rel MSE ≤ 0.03, `full`'s mean
//! indirect within ±7% per channel, `full`'s blurred indirect error at most
//! `rsm`'s, `naive` = `full`, every image finite; a known failure is held
//! to the looser bound it meets, and says why. The full-size figures and
//! the real levels of data/lights/ are `eval_lights`' (docs/results.md,
//! "Every light").

use crate::common;

use gibake_eval::EvalSettings;
use gibake_eval::levels::judge_level;
use gibake_image::rel_mse;
use gibake_runtime::{Mode, Pass, RenderSettings, Renderer};
use gibake_scene::{LoadOptions, Scene};

fn every_light() -> LoadOptions {
    LoadOptions::default()
}

fn lamps() -> Scene {
    gibake_scene::load(&common::data("lamps.glb"), &every_light()).expect("data/lamps.glb")
}

fn random(seed: u64) -> (String, Scene) {
    let (bytes, info) = gibake_scenegen::random_lights(seed, &Default::default());
    let path = std::path::PathBuf::from(format!("random_lights_{seed}.glb"));
    let scene = gibake_scene::load_from_slice(&bytes, &path, &every_light()).expect("loads");
    (format!("random_lights {seed} ({info})"), scene)
}

fn settings() -> EvalSettings {
    EvalSettings {
        size: 40,
        spp: 256,
        vpls: 664,
        ssaa: 2,
        blur: 2,
        // naive = full is checked apart, with fewer VPLs (common::NAIVE_VPLS).
        naive: false,
        ..Default::default()
    }
}

/// Known failures: (scene name prefix, indirect bias bound, full/rsm error
/// ratio bound, why). None since session 15: random seed 1 (a sun and seven
/// lamps over open ground, whose 664 VPLs give the sun ~100) was held to
/// ±10% and 1.5× `rsm`'s error until then; with sessions 14 and 15's
/// changes (the far-field lobe, crease sub-disks, the RSM's geometric
/// emission normal) it measures −0.9/−3.1/−1.0% and 0.91× here.
const KNOWN_FAILURES: &[(&str, f32, f64, &str)] = &[];

#[test]
fn every_light_matches_the_reference() {
    let ctx = common::gpu();
    let s = settings();
    let mut scenes = vec![("lamps".to_string(), lamps())];
    scenes.extend((0..3).map(random));
    let mut failures = Vec::new();
    for (name, scene) in &scenes {
        let (e, images) = match judge_level(&ctx, scene, name, &s) {
            Ok(r) => r,
            Err(e) => {
                failures.push(format!("{name}: not judged: {e}"));
                continue;
            }
        };
        eprintln!("{name}: {} lights: {}", scene.lights.len(), e.line());
        let i = &e.indirect;
        for img in [&images.full, &images.direct, &images.rsm] {
            if !img.all_finite() {
                failures.push(format!("{name}: a rendered image is not finite"));
            }
        }
        if e.image_rel_mse > 0.06 {
            failures.push(format!(
                "{name}: image rel MSE {:.4} > 0.06",
                e.image_rel_mse
            ));
        }
        if e.direct_rel_mse > 0.03 {
            failures.push(format!(
                "{name}: direct rel MSE {:.4} > 0.03",
                e.direct_rel_mse
            ));
        }
        let (tol, ratio) = match KNOWN_FAILURES.iter().find(|k| name.starts_with(k.0)) {
            Some(k) => {
                eprintln!(
                    "{name}: known failure, held to ±{:.0}% and {:.1}× rsm's error: {}",
                    k.1 * 1e2,
                    k.2,
                    k.3
                );
                (k.1, k.2)
            }
            None => (0.07, 1.0),
        };
        if !i.full_bias_within(tol) {
            failures.push(format!(
                "{name}: full's mean indirect bias {:?} beyond ±{:.0}% (reference noise {:?})",
                i.full_bias,
                tol * 1e2,
                i.ref_noise
            ));
        }
        if i.full_err > ratio * i.rsm_err {
            failures.push(format!(
                "{name}: full's indirect error {:.4} above {ratio}× rsm's {:.4}",
                i.full_err, i.rsm_err
            ));
        }
        match common::naive_against_full(&ctx, scene, &s) {
            Ok(d) if d <= 1e-4 => {}
            Ok(d) => failures.push(format!("{name}: naive differs from full ({d:.2e})")),
            Err(e) => failures.push(format!("{name}: naive against full not rendered: {e}")),
        }
    }
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}

fn direct(scene: &Scene, asset: Option<&gibake_asset::Asset>) -> gibake_image::Image {
    let ctx = common::gpu();
    let s = RenderSettings {
        width: 48,
        height: 48,
        mode: Mode::Direct,
        ..Default::default()
    };
    gibake_eval::frame::render_image(&ctx.device, &ctx.queue, scene, asset, &s, 0.5, 1)
        .expect("renders")
}

/// What a game sees of several lights: each with its VPLs, the bounce
/// off moving objects from the first only; the other lights' maps are
/// allocated (and the light merge planned) only where needed; moving
/// objects are merged only into the views they touch this frame; and the
/// direct light rendered from the asset's maps equals the one from maps
/// the runtime renders itself (no asset, `direct` mode).
#[test]
fn the_lights_and_their_merges_are_what_the_scene_needs() {
    let ctx = common::gpu();
    let scene = lamps();
    let asset = gibake_eval::bake(&ctx, &scene, &settings()).expect("bake");
    let rs = RenderSettings {
        width: 32,
        height: 32,
        ..Default::default()
    };
    // What the other lights need of a device is known before: two more
    // storage buffers and two more textures in shading than one light.
    let req = gibake_runtime::Requirements::of(&scene, Some(&asset), &rs).unwrap();
    assert!(req.limits.max_storage_buffers_per_shader_stage >= 6);
    assert!(req.limits.max_sampled_textures_per_shader_stage >= 17);
    let e = req
        .check(&gibake_runtime::wgpu::Limits::downlevel_defaults())
        .expect_err("downlevel devices bind 4 storage buffers and 16 textures");
    // The first limit found: the other lights' bindings, the merge's, or
    // (format 4.7) the VPL maps and second maps in one texture.
    assert!(
        e.to_string().contains("other lights")
            || e.to_string().contains("merge")
            || e.to_string().contains("second maps in one texture"),
        "{e}"
    );
    let mut r = Renderer::new(&ctx.device, &ctx.queue, &scene, Some(&asset), &rs).unwrap();
    let lights = r.lights();
    assert_eq!(lights.len(), 3);
    let vpls: u32 = lights.iter().map(|l| l.vpls.expect("baked")).sum();
    assert_eq!(vpls as usize, asset.vpls.len());
    assert!(lights.iter().all(|l| l.shaded));
    // Every light bounces off the balls: the spot by its primary RSM, the
    // lamps by the stored RSMs of the faces the balls can enter.
    let bounce: Vec<bool> = lights.iter().map(|l| l.dynamic_bounce).collect();
    assert_eq!(bounce, [true, true, true]);
    assert!(r.plan().has(Pass::LightBounce));
    assert!(!asset.manifest.view_rsms.is_empty());
    assert!(r.other_light_bytes() > 0);
    assert!(
        r.plan().has(Pass::LightMerge),
        "the balls move by the lamps"
    );
    // Each frame merges only the views the balls touch: fewer than all 12
    // (a ball is never on all six sides of a lamp), at least one.
    for t in [0.0f32, 0.7, 1.9] {
        r.prepare_at_time(&ctx.device, &ctx.queue, &scene, t)
            .unwrap();
        let mut enc = ctx.device.create_command_encoder(&Default::default());
        r.record(&mut enc);
        ctx.queue.submit([enc.finish()]);
        let st = r.stats(&ctx.device);
        assert!(
            (1..12).contains(&st.light_views_merged),
            "t = {t}: {} views merged",
            st.light_views_merged
        );
        // The bounce too: only in the stored views the balls touch, and
        // shading reads only their dynamic VPL slots (and the spot's).
        assert!(
            (1..=asset.view_rsms.len() as u32).contains(&st.light_views_bounced),
            "t = {t}: {} views bounced of {}",
            st.light_views_bounced,
            asset.view_rsms.len()
        );
        // The spot's 256 dynamic VPLs take (4⁵ − 1)/3 = 341 slots, each
        // touched lamp view's 16 take (4³ − 1)/3 = 21 (the defaults).
        assert_eq!(
            (rs.max_dynamic_vpls, rs.max_dynamic_vpls_per_view),
            (256, 16)
        );
        assert_eq!(
            st.dynamic_vpl_slots,
            341 + 21 * st.light_views_bounced,
            "t = {t}"
        );
        // The per-texel work covers the balls' windows, not whole maps.
        let map = u64::from(asset.manifest.settings.rsm_size).pow(2);
        let whole = map * u64::from(1 + st.light_views_bounced);
        assert!(
            st.bounce_texels > 0 && st.bounce_texels < whole,
            "t = {t}: {} texels of {whole}",
            st.bounce_texels
        );
    }
    // Balls far apart in a view bounce in a window each: never more
    // texels than one window around them all (`split_windows` off), fewer
    // at some time of the animation.
    let mut one_window = Renderer::new(
        &ctx.device,
        &ctx.queue,
        &scene,
        Some(&asset),
        &RenderSettings {
            split_windows: false,
            ..rs.clone()
        },
    )
    .unwrap();
    let mut fewer = 0;
    for k in 0..8 {
        let t = 0.3 * k as f32;
        let mut texels = [0u64; 2];
        for (r, n) in [&mut r, &mut one_window].into_iter().zip(&mut texels) {
            r.prepare_at_time(&ctx.device, &ctx.queue, &scene, t)
                .unwrap();
            let mut enc = ctx.device.create_command_encoder(&Default::default());
            r.record(&mut enc);
            ctx.queue.submit([enc.finish()]);
            *n = r.stats(&ctx.device).bounce_texels;
        }
        assert!(texels[0] <= texels[1], "t = {t}: {texels:?}");
        fewer += usize::from(texels[0] < texels[1]);
    }
    assert!(fewer > 0, "no frame split a view's window");
    // The asset's maps and the runtime's own give the same direct light.
    let baked = direct(&scene, Some(&asset));
    let own = direct(&scene, None);
    assert!(baked.all_finite());
    let d = rel_mse(&own, &baked);
    assert!(d < 1e-9, "direct light from the asset vs without: {d:.2e}");
    // One light: nothing of this exists.
    let one = gibake_scene::load(
        &common::data("lamps.glb"),
        &LoadOptions {
            lights: vec!["spot_lamp".into()],
            ..Default::default()
        },
    )
    .unwrap();
    assert_eq!(one.lights.len(), 1);
    let r1 = Renderer::new(
        &ctx.device,
        &ctx.queue,
        &one,
        None,
        &RenderSettings {
            mode: Mode::Direct,
            ..rs.clone()
        },
    )
    .unwrap();
    assert_eq!(r1.other_light_bytes(), 0);
    assert!(!r1.plan().has(Pass::LightMerge));
}

/// Stiff light sets at frame level, baked and rendered (`full` and
/// `direct`): a point lamp 10⁻⁶ of the room from a wall, 64 lights (the
/// spot and 63 point lamps, a quarter with a range), and a 10⁶ and a 10⁻⁶
/// point lamp side by side (a point light first: no primary map) — every
/// pixel finite and non-negative; the dim lamp changes nothing visible
/// (the image equals the bright lamp's alone to 10⁻⁴ rel MSE).
#[test]
fn stiff_light_sets_render_finite() {
    let ctx = common::gpu();
    let base = lamps();
    let b = base.static_bounds();
    let (size, mid) = (b.max - b.min, (b.min + b.max) * 0.5);
    let point = |name: &str, p: gibake_runtime::glam::Vec3, i: f32| gibake_scene::Light {
        name: name.into(),
        kind: gibake_scene::LightKind::Point,
        color: gibake_runtime::glam::Vec3::splat(i),
        position: p,
        direction: gibake_runtime::glam::Vec3::NEG_Y,
        range: None,
    };
    let with = |lights: Vec<gibake_scene::Light>| {
        let mut s = base.clone();
        s.lights = lights;
        s
    };
    let spot = base.lights[0].clone();
    // The room's +X wall is at b.max.x (inside faces): 1e-6 of the room in.
    let wall = with(vec![
        spot.clone(),
        point(
            "by the wall",
            gibake_runtime::glam::Vec3::new(b.max.x - 1e-6 * size.x, mid.y, mid.z),
            5.0,
        ),
    ]);
    let mut many = vec![spot];
    for k in 0..63 {
        let t = k as f32 / 63.0;
        let f = |a: f32| 0.1 + 0.8 * a.fract();
        let mut l = point(
            &format!("lamp {k}"),
            b.min + size * gibake_runtime::glam::Vec3::new(f(t), f(t * 7.0), f(t * 3.0)),
            0.5 + t,
        );
        if k % 4 == 0 {
            l.range = Some(0.25 * size.max_element());
        }
        many.push(l);
    }
    let many = with(many);
    let bright = point("bright", mid + size * 0.2, 1e6);
    let dim = point("dim", mid - size * 0.2, 1e-6);
    let extremes = with(vec![bright.clone(), dim]);
    let bright_alone = with(vec![bright]);
    let s = EvalSettings {
        size: 32,
        vpls: 128,
        rsm_size: 64,
        vpl_map_size: 32,
        ssaa: 1,
        ..Default::default()
    };
    let mut images = Vec::new();
    for (what, scene) in [
        ("a lamp 1e-6 from a wall", &wall),
        ("64 lights", &many),
        ("1e6 and 1e-6 side by side", &extremes),
        ("the 1e6 lamp alone", &bright_alone),
    ] {
        let asset = gibake_eval::bake(&ctx, scene, &s).unwrap_or_else(|e| panic!("{what}: {e}"));
        if matches!(scene.light().kind, gibake_scene::LightKind::Point) {
            // A point light first has no primary map: no primary RSM or
            // merge (its faces take the moving objects, and the bounce off
            // them comes from the stored RSMs of the faces they can enter).
            assert!(asset.rsm.is_none(), "{what}");
            let rs = RenderSettings {
                width: 8,
                height: 8,
                ..Default::default()
            };
            let r = Renderer::new(&ctx.device, &ctx.queue, scene, Some(&asset), &rs).unwrap();
            assert!(r.lights().iter().all(|l| l.shaded));
            assert!(!r.plan().has(Pass::PrimaryMerge) && r.plan().has(Pass::LightMerge));
            assert!(!r.plan().has(Pass::DynamicRsm), "{what}");
            assert_eq!(
                r.plan().has(Pass::LightBounce),
                !asset.view_rsms.is_empty(),
                "{what}"
            );
            assert_eq!(
                r.lights().iter().any(|l| l.dynamic_bounce),
                !asset.view_rsms.is_empty(),
                "{what}"
            );
        }
        for mode in [Mode::Full, Mode::Direct] {
            let img = gibake_eval::render(&ctx, scene, &asset, mode, &s)
                .unwrap_or_else(|e| panic!("{what}: {e}"));
            let ok = img
                .pixels
                .iter()
                .all(|p| p.is_finite() && p.min_element() >= 0.0);
            assert!(ok, "{what}, {mode:?}: a pixel is not finite or negative");
            assert!(img.mean().max_element() > 0.0, "{what}, {mode:?}: black");
            if mode == Mode::Full {
                images.push(img);
            }
        }
    }
    let d = rel_mse(&images[2], &images[3]);
    assert!(d < 1e-4, "the 1e-6 lamp changed the image: rel MSE {d:.2e}");
}

/// Light culling (`RenderSettings::light_culling`, on by default) is exact:
/// each 8×8 tile skips the lights whose range ends before all its
/// surfaces or whose spot cone misses them, and the direct image is the
/// same to the bit with it off — on the bundled room (one lamp with a
/// range among the lights after the first), with 63 more lamps each with a
/// short range, with 63 narrow spots without one, whose light shows in
/// the image, and with 2100 spots (past the tile mask's 2048 lights the
/// rest are shaded everywhere). It is planned only where a light after
/// the first has a range or a cone.
#[test]
fn light_culling_is_exact_and_planned_only_where_a_light_has_a_range_or_cone() {
    use gibake_runtime::ShadeFlag;
    let ctx = common::gpu();
    let base = lamps();
    let b = base.static_bounds();
    let size = b.max - b.min;
    let mut many = base.clone();
    for k in 0..63 {
        let t = k as f32 / 63.0;
        let f = |a: f32| 0.1 + 0.8 * a.fract();
        many.lights.push(gibake_scene::Light {
            name: format!("lamp {k}"),
            kind: gibake_scene::LightKind::Point,
            color: gibake_runtime::glam::Vec3::splat(2.0),
            position: b.min + size * gibake_runtime::glam::Vec3::new(f(t), f(t * 7.0), f(t * 3.0)),
            direction: gibake_runtime::glam::Vec3::NEG_Y,
            range: Some(0.15 * size.max_element()),
        });
    }
    // The same lamps as spots without a range, their narrow cones down.
    let mut spots = many.clone();
    for l in spots.lights.iter_mut().skip(base.lights.len()) {
        l.kind = gibake_scene::LightKind::Spot {
            inner_cone: 0.2,
            outer_cone: 0.35,
        };
        l.range = None;
        l.color *= 8.0;
    }
    // More lights than the tile mask holds (2048): the ones past it are
    // shaded everywhere, culled or not.
    let mut crowd = base.clone();
    for k in 0..2100 {
        let t = k as f32 / 2100.0;
        let f = |a: f32| 0.1 + 0.8 * a.fract();
        crowd.lights.push(gibake_scene::Light {
            name: format!("spot {k}"),
            kind: gibake_scene::LightKind::Spot {
                inner_cone: 0.05,
                outer_cone: 0.1,
            },
            color: gibake_runtime::glam::Vec3::splat(20.0),
            position: b.min + size * gibake_runtime::glam::Vec3::new(f(t * 13.0), 0.9, f(t * 29.0)),
            direction: gibake_runtime::glam::Vec3::NEG_Y,
            range: Some(0.5 * size.max_element()),
        });
    }
    // Small shadow maps: culling's exactness does not depend on them, and
    // 2100 spots' maps at the default size were most of this test's time.
    let on = RenderSettings {
        width: 48,
        height: 48,
        mode: Mode::Direct,
        shadow_map_size: 256,
        ..Default::default()
    };
    let off = RenderSettings {
        light_culling: false,
        ..on.clone()
    };
    // Renders with the renderer whose plan was checked (a renderer of 2100
    // spots takes seconds to make on lavapipe: one per setting and scene).
    let render = |scene: &Scene, s: &RenderSettings, culled: bool, what: &str| {
        let mut r = Renderer::new(&ctx.device, &ctx.queue, scene, None, s).unwrap();
        assert_eq!(
            r.plan().shade_flags() & ShadeFlag::CullLights as u32 != 0,
            culled,
            "{what}"
        );
        r.prepare_at_time(&ctx.device, &ctx.queue, scene, 0.5)
            .unwrap();
        let mut enc = ctx.device.create_command_encoder(&Default::default());
        r.record(&mut enc);
        ctx.queue.submit([enc.finish()]);
        gibake_eval::frame::read_output(&r, &ctx.device, &ctx.queue, 1).expect("renders")
    };
    let mut with = Vec::new();
    for (what, scene) in [
        ("the room", &base),
        ("the room and 63 lamps", &many),
        ("the room and 63 spots", &spots),
        ("the room and 2100 spots", &crowd),
    ] {
        let (a, c) = (
            render(scene, &on, true, what),
            render(scene, &off, false, what),
        );
        assert!(a.all_finite() && a.mean().max_element() > 0.0, "{what}");
        let same = a
            .pixels
            .iter()
            .zip(&c.pixels)
            .all(|(p, q)| p.to_array().map(f32::to_bits) == q.to_array().map(f32::to_bits));
        assert!(
            same,
            "{what}: culling changed the image (rel MSE {:.2e})",
            rel_mse(&a, &c)
        );
        with.push(a);
    }
    // The 63 lamps' and spots' light is in the image (culling had lights
    // to keep).
    for (what, image) in [("lamps", &with[1]), ("spots", &with[2])] {
        let d = rel_mse(image, &with[0]);
        assert!(d > 1e-3, "the 63 {what} change nothing: rel MSE {d:.2e}");
    }
    // No light after the first with a range or a cone: nothing to cull,
    // no flag.
    let mut unranged = base.clone();
    for l in &mut unranged.lights {
        l.range = None;
    }
    let r = Renderer::new(&ctx.device, &ctx.queue, &unranged, None, &on).unwrap();
    assert_eq!(r.plan().shade_flags() & ShadeFlag::CullLights as u32, 0);
}

/// What the moving objects change in the indirect light of every light,
/// against the reference, on a generated scene nobody chose (random seed
/// 0: a spot and a point lamp with a range in a hall, five moving
/// objects): the mean indirect light with them less the static scene's
/// (rendered with the same asset), runtime against path tracer. With the
/// other lights' view RSMs (format 4.1: the lamp's occlusion and bounce
/// off the moving objects) it is the reference's to 30% per channel
/// (measured: +0.0040/+0.0019/+0.0025 against +0.0037/+0.0018/+0.0024);
/// without them (a 4.0 asset: the spot's only) it is not even of the
/// reference's sign.
#[test]
fn moving_objects_change_every_lights_indirect_light_as_the_reference_does() {
    let ctx = common::gpu();
    let (name, scene) = random(0);
    assert!(
        scene.lights.len() > 1 && !scene.dynamic_objects.is_empty(),
        "{name}"
    );
    let still = gibake_bake::static_only(&scene);
    let s = EvalSettings {
        size: 48,
        spp: 256,
        ..settings()
    };
    let mean = |scene: &Scene, asset: &gibake_asset::Asset| {
        let img = gibake_eval::render(&ctx, scene, asset, Mode::Indirect, &s).unwrap();
        assert!(img.all_finite(), "{name}");
        img.mean()
    };
    let asset = gibake_eval::bake(&ctx, &scene, &s).unwrap();
    assert!(!asset.view_rsms.is_empty(), "{name}");
    let without = gibake_eval::without_view_rsms(asset.clone());
    // The static part rendered with the same asset (a bake of the static
    // part alone fits the light views without the moving objects' bounds:
    // its other VPLs would count as their effect).
    let base = mean(&still, &asset);
    let (effect, effect_without) = (mean(&scene, &asset) - base, mean(&scene, &without) - base);
    let truth = gibake_eval::reference_moving_effect(&scene, &s).unwrap();
    eprintln!(
        "{name}: the moving objects' effect on the mean indirect light {effect}, without the view RSMs {effect_without}, reference {truth}"
    );
    for c in 0..3 {
        assert!(truth[c] > 0.0, "{name}: reference {truth}");
        assert!(
            (effect[c] - truth[c]).abs() < 0.3 * truth[c],
            "{name}: channel {c}: {effect} against the reference's {truth}"
        );
        assert!(
            effect_without[c] < 0.0,
            "{name}: without the view RSMs {effect_without}"
        );
    }
}

/// The same on a real level made by others (the Blenvy start level: a
/// sun, a spot and three point lamps over a 94 m ground), with moving
/// balls placed by a rule, one resting under each lamp
/// (`gibake_eval::moving::balls_under_lamps`). Judged where the reference
/// can show it (`gibake_eval::moving`): on the pixels that show the level,
/// with the reference's noise cancelled by rendering the scene and its
/// static part with the same seeds. The balls' bounce is most of what they
/// change here (+44% of the level's red indirect light on those pixels).
/// The runtime gives 0.96/0.93/0.90 of the reference's change (0.88/0.89/
/// 0.86 with one window around all the balls per view); without the view
/// RSMs 0.83/0.59/0.63; with session 5's dynamic VPLs (their lobe within
/// the mean normal's hemisphere, clustered over the whole map, not the
/// balls' window) 0.65/0.64/0.56: a ball's lit cap sent no light to the
/// ground on its far side.
#[test]
fn balls_under_a_real_levels_lamps_change_its_indirect_light_as_the_reference_does() {
    let ctx = common::gpu();
    let path = common::data("lights/blenvy_start_level/StartLevel.glb");
    let mut scene = gibake_scene::load(&path, &every_light()).unwrap();
    let s = EvalSettings {
        size: 48,
        spp: 256,
        ..settings()
    };
    let balls = gibake_eval::moving::balls_under_lamps(&scene, 0.5, s.time);
    assert_eq!(balls.len(), 4, "a ball under each lamp: {balls:?}");
    for (i, b) in balls.iter().enumerate() {
        gibake_eval::levels::add_ball(&mut scene, &format!("ball {i}"), b);
    }
    let e = gibake_eval::moving::moving_effect(&ctx, &scene, &s).unwrap();
    eprintln!("blenvy with balls under its lamps: {}", e.line());
    assert!(e.view_rsms > 0, "the lamps' views store RSMs");
    assert!(
        e.pixels.0 * 10 > e.pixels.1 * 9,
        "the balls hide most of the image: {:?}",
        e.pixels
    );
    for c in 0..3 {
        let truth = e.reference[c];
        assert!(
            truth > 6.0 * e.noise[c],
            "channel {c}: the reference's change {truth} is within its noise {}",
            e.noise[c]
        );
        assert!(
            (e.runtime[c] - truth).abs() < 0.2 * truth,
            "channel {c}: runtime {} against the reference's {truth}",
            e.runtime[c]
        );
        assert!(
            (e.without_view_rsms[c] - truth).abs() > (e.runtime[c] - truth).abs(),
            "channel {c}: the view RSMs do not help: {}",
            e.line()
        );
    }
}
