//! A game's view of gibake, using `gibake-runtime` alone: load a scene and
//! its baked asset, ask what it needs of a device before making one, create
//! the runtime on the game's own `wgpu::Device`, and each frame pass the
//! game's own cameras (the main view and a small top-down second view over
//! the same upload and per-frame update) and move the dynamic objects by
//! handle; hide one for a while; resize once on the way; read per-pass
//! times without waiting; write the lit frames as EXR.
//!
//! ```text
//! gibake bake data/corner_bunny.glb -o bunny.gibake
//! cargo run --release -p gibake-runtime --example game_loop -- data/corner_bunny.glb bunny.gibake [--out DIR]
//! ```
//! The scene's own camera is dropped on purpose: a game brings its own.

use std::path::{Path, PathBuf};

use gibake_runtime::glam::{Mat4, Vec3};
use gibake_runtime::{
    CameraMatrices, FrameInput, Image, Mode, RenderSettings, Renderer, Requirements, wgpu,
};

/// Copies an `Rgba32Float` texture to the CPU (what a game does for a
/// screenshot; tools use `gibake_eval::frame::read_output`).
fn read_back(
    device: &wgpu::Device,
    queue: &wgpu::Queue,
    texture: &wgpu::Texture,
) -> Result<Image, Box<dyn std::error::Error>> {
    let (w, h) = (texture.width(), texture.height());
    let row = (w * 16).next_multiple_of(wgpu::COPY_BYTES_PER_ROW_ALIGNMENT);
    let buffer = device.create_buffer(&wgpu::BufferDescriptor {
        label: Some("screenshot"),
        size: u64::from(row) * u64::from(h),
        usage: wgpu::BufferUsages::COPY_DST | wgpu::BufferUsages::MAP_READ,
        mapped_at_creation: false,
    });
    let mut encoder = device.create_command_encoder(&Default::default());
    encoder.copy_texture_to_buffer(
        texture.as_image_copy(),
        wgpu::TexelCopyBufferInfo {
            buffer: &buffer,
            layout: wgpu::TexelCopyBufferLayout {
                offset: 0,
                bytes_per_row: Some(row),
                rows_per_image: None,
            },
        },
        texture.size(),
    );
    queue.submit([encoder.finish()]);
    buffer.slice(..).map_async(wgpu::MapMode::Read, |_| {});
    device.poll(wgpu::PollType::wait_indefinitely())?;
    let data = buffer.slice(..).get_mapped_range()?;
    let mut rgba = Vec::with_capacity((w * h * 4) as usize);
    for y in 0..h as usize {
        let start = y * row as usize;
        let line: &[f32] = bytemuck::cast_slice(&data[start..start + w as usize * 16]);
        rgba.extend_from_slice(line);
    }
    Ok(Image::from_rgba_f32(w, h, &rgba))
}

/// The game's camera: orbiting the scene's centre.
fn orbit_camera(centre: Vec3, radius: f32, angle: f32, aspect: f32) -> CameraMatrices {
    let eye = centre + Vec3::new(angle.sin(), 0.35, angle.cos()) * radius;
    // Camera axes: looking down its −Z at the centre, +Y up.
    let back = (eye - centre).normalize();
    let right = Vec3::Y.cross(back).normalize();
    let up = back.cross(right);
    let camera_to_world = Mat4::from_cols(
        right.extend(0.0),
        up.extend(0.0),
        back.extend(0.0),
        eye.extend(1.0),
    );
    CameraMatrices::perspective(camera_to_world, 50f32.to_radians(), aspect, 0.01)
}

