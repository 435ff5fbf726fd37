//! `gibake bench quality`: error against run time, complete — every quality
//! setting (VPL budget, hemisphere map size, interleave) and every mode, on
//! the bundled scenes and seeded random ones (`gibake_scenegen::random`),
//! against the CPU reference, as rel MSE and mean FLIP of the whole image
//! and of the indirect part, with the Pareto front (error against frame
//! time) marked in the tables and ringed in the plots. Every image is also
//! scored against the every-bounce reference (issue 50), and each budget is
//! baked a second time with every bounce (`gibake bake`'s default: the
//! later bounces' VPLs after the first's), its `full` a row `full+later`.

use std::time::Instant;

use crate::error::Context;
use gibake_eval::{flip::mean_flip, pareto::pareto_front};
use gibake_image::{Image, rel_mse};
use gibake_runtime::{FrameStats, Mode};
use gibake_scene::Scene;
use serde::Serialize;
use serde_json::json;

use super::frame::{frame_total, render_measured, shade_ms};
use super::plot::{Point, error_vs_time};
use super::report::sig;
use super::{Bench, QUALITY_TIME, Table, distinct, load_embedded, scene_of};
use crate::BenchScene;
use crate::out::bar;

/// The CPU reference of one scene: one bounce, direct only, and their
/// difference (the indirect part); every bounce and its indirect part.
pub(super) struct Refs {
    pub(super) one: Image,
    pub(super) direct: Image,
    pub(super) indirect: Image,
    pub(super) every: Image,
    pub(super) every_indirect: Image,
    pub(super) seconds: f64,
}

/// Renders the reference of `scene` at `size`² with `spp` samples (the
/// direct-only image with the same).
pub(super) fn references(scene: &Scene, name: &str, size: u32, spp: u32) -> crate::Result<Refs> {
    let t = Instant::now();
    let one = reference(
        scene,
        name,
        size,
        spp,
        gibake_reference::Depth::OneBounce,
        1,
    )?;
    let direct = reference(scene, name, size, spp, gibake_reference::Depth::Direct, 1)?;
    let every = reference(scene, name, size, spp, gibake_reference::Depth::Every, 1)?;
    Ok(Refs {
        indirect: one.sub(&direct),
        every_indirect: every.sub(&direct),
        one,
        direct,
        every,
        seconds: t.elapsed().as_secs_f64(),
    })
}

fn reference(
    scene: &Scene,
    name: &str,
    size: u32,
    spp: u32,
    depth: gibake_reference::Depth,
    seed: u64,
) -> crate::Result<Image> {
    let settings = gibake_reference::Settings {
        width: size,
        height: size,
        spp,
        time: QUALITY_TIME,
        depth,
        seed,
    };
    gibake_reference::render(scene, &settings, &|_| {})
        .with_context(|| format!("reference render of {name}"))
}

/// Errors of one image against the reference.
#[derive(Clone, Copy, Debug, Serialize)]
pub(super) struct Scores {
    /// rel MSE of the whole image against the one-bounce reference (for
    /// mode `indirect`: of the image against the reference's indirect part).
    pub(super) rel_mse: f64,
    /// Mean FLIP, same pairing.
    pub(super) flip: f64,
    /// rel MSE of the indirect part (image − direct) against the
    /// reference's indirect part.
    pub(super) indirect_rel_mse: f64,
    /// Mean FLIP of the indirect part.
    pub(super) indirect_flip: f64,
    /// rel MSE of the whole image against the every-bounce reference (mode
    /// `indirect`: against its indirect part).
    pub(super) every_rel_mse: f64,
    /// rel MSE of the indirect part against the every-bounce reference's.
    pub(super) every_indirect_rel_mse: f64,
}

