//! `gibake bake` for content pipelines and `gibake merge`:
//!
//! - one scene (`-o OUT.gibake`) or a batch (`SCENE... --out-dir DIR`), each
//!   left untouched when its asset is up to date
//!   ([`gibake_bake::check_up_to_date`]) unless `--force`;
//! - one shard of a distributed bake (`-o PART --shard K/N`,
//!   [`gibake_bake::bake_shard`]) and the merge of all parts
//!   ([`gibake_asset::merge`]) into the single bake's bytes.
//!
//! See docs/pipeline.md for the contract.

use std::path::{Path, PathBuf};
use std::process::ExitCode;
use std::sync::Mutex;
use std::time::Instant;

use anyhow::{Context, bail};
use gibake_asset::SceneOptions;
use gibake_bake::{BakeOptions, BakeProgress, Freshness, Shard};
use gibake_gpu::{GpuContext, GpuOptions};
use gibake_scene::Scene;
use indicatif::{MultiProgress, ProgressBar};
use serde_json::json;

use crate::cli::{BakeArgs, MergeArgs, SceneArgs};
use crate::commands::{BarProgress, load_scene};
use crate::guard::lossy;
use crate::output::bar;

/// Environment variable that overrides the baker version recorded in (and
/// compared with) assets: a test hook for "the baker version changed".
pub const BAKER_VERSION_ENV: &str = "GIBAKE_BAKER_VERSION";

/// The baker version to record: `GIBAKE_BAKER_VERSION` when set and not
/// empty, else the bake library's version and method revision
/// ([`gibake_bake::baker_version`], e.g. `0.1.0+bake.1`).
pub fn baker_version() -> String {
    std::env::var(BAKER_VERSION_ENV)
        .ok()
        .filter(|v| !v.is_empty())
        .unwrap_or_else(gibake_bake::baker_version)
}

/// The scene arguments of `scene` in a bake with `a`'s flags.
fn scene_args(a: &BakeArgs, scene: &Path) -> SceneArgs {
    SceneArgs {
        scene: scene.to_path_buf(),
        lights: a.lights.clone(),
        all_lights: a.all_lights,
        level: a.level.clone(),
        camera: Default::default(),
        limits: a.limits.clone(),
    }
}

/// The scene options a bake with `a`'s flags records in its asset
/// (`--sun`, `--dynamic`, `--light`, `--bake-volume`,
/// `--max-texture-size`: format 4.4, `Manifest::scene_options`), so that
/// `render`, `view` and the runtime load the level the same way.
fn recorded(a: &BakeArgs) -> SceneOptions {
    gibake_runtime::scene_options::scene_options_of(&scene_args(a, Path::new("")).load_options())
}

fn options(a: &BakeArgs) -> BakeOptions {
    let target = match (a.vpls, a.threshold) {
        (Some(n), _) => gibake_bake::cluster::ClusterTarget::Count(n),
        (None, Some(t)) => gibake_bake::cluster::ClusterTarget::Threshold(t),
        (None, None) => gibake_bake::cluster::ClusterTarget::Count(256),
    };
    BakeOptions {
        rsm_size: a.rsm_size,
        vpl_map_size: a.vpl_map_size,
        shadow_map_size: a.shadow_map_size,
        target,
        bounces: a.bounces.unwrap_or(gibake_bake::later::Bounces::Every),
        later_vpls: a.later_vpls,
    }
}

