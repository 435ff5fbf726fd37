//! The bake of every light (issue 19, asset format 4): the bundled
//! multi-light room (`data/lamps.glb`: a spot, two point lamps) baked with
//! every light is deterministic, records each light's VPLs and views (a
//! point light's six cube faces), stores only the maps that hold a surface,
//! round-trips through the files and merges from shards byte for byte;
//! a point light first is baked with its six faces.
//!
//! Runs on the GPU (lavapipe in CI); without an adapter it fails with a
//! message saying what to install.

use std::path::{Path, PathBuf};

use gibake_asset::{Asset, LIGHT_POINT, NO_MAP};
use gibake_bake::cluster::ClusterTarget;
use gibake_bake::{BakeOptions, NoProgress, Shard, bake, bake_shard};
use gibake_gpu::GpuContext;
use gibake_scene::{LightKind, LoadOptions, Scene};

fn gpu() -> GpuContext {
    GpuContext::new(&Default::default()).unwrap_or_else(|e| {
        panic!(
            "the bake tests need a GPU adapter ({e}); on Debian/Ubuntu \
             `apt-get install mesa-vulkan-drivers` gives the lavapipe software GPU"
        )
    })
}

fn lamps() -> Scene {
    let path = Path::new(concat!(env!("CARGO_MANIFEST_DIR"), "/../../data/lamps.glb"));
    let opts = LoadOptions::default();
    gibake_scene::load(path, &opts).expect("data/lamps.glb")
}

fn options() -> BakeOptions {
    BakeOptions {
        rsm_size: 128,
        vpl_map_size: 32,
        shadow_map_size: 256,
        target: ClusterTarget::Count(96),
        // The first bounce alone (what this checks).
        bounces: gibake_bake::later::Bounces::Count(1),
        later_vpls: None,
    }
}

#[test]
fn a_bake_of_every_light_records_each_light_and_its_views() {
    let ctx = gpu();
    let scene = lamps();
    assert_eq!(scene.lights.len(), 3);
    let out = bake(&ctx, &scene, &options(), &NoProgress, "test").expect("bake");
    let a = &out.asset;
    let m = &a.manifest;
    // Every light, in the scene's order, each with its share of the VPLs.
    let names: Vec<&str> = m.lights.iter().map(|l| l.name.as_str()).collect();
    let scene_names: Vec<&str> = scene.lights.iter().map(|l| l.name.as_str()).collect();
    assert_eq!(names, scene_names);
    let sum: u32 = m.lights.iter().map(|l| l.vpls).sum();
    assert_eq!(sum as usize, a.vpls.len());
    assert!(
        m.lights.iter().all(|l| l.vpls > 0),
        "every lamp of this room bounces: {:?}",
        m.lights.iter().map(|l| l.vpls).collect::<Vec<_>>()
    );
    // The two point lamps' six faces each, in light order.
    let points = m.lights.iter().filter(|l| l.kind == LIGHT_POINT).count();
    assert_eq!(points, 2);
    assert_eq!(m.views.len(), 12);
    assert!(m.views[..6].iter().all(|v| v.light == 1));
    assert!(m.views[6..].iter().all(|v| v.light == 2));
    assert_eq!(m.light_map_size, 128, "half the primary map");
    // Only the maps that hold a surface are stored, numbered in view order;
    // a stored map holds finite texels (the room closes around the lamps).
    let stored: Vec<u32> = m
        .views
        .iter()
        .map(|v| v.tile)
        .filter(|&t| t != NO_MAP)
        .collect();
    assert_eq!(stored, (0..stored.len() as u32).collect::<Vec<_>>());
    assert_eq!(a.light_maps.count() as usize, stored.len());
    assert!(a.light_maps.texels().iter().any(|t| t.is_finite()));
    // Deterministic.
    let again = bake(&ctx, &scene, &options(), &NoProgress, "test").expect("bake");
    assert!(
        again.asset == out.asset,
        "same scene and settings, other asset"
    );
    // Through the files and back.
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path().join("lamps.gibake");
    gibake_asset::write(a, &dir).expect("write");
    assert!(dir.join(gibake_asset::FILE_LIGHT_MAPS).is_file());
    let loaded = gibake_asset::load(&dir).expect("load");
    assert_eq!(loaded.light_maps, a.light_maps);
    assert_eq!(loaded.manifest.views, m.views);
    assert_eq!(loaded.vpls, a.vpls);
}

