//! One function per subcommand.

use std::path::{Path, PathBuf};
use std::process::ExitCode;
use std::time::Instant;

use anyhow::{Context, bail};
use gibake_gpu::{GpuContext, GpuOptions};
use gibake_scene::Scene;

use crate::cli::{
    DiffArgs, InspectArgs, ModeArg, ReferenceArgs, RenderArgs, SceneArgs, TolerancePreset,
};
use crate::output::{bar, write_image_atomic};

/// The bundled paper scene, embedded for `gibake demo`.
pub(crate) const CORNER_BUNNY: &[u8] = include_bytes!("../../data/corner_bunny.glb");

pub(crate) fn load_scene(a: &SceneArgs) -> anyhow::Result<Scene> {
    let scene = gibake_scene::load(&a.scene, &a.load_options())?;
    // The importer has logged each of `scene.warnings` once already.
    Ok(scene)
}

/// The level of `render` and `view` (`command`), for the asset `bake`
/// (its directory and the asset) when there is one: loaded with the
/// asset's recorded scene flags (`--sun`, `--dynamic`, `--light`,
/// `--bake-volume`, `--max-texture-size`; format 4.4) wherever `a` gives
/// none of their kind, with one line saying which; refused (exit 2) when
/// `a` gives some that differ, naming both; then checked against the
/// asset's lights and static-scene hash.
pub(crate) fn load_level(
    a: &SceneArgs,
    bake: Option<(&Path, &gibake_asset::Asset)>,
    command: &str,
) -> anyhow::Result<Scene> {
    let Some((dir, asset)) = bake else {
        return load_scene(a);
    };
    let (options, r) = gibake_runtime::load_options_for(asset, &a.load_options())
        .map_err(|c| anyhow::anyhow!(c.flags_message(&dir.display().to_string(), command)))?;
    if !r.applied.is_empty() {
        eprintln!(
            "applying the bake's {} (recorded in {})",
            r.applied.flags(),
            dir.display()
        );
    }
    let scene = gibake_scene::load(&a.scene, &options)?;
    let baked = &asset.manifest.lights;
    if !baked.is_empty() && baked.len() != scene.lights.len() {
        let names = |v: Vec<&str>| v.join(", ");
        bail!(
            "{} was baked with {} light(s) ({}) but the scene is loaded with {} ({}): give `bake` and `{command}` the same --light flags, or re-bake",
            dir.display(),
            baked.len(),
            names(baked.iter().map(|l| l.name.as_str()).collect()),
            scene.lights.len(),
            names(scene.lights.iter().map(|l| l.name.as_str()).collect())
        );
    }
    let hash = gibake_scene::static_scene_hash(&scene);
    gibake_asset::check_scene_hash_for(dir, &asset.manifest, &hash, &a.scene, Some(&r.options))?;
    Ok(scene)
}

pub(crate) fn check_size(width: u32, height: u32) -> anyhow::Result<()> {
    for (flag, v) in [("--width", width), ("--height", height)] {
        if v == 0 || v > 16384 {
            bail!("{flag} {v} is out of range (1..=16384)");
        }
    }
    Ok(())
}

pub(crate) fn check_time(t: f32) -> anyhow::Result<()> {
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
    let name = path
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_default();
    if let Some(start) = name.find('#') {
        let len = name[start..].chars().take_while(|c| *c == '#').count();
        let new = format!(
            "{}{:0len$}{}",
            &name[..start],
            frame,
            &name[start + len..],
            len = len
        );
        return path.with_file_name(new);
    }
    let stem = path
        .file_stem()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_default();
    let ext = path
        .extension()
        .map(|e| e.to_string_lossy().into_owned())
        .unwrap_or_else(|| "exr".into());
    path.with_file_name(format!("{stem}_{frame:04}.{ext}"))
}

/// The `--mode` value as typed on the command line.
pub(crate) fn mode_name(m: ModeArg) -> String {
    use clap::ValueEnum;
    m.to_possible_value()
        .map(|v| v.get_name().to_string())
        .unwrap_or_default()
}

