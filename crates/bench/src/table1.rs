//! `gibake bench table1`: the shape of the paper's Table 1 — corner_bunny,
//! mode `full`, 250 and 664 static VPLs × 0 / 13 / 41 dynamic VPLs, at
//! interleave 1 and 4 — at `--table1-size` (default 320×180 so that the
//! default sweep stays short on a CPU rasterizer; the paper's is 1280×720:
//! `gibake bench table1 --table1-size 1280x720`).

use serde_json::json;

use super::frame::{Config, measure_all};
use super::{Bench, CORNER_BUNNY, Table, load_embedded};
use crate::out::bar;
use gibake_runtime::{Mode, RenderSettings};

/// The paper's dynamic VPL counts.
const DYNAMIC: [u32; 3] = [0, 13, 41];
/// The paper's static VPL budgets.
const BUDGETS: [u32; 2] = [250, 664];
/// Interleave factors compared.
const INTERLEAVE: [u32; 2] = [1, 4];

/// Runs Table 1 at `size` = (width, height).
pub(super) fn bench_table1(b: &mut Bench, size: (u32, u32)) -> crate::Result<()> {
    b.section("The paper's Table 1");
    // --quick: a quarter of the size each way.
    let (tw, th) = if b.quick {
        ((size.0 / 4).max(8), (size.1 / 4).max(8))
    } else {
        size
    };
    let map = if b.quick { 64 } else { 128 };
    let frames = if b.quick { 1 } else { b.frames.min(2) };
    let cb = load_embedded(CORNER_BUNNY, "corner_bunny")?;
    let mut assets = Vec::new();
    for &budget in &BUDGETS {
        assets.push(b.bake(&cb, budget, map)?.0.asset);
    }
    let mut configs = Vec::new();
    for a in &assets {
        for &il in &INTERLEAVE {
            for &d in &DYNAMIC {
                configs.push(Config {
                    scene: &cb,
                    asset: Some(a),
                    settings: RenderSettings {
                        width: tw,
                        height: th,
                        shadow_map_size: 2048,
                        mode: Mode::Full,
                        max_dynamic_vpls: d,
                        interleave: il,
                        max_spawned: 0,
                        ..Default::default()
                    },
                    frames,
                });
            }
        }
    }
    let pb = bar(configs.len() as u64 * (u64::from(frames) + 1), "table1");
    let measured = measure_all(&b.ctx, &configs, &|| pb.inc(1))?;
    pb.finish_and_clear();
    drop(configs);
    let timing = measured
        .first()
        .map(|m| m.timing.clone())
        .unwrap_or_default();
    let mut t = Table::new(
        format!(
            "Table 1 shape — corner_bunny, mode full, {tw}×{th}, {map}² maps, median of {frames} frame(s) after a warm-up, interleaved — times: {timing} — adapter: {}",
            b.adapter
        ),
        &[
            "static VPLs",
            "interleave",
            "max_dynamic_vpls 0: slots / ms / FPS",
            "13: slots / ms / FPS",
            "41: slots / ms / FPS",
        ],
    );
    let mut rows = Vec::new();
    let mut k = 0;
    for (budget, asset) in BUDGETS.iter().zip(&assets) {
        for &il in &INTERLEAVE {
            let mut cells = vec![
                format!("{} (budget {budget})", asset.manifest.vpl_count),
                il.to_string(),
            ];
            for &d in &DYNAMIC {
                let m = &measured[k];
                k += 1;
                cells.push(format!(
                    "{} / {:.1} / {:.2}",
                    m.dynamic_slots,
                    m.frame_ms,
                    1e3 / m.frame_ms
                ));
                rows.push(json!({
                    "static_vpl_budget": budget,
                    "static_vpls": asset.manifest.vpl_count,
                    "max_dynamic_vpls": d,
                    "interleave": il,
                    "width": tw,
                    "height": th,
                    "fps": 1e3 / m.frame_ms,
                    "stats": m.json(),
                }));
            }
            t.row(cells);
        }
    }
    t.notes.push(
        "The paper (GTX 780, DirectX 9, 1280×720): 250 static VPLs 50.2 / 15.7 / 10.1 FPS and 664 static VPLs \
         23.5 / 7.3 / 4.5 FPS with 0 / 13 / 41 dynamic VPLs. Columns are the `max_dynamic_vpls` setting \
         (slots: the dynamic VPL slots the runtime shades); frame ms is the sum of the GPU passes \
         (update + G-buffer + shade + interleave filter). At 1280×720: \
         `gibake bench table1 --table1-size 1280x720`."
            .into(),
    );
    b.emit(&t);
    b.write_json(
        "table1",
        &json!({"adapter": b.adapter, "width": tw, "height": th, "vpl_map_size": map, "rows": rows}),
    )
}
