//! Interleaved VPL sampling (issue 10): `RenderSettings::interleave`.
//!
//! On the bundled scenes, at 64² (ssaa 1, `--vpls 664`, RSM 256², maps
//! 64²), against the CPU reference (one bounce, 512 spp):
//! - interleave 4's relative MSE is at most 1.15× interleave 1's;
//! - interleave 1 is bit-identical to the default settings' image;
//! - two interleave-4 renders are bit-identical (determinism), and finite;
//! - on static levels, `naive` = `full` at interleave 4 (rel MSE < 1e-4;
//!   baked at `common::NAIVE_VPLS` VPLs, as every suite's naive check is).
//!
//! Invalid values are `RuntimeError::InvalidSetting`. Interleave 2 and 8
//! are rendered, checked finite and their error reported by `gibake bench
//! quality` (`tests/bench_small.rs` runs it on a bundled and a random
//! scene and checks every figure finite).

use crate::common;

use gibake_eval::EvalSettings;
use gibake_image::{Image, rel_mse};
use gibake_runtime::{Mode, RenderSettings, RuntimeError};

const SIZE: u32 = 64;
const TIME: f32 = 0.5;

fn eval_settings() -> EvalSettings {
    EvalSettings {
        size: SIZE,
        spp: 512,
        vpls: 664,
        rsm_size: 256,
        vpl_map_size: 64,
        time: TIME,
        ssaa: 1,
        ..Default::default()
    }
}

fn render(
    ctx: &gibake_gpu::GpuContext,
    scene: &gibake_scene::Scene,
    asset: &gibake_asset::Asset,
    mode: Mode,
    interleave: Option<u32>,
) -> Image {
    let mut s = RenderSettings {
        width: SIZE,
        height: SIZE,
        mode,
        ..Default::default()
    };
    if let Some(n) = interleave {
        s.interleave = n;
    }
    let img =
        gibake_eval::frame::render_image(&ctx.device, &ctx.queue, scene, Some(asset), &s, TIME, 1)
            .unwrap();
    assert!(
        img.all_finite(),
        "{mode:?} interleave {interleave:?}: non-finite pixels"
    );
    img
}

fn bits(img: &Image) -> Vec<u32> {
    img.pixels
        .iter()
        .flat_map(|p| p.to_array())
        .map(f32::to_bits)
        .collect()
}

fn reference(scene: &gibake_scene::Scene) -> Image {
    gibake_reference::render(
        scene,
        &gibake_reference::Settings {
            width: SIZE,
            height: SIZE,
            spp: 512,
            time: TIME,
            depth: gibake_reference::Depth::OneBounce,
            seed: 0,
        },
        &|_| {},
    )
    .unwrap()
}

#[test]
fn interleave_4_keeps_the_error_within_15_percent_of_the_full_sum() {
    let ctx = common::gpu();
    let s = eval_settings();
    let mut failures = Vec::new();
    for (name, f) in gibake_scenegen::all() {
        let scene = gibake_eval::load(&f(&Default::default()), &format!("{name}.glb"));
        let asset = gibake_eval::bake(&ctx, &scene, &s).unwrap();
        let default = render(&ctx, &scene, &asset, Mode::Full, None);
        let one = render(&ctx, &scene, &asset, Mode::Full, Some(1));
        let four = render(&ctx, &scene, &asset, Mode::Full, Some(4));
        let again = render(&ctx, &scene, &asset, Mode::Full, Some(4));
        if bits(&one) != bits(&default) {
            failures.push(format!(
                "{name}: interleave 1 differs from the default path"
            ));
        }
        if bits(&four) != bits(&again) {
            failures.push(format!("{name}: two interleave-4 renders differ"));
        }
        let r = reference(&scene);
        let (e1, e4) = (rel_mse(&one, &r), rel_mse(&four, &r));
        eprintln!(
            "{name}: rel MSE against the reference: interleave 1 {e1:.5}, 4 {e4:.5} (ratio {:.3}; 4 against 1: {:.5})",
            e4 / e1,
            rel_mse(&four, &one)
        );
        if std::env::var_os("GIBAKE_IL_MAP").is_some() {
            for y in 0..SIZE {
                let row: String = (0..SIZE)
                    .map(|x| {
                        let (a, b) = (four.get(x, y), one.get(x, y));
                        let d = ((a - b).length_squared() / (b.length_squared() + 0.03)).sqrt();
                        b" .:-=+*#%@"[((d * 20.0) as usize).min(9)] as char
                    })
                    .collect();
                eprintln!("{row}");
            }
        }
        if e4 > 1.15 * e1 {
            failures.push(format!(
                "{name}: interleave 4's rel MSE {e4:.5} above 1.15 × interleave 1's {e1:.5}"
            ));
        }
        // Naive = full at interleave 4, on the level without moving objects.
        let st = gibake_bake::static_only(&scene);
        // At `common::NAIVE_VPLS`: `naive` re-renders every map each frame,
        // and the merge it checks is the same per VPL.
        let st_s = EvalSettings {
            vpls: common::NAIVE_VPLS,
            ..s.clone()
        };
        let st_asset = gibake_eval::bake(&ctx, &st, &st_s).unwrap();
        let full = render(&ctx, &st, &st_asset, Mode::Full, Some(4));
        let naive = render(&ctx, &st, &st_asset, Mode::Naive, Some(4));
        let d = rel_mse(&naive, &full);
        eprintln!("{name} (static only): naive vs full at interleave 4: {d:.2e}");
        if d >= 1e-4 {
            failures.push(format!(
                "{name}: naive differs from full at interleave 4 ({d:.2e})"
            ));
        }
    }
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}

