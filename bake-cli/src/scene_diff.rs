//! `gibake diff A B --scene LEVEL` — the image-space diff: both assets
//! rendered by the runtime from the same views at the same times (`full`,
//! and `direct`: the indirect light is `full − direct`, equal to the
//! `indirect` mode's frame to 1e-7 and a twentieth of its cost on
//! lavapipe, where shading every VPL is the frame's cost), compared by
//! `gibake_eval::view_diff`, judged
//! against `--max-image-relmse` and `--max-flip`, and reported as text,
//! JSON (`image_diff`), pictures (`--images`) and Markdown (`--markdown`,
//! a CI job summary or review comment). docs/pipeline.md, "Diffing bakes
//! in CI", has the CI step.

use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use anyhow::{Context, bail};
use gibake_asset::Asset;
use gibake_eval::view_diff::{ViewDiff, ViewPictures};
use gibake_gpu::{GpuContext, GpuOptions};
use gibake_runtime::{CameraMatrices, FrameInput, Mode, RenderSettings, Renderer};
use gibake_scene::Scene;
use serde_json::json;

use crate::cli::{CameraArgs, DiffArgs, SceneArgs};
use crate::guard::lossy;

/// Bytes per rendered pixel of the diff, an upper estimate: the runtime's
/// (see `commands::render`) plus the G-buffer position read back.
const BYTES_PER_PIXEL: u64 = 124;

/// One view and time, compared.
pub struct ViewResult {
    /// What the view is: the camera's name, or `view K` for a `--view`.
    pub name: String,
    /// Animation time, seconds.
    pub time: f32,
    /// The figures.
    pub diff: ViewDiff,
    /// World position of the surface at the largest local change (A's
    /// frame, else B's; `None` where both see the background).
    pub world: Option<[f32; 3]>,
    /// Whether the change is visible (over a threshold).
    pub visible: bool,
    /// The pictures written (`--images`): A, B, heat map, the strip.
    pub pictures: Option<[PathBuf; 4]>,
}

/// The image-space diff of two assets.
pub struct ImageDiff {
    /// Frame size.
    pub width: u32,
    /// Frame height.
    pub height: u32,
    /// Supersampling.
    pub ssaa: u32,
    /// The adapter that rendered.
    pub adapter: String,
    /// A's and B's scenes.
    pub scenes: [PathBuf; 2],
    /// The thresholds.
    pub max_relmse: f64,
    /// The thresholds.
    pub max_flip: f64,
    /// Per view and time.
    pub views: Vec<ViewResult>,
}

impl ImageDiff {
    /// Whether any view changed visibly.
    pub fn visible(&self) -> bool {
        self.views.iter().any(|v| v.visible)
    }

    /// The verdict in words.
    pub fn verdict(&self) -> String {
        let n = self.views.iter().filter(|v| v.visible).count();
        if n == 0 {
            format!(
                "no visible change ({} view{} within rel MSE {} and FLIP {})",
                self.views.len(),
                plural(self.views.len()),
                self.max_relmse,
                self.max_flip
            )
        } else {
            format!(
                "VISIBLE CHANGE in {n} of {} view{} (over rel MSE {} or FLIP {})",
                self.views.len(),
                plural(self.views.len()),
                self.max_relmse,
                self.max_flip
            )
        }
    }

    /// The `image_diff` object of `--json`.
    pub fn json(&self, base: Option<&Path>) -> serde_json::Value {
        let views: Vec<_> = self
            .views
            .iter()
            .map(|v| {
                let mut j = serde_json::to_value(&v.diff).unwrap_or_default();
                j["view"] = json!(v.name);
                j["time"] = json!(v.time);
                j["local_world"] = json!(v.world);
                j["visible"] = json!(v.visible);
                if let Some(p) = &v.pictures {
                    let show = |p: &Path| lossy(&base.map_or(p.to_owned(), |b| relative(b, p)));
                    j["pictures"] = json!({
                        "a": show(&p[0]), "b": show(&p[1]), "heat": show(&p[2]), "strip": show(&p[3]),
                    });
                }
                j
            })
            .collect();
        json!({
            "scenes": [lossy(&self.scenes[0]), lossy(&self.scenes[1])],
            "width": self.width,
            "height": self.height,
            "ssaa": self.ssaa,
            "adapter": self.adapter,
            "max_image_relmse": self.max_relmse,
            "max_flip": self.max_flip,
            "visible": self.visible(),
            "verdict": self.verdict(),
            "views": views,
        })
    }

