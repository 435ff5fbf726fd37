//! `gibake bench` (this crate; the binary only parses [`BenchArgs`] and
//! calls [`run`]): bake time, per-frame update cost (full against naive),
//! the paper's Table 1, error against run time for every mode and quality
//! setting (rel MSE and mean FLIP, Pareto front marked), interleaved
//! shading side by side, scaling sweeps with fitted growth exponents, the
//! pipeline's up-to-date check and the indirect accuracy; and `gibake
//! bench frame` (`frame_cost.rs`, `frame_cost_report.rs`): the per-pass
//! frame cost of this binary against an earlier gibake binary, both driven
//! through their command lines (it needs no GPU context of its own).
//!
//! One file per sub-benchmark; the shared table and report code is in
//! `report.rs`, every render in `frame.rs`, the plots (plotters, PNG) in
//! `plot.rs`.
//!
//! Every table names the adapter it was measured on. Ratios are measured
//! side by side in one run; absolute times mean something only with the
//! adapter named (on lavapipe, a CPU rasterizer, they are not GPU times).
//! Output: `DIR/report.md` (the tables of this run), `DIR/<bench>.json`, and
//! the PNG plots.

use std::fmt::Write as _;
use std::path::PathBuf;
use std::time::Instant;

use gibake_bake::cluster::ClusterTarget;
use gibake_bake::{BakeOptions, NoProgress};
use gibake_gpu::{GpuContext, GpuOptions};
use gibake_scene::{LoadOptions, Scene};

mod accuracy;
mod args;
mod bake;
mod error;
mod frame;
mod frame_cost;
mod frame_cost_report;
mod interleave;
mod out;
mod pipeline;
mod plot;
mod quality;
mod report;
mod runtime;
mod scaling;
mod table1;
mod text;

pub use args::{BenchArgs, BenchScene, BenchWhich, FrameArgs};
pub use error::{BenchError, Result};
use error::{Context, bail};
use out::write_atomic;
pub(crate) use report::{Table, median};

const CORNER_BUNNY: &[u8] = include_bytes!("../../../data/corner_bunny.glb");
const OCCLUDED: &[u8] = include_bytes!("../../../data/occluded.glb");
const SUN: &[u8] = include_bytes!("../../../data/sun.glb");

/// Animation step between measured frames.
const FRAME_STEP_S: f32 = 1.0 / 30.0;
/// Time of the quality benchmarks' frame.
const QUALITY_TIME: f32 = 0.5;

/// Shared state of one `gibake bench` run.
struct Bench {
    ctx: GpuContext,
    adapter: String,
    lavapipe: bool,
    quick: bool,
    frames: u32,
    out: PathBuf,
    tmp: PathBuf,
    report: String,
    /// Plots written, `(file name, the command that reproduces it)`.
    plots: Vec<(String, String)>,
}