/// Scores `img`; `direct` is the same renderer's direct-only image (the
/// indirect part is `img − direct`), `None` when `img` is already the
/// indirect part (mode `indirect`).
pub(super) fn score(img: &Image, direct: Option<&Image>, r: &Refs) -> crate::Result<Scores> {
    let ind = match direct {
        Some(d) => img.sub(d),
        None => img.clone(),
    };
    let (whole, every) = if direct.is_some() {
        (&r.one, &r.every)
    } else {
        (&r.indirect, &r.every_indirect)
    };
    Ok(Scores {
        rel_mse: rel_mse(img, whole),
        flip: mean_flip(img, whole)?,
        indirect_rel_mse: rel_mse(&ind, &r.indirect),
        indirect_flip: mean_flip(&ind, &r.indirect)?,
        every_rel_mse: rel_mse(img, every),
        every_indirect_rel_mse: rel_mse(&ind, &r.every_indirect),
    })
}

/// One row of a scene's table.
#[derive(Clone, Debug, Serialize)]
struct Row {
    mode: String,
    interleave: Option<u32>,
    vpl_budget: Option<u32>,
    vpls: Option<u32>,
    vpl_map_size: Option<u32>,
    spp: Option<u32>,
    #[serde(flatten)]
    scores: Scores,
    update_ms: Option<f64>,
    shade_ms: Option<f64>,
    frame_ms: f64,
    bake_seconds: Option<f64>,
    timing: String,
    /// On the Pareto front of whole-image rel MSE against frame time.
    pareto_rel_mse: bool,
    /// On the Pareto front of whole-image mean FLIP against frame time.
    pareto_flip: bool,
    /// On the Pareto front of the indirect part's rel MSE against frame time.
    pareto_indirect: bool,
}

impl Row {
    fn gpu(mode: &str, il: u32, st: &FrameStats, scores: Scores) -> Row {
        Row {
            mode: mode.into(),
            interleave: Some(il),
            vpl_budget: None,
            vpls: None,
            vpl_map_size: None,
            spp: None,
            scores,
            update_ms: Some(st.update_ms()),
            shade_ms: Some(shade_ms(st)),
            frame_ms: frame_total(st),
            bake_seconds: None,
            timing: st.timing.to_string(),
            pareto_rel_mse: false,
            pareto_flip: false,
            pareto_indirect: false,
        }
    }

    /// Rows whose whole image is the full picture (on the whole-image fronts).
    fn whole(&self) -> bool {
        matches!(
            self.mode.as_str(),
            "full" | "full+later" | "naive" | "rsm" | "direct"
        )
    }

    /// Rows with an indirect part, for the indirect front (GPU only).
    fn has_indirect(&self) -> bool {
        self.mode != "reference"
    }
}

/// The quality grid.
struct Grid {
    size: u32,
    ssaa: u32,
    budgets: Vec<u32>,
    maps: Vec<u32>,
    /// Budgets also baked at the maps after the first (the map-size axis is
    /// swept at these only, to keep the default sweep inside 15 minutes).
    map_sweep_budgets: Vec<u32>,
    /// Interleave factors of `full`.
    full_il: Vec<u32>,
    /// Interleave factors of `rsm` and `indirect`.
    other_il: Vec<u32>,
    /// Largest budget `naive` is rendered at (it re-renders every map each frame).
    naive_max: u32,
    cpu_spps: Vec<u32>,
}

impl Grid {
    fn new(quick: bool) -> Grid {
        if quick {
            Grid {
                size: 32,
                ssaa: 2,
                budgets: vec![64, 250],
                maps: vec![64],
                map_sweep_budgets: vec![],
                full_il: vec![1, 2, 4, 8],
                other_il: vec![1],
                naive_max: 64,
                cpu_spps: vec![16],
            }
        } else {
            Grid {
                size: 64,
                ssaa: 2,
                budgets: vec![64, 250, 664, 2048],
                maps: vec![64, 128],
                map_sweep_budgets: vec![664],
                full_il: vec![1, 2, 4, 8],
                other_il: vec![1, 4],
                naive_max: 250,
                cpu_spps: vec![16, 64, 256],
            }
        }
    }