#[test]
fn invalid_interleave_is_a_typed_error() {
    let ctx = common::gpu();
    let scene = gibake_eval::load(
        &gibake_scenegen::corner_bunny(&Default::default()),
        "cb.glb",
    );
    for n in [3, 5, 16] {
        let s = RenderSettings {
            width: 8,
            height: 8,
            mode: Mode::Direct,
            interleave: n,
            ..Default::default()
        };
        match gibake_runtime::Renderer::new(&ctx.device, &ctx.queue, &scene, None, &s) {
            Err(RuntimeError::InvalidSetting(m)) => assert!(m.contains("interleave"), "{m}"),
            Err(e) => panic!("interleave {n}: wrong error {e}"),
            Ok(_) => panic!("interleave {n} accepted"),
        }
    }
}

/// Interleave 0 (the default) is automatic: the exact sum below 256²
/// pixels, 4×4 from there on, re-chosen on resize.
#[test]
fn automatic_interleave_follows_the_output_size() {
    let ctx = common::gpu();
    let scene = gibake_eval::load(
        &gibake_scenegen::corner_bunny(&Default::default()),
        "cb.glb",
    );
    let s = RenderSettings {
        width: 64,
        height: 64,
        mode: Mode::Direct,
        ..Default::default()
    };
    assert_eq!(s.interleave, 0, "the default is automatic");
    let mut r = gibake_runtime::Renderer::new(&ctx.device, &ctx.queue, &scene, None, &s)
        .expect("automatic interleave is a valid setting");
    assert_eq!(r.interleave(), 1);
    r.resize(&ctx.device, &ctx.queue, 256, 256).expect("resize");
    assert_eq!(r.interleave(), 4);
    r.resize(&ctx.device, &ctx.queue, 255, 256).expect("resize");
    assert_eq!(r.interleave(), 1);
}

#[test]
fn cli_rejects_an_invalid_interleave() {
    let mut c = common::gibake();
    c.args(["render", "--interleave", "3", "-o", "x.exr"])
        .arg(common::data("corner_bunny.glb"));
    let r = common::run_command(c);
    assert_eq!(r.code, Some(2), "{r}");
    assert!(r.stderr.contains("--interleave"), "{r}");
}