/// A camera high above the scene centre, looking straight down.
fn top_down_camera(centre: Vec3, radius: f32) -> CameraMatrices {
    let eye = centre + Vec3::Y * radius;
    // Looking down its −Z (world −Y), +Y of the camera along world −Z.
    let camera_to_world = Mat4::from_cols(
        Vec3::X.extend(0.0),
        Vec3::NEG_Z.extend(0.0),
        Vec3::Y.extend(0.0),
        eye.extend(1.0),
    );
    CameraMatrices::perspective(camera_to_world, 60f32.to_radians(), 1.0, 0.01)
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let mut args: Vec<String> = std::env::args().skip(1).collect();
    let mut out = PathBuf::from("game_loop_out");
    if let Some(i) = args.iter().position(|a| a == "--out") {
        out = PathBuf::from(args.get(i + 1).ok_or("--out needs a directory")?);
        args.drain(i..=i + 1);
    }
    let [scene_path, asset_path] = args.as_slice() else {
        return Err("usage: game_loop SCENE.glb ASSET.gibake [--out DIR] \
                    (make the asset with `gibake bake SCENE.glb -o ASSET.gibake`)"
            .into());
    };
    std::fs::create_dir_all(&out)?;

    // The scene (geometry, light, moving objects) and the baked asset.
    let mut scene = gibake_runtime::load_scene(Path::new(scene_path), &Default::default())?;
    scene.camera = None; // the game's camera is used, never the file's
    let asset = gibake_runtime::load_asset(Path::new(asset_path))?;
    let settings = RenderSettings {
        width: 320,
        height: 240,
        mode: Mode::Full,
        ..Default::default()
    };

    // What the level needs of a device, before the game makes one.
    let needs = Requirements::of(&scene, Some(&asset), &settings)?;
    let instance = wgpu::Instance::new(wgpu::InstanceDescriptor::new_without_display_handle());
    let adapter = pollster::block_on(instance.request_adapter(&Default::default()))?;
    needs.check(&adapter.limits())?;
    let (device, queue) = pollster::block_on(adapter.request_device(&wgpu::DeviceDescriptor {
        // Timestamps, where the adapter has them, give per-pass GPU times.
        required_features: adapter.features() & needs.optional_features,
        required_limits: needs.limits.clone(),
        ..Default::default()
    }))?;
    println!(
        "GPU: {} (the level needs {:.1} MiB of GPU memory, {:.1} MiB of it the asset)",
        adapter.get_info().name,
        needs.gpu_bytes as f64 / (1 << 20) as f64,
        needs.asset_bytes as f64 / (1 << 20) as f64
    );

    let mut renderer = Renderer::new(&device, &queue, &scene, Some(&asset), &settings)?;
    let names: Vec<&str> = renderer.objects().map(|(_, n)| n).collect();
    println!("moving objects: {names:?}");
    println!(
        "passes: {}",
        renderer
            .plan()
            .passes()
            .iter()
            .map(|p| p.name())
            .collect::<Vec<_>>()
            .join(", ")
    );
    // Handles and rest poses of the moving objects.
    let rest: Vec<_> = renderer
        .objects()
        .map(|(h, _)| renderer.transform(h).map(|m| (h, m)))
        .collect::<Result<_, _>>()?;
    // A second, top-down view (a minimap): its own G-buffer and shading,
    // the same asset and per-frame update.
    let minimap = renderer.add_view(&device, &queue, 96, 96, 0)?;

    let bounds = scene.static_bounds();
    let (centre, radius) = (bounds.center(), bounds.diagonal() * 0.9);
    for frame in 0..8 {
        if frame == 4 {
            // The window changed size.
            renderer.resize(&device, &queue, 400, 225)?;
        }
        let (w, h) = renderer.size();
        let camera = orbit_camera(centre, radius, frame as f32 * 0.1, w as f32 / h as f32);
        // The game moves its objects: each circles the scene centre.
        let angle = frame as f32 * 0.15;
        let moved: Vec<_> = rest
            .iter()
            .map(|&(handle, m)| {
                let p = m.w_axis.truncate() - centre;
                let rotated = Mat4::from_rotation_y(angle).transform_point3(p) + centre;
                (
                    handle,
                    Mat4::from_translation(rotated - m.w_axis.truncate()) * m,
                )
            })
            .collect();
        // One ball leaves the level for frames 2 and 3.
        if let Some(&(ball, _)) = rest.first() {
            renderer.set_visible(ball, !(2..4).contains(&frame))?;
        }
        let top = [(minimap, top_down_camera(centre, radius))];
        renderer.prepare(
            &device,
            &queue,
            &FrameInput::new(camera).moving(&moved).views(&top),
        )?;

        let mut encoder = device.create_command_encoder(&Default::default());
        renderer.record(&mut encoder);
        // A game would now sample `renderer.output()` (linear radiance) in
        // its own tone-mapping pass, in the same encoder.
        queue.submit([encoder.finish()]);

        // The newest finished frame's figures, without waiting for the GPU.
        match renderer.poll_stats(&device) {
            Some(s) => println!(
                "frame {frame} ({w}×{h}): figures of frame {}: update {:.2} ms, frame {:.2} ms, {} affected VPL maps, {} views ({})",
                s.frame,
                s.update_ms(),
                s.frame_ms,
                s.affected_maps,
                s.views,
                s.timing
            ),
            None => println!("frame {frame} ({w}×{h}): no frame finished yet"),
        }
        let image = read_back(&device, &queue, renderer.output())?;
        image.write_exr(&out.join(format!("frame_{frame}.exr")))?;
        let map = read_back(&device, &queue, renderer.view_output(minimap)?)?;
        map.write_exr(&out.join(format!("minimap_{frame}.exr")))?;
    }
    println!("frames in {}", out.display());
    Ok(())
}
