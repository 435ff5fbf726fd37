//! One function per subcommand.

use std::path::{Path, PathBuf};
use std::process::ExitCode;
use std::time::Instant;

use anyhow::{Context, bail};
use gibake_gpu::{GpuContext, GpuOptions};
use gibake_scene::{LoadOptions, Scene};

use crate::cli::{Cli, Command, DemoArgs, ModeArg, ReferenceArgs, RenderArgs, SceneArgs};
use crate::output::{bar, write_image_atomic};

/// The bundled paper scene, embedded for `gibake demo`.
const CORNER_BUNNY: &[u8] = include_bytes!("../../data/corner_bunny.glb");

/// Runs the parsed command line.
pub fn run(cli: Cli) -> anyhow::Result<ExitCode> {
    match cli.command {
        Command::Render(a) => render(a),
        Command::Reference(a) => reference(a),
        Command::Demo(a) => demo(a),
        Command::Bake(_) => not_built("bake", "issue 3"),
        Command::Diff(_) => not_built("diff", "issue 3"),
        Command::Inspect(_) => not_built("inspect", "issue 3"),
        Command::Bench(_) => not_built("bench", "issues 3 and 4"),
    }
}

fn not_built(cmd: &str, issue: &str) -> anyhow::Result<ExitCode> {
    eprintln!("gibake {cmd}: not built yet ({issue}).");
    Ok(ExitCode::from(2))
}

fn load_scene(a: &SceneArgs) -> anyhow::Result<Scene> {
    let scene = gibake_scene::load(&a.scene, &LoadOptions { light: a.light.clone() })?;
    for w in &scene.warnings {
        tracing::warn!("{}: {w}", a.scene.display());
    }
    Ok(scene)
}

fn check_output_dir(path: &Path) -> anyhow::Result<()> {
    let dir = path.parent().filter(|p| !p.as_os_str().is_empty()).unwrap_or(Path::new("."));
    if !dir.is_dir() {
        bail!("{}: the output directory {} does not exist", path.display(), dir.display());
    }
    Ok(())
}

fn check_size(width: u32, height: u32) -> anyhow::Result<()> {
    if width == 0 || height == 0 || width > 16384 || height > 16384 {
        bail!("image size {width}×{height} is out of range (1..=16384 per side)");
    }
    Ok(())
}

fn check_time(t: f32) -> anyhow::Result<()> {
    if !t.is_finite() {
        bail!("--time must be a finite number of seconds, got {t}");
    }
    Ok(())
}

/// Replaces a run of `#` in the file name by the zero-padded frame number,
/// or inserts `_NNNN` before the extension when there is none.
fn frame_path(path: &Path, frame: u32, frames: u32) -> PathBuf {
    if frames <= 1 {
        return path.to_owned();
    }
    let name = path.file_name().map(|n| n.to_string_lossy().into_owned()).unwrap_or_default();
    if let Some(start) = name.find('#') {
        let len = name[start..].chars().take_while(|c| *c == '#').count();
        let new = format!("{}{:0len$}{}", &name[..start], frame, &name[start + len..], len = len);
        return path.with_file_name(new);
    }
    let stem = path.file_stem().map(|s| s.to_string_lossy().into_owned()).unwrap_or_default();
    let ext = path.extension().map(|e| e.to_string_lossy().into_owned()).unwrap_or_else(|| "exr".into());
    path.with_file_name(format!("{stem}_{frame:04}.{ext}"))
}

fn render(a: RenderArgs) -> anyhow::Result<ExitCode> {
    check_size(a.width, a.height)?;
    check_time(a.time)?;
    if !(a.fps.is_finite() && a.fps > 0.0) {
        bail!("--fps must be a positive number, got {}", a.fps);
    }
    if a.frames == 0 {
        bail!("--frames must be at least 1");
    }
    check_output_dir(&a.output)?;
    let mode = match a.mode {
        ModeArg::Direct => gibake_runtime::Mode::Direct,
        other => {
            eprintln!(
                "gibake render --mode {}: not built yet (issue 4); only --mode direct works at this stage.",
                format!("{other:?}").to_lowercase()
            );
            return Ok(ExitCode::from(2));
        }
    };
    if a.bake.is_some() {
        tracing::warn!("--bake is not used by --mode direct");
    }
    let scene = load_scene(&a.scene)?;
    let ctx = GpuContext::new(&GpuOptions { adapter: a.adapter.clone() })?;
    eprintln!("GPU: {}", ctx.record);
    let settings = gibake_runtime::RenderSettings {
        width: a.width,
        height: a.height,
        shadow_map_size: a.shadow_map_size,
        mode,
    };
    let mut frame_times = Vec::new();
    for f in 0..a.frames {
        let t = a.time + f as f32 / a.fps;
        let start = Instant::now();
        let img = gibake_runtime::render_image(&ctx, &scene, &settings, t, a.ssaa)
            .with_context(|| format!("rendering {}", a.scene.scene.display()))?;
        frame_times.push(start.elapsed().as_secs_f64());
        let out = frame_path(&a.output, f, a.frames);
        write_image_atomic(&img, &out)?;
        eprintln!("wrote {} ({:.3} s)", out.display(), frame_times.last().copied().unwrap_or(0.0));
    }
    if let Some(stats) = &a.stats {
        let json = serde_json::json!({
            "adapter": ctx.record.to_string(),
            "mode": format!("{:?}", a.mode).to_lowercase(),
            "timing": "wall (CPU-side, includes readback)",
            "frame_seconds": frame_times,
        });
        std::fs::write(stats, serde_json::to_string_pretty(&json)?).with_context(|| format!("{}", stats.display()))?;
    }
    Ok(ExitCode::SUCCESS)
}