/// `gibake bake`: a batch, a shard, or one scene.
pub fn bake(a: BakeArgs) -> anyhow::Result<ExitCode> {
    // The bake's memory, estimated before anything is read (--max-memory).
    gibake_bake::budget::check(&options(&a), crate::limits::memory())?;
    if let Some(dir) = a.out_dir.clone() {
        return batch(&a, &dir);
    }
    let Some(output) = a.output.clone() else {
        bail!("give -o OUT.gibake (one scene) or --out-dir DIR (a batch)");
    };
    let [scene_path] = a.scenes.as_slice() else {
        bail!(
            "-o {} takes one scene but {} were given; bake several with --out-dir DIR",
            output.display(),
            a.scenes.len()
        );
    };
    // A link to an asset directory is written where it points.
    let target = if a.shard.is_some() {
        crate::guard::check_part_output(&output)?;
        output.clone()
    } else {
        crate::guard::check_asset_output("-o", &output)?
    };
    crate::output::check_not_input("-o", &output, &[scene_path])?;
    // One writer per output from here on: a second bake of the same output
    // waits, then finds it up to date. Where the lock cannot be taken (a
    // read-only checkout), only the up-to-date check may go on: it reads.
    let lock = if a.shard.is_some() {
        Ok(crate::guard::lock_output(&output)?)
    } else {
        lock_and_tidy(&target)
    };
    let opts = options(&a);
    let flags = recorded(&a);
    let total = Instant::now();
    let scene = load_scene(&scene_args(&a, scene_path))?;
    let load_s = total.elapsed().as_secs_f64();
    let gpu = GpuOptions {
        adapter: a.adapter.clone(),
    };
    if let Some((index, count)) = a.shard {
        let ctx = GpuContext::new(&gpu)?;
        return shard(
            &a,
            &ctx,
            &scene,
            &output,
            Shard { index, count },
            load_s,
            &flags,
        );
    }
    // The up-to-date check needs only the adapter's identity, not a device.
    let record = GpuContext::adapter_record(&gpu)?;
    let (freshness, check_s) = decide(&target, &scene, &opts, &flags, a.force, &record, &lock)?;
    let o = match freshness {
        Freshness::UpToDate => Outcome {
            reasons: None,
            check_s,
            baked: None,
        },
        Freshness::Stale(reasons) => {
            let ctx = GpuContext::new(&gpu)?;
            let progress = BarProgress {
                bar: Mutex::new(None),
                quiet: a.json,
            };
            let stale = Stale {
                reasons,
                check_s,
                load_s,
            };
            bake_stale(&ctx, &scene, &target, &opts, &flags, stale, &progress)?
        }
    };
    let total_s = total.elapsed().as_secs_f64();
    if a.json {
        let mut j = o.json(&output);
        // The importer's warnings (also logged on stderr as it ran).
        j["warnings"] = json!(scene.warnings);
        j["adapter"] = json!(record.to_string());
        j["total_seconds"] = json!(total_s);
        crate::output::print_stdout(&serde_json::to_string_pretty(&j)?)?;
    } else {
        eprintln!("GPU: {record}");
        o.print(&output);
        if o.baked.is_some() {
            eprintln!("  {:<14} {:>8.3} s", "total", total_s);
        }
    }
    Ok(ExitCode::SUCCESS)
}

/// What [`bake_one`] did.
struct Outcome {
    /// Why it (re-)baked; `None`: up to date, left untouched.
    reasons: Option<Vec<String>>,
    /// Seconds the up-to-date check took (next to nothing with --force).
    check_s: f64,
    /// The bake's summary when it baked.
    baked: Option<Baked>,
}

struct Baked {
    vpls: u32,
    maps: u32,
    /// VPLs dropped because their hemisphere sees nothing.
    dropped: usize,
    /// The `--vpls` budget asked for (`None`: `--threshold`).
    budget: Option<u32>,
    threshold: f32,
    has_dynamic: bool,
    /// The later bounces' record (`None`: `--bounces 1`).
    later: Option<gibake_asset::LaterRecord>,
    stages: Vec<(String, f64)>,
}

impl Baked {
    /// The first bounce's VPLs (what `--vpls` budgets).
    fn first_vpls(&self) -> u32 {
        self.vpls - self.later.as_ref().map_or(0, |l| l.vpls)
    }
}

