//! What moving objects change in a level's indirect light, runtime against
//! the reference, on the pixels that show the static level, with the
//! reference's noise cancelled by correlated sampling
//! (`gibake_eval::moving::moving_effect`).
//!
//! ```text
//! cargo run --release -p gibake-eval --example moving_effect -- SCENE [--ball X,Y,Z,R,r,g,b]... [--balls-under-lamps R] [--size N] [--spp N] [--vpls N] [--time T] [--out FILE.png] [--max-dynamic-vpls N]
//! ```
//!
//! `SCENE`: a glTF file, loaded with every light (`FILE.glb:K`: light `K`
//! alone), or `random:SEED` (`gibake_scenegen::random_lights`, with its own
//! moving objects). `--ball` adds a moving ball (centre, radius, albedo).
//! `--balls-under-lamps R` adds one ball of radius `R` resting on whatever
//! is below each point and spot light (a ray cast straight down), albedos
//! red, green, grey in turn: moving props where a level's lamps light them,
//! placed by a rule, not by hand. `--out FILE.png` writes reference |
//! runtime | without view RSMs | 4·|runtime − reference| of the changes
//! (at the reference's exposure) and the three changes as linear EXRs
//! beside it (`FILE.reference.exr`, `FILE.runtime.exr`,
//! `FILE.without.exr`).

use gibake_eval::levels::{LevelBall, add_ball};

fn main() {
    let mut s = gibake_eval::EvalSettings {
        size: 48,
        spp: 256,
        ..Default::default()
    };
    let args: Vec<String> = std::env::args().skip(1).collect();
    let mut it = args.iter();
    let mut scene_arg = None;
    let mut balls = Vec::new();
    let mut under_lamps = None;
    let mut out = None;
    while let Some(a) = it.next() {
        let mut value = || it.next().expect("a value").clone();
        match a.as_str() {
            "--size" => s.size = value().parse().expect("--size N"),
            "--spp" => s.spp = value().parse().expect("--spp N"),
            "--vpls" => s.vpls = value().parse().expect("--vpls N"),
            "--out" => out = Some(std::path::PathBuf::from(value())),
            "--time" => s.time = value().parse().expect("--time T"),
            "--max-dynamic-vpls" => {
                s.max_dynamic_vpls = value().parse().expect("--max-dynamic-vpls N")
            }
            "--balls-under-lamps" => {
                under_lamps = Some(value().parse::<f32>().expect("--balls-under-lamps R"))
            }
            "--ball" => {
                let v: Vec<f32> = value()
                    .split(',')
                    .map(|x| x.parse().expect("--ball X,Y,Z,R,r,g,b"))
                    .collect();
                assert_eq!(v.len(), 7, "--ball X,Y,Z,R,r,g,b");
                balls.push(LevelBall {
                    center: [v[0], v[1], v[2]],
                    radius: v[3],
                    albedo: [v[4], v[5], v[6]],
                });
            }
            _ => scene_arg = Some(a.clone()),
        }
    }
    let Some(arg) = scene_arg else {
        eprintln!("usage: moving_effect SCENE [--ball X,Y,Z,R,r,g,b]... [--balls-under-lamps R]");
        std::process::exit(2);
    };
    let mut scene = if let Some(seed) = arg.strip_prefix("random:") {
        let seed: u64 = seed.parse().expect("random:SEED");
        let (bytes, _) = gibake_scenegen::random_lights(seed, &Default::default());
        gibake_scene::load_from_slice(
            &bytes,
            std::path::Path::new("random_lights.glb"),
            &gibake_scene::LoadOptions::default(),
        )
        .expect("the random scene loads")
    } else {
        gibake_eval::load_gltf_lights(&arg).expect("SCENE: a glTF file or random:SEED")
    };
    if let Some(r) = under_lamps {
        balls.extend(gibake_eval::moving::balls_under_lamps(&scene, r, s.time));
    }
    for (i, b) in balls.iter().enumerate() {
        println!(
            "ball {i}: centre {:?}, radius {}, albedo {:?}",
            b.center, b.radius, b.albedo
        );
        add_ball(&mut scene, &format!("ball {i}"), b);
    }
    if scene.dynamic_objects.is_empty() {
        eprintln!("{arg}: no moving objects (give --ball or --balls-under-lamps)");
        std::process::exit(2);
    }
    let ctx = gibake_gpu::GpuContext::new(&Default::default()).expect("a GPU adapter");
    let t = std::time::Instant::now();
    let e = gibake_eval::moving::moving_effect(&ctx, &scene, &s).expect("measured");
    println!(
        "{arg} ({} lights, {} moving objects, {}², {} spp): {} ({:.0} s)",
        scene.lights.len(),
        scene.dynamic_objects.len(),
        s.size,
        s.spp,
        e.line(),
        t.elapsed().as_secs_f64()
    );
    if let Some(path) = out {
        let [r, ours, without] = &e.images;
        gibake_eval::levels::write_row(r, ours, without, &path).expect("--out FILE.png");
        for (img, what) in [(r, "reference"), (ours, "runtime"), (without, "without")] {
            img.write_exr(&path.with_extension(format!("{what}.exr")))
                .expect("--out");
        }
        println!(
            "wrote {} (reference | runtime | without view RSMs | 4·|runtime − reference|)",
            path.display()
        );
    }
}