#[test]
fn shards_of_a_bake_of_every_light_merge_into_the_same_asset() {
    let ctx = gpu();
    let scene = lamps();
    let whole = bake(&ctx, &scene, &options(), &NoProgress, "test")
        .expect("bake")
        .asset;
    let parts: Vec<(PathBuf, gibake_asset::ShardPart)> = (0..2)
        .map(|index| {
            let s = Shard { index, count: 2 };
            let out = bake_shard(&ctx, &scene, &options(), s, &NoProgress, "test").expect("shard");
            (PathBuf::from(format!("part{index}")), out.part)
        })
        .collect();
    let merged: Asset = gibake_asset::merge(parts).expect("merge");
    // Byte for byte once written (the counts are filled in by the write).
    let tmp = tempfile::tempdir().unwrap();
    let (a, b) = (
        tmp.path().join("whole.gibake"),
        tmp.path().join("merged.gibake"),
    );
    gibake_asset::write(&whole, &a).expect("write");
    gibake_asset::write(&merged, &b).expect("write");
    let mut names: Vec<_> = std::fs::read_dir(&a)
        .unwrap()
        .map(|e| e.unwrap().file_name())
        .collect();
    names.sort();
    assert!(names.iter().any(|n| n == gibake_asset::FILE_LIGHT_MAPS));
    for n in names {
        let (x, y) = (
            std::fs::read(a.join(&n)).unwrap(),
            std::fs::read(b.join(&n)),
        );
        assert!(y.is_ok_and(|y| y == x), "{n:?} differs");
    }
}

/// A point light first has no primary map: its six faces are views like
/// the other lights', it has VPLs of its own, and without a primary RSM
/// (has_dynamic false) the moving objects' bounce comes from the stored
/// RSMs of the faces they can enter (format 4.1): each of those views,
/// and only those, stores one, whose texels name only its own light's
/// VPLs; they survive write and load.
#[test]
fn a_point_light_first_is_baked_with_its_six_faces() {
    let ctx = gpu();
    let mut scene = lamps();
    scene.lights.retain(|l| l.kind == LightKind::Point);
    assert_eq!(scene.lights.len(), 2);
    assert!(!scene.dynamic_objects.is_empty());
    let out = bake(&ctx, &scene, &options(), &NoProgress, "test").expect("bake");
    let m = &out.asset.manifest;
    assert_eq!(m.views.len(), 12);
    assert!(m.views[..6].iter().all(|v| v.light == 0));
    assert!(m.views[6..].iter().all(|v| v.light == 1));
    assert!(m.lights[0].vpls > 0 && m.lights[1].vpls > 0);
    assert!(!m.has_dynamic && out.asset.rsm.is_none());
    assert!(out.warnings.is_empty(), "{:?}", out.warnings);
    // The faces the balls' swept bounds can enter, and only those.
    let swept = scene.dynamic_swept_bounds();
    let enterable: Vec<u32> = (0..m.views.len() as u32)
        .filter(|&v| {
            gibake_gpu::LightView::from_record(&m.views[v as usize].view, m.light_map_size)
                .may_see(&swept)
        })
        .collect();
    assert!(
        !enterable.is_empty() && enterable.len() < 12,
        "{enterable:?}"
    );
    assert_eq!(m.view_rsms, enterable);
    assert_eq!(out.asset.view_rsms.len(), enterable.len());
    let first_of = |l: usize| m.lights[..l].iter().map(|r| r.vpls).sum::<u32>();
    let mut named = 0;
    for (&v, r) in m.view_rsms.iter().zip(&out.asset.view_rsms) {
        let l = m.views[v as usize].light as usize;
        let own = first_of(l)..first_of(l) + m.lights[l].vpls;
        assert_eq!(r.size, options().rsm_size);
        for &t in &r.vpl {
            assert!(
                t == u32::MAX || own.contains(&t),
                "view {v}: VPL {t} not in {own:?}"
            );
            named += usize::from(t != u32::MAX);
        }
    }
    assert!(named > 0, "no stored texel belongs to a VPL");
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path().join("points.gibake");
    gibake_asset::write(&out.asset, &dir).expect("write");
    let loaded = gibake_asset::load(&dir).expect("load");
    assert_eq!(loaded.manifest.view_rsms, m.view_rsms);
    assert_eq!(loaded.view_rsms, out.asset.view_rsms);
}

