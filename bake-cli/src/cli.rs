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
    /// Only this light (its glTF light name, else its node's name); give
    /// it again for several. Default: every KHR_lights_punctual light of
    /// the scene (directional, spot and point, glTF ranges honoured), each
    /// with its shadow maps and its share of one VPL budget. The first
    /// directional light leads, else the first spot: its maps are the
    /// full-size primary ones (cascades for a sun). `render` and `view`
    /// take the bake's --light flags (recorded in the asset) when given
    /// none, and refuse others.
    #[arg(long = "light", value_name = "NAME")]
    pub lights: Vec<String>,
    /// Once needed for every light; every light is now the default. Still
    /// accepted (scripts written before) and changes nothing.
    #[arg(long, hide = true)]
    pub all_lights: bool,
    /// What the level needs that its file lacks (sun, moving objects).
    #[command(flatten)]
    pub level: LevelArgs,
    /// The camera to render from.
    #[command(flatten)]
    pub camera: CameraArgs,
    /// Import budgets.
    #[command(flatten)]
    pub limits: crate::limits::LimitArgs,
}

impl SceneArgs {
    /// The importer's options.
    pub fn load_options(&self) -> gibake_scene::LoadOptions {
        gibake_scene::LoadOptions {
            lights: self.lights.clone(),
            limits: self.limits.to_limits(),
            sun: self.level.sun(),
            camera: self.camera.choice(),
            dynamic: self.level.dynamic.clone(),
            bake_volume: self.level.bake_volume(),
        }
    }
}

/// Additions to a level as exported, without editing the file. They change
/// what is baked (the static-scene hash): `bake` records them in the asset
/// (with --light and --max-texture-size), and `render` and `view` apply the
/// asset's when given none of a kind; ones given must equal the asset's.
/// `reference` takes no asset: give it the bake's (`gibake inspect` shows
/// them).
#[derive(Args, Debug, Clone, Default)]
pub struct LevelArgs {
    /// Add a directional primary light (for a level exported without one; it
    /// replaces the file's lights): azimuth and elevation in degrees.
    /// Azimuth turns clockwise seen from above (+Y) from −Z: 0 puts the sun
    /// toward −Z, 90 toward +X; elevation is above the XZ plane, in (0, 90].
    /// `bake` records it (with its irradiance and colour): `render` and
    /// `view` apply the bake's when given no --sun.
    #[arg(long, value_name = "AZIMUTH,ELEVATION", value_parser = parse_sun, allow_hyphen_values = true)]
    pub sun: Option<(f32, f32)>,
    /// Irradiance of the --sun on a surface facing it, W/m².
    #[arg(long, value_name = "W/M2", default_value_t = 1.0, requires = "sun")]
    pub sun_irradiance: f32,
    /// Linear RGB colour of the --sun (multiplies the irradiance).
    #[arg(long, value_name = "R,G,B", value_parser = parse_rgb, requires = "sun")]
    pub sun_color: Option<[f32; 3]>,
    /// Mark nodes as moving objects by name (repeatable; glob: `*` any run,
    /// `?` one character): a matching node and its children leave the
    /// static scene and are drawn per frame. A pattern matching no node is
    /// an error. `bake` records the patterns: `render` and `view` apply the
    /// bake's when given no --dynamic.
    #[arg(long, value_name = "PATTERN")]
    pub dynamic: Vec<String>,
    /// The part of the level a directional light's shadow map and RSM cover
    /// (world box; replaces a node marked `extras: {"bake_volume": true}`).
    /// Default: the static geometry without outliers such as a distant
    /// ground plane (docs/method.md, "Light views"). Recorded by `bake`, as
    /// --sun is.
    #[arg(long, value_name = "MINX,MINY,MINZ,MAXX,MAXY,MAXZ", value_parser = parse_box, allow_hyphen_values = true)]
    pub bake_volume: Option<[f32; 6]>,
}

impl LevelArgs {
    /// The `--bake-volume` as a box.
    pub fn bake_volume(&self) -> Option<gibake_scene::Aabb> {
        use gibake_runtime::glam::Vec3;
        self.bake_volume.map(|v| gibake_scene::Aabb {
            min: Vec3::new(v[0], v[1], v[2]),
            max: Vec3::new(v[3], v[4], v[5]),
        })
    }

