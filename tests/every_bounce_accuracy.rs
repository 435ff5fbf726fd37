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
//! first bounce's figures.

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
const KNOWN: &[(&str, f32, &str)] = &[(
    "arena",
    0.30,
    "albedo 1 everywhere (glTF's default material), the later bounces carry 20× the first: \
     64 later VPLs over-light their surfels' own light (+20% here; 256 later VPLs give +4% in \
     the CPU twin)",
)];

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
/// outdoor town (left out) and the known failures, each named above.
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
/// nobody placed), and the bundled scenes.
#[test]
fn the_default_bake_matches_every_bounce_on_random_and_bundled_scenes() {
    let ctx = common::gpu();
    let s = settings();
    let mut failures = Vec::new();
    let (mut judged, mut seed) = (0, 0u64);
    while judged < 4 && seed < 12 {
        let (scene, name) = random_scene(seed);
        seed += 1;
        if let Some(e) = evaluate_if_judgeable(&ctx, &scene, &name, &s, false, 0.03).unwrap() {
            check(&e, BOUND, &mut failures);
            judged += 1;
        }
    }
    assert_eq!(judged, 4, "too few judgeable seeds");
    for name in ["corner_bunny", "occluded", "lamps"] {
        let scene = gibake_scene::load(&common::data(&format!("{name}.glb")), &Default::default())
            .expect("loads");
        let e = gibake_eval::evaluate(&ctx, &scene, name, &s, false).unwrap();
        check(&e, BOUND, &mut failures);
    }
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}
