//! The up-to-date comparison (`gibake_bake::uptodate::differences`) against
//! a real bake's manifest: nothing differs for the same inputs, and each
//! changed input is named — including the two the static-scene hash leaves
//! out (the moving objects' presence and their swept bounds, recorded since
//! format 4.5, which shape the light view and the VPLs).

use std::path::Path;

use gibake_bake::cluster::ClusterTarget;
use gibake_bake::uptodate::{differences, swept_record};
use gibake_bake::{BakeOptions, NoProgress, bake, static_only};
use gibake_gpu::GpuContext;
use gibake_scene::LoadOptions;

#[test]
fn every_changed_input_is_named_and_nothing_else() {
    let ctx = GpuContext::new(&Default::default()).unwrap_or_else(|e| {
        panic!("needs a GPU adapter ({e}); `apt-get install mesa-vulkan-drivers` gives lavapipe")
    });
    let path = Path::new(concat!(env!("CARGO_MANIFEST_DIR"), "/../../data/sun.glb"));
    let scene = gibake_scene::load(path, &LoadOptions::default()).expect("data/sun.glb loads");
    assert!(
        !scene.dynamic_objects.is_empty(),
        "sun.glb has moving objects"
    );
    let opts = BakeOptions {
        rsm_size: 64,
        vpl_map_size: 16,
        shadow_map_size: 256,
        target: ClusterTarget::Count(32),
        // The first bounce alone (what this checks).
        bounces: gibake_bake::later::Bounces::Count(1),
        later_vpls: None,
    };
    let asset = bake(&ctx, &scene, &opts, &NoProgress, "1.0.0")
        .expect("bake")
        .asset;
    let m = &asset.manifest;
    let diff = |scene: &gibake_scene::Scene, opts: &BakeOptions, version: &str| {
        differences(m, scene, opts, &ctx.record, version)
    };
    assert_eq!(diff(&scene, &opts, "1.0.0"), Vec::<String>::new());

    let one = |r: Vec<String>, what: &str| {
        assert_eq!(r.len(), 1, "expected one reason ({what}), got {r:?}");
        assert!(r[0].contains(what), "expected `{what}` in {r:?}");
    };
    one(
        diff(&scene, &opts, "1.0.1"),
        "baker version changed (1.0.0 → 1.0.1)",
    );
    assert!(!diff(&scene, &opts, "1.0.1")[0].contains("method"));
    // The same release with a revised bake method (gibake_bake::BAKE_METHOD).
    one(
        diff(&scene, &opts, "1.0.0+bake.7"),
        "baker version changed (1.0.0 → 1.0.0+bake.7): the bake's method was revised",
    );
    for (o, what) in [
        (
            BakeOptions {
                rsm_size: 128,
                ..opts.clone()
            },
            "--rsm-size changed (64 → 128)",
        ),
        (
            BakeOptions {
                vpl_map_size: 8,
                ..opts.clone()
            },
            "--vpl-map-size changed (16 → 8)",
        ),
        (
            BakeOptions {
                shadow_map_size: 512,
                ..opts.clone()
            },
            "--shadow-map-size changed (256 → 512)",
        ),
        (
            BakeOptions {
                target: ClusterTarget::Count(33),
                ..opts.clone()
            },
            "--vpls changed (32 → 33)",
        ),
        (
            BakeOptions {
                target: ClusterTarget::Threshold(0.5),
                ..opts.clone()
            },
            "--vpls 32 → --threshold 0.5",
        ),
    ] {
        one(diff(&scene, &o, "1.0.0"), what);
    }
    let mut other = ctx.record.clone();
    other.name = "Some Other GPU".into();
    one(
        differences(m, &scene, &opts, &other, "1.0.0"),
        "adapter changed",
    );

    // A static vertex moved: the static-scene hash.
    let mut moved = scene.clone();
    moved.static_meshes[0].positions[0].x += 1e-3;
    one(
        diff(&moved, &opts, "1.0.0"),
        "scene changed (static-scene hash",
    );
    one(diff(&moved, &opts, "1.0.0"), "not the lights");

    // The light moved, or a light was added: said by name.
    let mut lit = scene.clone();
    lit.lights[0].position.y += 0.5;
    one(diff(&lit, &opts, "1.0.0"), "changed: position");
    let mut lamp = scene.clone();
    let mut extra = lamp.lights[0].clone();
    extra.name = "Extra lamp".into();
    extra.kind = gibake_scene::LightKind::Point;
    extra.range = Some(3.0);
    lamp.lights.push(extra);
    one(
        diff(&lamp, &opts, "1.0.0"),
        "light 'Extra lamp' (point) added",
    );

    // Moving objects' swept bounds grown: same static hash, other light view.
    let mut big = scene.clone();
    for mesh in &mut big.dynamic_meshes {
        for p in &mut mesh.positions {
            *p *= 40.0;
        }
    }
    for o in &mut big.dynamic_objects {
        o.local_bounds.min *= 40.0;
        o.local_bounds.max *= 40.0;
    }
    assert_eq!(
        gibake_scene::static_scene_hash(&big),
        m.static_scene_hash,
        "moving objects are not part of the static-scene hash"
    );
    one(
        diff(&big, &opts, "1.0.0"),
        "the moving objects' swept bounds changed",
    );
    // The light view is compared too (it follows the box: a manifest that
    // records the new box but the old view is named by its view).
    let mut m2 = m.clone();
    m2.swept_bounds = Some(swept_record(&big));
    one(
        differences(&m2, &big, &opts, &ctx.record, "1.0.0"),
        "the light's view changed",
    );
    // Objects half as tall: a smaller box, the same static hash.
    let mut lower = scene.clone();
    for o in &mut lower.dynamic_objects {
        o.local_bounds.max.y =
            o.local_bounds.min.y + 0.5 * (o.local_bounds.max.y - o.local_bounds.min.y);
    }
    assert_ne!(swept_record(&lower), swept_record(&scene));
    one(
        diff(&lower, &opts, "1.0.0"),
        "the moving objects' swept bounds changed",
    );
    // An asset from before format 4.5 does not record the box.
    let mut old = m.clone();
    old.swept_bounds = None;
    one(
        differences(&old, &scene, &opts, &ctx.record, "1.0.0"),
        "does not record the moving objects' swept bounds",
    );
    // ... which matters only with moving objects: a static level's
    // older asset is not re-baked for it.
    let still = static_only(&scene);
    let baked = bake(&ctx, &still, &opts, &NoProgress, "1.0.0")
        .expect("bake")
        .asset;
    let mut old = baked.manifest.clone();
    old.swept_bounds = None;
    assert_eq!(
        differences(&old, &still, &opts, &ctx.record, "1.0.0"),
        Vec::<String>::new()
    );

    // No moving objects any more: the box is empty, and the RSM goes.
    let r = diff(&static_only(&scene), &opts, "1.0.0");
    assert_eq!(r.len(), 2, "{r:?}");
    assert!(
        r[0].contains("swept bounds changed") && r[0].ends_with("→ none)"),
        "{r:?}"
    );
    assert!(r[1].contains("moving objects removed"), "{r:?}");
}

