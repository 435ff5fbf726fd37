//! Where a band of image rows gets its bounce light from, by source mesh:
//! the CPU reference's one bounce (24² cosine samples per receiver, each
//! secondary hit's mesh) against every lit texel of the bake's 512² RSM as
//! its own point VPL with the bounded kernel (rsm_ceiling's), with exact
//! ray-cast visibility and without, each texel's mesh the one its ray from
//! the light hits. Red channel, static part, the level's camera. It finds
//! which surface's light a band loses before any clustering (the garden's
//! shore: the bridge and crowns' mesh, until the RSM's texels emitted about
//! their geometric normal; docs/method.md, "2. Reflective shadow map").
//!
//! `cargo run --release -p gibake-eval --example band_sources -- LEVEL --size N --rows A B`
//! (`LEVEL` a name in data/levels/levels.json; receivers: the pixel rows
//! `A..B` of an `N`² image; ≈ 20 s for 12 rows of 96 on 2 cores).
use gibake_raycast::RayScene;
use glam::Vec3;
use rayon::prelude::*;
use std::collections::HashMap;
use std::f32::consts::PI;

/// Sums by mesh index: the reference's bounce light by source mesh, the
/// texels' with visibility and without by source mesh, the receivers' own
/// meshes (pixel counts).
type Tally = [HashMap<u32, f64>; 4];

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let name = args[0].clone();
    let size: u32 = args[args.iter().position(|a| a == "--size").unwrap() + 1]
        .parse()
        .unwrap();
    let r = args.iter().position(|a| a == "--rows").unwrap();
    let (ra, rb): (u32, u32) = (args[r + 1].parse().unwrap(), args[r + 2].parse().unwrap());
    let list = gibake_eval::levels::bundled_list();
    let levels = gibake_eval::levels::read_specs(&list).unwrap();
    let scene = levels
        .iter()
        .find(|l| l.name == name)
        .unwrap()
        .load(list.parent().unwrap())
        .unwrap();
    let stat = gibake_bake::static_only(&scene);
    let rays = RayScene::build(&stat, 0.0);
    let maps = gibake_eval::bounce::every_view_rsm(&scene, &rays, 512);
    // Each lit texel with the mesh its own ray from the light hits.
    let texels: Vec<(Vec3, Vec3, f32, Vec3, u32)> = maps
        .iter()
        .flat_map(|(v, rsm)| {
            (0..rsm.flux.len())
                .filter(|&t| rsm.flux[t].max_element() > 0.0 && rsm.metric[t].is_finite())
                .map(|t| {
                    let (o, d) = v.texel_ray(t as u32 % rsm.size, t as u32 / rsm.size);
                    let m = rays
                        .intersect(o, d, f32::INFINITY)
                        .map_or(u32::MAX, |h| h.mesh);
                    (rsm.position[t], rsm.normal[t], rsm.area[t], rsm.flux[t], m)
                })
                .collect::<Vec<_>>()
        })
        .collect();
    let cam = gibake_reference::View::from_scene(&stat, 0.0).unwrap();
    // Per receiver, by mesh: [reference by source, texels with visibility
    // by source, texels without by source, receivers' own mesh (pixels)].
    let per: Vec<Tally> = (ra * size..rb * size)
        .into_par_iter()
        .map(|p| {
            let mut t = Tally::default();
            let Some(h) = gibake_eval::bounce::pixel_hit(&rays, &cam, size, p) else {
                return t;
            };
            *t[3].entry(h.mesh).or_insert(0.0) += 1.0;
            let a = h.albedo / PI;
            let m = 24;
            gibake_eval::bounce::one_bounce_samples(&rays, &h, p, m, |y2, lr| {
                let v = f64::from((h.albedo * lr).x) / f64::from(m * m);
                *t[0].entry(y2.mesh).or_insert(0.0) += v;
            });
            for &(pp, nn, area, flux, mesh) in &texels {
                let Some(k) = gibake_eval::bounce::texel_kernel(pp, nn, area, &h) else {
                    continue;
                };
                let b = f64::from((a * flux).x * k.bounded);
                *t[2].entry(mesh).or_insert(0.0) += b;
                if rays.visible(pp, nn, h.position, h.geometric_normal) {
                    *t[1].entry(mesh).or_insert(0.0) += b;
                }
            }
            t
        })
        .collect();
    let mut tot = Tally::default();
    for t in per {
        for (k, m) in t.into_iter().enumerate() {
            for (id, v) in m {
                *tot[k].entry(id).or_insert(0.0) += v;
            }
        }
    }
    let names: Vec<String> = stat
        .meshes_at(0.0)
        .iter()
        .map(|m| m.0.name.clone())
        .collect();
    let rsum: f64 = tot[0].values().sum();
    let bsum: f64 = tot[1].values().sum();
    let usum: f64 = tot[2].values().sum();
    println!(
        "{name} rows {ra}..{rb} of {size}: red channel; per-texel with vis {:+.1}%, without {:+.1}%",
        100.0 * (bsum / rsum - 1.0),
        100.0 * (usum / rsum - 1.0)
    );
    let mut ids: Vec<u32> = tot[0].keys().chain(tot[1].keys()).copied().collect();
    ids.sort();
    ids.dedup();
    ids.sort_by(|a, b| {
        tot[0]
            .get(b)
            .unwrap_or(&0.0)
            .total_cmp(tot[0].get(a).unwrap_or(&0.0))
    });
    for id in ids.iter().take(15) {
        let r = tot[0].get(id).copied().unwrap_or(0.0);
        let b = tot[1].get(id).copied().unwrap_or(0.0);
        let u = tot[2].get(id).copied().unwrap_or(0.0);
        let n = names.get(*id as usize).cloned().unwrap_or("?".into());
        let n = format!("{n} {}", describe(&stat, *id as usize));
        println!(
            "  source {id:4} {n:30} ref {:5.1}%  texels vis {:5.1}%  no vis {:5.1}%",
            100.0 * r / rsum,
            100.0 * b / rsum,
            100.0 * u / rsum
        );
    }
    let mut rec: Vec<_> = tot[3].iter().collect();
    rec.sort_by(|a, b| b.1.total_cmp(a.1));
    for (id, c) in rec.iter().take(6) {
        println!(
            "  receiver {id:4} {:30} {c} px",
            names.get(**id as usize).cloned().unwrap_or("?".into())
        );
    }
}

/// A mesh's triangle count and world bounds (the bundled levels' meshes
/// are often unnamed).
fn describe(stat: &gibake_scene::Scene, id: usize) -> String {
    let ms = stat.meshes_at(0.0);
    let (m, xf) = &ms[id];
    let mut lo = Vec3::splat(f32::INFINITY);
    let mut hi = Vec3::splat(f32::NEG_INFINITY);
    for p in &m.positions {
        let q = xf.transform_point3(*p);
        lo = lo.min(q);
        hi = hi.max(q);
    }
    format!("tris {} bounds {lo:.2}..{hi:.2}", m.indices.len() / 3)
}