pub(crate) fn mode_of(m: ModeArg) -> gibake_runtime::Mode {
    match m {
        ModeArg::Full => gibake_runtime::Mode::Full,
        ModeArg::Direct => gibake_runtime::Mode::Direct,
        ModeArg::Indirect => gibake_runtime::Mode::Indirect,
        ModeArg::Rsm => gibake_runtime::Mode::Rsm,
        ModeArg::Naive => gibake_runtime::Mode::Naive,
    }
}

/// Bytes per rendered pixel, an upper estimate: G-buffer (48), depth (4),
/// radiance (16), its read-back (16) and the CPU image (12 + 12 after the
/// box filter).
const RENDER_BYTES_PER_PIXEL: u64 = 108;

pub(crate) fn render(a: RenderArgs) -> anyhow::Result<ExitCode> {
    check_size(a.width, a.height)?;
    // The frame's memory, before anything is allocated (--max-memory).
    let pixels = u64::from(a.width) * u64::from(a.ssaa) * u64::from(a.height) * u64::from(a.ssaa);
    let need = pixels * RENDER_BYTES_PER_PIXEL;
    let budget = crate::limits::memory();
    if need > budget {
        bail!(
            "rendering {}×{} with --ssaa {} needs about {} MiB, over the memory budget of {} MiB: \
             render smaller, lower --ssaa, or raise --max-memory",
            a.width,
            a.height,
            a.ssaa,
            need >> 20,
            budget >> 20
        );
    }
    check_time(a.time)?;
    if !(a.fps.is_finite() && a.fps > 0.0) {
        bail!("--fps must be a positive number, got {}", a.fps);
    }
    if a.frames == 0 {
        bail!("--frames must be at least 1");
    }
    if let Some(e) = a.exposure
        && !(e.is_finite() && e > 0.0)
    {
        bail!("--exposure must be a positive number, got {e}");
    }
    check_render_outputs(&a)?;
    let mode = mode_of(a.mode);
    let asset = match (&a.bake, mode) {
        (Some(p), _) => Some(crate::limits::load_asset(p)?),
        (None, gibake_runtime::Mode::Direct) => None,
        (None, _) => bail!(
            "--mode {} needs a baked asset: run `gibake bake {} -o OUT.gibake` and pass --bake OUT.gibake",
            mode_name(a.mode),
            a.scene.scene.display()
        ),
    };
    let bake = a.bake.as_deref().zip(asset.as_ref());
    let scene = load_level(&a.scene, bake, "render")?;
    let ctx = GpuContext::new(&GpuOptions {
        adapter: a.adapter.clone(),
    })?;
    eprintln!("GPU: {}", ctx.record);
    let settings = gibake_runtime::RenderSettings {
        width: a.width * a.ssaa,
        height: a.height * a.ssaa,
        shadow_map_size: a.shadow_map_size,
        mode,
        max_dynamic_vpls: a.max_dynamic_vpls,
        max_dynamic_vpls_per_view: a.max_dynamic_vpls_per_view,
        interleave: a.interleave,
        max_spawned: 0,
        cascades: match a.cascades {
            crate::cli::CascadesArg::Auto => gibake_runtime::Cascades::Auto,
            crate::cli::CascadesArg::On => gibake_runtime::Cascades::On,
            crate::cli::CascadesArg::Off => gibake_runtime::Cascades::Off,
        },
        cascade_map_size: 0,
        light_culling: !a.no_light_culling,
        split_windows: !a.no_split_windows,
        near_field_descent: a.near_field_descent,
        later_near_field_descent: a.later_near_field_descent,
        later_full_resolution: a.later_full_resolution,
        merge_cull_share: a.merge_cull_share,
    };
    let t0 = Instant::now();
    // The scene's camera, checked before any GPU work.
    gibake_runtime::CameraMatrices::from_scene(&scene, a.time, settings.width, settings.height)
        .context("`gibake render` views the scene through its camera")?;
    let mut renderer =
        gibake_runtime::Renderer::new(&ctx.device, &ctx.queue, &scene, asset.as_ref(), &settings)
            .with_context(|| format!("setting up {}", a.scene.scene.display()))?;
    ctx.wait()?;
    let setup_s = t0.elapsed().as_secs_f64();
    let mut frames = Vec::new();
    // PNG frames: one exposure for the whole sequence (--exposure, or the
    // first frame's automatic one), so a sequence does not flicker.
    let mut exposure = a.exposure;
    for f in 0..a.frames {
        let t = a.time + f as f32 / a.fps;
        let start = Instant::now();
        let camera =
            gibake_runtime::CameraMatrices::from_scene(&scene, t, settings.width, settings.height)?;
        let transforms = gibake_runtime::scene_transforms(&scene, t);
        let frame = gibake_runtime::FrameInput::new(camera).transforms(&transforms);
        renderer.prepare(&ctx.device, &ctx.queue, &frame)?;
        let mut enc = ctx.device.create_command_encoder(&Default::default());
        renderer.record(&mut enc);
        ctx.queue.submit([enc.finish()]);
        let stats = renderer.stats(&ctx.device);
        let frame_s = start.elapsed().as_secs_f64();
        let img = gibake_eval::frame::read_output(&renderer, &ctx.device, &ctx.queue, a.ssaa)?;
        let out = frame_path(&a.output, f, a.frames);
        let e = *exposure.get_or_insert_with(|| img.auto_exposure());
        write_image_atomic(&img, &out, Some(e))?;
        let gpu_ms = stats.frame_ms;
        eprintln!(
            "wrote {} (t = {t:.3} s, GPU {gpu_ms:.2} ms, wall {:.3} s)",
            out.display(),
            frame_s
        );
        frames.push(serde_json::json!({
            "time": t,
            "output": crate::guard::lossy(&out),
            "wall_seconds": frame_s,
            "timing": stats.timing,
            "passes_ms": stats.passes.iter().map(|(n, ms)| serde_json::json!({"pass": n, "ms": ms})).collect::<Vec<_>>(),
            "update_ms": stats.update_ms(),
            "static_vpls": stats.static_vpls,
            "dynamic_vpl_slots": stats.dynamic_vpl_slots,
            "bounce_texels": stats.bounce_texels,
            "affected_maps": stats.affected_maps,
            "hidden_maps": stats.hidden_maps,
            "later_half_views": stats.later_half_views,
            "later_scale": stats.later_scale,
            "merge_faint_pairs": stats.merge_faint_pairs,
            "merge_maps_per_object": stats.merge_maps_per_object,
            "merge_instances": stats.merge_instances,
            "update_draw_calls": stats.update_draw_calls,
            "draw_calls": stats.draw_calls,
        }));
    }
    if let Some(stats) = &a.stats {
        let json = serde_json::json!({
            "adapter": ctx.record.to_string(),
            "scene": crate::guard::lossy(&a.scene.scene),
            "mode": mode_name(a.mode),
            "png_exposure": exposure,
            "width": a.width,
            "height": a.height,
            "ssaa": a.ssaa,
            "interleave": renderer.interleave(),
            "setup_seconds": setup_s,
            "asset_upload_bytes": renderer.asset_bytes(),
            "frames": frames,
            "warnings": scene.warnings,
        });
        crate::output::write_atomic(stats, serde_json::to_string_pretty(&json)?.as_bytes())?;
    }
    Ok(ExitCode::SUCCESS)
}