impl Outcome {
    fn decision(&self) -> &'static str {
        if self.baked.is_some() {
            "baked"
        } else {
            "up_to_date"
        }
    }

    fn json(&self, asset: &Path) -> serde_json::Value {
        let mut j = json!({
            "asset": lossy(asset),
            "decision": self.decision(),
            "reasons": self.reasons.clone().unwrap_or_default(),
            "check_seconds": self.check_s,
        });
        if let Some(b) = &self.baked {
            j["vpls"] = json!(b.vpls);
            j["first_bounce_vpls"] = json!(b.first_vpls());
            j["later"] = match &b.later {
                None => json!(null),
                Some(l) => json!({
                    "bounces": if l.bounces == 0 { json!("every") } else { json!(l.bounces) },
                    "vpls": l.vpls,
                    "left_out": l.left_out,
                    "converged": l.converged,
                    "share": l.later_share(),
                    "bounces_followed": l.per_bounce.len(),
                }),
            };
            j["maps_stored"] = json!(b.maps);
            j["vpls_dropped"] = json!(b.dropped);
            j["threshold"] = json!(b.threshold);
            j["has_dynamic"] = json!(b.has_dynamic);
            j["stages"] = json!(
                b.stages
                    .iter()
                    .map(|(n, s)| json!({"stage": n, "seconds": s}))
                    .collect::<Vec<_>>()
            );
        }
        j
    }

    fn print(&self, asset: &Path) {
        match (&self.baked, &self.reasons) {
            (None, _) => eprintln!(
                "{}: up to date (same static-scene hash, scene flags, settings, baker version and adapter); left untouched (checked in {:.3} s)",
                asset.display(),
                self.check_s
            ),
            (Some(b), reasons) => {
                let why = reasons.clone().unwrap_or_default().join("; ");
                let first = b.first_vpls();
                eprintln!(
                    "baked {}: {} VPLs ({} maps stored{}{}), threshold {:.3e}; {}; reason: {why}",
                    asset.display(),
                    b.vpls,
                    b.maps,
                    match b.budget {
                        // The budget holds within 2% (docs/method.md, bake
                        // section 3) unless the level cannot be cut finer.
                        Some(n) if u64::from(first.abs_diff(n)) * 50 > u64::from(n) => format!(
                            "; --vpls {n} asked for: {}",
                            if first < n {
                                "the level's light that reaches a surface cannot be split into more"
                            } else {
                                "each light view whose bounce is not negligible keeps one VPL at least, and one split can add several depth layers"
                            }
                        ),
                        _ => String::new(),
                    },
                    if b.dropped > 0 {
                        format!("; {} more dropped: their light reaches nothing", b.dropped)
                    } else {
                        String::new()
                    },
                    b.threshold,
                    match &b.later {
                        None => "the first bounce alone (--bounces 1)".to_string(),
                        Some(l) if l.left_out => format!(
                            "later bounces left out: they carry {:.2}% of the light the surfaces reflect",
                            100.0 * l.later_share()
                        ),
                        Some(l) => format!(
                            "{first} first-bounce VPLs + {} for {} later bounces{} ({:.1}% of the light the surfaces reflect)",
                            l.vpls,
                            l.per_bounce.len().saturating_sub(1),
                            if l.tail != [0.0; 3] {
                                " and their tail"
                            } else {
                                ""
                            },
                            100.0 * l.later_share()
                        ),
                    }
                );
                for (n, s) in &b.stages {
                    eprintln!("  {n:<14} {s:>8.3} s");
                }
            }
        }
    }
}