    /// The text report (after the data diff's).
    pub fn text(&self) -> String {
        let mut s = format!(
            "image diff ({}×{}, ssaa {}, on {}):\n",
            self.width, self.height, self.ssaa, self.adapter
        );
        for v in &self.views {
            let _ = writeln!(
                s,
                "  {} at t = {} s: rel MSE {:.3e}, FLIP {:.4}, indirect mean {}, largest local change {} at {}  {}",
                v.name,
                v.time,
                v.diff.rel_mse,
                v.diff.flip,
                indirect_change(&v.diff),
                local(&v.diff),
                place(v),
                if v.visible { "VISIBLE" } else { "ok" }
            );
        }
        let _ = write!(s, "verdict: {}", self.verdict());
        s
    }

    /// The Markdown summary; picture paths relative to `dir` (the
    /// Markdown file's directory). `data` is the data diff's text.
    pub fn markdown(&self, a: &Path, b: &Path, dir: &Path, data: &str) -> String {
        let mut s = String::new();
        let (mark, words) = if self.visible() {
            ("FAIL", "visible change")
        } else {
            ("PASS", "no visible change")
        };
        let _ = writeln!(s, "## gibake diff: **{mark}**, {words}\n");
        let _ = writeln!(
            s,
            "`{}` (baked from `{}`) against `{}` (baked from `{}`): {}.\n",
            name(a),
            name(&self.scenes[0]),
            name(b),
            name(&self.scenes[1]),
            self.verdict()
        );
        let _ = writeln!(
            s,
            "Frames {}×{} (ssaa {}) rendered by the gibake runtime on {}. A view fails when B's frame differs from A's by more than rel MSE {} or mean FLIP {}.\n",
            self.width, self.height, self.ssaa, self.adapter, self.max_relmse, self.max_flip
        );
        s.push_str(
            "| view | time | rel MSE | mean FLIP | indirect mean change (R / G / B) | largest local change | where | |\n\
             |---|---:|---:|---:|---|---|---|---|\n",
        );
        for v in &self.views {
            let _ = writeln!(
                s,
                "| {} | {} s | {:.3e} | {:.4} | {} | {} | {} | {} |",
                v.name,
                v.time,
                v.diff.rel_mse,
                v.diff.flip,
                indirect_change(&v.diff),
                local(&v.diff),
                place(v),
                if v.visible { "**FAIL**" } else { "pass" }
            );
        }
        for v in &self.views {
            let Some(p) = &v.pictures else { continue };
            let _ = writeln!(
                s,
                "\n### {} at t = {} s\n\nA | B | change (FLIP heat map; the box: the largest local change)\n\n![{}: A, B and the change]({})",
                v.name,
                v.time,
                v.name,
                md_path(&relative(dir, &p[3]))
            );
        }
        let _ = writeln!(
            s,
            "\n<details><summary>The data diff (VPLs, trees, maps)</summary>\n\n```\n{}\n```\n</details>",
            data.trim_end()
        );
        s
    }
}

fn plural(n: usize) -> &'static str {
    if n == 1 { "" } else { "s" }
}

fn name(p: &Path) -> String {
    p.file_name()
        .map_or_else(|| lossy(p), |n| lossy(Path::new(n)))
}

fn indirect_change(d: &ViewDiff) -> String {
    d.indirect_change
        .iter()
        .map(|c| match c {
            Some(v) if (v * 100.0).abs() < 0.05 => "0.0%".into(),
            Some(v) => format!("{:+.1}%", v * 100.0),
            None => "new".into(),
        })
        .collect::<Vec<_>>()
        .join(" / ")
}

