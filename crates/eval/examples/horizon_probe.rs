//! `cargo run --release -p gibake-eval --example horizon_probe -- LEVEL|FILE.glb...`
//! The light the static VPLs send below their own horizon, under four
//! visibility rules, in the CPU twin of the shading
//! (`gibake_eval::transport`) against the CPU reference's one bounce at
//! 48² pixel centres (`SIZE=N` for another size), static part, 664 VPLs:
//! - `rim`: the first map's rim answer (the shading before format 4.7);
//! - `origin`: exact rays from the VPL's one map origin;
//! - `second`: exact rays from its second origin where it has one
//!   (`gibake_bake::horizon`), the rim answer elsewhere — what the second
//!   maps give, short of their own resolution;
//! - `open`: no test below the horizon.
//!
//! Above the horizon every rule takes exact rays from the map origin. One
//! line per level with each rule's mean bias, and the share of the light
//! below the horizons; `TOP=N` also lists the N VPLs that send the most
//! light below their horizon, with their share under each rule
//! (docs/method.md, "Below the horizon").
use glam::Vec3;

fn env(name: &str, d: f32) -> f32 {
    std::env::var(name)
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(d)
}

fn main() {
    let names: Vec<String> = std::env::args().skip(1).collect();
    assert!(
        !names.is_empty(),
        "name one or more levels of data/levels/levels.json or glTF files"
    );
    let list = gibake_eval::levels::bundled_list();
    let ctx = gibake_gpu::GpuContext::new(&Default::default()).unwrap();
    let is_file = |n: &String| n.ends_with(".glb") || n.ends_with(".gltf");
    let mut scenes = Vec::new();
    for spec in gibake_eval::levels::read_specs(&list).unwrap() {
        if names.contains(&spec.name) {
            scenes.push((
                spec.name.clone(),
                spec.load(list.parent().unwrap()).unwrap(),
            ));
        }
    }
    for n in names.iter().filter(|n| is_file(n)) {
        let scene = gibake_scene::load(std::path::Path::new(n), &Default::default())
            .unwrap_or_else(|e| panic!("{n}: {e}"));
        scenes.push((n.clone(), scene));
    }
    let size = env("SIZE", 48.0) as u32;
    let top = env("TOP", 0.0) as usize;
    for (name, mut scene) in scenes {
        scene.dynamic_meshes.clear();
        scene.dynamic_objects.clear();
        let asset = gibake_eval::bake(&ctx, &scene, &Default::default()).unwrap();
        let time = 0.5;
        let rays = gibake_reference::RayScene::build(&scene, time);
        let view = gibake_reference::View::from_scene(&scene, time).unwrap();
        let twin = gibake_eval::transport::TwinVpls::of_asset(&asset);
        let maps = gibake_eval::transport::TwinMaps::of_asset(&asset);
        let with = twin.lower.iter().filter(|l| l.is_some()).count();
        // The reference; the light above the horizons (and the open
        // part); below: per rule (rim, origin, second, open), per VPL.
        let (mut sr, mut rest) = (0.0f64, 0.0f64);
        let mut below = [0.0f64; 4];
        let mut per_vpl = vec![[0.0f64; 4]; asset.vpls.len()];
        for y in 0..size {
            for x in 0..size {
                let (o, d, t0) = view.primary_ray(size, size, x as f32 + 0.5, y as f32 + 0.5);
                let Some(h) = rays.intersect_range(o, d, t0, f32::INFINITY) else {
                    continue;
                };
                let radiance = |e: Vec3| (h.albedo / std::f32::consts::PI * e).element_sum() as f64;
                let (p, ns, ng) = (h.position, h.shading_normal, h.geometric_normal);
                let exact = |o: Vec3, n: Vec3| -> f64 {
                    if !gibake_eval::transport::origin_in_front(o, p, ng) {
                        return 1.0;
                    }
                    f64::from(u8::from(rays.visible(o, n, p, ng)))
                };
                for (i, t) in twin.terms(p, ns, ng) {
                    let nv = Vec3::from_array(asset.vpls[i].normal);
                    let origin = twin.origins[i];
                    rest += radiance(t.open);
                    let r = radiance(t.shadowed);
                    let e1 = exact(origin, nv);
                    if nv.dot(p - origin) >= 0.0 {
                        rest += r * e1;
                        continue;
                    }
                    let rim = maps.maps[i].as_deref().map_or(1.0, |m| {
                        gibake_eval::transport::map_visibility(m, maps.size, nv, origin, p, ng)
                    });
                    let rim = f64::from(rim);
                    let second = twin.lower_origin(i).map_or(rim, |o2| exact(o2, -nv));
                    for (k, vis) in [rim, e1, second, 1.0].into_iter().enumerate() {
                        below[k] += r * vis;
                        per_vpl[i][k] += r * vis;
                    }
                }
                let mut l = Vec3::ZERO;
                gibake_eval::bounce::one_bounce_samples(&rays, &h, y * size + x, 16, |_, r| l += r);
                sr += (h.albedo * l / 256.0).element_sum() as f64;
            }
        }
        let total = rest + below[1];
        if top > 0 {
            let mut order: Vec<usize> = (0..asset.vpls.len()).collect();
            order.sort_by(|&a, &b| per_vpl[b][3].total_cmp(&per_vpl[a][3]));
            for &i in order.iter().take(top) {
                let (v, q) = (&asset.vpls[i], per_vpl[i]);
                let pct = |x: f64| x / total * 100.0;
                println!(
                    "  VPL {i} at {:.2?}, normal {:.2?}, area {:.3}, coherence {:.2}, map origin {:.2?}, second origin {:.2?}: % of the light rim {:.2} origin {:.2} second {:.2} open {:.2}",
                    v.position,
                    v.normal,
                    v.area,
                    twin.lobes[i].vpl,
                    twin.origins[i],
                    twin.lower_origin(i),
                    pct(q[0]),
                    pct(q[1]),
                    pct(q[2]),
                    pct(q[3])
                );
            }
        }
        let pct = |b: f64| (rest + b) / sr * 100.0 - 100.0;
        println!(
            "{name}: {} VPLs, {with} with a second origin; light below the horizons (origin's rays) {:.1}% of the total; against the reference: rim {:+.1}%  origin {:+.1}%  second {:+.1}%  open {:+.1}%",
            asset.vpls.len(),
            below[1] / total * 100.0,
            pct(below[0]),
            pct(below[1]),
            pct(below[2]),
            pct(below[3])
        );
    }
}
