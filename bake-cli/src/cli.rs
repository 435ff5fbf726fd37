//! Command-line arguments (clap derive). The subcommand and flag names are
//! fixed by the design brief.

use std::path::PathBuf;

use clap::{Args, Parser, Subcommand, ValueEnum};

/// gibake bakes the light that static geometry bounces (virtual point
/// lights with per-light shadow maps) and, at run time, adds only what moving
/// objects change. Scenes are glTF 2.0 files with one KHR_lights_punctual spot
/// or directional light; see docs/method.md for the conventions.
#[derive(Parser, Debug)]
#[command(name = "gibake", version, about, long_about = None, propagate_version = true)]
pub struct Cli {
    /// Log progress details to stderr (also: GIBAKE_LOG=info|debug).
    #[arg(short, long, global = true)]
    pub verbose: bool,
    /// Memory budget (bytes; suffixes K, M, G, T) for a bake's estimated
    /// peak and for the maps an asset decodes to. Default: 2G, or half the
    /// available memory when that is less.
    #[arg(long, global = true, value_name = "BYTES", value_parser = crate::limits::parse_size)]
    pub max_memory: Option<u64>,
    /// The command.
    #[command(subcommand)]
    pub command: Command,
}

/// Scene input shared by the commands that read a glTF.
#[derive(Args, Debug, Clone)]
pub struct SceneArgs {
    /// The glTF 2.0 scene (.gltf or .glb).
    pub scene: PathBuf,
    /// Pick the primary light by name when the scene has several.
    #[arg(long, value_name = "NAME")]
    pub light: Option<String>,
    /// Import budgets.
    #[command(flatten)]
    pub limits: crate::limits::LimitArgs,
}

/// The commands.
#[derive(Subcommand, Debug)]
pub enum Command {
    /// Bake VPLs and their hemisphere shadow maps into OUT.gibake/.
    Bake(BakeArgs),
    /// Render frames of a scene on the GPU.
    Render(RenderArgs),
    /// Render the independent CPU reference (path tracer, direct + one bounce).
    Reference(ReferenceArgs),
    /// Compare two baked assets: exit 0 equal (within tolerance), 1 different, 2 bad input.
    Diff(DiffArgs),
    /// Describe a baked asset: counts, sizes, settings, provenance, VPL flux.
    Inspect(InspectArgs),
    /// Join the parts of a sharded bake (`bake --shard K/N`) into the asset
    /// the single-machine bake writes, byte for byte.
    Merge(MergeArgs),
    /// Measure: bake time per stage, per-frame update of full vs naive,
    /// Table 1, and error against run time for every mode and quality.
    Bench(BenchArgs),
    /// The embedded default: bake the bundled paper scene (corner + bunny +
    /// 13 moving balls), render a short animation, print per-pass times and
    /// the error against the CPU reference.
    Demo(DemoArgs),
}

