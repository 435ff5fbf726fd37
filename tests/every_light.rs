//! Every light's VPLs against the reference (issue 19), on the CPU: the
//! bake's front part for every light and the runtime's transport with exact
//! visibility (`gibake_eval::lights::judge`), on the bundled multi-light
//! scene, on the seeded random multi-light generator's first seeds (nothing
//! chosen: seeds 0–3) and on two real levels other people made with their
//! own lights (data/lights/: a Blenvy demo level, a sun, a spot and three
//! points; a game's store, 97 spots). This judges what the bake gives the
//! runtime, without a frame's other errors; the frame itself is
//! `tests/every_light_frame.rs`.

use gibake_eval::lights::{Budget, JudgeSettings, judge};
use gibake_scene::{CameraChoice, LoadOptions, Scene};

/// 664 VPLs in all; RSMs of the bake's default 512² per view and 32²
/// reference samples per receiver, except the 97-spot store (`lights >
/// 16`): 256² RSMs and 16² samples (a quarter of the rays each: its 97
/// views and 97 shadow rays per sample take minutes on CI's two cores at
/// full settings); 24² receivers.
fn settings(scene: &Scene, budget: Budget, keep_negligible: bool) -> JudgeSettings {
    let many = scene.lights.len() > 16;
    JudgeSettings {
        vpls: 664,
        rsm_size: if many { 256 } else { 512 },
        size: 24,
        side: if many { 16 } else { 32 },
        budget,
        keep_negligible,
        split: None,
        every_bounce: false,
    }
}

fn options() -> LoadOptions {
    LoadOptions::default()
}

fn every_light(bytes: &[u8], name: &str) -> Scene {
    gibake_scene::load_from_slice(bytes, std::path::Path::new(name), &options())
        .unwrap_or_else(|e| panic!("{name}: {e}"))
}

/// A real level of data/lights/ with every light.
fn level(path: &str, camera: CameraChoice) -> Scene {
    let p = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("..")
        .join(path);
    gibake_scene::load(
        &p,
        &LoadOptions {
            camera,
            ..options()
        },
    )
    .unwrap_or_else(|e| panic!("{path}: {e}"))
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
    out.push((
        "blenvy_start_level".into(),
        level(
            "data/lights/blenvy_start_level/StartLevel.glb",
            CameraChoice::First,
        ),
    ));
    // No camera in the file: the game's player start (data/lights/README.md).
    out.push((
        "pyraxia_store (97 spots)".into(),
        level(
            "data/lights/pyraxia_store/Store.gltf",
            CameraChoice::LookAt {
                eye: glam::Vec3::new(0.0, 3.0, 0.0),
                target: glam::Vec3::new(10.0, 0.0, 0.0),
                yfov_deg: 60.0,
            },
        ),
    ));
    out
}

/// Known failures: (scene index in [`scenes`], the bound it is held to,
/// why). None since session 16 (the finest near-field nodes' light not
/// map-tested near them, docs/method.md "Finest nodes near their
/// receiver"): random seed 1
/// (a sun and seven lamps over open ground, ~100 VPLs a light) was held
/// to ±10% and measures −1.7/−6.8/−4.0% here (−4.7/−7.9/−6.0% before);
/// the Blenvy level (a sun over a 94 m ground plane, four lamps) was held
/// to ±20% for the crease where an icosphere meets the ground at this
/// test's 24² receivers and measures +0.8/−1.2/+0.9%, as it did before
/// this change: it had been within ±7% here already.
const KNOWN_FAILURES: &[(usize, f64, &str)] = &[];

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
        let j = judge(&scene, &settings(&scene, Budget::Joint, false));
        // The equal split is compared where it is cheap (its own front part
        // again): up to 16 lights, not the 97-spot store.
        let e = (scene.lights.len() <= 16)
            .then(|| judge(&scene, &settings(&scene, Budget::EqualSplit, false)));
        let e_err = e.as_ref().map_or(f64::NAN, |e| e.blurred_error);
        println!(
            "{name}: {} lights, {} VPLs {:?}; bias {:+.1}/{:+.1}/{:+.1}% (reference noise ±{:.1}%), error {:.3} (equal split {:.3})",
            scene.lights.len(),
            j.every.clusters.vpl_count(),
            j.per_light,
            j.bias.x * 100.0,
            j.bias.y * 100.0,
            j.bias.z * 100.0,
            j.bias_sigma.max_element() * 100.0,
            j.blurred_error,
            e_err
        );
        assert!(
            j.reference_sum.min_element() > 0.0,
            "{name}: no bounce light seen"
        );
        assert!(j.bias.is_finite() && j.blurred_error.is_finite(), "{name}");
        // The judge itself must be sharper than the ±7% it judges.
        assert!(
            j.bias_sigma.max_element() < 0.03,
            "{name}: the reference's noise ±{:.1}% is too large to judge",
            j.bias_sigma.max_element() * 100.0
        );
        let (bound, why) = KNOWN_FAILURES
            .iter()
            .find(|f| f.0 == k)
            .map_or((0.07, ""), |f| (f.1, f.2));
        if j.bias.abs().max_element() > bound {
            failures.push(format!("{name}: bias {:.3?} beyond ±{bound} {why}", j.bias));
        }
        if e.is_some() {
            joint_err += j.blurred_error;
            equal_err += e_err;
        }
        if j.every.negligible_views > 0 {
            left_out += j.every.negligible_views;
            let kept = judge(&scene, &settings(&scene, Budget::Joint, true));
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

/// The clustered VPLs carry their texels' light (a real level, each light
/// alone, no visibility on either side: `gibake_eval::lights::Split`):
/// the VPLs the bake drops as seeing nothing hold none of the light the
/// camera's receivers get from the RSM's texels (the origin's 256-ray
/// probe alone dropped 1.9% of the Blenvy sun's and 1.0% of a lamp's),
/// and beyond the near field one disk per VPL sends what its texels send
/// to within 3% (drawn from the map origin instead of the texels'
/// centroid it was −3.4% for the sun, −7.1% for the lamp:
/// `lights_twin data/lights/blenvy_start_level/StartLevel.glb --size 32
/// --side 64 --only K --split`).
#[test]
fn clustered_vpls_carry_their_texels_light_on_a_real_level() {
    let full = level(
        "data/lights/blenvy_start_level/StartLevel.glb",
        CameraChoice::First,
    );
    for k in [0usize, 4] {
        let vpls = 664;
        let mut scene = full.clone();
        scene.lights = vec![full.lights[k].clone()];
        let j = judge(
            &scene,
            &JudgeSettings {
                vpls,
                split: Some(1),
                size: 32,
                side: 4,
                ..settings(&scene, Budget::Joint, false)
            },
        );
        let sp = j.split.expect("split asked for");
        let kept = sp.texels / sp.all_texels;
        let far = sp.far_clustered / sp.far_texels - 1.0;
        println!(
            "light {k} ({}), {vpls} VPLs: texels of kept VPLs / all {:.4}, far field clustered / texels {:+.2}% ({:.0}% of the light; from the map origins {:+.2}%), transport {:+.2}%",
            full.lights[k].name,
            kept,
            far * 100.0,
            sp.far_texels / sp.texels * 100.0,
            (sp.far_from_origin / sp.far_texels - 1.0) * 100.0,
            sp.transport() * 100.0
        );
        assert!(
            kept >= 0.995,
            "light {k}: dropped VPLs held {:.2}%",
            (1.0 - kept) * 100.0
        );
        assert!(
            far.abs() <= 0.03,
            "light {k}: far field {:+.2}%",
            far * 100.0
        );
    }
}
