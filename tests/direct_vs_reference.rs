//! Issue 2's acceptance check: on every bundled scene at 256×256 and two
//! animation times, the GPU's direct light agrees with the CPU reference's
//! direct-only path tracing (256 spp): relative MSE ≤ 0.02.

use crate::common;

use gibake_scene::LoadOptions;

#[test]
fn gpu_direct_matches_reference_direct_on_bundled_scenes() {
    let ctx = common::gpu();
    let mut report = Vec::new();
    for name in ["corner_bunny.glb", "occluded.glb", "sun.glb"] {
        let scene = gibake_scene::load(&common::data(name), &LoadOptions::default()).unwrap();
        for time in [0.0f32, 1.3] {
            let settings = gibake_runtime::RenderSettings {
                width: 256,
                height: 256,
                shadow_map_size: 2048,
                mode: gibake_runtime::Mode::Direct,
                ..Default::default()
            };
            let gpu = gibake_eval::frame::render_image(
                &ctx.device,
                &ctx.queue,
                &scene,
                None,
                &settings,
                time,
                2,
            )
            .unwrap();
            let reference = gibake_reference::render(
                &scene,
                &gibake_reference::Settings {
                    width: 256,
                    height: 256,
                    spp: 256,
                    time,
                    depth: gibake_reference::Depth::Direct,
                    seed: 7,
                },
                &|_| {},
            )
            .unwrap();
            assert!(gpu.all_finite(), "{name} t={time}: non-finite pixels");
            let mean = reference.mean();
            assert!(
                mean.max_element() > 0.0,
                "{name} t={time}: the reference is black"
            );
            let e = gibake_image::rel_mse(&gpu, &reference);
            report.push(format!("{name} t={time}: rel MSE {e:.5}"));
            assert!(
                e <= 0.02,
                "{name} t={time}: rel MSE {e} > 0.02\n{}",
                report.join("\n")
            );
        }
    }
    eprintln!("{}", report.join("\n"));
}
