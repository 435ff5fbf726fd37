//! The figures of `gibake bench frame` (`frame_cost.rs` runs the binaries):
//! per-render pass medians ([`RunStats`]), per level and size the medians
//! over repetitions and the paired ratios with their spread
//! ([`LevelResult`]), and the Markdown tables and JSON.

use std::fmt::Write as _;

use serde_json::{Value, json};

use crate::frame_cost::Level;
use crate::median;
use crate::report::{Table, sig};

/// The row name of the whole frame (the sum of its passes).
const FRAME: &str = "frame";

/// The configurations measured per level and size.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Cfg {
    /// The `--baseline` binary at its default settings.
    Baseline = 0,
    /// This binary at its default settings.
    Today = 1,
    /// This binary's `--bounces 1` bake.
    TodayB1 = 2,
}

impl Cfg {
    /// In the order of the first repetition.
    pub(crate) const ALL: [Cfg; 3] = [Cfg::Baseline, Cfg::Today, Cfg::TodayB1];

    pub(crate) fn label(self, baseline: &str) -> String {
        match self {
            Cfg::Baseline => baseline.to_string(),
            Cfg::Today => "today".into(),
            Cfg::TodayB1 => "today --bounces 1".into(),
        }
    }

    pub(crate) fn file_tag(self) -> &'static str {
        match self {
            Cfg::Baseline => "baseline",
            Cfg::Today => "today",
            Cfg::TodayB1 => "today-b1",
        }
    }
}

/// One render: per pass (and [`FRAME`], their sum) the median over its
/// measured frames.
#[derive(Clone, Debug)]
pub(crate) struct RunStats {
    pub(crate) passes: Vec<(String, f64)>,
    pub(crate) timing: String,
    pub(crate) adapter: String,
    pub(crate) vpls: Option<u64>,
    pub(crate) interleave: Option<u64>,
}

impl RunStats {
    /// From the passes of the measured frames (a pass missing from a frame
    /// counts 0 ms there).
    pub(crate) fn from_frames(
        frames: &[Vec<(String, f64)>],
        timing: String,
        adapter: String,
        vpls: Option<u64>,
        interleave: Option<u64>,
    ) -> RunStats {
        let mut names: Vec<String> = Vec::new();
        for f in frames {
            for (n, _) in f {
                if !names.contains(n) {
                    names.push(n.clone());
                }
            }
        }
        let of = |f: &[(String, f64)], n: &str| {
            f.iter()
                .filter(|(m, _)| m == n)
                .map(|(_, ms)| ms)
                .sum::<f64>()
        };
        let mut passes = vec![(
            FRAME.to_string(),
            median(
                &frames
                    .iter()
                    .map(|f| f.iter().map(|(_, ms)| ms).sum())
                    .collect::<Vec<_>>(),
            ),
        )];
        for n in names {
            let m = median(&frames.iter().map(|f| of(f, &n)).collect::<Vec<_>>());
            passes.push((n, m));
        }
        RunStats {
            passes,
            timing,
            adapter,
            vpls,
            interleave,
        }
    }

    fn get(&self, pass: &str) -> Option<f64> {
        self.passes
            .iter()
            .find(|(n, _)| n == pass)
            .map(|(_, ms)| *ms)
    }
}

/// A ratio's median over the repetitions and its range.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Ratio {
    pub(crate) median: f64,
    pub(crate) min: f64,
    pub(crate) max: f64,
}

impl Ratio {
    /// Paired per repetition: `num[r] / den[r]` where both have the pass.
    fn paired(num: &[RunStats], den: &[RunStats], pass: &str) -> Option<Ratio> {
        let v: Vec<f64> = num
            .iter()
            .zip(den)
            .filter_map(|(a, b)| Some(a.get(pass)? / b.get(pass)?))
            .filter(|r| r.is_finite())
            .collect();
        if v.is_empty() {
            return None;
        }
        Some(Ratio {
            median: median(&v),
            min: v.iter().copied().fold(f64::INFINITY, f64::min),
            max: v.iter().copied().fold(f64::NEG_INFINITY, f64::max),
        })
    }

