//! `gibake view`: the arguments checked and turned into
//! [`gibake_viewer::ViewOptions`]; the window, the frames and the report
//! live in `gibake-viewer`. A headless run's screenshot is written here,
//! through the same atomic writer as `render`'s frames.

use std::path::Path;
use std::process::ExitCode;

use anyhow::{Context, bail};

use crate::cli::ViewArgs;
use crate::commands::{check_size, check_time, load_level, mode_name, mode_of};

pub(crate) fn view(a: ViewArgs) -> anyhow::Result<ExitCode> {
    check_size(a.width, a.height)?;
    check_time(a.time)?;
    if !(a.fps.is_finite() && a.fps > 0.0) {
        bail!("--fps must be a positive number, got {}", a.fps);
    }
    if let Some(e) = a.exposure
        && !(e.is_finite() && e > 0.0)
    {
        bail!("--exposure must be a positive number, got {e}");
    }
    let mut inputs: Vec<&Path> = vec![&a.scene.scene];
    if let Some(b) = &a.bake {
        inputs.push(b);
    }
    let mut outputs: Vec<(&str, &Path)> = Vec::new();
    for (flag, path, exts) in [
        ("--screenshot", &a.screenshot, &["png", "exr"][..]),
        ("--presented", &a.presented, &["png"][..]),
    ] {
        if let Some(p) = path {
            crate::output::check_extension(flag, p, exts)?;
            crate::output::check_not_input(flag, p, &inputs)?;
            crate::guard::check_file_output(flag, p)?;
            outputs.push((flag, p));
        }
    }
    crate::output::check_distinct(&outputs)?;
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
    let scene = load_level(&a.scene, bake, "view")?;
    let settings = gibake_runtime::RenderSettings {
        width: a.width,
        height: a.height,
        shadow_map_size: a.shadow_map_size,
        mode,
        max_dynamic_vpls: a.max_dynamic_vpls,
        interleave: a.interleave,
        max_spawned: 0,
        ..Default::default()
    };
    if a.gpu_report {
        let report =
            gibake_viewer::gpu_report(&scene, asset.as_ref(), &settings, a.adapter.as_deref())?;
        crate::outln!("{}", report.text);
        return match report.refused {
            None => Ok(ExitCode::SUCCESS),
            Some(reason) => bail!(
                "the adapter cannot run {}: {reason}",
                a.scene.scene.display()
            ),
        };
    }
    let shot = gibake_viewer::run(gibake_viewer::ViewOptions {
        scene,
        reimport: Some(gibake_viewer::Reimport {
            path: a.scene.scene.clone(),
            options: a.scene.load_options(),
        }),
        asset,
        asset_dir: a.bake.clone(),
        max_decoded_bytes: crate::limits::memory(),
        settings,
        time: a.time,
        fps: a.fps,
        exposure: a.exposure,
        frames: a.frames,
        adapter: a.adapter.clone(),
    })
    .with_context(|| format!("viewing {}", a.scene.scene.display()))?;
    let Some(shot) = shot else {
        return Ok(ExitCode::SUCCESS);
    };
    if let Some(path) = &a.screenshot {
        eprintln!("GPU: {}", shot.adapter);
        crate::output::write_image_atomic(&shot.image, path, Some(shot.exposure))?;
        eprintln!("wrote {} (exposure {})", path.display(), shot.exposure);
    }
    if let Some(path) = &a.presented {
        let Some((w, h, rgb)) = &shot.presented else {
            bail!(
                "--presented: the window's surface on {} does not allow reading it back",
                shot.adapter.name
            );
        };
        crate::output::write_rgb8_png_atomic(path, *w, *h, rgb)?;
        eprintln!("wrote {} (the window's pixels)", path.display());
    }
    Ok(ExitCode::SUCCESS)
}
