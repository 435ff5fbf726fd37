//! The later bounces' VPLs judged on the CPU against an every-bounce
//! estimate (a probe for issue 50): the first bounce's VPLs
//! (`every_light`) and the later bounces' (`gibake_bake::later`), both
//! through the runtime's transport twin with exact visibility, against a
//! path-traced every-bounce indirect light at the pixel centres (next
//! event at every vertex, Russian roulette after the third bounce), and
//! the first bounce alone against the one-bounce reference.
//!
//! ```text
//! cargo run --release -p gibake-eval --example later_twin -- SCENE.glb | --list LEVELS.json NAME | LEVEL [--vpls N] [--later N] [--points N] [--rays N] [--size S] [--side N]
//! ```
//!
//! Environment: `SURFEL_DEBUG=1` prints the light of each bounce and the
//! surfels' directly reflected light; `DIAG=1` the pixels where the later
//! VPLs most exceed their surfels' own light and the VPLs that do it;
//! with `DIAG_TERMS=1` also, per such VPL, its open and map-tested parts
//! and its finest nodes near the pixel.

use gibake_bake::cluster::ClusterTarget;
use gibake_bake::later::{Bounces, LaterOptions, later_bounces};
use gibake_bake::lights::every_light;
use gibake_bake::reach::Reach;
use gibake_eval::transport::TwinVpls;
use gibake_reference::RayScene;
use glam::{DVec3, Vec3};
use rayon::prelude::*;
use std::f32::consts::PI;

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let (mut vpls, mut later, mut points, mut rays_per, mut size, mut side) =
        (256u32, 0u32, 16384u32, 64u32, 32u32, 16u32);
    let (mut list, mut name) = (None::<String>, None::<String>);
    let mut it = args.iter();
    while let Some(a) = it.next() {
        let mut num = || {
            it.next()
                .and_then(|v| v.parse::<u32>().ok())
                .expect("a number")
        };
        match a.as_str() {
            "--vpls" => vpls = num(),
            "--later" => later = num(),
            "--points" => points = num(),
            "--rays" => rays_per = num(),
            "--size" => size = num(),
            "--side" => side = num(),
            "--list" => list = it.next().cloned(),
            n => name = Some(n.to_string()),
        }
    }
    if later == 0 {
        later = vpls.div_ceil(4);
    }
    let name = name.expect("a scene or a level");
    let scene = if name.ends_with(".glb") || name.ends_with(".gltf") {
        gibake_scene::load(std::path::Path::new(&name), &Default::default()).expect("loads")
    } else {
        let list = list
            .map(std::path::PathBuf::from)
            .unwrap_or_else(gibake_eval::levels::bundled_list);
        let specs = gibake_eval::levels::read_specs(&list).expect("levels.json");
        let spec = specs
            .iter()
            .find(|s| s.name == name)
            .expect("a level of the list");
        spec.load(list.parent().unwrap()).expect("loads")
    };
    let stat = gibake_bake::static_only(&scene);
    let rays = RayScene::build(&stat, 0.0);
    let reach = Reach::new(&rays, scene.dynamic_swept_bounds());
    let t0 = std::time::Instant::now();
    let every = every_light(&scene, &reach, 512, 2048, ClusterTarget::Count(vpls));
    let t1 = t0.elapsed().as_secs_f64();
    let t0 = std::time::Instant::now();
    let l = later_bounces(
        &rays,
        &LaterOptions {
            bounces: Bounces::Every,
            points,
            rays: rays_per,
            vpls: later,
        },
        &[],
    );
    let t2 = t0.elapsed().as_secs_f64();
    // The same steps by hand, for the surfels' own light (each surfel a
    // small disk with exact visibility): what the clustering stands for.
    let sf = gibake_bake::later::surfels::place(&rays, points);
    let dir = gibake_bake::later::radiosity::direct(&rays, &sf);
    let links = gibake_bake::later::radiosity::link(&rays, &sf, rays_per);
    let sol = gibake_bake::later::radiosity::solve(&sf, &links, &dir, Bounces::Every);
    let emitters: Vec<(Vec3, Vec3, f32, Vec3)> = (0..sf.len())
        .map(|i| {
            (
                sf.position[i],
                sf.normal[i],
                sf.area[i],
                sf.albedo[i] * sol.indirect[i] * sf.area[i],
            )
        })
        .filter(|e| e.3.max_element() > 0.0)
        .collect();
    if std::env::var("SURFEL_DEBUG").is_ok() {
        for (k, b) in l.per_bounce.iter().enumerate() {
            eprintln!("  bounce {}: {:.4e} {:.4e} {:.4e}", k + 1, b.x, b.y, b.z);
        }
        eprintln!("  tail {:?}, direct {:?}", l.tail, l.direct);
    }
    if std::env::var("DIAG").is_ok() {
        // Per later VPL at the pixels where the VPLs most exceed their
        // surfels' own light: what each sends against what its surfels do.
        let em: Vec<Vec3> = (0..sf.len())
            .map(|i| sf.albedo[i] * sol.indirect[i] * sf.area[i])
            .collect();
        let b = stat.static_bounds();
        let sec = gibake_bake::later::secondary::cluster(
            &rays,
            &sf,
            &em,
            later,
            (b.max - b.min).length(),
        );
        let flags = vec![true; sec.vpls.len()];
        let tw = TwinVpls::new(&sec.vpls, &flags, &sec.nodes, &sec.coherence);
        let cam = gibake_reference::View::from_scene(&scene, 0.0).expect("a camera");
        // Per pixel: (excess, pixel, per-VPL (twin, surfels)).
        type Worst = (f32, u32, Vec<(usize, f32, f32)>);
        let mut worst: Vec<Worst> = (0..size * size)
            .into_par_iter()
            .filter_map(|p| {
                let (x, y) = (p % size, p / size);
                let (o, d, t0) = cam.primary_ray(size, size, x as f32 + 0.5, y as f32 + 0.5);
                let h = rays.intersect_range(o, d, t0, f32::INFINITY)?;
                let mut per = vec![(0f32, 0f32); sec.vpls.len()];
                for (i, v) in sec.vpls.iter().enumerate() {
                    let t = gibake_eval::transport::static_vpl_terms_at(
                        v,
                        tw.centres[i],
                        tw.tree(i),
                        &tw.lobes[i],
                        h.position,
                        h.shading_normal,
                        h.geometric_normal,
                        gibake_eval::transport::LATER_DESCENT_RATIO,
                    );
                    let vis = !gibake_eval::transport::origin_in_front(
                        tw.origins[i],
                        h.position,
                        h.geometric_normal,
                    ) || rays.visible(
                        tw.origins[i],
                        Vec3::from_array(v.normal),
                        h.position,
                        h.geometric_normal,
                    );
                    per[i].0 = (if vis { t.total() } else { t.open }).element_sum();
                    if std::env::var("DIAG_TERMS").is_ok() && t.open.element_sum() > 0.1 {
                        let tree = tw.tree(i);
                        for (k, n3) in tree.iter().enumerate().skip(20) {
                            if n3.texels == 0 {
                                continue;
                            }
                            let np = Vec3::from_array(n3.position);
                            let d = (np - h.position).length();
                            let r = (n3.area / PI).sqrt();
                            if d < 4.0 * r {
                                let near = sec
                                    .surfel_vpl
                                    .iter()
                                    .enumerate()
                                    .filter(|(_, v)| **v == i as u32)
                                    .map(|(s, _)| (sf.position[s] - np).length())
                                    .fold(f32::INFINITY, f32::min);
                                eprintln!(
                                    "        node {k}: at {np:.2?} normal {:.2?} r {r:.3} flux {:.4}, {d:.3} from the pixel (normal {:.2?}); nearest surfel of its VPL {near:.3} away",
                                    n3.normal,
                                    Vec3::from_array(n3.flux).element_sum(),
                                    h.geometric_normal
                                );
                            }
                        }
                        eprintln!(
                            "      pixel {p} VPL {i}: open {:.4} shadowed {:.4} visible {vis} at {:.2} from the origin",
                            t.open.element_sum(),
                            t.shadowed.element_sum(),
                            (tw.origins[i] - h.position).length()
                        );
                    }
                }
                for (k, &vv) in sec.surfel_vpl.iter().enumerate() {
                    if vv == u32::MAX {
                        continue;
                    }
                    let e = gibake_eval::transport::disk_irradiance(
                        sf.position[k],
                        sf.normal[k],
                        sf.area[k],
                        em[k],
                        h.position,
                        h.shading_normal,
                        h.geometric_normal,
                    );
                    if e != Vec3::ZERO
                        && rays.visible(
                            sf.position[k],
                            sf.normal[k],
                            h.position,
                            h.geometric_normal,
                        )
                    {
                        per[vv as usize].1 += e.element_sum();
                    }
                }
                let excess: f32 = per.iter().map(|(a, b)| a - b).sum();
                Some((
                    excess,
                    p,
                    per.into_iter()
                        .enumerate()
                        .map(|(i, (a, b))| (i, a, b))
                        .collect(),
                ))
            })
            .collect();
        worst.sort_by(|a, b| b.0.total_cmp(&a.0));
        for (excess, p, mut per) in worst.into_iter().take(3) {
            println!("  pixel {p}: later VPLs exceed their surfels by {excess:.4}");
            per.sort_by(|a, b| (b.1 - b.2).total_cmp(&(a.1 - a.2)));
            for (i, a, b) in per.into_iter().take(3) {
                let v = &sec.vpls[i];
                let n = sec.surfel_vpl.iter().filter(|&&x| x == i as u32).count();
                let (mut lo, mut hi) = (Vec3::splat(f32::MAX), Vec3::splat(f32::MIN));
                for (k, &x) in sec.surfel_vpl.iter().enumerate() {
                    if x == i as u32 {
                        lo = lo.min(sf.position[k]);
                        hi = hi.max(sf.position[k]);
                    }
                }
                println!(
                    "    VPL {i}: {n} surfels, at {:.2?} normal {:.2?}, area {:.2}, extent {:.2?}, coherence {:.3}: sends {a:.4}, its surfels {b:.4}",
                    v.position,
                    v.normal,
                    v.area,
                    hi - lo,
                    tw.lobes[i].vpl
                );
            }
        }
    }
    let records = every.vpl_records();
    let (nodes, coherence) = every.vpl_trees();
    let ring = every.ring_flags();
    let first = TwinVpls::new(&records, &ring, &nodes, &coherence);
    // Lifted by one surfel's radius, as the bake does (a ring VPL's rule).
    let no_ring = vec![true; l.vpls.len()];
    let second = TwinVpls::new(&l.vpls, &no_ring, &l.nodes, &l.coherence).with_later(l.vpls.len());
    let cam = gibake_reference::View::from_scene(&scene, 0.0).expect("a camera");
    // Per pixel: one-bounce and every-bounce reference, first-bounce VPLs,
    // later VPLs, surfels; and, without visibility, the later VPLs and
    // the surfels (what the clustering's transport does apart from its
    // visibility).
    type Px = (Vec3, Vec3, Vec3, Vec3, Vec3, Vec3, Vec3);
    let px: Vec<Px> = (0..size * size)
        .into_par_iter()
        .map(|p| {
            let (x, y) = (p % size, p / size);
            let (o, d, t0) = cam.primary_ray(size, size, x as f32 + 0.5, y as f32 + 0.5);
            let Some(h) = rays.intersect_range(o, d, t0, f32::INFINITY) else {
                return Px::default();
            };
            // The reference's one-bounce and every-bounce radiance at the
            // pixel centre (gibake_eval::bounce, validated against Mitsuba 3).
            let (mut one, mut all) = (Vec3::ZERO, Vec3::ZERO);
            let mut stats = gibake_reference::PathStats::default();
            gibake_eval::bounce::every_bounce_samples(&rays, &h, p, side, &mut stats, |_, d, e| {
                one += d;
                all += e;
            });
            let one = h.albedo * one / (side * side) as f32;
            let all = h.albedo * all / (side * side) as f32;
            let a = h.albedo / PI * first.irradiance(&rays, &h).visible;
            let later = second.irradiance(&rays, &h);
            let b = h.albedo / PI * later.visible;
            let (mut e, mut e_open) = (Vec3::ZERO, Vec3::ZERO);
            for &(p, n, ar, f) in &emitters {
                let k = gibake_eval::transport::disk_irradiance(
                    p,
                    n,
                    ar,
                    f,
                    h.position,
                    h.shading_normal,
                    h.geometric_normal,
                );
                e_open += k;
                if k != Vec3::ZERO && rays.visible(p, n, h.position, h.geometric_normal) {
                    e += k;
                }
            }
            (
                one,
                all,
                a,
                b,
                h.albedo / PI * e,
                h.albedo / PI * later.unshadowed,
                h.albedo / PI * e_open,
            )
        })
        .collect();
    let mut s = [DVec3::ZERO; 7];
    for v in &px {
        s[5] += v.5.as_dvec3();
        s[6] += v.6.as_dvec3();
        s[4] += v.4.as_dvec3();
        s[0] += v.0.as_dvec3();
        s[1] += v.1.as_dvec3();
        s[2] += v.2.as_dvec3();
        s[3] += v.3.as_dvec3();
    }
    let blur_err = |img: &dyn Fn(usize) -> Vec3, refi: &dyn Fn(usize) -> Vec3| {
        let (mut num, mut den) = (0f64, 0f64);
        for y in 0..size as i32 {
            for x in 0..size as i32 {
                let (mut a, mut r) = (Vec3::ZERO, Vec3::ZERO);
                for dy in -1..=1 {
                    for dx in -1..=1 {
                        let (xx, yy) = (
                            (x + dx).clamp(0, size as i32 - 1),
                            (y + dy).clamp(0, size as i32 - 1),
                        );
                        let i = (yy * size as i32 + xx) as usize;
                        a += img(i);
                        r += refi(i);
                    }
                }
                num += f64::from((a - r).length_squared());
                den += f64::from(r.length_squared());
            }
        }
        (num / den).sqrt()
    };
    let pct = |a: DVec3, b: DVec3| {
        let r = a / b - 1.0;
        format!(
            "{:+.1}/{:+.1}/{:+.1}%",
            r.x * 100.0,
            r.y * 100.0,
            r.z * 100.0
        )
    };
    let later_share: f64 = l.later_share();
    println!(
        "{name}: {} first-bounce VPLs ({t1:.1} s), {} later VPLs from {} surfels ({t2:.1} s, {} bounces{}, converged {}), later share of reflected light {:.2}%",
        records.len(),
        l.vpls.len(),
        l.surfels,
        l.per_bounce.len(),
        if l.tail != Vec3::ZERO { " + tail" } else { "" },
        l.converged,
        later_share * 100.0
    );
    println!(
        "  first + surfels' own light vs every-bounce ref: {} (err {:.3}); later VPLs / surfels' own light: {}",
        pct(s[2] + s[4], s[1]),
        blur_err(&|i| px[i].2 + px[i].4, &|i| px[i].1),
        pct(s[3], s[4]),
    );
    println!(
        "  without visibility: later VPLs / surfels {}; visibility keeps of the surfels' light {:.1}%, of the later VPLs' {:.1}%",
        pct(s[5], s[6]),
        100.0 * (s[4].element_sum() / s[6].element_sum()),
        100.0 * (s[3].element_sum() / s[5].element_sum()),
    );
    println!(
        "  every bounce / one bounce (reference, indirect): {}",
        pct(s[1], s[0]).replace('%', "").replace('+', "×+")
    );
    println!(
        "  first bounce vs one-bounce ref: {} (blurred err {:.3}); first+later vs every-bounce ref: {} (blurred err {:.3}); first alone vs every-bounce: {} (err {:.3})",
        pct(s[2], s[0]),
        blur_err(&|i| px[i].2, &|i| px[i].0),
        pct(s[2] + s[3], s[1]),
        blur_err(&|i| px[i].2 + px[i].3, &|i| px[i].1),
        pct(s[2], s[1]),
        blur_err(&|i| px[i].2, &|i| px[i].1),
    );
}