    fn cell(&self) -> String {
        format!("{:.2}× ({:.2}–{:.2})", self.median, self.min, self.max)
    }

    fn json(&self) -> Value {
        json!({"median": self.median, "min": self.min, "max": self.max})
    }
}

/// One pass of one level and size.
#[derive(Clone, Debug)]
pub(crate) struct PassRow {
    pub(crate) pass: String,
    /// Median ms of the reference (the baseline, or today's `--bounces 1`
    /// where the baseline could not run the level); `None`: no such pass.
    pub(crate) base_ms: Option<f64>,
    pub(crate) today_ms: Option<f64>,
    pub(crate) b1_ms: Option<f64>,
    /// today ÷ the reference.
    pub(crate) ratio: Option<Ratio>,
    /// today ÷ today's `--bounces 1`.
    pub(crate) over_b1: Option<Ratio>,
}

/// The figures of one level at one size.
#[derive(Clone, Debug)]
pub(crate) struct LevelResult {
    pub(crate) level: String,
    pub(crate) kind: &'static str,
    pub(crate) balls: usize,
    pub(crate) size: (u32, u32),
    /// Why the baseline could not run the level (the reference is then
    /// today's `--bounces 1`).
    pub(crate) fallback: Option<String>,
    pub(crate) reps: [usize; 3],
    pub(crate) vpls: [Option<u64>; 3],
    pub(crate) interleave: [Option<u64>; 3],
    pub(crate) timing: Vec<String>,
    pub(crate) adapters: Vec<String>,
    pub(crate) rows: Vec<PassRow>,
}

/// Median of a pass over renders; `None` when no render has it.
fn med(runs: &[RunStats], pass: &str) -> Option<f64> {
    let v: Vec<f64> = runs.iter().filter_map(|r| r.get(pass)).collect();
    if v.is_empty() {
        None
    } else {
        // A render without the pass (it did not run that frame) counts 0.
        let mut all = v;
        all.resize(runs.len(), 0.0);
        Some(median(&all))
    }
}

impl LevelResult {
    pub(crate) fn new(
        level: &Level,
        size: (u32, u32),
        runs: &[Vec<RunStats>; 3],
        fallback: Option<String>,
    ) -> LevelResult {
        let base: &[RunStats] = if fallback.is_some() {
            &runs[Cfg::TodayB1 as usize]
        } else {
            &runs[Cfg::Baseline as usize]
        };
        let today = &runs[Cfg::Today as usize];
        let b1 = &runs[Cfg::TodayB1 as usize];
        let mut names: Vec<String> = Vec::new();
        for r in today.iter().chain(base).chain(b1) {
            for (n, _) in &r.passes {
                if !names.contains(n) {
                    names.push(n.clone());
                }
            }
        }
        let rows = names
            .iter()
            .map(|n| PassRow {
                pass: n.clone(),
                base_ms: med(base, n),
                today_ms: med(today, n),
                b1_ms: med(b1, n),
                ratio: Ratio::paired(today, base, n),
                over_b1: Ratio::paired(today, b1, n),
            })
            .collect();
        let first =
            |c: Cfg, f: &dyn Fn(&RunStats) -> Option<u64>| runs[c as usize].first().and_then(f);
        let mut timing: Vec<String> = Vec::new();
        let mut adapters: Vec<String> = Vec::new();
        for r in runs.iter().flatten() {
            if !timing.contains(&r.timing) {
                timing.push(r.timing.clone());
            }
            if !adapters.contains(&r.adapter) {
                adapters.push(r.adapter.clone());
            }
        }
        LevelResult {
            level: level.name.clone(),
            kind: level.kind,
            balls: level.balls,
            size,
            fallback,
            reps: [runs[0].len(), runs[1].len(), runs[2].len()],
            vpls: Cfg::ALL.map(|c| first(c, &|r| r.vpls)),
            interleave: Cfg::ALL.map(|c| first(c, &|r| r.interleave)),
            timing,
            adapters,
            rows,
        }
    }

