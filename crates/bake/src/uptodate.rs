//! Whether an existing asset is up to date, so a pipeline that re-runs
//! `gibake bake` on every content change re-bakes only what changed.
//!
//! An asset is up to date when its manifest records exactly what a bake now
//! would record as its inputs: the same static-scene hash, the same settings,
//! the same scene file name, the same baker version and the same adapter
//! (name, backend, driver), and
//! its files are intact (sizes and BLAKE3 checksums as listed). Because the
//! bake is deterministic, a re-bake would then write the same bytes.
//!
//! The static-scene hash leaves the moving objects out (an asset stays
//! valid for the runtime when they change), yet the bytes depend on them
//! through one thing: their **swept bounds**, the box they fill over the
//! animation. The primary light's view is fitted to it, the other lights'
//! views it can enter store their static RSMs (format 4.1), and the reach
//! probe aims rays at it and keeps the VPLs whose light only it receives —
//! which moves the clustering threshold a `--vpls` budget searches. So the
//! asset records the box it was baked with ([`Manifest::swept_bounds`],
//! format 4.5) and the check compares it bit for bit, as it compares
//! whether the scene has moving objects at all (then the static RSM is
//! stored). An asset from before 4.5 does not record it: one of a level
//! with moving objects is re-baked once (without them the box is empty
//! and shapes nothing). "Up to date" then means a clean bake would write
//! the same data (an older asset's manifest keeps its older minor).

use std::path::Path;

use gibake_asset::{AssetError, Manifest};
use gibake_gpu::{AdapterRecord, LightView};
use gibake_scene::Scene;

use crate::BakeOptions;
use crate::cluster::ClusterTarget;

/// The outcome of [`check_up_to_date`].
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum Freshness {
    /// The existing asset records the same inputs and is intact: leave it.
    UpToDate,
    /// A (re-)bake is needed; the reasons, one line each (never empty).
    Stale(Vec<String>),
}

fn hex8(h: &[u8; 32]) -> String {
    h[..8].iter().map(|b| format!("{b:02x}")).collect()
}

/// The moving objects' swept bounds as a bake of `scene` records them
/// ([`Manifest::swept_bounds`]): `[min x, min y, min z, max x, max y,
/// max z]`, an empty box (`+∞ … −∞`) without moving objects.
pub fn swept_record(scene: &Scene) -> [f32; 6] {
    let b = scene.dynamic_swept_bounds();
    [b.min.x, b.min.y, b.min.z, b.max.x, b.max.y, b.max.z]
}

/// A recorded swept box for messages: `none` when empty, else
/// `(x, y, z)–(x, y, z)` with 4 significant digits.
fn show_box(b: &[f32; 6]) -> String {
    if (0..3).any(|k| b[k] > b[k + 3]) {
        return "none".into();
    }
    let p = |v: &[f32]| format!("({:.4}, {:.4}, {:.4})", v[0], v[1], v[2]);
    format!("{}–{}", p(&b[..3]), p(&b[3..]))
}

/// Compares the asset at `dir` with what baking `scene` with `opts` on
/// `adapter` by `baker_version` would record. Reads only the manifest and
/// hashes the asset's files; renders nothing.
pub fn check_up_to_date(
    dir: &Path,
    scene: &Scene,
    opts: &BakeOptions,
    adapter: &AdapterRecord,
    baker_version: &str,
) -> Freshness {
    if std::fs::symlink_metadata(dir).is_err() {
        return Freshness::Stale(vec!["no asset there yet".into()]);
    }
    let m = match gibake_asset::verify_files(dir) {
        Ok(m) => m,
        Err(e @ AssetError::NotSupported { .. }) => {
            return Freshness::Stale(vec![format!("the existing asset is not readable: {e}")]);
        }
        Err(e) => {
            return Freshness::Stale(vec![format!(
                "the existing asset is damaged or not an asset: {e}"
            )]);
        }
    };
    let reasons = differences(&m, scene, opts, adapter, baker_version);
    if reasons.is_empty() {
        Freshness::UpToDate
    } else {
        Freshness::Stale(reasons)
    }
}