/// Locks the asset output `target` for the rest of the command and removes
/// the temporaries an earlier run left there when it was killed (even when
/// this run then finds the asset up to date and writes nothing). An error
/// (a read-only file system, a planted link in place of the lock file) is
/// returned for [`decide`] to judge: an up-to-date check needs no lock.
fn lock_and_tidy(target: &Path) -> anyhow::Result<gibake_output::OutputLock> {
    let lock = crate::guard::lock_output(target)?;
    let owned: Vec<std::ffi::OsString> = gibake_asset::owned_names(target)
        .into_iter()
        .map(Into::into)
        .collect();
    let removed = gibake_output::remove_stale(target, &owned, &lock);
    if !removed.is_empty() {
        eprintln!(
            "{}: removed what an earlier run left when it was stopped: {}",
            target.display(),
            removed
                .iter()
                .map(|p| lossy(p.file_name().unwrap_or(p.as_os_str()).as_ref()))
                .collect::<Vec<_>>()
                .join(", ")
        );
    }
    Ok(lock)
}

/// Whether `out` needs a (re-)bake, and how long deciding took: the bake
/// library's check ([`gibake_bake::check_up_to_date`]), and whether the
/// asset records the scene options `flags` ([`flags_change`]). `lock` is
/// the output's lock, or why it could not be taken: then only "up to date"
/// is an answer (it writes nothing; a note says the check ran without the
/// lock), and a needed bake is an error that gives the reasons and why the
/// output cannot be written.
fn decide(
    out: &Path,
    scene: &Scene,
    opts: &BakeOptions,
    flags: &SceneOptions,
    force: bool,
    adapter: &gibake_gpu::AdapterRecord,
    lock: &anyhow::Result<gibake_output::OutputLock>,
) -> anyhow::Result<(Freshness, f64)> {
    let check = Instant::now();
    let freshness = if force {
        Freshness::Stale(vec!["--force".into()])
    } else {
        let change = flags_change(out, flags);
        match gibake_bake::check_up_to_date(out, scene, opts, adapter, &baker_version()) {
            Freshness::UpToDate => match change {
                Some(why) => Freshness::Stale(vec![why]),
                None => Freshness::UpToDate,
            },
            Freshness::Stale(mut reasons) => {
                reasons.extend(change);
                Freshness::Stale(reasons)
            }
        }
    };
    let seconds = check.elapsed().as_secs_f64();
    if let Err(e) = lock {
        match &freshness {
            Freshness::UpToDate => eprintln!(
                "{}: checked without the output's lock, which cannot be taken ({e}); nothing needs writing",
                out.display()
            ),
            Freshness::Stale(reasons) => bail!(
                "{}: needs a bake ({}) but cannot be written: {e}",
                out.display(),
                reasons.join("; ")
            ),
        }
    }
    Ok((freshness, seconds))
}

/// Why the asset at `out` does not record the scene options `flags` a
/// bake now records (`None`: it does, or there is no readable asset, which
/// the bake library's check reports). An asset of format 4.3 or older
/// records none: baked without any it stays up to date (there is nothing
/// to apply), baked with some it is re-baked to record them.
fn flags_change(out: &Path, flags: &SceneOptions) -> Option<String> {
    let m = gibake_asset::load_manifest(out).ok()?;
    match &m.scene_options {
        Some(was) if was.same(flags) => None,
        None if flags.is_empty() => None,
        None => Some(format!(
            "the asset does not record its scene flags (format 4.3 or older): re-baked to record {}",
            flags.flags()
        )),
        Some(was) => Some(format!(
            "scene flags changed ({} → {}; the asset records them)",
            was.flags_or_none(),
            flags.flags_or_none()
        )),
    }
}

/// A decision to bake: why, and the times so far.
struct Stale {
    reasons: Vec<String>,
    check_s: f64,
    load_s: f64,
}

/// Bakes `scene` into `out` unless the asset there is up to date.
#[allow(clippy::too_many_arguments)]
fn bake_one(
    ctx: &GpuContext,
    scene: &Scene,
    out: &Path,
    opts: &BakeOptions,
    flags: &SceneOptions,
    force: bool,
    progress: &dyn BakeProgress,
    load_s: f64,
) -> anyhow::Result<Outcome> {
    let lock = lock_and_tidy(out);
    match decide(out, scene, opts, flags, force, &ctx.record, &lock)? {
        (Freshness::UpToDate, check_s) => Ok(Outcome {
            reasons: None,
            check_s,
            baked: None,
        }),
        (Freshness::Stale(reasons), check_s) => {
            let stale = Stale {
                reasons,
                check_s,
                load_s,
            };
            bake_stale(ctx, scene, out, opts, flags, stale, progress)
        }
    }
}

