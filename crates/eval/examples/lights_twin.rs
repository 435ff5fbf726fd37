//! Every light's VPLs judged on the CPU against the reference
//! (`gibake_eval::lights::judge`: the bake's front part for every light,
//! the runtime's transport on the CPU with exact visibility, the
//! reference's one-bounce indirect light from every light; static part).
//!
//! ```text
//! cargo run --release -p gibake-eval --example lights_twin -- SCENE... [--vpls N] [--size S]
//! ```
//!
//! `SCENE`: a glTF file, or a level of data/levels/levels.json by name
//! (`city`: its sun, camera and moving objects as `eval_levels` loads
//! them), or `random:SEED` (`gibake_scenegen::random_lights`,
//! the seeded multi-light generator), or `random:A..B` (seeds `A` to `B−1`;
//! a summary line over them follows).
//!
//! `--keep-negligible`: keep the views whose light is negligible
//! (`gibake_bake::lights::NEGLIGIBLE_VPL_FRACTION`), to see what leaving
//! them out changes.
//!
//! `--look-at EX,EY,EZ,TX,TY,TZ`: a 60° camera at the eye looking at the
//! target (for a level without a camera).
//!
//! `--rsm N`: RSM resolution per view (default 512, the bake's).
//!
//! `--side N`: the reference's samples per receiver, `N²` (default 32).
//!
//! `--only K`: light `K` alone (where a scene's error comes from).
//!
//! `GIBAKE_NO_RANGE=1`: the lights without their glTF ranges (a
//! diagnostic: what the range changes).
//!
//! `--split`: also where the bias comes from, without visibility: the
//! clustered VPLs' transport against every texel of theirs as its own
//! small disk, and what one visibility point per VPL costs against the
//! reference's visible share (`gibake_eval::lights::Split`; every texel
//! against every receiver, seconds to minutes). Its far-field line also
//! draws each VPL from its map origin (the rule before session 10) and as
//! its level-1 near-field nodes (`--split-level 2` or `3`: level 2 or 3).
//!
//! `--every-bounce`: also the bias against the every-bounce reference (one
//! every-bounce path from each secondary hit) and the every-bounce ÷
//! one-bounce indirect ratio.
//!
//! `--equal-split`: each light gets `N / lights` VPLs over its own views
//! (the alternative to one budget spread by the light's bounce).
//!
//! Prints per scene: the lights (kind, VPLs each), the views left out
//! because they reflect nothing, the VPLs dropped because they see
//! nothing, the mean indirect bias per channel (Σ twin / Σ reference − 1)
//! and the relative RMS error of the 3×3-blurred indirect image.

use gibake_eval::lights::Budget;
use gibake_scene::{LightKind, LoadOptions};
use glam::DVec3;

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let (mut vpls, mut size) = (664u32, 40u32);
    let mut equal = false;
    let mut keep_negligible = false;
    let mut split = false;
    let mut every_bounce = false;
    let mut split_level = 1u32;
    let mut only: Option<usize> = None;
    let mut rsm = 512u32;
    let mut side = 32u32;
    let mut camera = gibake_scene::CameraChoice::First;
    let mut files = Vec::new();
    let mut i = 0;
    while i < args.len() {
        match args[i].as_str() {
            "--vpls" => {
                vpls = args[i + 1].parse().expect("--vpls N");
                i += 1
            }
            "--size" => {
                size = args[i + 1].parse().expect("--size S");
                i += 1
            }
            "--equal-split" => equal = true,
            "--keep-negligible" => keep_negligible = true,
            "--split" => split = true,
            "--every-bounce" => every_bounce = true,
            "--split-level" => {
                split_level = args[i + 1].parse().expect("--split-level 1|2|3");
                assert!((1..=3).contains(&split_level), "--split-level 1|2|3");
                i += 1
            }
            "--look-at" => {
                let v: Vec<f32> = args[i + 1]
                    .split(',')
                    .map(|x| x.parse().expect("--look-at EX,EY,EZ,TX,TY,TZ"))
                    .collect();
                assert_eq!(v.len(), 6, "--look-at EX,EY,EZ,TX,TY,TZ");
                camera = gibake_scene::CameraChoice::LookAt {
                    eye: glam::Vec3::new(v[0], v[1], v[2]),
                    target: glam::Vec3::new(v[3], v[4], v[5]),
                    yfov_deg: 60.0,
                };
                i += 1
            }
            "--side" => {
                side = args[i + 1].parse().expect("--side N");
                i += 1
            }
            "--rsm" => {
                rsm = args[i + 1].parse().expect("--rsm N");
                i += 1
            }
            "--only" => {
                only = Some(args[i + 1].parse().expect("--only K"));
                i += 1
            }
            s => files.push(s.to_string()),
        }
        i += 1;
    }
    if files.is_empty() {
        eprintln!("usage: lights_twin SCENE.glb... [--vpls N] [--size S]");
        std::process::exit(2);
    }
    let opts = LoadOptions {
        camera,
        ..Default::default()
    };
    for f in files {
        if let Some(seeds) = f.strip_prefix("random:") {
            let (a, b) = match seeds.split_once("..") {
                Some((a, b)) => (a.parse::<u64>().expect("A"), b.parse::<u64>().expect("B")),
                None => {
                    let s = seeds.parse::<u64>().expect("random:SEED");
                    (s, s + 1)
                }
            };
            let mut all = Vec::new();
            for seed in a..b {
                let (bytes, info) = gibake_scenegen::random_lights(seed, &Default::default());
                let name = format!("random:{seed} ({info})");
                let scene = gibake_scene::load_from_slice(
                    &bytes,
                    std::path::Path::new(&format!("random_lights_{seed}.glb")),
                    &opts,
                )
                .unwrap_or_else(|e| panic!("{name}: {e}"));
                let scene = only_light(scene, only);
                all.push(judge(
                    &name,
                    &scene,
                    (vpls, rsm, side),
                    size,
                    equal,
                    (keep_negligible, split.then_some(split_level), every_bounce),
                ));
            }
            if all.len() > 1 {
                let worst = all
                    .iter()
                    .map(|(b, _)| b.abs().max_element())
                    .fold(0.0f64, f64::max);
                let within = all
                    .iter()
                    .filter(|(b, _)| b.abs().max_element() <= 0.07)
                    .count();
                let mean_err = all.iter().map(|(_, e)| e).sum::<f64>() / all.len() as f64;
                println!(
                    "random:{a}..{b}: {within}/{} scenes within ±7% on every channel, worst |bias| {:.1}%, mean blurred error {mean_err:.3}",
                    all.len(),
                    worst * 100.0
                );
            }
        } else {
            let list = gibake_eval::levels::bundled_list();
            let levels = gibake_eval::levels::read_specs(&list).expect("data/levels/levels.json");
            let scene = if let Some(l) = levels.iter().find(|l| l.name == f) {
                // A real level of levels.json, its sun, camera and moving
                // objects as eval_levels loads them.
                l.load(list.parent().expect("a folder"))
                    .unwrap_or_else(|e| panic!("{f}: {e}"))
            } else {
                gibake_scene::load(std::path::Path::new(&f), &opts)
                    .unwrap_or_else(|e| panic!("{f}: {e}"))
            };
            let scene = only_light(scene, only);
            judge(
                &f,
                &scene,
                (vpls, rsm, side),
                size,
                equal,
                (keep_negligible, split.then_some(split_level), every_bounce),
            );
        }
    }
}