    fn row(&self, pass: &str) -> Option<&PassRow> {
        self.rows.iter().find(|r| r.pass == pass)
    }

    /// The reference's name in the tables.
    fn reference(&self, baseline: &str) -> String {
        if self.fallback.is_some() {
            "today `--bounces 1` ¹".into()
        } else {
            format!("`{baseline}`")
        }
    }
}

/// How the run was set up.
pub(crate) struct Setup {
    pub(crate) today: String,
    pub(crate) baseline: String,
    pub(crate) baseline_name: String,
    pub(crate) same_binary: bool,
    pub(crate) frames: u32,
    pub(crate) reps: u32,
    pub(crate) ssaa: u32,
    pub(crate) interleave: Option<u32>,
    pub(crate) vpls: Option<u32>,
}

/// A ratio cell: the ratio, or which side lacks the pass.
fn ratio_cell(ratio: Option<Ratio>, num: Option<f64>, den: Option<f64>, den_name: &str) -> String {
    match (ratio, num, den) {
        (Some(r), _, _) => r.cell(),
        (None, Some(_), None) => format!("not in {den_name}"),
        (None, None, Some(_)) => "not in today".into(),
        (None, Some(a), Some(b)) if a == 0.0 && b == 0.0 => "0 ms both".into(),
        _ => "—".into(),
    }
}

fn ms_cell(v: Option<f64>) -> String {
    v.map_or_else(|| "absent".into(), sig)
}

/// The passes of the summary table: the (frame, shade, VPL-map
/// merge, G-buffer) and the interleave filter.
const SUMMARY: [(&str, &str); 5] = [
    (FRAME, "frame"),
    ("shade", "shade"),
    ("vpl maps", "VPL-map merge"),
    ("gbuffer", "G-buffer"),
    ("interleave", "interleave filter"),
];

