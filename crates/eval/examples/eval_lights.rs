//! Every light at frame level: bakes each scene with all its lights (asset
//! format 4), renders `direct`, `full`, `rsm` and `naive` with the runtime
//! and judges them against the CPU reference lit by every light
//! (`gibake_eval::levels::judge_level`: image and direct rel MSE, indirect
//! bias per channel, full's blurred indirect error against rsm's, naive
//! against full, FLIP), one bounce and every bounce (`vs one bounce: …`,
//! `vs every bounce ×R/G/B of one: …`; `--one-bounce-only` leaves the
//! every-bounce reference out; `--no-second-maps` renders the bakes as a
//! format 4.6 asset did, without the VPLs' second origins and maps).
//!
//! ```text
//! cargo run --release -p gibake-eval --example eval_lights -- SCENE... [--size N] [--spp N] [--vpls N] [--blur N] [--ssaa N] [--near-field-descent N] [--look-at EX,EY,EZ,TX,TY,TZ] [--no-light-bounce] [--balls-under-lamps R] [--out DIR] [--no-naive] [--one-bounce-only] [--no-second-maps]
//! ```
//!
//! `--no-naive` leaves out the `naive` render (every VPL map re-rendered:
//! 90% of the time on lavapipe) and its naive~full figure.
//!
//! `--balls-under-lamps R` adds a moving ball of radius `R` under each
//! point and spot light (`gibake_eval::moving::balls_under_lamps`).
//!
//! `--no-light-bounce` removes the other lights' view RSMs from the asset
//! (format 4.1) before rendering: their bounce off moving objects is not
//! computed, as with a 4.0 asset.
//!
//! `--ssaa N` (default 4): N² samples per pixel, as eval_levels (its docs
//! say why 2 is too few on a small image).
//!
//! `SCENE`: a glTF file (loaded with every light), or
//! `random:SEED` / `random:A..B` (`gibake_scenegen::random_lights`). With
//! `--out DIR`, writes `reference | full | rsm | error` (NAME.png) and the
//! same for the indirect light alone (NAME_indirect.png).
//!
//! `DUMP_EXR=1` with `--out DIR`: also the reference's, `full`'s and
//! `rsm`'s indirect images and the runtime's direct light as EXR
//! (`NAME_ref_ind.exr`, `NAME_full_ind.exr`, `NAME_rsm_ind.exr`,
//! `NAME_direct.exr`) and the reference's direct light
//! (`NAME_ref_direct.exr`), for looking at where the indirect light is
//! lost or the direct light's shadows leak.

use gibake_scene::LoadOptions;

