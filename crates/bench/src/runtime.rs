//! `gibake bench runtime`: the per-frame update of `full` against `naive`
//! on corner_bunny and a variant with a heavier static part (issue 4's
//! targets), and the asset load + GPU upload time.

use std::path::Path;
use std::time::Instant;

use crate::error::Context;
use gibake_runtime::{Mode, RenderSettings};
use gibake_scene::LoadOptions;
use serde_json::json;

use super::frame::{Config, FrameSummary, measure_all, new_renderer};
use super::report::{dir_bytes, mib};
use super::{Bench, CORNER_BUNNY, FRAME_STEP_S, Table, load_embedded, median};
use crate::out::bar;

/// Issue 4: full's update cost grows at most this much when the static part is 20× heavier.
const GROWTH_TARGET: f64 = 0.20;
/// Issue 4: naive is at least this many times slower than full on the heavy scene.
const NAIVE_TARGET: f64 = 10.0;

/// Runs the runtime benchmark (`heavy`: the static-detail multiplier).
pub(super) fn bench_runtime(b: &mut Bench, heavy: u32) -> crate::Result<()> {
    b.section("Runtime");
    let (vpls, map) = if b.quick { (250, 64) } else { (664, 128) };
    let frames = b.frames;
    let cb = load_embedded(CORNER_BUNNY, "corner_bunny")?;
    let heavy_name = format!("corner_bunny heavy×{heavy}");
    let heavy_scene = gibake_scene::load_from_slice(
        &gibake_scenegen::corner_bunny(&gibake_scenegen::Params {
            heavy,
            ..Default::default()
        }),
        Path::new(&format!("corner_bunny_heavy{heavy}.glb (generated)")),
        &LoadOptions::default(),
    )?;
    let (w, h) = (320, 180);
    // naive re-renders every VPL map from all geometry: on a CPU rasterizer
    // a frame of the heavy scene takes minutes, so it gets fewer frames.
    let naive_frames = frames.min(2);
    let steps = 2 * (frames as u64 + naive_frames as u64 + 2);
    let pb = bar(steps, "runtime");
    let tick = || pb.inc(1);

    // --- full against naive on corner_bunny and its heavy variant ---
    let mut baked = Vec::new();
    for scene in [&cb, &heavy_scene] {
        baked.push(b.bake(scene, vpls, map)?);
    }
    let settings = |mode| RenderSettings {
        width: w,
        height: h,
        shadow_map_size: 2048,
        mode,
        max_dynamic_vpls: 64,
        interleave: 1,
        max_spawned: 0,
        ..Default::default()
    };
    let mut configs = Vec::new();
    for (scene, (out, _)) in [&cb, &heavy_scene].into_iter().zip(&baked) {
        for (mode, n) in [(Mode::Full, frames), (Mode::Naive, naive_frames)] {
            configs.push(Config {
                scene,
                asset: Some(&out.asset),
                settings: settings(mode),
                frames: n,
            });
        }
    }
    let measured = measure_all(&b.ctx, &configs, &tick)?;
    drop(configs);
    let mut scenes_json = Vec::new();
    let mut results: Vec<(String, usize, FrameSummary, FrameSummary)> = Vec::new();
    for (i, (name, scene)) in [
        ("corner_bunny".to_string(), &cb),
        (heavy_name.clone(), &heavy_scene),
    ]
    .into_iter()
    .enumerate()
    {
        let (out, bake_s) = &baked[i];
        let (full, naive) = (measured[2 * i].clone(), measured[2 * i + 1].clone());
        let (st, dt) = scene.triangle_counts();
        scenes_json.push(json!({
            "scene": name,
            "static_triangles": st,
            "dynamic_triangles": dt,
            "moving_objects": scene.dynamic_objects.len(),
            "vpls": out.asset.manifest.vpl_count,
            "bake_seconds": bake_s,
            "full": full.json(),
            "naive": naive.json(),
            "full_over_naive": full.update_ms / naive.update_ms,
        }));
        results.push((name, st, full, naive));
    }
    let cb_asset = baked.swap_remove(0).0.asset;
    drop(baked);
    let timing = results[0].2.timing.clone();
    let mut t = Table::new(
        format!(
            "Per-frame update, full against naive — {w}×{h}, ssaa 1, {vpls} static VPL budget, {map}² maps, ≤ 64 dynamic VPLs, median of {frames} frame(s) (naive: {naive_frames}) after a warm-up, interleaved — times: {timing} — adapter: {}",
            b.adapter
        ),
        &[
            "scene",
            "static tris",
            "mode",
            "update (ms)",
            "shade (ms)",
            "frame (ms)",
            "affected maps",
            "update draw calls",
            "full/naive update",
        ],
    );
    for (name, st, full, naive) in &results {
        for (mode, s) in [("full", full), ("naive", naive)] {
            t.row(vec![
                name.clone(),
                st.to_string(),
                mode.into(),
                format!("{:.2}", s.update_ms),
                format!("{:.2}", s.shade_ms),
                format!("{:.2}", s.frame_ms),
                format!("{:.0}", s.affected_maps),
                format!("{:.0}", s.update_draw_calls),
                if mode == "full" {
                    format!("{:.4}", full.update_ms / naive.update_ms)
                } else {
                    String::new()
                },
            ]);
        }
    }
    let growth = results[1].2.update_ms / results[0].2.update_ms - 1.0;
    let naive_over_full = results[1].3.update_ms / results[1].2.update_ms;
    let growth_met = growth <= GROWTH_TARGET;
    let naive_met = naive_over_full >= NAIVE_TARGET;
    t.notes.push(format!(
        "update = GPU time of the merge passes (primary merge, dynamic rsm, occlusion, dynamic vpls, vpl maps); \
         frame = every pass including G-buffer and shading. Static triangles: {} → {} ({:.1}×).",
        results[0].1,
        results[1].1,
        results[1].1 as f64 / results[0].1 as f64
    ));
    t.notes.push(format!(
        "Issue 4 targets: full's update grows ≤ {:.0}% from corner_bunny to {heavy_name}: **{}** ({:+.1}%); \
         naive/full update on {heavy_name} ≥ {NAIVE_TARGET}×: **{}** ({naive_over_full:.1}×).",
        GROWTH_TARGET * 100.0,
        if growth_met { "MET" } else { "MISSED" },
        growth * 100.0,
        if naive_met { "MET" } else { "MISSED" },
    ));
    pb.suspend(|| b.emit(&t));

    // --- asset load + GPU upload ---
    pb.set_message("load");
    std::fs::create_dir_all(&b.tmp).with_context(|| format!("creating {}", b.tmp.display()))?;
    let dir = b.tmp.join("runtime_cb.gibake");
    gibake_asset::write(&cb_asset, &dir)?;
    let disk = dir_bytes(&dir);
    let mut loads = Vec::new();
    let mut uploads = Vec::new();
    let mut bytes = 0;
    for _ in 0..3 {
        let t0 = Instant::now();
        let asset = gibake_asset::load(&dir)?;
        loads.push(t0.elapsed().as_secs_f64());
        let t1 = Instant::now();
        let r = new_renderer(
            &b.ctx,
            &cb,
            Some(&asset),
            &RenderSettings {
                width: w,
                height: h,
                ..Default::default()
            },
        )?;
        b.ctx.wait()?;
        uploads.push(t1.elapsed().as_secs_f64());
        bytes = r.asset_bytes();
    }
    let _ = std::fs::remove_dir_all(&dir);
    pb.finish_and_clear();
    let mut tl = Table::new(
        format!(
            "Asset load + GPU upload — corner_bunny, {} VPLs, {map}² maps — median of 3 — adapter: {}",
            cb_asset.manifest.vpl_count, b.adapter
        ),
        &["step", "seconds", "bytes"],
    );
    tl.row(vec![
        "gibake_asset::load (read + verify)".into(),
        format!("{:.3}", median(&loads)),
        mib(disk),
    ]);
    tl.row(vec![
        "Renderer::new (GPU upload + pipelines)".into(),
        format!("{:.3}", median(&uploads)),
        mib(bytes),
    ]);
    tl.row(vec![
        "**total**".into(),
        format!("{:.3}", median(&loads) + median(&uploads)),
        String::new(),
    ]);
    b.emit(&tl);

    b.write_json(
        "runtime",
        &json!({
            "adapter": b.adapter,
            "quick": b.quick,
            "width": w,
            "height": h,
            "vpl_budget": vpls,
            "vpl_map_size": map,
            "frames": frames,
            "frame_step_seconds": FRAME_STEP_S,
            "scenes": scenes_json,
            "full_growth": growth,
            "full_growth_target": GROWTH_TARGET,
            "full_growth_met": growth_met,
            "naive_over_full_heavy": naive_over_full,
            "naive_over_full_target": NAIVE_TARGET,
            "naive_over_full_met": naive_met,
            "load": {
                "vpls": cb_asset.manifest.vpl_count,
                "load_seconds": median(&loads),
                "renderer_new_seconds": median(&uploads),
                "disk_bytes": disk,
                "gpu_asset_bytes": bytes,
            },
        }),
    )
}