/// Output safety of `render`: image extensions, `--stats` `.json`, no
/// output over an input (the scene, the asset), every output distinct.
fn check_render_outputs(a: &RenderArgs) -> anyhow::Result<()> {
    let mut inputs: Vec<&Path> = vec![&a.scene.scene];
    if let Some(b) = &a.bake {
        inputs.push(b);
    }
    let frames: Vec<PathBuf> = (0..a.frames.min(100_000))
        .map(|f| frame_path(&a.output, f, a.frames))
        .collect();
    crate::output::check_extension("-o", &a.output, &["exr", "png"])?;
    let mut outputs: Vec<(&str, &Path)> = Vec::new();
    for f in &frames {
        crate::output::check_extension("-o", f, &["exr", "png"])?;
        crate::output::check_not_input("-o", f, &inputs)?;
        crate::guard::check_file_output("-o", f)?;
        outputs.push(("-o", f));
    }
    if let Some(stats) = &a.stats {
        crate::output::check_extension("--stats", stats, &["json"])?;
        crate::output::check_not_input("--stats", stats, &inputs)?;
        crate::guard::check_file_output("--stats", stats)?;
        outputs.push(("--stats", stats));
    }
    crate::output::check_distinct(&outputs)?;
    Ok(())
}

pub(crate) fn reference(a: ReferenceArgs) -> anyhow::Result<ExitCode> {
    check_size(a.width, a.height)?;
    check_time(a.time)?;
    if a.spp == 0 {
        bail!("--spp must be at least 1");
    }
    crate::output::check_extension("-o", &a.output, &["exr", "png"])?;
    crate::output::check_not_input("-o", &a.output, &[&a.scene.scene])?;
    crate::guard::check_file_output("-o", &a.output)?;
    let scene = gibake_scene::load(&a.scene.scene, &a.scene.load_options())?;
    let settings = gibake_reference::Settings {
        width: a.width,
        height: a.height,
        spp: a.spp,
        time: a.time,
        depth: if a.direct_only {
            gibake_reference::Depth::Direct
        } else {
            a.bounces
        },
        seed: a.seed,
    };
    let start = Instant::now();
    if settings.depth == gibake_reference::Depth::Every {
        probe_every_bounce(&scene, &settings)?;
    }
    let (img, stats) = run_reference_with_stats(&scene, &settings)?;
    write_image_atomic(&img, &a.output, None)?;
    eprintln!(
        "wrote {} ({:.2} s, {} spp, {})",
        a.output.display(),
        start.elapsed().as_secs_f64(),
        a.spp,
        depth_words(settings.depth, &stats)
    );
    Ok(ExitCode::SUCCESS)
}