fn local(d: &ViewDiff) -> String {
    format!(
        "{:.2}× the mean brightness ({}×{} px)",
        d.local_change,
        2 * d.local_radius + 1,
        2 * d.local_radius + 1
    )
}

fn place(v: &ViewResult) -> String {
    let [x, y] = v.diff.local_at;
    match v.world {
        Some(w) => format!(
            "pixel ({x}, {y}), world ({:.3}, {:.3}, {:.3})",
            w[0], w[1], w[2]
        ),
        None => format!("pixel ({x}, {y})"),
    }
}

/// `to` relative to the directory `from` (both made absolute first).
pub fn relative(from: &Path, to: &Path) -> PathBuf {
    let abs = |p: &Path| {
        std::fs::canonicalize(p).unwrap_or_else(|_| {
            std::env::current_dir()
                .map(|d| d.join(p))
                .unwrap_or_else(|_| p.to_owned())
        })
    };
    let (f, t) = (abs(from), abs(to));
    let (fc, tc): (Vec<_>, Vec<_>) = (f.components().collect(), t.components().collect());
    let common = fc.iter().zip(&tc).take_while(|(a, b)| a == b).count();
    let mut out = PathBuf::new();
    for _ in common..fc.len() {
        out.push("..");
    }
    for c in &tc[common..] {
        out.push(c);
    }
    out
}

/// A path for a Markdown link: `/` separators, spaces and parentheses
/// escaped.
fn md_path(p: &Path) -> String {
    lossy(p)
        .replace('\\', "/")
        .replace(' ', "%20")
        .replace('(', "%28")
        .replace(')', "%29")
}

/// A file-name-safe key for a view at a time: `camera_t0`, `view2_t1.5`.
fn key(name: &str, time: f32) -> String {
    let base: String = name
        .chars()
        .filter_map(|c| match c {
            'a'..='z' | 'A'..='Z' | '0'..='9' | '_' | '-' => Some(c),
            ' ' | '.' => Some('_'),
            _ => None,
        })
        .collect();
    let base = if base.is_empty() { "view".into() } else { base };
    format!("{base}_t{time}")
}

/// What `--scene` needs checked before any work: the scene count, sizes,
/// times, the frames' memory.
pub fn check_args(a: &DiffArgs) -> anyhow::Result<()> {
    if a.scenes.len() > 2 {
        bail!(
            "--scene is given {} times: give the scene both assets were baked from, or two (A's, then B's)",
            a.scenes.len()
        );
    }
    crate::commands::check_size(a.width, a.height)?;
    for &t in &a.times {
        crate::commands::check_time(t)?;
    }
    let pixels = u64::from(a.width * a.ssaa) * u64::from(a.height * a.ssaa);
    let need = pixels * BYTES_PER_PIXEL;
    let budget = crate::limits::memory();
    if need > budget {
        bail!(
            "rendering {}×{} with --ssaa {} needs about {} MiB, over the memory budget of {} MiB: \
             render smaller, lower --ssaa, or raise --max-memory",
            a.width,
            a.height,
            a.ssaa,
            need >> 20,
            budget >> 20
        );
    }
    Ok(())
}

/// The views asked for: `--view-camera` names, then `--view`s; the
/// scene's first camera when none is given.
fn choices(a: &DiffArgs) -> Vec<(Option<String>, CameraArgs)> {
    let mut v: Vec<(Option<String>, CameraArgs)> = a
        .view_cameras
        .iter()
        .map(|n| {
            let camera = CameraArgs {
                camera: Some(n.clone()),
                look_at: None,
            };
            (Some(n.clone()), camera)
        })
        .collect();
    let several = a.views.len() > 1;
    for (k, l) in a.views.iter().enumerate() {
        let name = if several {
            format!("view {}", k + 1)
        } else {
            "view".into()
        };
        let camera = CameraArgs {
            camera: None,
            look_at: Some(*l),
        };
        v.push((Some(name), camera));
    }
    if v.is_empty() {
        v.push((None, CameraArgs::default()));
    }
    v
}

