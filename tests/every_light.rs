//! Every light's VPLs against the reference (issue 19), on the CPU: the
//! bake's front part for every light and the runtime's transport with exact
//! visibility (`gibake_eval::lights::judge`), on the bundled multi-light
//! scene and on the seeded random multi-light generator's first seeds
//! (nothing chosen: seeds 0–3). The runtime does not shade several lights
//! yet; this judges what the bake gives it.

use gibake_eval::lights::{Budget, judge};
use gibake_scene::{LoadOptions, Scene};

const VPLS: u32 = 664;
const SIZE: u32 = 24;
const SIDE: u32 = 16;

fn every_light(bytes: &[u8], name: &str) -> Scene {
    gibake_scene::load_from_slice(
        bytes,
        std::path::Path::new(name),
        &LoadOptions {
            all_lights: true,
            ..Default::default()
        },
    )
    .unwrap_or_else(|e| panic!("{name}: {e}"))
}

fn scenes() -> Vec<(String, Scene)> {
    let mut out = vec![(
        "lamps".to_string(),
        every_light(&gibake_scenegen::lamps(&Default::default()), "lamps.glb"),
    )];
    for seed in 0..4u64 {
        let (bytes, info) = gibake_scenegen::random_lights(seed, &Default::default());
        out.push((
            format!("random_lights {seed} ({info})"),
            every_light(&bytes, &format!("random_lights_{seed}.glb")),
        ));
    }
    out
}

/// Known failures: (scene index in [`scenes`], the bound it is held to,
/// why). Random seed 1 is a sun and seven lamps over open ground: each
/// light alone with 664 VPLs is within ±2.3%, but the one budget of 664
/// gives each ~100, and at ~100 VPLs the sun alone is −6.3/−8.0/−6.7%
/// (`lights_twin random:1 --only 0 --vpls 110`): the clustering's bias at
/// a low VPL count per light, not the sharing (an equal split is worse).
const KNOWN_FAILURES: &[(usize, f64, &str)] = &[(2, 0.10, "664 VPLs shared by 8 lights")];

/// Mean indirect within ±7% per channel on every scene (known failures
/// within their bound); one budget spread by the lights' bounce no worse in
/// total than an equal split; and what is left out was not needed: views
/// whose light is negligible keep no VPL, and keeping them changes the
/// mean indirect by under 0.5% of itself.
#[test]
fn every_light_indirect_is_within_seven_percent() {
    let (mut joint_err, mut equal_err) = (0.0, 0.0);
    let mut failures = Vec::new();
    let mut left_out = 0;
    for (k, (name, scene)) in scenes().into_iter().enumerate() {
        let j = judge(&scene, VPLS, SIZE, SIDE, Budget::Joint, false);
        let e = judge(&scene, VPLS, SIZE, SIDE, Budget::EqualSplit, false);
        println!(
            "{name}: {} lights, {} VPLs {:?}; bias {:+.1}/{:+.1}/{:+.1}%, error {:.3} (equal split {:.3})",
            scene.lights.len(),
            j.every.clusters.vpl_count(),
            j.per_light,
            j.bias.x * 100.0,
            j.bias.y * 100.0,
            j.bias.z * 100.0,
            j.blurred_error,
            e.blurred_error
        );
        assert!(
            j.reference_sum.min_element() > 0.0,
            "{name}: no bounce light seen"
        );
        assert!(j.bias.is_finite() && j.blurred_error.is_finite(), "{name}");
        let (bound, why) = KNOWN_FAILURES
            .iter()
            .find(|f| f.0 == k)
            .map_or((0.07, ""), |f| (f.1, f.2));
        if j.bias.abs().max_element() > bound {
            failures.push(format!("{name}: bias {:.3?} beyond ±{bound} {why}", j.bias));
        }
        joint_err += j.blurred_error;
        equal_err += e.blurred_error;
        if j.every.negligible_views > 0 {
            left_out += j.every.negligible_views;
            let kept = judge(&scene, VPLS, SIZE, SIDE, Budget::Joint, true);
            let change = (j.bias - kept.bias).abs().max_element();
            assert!(
                change < 0.005,
                "{name}: leaving {} views out moved the bias by {:.2}%",
                j.every.negligible_views,
                change * 100.0
            );
        }
    }
    assert!(failures.is_empty(), "{failures:#?}");
    assert!(
        joint_err <= equal_err,
        "one budget: Σ error {joint_err:.3}, an equal split per light: {equal_err:.3}"
    );
    assert!(
        left_out > 0,
        "no negligible view left out: the check above checked nothing"
    );
}