/// What `depth` rendered, for the summary line.
fn depth_words(depth: gibake_reference::Depth, stats: &gibake_reference::PathStats) -> String {
    use gibake_reference::Depth;
    match depth {
        Depth::Direct => "direct light only".into(),
        Depth::OneBounce => "direct + one bounce".into(),
        Depth::Bounces(n) => format!(
            "direct + {n} bounces, {:.1} bounce rays a path",
            stats.mean_bounces()
        ),
        Depth::Every => format!(
            "every bounce, {:.1} bounce rays a path",
            stats.mean_bounces()
        ),
    }
}

/// The warning for paths cut at the cap of every bounce (none: `None`).
fn cap_warning(stats: &gibake_reference::PathStats) -> Option<String> {
    (stats.capped > 0).then(|| {
        format!(
            "warning: {} of {} paths ({:.3}%) reached {} bounces and were cut there: the scene \
             traps light (albedo 1, or very near 1, in a closed space; with albedo 1 there is no \
             finite answer). The image is the sum of the first {} bounces, too dark by the light \
             those paths still carried; `--bounces N` sets the bounces instead (docs/reference.md, \
             \"Every bounce\")",
            stats.capped,
            stats.paths,
            100.0 * stats.capped_fraction(),
            gibake_reference::MAX_BOUNCES,
            gibake_reference::MAX_BOUNCES,
        )
    })
}

