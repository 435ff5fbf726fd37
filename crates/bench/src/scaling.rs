//! `gibake bench scaling`: how the per-frame cost grows, with growth
//! exponents fitted by least squares in log-log space
//! (`gibake_eval::fit::power_fit`): static triangles 1…64× (corner_bunny's
//! static detail multiplier), moving objects 1…64, static VPLs 64…4096,
//! lights 1…64 (corner_bunny's spot plus point lamps with a range, in a
//! grid under the ceiling: the update against the lamps' views the balls
//! touch, the shading against every light).
//! The update (every pass the moving objects cause) and the shade (shade
//! pass + interleave filter) are timed separately, GPU timestamps where the
//! adapter has them; each sweep's points are measured side by side.

use std::path::Path;

use gibake_eval::fit::{PowerFit, power_fit};
use gibake_runtime::{Mode, RenderSettings};
use gibake_scene::{LoadOptions, Scene};
use serde_json::json;

use super::frame::{Config, FrameSummary, measure_all};
use super::plot::{Curve, scaling};
use super::report::sig;
use super::{Bench, CORNER_BUNNY, Table, load_embedded};
use crate::out::bar;

/// corner_bunny with `n` moving objects: the first `n` of its 13 balls, and
/// beyond 13, copies of them that follow the same paths (each drawn and
/// updated like a ball of its own).
fn with_moving(base: &Scene, n: usize) -> Scene {
    let mut s = base.clone();
    let objs = &base.dynamic_objects;
    s.dynamic_objects = (0..n)
        .filter_map(|i| objs.get(i % objs.len().max(1)).cloned())
        .collect();
    s
}

/// corner_bunny with `n` lights: its spot, then `n − 1` point lamps in a
/// grid 0.3 below the ceiling of its static bounds, each lighting a range
/// of a quarter of the room's width (glTF `range`): a ball touches the
/// views of the lamps it passes, not all of them.
fn with_lights(base: &Scene, n: usize) -> Scene {
    let mut s = base.clone();
    let b = s.static_bounds();
    let size = b.max - b.min;
    let lamps = n.saturating_sub(1);
    let side = (lamps as f64).sqrt().ceil().max(1.0) as usize;
    let range = 0.25 * size.x.max(size.z);
    for k in 0..lamps {
        let (i, j) = (k % side, k / side);
        let f = |a: usize| (a as f32 + 0.5) / side as f32;
        s.lights.push(gibake_scene::Light {
            name: format!("lamp {k}"),
            kind: gibake_scene::LightKind::Point,
            color: gibake_runtime::glam::Vec3::splat(2.0 * range * range),
            position: gibake_runtime::glam::Vec3::new(
                b.min.x + f(i) * size.x,
                b.max.y - 0.3 * size.y.min(size.x),
                b.min.z + f(j) * size.z,
            ),
            direction: gibake_runtime::glam::Vec3::NEG_Y,
            range: Some(range),
        });
    }
    s
}

/// corner_bunny with its balls replaced by four balls of a tenth of the
/// room's width resting on its floor, one towards each corner (at 35% of the
/// room's width from its centre): moving objects far apart in the spot's
/// view, which the bounce clusters in a window each
/// ([`RenderSettings::split_windows`]).
fn with_balls_far_apart(base: &Scene) -> Scene {
    let mut s = base.clone();
    s.dynamic_objects.clear();
    let b = s.static_bounds();
    let (c, size) = ((b.min + b.max) * 0.5, b.max - b.min);
    let r = 0.05 * size.x.min(size.z);
    for (k, (dx, dz)) in [(-1.0, -1.0), (1.0, -1.0), (-1.0, 1.0), (1.0, 1.0)]
        .into_iter()
        .enumerate()
    {
        let ball = gibake_eval::levels::LevelBall {
            center: [
                c.x + dx * 0.35 * size.x,
                b.min.y + r,
                c.z + dz * 0.35 * size.z,
            ],
            radius: r,
            albedo: [0.8, 0.3, 0.2],
        };
        gibake_eval::levels::add_ball(&mut s, &format!("far ball {k}"), &ball);
    }
    s
}

/// One sweep: its name, the x axis, and the scenes/bakes at each point.
struct Sweep {
    key: &'static str,
    title: &'static str,
    x_desc: &'static str,
}

const SWEEPS: [Sweep; 4] = [
    Sweep {
        key: "static_triangles",
        title: "static triangles (corner_bunny heavy 1…64×)",
        x_desc: "static triangles (log)",
    },
    Sweep {
        key: "moving_objects",
        title: "moving objects (1…64)",
        x_desc: "moving objects (log)",
    },
    Sweep {
        key: "static_vpls",
        title: "static VPLs (64…4096)",
        x_desc: "static VPLs (log)",
    },
    Sweep {
        key: "lights",
        title: "lights (1…64: a spot and point lamps with a range)",
        x_desc: "lights (log)",
    },
];