/// Shade time, interleave 1 against 4, side by side in one process:
/// corner_bunny, 256², 664 VPLs (RSM 512², maps 128²), GPU timestamps,
/// median of 5 frames after a warm-up, alternating. A measurement, not a
/// check (`cargo test --release -p gibake --test end_to_end interleave:: -- --ignored
/// --nocapture`).
#[test]
#[ignore = "measurement"]
fn shade_time_interleave_1_against_4() {
    let ctx = common::gpu();
    let scene = gibake_eval::load(
        &gibake_scenegen::corner_bunny(&Default::default()),
        "cb.glb",
    );
    let s = EvalSettings {
        vpls: 664,
        ..Default::default()
    };
    let asset = gibake_eval::bake(&ctx, &scene, &s).unwrap();
    let mut renderers: Vec<_> = [1, 4]
        .map(|n| {
            let rs = RenderSettings {
                width: 256,
                height: 256,
                interleave: n,
                ..Default::default()
            };
            let mut r =
                gibake_runtime::Renderer::new(&ctx.device, &ctx.queue, &scene, Some(&asset), &rs)
                    .unwrap();
            r.prepare_at_time(&ctx.device, &ctx.queue, &scene, TIME)
                .unwrap();
            r
        })
        .into();
    let mut times = [Vec::new(), Vec::new()];
    for frame in 0..6 {
        for (k, r) in renderers.iter_mut().enumerate() {
            r.prepare_at_time(&ctx.device, &ctx.queue, &scene, TIME)
                .unwrap();
            let mut enc = ctx.device.create_command_encoder(&Default::default());
            r.record(&mut enc);
            ctx.queue.submit([enc.finish()]);
            let st = r.stats(&ctx.device);
            let ms = |pass| st.pass_ms(pass);
            if frame > 0 {
                times[k].push((
                    ms(gibake_runtime::Pass::Shade),
                    ms(gibake_runtime::Pass::Interleave),
                    st.timing.to_string(),
                ));
            }
        }
    }
    let median = |v: &[(f64, f64, String)], f: &dyn Fn(&(f64, f64, String)) -> f64| {
        let mut x: Vec<f64> = v.iter().map(f).collect();
        x.sort_by(f64::total_cmp);
        x[x.len() / 2]
    };
    let s1 = median(&times[0], &|t| t.0);
    let s4 = median(&times[1], &|t| t.0);
    let f4 = median(&times[1], &|t| t.1);
    eprintln!(
        "timing: {} — interleave 1: shade {s1:.2} ms; interleave 4: shade {s4:.2} ms + filter {f4:.2} ms = {:.2} ms; ratio {:.3}",
        times[0][0].2,
        s4 + f4,
        (s4 + f4) / s1
    );
}

/// An external G-buffer is filtered like the own one (the filter pass is
/// re-bound to it), and the filter pass is timed as "interleave".
#[test]
fn an_external_gbuffer_is_filtered_like_the_own_one() {
    let ctx = common::gpu();
    let scene = gibake_eval::load(
        &gibake_scenegen::corner_bunny(&Default::default()),
        "cb.glb",
    );
    let s = EvalSettings {
        vpls: 64,
        rsm_size: 64,
        vpl_map_size: 32,
        ..Default::default()
    };
    let asset = gibake_eval::bake(&ctx, &scene, &s).unwrap();
    let rs = RenderSettings {
        width: 48,
        height: 48,
        interleave: 4,
        ..Default::default()
    };
    let new = || {
        gibake_runtime::Renderer::new(&ctx.device, &ctx.queue, &scene, Some(&asset), &rs).unwrap()
    };
    let (mut own, mut ext) = (new(), new());
    let views = own.gbuffer_views();
    ext.use_external_gbuffer(&ctx.device, [&views[0], &views[1], &views[2]]);
    for r in [&mut own, &mut ext] {
        r.prepare_at_time(&ctx.device, &ctx.queue, &scene, 0.4)
            .unwrap();
    }
    let mut enc = ctx.device.create_command_encoder(&Default::default());
    own.record(&mut enc);
    ext.record(&mut enc);
    ctx.queue.submit([enc.finish()]);
    let stats = own.stats(&ctx.device);
    if stats.timing == gibake_runtime::Timing::GpuTimestamps {
        let names: Vec<_> = stats.passes.iter().map(|(n, _)| n.name()).collect();
        assert_eq!(
            names[names.len() - 3..],
            ["gbuffer", "shade", "interleave"],
            "{names:?}"
        );
        let upd: f64 = stats.passes[..names.len() - 3].iter().map(|p| p.1).sum();
        assert_eq!(stats.update_ms(), upd, "the filter is shading, not update");
    }
    let a = gibake_eval::frame::read_output(&own, &ctx.device, &ctx.queue, 1).unwrap();
    let b = gibake_eval::frame::read_output(&ext, &ctx.device, &ctx.queue, 1).unwrap();
    assert!(a.mean().x > 0.0);
    assert!(a.all_finite());
    assert_eq!(a, b);
}