    /// The `--sun` as the importer's type.
    pub fn sun(&self) -> Option<gibake_scene::Sun> {
        self.sun.map(|(az, el)| gibake_scene::Sun {
            azimuth_deg: az,
            elevation_deg: el,
            irradiance: self.sun_irradiance,
            color: self.sun_color.map_or(
                gibake_runtime::glam::Vec3::ONE,
                gibake_runtime::glam::Vec3::from,
            ),
        })
    }
}

/// The camera of `render` and `reference` (default: the scene's first).
#[derive(Args, Debug, Clone, Default)]
pub struct CameraArgs {
    /// Render from the scene's camera of this name (glTF camera or node name).
    #[arg(long, value_name = "NAME", conflicts_with = "look_at")]
    pub camera: Option<String>,
    /// Render from a perspective camera at EYE looking at TARGET (world
    /// coordinates, +Y up), vertical field of view FOV degrees (default 60).
    #[arg(long, value_name = "EX,EY,EZ,TX,TY,TZ[,FOV]", value_parser = parse_look_at, allow_hyphen_values = true)]
    pub look_at: Option<[f32; 7]>,
}

impl CameraArgs {
    /// The importer's camera choice.
    pub fn choice(&self) -> gibake_scene::CameraChoice {
        use gibake_scene::CameraChoice;
        match (&self.camera, &self.look_at) {
            (Some(n), _) => CameraChoice::Named(n.clone()),
            (None, Some(v)) => CameraChoice::LookAt {
                eye: gibake_runtime::glam::Vec3::new(v[0], v[1], v[2]),
                target: gibake_runtime::glam::Vec3::new(v[3], v[4], v[5]),
                yfov_deg: v[6],
            },
            (None, None) => CameraChoice::First,
        }
    }
}

/// Comma-separated finite numbers, `min..=max` of them.
fn parse_numbers(s: &str, min: usize, max: usize, what: &str) -> Result<Vec<f32>, String> {
    let v: Vec<f32> = s
        .split(',')
        .map(|t| {
            t.trim()
                .parse::<f32>()
                .ok()
                .filter(|x| x.is_finite())
                .ok_or_else(|| format!("`{}` is not a finite number (expected {what})", t.trim()))
        })
        .collect::<Result<_, _>>()?;
    if v.len() < min || v.len() > max {
        return Err(format!("expected {what}, got {} number(s)", v.len()));
    }
    Ok(v)
}

fn parse_sun(s: &str) -> Result<(f32, f32), String> {
    let v = parse_numbers(s, 2, 2, "AZIMUTH,ELEVATION in degrees")?;
    if !(v[1] > 0.0 && v[1] <= 90.0) {
        return Err(format!(
            "elevation {} must be in (0, 90] degrees above the horizon",
            v[1]
        ));
    }
    Ok((v[0], v[1]))
}

fn parse_box(s: &str) -> Result<[f32; 6], String> {
    let v = parse_numbers(s, 6, 6, "MINX,MINY,MINZ,MAXX,MAXY,MAXZ")?;
    if (0..3).any(|k| v[k] >= v[k + 3]) {
        return Err("each minimum must be below its maximum".into());
    }
    Ok([v[0], v[1], v[2], v[3], v[4], v[5]])
}

fn parse_rgb(s: &str) -> Result<[f32; 3], String> {
    let v = parse_numbers(s, 3, 3, "R,G,B")?;
    if v.iter().any(|c| *c < 0.0) {
        return Err("colour components must be non-negative".into());
    }
    Ok([v[0], v[1], v[2]])
}

fn parse_look_at(s: &str) -> Result<[f32; 7], String> {
    let v = parse_numbers(s, 6, 7, "EX,EY,EZ,TX,TY,TZ[,FOV]")?;
    let fov = v.get(6).copied().unwrap_or(60.0);
    if !(fov > 0.0 && fov < 180.0) {
        return Err(format!("field of view {fov} must be in (0, 180) degrees"));
    }
    Ok([v[0], v[1], v[2], v[3], v[4], v[5], fov])
}