/// `gibake bake`.
#[derive(Args, Debug)]
#[command(group(clap::ArgGroup::new("out").required(true).args(["output", "out_dir"])))]
pub struct BakeArgs {
    /// The glTF 2.0 scene(s) (.gltf or .glb). Several scenes need --out-dir
    /// (a batch: each is baked into DIR/NAME.gibake, NAME = the file stem).
    #[arg(required = true, value_name = "SCENE")]
    pub scenes: Vec<PathBuf>,
    /// Pick the primary light by name when the scene has several.
    #[arg(long, value_name = "NAME")]
    pub light: Option<String>,
    /// Import budgets.
    #[command(flatten)]
    pub limits: crate::limits::LimitArgs,
    /// Output asset directory (NAME.gibake) of one scene; with --shard, the
    /// shard's part file. An existing asset is left untouched when it is up
    /// to date (see --force) and replaced otherwise.
    #[arg(short, long, value_name = "OUT.gibake")]
    pub output: Option<PathBuf>,
    /// Batch: bake every SCENE into DIR/NAME.gibake (DIR is created). A
    /// scene that fails is named and the others are still baked; the exit
    /// code is 2 if any failed.
    #[arg(long, value_name = "DIR", conflicts_with = "output")]
    pub out_dir: Option<PathBuf>,
    /// Re-bake even when the existing asset is up to date (same static-scene
    /// hash, settings, baker version and adapter).
    #[arg(long)]
    pub force: bool,
    /// Bake shard K of N (0-based, K in 0..N) of a distributed bake: the
    /// shared front part (shadow map, RSM, clusters) and the hemisphere maps
    /// of the K-th of N equal runs of VPLs, into the part file -o PART.
    /// `gibake merge` joins the N parts into the single bake's bytes.
    #[arg(long, value_name = "K/N", value_parser = parse_shard, conflicts_with = "out_dir")]
    pub shard: Option<(u32, u32)>,
    /// Number of VPLs to make (the result has N ± 2%). Default 256 unless --threshold is given.
    #[arg(long, value_name = "N", conflicts_with = "threshold")]
    pub vpls: Option<u32>,
    /// Quadtree split threshold (dimensionless; smaller → more VPLs).
    #[arg(long, value_name = "X")]
    pub threshold: Option<f32>,
    /// Reflective shadow map resolution.
    #[arg(long, default_value_t = 512, value_name = "N")]
    pub rsm_size: u32,
    /// Hemisphere shadow map resolution per VPL.
    #[arg(long, default_value_t = 128, value_name = "N")]
    pub vpl_map_size: u32,
    /// Primary shadow map resolution.
    #[arg(long, default_value_t = 2048, value_name = "N")]
    pub shadow_map_size: u32,
    /// Print the summary as JSON on stdout: the decision ("baked" or
    /// "up_to_date") and why, counts, per-stage times, the import's
    /// warnings; a batch gives one entry per scene and the failed scenes
    /// (see docs/pipeline.md).
    #[arg(long)]
    pub json: bool,
    /// GPU adapter to use (substring of its name).
    #[arg(long)]
    pub adapter: Option<String>,
}

/// Parses `K/N` (0-based shard K of N).
fn parse_shard(s: &str) -> Result<(u32, u32), String> {
    let (k, n) = s
        .split_once('/')
        .ok_or_else(|| format!("`{s}` is not K/N (for example 0/4)"))?;
    let k: u32 = k
        .trim()
        .parse()
        .map_err(|_| format!("`{s}`: K is not a whole number"))?;
    let n: u32 = n
        .trim()
        .parse()
        .map_err(|_| format!("`{s}`: N is not a whole number"))?;
    let max = gibake_asset::MAX_SHARDS;
    if n == 0 || n > max {
        return Err(format!("`{s}`: N must be in 1..={max}"));
    }
    if k >= n {
        return Err(format!(
            "`{s}`: K must be in 0..{n} (shards are numbered from 0)"
        ));
    }
    Ok((k, n))
}

/// `gibake merge`.
#[derive(Args, Debug)]
pub struct MergeArgs {
    /// The part files of every shard, in any order (each exactly once).
    #[arg(required = true, value_name = "PART")]
    pub parts: Vec<PathBuf>,
    /// The merged asset directory (NAME.gibake); an existing asset is replaced.
    #[arg(short, long, value_name = "OUT.gibake")]
    pub output: PathBuf,
    /// Print a summary as JSON on stdout.
    #[arg(long)]
    pub json: bool,
}

/// Render modes.
#[derive(ValueEnum, Clone, Copy, Debug, PartialEq, Eq)]
pub enum ModeArg {
    /// The method: direct + static VPLs with merged maps + dynamic VPLs.
    Full,
    /// Direct light from the primary light only.
    Direct,
    /// The indirect part of `full` only.
    Indirect,
    /// Dachsbacher's RSM: every VPL, no visibility.
    Rsm,
    /// Re-render every VPL map from all geometry every frame (cost baseline).
    Naive,
}

