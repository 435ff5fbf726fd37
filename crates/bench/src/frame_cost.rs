//! `gibake bench frame`: the per-pass frame cost of this binary against an
//! earlier gibake binary (`--baseline BIN`, e.g. one built from a pinned
//! commit by `scripts/bench-frame.sh`), side by side in one run.
//!
//! Both binaries are driven through their command lines only — `gibake
//! bake` (an up-to-date asset is reused) and `gibake render --frames N
//! --stats F.json` — so the baseline can be any earlier version. What the
//! baseline accepts is read from its `--help` (`bake --help`, `render
//! --help`), never assumed: a level that needs a flag it lacks (`--sun`,
//! `--dynamic`, `--look-at`, …), or that it fails to bake or render, is
//! compared with this binary's `--bounces 1` instead (the first bounce
//! alone, the paper's method), and the table says so and why.
//!
//! Per level: three bakes (baseline; today's default; today's `--bounces
//! 1`), then per size and repetition one render of each configuration, in
//! an order that rotates with the repetition, so that a change of machine
//! load hits all of them alike. Per render, frames 2..N are measured (the
//! first is a warm-up); the per-pass GPU times of its stats file are
//! reduced to medians per render, then to medians over the repetitions;
//! the ratios are paired per repetition (their median, minimum and
//! maximum: the spread). The tables and JSON are `frame_cost_report.rs`'s.

use std::collections::BTreeSet;
use std::ffi::OsString;
use std::path::{Path, PathBuf};
use std::process::Command;

use gibake_eval::levels::{LevelCamera, LevelSun};
use serde_json::Value;

use crate::error::{Context, bail};
use crate::frame_cost_report::{self as report, Cfg, LevelResult, RunStats};
use crate::out::{bar, print_stdout, write_atomic};
use crate::{BenchArgs, CORNER_BUNNY, OCCLUDED, Result, SUN};

/// Default frame sizes: the two (issue 51, item 4).
const SIZES: [(u32, u32); 2] = [(480, 270), (1280, 720)];
/// The frame size of `--quick`.
const QUICK_SIZE: (u32, u32) = (160, 90);

/// A gibake binary and the flags its `bake` and `render` accept.
pub(crate) struct Binary {
    pub(crate) path: PathBuf,
    pub(crate) name: String,
    bake_flags: BTreeSet<String>,
    render_flags: BTreeSet<String>,
}

/// The `--flag` names in a `--help` text.
fn flags_of(help: &str) -> BTreeSet<String> {
    let mut out = BTreeSet::new();
    for (i, _) in help.match_indices("--") {
        let rest = &help[i + 2..];
        let name: String = rest
            .chars()
            .take_while(|c| c.is_ascii_alphanumeric() || *c == '-')
            .collect();
        if name.chars().next().is_some_and(|c| c.is_ascii_alphabetic()) {
            out.insert(format!("--{name}"));
        }
    }
    out
}

/// Runs `bin ARGS` and returns its stdout, or why it failed (the last lines
/// of its stderr).
fn run_tool(bin: &Path, args: &[OsString]) -> std::result::Result<String, String> {
    let out = Command::new(bin)
        .args(args)
        .output()
        .map_err(|e| format!("cannot run it: {e}"))?;
    if out.status.success() {
        return Ok(String::from_utf8_lossy(&out.stdout).into_owned());
    }
    let stderr = String::from_utf8_lossy(&out.stderr);
    let last: Vec<&str> = stderr
        .lines()
        .map(str::trim)
        .filter(|l| !l.is_empty() && !l.contains("XDG_RUNTIME_DIR"))
        .collect();
    let tail = last[last.len().saturating_sub(2)..].join(" / ");
    Err(match out.status.code() {
        Some(c) => format!("exit code {c}: {tail}"),
        None => format!("killed by a signal ({}): {tail}", out.status),
    })
}

