//! `cargo run --release -p gibake-eval --example map_visibility -- LEVEL...`
//! How much of a level's indirect error is the VPL maps' visibility: bakes
//! the level (static part only, 664 VPLs, default maps), renders `indirect`
//! on the GPU (48², interleave 1), and sums at the same pixel centres the
//! CPU twin of the shading's transport (`gibake_eval::transport`) over the
//! same VPLs with exact ray-cast visibility, and without visibility. GPU /
//! CPU above 1 is light the maps let through that rays stop (as
//! `tests/runtime_modes.rs` checks on the bundled scenes). A second line
//! gives the twin with exact visibility but without the near-field trees
//! (every VPL one disk): what the near field adds.
use gibake_runtime::{Mode, RenderSettings};
use glam::Vec3;
fn main() {
    let names: Vec<String> = std::env::args().skip(1).collect();
    assert!(
        !names.is_empty(),
        "name one or more levels of data/levels/levels.json"
    );
    let list = gibake_eval::levels::bundled_list();
    let ctx = gibake_gpu::GpuContext::new(&Default::default()).unwrap();
    for spec in gibake_eval::levels::read_specs(&list).unwrap() {
        if !names.contains(&spec.name) {
            continue;
        }
        let mut scene = spec.load(list.parent().unwrap()).unwrap();
        scene.dynamic_meshes.clear();
        scene.dynamic_objects.clear();
        let s = gibake_eval::EvalSettings::default();
        let asset = gibake_eval::bake(&ctx, &scene, &s).unwrap();
        let size = 48u32;
        let time = 0.5;
        let settings = RenderSettings {
            width: size,
            height: size,
            mode: Mode::Indirect,
            interleave: 1,
            ..Default::default()
        };
        let gpu = gibake_eval::frame::render_image(
            &ctx.device,
            &ctx.queue,
            &scene,
            Some(&asset),
            &settings,
            time,
            1,
        )
        .unwrap();
        let rays = gibake_reference::RayScene::build(&scene, time);
        let view = gibake_reference::View::from_scene(&scene, time).unwrap();
        let (mut sd, mut sg, mut sv, mut su) = (0.0f64, 0.0f64, 0.0f64, 0.0f64);
        for y in 0..size {
            for x in 0..size {
                let (o, d, t0) = view.primary_ray(size, size, x as f32 + 0.5, y as f32 + 0.5);
                let Some(h) = rays.intersect_range(o, d, t0, f32::INFINITY) else {
                    continue;
                };
                let (mut e, mut eu, mut edisk) = (Vec3::ZERO, Vec3::ZERO, Vec3::ZERO);
                for (i, v) in asset.vpls.iter().enumerate() {
                    let n = Vec3::from_array(v.normal);
                    let org =
                        gibake_gpu::hemisphere::vpl_origin(Vec3::from_array(v.position), n, v.area);
                    let nodes = &asset.vpl_nodes
                        [i * gibake_asset::NODES_PER_VPL..(i + 1) * gibake_asset::NODES_PER_VPL];
                    let ei = gibake_eval::transport::static_vpl_irradiance(
                        v,
                        org,
                        nodes,
                        h.position,
                        h.shading_normal,
                        h.geometric_normal,
                    );
                    let ed = gibake_eval::transport::static_vpl_irradiance(
                        v,
                        org,
                        &[],
                        h.position,
                        h.shading_normal,
                        h.geometric_normal,
                    );
                    let vis = rays.visible(org, n, h.position, h.geometric_normal);
                    if vis {
                        edisk += ed;
                    }
                    eu += ei;
                    if vis {
                        e += ei;
                    }
                }
                let c = h.albedo / std::f32::consts::PI * e;
                let cu = h.albedo / std::f32::consts::PI * eu;
                sv += (c.x + c.y + c.z) as f64;
                su += (cu.x + cu.y + cu.z) as f64;
                let cd = h.albedo / std::f32::consts::PI * edisk;
                sd += (cd.x + cd.y + cd.z) as f64;
                let g = gpu.get(x, y);
                sg += (g.x + g.y + g.z) as f64;
            }
        }
        println!(
            "{}: GPU indirect {:.4e}, CPU twin exact vis {:.4e} (GPU/CPU {:.3}), CPU twin no vis {:.4e}",
            spec.name,
            sg,
            sv,
            sg / sv,
            su
        );
        println!(
            "  disk only (no near field), exact vis: {:.4e} (near field / disk {:.3})",
            sd,
            sv / sd
        );
    }
}
