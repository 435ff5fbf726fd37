//! `gibake bench pipeline`: what an up-to-date check costs against the bake
//! it skips, for every bundled scene at the default settings (the figure
//! docs/pipeline.md quotes). Both are timed as `gibake bake` does them, from
//! the scene file: the bake = import + bake + write (GPU device already
//! created, so the ratio errs high); the check = import + static-scene hash +
//! adapter query (no device) + manifest and file checksums.

use std::time::Instant;

use crate::error::{Context, bail};
use gibake_bake::{BakeOptions, Freshness, NoProgress};
use gibake_gpu::{GpuContext, GpuOptions};
use gibake_scene::LoadOptions;
use serde_json::json;

use super::{Bench, Table, median, scene_of};
use crate::BenchScene;
use crate::out::bar;

/// Runs the pipeline benchmark into `b`'s report and `pipeline.json`.
pub(super) fn bench_pipeline(b: &mut Bench) -> crate::Result<()> {
    let runs = if b.quick { 1 } else { 3 };
    let scenes = [
        BenchScene::CornerBunny,
        BenchScene::Occluded,
        BenchScene::Sun,
    ];
    b.section("Pipeline: up-to-date check against the bake it skips");
    std::fs::create_dir_all(&b.tmp).with_context(|| format!("creating {}", b.tmp.display()))?;
    let opts = BakeOptions::default();
    let version = &gibake_bake::baker_version();
    let gpu = GpuOptions {
        adapter: Some(b.ctx.record.name.clone()),
    };
    let mut table = Table::new(
        format!(
            "Bake against up-to-date check, default settings (256 VPLs, 128² maps, 512² RSM, 2048² shadow map) — median of {runs} run(s) — adapter: {}",
            b.adapter
        ),
        &["scene", "bake (s)", "up-to-date check (s)", "check / bake"],
    );
    let pb = bar((runs * scenes.len()) as u64, "pipeline");
    let mut rows = Vec::new();
    for s in scenes {
        let (name, bytes) = scene_of(s);
        let path = b.tmp.join(format!("{name}.glb"));
        std::fs::write(&path, bytes).with_context(|| format!("writing {}", path.display()))?;
        let dir = b.tmp.join(format!("{name}.gibake"));
        let (mut bake_s, mut check_s) = (Vec::new(), Vec::new());
        for _ in 0..runs {
            let t = Instant::now();
            let scene = gibake_scene::load(&path, &LoadOptions::default())?;
            let out = gibake_bake::bake(&b.ctx, &scene, &opts, &NoProgress, version)
                .with_context(|| format!("baking {name}"))?;
            gibake_asset::write(&out.asset, &dir)?;
            bake_s.push(t.elapsed().as_secs_f64());

            let t = Instant::now();
            let scene = gibake_scene::load(&path, &LoadOptions::default())?;
            let record = GpuContext::adapter_record(&gpu)?;
            let fresh = gibake_bake::check_up_to_date(&dir, &scene, &opts, &record, version);
            check_s.push(t.elapsed().as_secs_f64());
            if let Freshness::Stale(why) = fresh {
                bail!(
                    "{name}: the asset just baked is not up to date: {}",
                    why.join("; ")
                );
            }
            pb.inc(1);
        }
        let (mb, mc) = (median(&bake_s), median(&check_s));
        table.row(vec![
            name.to_string(),
            format!("{mb:.3}"),
            format!("{mc:.4}"),
            format!("{:.1} %", 100.0 * mc / mb),
        ]);
        rows.push(json!({
            "scene": name,
            "bake_seconds": bake_s,
            "check_seconds": check_s,
            "median_bake_seconds": mb,
            "median_check_seconds": mc,
            "ratio": mc / mb,
        }));
    }
    pb.finish_and_clear();
    table.notes.push(
        "The bake is timed without creating the GPU device (shared by the benchmark), \
         the check with its adapter query: the ratio errs high. `gibake bake` on an \
         up-to-date asset does exactly the check."
            .into(),
    );
    b.emit(&table);
    b.write_json(
        "pipeline",
        &json!({"adapter": b.adapter, "runs": runs, "scenes": rows}),
    )
}