impl Binary {
    /// Reads what `path` accepts from its `--help`; an error when it is not
    /// a gibake binary or does not run.
    pub(crate) fn probe(path: &Path, name: String, what: &str) -> Result<Binary> {
        if !path.is_file() {
            bail!("{what} {}: no such file", path.display());
        }
        let help = |args: &[&str]| -> Result<String> {
            let args: Vec<OsString> = args.iter().map(OsString::from).collect();
            run_tool(path, &args).map_err(|e| {
                crate::BenchError::Invalid(format!(
                    "{what} {}: not a working gibake binary (`{}` failed: {e})",
                    path.display(),
                    std::iter::once("gibake")
                        .chain(args.iter().filter_map(|a| a.to_str()))
                        .collect::<Vec<_>>()
                        .join(" ")
                ))
            })
        };
        let top = help(&["--help"])?;
        let lists = |cmd: &str| {
            top.lines()
                .any(|l| l.split_whitespace().next() == Some(cmd))
        };
        if !top.contains("gibake") || !lists("bake") || !lists("render") {
            bail!(
                "{what} {}: not a gibake binary (its --help names no `gibake` with `bake` and `render` commands)",
                path.display()
            );
        }
        Ok(Binary {
            bake_flags: flags_of(&help(&["bake", "--help"])?),
            render_flags: flags_of(&help(&["render", "--help"])?),
            path: path.to_path_buf(),
            name,
        })
    }

    /// The first flag `level` needs that this binary lacks, as a sentence.
    fn missing(&self, level: &Level, a: &BenchArgs) -> Option<String> {
        let f = &a.frame;
        let mut bake = level.scene_flag_names();
        let mut render = bake.clone();
        if level.look_at.is_some() {
            render.extend(["--look-at", "--time"]);
        }
        render.extend(["--stats", "--frames", "--width", "--height", "--ssaa"]);
        if f.interleave.is_some() {
            render.push("--interleave");
        }
        if a.vpls.is_some() {
            bake.push("--vpls");
        }
        if a.adapter.is_some() {
            bake.push("--adapter");
            render.push("--adapter");
        }
        bake.push("--output");
        for (cmd, need, have) in [
            ("bake", &bake, &self.bake_flags),
            ("render", &render, &self.render_flags),
        ] {
            if let Some(m) = need.iter().find(|n| !have.contains(**n)) {
                return Some(format!("its `{cmd}` has no {m}"));
            }
        }
        None
    }
}

/// A level to measure: a file and the flags a user gives it.
pub(crate) struct Level {
    pub(crate) name: String,
    /// "real level" or "bundled scene".
    pub(crate) kind: &'static str,
    path: PathBuf,
    sun: Option<LevelSun>,
    dynamic: Vec<String>,
    look_at: Option<LevelCamera>,
    bake_volume: Option<[f32; 6]>,
    time: f32,
    /// Moving balls of levels.json (an engine's, not the command line's:
    /// neither binary renders them).
    pub(crate) balls: usize,
}

impl Level {
    fn scene_flag_names(&self) -> Vec<&'static str> {
        let mut v = Vec::new();
        if self.sun.is_some() {
            v.extend(["--sun", "--sun-irradiance"]);
        }
        if !self.dynamic.is_empty() {
            v.push("--dynamic");
        }
        if self.bake_volume.is_some() {
            v.push("--bake-volume");
        }
        v
    }

    /// `--sun`, `--dynamic`, `--bake-volume` (bake and render).
    fn scene_flags(&self) -> Vec<OsString> {
        let mut v: Vec<String> = Vec::new();
        if let Some(s) = self.sun {
            v.push(format!("--sun={},{}", s.azimuth, s.elevation));
            v.push(format!("--sun-irradiance={}", s.irradiance));
        }
        for d in &self.dynamic {
            v.push(format!("--dynamic={d}"));
        }
        if let Some(b) = self.bake_volume {
            v.push(format!(
                "--bake-volume={},{},{},{},{},{}",
                b[0], b[1], b[2], b[3], b[4], b[5]
            ));
        }
        v.into_iter().map(OsString::from).collect()
    }

    /// The scene flags and the camera (render).
    fn render_flags(&self) -> Vec<OsString> {
        let mut v = self.scene_flags();
        if let Some(c) = self.look_at {
            v.push(
                format!(
                    "--look-at={},{},{},{},{},{},{}",
                    c.eye[0], c.eye[1], c.eye[2], c.target[0], c.target[1], c.target[2], c.fov
                )
                .into(),
            );
            v.push(format!("--time={}", self.time).into());
        }
        v
    }
}