/// The commands.
#[derive(Subcommand, Debug)]
pub enum Command {
    /// Bake VPLs and their hemisphere shadow maps into OUT.gibake/.
    Bake(BakeArgs),
    /// Render frames of a scene on the GPU.
    Render(RenderArgs),
    /// Fly through a baked level in a window (the runtime, live): WASD +
    /// mouse, Space plays/pauses, 1-5 modes, I interleave; hot-reloads the
    /// asset when it is re-baked. `--frames N --screenshot F.png` runs
    /// headless (still in a window); `--gpu-report` needs no window.
    View(ViewArgs),
    /// Render the independent CPU reference (path tracer: every bounce by
    /// default, `--bounces N` for the first N, `--bounces 1` direct + one
    /// bounce). It reads no asset: give it the scene flags the bake was
    /// given (--sun, --dynamic, --light, --bake-volume; `gibake inspect
    /// ASSET` prints them).
    Reference(ReferenceArgs),
    /// Compare two baked assets: exit 0 equal (within tolerance), 1 different, 2 bad input.
    /// With --scene, render both and compare what a player sees: exit 1 on
    /// a visible change.
    Diff(DiffArgs),
    /// Describe a baked asset: counts, sizes, settings, provenance, VPL flux.
    Inspect(InspectArgs),
    /// Join the parts of a sharded bake (`bake --shard K/N`) into the asset
    /// the single-machine bake writes, byte for byte.
    Merge(MergeArgs),
    /// Measure: bake time per stage, per-frame update of full vs naive,
    /// Table 1, and error against run time for every mode and quality;
    /// `bench frame --baseline BIN`: per-pass frame cost against an earlier
    /// gibake binary.
    Bench(gibake_bench::BenchArgs),
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
    /// Only this light (its glTF light name, else its node's name); give
    /// it again for several. Default: every KHR_lights_punctual light of
    /// the scene (directional, spot and point, glTF ranges honoured), each
    /// with its shadow maps and its share of one VPL budget. The first
    /// directional light leads, else the first spot: its maps are the
    /// full-size primary ones (cascades for a sun). Recorded in the asset
    /// with --sun, --dynamic, --bake-volume and --max-texture-size: `render`
    /// and `view` apply them when given none.
    #[arg(long = "light", value_name = "NAME")]
    pub lights: Vec<String>,
    /// Once needed for every light; every light is now the default. Still
    /// accepted (scripts written before) and changes nothing.
    #[arg(long, hide = true)]
    pub all_lights: bool,
    /// What the level needs that its file lacks (sun, moving objects).
    #[command(flatten)]
    pub level: LevelArgs,
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
    /// The VPL budget, 1 to 1048576: the asset holds N VPLs (± 2%), every
    /// one of them a VPL whose light reaches a surface (by its texels' rays
    /// or, for far ground round small objects, by rays from its origin);
    /// fewer only when the level's reaching light cannot be split that
    /// finely (the bake says so). More VPLs: more accurate indirect light,
    /// a costlier frame (docs/method.md, bake section 3). Default 256 unless
    /// --threshold is given.
    #[arg(long, value_name = "N", conflicts_with = "threshold",
          value_parser = clap::value_parser!(u32).range(1..=1 << 20))]
    pub vpls: Option<u32>,
    /// Quadtree split threshold (dimensionless, finite, ≥ 0; smaller → more
    /// VPLs). The VPL count is known only after clustering: the memory
    /// budget (--max-memory) is checked again then, before any map is made.
    #[arg(long, value_name = "X", value_parser = threshold_value)]
    pub threshold: Option<f32>,
    /// How many bounces of light the asset carries, in all (1 to 256), or
    /// `all`. Default (`all`): every bounce that matters — the first bounce's VPLs (the
    /// paper's method, shadowed by moving objects each frame) plus VPLs for
    /// the later bounces of the static scene, gathered on surface samples
    /// until a bounce carries under a thousandth of the light so far; left
    /// out when they carry under 0.1% of the light the level's surfaces
    /// reflect (outdoors). 1: the first bounce alone (the paper's method;
    /// the asset of earlier versions). In interiors the later bounces carry
    /// as much light again as the first or many times more
    /// (docs/method.md, "Every bounce").
    #[arg(long, value_name = "N|all", value_parser = bake_bounces_value)]
    pub bounces: Option<gibake_bake::later::Bounces>,
    /// The later bounces' VPLs (default: a quarter of the first bounce's,
    /// at least 1). More: the later light nearer the truth where it
    /// dominates (a white interior), a costlier frame.
    #[arg(long, value_name = "N",
          value_parser = clap::value_parser!(u32).range(1..=1 << 20))]
    pub later_vpls: Option<u32>,
    /// Reflective shadow map resolution, 8 to 8192.
    #[arg(long, default_value_t = 512, value_name = "N",
          value_parser = clap::value_parser!(u32).range(8..=8192))]
    pub rsm_size: u32,
    /// Hemisphere shadow map resolution per VPL, 4 to 2048.
    #[arg(long, default_value_t = 128, value_name = "N",
          value_parser = clap::value_parser!(u32).range(4..=2048))]
    pub vpl_map_size: u32,
    /// Primary shadow map resolution, 16 to 16384 (and at most the GPU's
    /// largest texture).
    #[arg(long, default_value_t = 2048, value_name = "N",
          value_parser = clap::value_parser!(u32).range(16..=16384))]
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