/// Every difference between the manifest `m` and the inputs of a bake now.
pub fn differences(
    m: &Manifest,
    scene: &Scene,
    opts: &BakeOptions,
    adapter: &AdapterRecord,
    baker_version: &str,
) -> Vec<String> {
    let mut r = Vec::new();
    let hash = gibake_scene::static_scene_hash(scene);
    if hash != m.static_scene_hash {
        // Which lights changed, when the asset records them (3.1); a scene
        // whose lights are the same changed its geometry or materials.
        let lights = if m.lights.is_empty() {
            Vec::new()
        } else {
            gibake_asset::light_changes(&m.lights, &crate::bake::light_records(scene))
        };
        let what = match (m.lights.is_empty(), lights.is_empty()) {
            (true, _) => String::new(),
            (false, true) => ": the static geometry or materials (not the lights)".into(),
            (false, false) => format!(": {}", lights.join("; ")),
        };
        r.push(format!(
            "scene changed (static-scene hash {} → {}){what}",
            hex8(&m.static_scene_hash),
            hex8(&hash)
        ));
    }
    let s = &m.settings;
    for (flag, was, now) in [
        ("--rsm-size", s.rsm_size, opts.rsm_size),
        ("--vpl-map-size", s.vpl_map_size, opts.vpl_map_size),
        ("--shadow-map-size", s.shadow_map_size, opts.shadow_map_size),
    ] {
        if was != now {
            r.push(format!("setting {flag} changed ({was} → {now})"));
        }
    }
    match (s.vpl_budget, opts.target) {
        (Some(was), ClusterTarget::Count(now)) if was != now => {
            r.push(format!("setting --vpls changed ({was} → {now})"));
        }
        (Some(was), ClusterTarget::Threshold(t)) => {
            r.push(format!("setting changed (--vpls {was} → --threshold {t})"))
        }
        (None, ClusterTarget::Count(n)) => r.push(format!(
            "setting changed (--threshold {} → --vpls {n})",
            s.threshold
        )),
        (None, ClusterTarget::Threshold(t)) if t.to_bits() != s.threshold.to_bits() => r.push(
            format!("setting --threshold changed ({} → {t})", s.threshold),
        ),
        _ => {}
    }
    // The bounces (format 4.6: none recorded is the first bounce alone).
    let bounces = |b: u32| match b {
        0 => "every bounce".to_string(),
        1 => "1 (the first bounce alone)".to_string(),
        n => n.to_string(),
    };
    let (was, was_budget) = m
        .later
        .as_ref()
        .map_or((1, 0), |l| (l.bounces, l.vpl_budget));
    let now = match opts.bounces {
        crate::later::Bounces::Every => 0,
        crate::later::Bounces::Count(n) => n.max(1),
    };
    if was != now {
        r.push(format!(
            "setting --bounces changed ({} → {})",
            bounces(was),
            bounces(now)
        ));
    } else if now != 1 && was_budget != opts.later_vpls.unwrap_or(0) {
        let budget = |b: u32| {
            if b == 0 {
                "the default".to_string()
            } else {
                b.to_string()
            }
        };
        r.push(format!(
            "setting --later-vpls changed ({} → {})",
            budget(was_budget),
            budget(opts.later_vpls.unwrap_or(0))
        ));
    }
    let p = &m.provenance;
    // The asset records the scene's file name: the same content under a new
    // name would give other bytes, so it is not up to date either.
    let name = scene
        .source
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_default();
    if p.scene_name != name {
        r.push(format!(
            "the scene's file name changed ({} → {name}; the asset records it)",
            p.scene_name
        ));
    }
    if p.baker_version != baker_version {
        // Same release, another method revision (crate::BAKE_METHOD), or an
        // asset from before the revision was recorded.
        let why = if p.baker_version.split('+').next() == baker_version.split('+').next() {
            ": the bake's method was revised since this asset was baked"
        } else {
            ""
        };
        r.push(format!(
            "baker version changed ({} → {baker_version}){why}",
            p.baker_version
        ));
    }
    let driver = format!("{} {}", adapter.driver, adapter.driver_info);
    if p.adapter != adapter.name || p.backend != adapter.backend || p.driver != driver {
        r.push(format!(
            "adapter changed ({} / {} / {} → {} / {} / {driver})",
            p.adapter, p.backend, p.driver, adapter.name, adapter.backend
        ));
    }
    // The moving objects' swept bounds, bit for bit (see the module docs).
    let swept = swept_record(scene);
    match &m.swept_bounds {
        // Without moving objects the box is empty and shapes nothing.
        None if (0..3).all(|k| swept[k] > swept[k + 3]) => {}
        None => r.push(
            "the asset does not record the moving objects' swept bounds (baked before format 4.5), on which its VPLs depend"
                .into(),
        ),
        Some(b) if b.map(f32::to_bits) != swept.map(f32::to_bits) => {
            let (was, now) = (show_box(b), show_box(&swept));
            r.push(if was == now {
                format!("the moving objects' swept bounds changed (in the last digits: {now})")
            } else {
                format!("the moving objects' swept bounds changed ({was} → {now})")
            });
        }
        Some(_) => {}
    }
    // (A point light first has no primary map, so no primary RSM either.)
    let has_dynamic = !scene.dynamic_objects.is_empty()
        && gibake_gpu::passes::light_maps::first_viewed_light(scene) == 1;
    if has_dynamic != m.has_dynamic {
        r.push(format!(
            "moving objects {} (the static RSM is stored only with them)",
            if has_dynamic { "added" } else { "removed" }
        ));
    }
    if r.is_empty() {
        // Same light and settings: the light view differs only when the
        // moving objects' swept bounds changed the fitted frustum.
        let v = LightView::for_scene(scene, opts.shadow_map_size);
        let same = v.record() == m.light_view;
        if !same {
            r.push("the light's view changed (the moving objects' swept bounds changed)".into());
        }
        // And the other lights' views whose RSMs are stored only when the
        // moving objects' swept bounds changed which ones they can enter.
        let views = if crate::bake::bakes_every_light(scene) {
            crate::bake::moving_views(scene, opts.shadow_map_size)
        } else {
            Vec::new()
        };
        if views != m.view_rsms {
            r.push(format!(
                "the other lights' views the moving objects can enter changed (their RSMs are stored: {} views now, {} in the asset)",
                views.len(),
                m.view_rsms.len()
            ));
        }
    }
    r
}