/// The bundled scenes (embedded in this binary, written into the work
/// directory), in the default order.
const BUNDLED: [(&str, &[u8]); 3] = [
    ("corner_bunny", CORNER_BUNNY),
    ("occluded", OCCLUDED),
    ("sun", SUN),
];

/// The levels `names` asks for (all, when empty): the bundled scenes, then
/// every level of data/levels/levels.json.
fn levels(names: &[String], list: Option<&Path>, work: &Path) -> Result<Vec<Level>> {
    let list = list.map_or_else(gibake_eval::levels::bundled_list, Path::to_path_buf);
    let dir = list.parent().unwrap_or(Path::new(".")).to_path_buf();
    let specs = gibake_eval::levels::read_specs(&list)
        .map_err(|e| crate::BenchError::Invalid(format!("the level list: {e}")))?;
    let mut all: Vec<Level> = Vec::new();
    for (name, bytes) in BUNDLED {
        let path = work.join("scenes").join(format!("{name}.glb"));
        if std::fs::read(&path).ok().as_deref() != Some(bytes) {
            std::fs::create_dir_all(path.parent().unwrap_or(work))
                .with_context(|| format!("creating {}", work.join("scenes").display()))?;
            write_atomic(&path, bytes)?;
        }
        all.push(Level {
            name: name.to_string(),
            kind: "bundled scene",
            path,
            sun: None,
            dynamic: Vec::new(),
            look_at: None,
            bake_volume: None,
            time: 0.0,
            balls: 0,
        });
    }
    for s in specs {
        let path = s.path(&dir);
        all.push(Level {
            name: s.name.clone(),
            kind: "real level",
            path,
            sun: s.sun,
            dynamic: s.dynamic.clone(),
            look_at: Some(s.camera),
            bake_volume: s.bake_volume,
            time: s.time,
            balls: s.balls.len(),
        });
    }
    let chosen = if names.is_empty() {
        all
    } else {
        let mut chosen = Vec::new();
        for n in names {
            let Some(i) = all.iter().position(|l| &l.name == n) else {
                bail!(
                    "--levels: no level {n:?} (known: {})",
                    all.iter()
                        .map(|l| l.name.as_str())
                        .collect::<Vec<_>>()
                        .join(", ")
                );
            };
            chosen.push(all.remove(i));
        }
        chosen
    };
    for l in &chosen {
        if !l.path.is_file() {
            bail!("level {}: {}: no such file", l.name, l.path.display());
        }
    }
    Ok(chosen)
}

/// Reads one render's stats file: per-pass medians over frames 2..N.
fn read_stats(path: &Path) -> Result<RunStats> {
    let text =
        std::fs::read_to_string(path).with_context(|| format!("reading {}", path.display()))?;
    let v: Value = serde_json::from_str(&text).with_context(|| format!("{}", path.display()))?;
    let bad = |what: &str| crate::BenchError::Invalid(format!("{}: {what}", path.display()));
    let frames = v["frames"]
        .as_array()
        .ok_or_else(|| bad("no `frames` array"))?;
    if frames.len() < 2 {
        return Err(bad("fewer than 2 frames"));
    }
    let mut per_frame: Vec<Vec<(String, f64)>> = Vec::new();
    for f in &frames[1..] {
        let passes = f["passes_ms"]
            .as_array()
            .ok_or_else(|| bad("a frame without `passes_ms`"))?;
        let mut row = Vec::new();
        for p in passes {
            let (Some(n), Some(ms)) = (p["pass"].as_str(), p["ms"].as_f64()) else {
                return Err(bad("a pass without `pass` and `ms`"));
            };
            row.push((n.to_string(), ms));
        }
        per_frame.push(row);
    }
    Ok(RunStats::from_frames(
        &per_frame,
        frames[0]["timing"].as_str().unwrap_or("?").to_string(),
        v["adapter"].as_str().unwrap_or("?").to_string(),
        frames[0]["static_vpls"].as_u64(),
        v["interleave"].as_u64(),
    ))
}

