//! `gibake bench`'s options: the clap arguments of the subcommand (the
//! binary parses them; this crate runs what they name).

use std::path::PathBuf;

use clap::{Args, ValueEnum};

/// `gibake bench`.
#[derive(Args, Debug)]
pub struct BenchArgs {
    /// Which benchmarks (comma-separated): `bake` (bake time per stage),
    /// `runtime` (per-frame update of full against naive, asset load),
    /// `table1` (the paper's Table 1), `pipeline` (an up-to-date check
    /// against the bake it skips), `quality` (error against run time for
    /// every mode and setting, Pareto front), `interleave` (interleave N
    /// against 1 side by side), `scaling` (growth exponents), `accuracy`
    /// (indirect bias on bundled and random scenes), or `all` (default:
    /// every table and plot of docs/results.md). `frame` (per-pass frame
    /// cost of this binary against `--baseline BIN`, an earlier gibake, on
    /// the bundled levels) runs on its own and is not part of `all`.
    #[arg(value_enum, value_delimiter = ',', default_values_t = [BenchWhich::All])]
    pub which: Vec<BenchWhich>,
    /// Directory for the Markdown report, the JSON and the PNG plots.
    #[arg(long, default_value = "bench-out", value_name = "DIR")]
    pub out: PathBuf,
    /// Frames measured per runtime configuration, after one warm-up frame
    /// (naive: at most 2; Table 1: at most 2; interleave: at most 4;
    /// scaling: at most 3; --quick: at most 2). `frame`: frames per render,
    /// the first a warm-up (at least 2).
    #[arg(long, default_value_t = 3, value_name = "N")]
    pub frames: u32,
    /// A fast smoke run: fewer runs, frames, settings, smaller images and
    /// fewer samples (seconds, not minutes).
    #[arg(long)]
    pub quick: bool,
    /// Scene of the bake benchmark (default: the bundled corner_bunny, embedded).
    #[arg(long, value_name = "SCENE")]
    pub scene: Option<PathBuf>,
    /// Random scenes (seeds 0..N) of the accuracy benchmark.
    #[arg(long, default_value_t = 4, value_name = "N")]
    pub seeds: u64,
    /// Bundled scenes of the quality and interleave benchmarks (comma-separated).
    #[arg(long, value_enum, value_delimiter = ',', default_values_t = [BenchScene::CornerBunny, BenchScene::Occluded, BenchScene::Sun])]
    pub scenes: Vec<BenchScene>,
    /// Random scenes (`gibake_scenegen::random`, seeds 0..N) added to the
    /// quality benchmark's scenes.
    #[arg(long, default_value_t = 1, value_name = "N")]
    pub random_scenes: u64,
    /// Static VPL budget of the interleave benchmark (default 664) and of
    /// `frame`'s bakes (default: each binary's own default budget).
    #[arg(long, value_name = "N")]
    pub vpls: Option<u32>,
    /// Image size of the Table 1 benchmark (the paper's: 1280x720).
    #[arg(long, default_value = "320x180", value_name = "WxH", value_parser = parse_size)]
    pub table1_size: (u32, u32),
    /// Samples per pixel of the quality and interleave benchmarks'
    /// reference (default 1024; 128 with --quick).
    #[arg(long, value_name = "N")]
    pub ref_spp: Option<u32>,
    /// Static-detail multiplier of the runtime benchmark's heavy corner_bunny variant.
    #[arg(long, default_value_t = 20, value_name = "N")]
    pub heavy: u32,
    /// GPU adapter to use (substring of its name; `frame` passes it to
    /// both binaries).
    #[arg(long)]
    pub adapter: Option<String>,
    /// `frame`'s options.
    #[command(flatten)]
    pub frame: FrameArgs,
}