/// Parses `--threshold`: a finite number ≥ 0 (what it costs is bounded by
/// the memory budget, checked once clustering has counted the VPLs).
fn threshold_value(s: &str) -> Result<f32, String> {
    match s.trim().parse::<f32>() {
        Ok(t) if t.is_finite() && t >= 0.0 => Ok(t),
        _ => Err(format!("`{s}` is not a finite number ≥ 0")),
    }
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

/// Cascaded shadow maps for a directional light's direct term.
#[derive(ValueEnum, Clone, Copy, Debug, PartialEq, Eq)]
pub enum CascadesArg {
    /// When the primary map's texel is coarse against what the camera sees.
    Auto,
    /// Always (directional light).
    On,
    /// Never: the single primary map.
    Off,
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
    /// own static shadow map without one). Its recorded scene flags
    /// (--sun, --dynamic, --light, --bake-volume, --max-texture-size) are
    /// applied when given none of a kind, with a line saying so; flags
    /// given that differ from them are refused (exit 2).
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
    /// PNG frames: scale radiance by this before the tone curve. Default:
    /// the first frame's automatic exposure (its 99th-percentile luminance
    /// maps to 0.8), kept for every frame of a sequence; give a fixed value
    /// to compare modes or runs. EXR frames are never exposed.
    #[arg(long, value_name = "SCALE")]
    pub exposure: Option<f32>,
    /// Supersampling: render at N× the resolution and box-filter down.
    #[arg(long, default_value_t = 2, value_parser = clap::value_parser!(u32).range(1..=8))]
    pub ssaa: u32,
    /// Primary shadow map resolution.
    #[arg(long, default_value_t = 2048)]
    pub shadow_map_size: u32,
    /// Shadow cascades fitted to the camera for a directional light's
    /// direct term (runtime/README.md, "Cascades"): `auto` turns them on
    /// when the primary map's texel is coarse against the camera's pixel.
    #[arg(long, value_enum, default_value_t = CascadesArg::Auto)]
    pub cascades: CascadesArg,
    /// Shade every light at every pixel: turns off the light culling that
    /// skips, per tile of 8×8 pixels (N apart at --interleave N), the
    /// lights after the first whose range or spot cone cannot reach it. The image is the same to the bit; this only
    /// measures what culling saves (see `--stats`).
    #[arg(long)]
    pub no_light_culling: bool,
    /// Cluster the bounce off moving objects in one window per light view,
    /// around all of them, instead of one window per group of objects
    /// standing far apart (each with a quarter of the view's dynamic VPLs
    /// at finer cells). For measuring what the split buys; the image
    /// differs (coarser cells on each object).
    #[arg(long)]
    pub no_split_windows: bool,
    /// Most dynamic VPLs (moving surfaces bouncing light) per frame, rounded
    /// up to a power of 4; 0 turns them off. Fewer, larger clusters lose
    /// light next to the moving objects (docs/method.md, "Near field").
    #[arg(long, default_value_t = 256, value_name = "N")]
    pub max_dynamic_vpls: u32,
    /// Most dynamic VPLs per view of the lights after the first that the
    /// moving objects touch (their bounce off moving objects; rounded up to
    /// a power of 4; 0: none). Shading reads 21 slots per touched view at
    /// the default.
    #[arg(long, default_value_t = 16, value_name = "N")]
    pub max_dynamic_vpls_per_view: u32,
    /// Interleaved VPL sampling: each pixel of an N×N block shades a disjoint
    /// 1/N² of the VPLs and a geometry-aware filter reconstructs the sum
    /// (1: every pixel shades every VPL). `auto` (the default): 4 from 256²
    /// pixels on, else 1 (measured in docs/results.md, "Interleaved VPL
    /// sampling"). Applies at the supersampled resolution.
    #[arg(long, default_value = "auto", value_name = "N|auto", value_parser = interleave_value)]
    pub interleave: u32,
    /// Near-field descent of the static VPLs, in disk radii (4–32): a
    /// VPL's tree node is drawn as its children where the pixel is nearer
    /// than N of its radii. 8 (the default) is the accurate choice; 4 costs
    /// about 0.6× the shading and is darker next to clusters whose parts
    /// face different ways (docs/method.md, "Descent ratio"). A finest
    /// node's light skips the map test within half of N of its radii, at
    /// most 4.
    #[arg(long, default_value_t = 8, value_name = "N", value_parser = clap::value_parser!(u32).range(4..=32))]
    pub near_field_descent: u32,
    /// Near-field descent of the later bounces' VPLs (an asset baked with
    /// every bounce), in disk radii (0–32; 0: each drawn as one disk). A
    /// later VPL stands for a wide stretch of the walls, so its tree
    /// descends at most pixels of a room: the later bounces' share of the
    /// shading follows this (docs/method.md, "Every bounce"). A finest
    /// node's light skips the map test within half of N of its radii, at
    /// most 4.
    #[arg(long, default_value_t = gibake_runtime::DEFAULT_LATER_NEAR_FIELD_DESCENT, value_name = "N", value_parser = clap::value_parser!(u32).range(0..=32))]
    pub later_near_field_descent: u32,
    /// Shade the later bounces' VPLs at every pixel. By default an
    /// interleaved render (`--interleave` above 1) shades them on a
    /// half-resolution grid and its filter brings them up to full
    /// resolution: about a quarter of their cost, for smooth light
    /// (docs/method.md, "Every bounce" → "Frame cost: the later bounces at half resolution"). For measuring
    /// what that changes.
    #[arg(long)]
    pub later_full_resolution: bool,
    /// The largest share of each moving object's shadow in the static
    /// VPLs' light that the VPL-map merge may leave out, the faintest
    /// first (the maps of VPLs across the level from a small object): 0
    /// draws every moving object into every map it reaches (docs/method.md,
    /// "The VPL-map merge" → "Faint shadows left out"). From 0 to 0.5.
    #[arg(long, default_value_t = gibake_runtime::DEFAULT_MERGE_CULL_SHARE, value_name = "SHARE")]
    pub merge_cull_share: f32,
    /// GPU adapter to use (substring of its name; default: GIBAKE_ADAPTER or the first real GPU).
    #[arg(long)]
    pub adapter: Option<String>,
}

/// `gibake view`.
#[derive(Args, Debug)]
pub struct ViewArgs {
    /// Scene (the same level flags as `render`).
    #[command(flatten)]
    pub scene: SceneArgs,
    /// The baked asset, watched for hot reload (needed by every mode but
    /// `direct`). Its recorded scene flags are applied as by `render`; a
    /// re-bake with other flags reloads the level with them.
    #[arg(long, value_name = "OUT.gibake")]
    pub bake: Option<PathBuf>,
    /// Animation time of the first frame, seconds.
    #[arg(long, default_value_t = 0.0)]
    pub time: f32,
    /// Window width in pixels (and the headless frames' width).
    #[arg(long, default_value_t = 960)]
    pub width: u32,
    /// Window height in pixels.
    #[arg(long, default_value_t = 540)]
    pub height: u32,
    /// The first mode (keys 1-5 switch: full, direct, indirect, rsm, naive).
    #[arg(long, value_enum, default_value_t = ModeArg::Full)]
    pub mode: ModeArg,
    /// Interleaved VPL sampling, as for `render` (key I cycles 1, 2, 4, 8).
    #[arg(long, default_value = "auto", value_name = "N|auto", value_parser = interleave_value)]
    pub interleave: u32,
    /// Scale radiance by this before the tone curve. Default: the first
    /// frame's automatic exposure, as `render` (key X measures it again).
    #[arg(long, value_name = "SCALE")]
    pub exposure: Option<f32>,
    /// Headless: render and present this many frames, then exit (frame f
    /// at --time + f/--fps, as `render --frames`).
    #[arg(long, value_name = "N", value_parser = clap::value_parser!(u32).range(1..=100_000))]
    pub frames: Option<u32>,
    /// Frame rate of the headless frames' animation time.
    #[arg(long, default_value_t = 30.0)]
    pub fps: f32,
    /// Headless: write the last frame here (.png tone-mapped, or .exr).
    #[arg(long, value_name = "FRAME.png", requires = "frames")]
    pub screenshot: Option<PathBuf>,
    /// Headless: also write what the window showed (the surface's pixels
    /// after the present pass, PNG), where the surface allows reading it.
    #[arg(long, value_name = "SHOWN.png", requires = "frames")]
    pub presented: Option<PathBuf>,
    /// Print the adapter, the limits the level needs against the adapter's
    /// and the GPU memory it needs, then exit (0, or 2 when the adapter
    /// cannot run it). Needs no display.
    #[arg(long, conflicts_with_all = ["frames", "screenshot", "presented"])]
    pub gpu_report: bool,
    /// Primary shadow map resolution.
    #[arg(long, default_value_t = 2048)]
    pub shadow_map_size: u32,
    /// Most dynamic VPLs per frame, as for `render`.
    #[arg(long, default_value_t = 256, value_name = "N")]
    pub max_dynamic_vpls: u32,
    /// GPU adapter to use (substring of its name; default: GIBAKE_ADAPTER or
    /// the first real GPU that can show the window).
    #[arg(long)]
    pub adapter: Option<String>,
}

/// `gibake reference`.
#[derive(Args, Debug)]
pub struct ReferenceArgs {
    /// Scene. It reads no asset: to judge a bake, give the scene flags the
    /// bake was given (`gibake inspect ASSET`: "scene flags").
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
    /// Light bounces to follow: `all` (the default) is every bounce —
    /// unbounded path depth, Russian roulette after the third bounce,
    /// unbiased; a path is cut at 1024 bounces, which only a scene that
    /// traps light reaches (albedo 1 in a closed space has no finite
    /// answer), and a warning says how many were. N (0 to 1024): direct
    /// light and the first N bounces exactly. `--bounces 1` is direct + one
    /// bounce (path depth 3: light → surface → surface → eye, what the
    /// paper's method computes and what this command rendered before every
    /// bounce), bit for bit; `--bounces 0` is direct light only.
    #[arg(long, value_name = "N|all", default_value = "all", value_parser = bounces_value)]
    pub bounces: gibake_reference::Depth,
    /// Direct light only (path depth 2): the same as `--bounces 0`.
    #[arg(long, conflicts_with = "bounces")]
    pub direct_only: bool,
    /// Random seed (the image is deterministic for a given seed).
    #[arg(long, default_value_t = 0)]
    pub seed: u64,
    /// Output EXR (linear radiance) or PNG preview.
    #[arg(short, long, value_name = "REF.exr")]
    pub output: PathBuf,
}

/// Parses `bake --bounces`: `all` or 1 to 256 (the bake's cap,
/// `gibake_bake::later::radiosity::MAX_BOUNCES`).
fn bake_bounces_value(s: &str) -> Result<gibake_bake::later::Bounces, String> {
    use gibake_bake::later::{Bounces, radiosity::MAX_BOUNCES};
    match s.parse::<u32>() {
        _ if s == "all" => Ok(Bounces::Every),
        Ok(n @ 1..) if n <= MAX_BOUNCES => Ok(Bounces::Count(n)),
        Ok(n) => Err(format!(
            "{n} bounces: the bake carries 1 (the first bounce alone) to {MAX_BOUNCES}, or `all`"
        )),
        Err(_) => Err(format!(
            "{s:?} is not a number of bounces (1 to {MAX_BOUNCES}) or `all`"
        )),
    }
}

/// Parses `--bounces`: `all` or 0 to 1024.
fn bounces_value(s: &str) -> Result<gibake_reference::Depth, String> {
    use gibake_reference::{Depth, MAX_BOUNCES};
    match s.parse::<u32>() {
        _ if s == "all" => Ok(Depth::Every),
        Ok(0) => Ok(Depth::Direct),
        Ok(1) => Ok(Depth::OneBounce),
        Ok(n) if n <= MAX_BOUNCES => Ok(Depth::Bounces(n)),
        Ok(n) => Err(format!(
            "{n} is more bounces than the reference follows (at most {MAX_BOUNCES}; `all` for every bounce)"
        )),
        Err(_) => Err(format!(
            "{s:?} is not a number of bounces (0 to {MAX_BOUNCES}) or `all`"
        )),
    }
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
    /// Write |A−B| EXR images of the maps that differ into this directory
    /// (created); with --scene also, per view, A's and B's frames and a heat
    /// map as PNGs (`VIEW_a.png`, `VIEW_b.png`, `VIEW_heat.png`) and the
    /// three side by side (`VIEW.png`).
    #[arg(long, value_name = "DIR")]
    pub images: Option<PathBuf>,
    /// The image-space diff (what a player sees differently): render both
    /// assets from the level's camera (or --view-camera / --view) and
    /// compare the frames. Give the scene both were baked from, or twice:
    /// A's scene, then B's (a level that changed). The verdict then comes
    /// from the images (--max-image-relmse, --max-flip); the data diff is
    /// still reported.
    #[arg(long = "scene", value_name = "SCENE.glb", num_args = 1, action = clap::ArgAction::Append)]
    pub scenes: Vec<PathBuf>,
    /// With --scene: --sun, --dynamic, --bake-volume as `render` takes them
    /// (each asset's recorded flags apply when none is given).
    #[command(flatten)]
    pub level: LevelArgs,
    /// With --scene: only these lights (as `render --light`; repeatable).
    #[arg(long = "light", value_name = "NAME")]
    pub lights: Vec<String>,
    /// With --scene: import budgets.
    #[command(flatten)]
    pub limits: crate::limits::LimitArgs,
    /// With --scene: a view from the scene's camera of this name
    /// (repeatable). Default: the scene's first camera.
    #[arg(long = "view-camera", value_name = "NAME")]
    pub view_cameras: Vec<String>,
    /// With --scene: a view from a perspective camera at EYE looking at
    /// TARGET, vertical field of view FOV degrees (default 60; repeatable;
    /// write `--view=-2,1,…` when the first number is negative).
    #[arg(long = "view", value_name = "EX,EY,EZ,TX,TY,TZ[,FOV]", value_parser = parse_look_at, allow_hyphen_values = true)]
    pub views: Vec<[f32; 7]>,
    /// With --scene: animation times to compare at, in seconds (repeatable;
    /// default 0).
    #[arg(long = "time", value_name = "T")]
    pub times: Vec<f32>,
    /// With --scene: frame width in pixels (small keeps a CI step fast).
    #[arg(long, default_value_t = 320)]
    pub width: u32,
    /// With --scene: frame height in pixels.
    #[arg(long, default_value_t = 180)]
    pub height: u32,
    /// With --scene: supersampling (render N× larger, box-filter down).
    #[arg(long, default_value_t = 1, value_parser = clap::value_parser!(u32).range(1..=8))]
    pub ssaa: u32,
    /// With --scene: primary shadow map resolution of the renders.
    #[arg(long, default_value_t = 2048)]
    pub shadow_map_size: u32,
    /// With --scene: a view whose frames differ by more than this rel MSE
    /// (per pixel and channel (b−a)²/(a²+0.01), averaged) is a visible
    /// change (exit 1).
    #[arg(long, value_name = "X", default_value_t = 0.002, value_parser = crate::limits::tolerance_f64("--max-image-relmse"))]
    pub max_image_relmse: f64,
    /// With --scene: a view whose frames differ by more than this mean FLIP
    /// (NVIDIA's perceptual difference, 0 to 1) is a visible change.
    #[arg(long, value_name = "X", default_value_t = 0.02, value_parser = crate::limits::tolerance_f64("--max-flip"))]
    pub max_flip: f64,
    /// Write a Markdown summary (verdict, a table per view, the pictures of
    /// --images by paths relative to FILE's directory, the data diff) for a
    /// CI job summary or a review comment.
    #[arg(long, value_name = "FILE.md")]
    pub markdown: Option<PathBuf>,
    /// The GPU adapter of the renders (a substring of its name).
    #[arg(long, value_name = "NAME")]
    pub adapter: Option<String>,
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
