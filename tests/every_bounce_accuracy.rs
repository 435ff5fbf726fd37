//! The default bake — the first bounce's VPLs and the later bounces'
//! (issue 50) — against the every-bounce reference (`gibake reference`'s
//! default, validated against Mitsuba 3: docs/reference.md), on real levels
//! made by other people (data/levels/), on seeded random scenes and on the
//! bundled scenes, at `--vpls 256` (the default) and a small image so that
//! CI can afford it. The full-size table is docs/method.md, "Every bounce",
//! from `eval_levels`.
//!
//! Per scene: `full`'s mean indirect light within ±8% of the every-bounce
//! reference's per channel (beyond three standard errors of the
//! reference's own mean; a level listed in [`KNOWN`] is held to the looser
//! bound written there, and says why), and, where the later bounces carry
//! light (the reference's every ÷ one bounce ratio over 1.1), the default
//! bake's blurred indirect error under the first bounce alone's against the
//! same reference: the later bounces make the picture better, not only the
//! mean. A level lit from outside (the town) leaves them out and keeps the
//! first bounce's figures. Where moving objects are large (the random
//! scenes' boxes, the bundled scenes' panels), the light they pass on after
//! the first bounce is not followed: those scenes are held to ±8% without
//! them, and with them only to being nearer the truth than the first
//! bounce alone (docs/method.md, "Moving objects and the later bounces").

use crate::common;

use gibake_eval::levels::{bundled_list, judge_level, read_specs};
use gibake_eval::{EvalSettings, IndirectEval, evaluate_if_judgeable, random_scene};

fn settings() -> EvalSettings {
    EvalSettings {
        size: 32,
        spp: 512,
        vpls: 256,
        ssaa: 2,
        blur: 1,
        naive: false,
        every_bounce: true,
        every_bounce_bake: true,
        ..Default::default()
    }
}

/// The default bound on the mean indirect bias against every bounce.
const BOUND: f32 = 0.08;

/// Levels held to a looser bound, and why (measured with `eval_levels
/// LEVEL --size 32 --spp 512 --ssaa 2 --vpls 256 --no-naive --blur 1`;
/// docs/method.md, "Every bounce", says more).
/// None since bake method revision 10 (session 30): the white arena, the
/// one level listed before (64 later VPLs over-lit it by 20%), is within
/// ±1% at 256 VPLs.
const KNOWN: &[(&str, f32, &str)] = &[];

fn bound_of(name: &str) -> f32 {
    KNOWN
        .iter()
        .find(|(n, _, _)| *n == name)
        .map_or(BOUND, |(_, b, why)| {
            eprintln!("{name}: known to fail ±{:.0}%: {why}", BOUND * 100.0);
            *b
        })
}

/// Checks `e`'s every-bounce figures; returns the failures.
fn check(e: &IndirectEval, bound: f32, failures: &mut Vec<String>) {
    eprintln!("{}", e.line());
    let Some(every) = &e.every else {
        failures.push(format!("{}: no every-bounce figures", e.name));
        return;
    };
    let Some(baked) = &every.baked else {
        failures.push(format!("{}: the default bake was not judged", e.name));
        return;
    };
    for c in 0..3 {
        if baked.full_bias[c].abs() > bound + 3.0 * every.ref_noise[c] {
            failures.push(format!(
                "{}: the default bake's mean indirect bias {:+.1}% (channel {c}) beyond ±{:.0}% \
                 of the every-bounce reference",
                e.name,
                100.0 * baked.full_bias[c],
                100.0 * bound
            ));
        }
    }
    let later_matters = every.ratio.iter().any(|r| *r > 1.1);
    if later_matters && baked.later_vpls > 0 && baked.full_err >= every.full_err {
        failures.push(format!(
            "{}: the later bounces do not improve the picture (error {:.3} with them, {:.3} \
             without, against every bounce)",
            e.name, baked.full_err, every.full_err
        ));
    }
    if !baked.full_err.is_finite() {
        failures.push(format!("{}: the error is not finite", e.name));
    }
}