    /// The `(budget, map size)` pairs baked: every budget at the first map
    /// size, the map-sweep budgets at the others.
    fn bakes(&self) -> Vec<(u32, u32)> {
        let mut out = Vec::new();
        for (i, &map) in self.maps.iter().enumerate() {
            for &vpls in &self.budgets {
                if i == 0 || self.map_sweep_budgets.contains(&vpls) {
                    out.push((vpls, map));
                }
            }
        }
        out
    }

    fn renders(&self) -> u64 {
        let first = self.maps.first().copied();
        let last = self.maps.last().copied();
        self.bakes()
            .iter()
            .map(|&(vpls, map)| {
                let others = usize::from(Some(map) == first) + usize::from(Some(map) == last);
                // (and `full+later` at the first map size)
                (self.full_il.len()
                    + others * self.other_il.len()
                    + usize::from(Some(map) == first)
                    + usize::from(vpls <= self.naive_max)) as u64
            })
            .sum()
    }
}

/// Runs the quality benchmark over the bundled `scenes` and `randoms`
/// random scenes (seeds 0..randoms), reference `ref_spp` samples.
pub(super) fn bench_quality(
    b: &mut Bench,
    scenes: &[BenchScene],
    randoms: u64,
    ref_spp: u32,
) -> crate::Result<()> {
    b.section("Quality: error against run time");
    let g = Grid::new(b.quick);
    let mut all: Vec<(String, Scene)> = Vec::new();
    for s in distinct(scenes) {
        let (name, bytes) = scene_of(s);
        all.push((name.to_string(), load_embedded(bytes, name)?));
    }
    for seed in 0..randoms {
        let (scene, _) = gibake_eval::random_scene(seed);
        all.push((format!("random_{seed}"), scene));
    }
    let steps = all.len() as u64 * (g.renders() + 2 + g.cpu_spps.len() as u64);
    let pb = bar(steps, "quality");
    let mut scenes_json = Vec::new();
    let mut summary = Table::new(
        format!(
            "Pareto front per scene (whole-image rel MSE against frame time), {0}×{0} (ssaa {1}) — adapter: {2}",
            g.size, g.ssaa, b.adapter
        ),
        &[
            "scene",
            "settings on the front (mode interleave VPLs/map: frame ms, rel MSE)",
        ],
    );
    for (name, scene) in &all {
        pb.set_message(format!("{name}: reference"));
        let refs = references(scene, name, g.size, ref_spp)?;
        pb.inc(2);
        let mut rows: Vec<Row> = Vec::new();
        for &spp in &g.cpu_spps {
            let t = Instant::now();
            let img = reference(
                scene,
                name,
                g.size,
                spp,
                gibake_reference::Depth::OneBounce,
                2,
            )?;
            let secs = t.elapsed().as_secs_f64();
            let scores = score(&img, Some(&refs.direct), &refs)?;
            rows.push(Row {
                mode: "reference".into(),
                interleave: None,
                vpl_budget: None,
                vpls: None,
                vpl_map_size: None,
                spp: Some(spp),
                scores,
                update_ms: None,
                shade_ms: None,
                frame_ms: secs * 1e3,
                bake_seconds: None,
                timing: "CPU wall".into(),
                pareto_rel_mse: false,
                pareto_flip: false,
                pareto_indirect: false,
            });
            pb.inc(1);
        }
        let mut direct: Option<Image> = None;
        for (vpls, map) in g.bakes() {
            {
                pb.set_message(format!("{name}: bake {vpls} VPLs, {map}²"));
                let (out, _) = b.bake(scene, vpls, map)?;
                let bake_s: f64 = out.stages.iter().map(|s| s.seconds).sum();
                let asset = out.asset;
                if direct.is_none() {
                    // Direct light does not depend on the bake: rendered once.
                    let (img, st) = render_measured(
                        b,
                        scene,
                        Some(&asset),
                        Mode::Direct,
                        g.size,
                        g.ssaa,
                        1,
                        QUALITY_TIME,
                    )?;
                    let zero = Image::new(img.width, img.height);
                    let mut sc = score(&img, Some(&img), &refs)?;
                    // The indirect part of `direct` is zero.
                    sc.indirect_rel_mse = rel_mse(&zero, &refs.indirect);
                    sc.indirect_flip = mean_flip(&zero, &refs.indirect)?;
                    rows.push(Row::gpu("direct", 1, &st, sc));
                    direct = Some(img);
                }
                let Some(dimg) = direct.as_ref() else {
                    unreachable!("set above")
                };
                let mut jobs: Vec<(&str, Mode, u32)> = Vec::new();
                for &il in &g.full_il {
                    jobs.push(("full", Mode::Full, il));
                }
                // `rsm` does not read the hemisphere maps: rendered at the
                // first map size only; `indirect` (full − direct) at the
                // largest only.
                for &il in &g.other_il {
                    if Some(&map) == g.maps.first() {
                        jobs.push(("rsm", Mode::Rsm, il));
                    }
                    if Some(&map) == g.maps.last() {
                        jobs.push(("indirect", Mode::Indirect, il));
                    }
                }
                if vpls <= g.naive_max {
                    jobs.push(("naive", Mode::Naive, 1));
                }
                for (mname, mode, il) in jobs {
                    pb.set_message(format!("{name}: {mname} ×{il}, {vpls} VPLs, {map}²"));
                    let (img, st) = render_measured(
                        b,
                        scene,
                        Some(&asset),
                        mode,
                        g.size,
                        g.ssaa,
                        il,
                        QUALITY_TIME,
                    )?;
                    let sc = if mode == Mode::Indirect {
                        score(&img, None, &refs)?
                    } else {
                        score(&img, Some(dimg), &refs)?
                    };
                    let mut row = Row::gpu(mname, il, &st, sc);
                    row.vpl_budget = Some(vpls);
                    row.vpls = Some(asset.manifest.vpl_count);
                    row.vpl_map_size = Some(map);
                    row.bake_seconds = Some(bake_s);
                    rows.push(row);
                    pb.inc(1);
                }
                // The default bake (every bounce) beside it, at the first
                // map size: `full` at interleave 1.
                if Some(&map) == g.maps.first() {
                    pb.set_message(format!("{name}: bake {vpls} VPLs, {map}², every bounce"));
                    let (out, _) =
                        b.bake_bounces(scene, vpls, map, gibake_bake::later::Bounces::Every)?;
                    let bake_s: f64 = out.stages.iter().map(|s| s.seconds).sum();
                    let (img, st) = render_measured(
                        b,
                        scene,
                        Some(&out.asset),
                        Mode::Full,
                        g.size,
                        g.ssaa,
                        1,
                        QUALITY_TIME,
                    )?;
                    let mut row = Row::gpu("full+later", 1, &st, score(&img, Some(dimg), &refs)?);
                    row.vpl_budget = Some(vpls);
                    row.vpls = Some(out.asset.manifest.vpl_count);
                    row.vpl_map_size = Some(map);
                    row.bake_seconds = Some(bake_s);
                    rows.push(row);
                    pb.inc(1);
                }
            }
        }
        mark_fronts(&mut rows);
        let plots = pb.suspend(|| plot_scene(b, name, &g, &rows))?;
        let table = scene_table(b, name, &g, ref_spp, &refs, &rows, &plots);
        pb.suspend(|| b.emit(&table));
        for f in &plots {
            b.plot_written(f, "quality");
        }
        let front: Vec<String> = rows
            .iter()
            .filter(|r| r.pareto_rel_mse)
            .map(|r| {
                format!(
                    "{}: {} ms, {}",
                    label(r),
                    sig(r.frame_ms),
                    sig(r.scores.rel_mse)
                )
            })
            .collect();
        summary.row(vec![name.clone(), front.join("; ")]);
        scenes_json.push(json!({
            "scene": name,
            "time": QUALITY_TIME,
            "width": g.size,
            "height": g.size,
            "ssaa": g.ssaa,
            "reference_spp": ref_spp,
            "reference_seconds": refs.seconds,
            "rows": rows,
            "plots": plots,
        }));
    }
    pb.finish_and_clear();
    b.emit(&summary);
    b.write_json(
        "quality",
        &json!({
            "adapter": b.adapter,
            "quick": b.quick,
            "scenes": scenes_json,
        }),
    )
}

