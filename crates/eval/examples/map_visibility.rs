//! `cargo run --release -p gibake-eval --example map_visibility -- LEVEL|FILE.glb...`
//! How much of a level's indirect error is the VPL maps' visibility: bakes
//! the level (static part only, 664 VPLs, default maps), renders `indirect`
//! on the GPU (48², interleave 1), and sums at the same pixel centres the
//! CPU twin of the shading's transport (`gibake_eval::transport`) over the
//! same VPLs with exact ray-cast visibility, and without visibility. GPU /
//! CPU above 1 is light the maps let through that rays stop (as
//! `tests/runtime_modes.rs` checks on the bundled scenes). A second line
//! gives the twin with exact visibility but without the near-field trees
//! (every VPL one disk): what the near field adds. A third line: the CPU
//! reference's one-bounce light at the same pixel centres
//! (`gibake_eval::bounce`, 16 × 16 stratified samples), and the GPU's and
//! the twin's mean against it (the static bake's own bias, to compare with
//! `lights_twin`'s, whose bake is the every-light path's). A fourth line:
//! the maps emulated on the CPU (`gibake_eval::transport::map_visibility`,
//! the shader's lookup on the asset's maps; its ratio to the rays should
//! match the GPU's), and where their excess over the rays lies — light to
//! receivers below the VPL's horizon (its second map's, from its second
//! origin, where it has one: `gibake_bake::horizon`; else the first map's
//! rim) or above it — as shares of the rays' total. The twin's exact rays
//! are cast from the same origins as the maps
//! (`TwinVpls::visibility_frame`). A fifth line: the GPU again without the
//! second maps (`gibake_eval::without_second_maps`, as a format 4.6 asset
//! renders: the first map's rim below the horizon).
use gibake_runtime::{Mode, RenderSettings};
fn main() {
    let names: Vec<String> = std::env::args().skip(1).collect();
    assert!(
        !names.is_empty(),
        "name one or more levels of data/levels/levels.json"
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
    for (name, mut scene) in scenes {
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
        let without = gibake_eval::without_second_maps(asset.clone());
        let gpu_rim = gibake_eval::frame::render_image(
            &ctx.device,
            &ctx.queue,
            &scene,
            Some(&without),
            &settings,
            time,
            1,
        )
        .unwrap();
        let mut sg_rim = 0.0f64;
        let rays = gibake_reference::RayScene::build(&scene, time);
        let view = gibake_reference::View::from_scene(&scene, time).unwrap();
        let twin = gibake_eval::transport::TwinVpls::of_asset(&asset);
        let maps = gibake_eval::transport::TwinMaps::of_asset(&asset);
        // Emulated maps' total; their excess over rays below / above the
        // VPL's horizon.
        let (mut sm, mut below, mut above) = (0.0f64, 0.0f64, 0.0f64);
        let (mut sd, mut sg, mut sv, mut su) = (0.0f64, 0.0f64, 0.0f64, 0.0f64);
        let mut sr = 0.0f64;
        for y in 0..size {
            for x in 0..size {
                let (o, d, t0) = view.primary_ray(size, size, x as f32 + 0.5, y as f32 + 0.5);
                let Some(h) = rays.intersect_range(o, d, t0, f32::INFINITY) else {
                    continue;
                };
                let t = twin.irradiance(&rays, &h);
                // Radiance (albedo/π · E), summed over the channels.
                let radiance =
                    |e: glam::Vec3| (h.albedo / std::f32::consts::PI * e).element_sum() as f64;
                sv += radiance(t.visible);
                su += radiance(t.unshadowed);
                sd += radiance(t.visible_disk);
                let (p, ns, ng) = (h.position, h.shading_normal, h.geometric_normal);
                for (i, t) in twin.terms(p, ns, ng) {
                    let nv = glam::Vec3::from_array(asset.vpls[i].normal);
                    let origin = twin.origins[i];
                    let (o, n, _) = twin.visibility_frame(i, p);
                    let exact = if gibake_eval::transport::origin_in_front(o, p, ng) {
                        f64::from(u8::from(rays.visible(o, n, p, ng)))
                    } else {
                        1.0
                    };
                    let m = maps.visibility(&twin, i, p, ng);
                    // The open part (finest nodes, near) is not map-tested.
                    let r = radiance(t.shadowed);
                    sm += r * f64::from(m) + radiance(t.open);
                    if nv.dot(p - origin) < 0.0 {
                        below += r * (f64::from(m) - exact);
                    } else {
                        above += r * (f64::from(m) - exact);
                    }
                }
                let g = gpu.get(x, y);
                sg += (g.x + g.y + g.z) as f64;
                let g = gpu_rim.get(x, y);
                sg_rim += (g.x + g.y + g.z) as f64;
                let mut l = glam::Vec3::ZERO;
                gibake_eval::bounce::one_bounce_samples(&rays, &h, y * size + x, 16, |_, r| l += r);
                sr += (h.albedo * l / 256.0).element_sum() as f64;
            }
        }
        println!(
            "{}: GPU indirect {:.4e}, CPU twin exact vis {:.4e} (GPU/CPU {:.3}), CPU twin no vis {:.4e}",
            name,
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
        println!(
            "  reference one bounce {:.4e}: GPU {:+.1}%, CPU twin exact vis {:+.1}%",
            sr,
            (sg / sr - 1.0) * 100.0,
            (sv / sr - 1.0) * 100.0
        );
        println!(
            "  maps on the CPU {:.4e} (CPU maps / rays {:.3}); their excess over rays: {:+.1}% below the VPLs' horizon, {:+.1}% above",
            sm,
            sm / sv,
            below / sv * 100.0,
            above / sv * 100.0
        );
        let with = asset.vpl_lower.iter().filter(|l| l.is_some()).count();
        println!(
            "  GPU without the second maps (a 4.6 asset) {:.4e}: {:+.1}% against the reference ({with} of {} VPLs have a second origin)",
            sg_rim,
            (sg_rim / sr - 1.0) * 100.0,
            asset.vpls.len()
        );
    }
}