/// Before an every-bounce render, a quick one (1/8 the size, 1 spp) that
/// warns when many paths run to the cap: such a render costs up to 1024
/// bounce rays a sample, and the user may rather bound it now than wait.
fn probe_every_bounce(scene: &Scene, s: &gibake_reference::Settings) -> anyhow::Result<()> {
    let probe = gibake_reference::Settings {
        width: s.width.div_ceil(8),
        height: s.height.div_ceil(8),
        spp: 1,
        ..s.clone()
    };
    let (_, stats) = gibake_reference::render_with_stats(scene, &probe, &|_| {})
        .with_context(|| format!("reference render of {}", scene.source.display()))?;
    if stats.capped_fraction() >= 0.01 {
        eprintln!(
            "warning: {:.0}% of a quick probe's paths ({}×{}, 1 spp) reach the cap of {} \
             bounces: this render follows them all that way ({:.0} bounce rays a path, against \
             1 for `--bounces 1`), and will take long; `--bounces N` bounds it",
            100.0 * stats.capped_fraction(),
            probe.width,
            probe.height,
            gibake_reference::MAX_BOUNCES,
            stats.mean_bounces()
        );
    }
    Ok(())
}

pub(crate) fn run_reference(
    scene: &Scene,
    settings: &gibake_reference::Settings,
) -> anyhow::Result<gibake_image::Image> {
    run_reference_with_stats(scene, settings).map(|(img, _)| img)
}

/// The reference render with a progress bar; warns when paths were cut at
/// the cap of every bounce.
fn run_reference_with_stats(
    scene: &Scene,
    settings: &gibake_reference::Settings,
) -> anyhow::Result<(gibake_image::Image, gibake_reference::PathStats)> {
    let pb = bar(settings.height as u64, "reference");
    let (img, stats) =
        gibake_reference::render_with_stats(scene, settings, &|rows| pb.set_position(rows))
            .with_context(|| format!("reference render of {}", scene.source.display()))?;
    pb.finish_and_clear();
    if let Some(w) = cap_warning(&stats) {
        eprintln!("{w}");
    }
    Ok((img, stats))
}

/// indicatif progress for the bake's stages.
pub(crate) struct BarProgress {
    pub(crate) bar: std::sync::Mutex<Option<indicatif::ProgressBar>>,
    pub(crate) quiet: bool,
}

impl gibake_bake::BakeProgress for BarProgress {
    fn memory_limit(&self) -> Option<u64> {
        Some(crate::limits::memory())
    }
    fn begin(&self, stage: &str, total: u64) {
        if self.quiet {
            return;
        }
        let pb = if total > 0 {
            bar(total, stage)
        } else {
            let pb = indicatif::ProgressBar::new_spinner();
            pb.set_message(stage.to_string());
            pb.enable_steady_tick(std::time::Duration::from_millis(120));
            pb
        };
        *self.bar.lock().expect("progress lock") = Some(pb);
    }
    fn advance(&self, n: u64) {
        if let Some(pb) = self.bar.lock().expect("progress lock").as_ref() {
            pb.inc(n);
        }
    }
    fn end(&self) {
        if let Some(pb) = self.bar.lock().expect("progress lock").take() {
            pb.finish_and_clear();
        }
    }
}

pub(crate) fn inspect(a: InspectArgs) -> anyhow::Result<ExitCode> {
    let asset = crate::limits::load_asset(&a.asset)?;
    let info = gibake_asset::inspect(&asset);
    if a.json {
        crate::output::print_stdout(&serde_json::to_string_pretty(&info)?)?;
    } else {
        crate::output::print_stdout(&info.to_string())?;
    }
    Ok(ExitCode::SUCCESS)
}