/// Bakes `scene` into `out` (the decision to bake was `stale`), recording
/// the scene options `flags` it was loaded with.
fn bake_stale(
    ctx: &GpuContext,
    scene: &Scene,
    out: &Path,
    opts: &BakeOptions,
    flags: &SceneOptions,
    stale: Stale,
    progress: &dyn BakeProgress,
) -> anyhow::Result<Outcome> {
    let version = baker_version();
    let Stale {
        reasons,
        check_s,
        load_s,
    } = stale;
    let mut o = gibake_bake::bake(ctx, scene, opts, progress, &version)
        .with_context(|| format!("baking {}", scene.source.display()))?;
    o.asset.manifest.scene_options = Some(flags.clone());
    let w = Instant::now();
    gibake_asset::write(&o.asset, out)?;
    let write_s = w.elapsed().as_secs_f64();
    let m = &o.asset.manifest;
    let stages0 = [("load scene", load_s), ("check", check_s)];
    let mut stages: Vec<(String, f64)> = stages0.iter().map(|(n, s)| (n.to_string(), *s)).collect();
    stages.extend(o.stages.iter().map(|s| (s.stage.to_string(), s.seconds)));
    stages.push(("write".into(), write_s));
    Ok(Outcome {
        reasons: Some(reasons),
        check_s,
        baked: Some(Baked {
            vpls: m.vpl_count,
            maps: o.asset.stored_map_count() as u32,
            dropped: o.dropped_vpls,
            budget: match opts.target {
                gibake_bake::cluster::ClusterTarget::Count(n) => Some(n),
                gibake_bake::cluster::ClusterTarget::Threshold(_) => None,
            },
            threshold: m.settings.threshold,
            has_dynamic: m.has_dynamic,
            later: m.later.clone(),
            stages,
        }),
    })
}

/// `bake SCENE -o PART --shard K/N` (its part records the scene options
/// `flags`, as the single bake's asset does).
fn shard(
    a: &BakeArgs,
    ctx: &GpuContext,
    scene: &Scene,
    output: &Path,
    shard: Shard,
    load_s: f64,
    flags: &SceneOptions,
) -> anyhow::Result<ExitCode> {
    let progress = BarProgress {
        bar: Mutex::new(None),
        quiet: a.json,
    };
    let t = Instant::now();
    let mut o =
        gibake_bake::bake_shard(ctx, scene, &options(a), shard, &progress, &baker_version())
            .with_context(|| format!("baking {}", scene.source.display()))?;
    o.part.front.manifest.scene_options = Some(flags.clone());
    gibake_asset::write_part(&o.part, output)?;
    let seconds = t.elapsed().as_secs_f64() + load_s;
    let vpls = o.part.front.vpls.len();
    let range = gibake_asset::shard_range(vpls, shard.index, shard.count);
    let stored = o.part.maps.iter().filter(|m| m.is_some()).count();
    if a.json {
        let j = json!({
            "part": lossy(output),
            "shard": shard.index,
            "shards": shard.count,
            "vpls": vpls,
            "vpl_range": [range.start, range.end],
            "maps_stored": stored,
            "adapter": ctx.record.to_string(),
            "stages": o.stages.iter().map(|s| json!({"stage": s.stage, "seconds": s.seconds})).collect::<Vec<_>>(),
            "total_seconds": seconds,
            "warnings": scene.warnings,
        });
        crate::output::print_stdout(&serde_json::to_string_pretty(&j)?)?;
    } else {
        eprintln!("GPU: {}", ctx.record);
        eprintln!(
            "wrote shard {}/{} of {} to {}: {vpls} VPLs, maps of VPLs {}..{} ({stored} stored), {seconds:.3} s",
            shard.index,
            shard.count,
            scene.source.display(),
            output.display(),
            range.start,
            range.end
        );
    }
    Ok(ExitCode::SUCCESS)
}