/// `gibake render`.
#[derive(Args, Debug)]
pub struct RenderArgs {
    /// Scene.
    #[command(flatten)]
    pub scene: SceneArgs,
    /// The baked asset (needed by every mode but `direct`, which renders its
    /// own static shadow map without one).
    #[arg(long, value_name = "OUT.gibake")]
    pub bake: Option<PathBuf>,
    /// Animation time in seconds (each animation is clamped to its range).
    #[arg(long, default_value_t = 0.0)]
    pub time: f32,
    /// Output width in pixels.
    #[arg(long, default_value_t = 640)]
    pub width: u32,
    /// Output height in pixels.
    #[arg(long, default_value_t = 480)]
    pub height: u32,
    /// What to render.
    #[arg(long, value_enum, default_value_t = ModeArg::Full)]
    pub mode: ModeArg,
    /// Output: .exr (linear radiance, R G B f32) or .png (tone-mapped preview).
    /// With --frames, a `#` run in the name is replaced by the frame number.
    #[arg(short, long, value_name = "FRAME.exr|FRAME.png")]
    pub output: PathBuf,
    /// Number of frames (a sequence starting at --time, 1/fps apart).
    #[arg(long, default_value_t = 1)]
    pub frames: u32,
    /// Frames per second of a sequence.
    #[arg(long, default_value_t = 30.0)]
    pub fps: f32,
    /// Write per-pass timings and counts as JSON.
    #[arg(long, value_name = "FILE.json")]
    pub stats: Option<PathBuf>,
    /// Supersampling: render at N× the resolution and box-filter down.
    #[arg(long, default_value_t = 2, value_parser = clap::value_parser!(u32).range(1..=8))]
    pub ssaa: u32,
    /// Primary shadow map resolution.
    #[arg(long, default_value_t = 2048)]
    pub shadow_map_size: u32,
    /// Most dynamic VPLs (moving surfaces bouncing light) per frame, rounded
    /// up to a power of 4; 0 turns them off. Fewer, larger clusters lose
    /// light next to the moving objects (docs/method.md, "Near field").
    #[arg(long, default_value_t = 256, value_name = "N")]
    pub max_dynamic_vpls: u32,
    /// Interleaved VPL sampling: each pixel of an N×N block shades a disjoint
    /// 1/N² of the VPLs and a geometry-aware filter reconstructs the sum
    /// (1: every pixel shades every VPL). `auto` (the default): 4 from 256²
    /// pixels on, else 1 (measured in docs/results.md, "Interleaved VPL
    /// sampling"). Applies at the supersampled resolution.
    #[arg(long, default_value = "auto", value_name = "N|auto", value_parser = interleave_value)]
    pub interleave: u32,
    /// GPU adapter to use (substring of its name; default: GIBAKE_ADAPTER or the first real GPU).
    #[arg(long)]
    pub adapter: Option<String>,
}

/// `gibake reference`.
#[derive(Args, Debug)]
pub struct ReferenceArgs {
    /// Scene.
    #[command(flatten)]
    pub scene: SceneArgs,
    /// Animation time in seconds.
    #[arg(long, default_value_t = 0.0)]
    pub time: f32,
    /// Output width in pixels.
    #[arg(long, default_value_t = 640)]
    pub width: u32,
    /// Output height in pixels.
    #[arg(long, default_value_t = 480)]
    pub height: u32,
    /// Samples per pixel.
    #[arg(long, default_value_t = 256)]
    pub spp: u32,
    /// Direct light only (path depth 2) instead of direct + one bounce.
    #[arg(long)]
    pub direct_only: bool,
    /// Random seed (the image is deterministic for a given seed).
    #[arg(long, default_value_t = 0)]
    pub seed: u64,
    /// Output EXR (linear radiance) or PNG preview.
    #[arg(short, long, value_name = "REF.exr")]
    pub output: PathBuf,
}