/// Marks the three Pareto fronts (frame time against whole-image rel MSE,
/// whole-image FLIP and the indirect part's rel MSE) among the GPU rows.
fn mark_fronts(rows: &mut [Row]) {
    let mark = |rows: &mut [Row],
                on: &dyn Fn(&Row) -> bool,
                err: &dyn Fn(&Row) -> f64,
                set: &dyn Fn(&mut Row, bool)| {
        let idx: Vec<usize> = (0..rows.len()).filter(|&i| on(&rows[i])).collect();
        let pts: Vec<(f64, f64)> = idx
            .iter()
            .map(|&i| (rows[i].frame_ms, err(&rows[i])))
            .collect();
        for (k, f) in pareto_front(&pts).into_iter().enumerate() {
            set(&mut rows[idx[k]], f);
        }
    };
    let whole = |r: &Row| r.whole();
    mark(rows, &whole, &|r| r.scores.rel_mse, &|r, f| {
        r.pareto_rel_mse = f
    });
    mark(rows, &whole, &|r| r.scores.flip, &|r, f| r.pareto_flip = f);
    mark(
        rows,
        &|r: &Row| r.has_indirect(),
        &|r| r.scores.indirect_rel_mse,
        &|r, f| r.pareto_indirect = f,
    );
}

fn label(r: &Row) -> String {
    match (r.interleave, r.vpl_budget, r.vpl_map_size, r.spp) {
        (_, _, _, Some(spp)) => format!("CPU reference {spp} spp"),
        (Some(il), Some(v), Some(m), _) => format!("{} ×{il} {v}/{m}", r.mode),
        _ => r.mode.clone(),
    }
}

