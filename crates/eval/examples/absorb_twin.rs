//! What moving objects change in the later bounces, on the CPU (a probe
//! for issue 50, item 2): the bake's surfels, links and later clusters for
//! the static level, gathered again with the objects in place — every link
//! an object blocks carrying the object's albedo instead (what it reflects
//! goes on as a static surface's would), and the direct light with the
//! objects' shadows — the exact answer on the surfels, per later VPL,
//! against the runtime's kinds of estimate:
//!
//! - what the objects absorb: `later_absorb::local_keep` (each transfer
//!   loses the VPL's own share), its share taken at the VPL's point (the
//!   runtime) and over a disk of its surfels' area;
//! - what their shadows take off the first bounce: the level's mean
//!   occluded share for every later VPL (format 4.7) against each VPL's
//!   source groups' (format 4.8, here with the directly lit surfels in
//!   grid cells of a sixteenth of the level's diagonal as the groups).
//!
//! ```text
//! cargo run --release -p gibake-eval --example absorb_twin -- LEVEL [--vpls N] [--points N] [--rays N]
//! ```

use gibake_bake::later::radiosity::{self, Bounces, ESCAPED};
use gibake_bake::later::{secondary, surfels};
use gibake_reference::RayScene;
use glam::Vec3;
use rayon::prelude::*;

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let (mut vpls, mut points, mut rays_per) = (256u32, 16384u32, 64u32);
    let mut name = None::<String>;
    let mut it = args.iter();
    while let Some(a) = it.next() {
        let mut num = || {
            it.next()
                .and_then(|v| v.parse::<u32>().ok())
                .expect("a number")
        };
        match a.as_str() {
            "--vpls" => vpls = num(),
            "--points" => points = num(),
            "--rays" => rays_per = num(),
            n => name = Some(n.to_string()),
        }
    }
    let later = vpls.div_ceil(4);
    let name = name.expect("a level");
    let list = gibake_eval::levels::bundled_list();
    let specs = gibake_eval::levels::read_specs(&list).expect("levels.json");
    let spec = specs.iter().find(|s| s.name == name).expect("a level");
    let scene = spec.load(list.parent().unwrap()).expect("loads");
    let stat = gibake_bake::static_only(&scene);
    let rays = RayScene::build(&stat, 0.0);
    let full = RayScene::build(&scene, 0.0);
    let n_static_meshes = scene.static_meshes.len() as u32;

    let sf = surfels::place(&rays, points);
    let dir = radiosity::direct(&rays, &sf);
    let links = radiosity::link(&rays, &sf, rays_per);
    let sol = radiosity::solve(&sf, &links, &dir, Bounces::Every);
    let emitted: Vec<Vec3> = (0..sf.len())
        .map(|s| sf.albedo[s] * sol.indirect[s] * sf.area[s])
        .collect();
    let b = scene.static_bounds();
    let sec = secondary::cluster(&rays, &sf, &emitted, later, (b.max - b.min).length());
    let per = links.rays as usize;
    let n = sf.len();

    // Each link's factor with the objects in place: the albedo of the
    // moving object between the surfel and the one its ray landed on.
    let factor: Vec<Vec3> = (0..n * per)
        .into_par_iter()
        .map(|i| {
            let (s, t) = (i / per, links.target[i]);
            if t >= ESCAPED {
                return Vec3::ONE;
            }
            let a = full.offset_point(sf.position[s], sf.normal[s]);
            let d = sf.position[t as usize] - a;
            let l = d.length();
            match full.intersect(a, d / l, l) {
                Some(h) if h.mesh >= n_static_meshes => h.albedo,
                _ => Vec3::ONE,
            }
        })
        .collect();
    let blocked = factor.iter().filter(|f| **f != Vec3::ONE).count();
    println!(
        "{name}: {n} surfels, {} later VPLs, {blocked} of {} links blocked by moving objects",
        sec.vpls.len(),
        n * per
    );

    // The gathers by hand from the direct irradiance `start`, with and
    // without the factors (the series to 1e-4 of its sum).
    let gather = |start: &[Vec3], with: bool| -> Vec<Vec3> {
        let mut prev = start.to_vec();
        let mut total = vec![Vec3::ZERO; n];
        let mut sum = 0.0f64;
        for _ in 0..2000 {
            let next: Vec<Vec3> = (0..n)
                .into_par_iter()
                .map(|s| {
                    let mut e = Vec3::ZERO;
                    let rays = links.target[s * per..(s + 1) * per]
                        .iter()
                        .zip(&factor[s * per..(s + 1) * per]);
                    for (&t, f) in rays {
                        if t < ESCAPED {
                            let f = if with { *f } else { Vec3::ONE };
                            e += f * sf.albedo[t as usize] * prev[t as usize];
                        }
                    }
                    e * (links.scale[s] / per as f32)
                })
                .collect();
            let c: f64 = next
                .iter()
                .zip(&sf.albedo)
                .zip(&sf.area)
                .map(|((e, a), ar)| f64::from((*e * *a * *ar).element_sum()))
                .sum();
            for (a, b) in total.iter_mut().zip(&next) {
                *a += *b;
            }
            sum += c;
            prev = next;
            if c < 1e-4 * sum {
                break;
            }
        }
        total
    };
    let (e0, e1) = (gather(&dir, false), gather(&dir, true));
    let nv = sec.vpls.len();
    let flux = |e: &[Vec3]| {
        let mut f = vec![Vec3::ZERO; nv];
        for (s, e) in e.iter().enumerate() {
            let v = sec.surfel_vpl[s];
            if (v as usize) < nv {
                f[v as usize] += sf.albedo[s] * *e * sf.area[s];
            }
        }
        f
    };
    let (phi0, phi1) = (flux(&e0), flux(&e1));

    // The moving objects: bounds, surface area and albedo.
    let transforms = scene.dynamic_transforms(0.0);
    let objects: Vec<(gibake_scene::Aabb, f32, Vec3)> = scene
        .dynamic_objects
        .iter()
        .enumerate()
        .map(|(i, o)| {
            let m = transforms[i];
            let (mut area, mut rho) = (0.0f32, Vec3::ZERO);
            for &mi in &o.meshes {
                let mesh = &scene.dynamic_meshes[mi];
                for tri in mesh.indices.chunks_exact(3) {
                    let p = |k: usize| m.transform_point3(mesh.positions[tri[k] as usize]);
                    let a = 0.5 * (p(1) - p(0)).cross(p(2) - p(0)).length();
                    area += a;
                    rho += a * scene.albedo(mesh.material, None);
                }
            }
            (
                o.local_bounds.transformed(m),
                area,
                if area > 0.0 { rho / area } else { Vec3::ONE },
            )
        })
        .collect();

    // The runtime's estimates.
    let pb: Vec<[f32; 3]> = sol.per_bounce.iter().map(|v| v.to_array()).collect();
    let tail = sol.tail.to_array();
    let pos: Vec<Vec3> = sec
        .vpls
        .iter()
        .map(|v| Vec3::from_array(v.position))
        .collect();
    let nrm: Vec<Vec3> = sec
        .vpls
        .iter()
        .map(|v| Vec3::from_array(v.normal))
        .collect();
    let local: Vec<Vec3> = (0..nv)
        .map(|v| {
            let mut l = Vec3::ZERO;
            for (bx, area, rho) in &objects {
                l += gibake_runtime::twin::intercepted_by_area(pos[v], nrm[v], bx, *area)
                    * (Vec3::ONE - *rho);
            }
            l.min(Vec3::ONE)
        })
        .collect();
    let keep_a: Vec<Vec3> = local
        .iter()
        .map(|l| gibake_runtime::twin::local_keep(&pb, tail, *l))
        .collect();
    // The same with the VPL a disk of its surfels' area.
    let local_d: Vec<Vec3> = (0..nv)
        .map(|v| {
            let radius = (sec.vpls[v].area / std::f32::consts::PI).sqrt();
            let mut l = Vec3::ZERO;
            for (bx, area, rho) in &objects {
                l += intercepted_by_disk(pos[v], nrm[v], radius, bx, *area) * (Vec3::ONE - *rho);
            }
            l.min(Vec3::ONE)
        })
        .collect();
    let keep_d: Vec<Vec3> = local_d
        .iter()
        .map(|l| gibake_runtime::twin::local_keep(&pb, tail, *l))
        .collect();

    let (mut w0, mut wx, mut wa, mut wd) = (Vec3::ZERO, Vec3::ZERO, Vec3::ZERO, Vec3::ZERO);
    println!("vpl  flux(sum)  loss l_v (R)  exact k (R,G,B)  local_keep k (R,G,B)");
    for v in 0..nv {
        let exact = phi1[v] / phi0[v].max(Vec3::splat(1e-30));
        if local[v].x > 1e-3 || (Vec3::ONE - exact).x > 0.01 {
            println!(
                "{v:3} {:9.3e} {:6.3}  {:5.3} {:5.3} {:5.3}  {:5.3} {:5.3} {:5.3}  disk {:5.3} {:5.3}",
                phi0[v].element_sum(),
                local[v].x,
                exact.x,
                exact.y,
                exact.z,
                keep_a[v].x,
                keep_a[v].y,
                keep_a[v].z,
                local_d[v].x,
                keep_d[v].x
            );
        }
        w0 += phi0[v];
        wx += phi1[v];
        wa += phi0[v] * keep_a[v];
        wd += phi0[v] * keep_d[v];
    }
    // The first bounce's light under the objects: the sun's shadows on
    // the surfels, and what that does to the later light.
    let dir_full = radiosity::direct(&full, &sf);
    let d_lum = |e: &[Vec3]| -> Vec<f32> {
        (0..n)
            .map(|i| (sf.albedo[i] * e[i] * sf.area[i]).element_sum())
            .collect()
    };
    let (dl0, dl1) = (d_lum(&dir), d_lum(&dir_full));
    let lost: f32 = dl0.iter().sum::<f32>() - dl1.iter().sum::<f32>();
    println!(
        "direct reflected light lost to the objects' shadows: {:.4} of it",
        lost / dl0.iter().sum::<f32>()
    );
    // Sources: the directly lit surfels in groups (as the first bounce's
    // VPLs are), here a grid of cells of a sixteenth of the diagonal.
    let cell = (b.max - b.min).length() / 16.0;
    let mut group_of = vec![u32::MAX; n];
    let mut keys: std::collections::HashMap<glam::IVec3, u32> = Default::default();
    for i in 0..n {
        if dl0[i] > 0.0 {
            let k = (sf.position[i] / cell).floor().as_ivec3();
            let g = keys.len() as u32;
            group_of[i] = *keys.entry(k).or_insert(g);
        }
    }
    let ng = keys.len();
    let mut occ = vec![(0.0f32, 0.0f32); ng];
    for i in 0..n {
        if group_of[i] != u32::MAX {
            let o = &mut occ[group_of[i] as usize];
            o.0 += dl0[i] - dl1[i];
            o.1 += dl0[i];
        }
    }
    let occ: Vec<f32> = occ
        .iter()
        .map(|(a, b)| {
            if *b > 0.0 {
                (a / b).clamp(0.0, 1.0)
            } else {
                0.0
            }
        })
        .collect();
    let level_occ = lost / dl0.iter().sum::<f32>();
    // K-channel gathers: the light of each source group, bounce after bounce.
    let albedo_l: Vec<f32> = sf.albedo.iter().map(|a| a.element_sum() / 3.0).collect();
    let mut prev = vec![0.0f32; n * ng];
    for i in 0..n {
        if group_of[i] != u32::MAX {
            prev[i * ng + group_of[i] as usize] = dl0[i] / (sf.area[i] * albedo_l[i]).max(1e-30);
        }
    }
    let bmax: usize = std::env::var("BOUNCES")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(3);
    let mut acc = vec![0.0f32; n * ng];
    let mut last = vec![0.0f32; n * ng];
    for _ in 0..bmax {
        let next: Vec<f32> = (0..n)
            .into_par_iter()
            .flat_map_iter(|s| {
                let mut e = vec![0.0f32; ng];
                for r in s * per..(s + 1) * per {
                    let t = links.target[r] as usize;
                    if t < ESCAPED as usize {
                        let a = albedo_l[t];
                        for (g, x) in e.iter_mut().zip(&prev[t * ng..(t + 1) * ng]) {
                            *g += a * x;
                        }
                    }
                }
                let k = links.scale[s] / per as f32;
                e.into_iter().map(move |x| x * k)
            })
            .collect();
        for (a, x) in acc.iter_mut().zip(&next) {
            *a += x;
        }
        last = next.clone();
        prev = next;
    }
    // Per later VPL: the occluded share of its light's sources (the
    // gathered bounces by group, and the rest in the last one's mix).
    let source_occ = |v: usize| -> f32 {
        let mut w_acc = vec![0.0f64; ng];
        let mut w_last = vec![0.0f64; ng];
        for i in 0..n {
            if sec.surfel_vpl[i] as usize == v {
                let c = f64::from(albedo_l[i] * sf.area[i]);
                for g in 0..ng {
                    w_acc[g] += c * f64::from(acc[i * ng + g]);
                    w_last[g] += c * f64::from(last[i * ng + g]);
                }
            }
        }
        let (sa, sl): (f64, f64) = (w_acc.iter().sum(), w_last.iter().sum());
        let total = f64::from(phi0[v].element_sum() / 3.0);
        let rest = (total - sa).max(0.0);
        let mut o = 0.0f64;
        for g in 0..ng {
            let w = w_acc[g] + if sl > 0.0 { rest * w_last[g] / sl } else { 0.0 };
            o += w * f64::from(occ[g]);
        }
        if total > 0.0 {
            (o / (sa + rest).max(1e-30)) as f32
        } else {
            0.0
        }
    };
    // Exact with both the shadows and the blocked links.
    let gather2 = gather(&dir_full, true);
    let phi2 = flux(&gather2);
    let mut err = [0.0f64; 2];
    let (mut total, mut kept) = (Vec3::ZERO, [Vec3::ZERO; 3]);
    println!("vpl  with the objects' shadows too: exact k(R)  level-mean occ  source-weighted occ");
    for v in 0..nv {
        let o = source_occ(v);
        let ex = phi2[v] / phi0[v].max(Vec3::splat(1e-30));
        let a = (1.0 - level_occ) * keep_d[v];
        let c = (1.0 - o) * keep_d[v];
        if (Vec3::ONE - ex).x > 0.02 {
            println!(
                "{v:3} exact {:.3}  level-mean {:.3}  sources {:.3} (occ {:.3})",
                ex.x, a.x, c.x, o
            );
        }
        for (k, m) in [a, c, ex].iter().enumerate() {
            kept[k] += phi0[v] * *m;
        }
        total += phi0[v];
        err[0] += f64::from(((a - ex) * phi0[v]).length_squared());
        err[1] += f64::from(((c - ex) * phi0[v]).length_squared());
    }
    println!(
        "level kept: exact {:.3} level-mean {:.3} sources {:.3} (red); rms error level-mean {:.3e} sources {:.3e}",
        (kept[2] / total).x,
        (kept[0] / total).x,
        (kept[1] / total).x,
        err[0].sqrt(),
        err[1].sqrt()
    );
    println!(
        "level's later light kept (disk: {:.3}/{:.3}/{:.3}): exact {:.3}/{:.3}/{:.3}, local_keep {:.3}/{:.3}/{:.3}",
        (wd / w0).x,
        (wd / w0).y,
        (wd / w0).z,
        (wx / w0).x,
        (wx / w0).y,
        (wx / w0).z,
        (wa / w0).x,
        (wa / w0).y,
        (wa / w0).z
    );
}

/// The share of a uniform Lambertian disk's flux (centre `origin`, unit
/// `normal`, `radius`) that a convex object of surface `area` (cross-section
/// a quarter of it) at the bounds' centre takes: on the axis at height `d`,
/// `(area/4)/π · 2 (1 − d/√(d² + R²)) / R²` (→ `(area/4)/(π d²)` as R → 0),
/// times the cosine to it.
fn intercepted_by_disk(
    origin: Vec3,
    normal: Vec3,
    radius: f32,
    b: &gibake_scene::Aabb,
    area: f32,
) -> f32 {
    let to = (b.min + b.max) * 0.5 - origin;
    let r = (b.max - b.min).length() * 0.5;
    let d2 = to.length_squared();
    let d = d2.sqrt();
    let cos = if d > 0.0 {
        (normal.dot(to / d) + (r / d).min(1.0)).clamp(0.0, 1.0)
    } else {
        1.0
    };
    let rr = radius * radius;
    let g = if rr > 1e-6 * d2 {
        2.0 * (1.0 - d / (d2 + rr).sqrt()) / rr
    } else {
        1.0 / d2
    };
    (area * 0.25 / std::f32::consts::PI * g * cos).clamp(0.0, 1.0)
}