/// Renders both assets and compares them (see the module docs); writes the
/// pictures into `--images` when given.
pub fn run(a: &DiffArgs, asset_a: &Asset, asset_b: &Asset) -> anyhow::Result<ImageDiff> {
    let scenes = [
        a.scenes[0].clone(),
        a.scenes.get(1).unwrap_or(&a.scenes[0]).clone(),
    ];
    let views = choices(a);
    let times = if a.times.is_empty() {
        vec![0.0]
    } else {
        a.times.clone()
    };
    // Every scene first, each loaded as `render` loads it for its asset
    // (the scene flags the asset records applied, then checked against the
    // asset's lights and static-scene hash), then the GPU.
    let mut side_scenes: Vec<Vec<Scene>> = Vec::new();
    for (k, (asset, dir)) in [(asset_a, &a.a), (asset_b, &a.b)].into_iter().enumerate() {
        let mut per_view = Vec::new();
        for (_, camera) in &views {
            let args = SceneArgs {
                scene: scenes[k].clone(),
                lights: a.lights.clone(),
                all_lights: false,
                level: a.level.clone(),
                camera: camera.clone(),
                limits: a.limits.clone(),
            };
            let scene = crate::commands::load_level(&args, Some((dir, asset)), "diff")
                .map_err(|e| {
                    if a.scenes.len() == 1 {
                        e.context(format!(
                            "give the scene each asset was baked from: --scene A_SCENE --scene B_SCENE (one --scene {} is used for both)",
                            scenes[0].display()
                        ))
                    } else {
                        e
                    }
                })?;
            per_view.push(scene);
        }
        for s in &per_view {
            if s.camera.is_none() {
                bail!(
                    "{}: the level has no camera: give the views to compare with --view EX,EY,EZ,TX,TY,TZ[,FOV] or --view-camera NAME",
                    scenes[k].display()
                );
            }
        }
        side_scenes.push(per_view);
    }
    let ctx = GpuContext::new(&GpuOptions {
        adapter: a.adapter.clone(),
    })?;
    let (w, h) = (a.width * a.ssaa, a.height * a.ssaa);
    // frames[side][full, direct][view × time]; positions[side][view × time].
    let mut frames: Vec<[Vec<gibake_image::Image>; 2]> = Vec::new();
    let mut positions: Vec<Vec<Vec<f32>>> = Vec::new();
    for (k, asset) in [asset_a, asset_b].into_iter().enumerate() {
        let per_view = &side_scenes[k];
        let mut by_mode: [Vec<gibake_image::Image>; 2] = [Vec::new(), Vec::new()];
        let mut pos = Vec::new();
        for (m, mode) in [Mode::Full, Mode::Direct].into_iter().enumerate() {
            let settings = RenderSettings {
                width: w,
                height: h,
                shadow_map_size: a.shadow_map_size,
                mode,
                // Every pixel shades every VPL: no interleave filter.
                interleave: 1,
                max_spawned: 0,
                ..Default::default()
            };
            let mut r = Renderer::new(
                &ctx.device,
                &ctx.queue,
                &per_view[0],
                Some(asset),
                &settings,
            )
            .with_context(|| format!("setting up {}", scenes[k].display()))?;
            for scene in per_view {
                for &t in &times {
                    let camera = CameraMatrices::from_scene(scene, t, w, h)?;
                    let transforms = gibake_runtime::scene_transforms(scene, t);
                    r.prepare(
                        &ctx.device,
                        &ctx.queue,
                        &FrameInput::new(camera).transforms(&transforms),
                    )?;
                    let mut enc = ctx.device.create_command_encoder(&Default::default());
                    r.record(&mut enc);
                    ctx.queue.submit([enc.finish()]);
                    by_mode[m].push(gibake_eval::frame::read_output(
                        &r,
                        &ctx.device,
                        &ctx.queue,
                        a.ssaa,
                    )?);
                    if mode == Mode::Full {
                        let p = r.gbuffer_positions(&ctx.device, &ctx.queue)?;
                        pos.push(p.into_iter().flatten().collect());
                    }
                }
            }
        }
        frames.push(by_mode);
        positions.push(pos);
    }
    if let Some(dir) = &a.images {
        std::fs::create_dir_all(dir).with_context(|| format!("creating {}", dir.display()))?;
    }
    let mut results = Vec::new();
    let mut keys = std::collections::HashSet::new();
    let mut i = 0;
    for (vi, (name, _)) in views.iter().enumerate() {
        let name = name.clone().unwrap_or_else(|| {
            side_scenes[0][vi]
                .camera
                .as_ref()
                .map_or_else(|| "camera".into(), |c| c.name.clone())
        });
        for &t in &times {
            let indirect = |k: usize| frames[k][0][i].sub(&frames[k][1][i]);
            let (d, pictures) = gibake_eval::view_diff::compare(
                &frames[0][0][i],
                &frames[1][0][i],
                &indirect(0),
                &indirect(1),
            )?;
            // The surface at the largest change, A's else B's.
            let [x, y] = d.local_at;
            let at = ((y * a.ssaa + a.ssaa / 2) * w + x * a.ssaa + a.ssaa / 2) as usize * 4;
            let world = positions.iter().find_map(|p| {
                let v = p[i].get(at..at + 4)?;
                (v[3] > 0.5 && v[..3].iter().all(|c| c.is_finite())).then(|| [v[0], v[1], v[2]])
            });
            let visible = !(d.rel_mse <= a.max_image_relmse && d.flip <= a.max_flip);
            // One file name per view and time (a view named twice gets `_2`).
            let mut k = key(&name, t);
            let mut n = 1;
            while !keys.insert(k.clone()) {
                n += 1;
                k = format!("{}_{n}", key(&name, t));
            }
            let written = match &a.images {
                Some(dir) => Some(write_pictures(dir, &k, &pictures)?),
                None => None,
            };
            results.push(ViewResult {
                name: name.clone(),
                time: t,
                diff: d,
                world,
                visible,
                pictures: written,
            });
            i += 1;
        }
    }
    Ok(ImageDiff {
        width: a.width,
        height: a.height,
        ssaa: a.ssaa,
        adapter: ctx.record.to_string(),
        scenes,
        max_relmse: a.max_image_relmse,
        max_flip: a.max_flip,
        views: results,
    })
}

