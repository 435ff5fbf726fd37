//! `gibake demo`: the whole method on the bundled paper scene, end to end —
//! bake `corner_bunny` (embedded in the binary), render a short animation in
//! `full` mode (PNG frames and one EXR), print a per-pass GPU time table,
//! and compare the first frame with the CPU reference.

use std::path::PathBuf;
use std::process::ExitCode;
use std::time::Instant;

use anyhow::Context;
use gibake_gpu::{GpuContext, GpuOptions};
use gibake_scene::LoadOptions;

use crate::cli::DemoArgs;
use crate::commands::{BarProgress, CORNER_BUNNY, check_size, run_reference};
use crate::output::write_image_atomic;

/// Runs the demo.
pub fn run(a: DemoArgs) -> anyhow::Result<ExitCode> {
    check_size(a.width, a.height)?;
    if a.frames == 0 || a.spp == 0 || a.vpls == 0 {
        anyhow::bail!("--frames, --spp and --vpls must be at least 1");
    }
    std::fs::create_dir_all(&a.output)
        .with_context(|| format!("creating {}", a.output.display()))?;
    let path = PathBuf::from("corner_bunny.glb");
    let scene = gibake_scene::load_from_slice(CORNER_BUNNY, &path, &LoadOptions::default())?;
    let (st, dt) = scene.triangle_counts();
    crate::outln!(
        "scene: corner_bunny (embedded) — {st} static triangles, {} moving objects ({dt} triangles)",
        scene.dynamic_objects.len()
    );
    let ctx = GpuContext::new(&GpuOptions::default())?;
    crate::outln!("GPU: {}", ctx.record);

    // 1. Bake.
    let t = Instant::now();
    let opts = gibake_bake::BakeOptions {
        target: gibake_bake::cluster::ClusterTarget::Count(a.vpls),
        ..Default::default()
    };
    let progress = BarProgress {
        bar: std::sync::Mutex::new(None),
        quiet: false,
    };
    let mut out = gibake_bake::bake(
        &ctx,
        &scene,
        &opts,
        &progress,
        &gibake_bake::baker_version(),
    )?;
    // The bundled scene as it is: no scene flags.
    out.asset.manifest.scene_options = Some(Default::default());
    let asset_dir = a.output.join("corner_bunny.gibake");
    gibake_asset::write(&out.asset, &asset_dir)?;
    let bake_s = t.elapsed().as_secs_f64();
    let m = &out.asset.manifest;
    crate::outln!(
        "baked {} VPLs ({} hemisphere maps) into {} in {bake_s:.2} s",
        m.vpl_count,
        m.map_count,
        asset_dir.display()
    );

    // 2. Animation in full mode.
    let settings = gibake_runtime::RenderSettings {
        width: a.width,
        height: a.height,
        mode: gibake_runtime::Mode::Full,
        ..Default::default()
    };
    let mut renderer = gibake_runtime::Renderer::new(
        &ctx.device,
        &ctx.queue,
        &scene,
        Some(&out.asset),
        &settings,
    )?;
    let mut per_pass: Vec<(String, Vec<f64>)> = Vec::new();
    let mut first = None;
    let t = Instant::now();
    let pb = crate::output::bar(a.frames as u64, "frames");
    let mut timing = String::new();
    let mut exposure = None;
    for f in 0..a.frames {
        let time = f as f32 / 15.0;
        let camera = gibake_runtime::CameraMatrices::from_scene(&scene, time, a.width, a.height)?;
        let transforms = gibake_runtime::scene_transforms(&scene, time);
        let frame = gibake_runtime::FrameInput::new(camera).transforms(&transforms);
        renderer.prepare(&ctx.device, &ctx.queue, &frame)?;
        let mut enc = ctx.device.create_command_encoder(&Default::default());
        renderer.record(&mut enc);
        ctx.queue.submit([enc.finish()]);
        let stats = renderer.stats(&ctx.device);
        timing = stats.timing.to_string();
        let times: Vec<(&str, f64)> = match stats.timing {
            gibake_runtime::Timing::GpuTimestamps => {
                stats.passes.iter().map(|(p, ms)| (p.name(), *ms)).collect()
            }
            gibake_runtime::Timing::Wall => vec![("frame", stats.frame_ms)],
        };
        for (name, ms) in times {
            match per_pass.iter_mut().find(|(n, _)| n == name) {
                Some((_, v)) => v.push(ms),
                None => per_pass.push((name.to_string(), vec![ms])),
            }
        }
        let img = gibake_eval::frame::read_output(&renderer, &ctx.device, &ctx.queue, 1)?;
        // One exposure for the sequence: the first frame's.
        let e = *exposure.get_or_insert_with(|| img.auto_exposure());
        write_image_atomic(&img, &a.output.join(format!("frame_{f:03}.png")), Some(e))?;
        if f == 0 {
            write_image_atomic(&img, &a.output.join("frame_000.exr"), None)?;
            first = Some(img);
        }
        pb.inc(1);
    }
    pb.finish_and_clear();
    let anim_s = t.elapsed().as_secs_f64();

    crate::outln!(
        "\nper-pass GPU time, {} frames at {}×{} ({timing}):",
        a.frames,
        a.width,
        a.height
    );
    crate::outln!("  {:<16} {:>10} {:>10}", "pass", "median ms", "max ms");
    let mut total = 0.0;
    for (name, v) in &mut per_pass {
        v.sort_by(|x, y| x.total_cmp(y));
        let med = v[v.len() / 2];
        total += med;
        crate::outln!("  {name:<16} {med:>10.2} {:>10.2}", v[v.len() - 1]);
    }
    crate::outln!("  {:<16} {total:>10.2}", "frame");

    // 3. Reference for the first frame.
    let t = Instant::now();
    let reference = run_reference(
        &scene,
        &gibake_reference::Settings {
            width: a.width,
            height: a.height,
            spp: a.spp,
            time: 0.0,
            depth: gibake_reference::Depth::OneBounce,
            seed: 0,
        },
    )?;
    let ref_s = t.elapsed().as_secs_f64();
    write_image_atomic(&reference, &a.output.join("reference_000.exr"), None)?;
    write_image_atomic(&reference, &a.output.join("reference_000.png"), exposure)?;
    let err = gibake_image::rel_mse(first.as_ref().expect("at least one frame"), &reference);
    crate::outln!(
        "\nframe 0 against the CPU reference (one bounce, {} spp, {ref_s:.1} s): rel MSE {err:.4}",
        a.spp
    );
    crate::outln!(
        "bake {bake_s:.1} s, animation {anim_s:.1} s; images in {}",
        a.output.display()
    );
    Ok(ExitCode::SUCCESS)
}
