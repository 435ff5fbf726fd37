//! `gibake bench accuracy`: the method's indirect light against the
//! independent reference, per scene — the bundled scenes (with and without
//! their moving objects) and seeded random scenes — as mean indirect bias
//! per channel and `full`'s against `rsm`'s indirect error (the figures of
//! issue 8; `gibake-eval` computes them, `tests/indirect_accuracy.rs` runs a
//! small version) — and with every light: the bundled multi-light room and
//! the seeded random multi-light scenes (issue 19).

use serde_json::json;

use super::{Bench, Table};

/// Runs the accuracy table over the bundled scenes and `seeds` random seeds.
pub(super) fn bench_accuracy(b: &mut Bench, seeds: u64) -> crate::Result<()> {
    let s = gibake_eval::EvalSettings {
        size: if b.quick { 48 } else { 96 },
        spp: if b.quick { 256 } else { 1024 },
        ..Default::default()
    };
    b.section("Indirect accuracy against the reference");
    let mut scenes = Vec::new();
    for (name, f) in gibake_scenegen::all() {
        let scene = gibake_eval::load(&f(&Default::default()), &format!("{name}.glb"));
        scenes.push((name.to_string(), gibake_bake::static_only(&scene)));
        scenes.push((format!("{name} (moving)"), scene));
    }
    for seed in 0..seeds {
        let (scene, name) = gibake_eval::random_scene(seed);
        scenes.push((name, scene));
    }
    // Every light: the bundled room and the random multi-light scenes.
    let every = gibake_scene::LoadOptions::default();
    let lamps = gibake_scenegen::lamps(&Default::default());
    let scene = gibake_scene::load_from_slice(&lamps, std::path::Path::new("lamps.glb"), &every)?;
    scenes.push(("lamps (every light)".into(), scene));
    for seed in 0..seeds {
        let (bytes, info) = gibake_scenegen::random_lights(seed, &Default::default());
        let path = format!("random_lights_{seed}.glb");
        let scene = gibake_scene::load_from_slice(&bytes, std::path::Path::new(&path), &every)?;
        scenes.push((format!("random_lights {seed} ({info})"), scene));
    }
    let mut t = Table::new(
        format!(
            "Mean indirect bias and indirect error, {} VPLs, {}² (ssaa {}), reference {} spp, t = {} s — adapter: {}",
            s.vpls, s.size, s.ssaa, s.spp, s.time, b.adapter
        ),
        &[
            "scene",
            "VPLs",
            "full bias R/G/B",
            "rsm bias R/G/B",
            "ref ±3σ",
            "full err",
            "rsm err",
            "full/rsm",
        ],
    );
    let pct = |v: [f32; 3]| format!("{:+.1}/{:+.1}/{:+.1}%", v[0] * 1e2, v[1] * 1e2, v[2] * 1e2);
    let mut rows = Vec::new();
    let (mut within, mut better, mut judged) = (0, 0, 0);
    for (name, scene) in &scenes {
        let st = scene.dynamic_objects.is_empty();
        let Some(e) = gibake_eval::evaluate_if_judgeable(&b.ctx, scene, name, &s, st, 0.02)? else {
            t.row(vec![
                name.clone(),
                "—".into(),
                "not judgeable: reference noise > 2%".into(),
            ]);
            continue;
        };
        eprintln!("{}", e.line());
        judged += 1;
        within += usize::from(e.full_bias_within(0.05));
        better += usize::from(e.full_err <= e.rsm_err);
        t.row(vec![
            name.clone(),
            e.vpls.to_string(),
            pct(e.full_bias),
            pct(e.rsm_bias),
            format!(
                "{:.1}%",
                300.0 * e.ref_noise.iter().fold(0f32, |a, b| a.max(*b))
            ),
            format!("{:.4}", e.full_err),
            format!("{:.4}", e.rsm_err),
            format!("{:.2}", e.full_err / e.rsm_err.max(1e-12)),
        ]);
        rows.push(serde_json::to_value(&e)?);
    }
    t.notes.push(format!(
        "Bias: mean of (full − direct) over the reference's (one bounce − direct only), per channel. \
         Error: RMSE after a {0}-pixel box blur, over the reference's mean. {within}/{judged} scenes within ±5% \
         (beyond 3σ of the reference's mean); full's error ≤ rsm's on {better}/{judged}.",
        2 * s.blur + 1
    ));
    b.emit(&t);
    b.write_json(
        "accuracy",
        &json!({
            "settings": {
                "size": s.size, "spp": s.spp, "vpls": s.vpls, "rsm_size": s.rsm_size,
                "vpl_map_size": s.vpl_map_size, "time": s.time, "blur": s.blur,
                "ssaa": s.ssaa, "max_dynamic_vpls": s.max_dynamic_vpls,
            },
            "scenes": rows,
        }),
    )?;
    Ok(())
}
