//! Where the twin's indirect light exceeds the reference's most, and which
//! VPLs put it there: the CPU twin of the runtime's transport
//! (`gibake_eval::transport`, no visibility) against every texel of each
//! VPL drawn as its own small disk (the light the clustering stands for),
//! per receiver, for the pixels with the largest excess.
//!
//! ```text
//! cargo run --release -p gibake-eval --example hot_spots -- SCENE.glb [--vpls N] [--size S] [--top K]
//! ```
//!
//! Prints, for each of the `K` pixels whose twin irradiance most exceeds
//! the texels' (no visibility on either side), the receiver and the VPLs
//! that send it the most: the VPL's record (texels, area, its disk radius
//! `√(A/π)`), the receiver's distance in those radii, and what its
//! clustered transport and its texels' disks send.

use gibake_bake::cluster::ClusterTarget;
use gibake_bake::lights::every_light;
use gibake_bake::reach::Reach;
use gibake_eval::transport::{TwinVpls, disk_irradiance};
use gibake_reference::RayScene;
use gibake_scene::LoadOptions;
use glam::Vec3;
use rayon::prelude::*;

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let (mut vpls, mut size, mut top) = (256u32, 32u32, 3usize);
    let mut file = None;
    let mut it = args.iter();
    while let Some(a) = it.next() {
        let mut num = || {
            it.next()
                .and_then(|v| v.parse::<u32>().ok())
                .expect("a number")
        };
        match a.as_str() {
            "--vpls" => vpls = num(),
            "--size" => size = num(),
            "--top" => top = num() as usize,
            f => file = Some(f.to_string()),
        }
    }
    let file = file.expect("usage: hot_spots SCENE.glb [--vpls N] [--size S] [--top K]");
    let scene = gibake_scene::load(std::path::Path::new(&file), &LoadOptions::default())
        .unwrap_or_else(|e| panic!("{file}: {e}"));
    let stat = gibake_bake::static_only(&scene);
    let rays = RayScene::build(&stat, 0.0);
    let reach = Reach::new(&rays, scene.dynamic_swept_bounds());
    let every = every_light(&scene, &reach, 512, 2048, ClusterTarget::Count(vpls));
    let records = every.vpl_records();
    let (nodes, coherence) = every.vpl_trees();
    let ring = every.ring_flags();
    let twin = TwinVpls::new(&records, &ring, &nodes, &coherence);
    // Each lit texel of a kept VPL: (position, normal, area, flux, VPL).
    let mut texels = Vec::new();
    let mut first = 0usize;
    for (m, c) in every.maps.iter().zip(&every.clusters.maps) {
        let r = &m.rsm;
        for (t, &v) in c.texel_vpl.iter().enumerate() {
            if v != gibake_bake::cluster::NO_VPL {
                texels.push((
                    r.position[t],
                    r.normal[t],
                    r.area[t],
                    r.flux[t],
                    first + v as usize,
                ));
            }
        }
        first += c.vpls.len();
    }
    let cam = gibake_reference::View::from_scene(&scene, 0.0).expect("the scene has a camera");
    let sum = |v: Vec3| f64::from(v.x + v.y + v.z);
    // Per pixel: (excess, pixel, per-VPL (twin, texels)).
    type Pixel = (f64, u32, Vec<(usize, f64, f64)>);
    let mut px: Vec<Pixel> = (0..size * size)
        .into_par_iter()
        .filter_map(|p| {
            let (x, y) = (p % size, p / size);
            let (o, d, t0) = cam.primary_ray(size, size, x as f32 + 0.5, y as f32 + 0.5);
            let h = rays.intersect_range(o, d, t0, f32::INFINITY)?;
            let (xp, ns, ng) = (h.position, h.shading_normal, h.geometric_normal);
            let mut per = vec![(0f64, 0f64); records.len()];
            for (i, t) in twin.terms(xp, ns, ng) {
                per[i].0 = sum(t.total());
            }
            for &(pt, n, a, f, v) in &texels {
                per[v].1 += sum(disk_irradiance(pt, n, a, f, xp, ns, ng));
            }
            let excess: f64 = per.iter().map(|(c, t)| c - t).sum();
            let list = per
                .into_iter()
                .enumerate()
                .filter(|(_, (c, t))| *c > 0.0 || *t > 0.0)
                .map(|(i, (c, t))| (i, c, t))
                .collect();
            Some((excess, p, list))
        })
        .collect();
    px.sort_by(|a, b| b.0.total_cmp(&a.0));
    for (excess, p, mut list) in px.into_iter().take(top) {
        let (x, y) = (p % size, p / size);
        let (o, d, t0) = cam.primary_ray(size, size, x as f32 + 0.5, y as f32 + 0.5);
        let h = rays.intersect_range(o, d, t0, f32::INFINITY).expect("hit");
        let (c, t): (f64, f64) = list.iter().fold((0.0, 0.0), |a, v| (a.0 + v.1, a.1 + v.2));
        println!(
            "pixel ({x}, {y}) at {:.3?} normal {:.2?}: twin {c:.4} texels {t:.4} (excess {excess:.4})",
            h.position, h.geometric_normal
        );
        list.sort_by(|a, b| (b.1 - b.2).abs().total_cmp(&(a.1 - a.2).abs()));
        for (k, (i, c, t)) in list.into_iter().take(5).enumerate() {
            let v = &records[i];
            let r = (v.area / std::f32::consts::PI).sqrt();
            let dist = (Vec3::from_array(v.position) - h.position).length();
            println!(
                "  VPL {i}: {} texels at {:.3?} normal {:.2?} area {:.4} (radius {r:.4}), receiver at {:.2} radii: twin {c:.4} texels {t:.4}",
                v.texels,
                v.position,
                v.normal,
                v.area,
                dist / r
            );
            if k == 0 && std::env::var("NODES").is_ok() {
                // The VPL's near-field nodes that send the receiver light.
                let tree = twin.tree(i);
                for (j, n) in tree.iter().enumerate() {
                    let e = sum(gibake_eval::transport::near_node_irradiance(
                        n,
                        1.0,
                        h.position,
                        h.shading_normal,
                        h.geometric_normal,
                    ));
                    if e > 1e-3 {
                        println!(
                            "    node {j}: {} texels at {:.3?} normal {:.2?} area {:.4}: {e:.4} (as a level-3 node)",
                            n.texels, n.position, n.normal, n.area
                        );
                    }
                }
            }
        }
    }
}