/// A progress that gives the bake a memory budget.
struct Budget(u64);

impl gibake_bake::BakeProgress for Budget {
    fn begin(&self, _: &str, _: u64) {}
    fn advance(&self, _: u64) {}
    fn end(&self) {}
    fn memory_limit(&self) -> Option<u64> {
        Some(self.0)
    }
}

/// Every view's RSM is held at once: 64 point lamps (384 faces) beside a
/// spot. Each lamp's faces get RSM texels by their share of the bounce
/// (`lights::ViewPlan`), so at the default RSM of 512² their RSMs hold
/// under an eighth of the texels of 385 full-size ones (about 6 GiB).
/// Under a budget below even the fewest texels the plan
/// could have, the bake is refused before any RSM is made, with a message
/// naming the views and what to lower; under one between that and the
/// planned resolutions, it is refused once the plan is made, before the
/// full RSMs.
#[test]
fn many_lights_over_the_memory_budget_are_refused_before_their_rsms() {
    use gibake_bake::budget::{check_lights, estimate_lights};
    use gibake_bake::lights::ViewPlan;
    let ctx = gpu();
    let mut scene = lamps();
    let spot = scene.lights[0].clone();
    let lamp = scene.lights[1].clone();
    scene.lights = std::iter::once(spot)
        .chain((0..64).map(|k| gibake_scene::Light {
            name: format!("lamp {k}"),
            ..lamp.clone()
        }))
        .collect();
    // Static: views that moving objects can enter keep the full size.
    scene.dynamic_meshes.clear();
    scene.dynamic_objects.clear();
    let opts = BakeOptions {
        rsm_size: 512,
        ..options()
    };
    let least = ViewPlan::least_texels(&scene, 512, opts.shadow_map_size);
    assert_eq!(least, (385, 512 * 512 + 384 * 64 * 64));
    let t = std::time::Instant::now();
    match bake(&ctx, &scene, &opts, &Budget(64 << 20), "test") {
        Err(gibake_bake::BakeError::OverBudget(e)) => {
            let m = e.to_string();
            assert!(m.contains("385 RSM(s)") && m.contains("--rsm-size"), "{m}");
        }
        Err(e) => panic!("another error: {e}"),
        Ok(_) => panic!("64 lamps' RSMs were baked within 64 MiB"),
    }
    assert!(
        t.elapsed().as_secs() < 20,
        "refused only after {:?}",
        t.elapsed()
    );
    // The plan's own texels: more than the fewest, far fewer than 385
    // full-size RSMs.
    let rays = gibake_raycast::RayScene::build(&scene, 0.0);
    let reach = gibake_bake::reach::Reach::new(&rays, gibake_scene::Aabb::EMPTY);
    let planned = ViewPlan::new(&scene, &reach, 512, opts.shadow_map_size).texels();
    assert!(
        planned > least.1 && planned < 385 * 512 * 512 / 8,
        "planned {planned} texels"
    );
    let light_maps = {
        let n = gibake_gpu::passes::light_maps::view_count(&scene);
        let (size, _) = gibake_gpu::passes::light_maps::light_map_size(
            opts.shadow_map_size,
            n,
            ctx.device.limits().max_texture_dimension_2d,
        );
        n as u64 * u64::from(size) * u64::from(size)
    };
    let low = estimate_lights(&opts, least.1, light_maps).total();
    let high = estimate_lights(&opts, planned, light_maps).total();
    let between = low + (high - low) / 2;
    assert!(check_lights(&opts, least, light_maps, between).is_ok());
    match bake(&ctx, &scene, &opts, &Budget(between), "test") {
        Err(gibake_bake::BakeError::OverBudget(e)) => {
            let m = e.to_string();
            assert!(m.contains(&format!("{planned} texels in all")), "{m}");
        }
        Err(e) => panic!("another error: {e}"),
        Ok(_) => panic!("the planned RSMs were baked over the budget"),
    }
}