/// One progress display for a batch: an overall bar of scenes and, below
/// it, the current stage's bar.
struct BatchProgress {
    multi: MultiProgress,
    stage: Mutex<Option<ProgressBar>>,
    quiet: bool,
}

impl BakeProgress for BatchProgress {
    fn memory_limit(&self) -> Option<u64> {
        Some(crate::limits::memory())
    }
    fn begin(&self, stage: &str, total: u64) {
        if self.quiet {
            return;
        }
        let pb = if total > 0 {
            bar(total, stage)
        } else {
            let pb = ProgressBar::new_spinner();
            pb.set_message(stage.to_string());
            pb
        };
        let pb = self.multi.add(pb);
        if total == 0 {
            pb.enable_steady_tick(std::time::Duration::from_millis(120));
        }
        *self.stage.lock().expect("progress lock") = Some(pb);
    }
    fn advance(&self, n: u64) {
        if let Some(pb) = self.stage.lock().expect("progress lock").as_ref() {
            pb.inc(n);
        }
    }
    fn end(&self) {
        if let Some(pb) = self.stage.lock().expect("progress lock").take() {
            pb.finish_and_clear();
            self.multi.remove(&pb);
        }
    }
}

/// `bake SCENE... --out-dir DIR`.
fn batch(a: &BakeArgs, dir: &Path) -> anyhow::Result<ExitCode> {
    // Output names first: two scenes with one stem would overwrite each other.
    let mut outs: Vec<(PathBuf, PathBuf)> = Vec::new();
    for s in &a.scenes {
        let Some(stem) = s.file_stem().filter(|n| !n.is_empty()) else {
            bail!("{}: has no file name to name its asset after", s.display());
        };
        let out = dir.join(format!("{}.gibake", stem.to_string_lossy()));
        let inputs: Vec<&Path> = a.scenes.iter().map(|p| p.as_path()).collect();
        crate::output::check_not_input("--out-dir", &out, &inputs)?;
        if let Some((other, _)) = outs.iter().find(|(_, o)| *o == out) {
            bail!(
                "{} and {} would both be baked into {}: rename one, or bake them into different --out-dir",
                other.display(),
                s.display(),
                out.display()
            );
        }
        outs.push((s.clone(), out));
    }
    std::fs::create_dir_all(dir)
        .with_context(|| format!("{}: cannot create the output directory", dir.display()))?;
    // Where each asset is written (a link to an asset directory: there).
    let mut targets = Vec::new();
    for (_, out) in &outs {
        targets.push(crate::guard::check_asset_output("--out-dir", out)?);
    }
    let opts = options(a);
    let flags = recorded(a);
    let total = Instant::now();
    let ctx = GpuContext::new(&GpuOptions {
        adapter: a.adapter.clone(),
    })?;
    let multi = MultiProgress::new();
    if a.json {
        multi.set_draw_target(indicatif::ProgressDrawTarget::hidden());
    }
    let overall = multi.add(bar(outs.len() as u64, "scenes"));
    let progress = BatchProgress {
        multi: multi.clone(),
        stage: Mutex::new(None),
        quiet: a.json,
    };
    let mut results = Vec::new();
    let mut failed = Vec::new();
    for ((scene_path, out), target) in outs.iter().zip(&targets) {
        let t = Instant::now();
        let mut warnings = Vec::new();
        let r = (|| {
            let scene = load_scene(&scene_args(a, scene_path))?;
            warnings.clone_from(&scene.warnings);
            let load_s = t.elapsed().as_secs_f64();
            bake_one(
                &ctx, &scene, target, &opts, &flags, a.force, &progress, load_s,
            )
        })();
        progress.end();
        let seconds = t.elapsed().as_secs_f64();
        let mut j = match &r {
            Ok(o) => o.json(out),
            Err(e) => json!({"asset": lossy(out), "decision": "failed", "error": format!("{e:#}")}),
        };
        j["scene"] = json!(lossy(scene_path));
        j["seconds"] = json!(seconds);
        j["warnings"] = json!(warnings);
        if !a.json {
            let line = match &r {
                Ok(o) if o.baked.is_some() => format!(
                    "{}: baked in {seconds:.2} s ({})",
                    out.display(),
                    o.reasons.clone().unwrap_or_default().join("; ")
                ),
                Ok(o) => format!(
                    "{}: up to date, left untouched (checked in {:.3} s)",
                    out.display(),
                    o.check_s
                ),
                Err(e) => format!("{}: FAILED: {e:#}", scene_path.display()),
            };
            multi.suspend(|| eprintln!("{line}"));
        }
        if r.is_err() {
            failed.push(scene_path.display().to_string());
        }
        results.push(j);
        overall.inc(1);
    }
    overall.finish_and_clear();
    let count = |d: &str| results.iter().filter(|j| j["decision"] == d).count();
    let (baked, fresh) = (count("baked"), count("up_to_date"));
    let total_s = total.elapsed().as_secs_f64();
    if a.json {
        let j = json!({
            "out_dir": lossy(dir),
            "adapter": ctx.record.to_string(),
            "scenes": results,
            "baked": baked,
            "up_to_date": fresh,
            "failed": failed,
            "total_seconds": total_s,
        });
        crate::output::print_stdout(&serde_json::to_string_pretty(&j)?)?;
    } else {
        eprintln!(
            "batch of {} scenes on {}: {baked} baked, {fresh} up to date, {} failed, {total_s:.2} s",
            outs.len(),
            ctx.record,
            failed.len()
        );
    }
    if failed.is_empty() {
        Ok(ExitCode::SUCCESS)
    } else {
        eprintln!(
            "error: {} of {} scenes failed: {}",
            failed.len(),
            outs.len(),
            failed.join(", ")
        );
        Ok(ExitCode::from(2))
    }
}

