//! How far the RSM itself is from the reference, before any clustering:
//! the one-bounce light of **every lit RSM texel** as its own point VPL,
//! with exact ray-cast visibility, against the CPU reference's one-bounce
//! light at the same receivers. The gap between this and the clustered
//! VPLs (`vpl_diag`, column T) is what clustering and one visibility point
//! per VPL cost; the gap between this and 1 is the RSM and the point
//! kernel's own limit. Also: which share of the reference's bounce light
//! comes from secondary hits within N RSM footprints of the receiver
//! (creases and contact, where no texel-sized point can be accurate), and
//! the largest single receiver's share of the reference: a receiver that
//! falls into a crease can hold a third of the mean at 24² (the Blenvy
//! sun's −11% at 24² is one ground point where an icosphere meets the
//! ground; at 64² the same RSM is −2.6%), so read a figure whose largest
//! share is over a few percent as that receiver's, not the level's.
//!
//! CPU only, static part, the level's camera, 512² RSM as the bake makes it.
//! `cargo run --release -p gibake-eval --example rsm_ceiling -- LEVEL… [--size N]`
//! (`LEVEL`: a name in data/levels/levels.json, or `random_lights:SEED` or
//! `random_lights:SEED:K` — a seeded multi-light scene, every view of every
//! light (or of light `K` alone) as the every-light bake makes them — or a
//! glTF file with its own lights and camera, `FILE.glb[:K]`)
//! (default 32² receivers; ≈ 5 s a level on 2 cores at 32²). `--rsm N`: the
//! RSM resolution (default 512, the bake's).
//!
//! A second line splits the receivers: those whose bounce light is at
//! least 10× the mean (on an open level, the objects' sides facing the
//! sunlit ground: 1% of the Blenvy level's receivers, 59% of its light)
//! against the rest, with the bounded per-texel bias on each.
//!
//! A third line: the share of the reference's bounce light that comes from
//! hits outside every view's map (ground a directional view's fit left
//! out: Blenvy's sun 3.3% at 64², the town 2.8%, the other real levels
//! 0.0%), and from hits inside a view whose texel's stored metric is more
//! than two footprints away from the hit's (sub-texel detail the light
//! sees past, and steep surfaces whose depth changes that much across one
//! texel: an upper bound on what sub-texel detail misses, 1–5% on the real
//! levels).

use gibake_gpu::LightView;
use gibake_raycast::RayScene;
use glam::Vec3;
use rayon::prelude::*;
use std::f32::consts::PI;

/// Reference samples per receiver (stratified, cosine-weighted).
const REF_SAMPLES_SIDE: u32 = 24;
/// Distance buckets, in RSM footprints, for the reference's near light.
const BUCKETS: [f32; 4] = [1.0, 2.0, 4.0, 8.0];

/// Per receiver: reference (total, then per bucket), per-texel sums
/// (bounded kernel with and without visibility, unbounded with visibility).
#[derive(Clone, Copy, Default)]
struct Sums {
    reference: f64,
    near: [f64; BUCKETS.len()],
    bounded: f64,
    bounded_unshadowed: f64,
    point: f64,
    /// The largest one receiver's reference (a receiver in a crease can
    /// hold a large share of the mean at few receivers).
    largest: f64,
    /// The reference's bounce light from hits outside every view's map.
    outside: f64,
    /// … from hits inside a view whose texel holds another surface (the
    /// light sees something else first at the texel's centre).
    unseen: f64,
}

