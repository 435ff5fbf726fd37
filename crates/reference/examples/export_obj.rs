//! Exports a scene for the Mitsuba 3 validation and renders the gibake
//! reference images of it.
//!
//! ```text
//! cargo run -p gibake-reference --release --example export_obj -- OUT_DIR \
//!     [--scene SCENE.glb [--sun AZ,EL,E] [--look-at EX,EY,EZ,TX,TY,TZ,FOV]] [--time T]
//!     [--size N] [--spp N] [--segments N] [--seed S] [--spot | --multi | --room] [--every-bounce]
//! ```
//!
//! Without `--scene` the hand-built validation corner
//! (`gibake_reference::scenes::validation_corner`) is used; `--spot` replaces
//! its directional light by a hard-edged spot (glTF inner = outer = 35°,
//! 6 W/sr), which Mitsuba's `spot` emitter reproduces up to a 0.1°-wide rim;
//! `--multi` uses `validation_corner_multi` (the corner's directional light,
//! a point light and a hard-edged spot, distinct colours); `--room` uses
//! `validation_room` (a closed room lit by a sun through a window, for
//! every bounce). With `--scene`, `--sun` and `--look-at` are `gibake`'s
//! (a level exported without a light or camera: the bundled levels'
//! values are in data/levels/levels.json); textures and alpha masks are
//! not exported, so both renderers get the base colour factors alone (the
//! gibake renders drop them too, with a warning). With `--scene`,
//! every glTF light of the file is imported, point lights included
//! (`--all-lights`, once needed for that, is still accepted). Writes to
//! `OUT_DIR`: one OBJ per mesh (world space at time T, positions and vertex
//! normals), `scene.json` (camera, `lights` — every light of the scene —,
//! meshes with albedo, image size, spp, timings) and `gibake_direct.exr` /
//! `gibake_one_bounce.exr` (N × N, `spp` samples); with `--every-bounce`
//! also `gibake_every_bounce.exr` (`Depth::Every`, the same spp and seed;
//! its bounce rays a path and paths cut at the cap in `scene.json`).
//!
//! A light with a glTF `range` is refused (exit status 2, before anything is
//! written): Mitsuba's emitters have no range window, so the comparison
//! would differ by design.
//!
//! `crates/reference/validation/mitsuba_validate.py OUT_DIR` renders the same
//! scene with Mitsuba and compares.

use std::fmt::Write as _;
use std::path::PathBuf;
use std::time::Instant;

use gibake_reference::{Depth, RayScene, Settings, View, render_view_with_stats, scenes};
use gibake_scene::{Light, LightKind, LoadOptions, Projection, Scene};
use glam::Vec3;

fn usage() -> ! {
    eprintln!(
        "usage: export_obj OUT_DIR [--scene SCENE.glb [--sun AZ,EL,E] [--look-at EX,EY,EZ,TX,TY,TZ,FOV]] [--time T] [--size N] [--spp N] [--segments N] [--seed S] [--spot | --multi | --room] [--every-bounce]"
    );
    std::process::exit(2);
}

/// `n` comma-separated numbers, or the usage.
fn numbers(s: &str, n: usize) -> Vec<f32> {
    let v: Vec<f32> = s.split(',').filter_map(|x| x.trim().parse().ok()).collect();
    if v.len() != n {
        usage();
    }
    v
}

fn v3(v: Vec3) -> String {
    format!("[{:?}, {:?}, {:?}]", v.x, v.y, v.z)
}