/// Levels of data/levels/levels.json: the interiors the method handles, the
/// outdoor town (left out), the white arena and the city diorama (its
/// small triangles' later light, lost before bake method revision 10:
/// −17%), with the known failures in [`KNOWN`] (none now).
#[test]
fn the_default_bake_matches_every_bounce_on_real_levels() {
    let ctx = common::gpu();
    let list = bundled_list();
    let dir = list.parent().expect("data/levels").to_path_buf();
    let specs = read_specs(&list).expect("data/levels/levels.json");
    let s = settings();
    let mut failures = Vec::new();
    for name in [
        "living_room",
        "gallery",
        "japanese_room",
        "house",
        "town",
        "arena",
        "city",
    ] {
        let spec = specs
            .iter()
            .find(|l| l.name == name)
            .unwrap_or_else(|| panic!("{name} is not a bundled level"));
        let scene = spec.load(&dir).expect("the level loads");
        let (e, images) = judge_level(&ctx, &scene, name, &s).expect("judged");
        for img in [images.every_full.as_ref(), Some(&images.full)]
            .into_iter()
            .flatten()
        {
            if !img.all_finite() {
                failures.push(format!("{name}: a rendered image is not finite"));
            }
        }
        check(&e.indirect, bound_of(name), &mut failures);
        let baked = e.indirect.every.as_ref().and_then(|v| v.baked.as_ref());
        if name == "town" && baked.is_some_and(|b| b.later_vpls != 0) {
            failures.push("town: the later bounces were not left out".into());
        }
        if name != "town" && baked.is_some_and(|b| b.later_vpls == 0) {
            failures.push(format!("{name}: the later bounces were left out"));
        }
    }
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}

/// Seeded random scenes (crates/scenegen `random`: rooms, boxes and lights
/// nobody placed), and the bundled scenes, each judged twice: without its
/// moving objects (bake, frames and reference alike: the later bounces are
/// the static scene's, and there they are held to ±8%), and with them in
/// place, where the light the moving objects pass on after the first bounce
/// is not followed (docs/method.md, "Moving objects and the later
/// bounces": up to 20% of the indirect light in these scenes, whose moving
/// boxes and panels are large): there the default bake must only be nearer
/// the every-bounce reference than the first bounce alone.
#[test]
fn the_default_bake_matches_every_bounce_on_random_and_bundled_scenes() {
    let ctx = common::gpu();
    let s = settings();
    let mut failures = Vec::new();
    let mut scenes = Vec::new();
    let mut seed = 0u64;
    while scenes.len() < 4 && seed < 12 {
        let (scene, name) = random_scene(seed);
        seed += 1;
        scenes.push((scene, name));
    }
    for name in ["corner_bunny", "occluded", "lamps"] {
        let scene = gibake_scene::load(&common::data(&format!("{name}.glb")), &Default::default())
            .expect("loads");
        scenes.push((scene, name.to_string()));
    }
    let mut judged = 0;
    for (scene, name) in &scenes {
        let still = gibake_bake::static_only(scene);
        let Some(e) =
            evaluate_if_judgeable(&ctx, &still, &format!("{name} (static)"), &s, false, 0.03)
                .unwrap()
        else {
            continue;
        };
        check(&e, BOUND, &mut failures);
        judged += 1;
        if scene.dynamic_objects.is_empty() {
            continue;
        }
        let e = gibake_eval::evaluate(&ctx, scene, name, &s, false).unwrap();
        eprintln!("{}", e.line());
        let every = e.every.as_ref().expect("every-bounce figures");
        let baked = every.baked.as_ref().expect("the default bake judged");
        let worst = |b: &[f32; 3]| b.iter().fold(0f32, |a, x| a.max(x.abs()));
        if !(baked.full_err < every.full_err && worst(&baked.full_bias) < worst(&every.full_bias)) {
            failures.push(format!(
                "{name} (moving objects in place): the default bake (bias {:?}, error {:.3}) is not \
                 nearer every bounce than the first bounce alone (bias {:?}, error {:.3})",
                baked.full_bias, baked.full_err, every.full_bias, every.full_err
            ));
        }
    }
    assert!(judged >= 6, "too few judgeable scenes: {judged}");
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}