/// A sun whose view cuts a ground (the Blenvy level, its sun alone) is baked
/// with outer rings (format 4.3): the manifest names the ring VPLs (the
/// last of the light's), they lie outside the light view, and each stored
/// map is the one cast from one texel's radius above the VPL's position
/// (`hemisphere::record_origin`). The bake is deterministic.
#[test]
fn a_sun_over_a_cut_ground_is_baked_with_ring_vpls() {
    let ctx = gpu();
    let path = Path::new(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../../data/lights/blenvy_start_level/StartLevel.glb"
    ));
    let mut scene = gibake_scene::load(path, &LoadOptions::default()).expect("the Blenvy level");
    scene.lights.retain(|l| l.kind == LightKind::Directional);
    let opts = options();
    let a = bake(&ctx, &scene, &opts, &NoProgress, "test")
        .expect("bake")
        .asset;
    let m = &a.manifest;
    assert_eq!(m.lights.len(), 1);
    let ring = m.ring_vpls.first().copied().unwrap_or(0) as usize;
    assert!(
        ring > 0 && ring < a.vpls.len(),
        "{:?} of {}",
        m.ring_vpls,
        a.vpls.len()
    );
    let flags = m.ring_flags();
    assert_eq!(flags.iter().filter(|f| **f).count(), ring);
    assert!(flags[a.vpls.len() - ring..].iter().all(|f| *f));
    // Outside the light view's square; the others inside.
    let view = gibake_gpu::LightView::from_record(&m.light_view, opts.shadow_map_size);
    for (v, &f) in a.vpls.iter().zip(&flags) {
        let c = view
            .texel_coords(glam::Vec3::from_array(v.position))
            .expect("orthographic");
        let s = opts.shadow_map_size as f32;
        let inside = c.x >= 0.0 && c.y >= 0.0 && c.x < s && c.y < s;
        assert_eq!(inside, !f, "VPL at {:?}", v.position);
    }
    // A ring VPL's stored map is cast from one texel's radius up.
    let stat = gibake_bake::static_only(&scene);
    let rays = gibake_raycast::RayScene::build(&stat, 0.0);
    let last = a.vpls.len() - 1;
    let lone = gibake_bake::vplmap::render_each_vpl_map(
        &rays,
        &a.vpls[last..],
        &[true],
        opts.vpl_map_size,
        &|| {},
    );
    let stored = a.vpl_maps.map(a.vpls[last].map);
    assert!(stored.is_some(), "the last ring VPL stores a map");
    assert_eq!(lone[0], stored, "the ring VPL's map");
    let lifted = gibake_bake::vplmap::render_each_vpl_map(
        &rays,
        &a.vpls[last..],
        &[false],
        opts.vpl_map_size,
        &|| {},
    );
    assert_ne!(
        lifted[0], stored,
        "a ring VPL is not lifted by its whole radius"
    );
    // Deterministic.
    let again = bake(&ctx, &scene, &opts, &NoProgress, "test")
        .expect("bake")
        .asset;
    assert_eq!(again, a);
}