/// `gibake diff`.
#[derive(Args, Debug)]
pub struct DiffArgs {
    /// First asset.
    pub a: PathBuf,
    /// Second asset.
    pub b: PathBuf,
    /// Machine-readable output.
    #[arg(long)]
    pub json: bool,
    /// Tolerance preset: `same-machine` (exact) or `another-gpu` (small
    /// relative differences and a few texels allowed). See docs/asset-format.md.
    #[arg(long, value_enum, default_value_t = TolerancePreset::SameMachine)]
    pub tolerance: TolerancePreset,
    /// Relative tolerance per map texel (overrides the preset).
    /// A finite number from 0 to 1.
    #[arg(long, value_name = "REL", value_parser = crate::limits::tolerance_f32("--map-rel"))]
    pub map_rel: Option<f32>,
    /// Allowed fraction of map texels over tolerance (overrides the preset),
    /// from 0 to 1.
    #[arg(long, value_name = "FRACTION", value_parser = crate::limits::tolerance_f64("--max-texels-over"))]
    pub max_texels_over: Option<f64>,
    /// VPL position tolerance, relative to the scene diagonal (overrides the
    /// preset), from 0 to 1.
    #[arg(long, value_name = "REL", value_parser = crate::limits::tolerance_f32("--vpl-position-rel"))]
    pub vpl_position_rel: Option<f32>,
    /// VPL flux tolerance, relative (overrides the preset), from 0 to 1.
    #[arg(long, value_name = "REL", value_parser = crate::limits::tolerance_f32("--vpl-flux-rel"))]
    pub vpl_flux_rel: Option<f32>,
    /// Count provenance differences (adapter, driver, baker version) as differences.
    #[arg(long)]
    pub strict_provenance: bool,
    /// Write |A−B| EXR images of the maps that differ into this directory.
    #[arg(long, value_name = "DIR")]
    pub images: Option<PathBuf>,
}

/// Tolerance presets of `diff`.
#[derive(ValueEnum, Clone, Copy, Debug, PartialEq, Eq)]
pub enum TolerancePreset {
    /// Bit-exact (same scene, settings and adapter give identical bytes).
    SameMachine,
    /// Small differences allowed (another GPU or driver).
    AnotherGpu,
}

/// `gibake inspect`.
#[derive(Args, Debug)]
pub struct InspectArgs {
    /// The asset.
    pub asset: PathBuf,
    /// Machine-readable output.
    #[arg(long)]
    pub json: bool,
}

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
    /// every table and plot of docs/results.md).
    #[arg(value_enum, value_delimiter = ',', default_values_t = [BenchWhich::All])]
    pub which: Vec<BenchWhich>,
    /// Directory for the Markdown report, the JSON and the PNG plots.
    #[arg(long, default_value = "bench-out", value_name = "DIR")]
    pub out: PathBuf,
    /// Frames measured per runtime configuration, after one warm-up frame
    /// (naive: at most 2; Table 1: at most 2; interleave: at most 4;
    /// scaling: at most 3; --quick: at most 2).
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
    /// Static VPL budget of the interleave benchmark.
    #[arg(long, default_value_t = 664, value_name = "N")]
    pub vpls: u32,
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
    /// GPU adapter to use (substring of its name).
    #[arg(long)]
    pub adapter: Option<String>,
}

/// Parses `WxH` (e.g. `1280x720`).
fn parse_size(s: &str) -> Result<(u32, u32), String> {
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
    /// All of them.
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

/// `gibake demo`.
#[derive(Args, Debug)]
pub struct DemoArgs {
    /// Output directory (created; replaced files only).
    #[arg(short, long, default_value = "gibake-demo")]
    pub output: PathBuf,
    /// Image width.
    #[arg(long, default_value_t = 256)]
    pub width: u32,
    /// Image height.
    #[arg(long, default_value_t = 256)]
    pub height: u32,
    /// Frames of animation to render (1/15 s apart).
    #[arg(long, default_value_t = 16)]
    pub frames: u32,
    /// Static VPLs to bake.
    #[arg(long, default_value_t = 250)]
    pub vpls: u32,
    /// Reference samples per pixel (one bounce, first frame).
    #[arg(long, default_value_t = 64)]
    pub spp: u32,
}

/// Parses `--interleave` (1, 2, 4 or 8).
fn interleave_value(s: &str) -> Result<u32, String> {
    match s.parse::<u32>() {
        _ if s == "auto" => Ok(0),
        Ok(n) if [1, 2, 4, 8].contains(&n) => Ok(n),
        _ => Err(format!("{s:?} is not one of auto, 1, 2, 4, 8")),
    }
}
