//! `gibake bench bake`: bake time per stage at 250 and 664 VPLs (median of
//! 3), VPL and map counts, asset size; issue 3's target.

use std::path::Path;
use std::time::Instant;

use crate::error::Context;
use gibake_scene::LoadOptions;
use serde_json::json;

use super::report::{dir_bytes, mib};
use super::{Bench, CORNER_BUNNY, Table, load_embedded, median};
use crate::out::bar;

/// Issue 3: the whole 664-VPL bake of corner_bunny under this many seconds on lavapipe.
const BAKE_TARGET_S: f64 = 3.0;

/// Runs the bake benchmark on `scene_path` (default: corner_bunny).
pub(super) fn bench_bake(b: &mut Bench, scene_path: Option<&Path>) -> crate::Result<()> {
    let (scene, name) = match scene_path {
        Some(p) => (
            gibake_scene::load(p, &LoadOptions::default())?,
            p.display().to_string(),
        ),
        None => (
            load_embedded(CORNER_BUNNY, "corner_bunny")?,
            "corner_bunny".to_string(),
        ),
    };
    let runs = if b.quick { 1 } else { 3 };
    let budgets = [250u32, 664];
    b.section("Bake");
    std::fs::create_dir_all(&b.tmp).with_context(|| format!("creating {}", b.tmp.display()))?;
    let pb = bar((runs * budgets.len()) as u64, "bake");
    let mut json_rows = Vec::new();
    let mut table = Table::new(
        format!(
            "Bake time per stage, {name}, 128² VPL maps, 512² RSM, 2048² shadow map — median of {runs} run(s) — adapter: {}",
            b.adapter
        ),
        &["stage", "250 VPLs (s)", "664 VPLs (s)"],
    );
    /// Medians per stage, VPL count, maps stored, asset bytes.
    struct Budget {
        stages: Vec<(String, f64)>,
        vpls: u32,
        maps: u32,
        bytes: u64,
    }
    let mut per_budget: Vec<Budget> = Vec::new();
    for &vpls in &budgets {
        let mut stage_runs: Vec<Vec<(String, f64)>> = Vec::new();
        let (mut count, mut maps, mut bytes) = (0, 0, 0);
        for run in 0..runs {
            let (out, _) = b.bake(&scene, vpls, 128)?;
            let dir = b.tmp.join(format!("bake_{vpls}_{run}.gibake"));
            let w = Instant::now();
            gibake_asset::write(&out.asset, &dir)?;
            let write_s = w.elapsed().as_secs_f64();
            bytes = dir_bytes(&dir);
            let _ = std::fs::remove_dir_all(&dir);
            count = out.asset.manifest.vpl_count;
            maps = out.asset.manifest.map_count;
            let mut st: Vec<(String, f64)> = out
                .stages
                .iter()
                .map(|s| (s.stage.to_string(), s.seconds))
                .collect();
            st.push(("write".into(), write_s));
            let total: f64 = st.iter().map(|(_, s)| s).sum();
            st.push(("total".into(), total));
            stage_runs.push(st);
            pb.inc(1);
        }
        let names: Vec<String> = stage_runs[0].iter().map(|(n, _)| n.clone()).collect();
        let med: Vec<(String, f64)> = names
            .iter()
            .enumerate()
            .map(|(i, n)| {
                let v: Vec<f64> = stage_runs.iter().map(|r| r[i].1).collect();
                (n.clone(), median(&v))
            })
            .collect();
        json_rows.push(json!({
            "vpl_budget": vpls,
            "vpls": count,
            "maps_stored": maps,
            "asset_bytes": bytes,
            "median_seconds": med.iter().map(|(n, s)| json!({"stage": n, "seconds": s})).collect::<Vec<_>>(),
            "runs": stage_runs.iter().map(|r| r.iter().map(|(n, s)| json!({"stage": n, "seconds": s})).collect::<Vec<_>>()).collect::<Vec<_>>(),
        }));
        per_budget.push(Budget {
            stages: med,
            vpls: count,
            maps,
            bytes,
        });
    }
    pb.finish_and_clear();
    let names: Vec<String> = per_budget[0]
        .stages
        .iter()
        .map(|(n, _)| n.clone())
        .collect();
    for (i, n) in names.iter().enumerate() {
        let cell = |k: usize| {
            per_budget[k]
                .stages
                .get(i)
                .map(|(_, s)| format!("{s:.3}"))
                .unwrap_or_default()
        };
        let label = if n == "total" {
            "**total**".to_string()
        } else {
            n.clone()
        };
        table.row(vec![label, cell(0), cell(1)]);
    }
    table.row(vec![
        "VPLs (maps stored)".into(),
        format!("{} ({})", per_budget[0].vpls, per_budget[0].maps),
        format!("{} ({})", per_budget[1].vpls, per_budget[1].maps),
    ]);
    table.row(vec![
        "asset size".into(),
        mib(per_budget[0].bytes),
        mib(per_budget[1].bytes),
    ]);
    let total_664 = per_budget[1]
        .stages
        .iter()
        .find(|(n, _)| n == "total")
        .map(|(_, s)| *s)
        .unwrap_or(f64::NAN);
    let met = total_664 < BAKE_TARGET_S;
    let verdict = if b.lavapipe {
        format!(
            "Issue 3 target (664-VPL bake under {BAKE_TARGET_S} s on lavapipe, {} CPU cores here): **{}** — {total_664:.2} s.",
            std::thread::available_parallelism()
                .map(|n| n.get())
                .unwrap_or(1),
            if met { "MET" } else { "MISSED" }
        )
    } else {
        format!(
            "Issue 3's target ({BAKE_TARGET_S} s) is defined on lavapipe; on this adapter the 664-VPL bake took {total_664:.2} s ({}).",
            if met { "under it" } else { "over it" }
        )
    };
    table.notes.push(
        "Stages are the bake's own wall times (BVH, GPU static shadow map, RSM by rays, \
         clustering, VPL hemisphere maps by rays); `write` is `gibake_asset::write` into a \
         temporary directory; scene import and GPU device creation are not included."
            .into(),
    );
    table.notes.push(verdict.clone());
    b.emit(&table);
    b.write_json(
        "bake",
        &json!({
            "adapter": b.adapter,
            "scene": name,
            "runs": runs,
            "vpl_map_size": 128,
            "rsm_size": 512,
            "shadow_map_size": 2048,
            "budgets": json_rows,
            "target_seconds": BAKE_TARGET_S,
            "target_met": met,
            "lavapipe": b.lavapipe,
            "verdict": verdict,
        }),
    )
}