fn plot_scene(b: &Bench, name: &str, g: &Grid, rows: &[Row]) -> crate::Result<Vec<String>> {
    let series = |r: &Row| match r.interleave {
        Some(il) if r.mode != "naive" && r.mode != "direct" => format!("{} ×{il}", r.mode),
        _ => r.mode.clone(),
    };
    let adapter = b
        .adapter
        .split(" (")
        .next()
        .unwrap_or(&b.adapter)
        .to_string();
    let mut files = Vec::new();
    for (suffix, ylab, err, front) in [
        (
            "",
            "rel MSE (log)",
            (|r: &Row| r.scores.rel_mse) as fn(&Row) -> f64,
            (|r: &Row| r.pareto_rel_mse) as fn(&Row) -> bool,
        ),
        (
            "_flip",
            "mean FLIP (log)",
            |r: &Row| r.scores.flip,
            |r: &Row| r.pareto_flip,
        ),
    ] {
        let pts: Vec<Point> = rows
            .iter()
            .filter(|r| r.whole())
            .map(|r| Point {
                series: series(r),
                ms: r.frame_ms,
                err: err(r),
                front: front(r),
            })
            .collect();
        let file = format!("quality_{name}{suffix}.png");
        error_vs_time(
            &b.out.join(&file),
            &format!(
                "{name}: {} against frame time, {}² ssaa {} ({adapter})",
                if suffix.is_empty() {
                    "rel MSE"
                } else {
                    "mean FLIP"
                },
                g.size,
                g.ssaa
            ),
            ylab,
            &pts,
        )?;
        files.push(file);
    }
    Ok(files)
}