pub(crate) fn diff(a: DiffArgs) -> anyhow::Result<ExitCode> {
    // Every output and every option checked before any work.
    let inputs: Vec<&Path> = [&a.a, &a.b]
        .into_iter()
        .chain(&a.scenes)
        .map(PathBuf::as_path)
        .collect();
    if let Some(dir) = &a.images {
        crate::output::check_not_input("--images", dir, &inputs)?;
        crate::guard::check_dir_output("--images", dir)?;
    }
    if let Some(md) = &a.markdown {
        crate::output::check_extension("--markdown", md, &["md", "markdown"])?;
        crate::output::check_not_input("--markdown", md, &inputs)?;
        crate::guard::check_file_output("--markdown", md)?;
    }
    if a.scenes.is_empty() {
        for (given, flag) in [
            (!a.views.is_empty(), "--view"),
            (!a.view_cameras.is_empty(), "--view-camera"),
            (!a.times.is_empty(), "--time"),
        ] {
            if given {
                bail!("{flag} chooses what the image-space diff renders: give --scene LEVEL too");
            }
        }
    } else {
        crate::scene_diff::check_args(&a)?;
    }
    let asset_a = crate::limits::load_asset(&a.a)?;
    let asset_b = crate::limits::load_asset(&a.b)?;
    let mut tol = match a.tolerance {
        TolerancePreset::SameMachine => gibake_asset::Tolerance::same_machine(),
        TolerancePreset::AnotherGpu => gibake_asset::Tolerance::another_gpu(),
    };
    if let Some(v) = a.map_rel {
        tol.map_rel = v;
    }
    if let Some(v) = a.max_texels_over {
        tol.max_texels_over = v;
    }
    if let Some(v) = a.vpl_position_rel {
        tol.vpl_position_rel = v;
    }
    if let Some(v) = a.vpl_flux_rel {
        tol.vpl_flux_rel = v;
    }
    tol.strict_provenance |= a.strict_provenance;
    let report = gibake_asset::diff(&asset_a, &asset_b, &tol);
    let images = if a.scenes.is_empty() {
        None
    } else {
        Some(crate::scene_diff::run(&a, &asset_a, &asset_b)?)
    };
    let md_dir = a.markdown.as_deref().map(|m| {
        m.parent()
            .filter(|p| !p.as_os_str().is_empty())
            .unwrap_or(Path::new("."))
            .to_owned()
    });
    if a.json {
        let mut j = serde_json::to_value(&report)?;
        if let Some(i) = &images {
            j["image_diff"] = i.json(None);
        }
        crate::output::print_stdout(&serde_json::to_string_pretty(&j)?)?;
    } else {
        crate::output::print_stdout(&report.to_string())?;
        if let Some(i) = &images {
            crate::output::print_stdout(&i.text())?;
        }
    }
    if let Some(dir) = &a.images {
        std::fs::create_dir_all(dir).with_context(|| format!("creating {}", dir.display()))?;
        for p in gibake_asset::write_diff_images(&asset_a, &asset_b, dir)? {
            eprintln!("wrote {}", p.display());
        }
    }
    if let (Some(md), Some(dir)) = (&a.markdown, &md_dir) {
        let text = match &images {
            Some(i) => i.markdown(&a.a, &a.b, dir, &report.to_string()),
            None => data_markdown(&a, &report),
        };
        crate::output::write_atomic(md, text.as_bytes())?;
        eprintln!("wrote {}", md.display());
    }
    let different = match &images {
        Some(i) => i.visible(),
        None => !report.equal(),
    };
    Ok(if different {
        ExitCode::from(1)
    } else {
        ExitCode::SUCCESS
    })
}

/// The Markdown summary of a data diff alone (no --scene).
fn data_markdown(a: &DiffArgs, report: &gibake_asset::DiffReport) -> String {
    let name = |p: &Path| crate::guard::lossy(p.file_name().map_or(p, Path::new));
    let (mark, words) = if report.equal() {
        ("PASS", "equal within the tolerance")
    } else {
        ("FAIL", "different")
    };
    format!(
        "## gibake diff: **{mark}**, {words}\n\n`{}` against `{}` (the baked data; give `--scene LEVEL` to compare what a player sees).\n\n```\n{}\n```\n",
        name(&a.a),
        name(&a.b),
        report.to_string().trim_end()
    )
}