fn main() {
    let mut args = std::env::args().skip(1);
    let mut out: Option<PathBuf> = None;
    let mut scene_path: Option<PathBuf> = None;
    let (mut use_spot, mut multi, mut room, mut every) = (false, false, false, false);
    let mut options = LoadOptions::default();
    let (mut time, mut size, mut spp, mut segments, mut seed) =
        (0.0f32, 128u32, 1024u32, 48u32, 0u64);
    while let Some(a) = args.next() {
        let mut val = || args.next().unwrap_or_else(|| usage());
        match a.as_str() {
            "--scene" => scene_path = Some(val().into()),
            "--time" => time = val().parse().unwrap_or_else(|_| usage()),
            "--size" => size = val().parse().unwrap_or_else(|_| usage()),
            "--spp" => spp = val().parse().unwrap_or_else(|_| usage()),
            "--segments" => segments = val().parse().unwrap_or_else(|_| usage()),
            "--seed" => seed = val().parse().unwrap_or_else(|_| usage()),
            "--spot" => use_spot = true,
            "--multi" => multi = true,
            "--room" => room = true,
            "--sun" => {
                let v = numbers(&val(), 3);
                options.sun = Some(gibake_scene::Sun {
                    azimuth_deg: v[0],
                    elevation_deg: v[1],
                    irradiance: v[2],
                    color: Vec3::ONE,
                });
            }
            "--look-at" => {
                let v = numbers(&val(), 7);
                options.camera = gibake_scene::CameraChoice::LookAt {
                    eye: Vec3::new(v[0], v[1], v[2]),
                    target: Vec3::new(v[3], v[4], v[5]),
                    yfov_deg: v[6],
                };
            }
            "--every-bounce" => every = true,
            "--all-lights" => {}
            s if s.starts_with("--") => usage(),
            s => out = Some(s.into()),
        }
    }
    let out = out.unwrap_or_else(|| usage());
    let built_in = [use_spot, multi, room].iter().filter(|&&b| b).count();
    if built_in > 1 || scene_path.is_some() && built_in > 0 {
        eprintln!("--spot, --multi and --room choose a built-in scene: use one, without --scene");
        std::process::exit(2);
    }

    let (scene, view): (Scene, View) = match &scene_path {
        None if multi => scenes::validation_corner_multi(segments),
        None if room => scenes::validation_room(segments),
        None => {
            let (mut scene, view) = scenes::validation_corner(segments);
            if use_spot {
                let pos = Vec3::new(0.9, 1.9, 1.3);
                let cone = 35f32.to_radians();
                scene.lights[0] = scenes::spot(
                    pos,
                    Vec3::new(-0.3, 0.2, -0.4) - pos,
                    Vec3::splat(6.0),
                    cone,
                    cone,
                );
            }
            (scene, view)
        }
        Some(p) => {
            let mut scene = gibake_scene::load(p, &options).unwrap_or_else(|e| {
                eprintln!("{e}");
                std::process::exit(2)
            });
            // Mitsuba gets the base colour factors: so does gibake here.
            if !scene.textures.is_empty() || scene.materials.iter().any(|m| m.cutoff().is_some()) {
                eprintln!(
                    "warning: textures and alpha masks are not exported; both renderers get the \
                     base colour factors alone"
                );
                for m in &mut scene.materials {
                    m.texture = None;
                    m.alpha_mode = gibake_scene::AlphaMode::Opaque;
                }
                scene.textures.clear();
            }
            let view = View::from_scene(&scene, time).unwrap_or_else(|e| {
                eprintln!("{e}");
                std::process::exit(2)
            });
            (scene, view)
        }
    };
    // Mitsuba has no range window: refuse rather than compare different scenes.
    if let Some(l) = scene.lights.iter().find(|l| l.range.is_some()) {
        eprintln!(
            "light {:?} has a glTF range ({} units): Mitsuba's emitters have no range window, so \
             the validation cannot reproduce it; remove the range (or the light) from the scene",
            l.name,
            l.range.unwrap_or_default()
        );
        std::process::exit(2);
    }
    std::fs::create_dir_all(&out).expect("create OUT_DIR");

    // Meshes, in world space at `time`.
    let mut meshes_json = Vec::new();
    let mut triangles = 0usize;
    for (i, (mesh, world)) in scene.meshes_at(time).into_iter().enumerate() {
        let normal_matrix = glam::Mat3::from_mat4(world).inverse().transpose();
        let mut obj = String::new();
        for p in &mesh.positions {
            let p = world.transform_point3(*p);
            writeln!(obj, "v {:?} {:?} {:?}", p.x, p.y, p.z).unwrap();
        }
        for n in &mesh.normals {
            let n = (normal_matrix * *n).normalize_or_zero();
            writeln!(obj, "vn {:?} {:?} {:?}", n.x, n.y, n.z).unwrap();
        }
        for t in mesh.indices.chunks_exact(3) {
            writeln!(
                obj,
                "f {0}//{0} {1}//{1} {2}//{2}",
                t[0] + 1,
                t[1] + 1,
                t[2] + 1
            )
            .unwrap();
        }
        triangles += mesh.indices.len() / 3;
        let file = format!("mesh_{i:03}.obj");
        std::fs::write(out.join(&file), obj).expect("write OBJ");
        let albedo = scene.materials[mesh.material].base_color;
        meshes_json.push(format!(
            "    {{\"file\": \"{file}\", \"name\": {:?}, \"albedo\": {}}}",
            mesh.name,
            v3(albedo)
        ));
    }

    let camera = match view.projection {
        Projection::Perspective { yfov, znear, .. } => format!(
            "{{\"type\": \"perspective\", \"position\": {}, \"forward\": {}, \"up\": {}, \"yfov_deg\": {:?}, \"znear\": {:?}}}",
            v3(view.position),
            v3(view.forward()),
            v3(view.up()),
            yfov.to_degrees(),
            znear
        ),
        Projection::Orthographic { .. } => {
            eprintln!("orthographic cameras are not supported by the validation script");
            std::process::exit(2)
        }
    };
    let lights: Vec<String> = scene.lights.iter().map(light_json).collect();

    // gibake reference renders.
    let rs = RayScene::build(&scene, time);
    let mut renders = Vec::new();
    let mut depths = vec![(Depth::Direct, "direct"), (Depth::OneBounce, "one_bounce")];
    if every {
        depths.push((Depth::Every, "every_bounce"));
    }
    for (depth, name) in depths {
        let settings = Settings {
            width: size,
            height: size,
            spp,
            time,
            depth,
            seed,
        };
        let t0 = Instant::now();
        let (img, stats) = render_view_with_stats(&rs, &view, &settings, &|_| {}).expect("render");
        let secs = t0.elapsed().as_secs_f64();
        let file = format!("gibake_{name}.exr");
        img.write_exr(&out.join(&file)).expect("write EXR");
        eprintln!(
            "gibake {name}: {size}×{size}, {spp} spp, {secs:.2} s, mean {}, {:.2} bounce rays a path, {} cut at the cap",
            img.mean(),
            stats.mean_bounces(),
            stats.capped
        );
        renders.push(format!(
            "    \"{name}\": {{\"file\": \"{file}\", \"seconds\": {secs:.3}, \"mean_bounces\": {:.4}, \"capped\": {}}}",
            stats.mean_bounces(),
            stats.capped
        ));
    }

    let threads = rayon::current_num_threads();
    let json = format!(
        "{{\n  \"source\": {:?},\n  \"width\": {size},\n  \"height\": {size},\n  \"spp\": {spp},\n  \"time\": {time:?},\n  \"triangles\": {triangles},\n  \"threads\": {threads},\n  \"camera\": {camera},\n  \"lights\": [\n{}\n  ],\n  \"meshes\": [\n{}\n  ],\n  \"gibake\": {{\n{}\n  }}\n}}\n",
        scene.source.display().to_string(),
        lights.join(",\n"),
        meshes_json.join(",\n"),
        renders.join(",\n")
    );
    std::fs::write(out.join("scene.json"), json).expect("write scene.json");
    eprintln!(
        "wrote {} ({triangles} triangles, {} lights)",
        out.display(),
        scene.lights.len()
    );
}

/// One light of `scene.json` (no range: refused before).
fn light_json(l: &Light) -> String {
    let body = match l.kind {
        LightKind::Directional => format!(
            "\"type\": \"directional\", \"direction\": {}, \"irradiance\": {}",
            v3(l.direction),
            v3(l.color)
        ),
        LightKind::Spot {
            inner_cone,
            outer_cone,
        } => format!(
            "\"type\": \"spot\", \"position\": {}, \"direction\": {}, \"intensity\": {}, \"inner_deg\": {:?}, \"outer_deg\": {:?}",
            v3(l.position),
            v3(l.direction),
            v3(l.color),
            inner_cone.to_degrees(),
            outer_cone.to_degrees()
        ),
        LightKind::Point => format!(
            "\"type\": \"point\", \"position\": {}, \"intensity\": {}",
            v3(l.position),
            v3(l.color)
        ),
    };
    format!("    {{\"name\": {:?}, {body}}}", l.name)
}