/// Runs the four sweeps.
pub(super) fn bench_scaling(b: &mut Bench) -> crate::Result<()> {
    b.section("Scaling: growth exponents");
    let quick = b.quick;
    let size = if quick { 64 } else { 128 };
    let frames = if quick { 1 } else { b.frames.min(3) };
    let (vpls, map) = (250u32, 64u32);
    let heavies: Vec<u32> = if quick {
        vec![1, 4]
    } else {
        vec![1, 2, 4, 8, 16, 32, 64]
    };
    let movings: Vec<usize> = if quick {
        vec![1, 4]
    } else {
        vec![1, 2, 4, 8, 16, 32, 64]
    };
    let budgets: Vec<u32> = if quick {
        vec![64, 256]
    } else {
        vec![64, 128, 256, 512, 1024, 2048, 4096]
    };
    let lights: Vec<usize> = if quick {
        vec![1, 4]
    } else {
        vec![1, 2, 4, 8, 16, 32, 64]
    };
    let cb = load_embedded(CORNER_BUNNY, "corner_bunny")?;
    let settings = RenderSettings {
        width: size,
        height: size,
        shadow_map_size: 2048,
        mode: Mode::Full,
        max_dynamic_vpls: 64,
        interleave: 1,
        max_spawned: 0,
        ..Default::default()
    };
    let mut fits_json = Vec::new();
    let mut summary = Table::new(
        format!(
            "Fitted growth exponents (least squares in log-log, time ∝ x^k) — mode full, {size}², interleave 1, median of {frames} frame(s) after a warm-up — adapter: {}",
            b.adapter
        ),
        &[
            "sweep",
            "range",
            "update k (R²)",
            "shade+filter k (R²)",
            "frame k (R²)",
        ],
    );
    for sw in &SWEEPS {
        // Scenes and bakes of the sweep's points: (x, scene, budget).
        let mut points: Vec<(Scene, u32)> = Vec::new();
        match sw.key {
            "static_triangles" => {
                for &h in &heavies {
                    let bytes = gibake_scenegen::corner_bunny(&gibake_scenegen::Params {
                        heavy: h,
                        ..Default::default()
                    });
                    let scene = gibake_scene::load_from_slice(
                        &bytes,
                        Path::new(&format!("corner_bunny_heavy{h}.glb (generated)")),
                        &LoadOptions::default(),
                    )?;
                    points.push((scene, vpls));
                }
            }
            "moving_objects" => {
                for &n in &movings {
                    points.push((with_moving(&cb, n), vpls));
                }
            }
            "lights" => {
                for &n in &lights {
                    points.push((with_lights(&cb, n), vpls));
                }
            }
            _ => {
                for &v in &budgets {
                    points.push((cb.clone(), v));
                }
            }
        }
        // The lights sweep also measures each point with light culling off,
        // side by side with it on.
        let culling_off = sw.key == "lights";
        let per_point = 2 + u64::from(frames) + u64::from(culling_off) * (1 + u64::from(frames));
        let pb = bar(points.len() as u64 * per_point, sw.key);
        let mut assets = Vec::new();
        let mut bake_s = Vec::new();
        for (scene, v) in &points {
            let (out, seconds) = b.bake(scene, *v, map)?;
            assets.push(out.asset);
            bake_s.push(seconds);
            pb.inc(1);
        }
        let mut configs: Vec<Config<'_>> = points
            .iter()
            .zip(&assets)
            .map(|((scene, _), asset)| Config {
                scene,
                asset: Some(asset),
                settings: settings.clone(),
                frames,
            })
            .collect();
        if culling_off {
            let off: Vec<Config<'_>> = points
                .iter()
                .zip(&assets)
                .map(|((scene, _), asset)| Config {
                    scene,
                    asset: Some(asset),
                    settings: RenderSettings {
                        light_culling: false,
                        ..settings.clone()
                    },
                    frames,
                })
                .collect();
            configs.extend(off);
        }
        let mut measured: Vec<FrameSummary> = measure_all(&b.ctx, &configs, &|| pb.inc(1))?;
        let unculled: Vec<FrameSummary> = measured.split_off(points.len());
        pb.finish_and_clear();
        let xs: Vec<f64> = points
            .iter()
            .zip(&assets)
            .map(|((scene, _), asset)| match sw.key {
                "static_triangles" => scene.triangle_counts().0 as f64,
                "moving_objects" => scene.dynamic_objects.len() as f64,
                "lights" => scene.lights.len() as f64,
                _ => asset.manifest.vpl_count as f64,
            })
            .collect();
        let fit_of = |f: &dyn Fn(&FrameSummary) -> f64| -> Option<PowerFit> {
            let pts: Vec<(f64, f64)> = xs.iter().zip(&measured).map(|(x, m)| (*x, f(m))).collect();
            power_fit(&pts)
        };
        let fu = fit_of(&|m| m.update_ms);
        let fs = fit_of(&|m| m.shade_ms);
        let ff = fit_of(&|m| m.frame_ms);
        let show = |f: &Option<PowerFit>| {
            f.map(|f| format!("{:.2} ({:.2})", f.exponent, f.r2))
                .unwrap_or_else(|| "—".into())
        };
        let mut head = vec![
            "x",
            "static tris",
            "moving objects",
            "static VPLs",
            "lights",
            "affected maps",
            "light views merged",
            "light views bounced",
            "bounce texels",
            "update (ms)",
            "shade+filter (ms)",
        ];
        if culling_off {
            head.push("shade+filter, no light culling (ms)");
        }
        head.push("frame (ms)");
        head.push("bake (s)");
        let mut t = Table::new(
            format!(
                "Scaling with {} — corner_bunny, mode full, {size}², interleave 1, {map}² maps, median of {frames} frame(s) after a warm-up — times: {} — adapter: {}",
                sw.title,
                measured.first().map(|m| m.timing.as_str()).unwrap_or(""),
                b.adapter
            ),
            &head,
        );
        let mut rows = Vec::new();
        for (k, ((scene, _), asset)) in points.iter().zip(&assets).enumerate() {
            let m = &measured[k];
            let (st, _) = scene.triangle_counts();
            let mut row = vec![
                sig(xs[k]),
                st.to_string(),
                scene.dynamic_objects.len().to_string(),
                asset.manifest.vpl_count.to_string(),
                scene.lights.len().to_string(),
                format!("{:.0}", m.affected_maps),
                format!("{:.0}", m.light_views),
                format!("{:.0}", m.light_bounce_views),
                format!("{:.0}", m.bounce_texels),
                sig(m.update_ms),
                sig(m.shade_ms),
            ];
            if culling_off {
                row.push(unculled.get(k).map_or("—".into(), |u| sig(u.shade_ms)));
            }
            row.push(sig(m.frame_ms));
            row.push(sig(bake_s[k]));
            t.row(row);
            rows.push(json!({
                "x": xs[k],
                "static_triangles": st,
                "moving_objects": scene.dynamic_objects.len(),
                "static_vpls": asset.manifest.vpl_count,
                "stats": m.json(),
                "stats_no_light_culling": unculled.get(k).map(FrameSummary::json),
                "bake_seconds": bake_s[k],
            }));
        }
        let line = format!(
            "Fitted exponents ({}): update **{}**, shade+filter **{}**, frame **{}** (k (R²); time ∝ x^k).",
            sw.key,
            show(&fu),
            show(&fs),
            show(&ff)
        );
        eprintln!("{line}");
        t.notes.push(line);
        if sw.key == "lights" {
            // The update against the views the balls touch (the light
            // merge's and the light bounce's passes), where some are
            // touched.
            let pts: Vec<(f64, f64)> = measured
                .iter()
                .filter(|m| m.light_views > 0.0)
                .map(|m| (m.light_views, m.update_ms))
                .collect();
            let fv = power_fit(&pts);
            let unculled_fit = power_fit(
                &xs.iter()
                    .zip(&unculled)
                    .map(|(x, m)| (*x, m.shade_ms))
                    .collect::<Vec<_>>(),
            );
            let ratio = measured
                .last()
                .zip(unculled.last())
                .map_or(f64::NAN, |(m, u)| m.shade_ms / u.shade_ms);
            // The bake against the lights: each view's RSM by its share of
            // the bounce (lights::ViewPlan), so more lamps sharing one
            // budget do not each cost a full-size RSM.
            let fb = power_fit(
                &xs.iter()
                    .zip(&bake_s)
                    .map(|(x, s)| (*x, *s))
                    .collect::<Vec<_>>(),
            );
            let line = format!(
                "Update (light merge and light bounce) against the lamps' views the moving objects touch (x = views merged): **{}**. Shade+filter with light culling (each 8×8 tile skips the lamps whose range ends before its surfaces) **{}**, without **{}**; at the most lights, culled / unculled = **{:.2}** (side by side). Bake (one budget; each view's RSM by its share of the bounce) against the lights: **{}**.",
                show(&fv),
                show(&fs),
                show(&unculled_fit),
                ratio,
                show(&fb)
            );
            eprintln!("{line}");
            t.notes.push(line);
        }
        if sw.key == "moving_objects" {
            t.notes.push(
                "corner_bunny has 13 balls: points beyond 13 add copies of them on the same paths \
                 (more draws and update work, no new affected maps)."
                    .into(),
            );
        }
        let range = format!(
            "{} … {}",
            sig(xs.first().copied().unwrap_or(f64::NAN)),
            sig(xs.last().copied().unwrap_or(f64::NAN))
        );
        summary.row(vec![sw.key.into(), range, show(&fu), show(&fs), show(&ff)]);
        b.emit(&t);
        let file = format!("scaling_{}.png", sw.key);
        let curve = |name: &str, f: &Option<PowerFit>, get: &dyn Fn(&FrameSummary) -> f64| Curve {
            name: format!(
                "{name}{}",
                f.map(|f| format!(" (k = {:.2})", f.exponent))
                    .unwrap_or_default()
            ),
            points: xs
                .iter()
                .zip(&measured)
                .map(|(x, m)| (*x, get(m)))
                .collect(),
            fit: f.map(|f| (f.scale, f.exponent)),
        };
        scaling(
            &b.out.join(&file),
            &format!(
                "GPU time against {} ({})",
                sw.title,
                b.adapter.split(" (").next().unwrap_or(&b.adapter)
            ),
            sw.x_desc,
            &[
                curve("update", &fu, &|m| m.update_ms),
                curve("shade+filter", &fs, &|m| m.shade_ms),
                curve("frame", &ff, &|m| m.frame_ms),
            ],
        )?;
        b.plot_written(&file, "scaling");
        fits_json.push(json!({
            "sweep": sw.key,
            "update": fu,
            "shade": fs,
            "frame": ff,
            "points": rows,
        }));
    }
    b.emit(&summary);
    let far = far_apart(b, &cb, &settings, vpls, map, frames, size)?;
    b.write_json(
        "scaling",
        &json!({"adapter": b.adapter, "size": size, "frames": frames, "vpl_map_size": map, "sweeps": fits_json, "far_apart": far}),
    )
}

