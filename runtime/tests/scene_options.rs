//! A level baked with scene options (a sun added, a mesh marked moving):
//! `load_scene_for` loads it with the asset's recorded options, so the
//! renderer takes the asset; `load_scene` without them is another static
//! scene, refused with a message naming the options in plain words;
//! options given that differ from the asset's are an error; an asset that
//! records none leaves the caller's options as they are. No message quotes
//! a command line.

use gibake_bake::cluster::ClusterTarget;
use gibake_gpu::GpuContext;
use gibake_runtime::glam::Vec3;
use gibake_runtime::scene_options::scene_options_of;
use gibake_runtime::{LoadOptions, RenderSettings, Renderer, RuntimeError, SceneOption};
use gibake_scene::Sun;

fn level() -> std::path::PathBuf {
    std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../data/corner_bunny.glb")
}

#[test]
fn a_level_loads_with_the_options_its_asset_was_baked_with() {
    let ctx = GpuContext::new(&Default::default()).unwrap_or_else(|e| {
        panic!(
            "this test needs a GPU adapter ({e}); `apt-get install mesa-vulkan-drivers` gives \
             the lavapipe software GPU"
        )
    });
    let baked_with = LoadOptions {
        sun: Some(Sun {
            azimuth_deg: 200.0,
            elevation_deg: 50.0,
            irradiance: 2.0,
            color: Vec3::ONE,
        }),
        dynamic: vec!["bun*".into()],
        ..Default::default()
    };
    let scene = gibake_runtime::load_scene(&level(), &baked_with).expect("load the level");
    assert!(scene.dynamic_objects.iter().any(|o| o.name == "bunny"));
    let opts = gibake_bake::BakeOptions {
        rsm_size: 64,
        vpl_map_size: 8,
        shadow_map_size: 128,
        target: ClusterTarget::Count(16),
        // The first bounce alone (what this checks).
        bounces: gibake_bake::later::Bounces::Count(1),
        later_vpls: None,
    };
    let mut asset = gibake_bake::bake(&ctx, &scene, &opts, &gibake_bake::NoProgress, "test")
        .expect("bake")
        .asset;
    // What `gibake bake` records.
    asset.manifest.scene_options = Some(scene_options_of(&baked_with));
    let settings = RenderSettings {
        width: 8,
        height: 8,
        max_dynamic_vpls: 16,
        ..Default::default()
    };
    let (d, q) = (&ctx.device, &ctx.queue);

    // With the asset's options: the scene it was baked from.
    let (options, r) = gibake_runtime::load_options_for(&asset, &Default::default()).unwrap();
    assert_eq!(options.sun, baked_with.sun);
    assert_eq!(r.applied.dynamic, vec!["bun*"]);
    let loaded = gibake_runtime::load_scene_for(&level(), &asset, &Default::default())
        .expect("the level loads for its asset");
    assert_eq!(
        gibake_scene::static_scene_hash(&loaded),
        asset.manifest.static_scene_hash
    );
    Renderer::new(d, q, &loaded, Some(&asset), &settings).expect("the renderer takes the asset");
    // The same options given: the same.
    let same = gibake_runtime::load_scene_for(&level(), &asset, &baked_with).unwrap();
    assert_eq!(
        gibake_scene::static_scene_hash(&same),
        asset.manifest.static_scene_hash
    );

    // Without them: another static scene, the message names the options.
    let plain = gibake_runtime::load_scene(&level(), &Default::default()).unwrap();
    let e = Renderer::new(d, q, &plain, Some(&asset), &settings)
        .err()
        .expect("the level as exported taken for the asset baked with a sun");
    let msg = e.to_string();
    assert!(matches!(e, RuntimeError::Asset(_)), "{e:?}");
    assert!(
        msg.contains("it was baked with the scene options sun at azimuth 200°, elevation 50°")
            && msg.contains("moving objects 'bun*'")
            && !msg.contains("--"),
        "{msg}"
    );

    // Another sun given: refused before loading, naming what differs.
    let other = LoadOptions {
        sun: Some(Sun::new(10.0, 50.0)),
        ..Default::default()
    };
    let e = gibake_runtime::load_scene_for(&level(), &asset, &other).unwrap_err();
    let RuntimeError::SceneOptions(c) = &e else {
        panic!("{e:?}")
    };
    assert_eq!(c.differ, vec![SceneOption::Sun]);
    let msg = e.to_string();
    assert!(
        msg.contains("azimuth 10°") && msg.contains("azimuth 200°") && !msg.contains("--"),
        "{msg}"
    );

    // An asset that records none: the caller's options as they are.
    asset.manifest.scene_options = None;
    let (options, r) = gibake_runtime::load_options_for(&asset, &other).unwrap();
    assert_eq!(options.sun, other.sun);
    assert!(r.applied.is_empty());
    let e = gibake_runtime::load_scene_for(&level().with_file_name("nope.glb"), &asset, &other)
        .unwrap_err();
    assert!(matches!(e, RuntimeError::Scene(_)), "{e:?}");
}