/// Runs `gibake bench frame`.
pub(crate) fn run(a: &BenchArgs) -> Result<()> {
    let f = &a.frame;
    let Some(base_path) = &f.baseline else {
        bail!(
            "`gibake bench frame` needs --baseline BIN: an earlier gibake binary \
             (scripts/bench-frame.sh builds the pinned commit's), or this one for a smoke run"
        );
    };
    if a.frames < 2 {
        bail!(
            "--frames must be at least 2 for `frame` (the first frame of each render is a warm-up)"
        );
    }
    let reps = f.reps.unwrap_or(if a.quick { 2 } else { 3 });
    if reps == 0 {
        bail!("--reps must be at least 1");
    }
    if let Some(i) = f.interleave
        && ![1, 2, 4, 8].contains(&i)
    {
        bail!("--interleave must be 1, 2, 4 or 8, got {i}");
    }
    let sizes: Vec<(u32, u32)> = if !f.size.is_empty() {
        f.size.clone()
    } else if a.quick {
        vec![QUICK_SIZE]
    } else {
        SIZES.to_vec()
    };
    let me = std::env::current_exe().context_io("finding this binary")?;
    let today = Binary::probe(&me, "today".into(), "this binary")?;
    let base_name = f.baseline_name.clone().unwrap_or_else(|| {
        base_path
            .file_name()
            .map(|n| n.to_string_lossy().into_owned())
            .unwrap_or_else(|| "baseline".into())
    });
    let baseline = Binary::probe(base_path, base_name, "--baseline")?;
    let same = match (me.canonicalize(), base_path.canonicalize()) {
        (Ok(x), Ok(y)) => x == y,
        _ => false,
    };
    let work = f.work.clone().unwrap_or_else(|| a.out.join("frame-work"));
    for d in [
        "assets/today",
        "assets/today-b1",
        "assets/baseline",
        "frames",
        "stats",
    ] {
        std::fs::create_dir_all(work.join(d))
            .with_context(|| format!("creating {}", work.join(d).display()))?;
    }
    let levels = levels(&f.levels, f.level_list.as_deref(), &work)?;
    let mut common: Vec<OsString> = Vec::new();
    if let Some(ad) = &a.adapter {
        common.push(format!("--adapter={ad}").into());
    }
    let bakes = levels.len() as u64 * 3;
    let renders = levels.len() as u64 * sizes.len() as u64 * u64::from(reps) * 3;
    let pb = bar(bakes + renders, "frame");
    let mut results: Vec<LevelResult> = Vec::new();
    for level in &levels {
        let asset = |dir: &str| {
            work.join("assets")
                .join(dir)
                .join(format!("{}.gibake", level.name))
        };
        let bake = |bin: &Binary, out: &Path, bounces1: bool| {
            pb.set_message(format!("{}: bake ({})", level.name, bin.name));
            let mut args: Vec<OsString> = vec!["bake".into(), level.path.clone().into()];
            args.push("--output".into());
            args.push(out.into());
            if bounces1 {
                args.push("--bounces=1".into());
            }
            if let Some(n) = a.vpls {
                args.push(format!("--vpls={n}").into());
            }
            args.extend(level.scene_flags());
            args.extend(common.iter().cloned());
            let r = run_tool(&bin.path, &args);
            pb.inc(1);
            r
        };
        let b_today = asset("today");
        let b_b1 = asset("today-b1");
        let b_base = if same {
            b_today.clone()
        } else {
            asset("baseline")
        };
        bake(&today, &b_today, false).map_err(|e| {
            crate::BenchError::Invalid(format!(
                "baking {} with this binary: {e}",
                level.path.display()
            ))
        })?;
        bake(&today, &b_b1, true).map_err(|e| {
            crate::BenchError::Invalid(format!(
                "baking {} with this binary (--bounces 1): {e}",
                level.path.display()
            ))
        })?;
        let mut fallback: Option<String> = baseline.missing(level, a);
        if fallback.is_none() && !same {
            if let Err(e) = bake(&baseline, &b_base, false) {
                fallback = Some(format!("its bake failed ({e})"));
            }
        } else {
            pb.inc(1);
        }
        for &(w, h) in &sizes {
            let mut runs: [Vec<RunStats>; 3] = [Vec::new(), Vec::new(), Vec::new()];
            for rep in 0..reps {
                let mut order = Cfg::ALL;
                order.rotate_left(rep as usize % 3);
                for cfg in order {
                    if cfg == Cfg::Baseline && fallback.is_some() {
                        pb.inc(1);
                        continue;
                    }
                    let (bin, asset) = match cfg {
                        Cfg::Baseline => (&baseline, &b_base),
                        Cfg::Today => (&today, &b_today),
                        Cfg::TodayB1 => (&today, &b_b1),
                    };
                    pb.set_message(format!(
                        "{} {w}×{h}: {} (rep {})",
                        level.name,
                        cfg.label(&baseline.name),
                        rep + 1
                    ));
                    let stats = work.join("stats").join(format!(
                        "{}_{w}x{h}_ssaa{}_{}_r{}.json",
                        level.name,
                        f.ssaa,
                        cfg.file_tag(),
                        rep + 1
                    ));
                    let _ = std::fs::remove_file(&stats);
                    let mut args: Vec<OsString> = vec![
                        "render".into(),
                        level.path.clone().into(),
                        "--bake".into(),
                        asset.into(),
                        format!("--width={w}").into(),
                        format!("--height={h}").into(),
                        format!("--ssaa={}", f.ssaa).into(),
                        format!("--frames={}", a.frames).into(),
                        "--output".into(),
                        work.join("frames")
                            .join(format!("{}.exr", cfg.file_tag()))
                            .into(),
                        "--stats".into(),
                        stats.clone().into(),
                    ];
                    if let Some(i) = f.interleave {
                        args.push(format!("--interleave={i}").into());
                    }
                    args.extend(level.render_flags());
                    args.extend(common.iter().cloned());
                    let r = run_tool(&bin.path, &args).map_err(|e| e.to_string());
                    pb.inc(1);
                    let parsed = r.and_then(|_| read_stats(&stats).map_err(|e| e.to_string()));
                    match (parsed, cfg) {
                        (Ok(s), _) => runs[cfg as usize].push(s),
                        (Err(e), Cfg::Baseline) => {
                            fallback = Some(format!("its render failed ({e})"));
                            runs[0].clear();
                        }
                        (Err(e), _) => bail!(
                            "rendering {} at {w}×{h} with this binary ({}): {e}",
                            level.path.display(),
                            cfg.label(&baseline.name)
                        ),
                    }
                }
            }
            results.push(LevelResult::new(level, (w, h), &runs, fallback.clone()));
        }
    }
    pb.finish_and_clear();
    let setup = report::Setup {
        today: today.path.display().to_string(),
        baseline: baseline.path.display().to_string(),
        baseline_name: baseline.name.clone(),
        same_binary: same,
        frames: a.frames,
        reps,
        ssaa: f.ssaa,
        interleave: f.interleave,
        vpls: a.vpls,
    };
    let md = report::markdown(&setup, &results);
    print_stdout(&md);
    if let Some(p) = &f.markdown {
        write_atomic(p, md.as_bytes())?;
    }
    if let Some(p) = &f.json {
        write_atomic(
            p,
            serde_json::to_string_pretty(&report::json(&setup, &results))?.as_bytes(),
        )?;
    }
    Ok(())
}

/// `?` on an I/O result with a step named.
trait IoContext<T> {
    fn context_io(self, what: &str) -> Result<T>;
}

impl<T> IoContext<T> for std::io::Result<T> {
    fn context_io(self, what: &str) -> Result<T> {
        self.with_context(|| what.to_string())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn flags_are_read_from_help_text() {
        let f = flags_of(
            "  --sun <AZ,EL>  the sun\n  -o, --output <OUT>\n      --look-at <..>  (--sun-irradiance too)\n --  x\n",
        );
        assert!(f.contains("--sun") && f.contains("--output") && f.contains("--look-at"));
        assert!(f.contains("--sun-irradiance"));
        assert_eq!(f.len(), 4, "{f:?}");
    }
}