/// Moving objects far apart in one view ([`with_balls_far_apart`]): the
/// bounce with a window per group against one window around them all,
/// side by side. Returns the rows' JSON.
fn far_apart(
    b: &mut Bench,
    cb: &Scene,
    settings: &RenderSettings,
    vpls: u32,
    map: u32,
    frames: u32,
    size: u32,
) -> crate::Result<serde_json::Value> {
    let scene = with_balls_far_apart(cb);
    let asset = b.bake(&scene, vpls, map)?.0.asset;
    let configs: Vec<Config<'_>> = [true, false]
        .into_iter()
        .map(|split| Config {
            scene: &scene,
            asset: Some(&asset),
            settings: RenderSettings {
                split_windows: split,
                // The first light's full slot pyramid, as a game would.
                max_dynamic_vpls: 256,
                ..settings.clone()
            },
            frames,
        })
        .collect();
    let pb = bar(configs.len() as u64, "far apart");
    let measured = measure_all(&b.ctx, &configs, &|| pb.inc(1))?;
    pb.finish_and_clear();
    let pass = |m: &FrameSummary, name: &str| {
        m.passes
            .iter()
            .find(|(n, _)| n == name)
            .map_or("—".into(), |(_, ms)| sig(*ms))
    };
    let mut t = Table::new(
        format!(
            "Moving objects far apart — corner_bunny with four balls towards its corners, mode full, {size}², interleave 1, {map}² maps, 256 dynamic VPLs, median of {frames} frame(s) after a warm-up — times: {} — adapter: {}",
            measured.first().map(|m| m.timing.as_str()).unwrap_or(""),
            b.adapter
        ),
        &[
            "bounce windows",
            "bounce texels",
            "occlusion (ms)",
            "dynamic vpls (ms)",
            "update (ms)",
            "frame (ms)",
        ],
    );
    let mut rows = Vec::new();
    for (m, name) in measured
        .iter()
        .zip(["a window per group (default)", "one window around all"])
    {
        t.row(vec![
            name.into(),
            format!("{:.0}", m.bounce_texels),
            pass(m, "occlusion"),
            pass(m, "dynamic vpls"),
            sig(m.update_ms),
            sig(m.frame_ms),
        ]);
        rows.push(json!({"windows": name, "stats": m.json()}));
    }
    t.notes.push(
        "Side by side in one run. The windows' accuracy (each ball's own cells against one coarse \
         window's) is measured against the reference by `moving_effect` (docs/results.md)."
            .into(),
    );
    b.emit(&t);
    Ok(serde_json::Value::Array(rows))
}