fn main() {
    let mut names = Vec::new();
    let mut size = 32u32;
    let mut rsm_size = 512u32;
    let mut whole = false;
    let mut args = std::env::args().skip(1);
    while let Some(a) = args.next() {
        if a == "--size" {
            size = args.next().and_then(|s| s.parse().ok()).expect("--size N");
        } else if a == "--whole" {
            whole = true;
        } else if a == "--rsm" {
            rsm_size = args.next().and_then(|s| s.parse().ok()).expect("--rsm N");
        } else {
            names.push(a);
        }
    }
    let list = gibake_eval::levels::bundled_list();
    let levels = gibake_eval::levels::read_specs(&list).unwrap();
    println!(
        "per-texel point VPLs (every lit texel of the {rsm_size}² RSM) against the reference, {size}² receivers"
    );
    println!(
        "{:>12} | {:>9} {:>9} {:>9} {:>11} | reference's bounce light from hits within 1 / 2 / 4 / 8 footprints | largest receiver's share",
        "level", "bounded", "point", "no vis", "footprint"
    );
    for name in names {
        let mut scene = if let Some(spec) = name.strip_prefix("random_lights:") {
            let mut parts = spec.split(':');
            let seed: u64 = parts.next().and_then(|s| s.parse().ok()).expect("SEED");
            let only: Option<usize> = parts.next().and_then(|s| s.parse().ok());
            let (bytes, _) = gibake_scenegen::random_lights(seed, &Default::default());
            let mut scene = gibake_scene::load_from_slice(
                &bytes,
                std::path::Path::new("random_lights.glb"),
                &gibake_scene::LoadOptions::default(),
            )
            .expect("generated scenes load");
            if let Some(k) = only {
                scene.lights = vec![scene.lights[k].clone()];
            }
            scene
        } else if let Some(scene) = gibake_eval::load_gltf_lights(&name) {
            scene
        } else {
            let l = levels
                .iter()
                .find(|l| l.name == name)
                .expect("a bundled level");
            l.load(list.parent().unwrap()).unwrap()
        };
        if whole {
            scene.bake_volume = Some(scene.static_bounds());
        }
        let stat = gibake_bake::static_only(&scene);
        let rays = RayScene::build(&stat, 0.0);
        // Every view of every light (one for a level's one light).
        let maps = gibake_eval::bounce::every_view_rsm(&scene, &rays, rsm_size);
        let cam = gibake_reference::View::from_scene(&stat, 0.0).unwrap();
        // Footprint buckets in the first view's texels at its origin's
        // scale (a level's one view; indicative for several).
        let fp = maps[0].0.footprint(Vec3::ZERO);
        let texels: Vec<(Vec3, Vec3, f32, Vec3)> = maps
            .iter()
            .flat_map(|(_, rsm)| {
                (0..rsm.flux.len())
                    .filter(|&t| rsm.flux[t].max_element() > 0.0 && rsm.metric[t].is_finite())
                    .map(|t| (rsm.position[t], rsm.normal[t], rsm.area[t], rsm.flux[t]))
                    .collect::<Vec<_>>()
            })
            .collect();
        let per_px = (0..size * size)
            .into_par_iter()
            .map(|p| {
                let mut s = Sums::default();
                let Some(h) = gibake_eval::bounce::pixel_hit(&rays, &cam, size, p) else {
                    return s;
                };
                let a = h.albedo / PI;
                let m = REF_SAMPLES_SIDE;
                gibake_eval::bounce::one_bounce_samples(&rays, &h, p, m, |y2, lr| {
                    let v = f64::from((h.albedo * lr).element_sum()) / f64::from(m * m);
                    s.reference += v;
                    match seen_by(&maps, y2.position) {
                        Seen::Outside => s.outside += v,
                        Seen::Other => s.unseen += v,
                        Seen::Yes => {}
                    }
                    let dist = (y2.position - h.position).length() / fp;
                    for (k, &limit) in BUCKETS.iter().enumerate() {
                        if dist < limit {
                            s.near[k] += v;
                        }
                    }
                });
                for &(pp, nn, area, flux) in &texels {
                    let Some(k) = gibake_eval::bounce::texel_kernel(pp, nn, area, &h) else {
                        continue;
                    };
                    let f = (a * flux).element_sum();
                    let bounded = f64::from(f * k.bounded);
                    s.bounded_unshadowed += bounded;
                    if rays.visible(pp, nn, h.position, h.geometric_normal) {
                        s.bounded += bounded;
                        s.point += f64::from(f * k.point);
                    }
                }
                s.largest = s.reference;
                s
            })
            .collect::<Vec<Sums>>();
        // Receivers whose bounce light is ≥ 10× the mean (the objects'
        // sides facing a sunlit ground on an open level) against the rest.
        let mean = per_px.iter().map(|s| s.reference).sum::<f64>() / per_px.len().max(1) as f64;
        let hot = |s: &&Sums| s.reference >= 10.0 * mean;
        let part = |pick: &dyn Fn(&&Sums) -> bool| {
            let (r, b, n) = per_px.iter().filter(pick).fold((0.0, 0.0, 0usize), |a, s| {
                (a.0 + s.reference, a.1 + s.bounded, a.2 + 1)
            });
            (r, b, n)
        };
        let (hr, hb, hn) = part(&hot);
        let hot_outside: f64 = per_px.iter().filter(hot).map(|s| s.outside).sum();
        let hot_unseen: f64 = per_px.iter().filter(hot).map(|s| s.unseen).sum();
        let (cr, cb, _) = part(&|s: &&Sums| !hot(s));
        let split = format!(
            "hot receivers (≥ 10× the mean): {:.1}% of them, {:.0}% of the light, bounded {:+.1}% there, {:+.1}% elsewhere",
            100.0 * hn as f64 / per_px.len().max(1) as f64,
            100.0 * hr / (hr + cr).max(f64::MIN_POSITIVE),
            100.0 * (hb / hr.max(f64::MIN_POSITIVE) - 1.0),
            100.0 * (cb / cr.max(f64::MIN_POSITIVE) - 1.0),
        );
        let total = per_px.into_iter().fold(Sums::default(), |mut a, b| {
            a.largest = a.largest.max(b.largest);
            a.reference += b.reference;
            for k in 0..BUCKETS.len() {
                a.near[k] += b.near[k];
            }
            a.outside += b.outside;
            a.unseen += b.unseen;
            a.bounded += b.bounded;
            a.bounded_unshadowed += b.bounded_unshadowed;
            a.point += b.point;
            a
        });
        let r = total.reference.max(f64::MIN_POSITIVE);
        println!(
            "{name:>12} | {:>+8.1}% {:>+8.1}% {:>+8.1}% {:>9.4} m | {:.1}% / {:.1}% / {:.1}% / {:.1}% | {:.1}%",
            100.0 * (total.bounded / r - 1.0),
            100.0 * (total.point / r - 1.0),
            100.0 * (total.bounded_unshadowed / r - 1.0),
            fp,
            100.0 * total.near[0] / r,
            100.0 * total.near[1] / r,
            100.0 * total.near[2] / r,
            100.0 * total.near[3] / r,
            100.0 * total.largest / r,
        );
        println!("{:>12}   {split}", "");
        println!(
            "{:>12}   reference's bounce light from hits outside every view: {:.1}% ({:.1}% on the hot receivers), inside a view but not what its texel holds: {:.1}% ({:.1}%)",
            "",
            100.0 * total.outside / r,
            100.0 * hot_outside / hr.max(f64::MIN_POSITIVE),
            100.0 * total.unseen / r,
            100.0 * hot_unseen / hr.max(f64::MIN_POSITIVE),
        );
    }
}

/// Where a point the reference's light bounces off lies in the maps.
enum Seen {
    /// In no view's map.
    Outside,
    /// In a view, but its texel holds a surface more than two footprints
    /// away along the view (the light sees something else there first).
    Other,
    /// What some view's texel holds.
    Yes,
}

fn seen_by(maps: &[(LightView, gibake_bake::rsm::Rsm)], p: Vec3) -> Seen {
    let mut inside = false;
    for (v, rsm) in maps {
        let Some(t) = v.texel_coords(p) else { continue };
        let n = v.size as f32;
        if !(t.x >= 0.0 && t.y >= 0.0 && t.x < n && t.y < n) {
            continue;
        }
        let clip = v.view_proj * p.extend(1.0);
        if !(clip.z >= 0.0 && clip.z <= clip.w) {
            continue;
        }
        inside = true;
        let i = t.y as usize * v.size as usize + t.x as usize;
        if (rsm.metric[i] - v.metric(p)).abs() <= 2.0 * v.footprint(p) {
            return Seen::Yes;
        }
    }
    if inside { Seen::Other } else { Seen::Outside }
}