fn main() {
    let mut s = gibake_eval::EvalSettings {
        size: 96,
        spp: 512,
        blur: 4,
        ssaa: 4,
        every_bounce: true,
        every_bounce_bake: true,
        ..Default::default()
    };
    let args: Vec<String> = std::env::args().skip(1).collect();
    let mut it = args.iter();
    let mut scenes = Vec::new();
    let mut out = None;
    let mut camera = gibake_scene::CameraChoice::First;
    let mut balls = None;
    while let Some(a) = it.next() {
        let mut num = || {
            it.next()
                .expect("a value")
                .parse::<u32>()
                .expect("a number")
        };
        match a.as_str() {
            "--size" => s.size = num(),
            "--spp" => s.spp = num(),
            "--vpls" => s.vpls = num(),
            "--blur" => s.blur = num(),
            "--rsm" => s.rsm_size = num(),
            "--ssaa" => s.ssaa = num(),
            "--near-field-descent" => s.near_field_descent = num(),
            "--look-at" => {
                let v: Vec<f32> = it
                    .next()
                    .expect("--look-at EX,EY,EZ,TX,TY,TZ")
                    .split(',')
                    .map(|x| x.parse().expect("--look-at EX,EY,EZ,TX,TY,TZ"))
                    .collect();
                assert_eq!(v.len(), 6, "--look-at EX,EY,EZ,TX,TY,TZ");
                camera = gibake_scene::CameraChoice::LookAt {
                    eye: glam::Vec3::new(v[0], v[1], v[2]),
                    target: glam::Vec3::new(v[3], v[4], v[5]),
                    yfov_deg: 60.0,
                };
            }
            "--no-light-bounce" => s.light_bounce = false,
            "--balls-under-lamps" => {
                balls = Some(
                    it.next()
                        .expect("--balls-under-lamps R")
                        .parse::<f32>()
                        .expect("a radius"),
                )
            }
            "--out" => out = Some(std::path::PathBuf::from(it.next().expect("a directory"))),
            "--no-naive" => s.naive = false,
            "--no-second-maps" => s.second_maps = false,
            "--one-bounce-only" => {
                s.every_bounce = false;
                s.every_bounce_bake = false;
            }
            _ => scenes.push(a.clone()),
        }
    }
    if scenes.is_empty() {
        eprintln!(
            "usage: eval_lights SCENE... [--size N] [--spp N] [--vpls N] [--out DIR] [--no-naive]"
        );
        std::process::exit(2);
    }
    let opts = LoadOptions {
        camera,
        ..Default::default()
    };
    let ctx = gibake_gpu::GpuContext::new(&Default::default()).expect("a GPU adapter");
    let mut loaded = Vec::new();
    for a in &scenes {
        if let Some(seeds) = a.strip_prefix("random:") {
            let (lo, hi) = match seeds.split_once("..") {
                Some((x, y)) => (x.parse::<u64>().expect("A"), y.parse::<u64>().expect("B")),
                None => {
                    let k = seeds.parse::<u64>().expect("random:SEED");
                    (k, k + 1)
                }
            };
            for seed in lo..hi {
                let (bytes, info) = gibake_scenegen::random_lights(seed, &Default::default());
                let path = std::path::PathBuf::from(format!("random_lights_{seed}.glb"));
                let scene = gibake_scene::load_from_slice(&bytes, &path, &opts)
                    .unwrap_or_else(|e| panic!("random:{seed}: {e}"));
                loaded.push((format!("random:{seed} ({info})"), scene));
            }
        } else {
            let path = std::path::Path::new(a);
            let scene = gibake_scene::load(path, &opts).unwrap_or_else(|e| panic!("{a}: {e}"));
            loaded.push((a.clone(), scene));
        }
    }
    for (name, mut scene) in loaded {
        if let Some(r) = balls {
            for (i, b) in gibake_eval::moving::balls_under_lamps(&scene, r, s.time)
                .iter()
                .enumerate()
            {
                gibake_eval::levels::add_ball(&mut scene, &format!("ball {i}"), b);
            }
        }
        let kinds: Vec<String> = scene
            .lights
            .iter()
            .map(|l| format!("{:?}", l.kind).chars().take(5).collect())
            .collect();
        let t = std::time::Instant::now();
        match gibake_eval::levels::judge_level(&ctx, &scene, &name, &s) {
            Ok((e, images)) => {
                println!(
                    "{name} [{} lights: {}] {} ({:.0} s)",
                    scene.lights.len(),
                    kinds.join(" "),
                    e.line(),
                    t.elapsed().as_secs_f64()
                );
                if let Some(dir) = &out {
                    std::fs::create_dir_all(dir).expect("--out directory");
                    let file: String = name
                        .split_whitespace()
                        .next()
                        .unwrap_or("scene")
                        .chars()
                        .map(|c| if c.is_alphanumeric() { c } else { '_' })
                        .collect();
                    gibake_eval::levels::write_panel(&images, &dir.join(format!("{file}.png")))
                        .expect("write panel");
                    gibake_eval::levels::write_indirect_panel(
                        &images,
                        &dir.join(format!("{file}_indirect.png")),
                    )
                    .expect("write panel");
                    if std::env::var("DUMP_EXR").is_ok() {
                        gibake_eval::levels::write_exrs(&images, dir, &file).expect("write EXR");
                    }
                }
            }
            Err(e) => println!("{name}: {e}"),
        }
    }
}