fn reference(a: ReferenceArgs) -> anyhow::Result<ExitCode> {
    check_size(a.width, a.height)?;
    check_time(a.time)?;
    if a.spp == 0 {
        bail!("--spp must be at least 1");
    }
    check_output_dir(&a.output)?;
    let scene = load_scene(&a.scene)?;
    let settings = gibake_reference::Settings {
        width: a.width,
        height: a.height,
        spp: a.spp,
        time: a.time,
        depth: if a.direct_only { gibake_reference::Depth::Direct } else { gibake_reference::Depth::OneBounce },
        seed: a.seed,
    };
    let start = Instant::now();
    let img = run_reference(&scene, &settings)?;
    write_image_atomic(&img, &a.output)?;
    eprintln!("wrote {} ({:.2} s, {} spp)", a.output.display(), start.elapsed().as_secs_f64(), a.spp);
    Ok(ExitCode::SUCCESS)
}

fn run_reference(scene: &Scene, settings: &gibake_reference::Settings) -> anyhow::Result<gibake_image::Image> {
    let pb = bar(settings.height as u64, "reference");
    let img = gibake_reference::render(scene, settings, &|rows| pb.set_position(rows))
        .with_context(|| format!("reference render of {}", scene.source.display()))?;
    pb.finish_and_clear();
    Ok(img)
}

fn demo(a: DemoArgs) -> anyhow::Result<ExitCode> {
    check_size(a.width, a.height)?;
    std::fs::create_dir_all(&a.output).with_context(|| format!("creating {}", a.output.display()))?;
    let path = PathBuf::from("corner_bunny.glb (embedded)");
    let scene = gibake_scene::load_from_slice(CORNER_BUNNY, &path, &LoadOptions::default())?;
    let (st, dt) = scene.triangle_counts();
    eprintln!("scene: corner_bunny — {st} static triangles, {} moving objects ({dt} triangles)", scene.dynamic_objects.len());
    let ctx = GpuContext::new(&GpuOptions::default())?;
    eprintln!("GPU: {}", ctx.record);
    let settings = gibake_runtime::RenderSettings {
        width: a.width,
        height: a.height,
        shadow_map_size: 2048,
        mode: gibake_runtime::Mode::Direct,
    };
    let t0 = Instant::now();
    let gpu = gibake_runtime::render_image(&ctx, &scene, &settings, 0.0, 2)?;
    let gpu_s = t0.elapsed().as_secs_f64();
    write_image_atomic(&gpu, &a.output.join("direct.exr"))?;
    write_image_atomic(&gpu, &a.output.join("direct.png"))?;
    let settings_ref = gibake_reference::Settings {
        width: a.width,
        height: a.height,
        spp: a.spp,
        time: 0.0,
        depth: gibake_reference::Depth::Direct,
        seed: 0,
    };
    let t1 = Instant::now();
    let reference = run_reference(&scene, &settings_ref)?;
    let ref_s = t1.elapsed().as_secs_f64();
    write_image_atomic(&reference, &a.output.join("reference_direct.exr"))?;
    write_image_atomic(&reference, &a.output.join("reference_direct.png"))?;
    let err = gibake_image::rel_mse(&gpu, &reference);
    println!("{:<28} {:>10} {:>12}", "image", "time (s)", "rel MSE");
    println!("{:<28} {:>10.3} {:>12.5}", "GPU direct (wgpu)", gpu_s, err);
    println!("{:<28} {:>10.3} {:>12}", format!("CPU reference ({} spp)", a.spp), ref_s, "—");
    println!("images in {}", a.output.display());
    Ok(ExitCode::SUCCESS)
}