/// The report: a summary table (ratios), the per-pass table (ms and
/// ratios) and the notes.
pub(crate) fn markdown(s: &Setup, results: &[LevelResult]) -> String {
    let mut md = String::new();
    let adapters: Vec<&String> = {
        let mut v: Vec<&String> = Vec::new();
        for a in results.iter().flat_map(|r| &r.adapters) {
            if !v.contains(&a) {
                v.push(a);
            }
        }
        v
    };
    let _ = writeln!(
        md,
        "### gibake bench frame — today (`{}`) against `{}` (`{}`){}\n",
        s.today,
        s.baseline_name,
        s.baseline,
        if s.same_binary {
            " — the same binary: a smoke run; its ratios show the measurement's noise"
        } else {
            ""
        }
    );
    let _ = writeln!(
        md,
        "Adapter: {}. Each binary at its default settings (its own bake, `--ssaa {}`{}{}); \
         per render frames 2–{} of {} measured (frame 1 a warm-up), {} repetition(s), the \
         configurations' order rotating per repetition. Times: per-pass GPU ms, medians; \
         ratios paired per repetition: median (min–max).\n",
        adapters
            .iter()
            .map(|a| a.as_str())
            .collect::<Vec<_>>()
            .join("; "),
        s.ssaa,
        s.interleave
            .map(|i| format!(", `--interleave {i}`"))
            .unwrap_or_default(),
        s.vpls
            .map(|v| format!(", `--vpls {v}`"))
            .unwrap_or_default(),
        s.frames,
        s.frames,
        s.reps
    );
    let mut head: Vec<&'static str> = vec!["level", "size", "compared with", "VPLs (ref / today)"];
    head.extend(SUMMARY.iter().map(|(_, h)| *h));
    head.push("frame: default ÷ `--bounces 1`");
    let mut t = Table::new(
        "Today ÷ the reference, per pass (ratios: median (min–max) over repetitions)".into(),
        &head,
    );
    // (why, the levels) of the baseline's failures, one entry per reason.
    let mut notes: Vec<(String, Vec<String>)> = Vec::new();
    for r in results {
        let ref_vpls = if r.fallback.is_some() {
            r.vpls[2]
        } else {
            r.vpls[0]
        };
        let mut cells = vec![
            r.level.clone(),
            format!("{}×{}", r.size.0, r.size.1),
            r.reference(&s.baseline_name),
            format!(
                "{} / {}",
                ref_vpls.map_or("?".into(), |v| v.to_string()),
                r.vpls[1].map_or("?".into(), |v| v.to_string())
            ),
        ];
        for (pass, _) in SUMMARY {
            cells.push(match r.row(pass) {
                Some(p) => ratio_cell(p.ratio, p.today_ms, p.base_ms, "the reference"),
                None => "—".into(),
            });
        }
        cells.push(
            r.row(FRAME)
                .and_then(|p| p.over_b1)
                .map_or("—".into(), |x| x.cell()),
        );
        t.row(cells);
        if let Some(why) = &r.fallback {
            let level = format!("`{}`", r.level);
            match notes.iter_mut().find(|(w, _)| w == why) {
                Some((_, levels)) if levels.contains(&level) => {}
                Some((_, levels)) => levels.push(level),
                None => notes.push((why.clone(), vec![level])),
            }
        }
    }
    if !notes.is_empty() {
        t.notes.push(format!(
            "¹ `{}` could not run these levels, so the reference is today's `--bounces 1` \
             (the first bounce alone, the paper's method): their ratios are then the cost of \
             today's default (every bounce) over today's first bounce alone on today's runtime, \
             not a comparison with `{}`. Why: {}.",
            s.baseline_name,
            s.baseline_name,
            notes
                .iter()
                .map(|(why, levels)| format!("{}: {why}", levels.join(", ")))
                .collect::<Vec<_>>()
                .join("; ")
        ));
    }
    let balls: Vec<String> = results
        .iter()
        .filter(|r| r.balls > 0)
        .map(|r| r.level.clone())
        .fold(Vec::new(), |mut v, l| {
            if !v.contains(&l) {
                v.push(l);
            }
            v
        });
    if !balls.is_empty() {
        t.notes.push(format!(
            "Rendered through the command line, without the moving balls that levels.json gives \
             {} (an engine's, added by `gibake_eval`; no `gibake render` flag adds them): these \
             levels have no VPL-map merge.",
            balls.join(", ")
        ));
    }
    md.push_str(&t.markdown());
    let mut d = Table::new(
        "Every pass (median ms; ratios: median (min–max) over repetitions)".into(),
        &[
            "level",
            "size",
            "pass",
            "reference ms",
            "today ms",
            "today ÷ reference",
            "today `--bounces 1` ms",
            "default ÷ `--bounces 1`",
        ],
    );
    for r in results {
        for p in &r.rows {
            d.row(vec![
                r.level.clone(),
                format!("{}×{}", r.size.0, r.size.1),
                p.pass.clone(),
                ms_cell(p.base_ms),
                ms_cell(p.today_ms),
                ratio_cell(p.ratio, p.today_ms, p.base_ms, "the reference"),
                ms_cell(p.b1_ms),
                ratio_cell(p.over_b1, p.today_ms, p.b1_ms, "`--bounces 1`"),
            ]);
        }
    }
    d.notes.push(
        "`frame` is the sum of the passes; `vpl maps` is the VPL-map merge (moving objects \
         into the VPL maps); `interleave` the interleaved-sampling filter. `absent`: that \
         configuration has no such pass; the reference is the baseline, or today's `--bounces 1` \
         where marked ¹ above."
            .into(),
    );
    let timing: Vec<&String> = results.iter().flat_map(|r| &r.timing).collect();
    if timing.iter().any(|t| !t.contains("timestamp")) {
        d.notes.push(format!(
            "Some renders had no GPU timestamps (timing: {}): their times are wall times.",
            timing
                .iter()
                .map(|t| t.as_str())
                .collect::<BTreeSetish>()
                .0
                .join(", ")
        ));
    }
    md.push_str(&d.markdown());
    md
}

