//! `cargo run --release -p gibake-eval --example cascade_cost -- [LEVEL] [--width W] [--height H] [--frames N] [--mode full|direct]`
//! The frame-time cost of the runtime's shadow cascades on a bundled level
//! (default: arena, 480×270, 12 frames, full mode): the same frames
//! rendered with cascades off and on, side by side (interleaved, on one
//! adapter), with the moving balls moving, first from the level's still
//! camera, then with the camera moving every frame (its static cascade
//! maps redrawn each frame). Prints median GPU milliseconds per pass and
//! per frame and the on/off ratios.
use gibake_runtime::{
    CameraMatrices, Cascades, FrameInput, Mode, Pass, RenderSettings, Renderer, glam,
};
use glam::{Mat4, Vec3};

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    if v.is_empty() { 0.0 } else { v[v.len() / 2] }
}

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let (mut name, mut w, mut h, mut frames, mut mode) =
        ("arena".to_string(), 480u32, 270u32, 12u32, Mode::Full);
    let mut it = args.iter();
    while let Some(a) = it.next() {
        let mut num = || {
            it.next()
                .expect("a value")
                .parse::<u32>()
                .expect("a number")
        };
        match a.as_str() {
            "--width" => w = num(),
            "--height" => h = num(),
            "--frames" => frames = num(),
            "--mode" => {
                mode = match it.next().map(String::as_str) {
                    Some("direct") => Mode::Direct,
                    _ => Mode::Full,
                }
            }
            n => name = n.to_string(),
        }
    }
    let list = gibake_eval::levels::bundled_list();
    let specs = gibake_eval::levels::read_specs(&list).unwrap();
    let spec = specs
        .iter()
        .find(|l| l.name == name)
        .expect("a bundled level");
    let scene = spec.load(list.parent().unwrap()).unwrap();
    let ctx = gibake_gpu::GpuContext::new(&Default::default()).unwrap();
    println!("{name} {w}×{h} {mode:?}, adapter {}", ctx.record);
    let asset = (mode != Mode::Direct)
        .then(|| gibake_eval::bake(&ctx, &scene, &gibake_eval::EvalSettings::default()).unwrap());
    let (d, q) = (&ctx.device, &ctx.queue);
    let mut renderers: Vec<Renderer> = [Cascades::Off, Cascades::On]
        .iter()
        .map(|&c| {
            let s = RenderSettings {
                width: w,
                height: h,
                mode,
                cascades: c,
                ..Default::default()
            };
            Renderer::new(d, q, &scene, asset.as_ref(), &s).unwrap()
        })
        .collect();
    println!("cascades: {:?}", renderers[1].plan().cascades());
    let base = CameraMatrices::from_scene(&scene, 0.0, w, h).unwrap();
    for moving_camera in [false, true] {
        // times[renderer] = (per pass, frame)
        let mut per_pass: Vec<Vec<(Pass, Vec<f64>)>> = vec![Vec::new(), Vec::new()];
        let mut frame_ms = [Vec::new(), Vec::new()];
        for f in 0..=frames {
            let t = f as f32 * 0.1;
            let mut transforms = gibake_runtime::scene_transforms(&scene, t);
            for (i, m) in transforms.iter_mut().enumerate() {
                *m = Mat4::from_translation(Vec3::new(0.3 * (t + i as f32).sin(), 0.0, 0.0)) * *m;
            }
            let camera = if moving_camera {
                let step =
                    Mat4::from_translation(Vec3::new(0.05 * f as f32, 0.0, -0.03 * f as f32));
                CameraMatrices {
                    view_proj: base.view_proj * step.inverse(),
                    position: step.transform_point3(base.position),
                    ..base
                }
            } else {
                base
            };
            for (k, r) in renderers.iter_mut().enumerate() {
                r.prepare(d, q, &FrameInput::new(camera).transforms(&transforms))
                    .unwrap();
                let mut enc = d.create_command_encoder(&Default::default());
                r.record(&mut enc);
                q.submit([enc.finish()]);
                let s = r.stats(d);
                if f == 0 {
                    continue; // warm-up (the still camera's static draw)
                }
                frame_ms[k].push(s.frame_ms);
                for (p, ms) in &s.passes {
                    match per_pass[k].iter_mut().find(|(q, _)| q == p) {
                        Some((_, v)) => v.push(*ms),
                        None => per_pass[k].push((*p, vec![*ms])),
                    }
                }
            }
        }
        let camera = if moving_camera {
            "moving camera"
        } else {
            "still camera"
        };
        let (off, on) = (median(frame_ms[0].clone()), median(frame_ms[1].clone()));
        println!(
            "{camera}: frame median {off:.2} ms off, {on:.2} ms on: ×{:.3}",
            on / off
        );
        for (p, v) in &per_pass[1] {
            let o = per_pass[0]
                .iter()
                .find(|(q, _)| q == p)
                .map_or(0.0, |(_, v)| median(v.clone()));
            println!(
                "  {:>14}: off {o:8.2} ms, on {:8.2} ms",
                p.name(),
                median(v.clone())
            );
        }
    }
}