/// Runs `gibake bench` with the options `a`.
pub fn run(a: &BenchArgs) -> Result<()> {
    if a.which.contains(&BenchWhich::Frame) {
        if a.which.len() > 1 {
            bail!(
                "`frame` runs on its own (it runs two gibake binaries): `gibake bench frame --baseline BIN`"
            );
        }
        return frame_cost::run(a);
    }
    if a.frames == 0 {
        bail!("--frames must be at least 1");
    }
    if a.heavy == 0 {
        bail!("--heavy must be at least 1");
    }
    if a.ref_spp == Some(0) {
        bail!("--ref-spp must be at least 1");
    }
    if a.scenes.is_empty() {
        bail!("--scenes names no scene");
    }
    if a.table1_size.0 == 0 || a.table1_size.1 == 0 {
        bail!("--table1-size must be at least 1×1");
    }
    std::fs::create_dir_all(&a.out).with_context(|| format!("creating {}", a.out.display()))?;
    let ctx = GpuContext::new(&GpuOptions {
        adapter: a.adapter.clone(),
    })?;
    let adapter = ctx.record.to_string();
    let lavapipe = ctx.record.driver.to_ascii_lowercase().contains("llvmpipe")
        || ctx.record.name.to_ascii_lowercase().contains("llvmpipe");
    eprintln!("GPU: {adapter}");
    let tmp = std::env::temp_dir().join(format!("gibake-bench-{}", std::process::id()));
    let mut b = Bench {
        ctx,
        adapter,
        lavapipe,
        quick: a.quick,
        frames: if a.quick { a.frames.min(2) } else { a.frames },
        out: a.out.clone(),
        tmp,
        report: String::new(),
        plots: Vec::new(),
    };
    let started = Instant::now();
    let _ = writeln!(
        b.report,
        "# gibake bench{}\n\nAdapter: **{}**{}\n",
        if a.quick { " (--quick)" } else { "" },
        b.adapter,
        if b.lavapipe {
            " — lavapipe, a CPU rasterizer: absolute times are CPU times, not GPU times; \
             only the ratios carry over to a GPU."
        } else {
            ""
        }
    );
    let all = a.which.contains(&BenchWhich::All);
    let on = |w: BenchWhich| all || a.which.contains(&w);
    let mut timings: Vec<(&str, f64)> = Vec::new();
    let result: Result<()> = (|| {
        let mut part = |name: &'static str,
                        on: bool,
                        b: &mut Bench,
                        f: &mut dyn FnMut(&mut Bench) -> Result<()>|
         -> Result<()> {
            if on {
                let t = Instant::now();
                f(b)?;
                timings.push((name, t.elapsed().as_secs_f64()));
            }
            Ok(())
        };
        part("bake", on(BenchWhich::Bake), &mut b, &mut |b| {
            bake::bench_bake(b, a.scene.as_deref())
        })?;
        part("runtime", on(BenchWhich::Runtime), &mut b, &mut |b| {
            runtime::bench_runtime(b, a.heavy)
        })?;
        part("table1", on(BenchWhich::Table1), &mut b, &mut |b| {
            table1::bench_table1(b, a.table1_size)
        })?;
        part("pipeline", on(BenchWhich::Pipeline), &mut b, &mut |b| {
            pipeline::bench_pipeline(b)
        })?;
        part("quality", on(BenchWhich::Quality), &mut b, &mut |b| {
            let spp = a.ref_spp.unwrap_or(if b.quick { 128 } else { 1024 });
            quality::bench_quality(b, &a.scenes, a.random_scenes, spp)
        })?;
        part("interleave", on(BenchWhich::Interleave), &mut b, &mut |b| {
            let spp = a.ref_spp.unwrap_or(if b.quick { 128 } else { 1024 });
            interleave::bench_interleave(b, &a.scenes, a.vpls.unwrap_or(664), spp)
        })?;
        part("scaling", on(BenchWhich::Scaling), &mut b, &mut |b| {
            scaling::bench_scaling(b)
        })?;
        part("accuracy", on(BenchWhich::Accuracy), &mut b, &mut |b| {
            accuracy::bench_accuracy(b, a.seeds)
        })?;
        Ok(())
    })();
    let _ = std::fs::remove_dir_all(&b.tmp);
    result?;
    let total = started.elapsed().as_secs_f64();
    let _ = writeln!(
        b.report,
        "_Benchmark time: {}; total {total:.0} s._",
        timings
            .iter()
            .map(|(n, s)| format!("{n} {s:.0} s"))
            .collect::<Vec<_>>()
            .join(", ")
    );
    write_atomic(&b.out.join("report.md"), b.report.as_bytes())?;
    b.write_json(
        "run",
        &serde_json::json!({
            "adapter": b.adapter,
            "quick": b.quick,
            "total_seconds": total,
            "parts": timings.iter().map(|(n, s)| serde_json::json!({"bench": n, "seconds": s})).collect::<Vec<_>>(),
            "plots": b.plots.iter().map(|(f, c)| serde_json::json!({"file": f, "command": c})).collect::<Vec<_>>(),
        }),
    )?;
    eprintln!(
        "wrote {} (and the JSON / PNG files beside it) in {total:.0} s",
        b.out.join("report.md").display()
    );
    Ok(())
}

impl Bench {
    /// Bakes `scene` with `vpls` VPLs and `map`² hemisphere maps; returns
    /// the bake and its wall seconds.
    fn bake(&self, scene: &Scene, vpls: u32, map: u32) -> Result<(gibake_bake::BakeOutput, f64)> {
        self.bake_bounces(scene, vpls, map, gibake_bake::later::Bounces::Count(1))
    }

    /// [`Bench::bake`] with `bounces` (the benches' bakes are the first
    /// bounce alone, the paper's method; `gibake bench quality` adds the
    /// default, every bounce, beside it).
    fn bake_bounces(
        &self,
        scene: &Scene,
        vpls: u32,
        map: u32,
        bounces: gibake_bake::later::Bounces,
    ) -> Result<(gibake_bake::BakeOutput, f64)> {
        let opts = BakeOptions {
            rsm_size: 512,
            vpl_map_size: map,
            shadow_map_size: 2048,
            target: ClusterTarget::Count(vpls),
            bounces,
            later_vpls: None,
        };
        let t = Instant::now();
        let out = gibake_bake::bake(
            &self.ctx,
            scene,
            &opts,
            &NoProgress,
            &gibake_bake::baker_version(),
        )
        .with_context(|| format!("baking {}", scene.source.display()))?;
        Ok((out, t.elapsed().as_secs_f64()))
    }

    /// The command line that reproduces sub-benchmark `which` into the
    /// same kind of output (for the plots' captions).
    fn command(&self, which: &str) -> String {
        format!(
            "gibake bench {which}{}",
            if self.quick { " --quick" } else { "" }
        )
    }
}

fn load_embedded(bytes: &[u8], name: &str) -> Result<Scene> {
    let path = PathBuf::from(format!("{name}.glb (embedded)"));
    Ok(gibake_scene::load_from_slice(
        bytes,
        &path,
        &LoadOptions::default(),
    )?)
}

fn scene_of(s: BenchScene) -> (&'static str, &'static [u8]) {
    match s {
        BenchScene::CornerBunny => ("corner_bunny", CORNER_BUNNY),
        BenchScene::Occluded => ("occluded", OCCLUDED),
        BenchScene::Sun => ("sun", SUN),
    }
}

/// The distinct scenes of `scenes`, in order.
fn distinct(scenes: &[BenchScene]) -> Vec<BenchScene> {
    let mut seen: Vec<BenchScene> = Vec::new();
    for s in scenes {
        if !seen.contains(s) {
            seen.push(*s);
        }
    }
    seen
}