/// Distinct strings in first-seen order.
struct BTreeSetish(Vec<String>);

impl<'a> FromIterator<&'a str> for BTreeSetish {
    fn from_iter<I: IntoIterator<Item = &'a str>>(it: I) -> Self {
        let mut v: Vec<String> = Vec::new();
        for s in it {
            if !v.iter().any(|x| x == s) {
                v.push(s.to_string());
            }
        }
        BTreeSetish(v)
    }
}

/// Every figure as JSON.
pub(crate) fn json(s: &Setup, results: &[LevelResult]) -> Value {
    json!({
        "today": s.today,
        "baseline": s.baseline,
        "baseline_name": s.baseline_name,
        "same_binary": s.same_binary,
        "frames_per_render": s.frames,
        "measured_frames": "2..N",
        "reps": s.reps,
        "ssaa": s.ssaa,
        "interleave": s.interleave,
        "vpls": s.vpls,
        "levels": results.iter().map(|r| json!({
            "level": r.level,
            "kind": r.kind,
            "size": [r.size.0, r.size.1],
            "reference": if r.fallback.is_some() { "today --bounces 1" } else { "baseline" },
            "baseline_failed": r.fallback,
            "renders": {"baseline": r.reps[0], "today": r.reps[1], "today_bounces1": r.reps[2]},
            "static_vpls": {"baseline": r.vpls[0], "today": r.vpls[1], "today_bounces1": r.vpls[2]},
            "interleave": {"baseline": r.interleave[0], "today": r.interleave[1], "today_bounces1": r.interleave[2]},
            "timing": r.timing,
            "adapters": r.adapters,
            "moving_balls_left_out": r.balls,
            "passes": r.rows.iter().map(|p| json!({
                "pass": p.pass,
                "reference_ms": p.base_ms,
                "today_ms": p.today_ms,
                "today_bounces1_ms": p.b1_ms,
                "today_over_reference": p.ratio.map(|x| x.json()),
                "default_over_bounces1": p.over_b1.map(|x| x.json()),
            })).collect::<Vec<_>>(),
        })).collect::<Vec<_>>(),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn run(passes: &[(&str, f64)]) -> RunStats {
        RunStats::from_frames(
            &[passes.iter().map(|(n, m)| (n.to_string(), *m)).collect()],
            "gpu timestamps".into(),
            "a".into(),
            Some(10),
            Some(4),
        )
    }

    #[test]
    fn frame_is_the_sum_and_ratios_pair_by_repetition() {
        let r = run(&[("shade", 2.0), ("gbuffer", 1.0)]);
        assert_eq!(r.get(FRAME), Some(3.0));
        let today = [run(&[("shade", 4.0)]), run(&[("shade", 9.0)])];
        let base = [run(&[("shade", 2.0)]), run(&[("shade", 3.0)])];
        let q = Ratio::paired(&today, &base, "shade").unwrap();
        assert_eq!((q.min, q.max), (2.0, 3.0));
        assert_eq!(q.median, 2.5);
        assert!(Ratio::paired(&today, &base, "vpl maps").is_none());
    }

    #[test]
    fn a_pass_one_side_lacks_is_named() {
        assert_eq!(ratio_cell(None, Some(1.0), None, "x"), "not in x");
        assert_eq!(ratio_cell(None, None, Some(1.0), "x"), "not in today");
    }
}
