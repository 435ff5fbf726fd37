//! Diagnostic: where does clustered-VPL indirect light lose energy?
//! CPU only. For each scene (random seeds), static part only, at the pixel
//! centres of a small image:
//!   REF  cosine-sampled one-bounce indirect (path tracer estimator)
//!   A    current VPLs: point at vpl_origin, ray-cast visibility
//!   B    VPL origin on the own texel nearest the centroid
//!   C    A's transport, visibility averaged over K flux-sampled own texels
//!   D    per-texel: K flux-sampled texels, each with own transport + vis
//!   E    A without visibility (rsm)
//!   F1   SUB² sub-points per VPL (env SUB, default 4), visibility from B
//!   F2   the same sub-points, each with its own visibility
//!   F3   the same sub-points, visibility as C
//!   T    the runtime's transport (one disk at B's origin far away, the
//!        bake's near-field tree near it: gibake_eval::transport), with
//!        exact visibility from B's origin — what the GPU computes with
//!        exact maps (B's lift: env LIFT, default the bake's 0.2)
//! After each scene's line, the same biases (A … T) on the "hot"
//! receivers, whose reference is ≥ 10× the mean, and on the rest, with
//! each group's share of the light.
//! usage: vpl_diag SEED|BUNDLED|LEVEL... [--vpls N] [--size S]
//! (LEVEL: a name in data/levels/levels.json; its camera and moving
//! objects as `eval_levels` loads them; or `FILE.glb[:K]`, a glTF file's
//! light K alone, default its first; not a point light, whose six views
//! `lights_twin FILE --only K --split` judges). VPLs as the bake makes them:
//! reach-weighted clustering, VPLs that see nothing dropped.