fn scene_table(
    b: &Bench,
    name: &str,
    g: &Grid,
    ref_spp: u32,
    refs: &Refs,
    rows: &[Row],
    plots: &[String],
) -> Table {
    let timing = if b.ctx.timestamps {
        "gpu timestamps"
    } else {
        "wall"
    };
    let mut t = Table::new(
        format!(
            "{name}, t = {QUALITY_TIME} s, {0}×{0} (ssaa {1}) — error against the CPU reference ({ref_spp} spp) — times: {timing} — adapter: {2}",
            g.size, g.ssaa, b.adapter
        ),
        &[
            "mode",
            "interleave",
            "VPLs (budget)",
            "map",
            "rel MSE",
            "FLIP",
            "indirect rel MSE",
            "indirect FLIP",
            "rel MSE vs every bounce",
            "indirect rel MSE vs every bounce",
            "bake (s)",
            "update (ms)",
            "shade+filter (ms)",
            "frame (ms)",
            "Pareto",
        ],
    );
    let opt = |v: Option<f64>| v.map(sig).unwrap_or_else(|| "—".into());
    for r in rows {
        let mut front = Vec::new();
        if r.pareto_rel_mse {
            front.push("★ MSE");
        }
        if r.pareto_flip {
            front.push("★ FLIP");
        }
        if r.pareto_indirect {
            front.push("☆ ind");
        }
        t.row(vec![
            match r.spp {
                Some(spp) => format!("CPU reference {spp} spp"),
                None => r.mode.clone(),
            },
            r.interleave
                .map(|i| i.to_string())
                .unwrap_or_else(|| "—".into()),
            match (r.vpls, r.vpl_budget) {
                (Some(v), Some(bu)) => format!("{v} ({bu})"),
                _ => "—".into(),
            },
            r.vpl_map_size
                .map(|m| format!("{m}²"))
                .unwrap_or_else(|| "—".into()),
            sig(r.scores.rel_mse),
            sig(r.scores.flip),
            sig(r.scores.indirect_rel_mse),
            sig(r.scores.indirect_flip),
            sig(r.scores.every_rel_mse),
            sig(r.scores.every_indirect_rel_mse),
            opt(r.bake_seconds),
            opt(r.update_ms),
            opt(r.shade_ms),
            if r.spp.is_some() {
                format!("{} (CPU wall)", sig(r.frame_ms))
            } else {
                sig(r.frame_ms)
            },
            front.join(", "),
        ]);
    }
    t.notes.push(format!(
        "Reference: CPU path tracer at {0}×{0}, one bounce, every bounce and direct only, {ref_spp} spp each ({1:.1} s). \
         `full+later`: `full` of the default bake (every bounce: the later bounces' VPLs after the first's, \
         a quarter as many; the VPL count includes them); the other rows bake the first bounce alone. \
         \"vs every bounce\": the same images against the every-bounce reference (the light a path tracer \
         users compare with shows). \
         rel MSE = mean of (x−r)²/(r²+0.01); FLIP = mean LDR-FLIP (nv-flip, NVIDIA's implementation) of the \
         images tone-mapped with the reference's exposure. Whole image: against the one-bounce reference \
         (mode `indirect`: its image against the reference's indirect part). Indirect part: image − the \
         `direct` image, against one-bounce − direct-only. Renders at {2}×{2}, box-downsampled. `naive` only up to \
         {3} VPLs (it re-renders every map each frame). frame = every GPU pass (update + G-buffer + shade + \
         interleave filter), one frame after a warm-up{4}. Pareto: ★ on the front of frame time against the whole \
         image's rel MSE / FLIP (among full, naive, rsm, direct), ☆ against the indirect part's rel MSE (every GPU \
         row); CPU reference rows (wall time of the CPU path tracer) are not on the fronts.",
        g.size,
        refs.seconds,
        g.size * g.ssaa,
        g.naive_max,
        if b.quick { " (--quick: no warm-up)" } else { "" }
    ));
    t.notes.push(format!(
        "Plots: {}.",
        plots
            .iter()
            .map(|p| format!("`{p}`"))
            .collect::<Vec<_>>()
            .join(", ")
    ));
    t
}