/// With several lights, which other lights' views the moving objects can
/// enter is an input too (their static RSMs are stored, format 4.1): the
/// same scene is up to date; moving objects whose paths now reach every
/// face of the lamps are named.
#[test]
fn the_views_moving_objects_can_enter_are_compared() {
    let ctx = GpuContext::new(&Default::default()).unwrap_or_else(|e| {
        panic!("needs a GPU adapter ({e}); `apt-get install mesa-vulkan-drivers` gives lavapipe")
    });
    let path = Path::new(concat!(env!("CARGO_MANIFEST_DIR"), "/../../data/lamps.glb"));
    let load = LoadOptions::default();
    let scene = gibake_scene::load(path, &load).expect("data/lamps.glb loads");
    assert!(scene.lights.len() > 1 && !scene.dynamic_objects.is_empty());
    let opts = BakeOptions {
        rsm_size: 64,
        vpl_map_size: 16,
        shadow_map_size: 256,
        target: ClusterTarget::Count(64),
        // The first bounce alone (what this checks).
        bounces: gibake_bake::later::Bounces::Count(1),
        later_vpls: None,
    };
    let asset = bake(&ctx, &scene, &opts, &NoProgress, "1.0.0")
        .expect("bake")
        .asset;
    let m = &asset.manifest;
    assert!(!m.view_rsms.is_empty() && m.view_rsms.len() < m.views.len());
    let diff = |scene: &gibake_scene::Scene| differences(m, scene, &opts, &ctx.record, "1.0.0");
    assert_eq!(diff(&scene), Vec::<String>::new());
    // Balls 40 times larger: their swept bounds enter every face.
    let mut big = scene.clone();
    for o in &mut big.dynamic_objects {
        o.local_bounds.min *= 40.0;
        o.local_bounds.max *= 40.0;
    }
    assert!(diff(&big)[0].contains("swept bounds changed"));
    // The views are compared too (they follow the box).
    let mut m2 = m.clone();
    m2.swept_bounds = Some(swept_record(&big));
    let r = differences(&m2, &big, &opts, &ctx.record, "1.0.0");
    assert!(
        r.iter()
            .any(|x| x.contains("views the moving objects can enter changed")),
        "{r:?}"
    );
    // Point lamps only (no primary map, so no primary RSM although
    // objects move): up to date, and removing the moving objects is named.
    let mut points = scene.clone();
    points
        .lights
        .retain(|l| l.kind == gibake_scene::LightKind::Point);
    let asset = bake(&ctx, &points, &opts, &NoProgress, "1.0.0")
        .expect("bake")
        .asset;
    let m = &asset.manifest;
    let diff = |scene: &gibake_scene::Scene| differences(m, scene, &opts, &ctx.record, "1.0.0");
    assert_eq!(diff(&points), Vec::<String>::new());
    let gone = static_only(&points);
    assert!(diff(&gone)[0].contains("swept bounds changed"));
    let mut m2 = m.clone();
    m2.swept_bounds = Some(swept_record(&gone));
    let r = differences(&m2, &gone, &opts, &ctx.record, "1.0.0");
    assert!(
        r.iter()
            .any(|x| x.contains("views the moving objects can enter changed")),
        "{r:?}"
    );
}