use gibake_bake::cluster::{ClusterTarget, cluster};
use gibake_bake::reach::Reach;
use gibake_bake::rsm::render_rsm;
use gibake_gpu::{LightView, hemisphere};
use gibake_raycast::RayScene;
use glam::Vec3;
use rayon::prelude::*;
use std::f32::consts::PI;

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let mut seeds = Vec::new();
    let mut vpls = 664u32;
    let mut size = 48u32;
    let mut k_samples = 8usize;
    let mut i = 0;
    while i < args.len() {
        match args[i].as_str() {
            "--vpls" => {
                vpls = args[i + 1].parse().unwrap();
                i += 1
            }
            "--size" => {
                size = args[i + 1].parse().unwrap();
                i += 1
            }
            "--k" => {
                k_samples = args[i + 1].parse().unwrap();
                i += 1
            }
            s => seeds.push(s.to_string()),
        }
        i += 1;
    }
    println!(
        "{:>14} {:>7} {:>7} {:>7} {:>7} {:>7} | {:>6} {:>6} {:>6} {:>6} {:>6}",
        "scene",
        "biasA",
        "biasB",
        "biasC",
        "biasD",
        "biasE",
        "errA",
        "errB",
        "errC",
        "errD",
        "errE"
    );
    println!(
        "   then F1 (sub-points, vis from B) F2 (sub-points, own vis) F3 (sub-points, vis as C) T (the runtime's transport, vis from B)"
    );
    for s in seeds {
        let list = gibake_eval::levels::bundled_list();
        let levels = gibake_eval::levels::read_specs(&list).unwrap();
        let (scene, info) = if let Ok(seed) = s.parse::<u64>() {
            let (b, i) = gibake_scenegen::random(seed, &Default::default());
            (gibake_eval::load(&b, "x.glb"), i.to_string())
        } else if s.contains(".gl") {
            // A glTF file's first light (or light K: `FILE.glb:K`) alone.
            let mut scene = gibake_eval::load_gltf_lights(&s).expect("a glTF file");
            scene.lights.truncate(1);
            (scene, s.clone())
        } else if let Some(l) = levels.iter().find(|l| l.name == s) {
            (l.load(list.parent().unwrap()).unwrap(), l.what.clone())
        } else {
            let b = gibake_scenegen::by_name(&s).unwrap()(&Default::default());
            (gibake_eval::load(&b, "x.glb"), s.clone())
        };
        if matches!(scene.light().kind, gibake_scene::LightKind::Point) {
            // One view per scene here; a point light has six (cube faces).
            eprintln!(
                "vpl_diag: {s}: a point light has six views and vpl_diag judges one; use `lights_twin FILE --only K --split`"
            );
            std::process::exit(2);
        }
        let stat = gibake_bake::static_only(&scene);
        let rays = RayScene::build(&stat, 0.0);
        let reach = Reach::new(&rays, scene.dynamic_swept_bounds());
        let view = LightView::for_scene(&scene, 2048).resized(512);
        let rsm = render_rsm(&rays, scene.light(), &view, Some(&reach));
        let mut cl = cluster(&rsm, ClusterTarget::Count(vpls));
        let reaching = cl.reaching_flux(&rsm);
        cl.retain(|i, c| reach.keeps(c, reaching[i], false));
        // Texels per VPL with flux weights.
        let mut members: Vec<Vec<(usize, f32)>> = vec![Vec::new(); cl.vpls.len()];
        for (t, &v) in cl.texel_vpl.iter().enumerate() {
            if v != u32::MAX {
                let f = rsm.flux[t];
                members[v as usize].push((t, f.x + f.y + f.z));
            }
        }
        // K stratified flux samples per VPL, along the Morton order of the
        // member texels (spread over the cluster; in row order a square
        // cluster of uniform flux put all K in its first column).
        let size_t = rsm.size as usize;
        let morton = |t: usize| {
            let (mut x, mut y, mut code) = ((t % size_t) as u64, (t / size_t) as u64, 0u64);
            for bit in 0..16 {
                code |= ((x & 1) << (2 * bit)) | ((y & 1) << (2 * bit + 1));
                x >>= 1;
                y >>= 1;
            }
            code
        };
        let samples: Vec<Vec<usize>> = members
            .iter()
            .map(|m| {
                let mut m = m.clone();
                m.sort_by_key(|&(t, _)| morton(t));
                let tot: f32 = m.iter().map(|x| x.1).sum();
                let mut out = Vec::new();
                let mut acc = 0.0;
                let mut j = 0;
                for k in 0..k_samples {
                    let u = (k as f32 + 0.5) / k_samples as f32 * tot;
                    while j + 1 < m.len() && acc + m[j].1 < u {
                        acc += m[j].1;
                        j += 1;
                    }
                    out.push(m[j].0);
                }
                out
            })
            .collect();
        // Origin on own texel nearest to centroid.
        let surf: Vec<Vec3> = cl
            .vpls
            .iter()
            .zip(&members)
            .map(|(v, m)| {
                m.iter()
                    .map(|&(t, _)| rsm.position[t])
                    .min_by(|a, b| {
                        (*a - v.position)
                            .length_squared()
                            .total_cmp(&(*b - v.position).length_squared())
                    })
                    .unwrap()
            })
            .collect();
        let sz = rsm.size as usize;
        let sub: Vec<Vec<(Vec3, Vec3, Vec3, f32)>> = members
            .iter()
            .map(|m| {
                let (mut x0, mut x1, mut y0, mut y1) = (usize::MAX, 0, usize::MAX, 0);
                for &(t, _) in m {
                    x0 = x0.min(t % sz);
                    x1 = x1.max(t % sz + 1);
                    y0 = y0.min(t / sz);
                    y1 = y1.max(t / sz + 1);
                }
                let g = sub_n();
                let mut acc = vec![(Vec3::ZERO, Vec3::ZERO, Vec3::ZERO, 0.0f32, 0.0f32); g * g];
                for &(t, w) in m {
                    let gx = ((t % sz - x0) * g / (x1 - x0)).min(g - 1);
                    let gy = ((t / sz - y0) * g / (y1 - y0)).min(g - 1);
                    let a = &mut acc[gy * g + gx];
                    a.0 += rsm.position[t] * w;
                    a.1 += rsm.normal[t] * w;
                    a.2 += rsm.flux[t];
                    a.3 += rsm.area[t];
                    a.4 += w;
                }
                acc.into_iter()
                    .filter(|a| a.4 > 0.0)
                    .map(|a| (a.0 / a.4, a.1.normalize(), a.2, a.3))
                    .collect()
            })
            .collect();
        let cam = gibake_reference::View::from_scene(&stat, 0.0).unwrap();
        let per_vpl = std::sync::Mutex::new(vec![0f64; cl.vpls.len()]);
        let trees: Vec<(Vec<gibake_asset::VplRecord>, Vec<f32>)> = (0..cl.vpls.len())
            .map(|i| gibake_bake::near_field::tree_and_coherence_of(&rsm, &cl, i))
            .collect();
        let lobes: Vec<gibake_eval::transport::VplLobes> = trees
            .iter()
            .map(|(t, c)| gibake_eval::transport::VplLobes::of_tree(t, c))
            .collect();
        let nodes: Vec<Vec<gibake_asset::VplRecord>> = trees.into_iter().map(|t| t.0).collect();
        let px: Vec<[Vec3; 10]> = (0..size * size)
            .into_par_iter()
            .map(|p| {
                let (x, y) = (p % size, p / size);
                let mut out = [Vec3::ZERO; 10];
                let (o, d, t0) = cam.primary_ray(size, size, x as f32 + 0.5, y as f32 + 0.5);
                let Some(h) = rays.intersect_range(o, d, t0, f32::INFINITY) else {
                    return out;
                };
                let a = h.albedo / PI;
                // REF
                let m = 32u32; // 1024 samples
                let mut s = Vec3::ZERO;
                gibake_eval::bounce::one_bounce_samples(&rays, &h, p, m, |_, l| s += l);
                out[0] = h.albedo * s / (m * m) as f32;
                let xg = h.position;
                let g = |org: Vec3, n: Vec3, area: f32, flux: Vec3| -> Vec3 {
                    let dv = xg - org;
                    let d2 = dv.length_squared();
                    let dir = dv / d2.sqrt();
                    let (cv, cr) = (n.dot(dir), h.shading_normal.dot(-dir));
                    if cv <= 0.0 || cr <= 0.0 || h.geometric_normal.dot(-dir) <= 0.0 {
                        return Vec3::ZERO;
                    }
                    let r2 = area / PI;
                    flux * (cv * cr / PI / (d2 * d2 + r2 * r2).sqrt())
                };
                let mut local = vec![0f64; cl.vpls.len()];
                for (vi, v) in cl.vpls.iter().enumerate() {
                    let before = (out[6] - out[4]).dot(h.albedo);
                    let n = v.normal;
                    let org = hemisphere::vpl_origin(v.position, n, v.area);
                    let ga = g(org, n, v.area, v.flux);
                    if ga != Vec3::ZERO {
                        out[5] += ga;
                        if rays.visible(org, n, xg, h.geometric_normal) {
                            out[1] += ga;
                        }
                    }
                    // C: averaged vis over own texels.
                    let mut visc = 0.0;
                    for &tx in &samples[vi] {
                        if rays.visible(rsm.position[tx], rsm.normal[tx], xg, h.geometric_normal) {
                            visc += 1.0;
                        }
                    }
                    let visc = visc / samples[vi].len() as f32;
                    out[3] += ga * visc;
                    let lift: f32 = std::env::var("LIFT")
                        .map(|s| s.parse().unwrap())
                        .unwrap_or(hemisphere::VPL_ORIGIN_OFFSET);
                    let orgb = surf[vi] + n * (lift * (v.area / PI).sqrt());
                    let gb = g(orgb, n, v.area, v.flux);
                    let visb = rays.visible(orgb, n, xg, h.geometric_normal);
                    if gb != Vec3::ZERO && visb {
                        out[2] += gb;
                    }
                    if visb {
                        let rec = gibake_asset::VplRecord {
                            position: orgb.to_array(),
                            area: v.area,
                            normal: n.to_array(),
                            texels: v.texels,
                            flux: v.flux.to_array(),
                            map: 0,
                        };
                        // Drawn from its far-field centre, as shading does.
                        let centre = gibake_asset::far_field_centre(&nodes[vi])
                            .map_or(orgb, Vec3::from_array);
                        out[9] += gibake_eval::transport::static_vpl_irradiance(
                            &rec,
                            centre,
                            &nodes[vi],
                            &lobes[vi],
                            xg,
                            h.shading_normal,
                            h.geometric_normal,
                        );
                    }
                    for &(sp, sn, sf, sa) in &sub[vi] {
                        let gs = g(sp, sn, sa, sf);
                        if gs == Vec3::ZERO {
                            continue;
                        }
                        if visb {
                            out[6] += gs;
                        }
                        out[8] += gs * visc;
                        if rays.visible(sp, sn, xg, h.geometric_normal) {
                            out[7] += gs;
                        }
                    }
                    // D: per texel sample.
                    let kk = samples[vi].len() as f32;
                    for &tx in &samples[vi] {
                        let gd = g(rsm.position[tx], rsm.normal[tx], v.area / kk, v.flux / kk);
                        if gd != Vec3::ZERO
                            && rays.visible(
                                rsm.position[tx],
                                rsm.normal[tx],
                                xg,
                                h.geometric_normal,
                            )
                        {
                            out[4] += gd;
                        }
                    }
                    local[vi] += f64::from((out[6] - out[4]).dot(h.albedo) - before);
                }
                for e in out.iter_mut().skip(1) {
                    *e *= a;
                }
                {
                    let mut g = per_vpl.lock().unwrap();
                    for (k, v) in local.iter().enumerate() {
                        g[k] += v;
                    }
                }
                out
            })
            .collect();
        // Means and blurred errors.
        let mean = |k: usize| px.iter().fold(Vec3::ZERO, |s, p| s + p[k]) / px.len() as f32;
        let blur = |k: usize| -> Vec<Vec3> {
            let mut o = vec![Vec3::ZERO; px.len()];
            for y in 0..size as i32 {
                for x in 0..size as i32 {
                    let mut s = Vec3::ZERO;
                    let mut c = 0.0;
                    for dy in -1..=1 {
                        for dx in -1..=1 {
                            let (xx, yy) = (x + dx, y + dy);
                            if xx >= 0 && yy >= 0 && xx < size as i32 && yy < size as i32 {
                                s += px[(yy * size as i32 + xx) as usize][k];
                                c += 1.0;
                            }
                        }
                    }
                    o[(y * size as i32 + x) as usize] = s / c;
                }
            }
            o
        };
        let r = mean(0);
        let br = blur(0);
        let rm = (r.x + r.y + r.z) / 3.0;
        let mut line = format!("{:>14}", &s);
        let mut errs = String::new();
        for k in 1..10 {
            let m = mean(k);
            let bias = ((m / r) - Vec3::ONE) * 100.0;
            line += &format!(" {:>+7.1}", bias.min_element().min(bias.max_element()));
            let bk = blur(k);
            let e = (bk
                .iter()
                .zip(&br)
                .map(|(a, b)| (*a - *b).length_squared() as f64)
                .sum::<f64>()
                / (3.0 * bk.len() as f64))
                .sqrt() as f32
                / rm;
            errs += &format!(" {:>6.3}", e);
        }
        println!("{line} |{errs}   {info} vpls={}", cl.vpls.len());
        // The same biases on the receivers whose reference is ≥ 10× the
        // mean (on an open level: the objects' sides facing the sunlit
        // ground) and on the rest.
        let lum = |v: Vec3| f64::from(v.x + v.y + v.z);
        let mean0 = px.iter().map(|p| lum(p[0])).sum::<f64>() / px.len().max(1) as f64;
        for (what, hot) in [("hot", true), ("rest", false)] {
            let pick: Vec<&[Vec3; 10]> = px
                .iter()
                .filter(|p| (lum(p[0]) >= 10.0 * mean0) == hot)
                .collect();
            let r: f64 = pick.iter().map(|p| lum(p[0])).sum();
            let mut line = format!("{:>14}", format!("{what} ({})", pick.len()));
            for k in 1..10 {
                let m: f64 = pick.iter().map(|p| lum(p[k])).sum();
                line += &format!(" {:>+7.1}", 100.0 * (m / r.max(f64::MIN_POSITIVE) - 1.0));
            }
            println!(
                "{line}   ({:.0}% of the light)",
                100.0 * r / (mean0 * px.len() as f64).max(f64::MIN_POSITIVE)
            );
        }
        if std::env::var("TOP").is_ok() {
            let g = per_vpl.lock().unwrap();
            let mut idx: Vec<usize> = (0..g.len()).collect();
            idx.sort_by(|a, b| g[*a].total_cmp(&g[*b]));
            let tot: f64 = g.iter().sum();
            println!("  total F1-D {tot:.4}");
            for &k in idx.iter().take(8) {
                let v = &cl.vpls[k];
                let m = &members[k];
                let nbar: Vec3 =
                    m.iter().map(|&(t, _)| rsm.normal[t]).sum::<Vec3>() / m.len() as f32;
                println!(
                    "  vpl {k}: F1-D {:.4} texels {} rect {:?} 1-|n| {:.3} anchor-centroid {:.3} R {:.3} pos {:?} n {:?}",
                    g[k],
                    v.texels,
                    cl.rects[k],
                    1.0 - nbar.length(),
                    (v.anchor - v.position).length(),
                    (v.area / PI).sqrt(),
                    v.position,
                    v.normal
                );
            }
        }
    }
}

fn sub_n() -> usize {
    std::env::var("SUB")
        .map(|s| s.parse().unwrap())
        .unwrap_or(4)
}