/// Writes `KEY_a.png`, `KEY_b.png`, `KEY_heat.png` and the strip
/// `KEY.png` into `dir`, each through a temporary and a rename.
fn write_pictures(dir: &Path, key: &str, p: &ViewPictures) -> anyhow::Result<[PathBuf; 4]> {
    let paths = [
        dir.join(format!("{key}_a.png")),
        dir.join(format!("{key}_b.png")),
        dir.join(format!("{key}_heat.png")),
        dir.join(format!("{key}.png")),
    ];
    for (path, rgb) in paths.iter().zip([&p.a, &p.b, &p.heat]) {
        crate::guard::check_file_output("--images", path)?;
        crate::output::write_rgb8_png_atomic(path, p.width, p.height, rgb)?;
    }
    let (sw, sh, strip) = p.strip();
    crate::guard::check_file_output("--images", &paths[3])?;
    crate::output::write_rgb8_png_atomic(&paths[3], sw, sh, &strip)?;
    Ok(paths)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn keys_and_relative_paths() {
        assert_eq!(key("camera", 0.0), "camera_t0");
        assert_eq!(key("view 2", 1.5), "view_2_t1.5");
        assert_eq!(key("../x", 0.25), "__x_t0.25");
        assert_eq!(
            relative(Path::new("/a/b"), Path::new("/a/c/d.png")),
            PathBuf::from("../c/d.png")
        );
        assert_eq!(
            relative(Path::new("/a"), Path::new("/a/p/x.png")),
            PathBuf::from("p/x.png")
        );
        assert_eq!(md_path(Path::new("my dir/(1).png")), "my%20dir/%281%29.png");
    }
}