/// `gibake merge PART... -o OUT.gibake`.
pub fn merge(a: MergeArgs) -> anyhow::Result<ExitCode> {
    let target = crate::guard::check_asset_output("-o", &a.output)?;
    let inputs: Vec<&Path> = a.parts.iter().map(PathBuf::as_path).collect();
    crate::output::check_not_input("-o", &a.output, &inputs)?;
    let _lock = lock_and_tidy(&target)?;
    let t = Instant::now();
    // One part's front data in memory at a time (plus every shard's maps).
    let mut merger = gibake_asset::Merger::default();
    for p in &a.parts {
        merger.add(p.clone(), gibake_asset::load_part(p)?)?;
    }
    let asset = merger.finish()?;
    gibake_asset::write(&asset, &target)?;
    let seconds = t.elapsed().as_secs_f64();
    let m = &asset.manifest;
    if a.json {
        let j = json!({
            "asset": lossy(&a.output),
            "parts": a.parts.iter().map(|p| lossy(p)).collect::<Vec<_>>(),
            "vpls": asset.vpls.len(),
            "maps_stored": asset.stored_map_count(),
            "seconds": seconds,
        });
        crate::output::print_stdout(&serde_json::to_string_pretty(&j)?)?;
    } else {
        eprintln!(
            "merged {} parts into {}: {} VPLs ({} maps stored), baked from {} by gibake {} on {}, {seconds:.3} s",
            a.parts.len(),
            a.output.display(),
            asset.vpls.len(),
            asset.stored_map_count(),
            m.provenance.scene_name,
            m.provenance.baker_version,
            m.provenance.adapter
        );
    }
    Ok(ExitCode::SUCCESS)
}
