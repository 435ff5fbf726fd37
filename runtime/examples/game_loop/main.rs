//! A game's view of gibake: load a scene and its baked asset, create the
//! runtime on the game's own `wgpu::Device`, move the dynamic objects with
//! the game's own transforms every frame, and use the lit frame.
//!
//! ```text
//! cargo run --release -p gibake-runtime --example game_loop -- [SCENE.glb [ASSET.gibake]] [--out DIR]
//! ```
//! Without an asset the example bakes one in memory first (a game would
//! ship the `.gibake` made by `gibake bake`).

use std::path::PathBuf;

use gibake_gpu::{GpuContext, GpuOptions};
use gibake_runtime::{Mode, RenderSettings, Renderer};
use glam::Mat4;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let mut args: Vec<String> = std::env::args().skip(1).collect();
    let mut out = PathBuf::from("game_loop_out");
    if let Some(i) = args.iter().position(|a| a == "--out") {
        out = PathBuf::from(args.get(i + 1).ok_or("--out needs a directory")?);
        args.drain(i..=i + 1);
    }
    let root = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("..");
    let scene_path = args
        .first()
        .map(PathBuf::from)
        .unwrap_or(root.join("data/corner_bunny.glb"));
    std::fs::create_dir_all(&out)?;

    // The game's device (here a headless one; a game passes its own).
    let ctx = GpuContext::new(&GpuOptions::default())?;
    println!("GPU: {}", ctx.record);

    // Load the scene and the baked asset (checked against the scene).
    let scene = gibake_scene::load(&scene_path, &Default::default())?;
    let asset = match args.get(1) {
        Some(p) => gibake_asset::load(std::path::Path::new(p))?,
        None => {
            println!("no asset given: baking {} in memory", scene_path.display());
            gibake_bake::bake(
                &ctx,
                &scene,
                &Default::default(),
                &gibake_bake::NoProgress,
                "example",
            )?
            .asset
        }
    };

    // GPU resources on the game's device.
    let settings = RenderSettings {
        width: 320,
        height: 240,
        mode: Mode::Full,
        ..Default::default()
    };
    let mut renderer = Renderer::new(
        &ctx.device,
        &ctx.queue,
        &scene,
        Some(&asset),
        &settings,
        0.0,
    )?;

    // The game loop: the game moves its objects (here: every dynamic object
    // circles the scene centre), the runtime does only what they change.
    let centre = scene.static_bounds().center();
    let rest: Vec<Mat4> = (0..scene.dynamic_objects.len())
        .map(|i| scene.dynamic_transform(i, 0.0))
        .collect();
    for frame in 0..8 {
        let angle = frame as f32 * 0.15;
        let transforms: Vec<Mat4> = rest
            .iter()
            .map(|m| {
                let p = m.w_axis.truncate() - centre;
                let rotated = Mat4::from_rotation_y(angle).transform_point3(p) + centre;
                Mat4::from_translation(rotated - m.w_axis.truncate()) * *m
            })
            .collect();
        renderer.set_dynamic_transforms(&ctx.queue, &transforms);

        let mut encoder = ctx.device.create_command_encoder(&Default::default());
        renderer.encode(&ctx.device, &ctx.queue, &mut encoder);
        // A game would now sample `renderer.output()` (linear radiance,
        // Rgba32Float) in its own tone-mapping pass, in the same encoder.
        ctx.queue.submit([encoder.finish()]);

        let stats = renderer.stats(&ctx.device);
        println!(
            "frame {frame}: update {:.2} ms, {} affected VPL maps, {} dynamic VPL slots ({})",
            stats.update_ms(),
            stats.affected_maps,
            stats.dynamic_vpl_slots,
            stats.timing
        );
        let image = gibake_runtime::read_output(&ctx, &renderer, 1)?;
        image.write_png(&out.join(format!("frame_{frame}.png")), None)?;
    }
    println!("frames in {}", out.display());
    Ok(())
}