/// The scene with light `k` alone (`--only K`), or as it is.
fn only_light(mut scene: gibake_scene::Scene, only: Option<usize>) -> gibake_scene::Scene {
    if let Some(k) = only {
        scene.lights = vec![scene.lights[k].clone()];
    }
    if std::env::var_os("GIBAKE_NO_RANGE").is_some() {
        for l in &mut scene.lights {
            l.range = None;
        }
    }
    scene
}

/// Prints the scene's figures; returns (bias per channel, blurred error).
fn judge(
    name: &str,
    scene: &gibake_scene::Scene,
    (vpls, rsm_size, side): (u32, u32, u32),
    size: u32,
    equal: bool,
    (keep_negligible, split, every_bounce): (bool, Option<u32>, bool),
) -> (DVec3, f64) {
    let budget = if equal {
        Budget::EqualSplit
    } else {
        Budget::Joint
    };
    let j = gibake_eval::lights::judge(
        scene,
        &gibake_eval::lights::JudgeSettings {
            vpls,
            rsm_size,
            size,
            side,
            budget,
            keep_negligible,
            split,
            every_bounce,
        },
    );
    println!(
        "{name}: {} lights, {} VPLs ({:.1} s), {} views reflect nothing, {} negligible, {} VPLs see nothing",
        scene.lights.len(),
        j.every.clusters.vpl_count(),
        j.bake_seconds,
        j.every.unlit_views,
        j.every.negligible_views,
        j.every.dropped_vpls
    );
    for (l, n) in scene.lights.iter().zip(&j.per_light) {
        let kind = match l.kind {
            LightKind::Spot { .. } => "spot",
            LightKind::Directional => "directional",
            LightKind::Point => "point",
        };
        let range = l.range.map_or(String::new(), |r| format!(", range {r:.3}"));
        println!("  {:<24} {kind:<11} {n:>5} VPLs{range}", l.name);
    }
    println!(
        "  indirect bias {:+.1}/{:+.1}/{:+.1}% (reference noise ±{:.1}%), blurred rel RMS error {:.3}",
        j.bias.x * 100.0,
        j.bias.y * 100.0,
        j.bias.z * 100.0,
        j.bias_sigma.max_element() * 100.0,
        j.blurred_error
    );
    if let Some(e) = j.every_bounce {
        println!(
            "  vs every bounce: indirect ×{:.2}/{:.2}/{:.2} of one bounce, bias {:+.1}/{:+.1}/{:+.1}% (reference noise ±{:.1}%, {:.1} bounces a path from the secondary hits)",
            e.ratio.x,
            e.ratio.y,
            e.ratio.z,
            e.bias.x * 100.0,
            e.bias.y * 100.0,
            e.bias.z * 100.0,
            e.bias_sigma.max_element() * 100.0,
            e.stats.mean_bounces()
        );
    }
    if let Some(sp) = j.split {
        println!(
            "  split (no visibility, channels summed): clustered / texels {:+.1}% (transport), texels of kept VPLs / all {:+.1}%, visibility from one point per VPL {:+.1}%",
            sp.transport() * 100.0,
            (sp.texels / sp.all_texels - 1.0) * 100.0,
            sp.visibility() * 100.0
        );
        let near_t = sp.texels - sp.far_texels;
        println!(
            "    far field: {:.1}% of the texels' light, clustered / texels {:+.1}% (from the map origins {:+.1}%, as the level-{} nodes {:+.1}%); near field: clustered / texels {:+.1}%",
            sp.far_texels / sp.texels * 100.0,
            (sp.far_clustered / sp.far_texels - 1.0) * 100.0,
            (sp.far_from_origin / sp.far_texels - 1.0) * 100.0,
            split.unwrap_or(1),
            (sp.far_nodes / sp.far_texels - 1.0) * 100.0,
            ((sp.clustered - sp.far_clustered) / near_t - 1.0) * 100.0
        );
    }
    (j.bias, j.blurred_error)
}