/// The options of `gibake bench frame` (ignored by the other benchmarks).
#[derive(Args, Debug, Clone)]
#[command(next_help_heading = "Options of `gibake bench frame`")]
pub struct FrameArgs {
    /// The earlier gibake binary to compare with (e.g. one built from a
    /// pinned commit: scripts/bench-frame.sh builds c2145de's). Its command
    /// line is read from its `--help`; a level it cannot bake or render is
    /// compared with this binary's `--bounces 1` instead, and the table
    /// says so. This binary itself is accepted (a smoke run).
    #[arg(long, value_name = "BIN")]
    pub baseline: Option<PathBuf>,
    /// The baseline's name in the tables (default: its file name), e.g. a
    /// commit.
    #[arg(long, value_name = "NAME")]
    pub baseline_name: Option<String>,
    /// Levels (comma-separated): names of data/levels/levels.json and the
    /// bundled scenes `corner_bunny`, `occluded`, `sun`. Default: the
    /// bundled scenes, then every real level.
    #[arg(long, value_delimiter = ',', value_name = "NAME,...")]
    pub levels: Vec<String>,
    /// The level list (default: data/levels/levels.json of the source tree
    /// this binary was built from).
    #[arg(long, value_name = "FILE")]
    pub level_list: Option<PathBuf>,
    /// Frame sizes (comma-separated WxH; default 480x270,1280x720, with
    /// --quick 160x90).
    #[arg(long, value_delimiter = ',', value_name = "WxH,...", value_parser = parse_size)]
    pub size: Vec<(u32, u32)>,
    /// Repetitions: each renders every configuration once, in an order
    /// that rotates (baseline, today, today --bounces 1, then today, ...),
    /// so that machine load hits them alike (default 3; --quick 2).
    #[arg(long, value_name = "N")]
    pub reps: Option<u32>,
    /// Supersampling of every render (`gibake render --ssaa`; the frame is
    /// WxH × N²). 1 (default) renders the frame size itself, as a game does.
    #[arg(long, default_value_t = 1, value_name = "N", value_parser = clap::value_parser!(u32).range(1..=8))]
    pub ssaa: u32,
    /// `gibake render --interleave N` for every render (default: each
    /// binary's `auto`).
    #[arg(long, value_name = "N")]
    pub interleave: Option<u32>,
    /// Where the assets (reused while up to date), frames and stats files
    /// go (default: DIR/frame-work of --out).
    #[arg(long, value_name = "DIR")]
    pub work: Option<PathBuf>,
    /// Also write the tables as Markdown to this file.
    #[arg(long, value_name = "FILE.md")]
    pub markdown: Option<PathBuf>,
    /// Also write every figure as JSON to this file.
    #[arg(long, value_name = "FILE.json")]
    pub json: Option<PathBuf>,
}

/// Parses `WxH` (e.g. `1280x720`).
pub(crate) fn parse_size(s: &str) -> Result<(u32, u32), String> {
    let (w, h) = s
        .split_once(['x', '×'])
        .ok_or_else(|| format!("{s:?} is not WxH (e.g. 1280x720)"))?;
    let n = |v: &str| {
        v.trim()
            .parse::<u32>()
            .ok()
            .filter(|n| (1..=16384).contains(n))
            .ok_or_else(|| format!("{s:?}: {v:?} is not a size from 1 to 16384"))
    };
    Ok((n(w)?, n(h)?))
}

/// The sub-benchmarks of `gibake bench`.
#[derive(ValueEnum, Clone, Copy, Debug, PartialEq, Eq)]
pub enum BenchWhich {
    /// Bake time per stage (250 and 664 VPLs, median of 3).
    Bake,
    /// Per-frame update, full against naive; asset load.
    Runtime,
    /// The paper's Table 1 (250/664 static × 0/13/41 dynamic VPLs,
    /// interleave 1 and 4) at --table1-size.
    Table1,
    /// An up-to-date check against the bake it skips, per bundled scene.
    Pipeline,
    /// Error (rel MSE, FLIP; whole image and indirect part) against run
    /// time for every mode, VPL budget, map size and interleave, with the
    /// Pareto front.
    Quality,
    /// Interleave 2/4/8 against 1, side by side: shade time and error ratios.
    Interleave,
    /// Scaling sweeps with fitted growth exponents.
    Scaling,
    /// Indirect light against the reference: mean bias per channel and full's
    /// against rsm's error, on the bundled scenes and --seeds random ones.
    Accuracy,
    /// Per-pass frame cost of this binary against `--baseline BIN` (an
    /// earlier gibake) and against its own `--bounces 1`, on the bundled
    /// levels at --size, side by side (not part of `all`; runs alone).
    Frame,
    /// All of them (but `frame`).
    All,
}

/// The bundled scenes the quality benchmark can use.
#[derive(ValueEnum, Clone, Copy, Debug, PartialEq, Eq)]
pub enum BenchScene {
    /// The paper's corner with the bunny and 13 balls (spot light).
    #[value(name = "corner_bunny")]
    CornerBunny,
    /// Coloured panels hidden behind a wall (the paper's Fig. 10).
    Occluded,
    /// A directional light over blocks.
    Sun,
}
