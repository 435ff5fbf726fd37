//! Acceptance tests of the bake (issue 3): hemisphere-map visibility against
//! CPU ray casts, flux conservation and closed forms, scale invariance, the
//! WGSL primary projection against its CPU twin, determinism and what is
//! (not) stored.
//!
//! Every test runs on the GPU (lavapipe in CI); without an adapter it fails
//! with a message saying what to install.

use std::path::Path;
use std::sync::OnceLock;

use gibake_asset::{Asset, NO_MAP};
use gibake_bake::cluster::{ClusterTarget, cluster};
use gibake_bake::reach::Reach;
use gibake_bake::rsm::render_rsm;
use gibake_bake::{BakeOptions, NoProgress, bake, static_only};
use gibake_gpu::{GpuContext, LightView, hemisphere};
use gibake_raycast::RayScene;
use gibake_reference::View;
use gibake_scene::{LoadOptions, Scene};
use gibake_scenegen::geom::quad_facing;
use gibake_scenegen::gltf::Builder;
use glam::{DVec3, Vec3};

/// The bundled scenes, by file name.
const SCENES: [&str; 3] = ["corner_bunny", "occluded", "sun"];

/// The shared GPU context (one device for every test of this file).
fn gpu() -> &'static GpuContext {
    static CTX: OnceLock<GpuContext> = OnceLock::new();
    CTX.get_or_init(|| {
        GpuContext::new(&Default::default()).unwrap_or_else(|e| {
            panic!(
                "the bake tests need a GPU adapter ({e}); on Debian/Ubuntu \
                 `apt-get install mesa-vulkan-drivers` gives the lavapipe software GPU"
            )
        })
    })
}

/// A bundled scene from `data/NAME.glb`.
fn load_bundled(name: &str) -> Scene {
    let path =
        Path::new(concat!(env!("CARGO_MANIFEST_DIR"), "/../../data")).join(format!("{name}.glb"));
    gibake_scene::load(&path, &LoadOptions::default())
        .unwrap_or_else(|e| panic!("load {}: {e}", path.display()))
}

/// A scene from GLB bytes held in memory.
fn load_bytes(bytes: &[u8], name: &str) -> Scene {
    gibake_scene::load_from_slice(bytes, Path::new(name), &Default::default())
        .unwrap_or_else(|e| panic!("load {name}: {e}"))
}

fn run_bake(scene: &Scene, opts: &BakeOptions) -> Asset {
    bake(gpu(), scene, opts, &NoProgress, "test")
        .unwrap_or_else(|e| panic!("bake of {}: {e}", scene.source.display()))
        .asset
}

/// The modest settings most tests bake with.
fn small_options() -> BakeOptions {
    BakeOptions {
        rsm_size: 256,
        vpl_map_size: 64,
        shadow_map_size: 256,
        target: ClusterTarget::Count(128),
        // The first bounce alone (what this checks).
        bounces: gibake_bake::later::Bounces::Count(1),
        later_vpls: None,
    }
}

/// Each bundled scene baked once with [`small_options`], shared by the tests.
fn small_bake(name: &str) -> &'static (Scene, Asset) {
    static BAKES: [OnceLock<(Scene, Asset)>; 3] =
        [OnceLock::new(), OnceLock::new(), OnceLock::new()];
    let i = SCENES
        .iter()
        .position(|s| *s == name)
        .expect("a bundled scene");
    BAKES[i].get_or_init(|| {
        let scene = load_bundled(name);
        let asset = run_bake(&scene, &small_options());
        (scene, asset)
    })
}

/// SplitMix64: a tiny deterministic generator.
struct Rng(u64);

impl Rng {
    fn next_u64(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }

    /// Uniform in `[0, 1)`.
    fn uniform(&mut self) -> f32 {
        (self.next_u64() >> 40) as f32 / (1u64 << 24) as f32
    }

    fn below(&mut self, n: usize) -> usize {
        (self.next_u64() % n as u64) as usize
    }
}

/// Sum of the flux channels, in `f64`.
fn flux_sum(f: [f32; 3]) -> f64 {
    f.iter().map(|&c| f64::from(c)).sum()
}

// ---------------------------------------------------------------------------
// 1. Visibility agreement
// ---------------------------------------------------------------------------

/// Outcome of the map-vs-ray comparison on one scene.
#[derive(Debug, Default)]
struct Agreement {
    drawn: usize,
    behind: usize,
    edge: usize,
    used: usize,
    agree: usize,
    /// Map says occluded, rays say visible.
    false_occluded: usize,
    /// Map says visible, rays say occluded.
    false_visible: usize,
    /// Used pairs the rays find occluded.
    occluded: usize,
    /// Used pairs whose VPL has no stored map.
    no_map: usize,
}

/// The stored distance at texel `(x, y)` of a `size²` map, `None` outside it.
fn texel(map: &[f32], size: u32, x: i64, y: i64) -> Option<f32> {
    let s = i64::from(size);
    ((0..s).contains(&x) && (0..s).contains(&y)).then(|| map[(y * s + x) as usize])
}

/// Over the `(2r+1)²` texels around `(x, y)` inside the map: `(min, max)` of
/// the finite distances and whether any is infinite.
fn neighbourhood(map: &[f32], size: u32, x: i64, y: i64, r: i64) -> (f32, f32, bool) {
    let (mut lo, mut hi, mut inf) = (f32::INFINITY, 0.0f32, false);
    for dy in -r..=r {
        for dx in -r..=r {
            if let Some(v) = texel(map, size, x + dx, y + dy) {
                if v.is_finite() {
                    lo = lo.min(v);
                    hi = hi.max(v);
                } else {
                    inf = true;
                }
            }
        }
    }
    (lo, hi, inf)
}

fn visibility_agreement(name: &str) -> Agreement {
    let (scene, asset) = small_bake(name);
    let stat = static_only(scene);
    let rays = RayScene::build(&stat, 0.0);
    let camera = View::from_scene(scene, 0.0).expect("bundled scenes have a camera");
    let size = asset.manifest.settings.vpl_map_size;
    let mut rng = Rng(0x5EED_0000 + name.len() as u64);
    let mut out = Agreement::default();
    while out.used < 2000 && out.drawn < 100_000 {
        // A static surface point seen by the camera.
        let (o, d, t_min) =
            camera.primary_ray(640, 480, rng.uniform() * 640.0, rng.uniform() * 480.0);
        let Some(hit) = rays.intersect_range(o, d, t_min, f32::INFINITY) else {
            continue;
        };
        let (x, nx) = (hit.position, hit.geometric_normal);
        let i = rng.below(asset.vpls.len());
        out.drawn += 1;
        let v = &asset.vpls[i];
        let n = Vec3::from_array(v.normal);
        let origin = hemisphere::vpl_origin(Vec3::from_array(v.position), n, v.area);
        let to_x = x - origin;
        if n.dot(to_x) <= 0.0 {
            out.behind += 1;
            continue;
        }
        let dist = to_x.length();
        let map_visible = match asset.vpl_map_of(i) {
            None => {
                out.no_map += 1;
                true
            }
            Some(map) => {
                let c = hemisphere::texel_coords(n, to_x / dist, size);
                let tx = (c.x.floor() as i64).clamp(0, i64::from(size) - 1);
                let ty = (c.y.floor() as i64).clamp(0, i64::from(size) - 1);
                let (lo, hi, inf) = neighbourhood(&map, size, tx, ty, 2);
                let any_finite = lo.is_finite();
                if any_finite && (inf || hi > lo * 1.1) {
                    out.edge += 1;
                    continue;
                }
                let stored = texel(&map, size, tx, ty).expect("in the map");
                // Slope-scaled bias measured from the map: half the spread
                // of the 3×3 texels around the lookup (a planar receiver
                // changes its distance by at most that much between the
                // texel centre and any point of the texel), plus 1e-3 of
                // the distance.
                let (lo3, hi3, _) = neighbourhood(&map, size, tx, ty, 1);
                let spread = if lo3.is_finite() { hi3 - lo3 } else { 0.0 };
                dist <= stored * (1.0 + 1e-3) + 0.5 * spread + 1e-3 * dist
            }
        };
        let ray_visible = rays.visible(origin, n, x, nx);
        out.used += 1;
        out.occluded += usize::from(!ray_visible);
        if map_visible == ray_visible {
            out.agree += 1;
        } else if ray_visible {
            out.false_occluded += 1;
        } else {
            out.false_visible += 1;
        }
    }
    out
}

#[test]
fn hemisphere_maps_agree_with_cpu_ray_casts() {
    for name in SCENES {
        let a = visibility_agreement(name);
        let pct = 100.0 * a.agree as f64 / a.used.max(1) as f64;
        println!(
            "visibility {name}: {} pairs drawn, {} behind the VPL, {} at depth edges, {} used \
             ({} occluded, {} with no stored map); agreement {pct:.2}% ({} map-occluded/ray-visible, \
             {} map-visible/ray-occluded)",
            a.drawn,
            a.behind,
            a.edge,
            a.used,
            a.occluded,
            a.no_map,
            a.false_occluded,
            a.false_visible
        );
        assert!(a.used >= 500, "{name}: only {} usable pairs: {a:?}", a.used);
        assert!(pct >= 99.0, "{name}: agreement {pct:.2}% < 99%: {a:?}");
        // The comparison must see both verdicts to mean anything.
        assert!(
            a.occluded >= a.used / 20 && a.occluded < a.used,
            "{name}: {} of {} used pairs occluded",
            a.occluded,
            a.used
        );
    }
}

// ---------------------------------------------------------------------------
// 2. Flux
// ---------------------------------------------------------------------------

#[test]
fn vpl_flux_sums_to_the_rsm_reflected_power() {
    for name in SCENES {
        let (scene, asset) = small_bake(name);
        let opts = small_options();
        let stat = static_only(scene);
        let rays = RayScene::build(&stat, 0.0);
        let view = LightView::for_scene(scene, opts.shadow_map_size).resized(opts.rsm_size);
        let reach = Reach::new(&rays, scene.dynamic_swept_bounds());
        let rsm = render_rsm(&rays, scene.light(), &view, Some(&reach));
        let texel_total: f64 = rsm.flux.iter().map(|f| flux_sum(f.to_array())).sum();
        assert!(texel_total > 0.0, "{name}: the RSM reflects nothing");

        // As the bake clusters: a budget counts the VPLs it keeps.
        let keep = |_: usize,
                    _: &gibake_bake::rsm::Rsm,
                    _: &[usize],
                    c: &gibake_bake::cluster::Cluster,
                    reaching: f64| reach.keeps(c, reaching, false);
        let mut clusters = gibake_bake::cluster::cluster_keeping(&rsm, opts.target, &keep);
        let cluster_total: f64 = clusters
            .vpls
            .iter()
            .map(|c| flux_sum(c.flux.to_array()))
            .sum();
        // The bake drops the VPLs whose light reaches nothing: the asset
        // carries the flux of the others.
        let reaching = clusters.reaching_flux(&rsm);
        clusters.retain(|i, c| reach.keeps(c, reaching[i], false));
        let kept_total: f64 = clusters
            .vpls
            .iter()
            .map(|c| flux_sum(c.flux.to_array()))
            .sum();
        let asset_total: f64 = asset.vpls.iter().map(|v| flux_sum(v.flux)).sum();
        let e_cluster = (cluster_total - texel_total).abs() / texel_total;
        let e_asset = (asset_total - kept_total).abs() / kept_total;
        println!(
            "flux {name}: RSM {texel_total:.6e} W, {} clusters {cluster_total:.6e} W (rel err {e_cluster:.2e}), \
             asset {} VPLs {asset_total:.6e} W (rel err {e_asset:.2e})",
            clusters.vpls.len(),
            asset.vpls.len()
        );
        assert!(
            e_cluster <= 1e-4,
            "{name}: cluster flux off by {e_cluster:.2e}"
        );
        assert!(
            e_asset <= 1e-4,
            "{name}: asset VPL flux off by {e_asset:.2e} from the kept clusters'"
        );

        // The RSM stored for the dynamic merge: each texel's share of its
        // VPL's flux, in proportion to the light it reflects, adding up to
        // the whole VPL.
        let stored = asset
            .rsm
            .as_ref()
            .expect("bundled scenes have moving objects");
        // Every texel belongs to the VPL the clustering gave it (none if that
        // VPL was dropped) and holds its share of that VPL's flux.
        let one = f64::from(gibake_asset::SHARE_ONE);
        let mut sums = vec![0u64; asset.vpls.len()];
        let mut per_vpl = vec![0.0f64; asset.vpls.len()];
        for (t, (&vpl, &share)) in stored.vpl.iter().zip(&stored.share).enumerate() {
            let want = clusters.texel_vpl[t];
            let want = if want == gibake_bake::cluster::NO_VPL {
                u32::MAX
            } else {
                want
            };
            assert_eq!(
                vpl, want,
                "{name}: RSM texel {t} maps to VPL {vpl}, the clustering said {want}"
            );
            let f = flux_sum(rsm.flux[t].to_array());
            let Some(v) = asset.vpls.get(vpl as usize) else {
                assert_eq!(share, 0, "{name}: texel {t} of no VPL has a share");
                continue;
            };
            sums[vpl as usize] += u64::from(share);
            per_vpl[vpl as usize] += f;
            let expected = f / flux_sum(v.flux);
            assert!(
                (f64::from(share) / one - expected).abs() <= 1e-4 * expected + 1e-6,
                "{name}: texel {t}'s share {share} of VPL {vpl}, expected {expected:.6}"
            );
        }
        for (i, (sum, v)) in sums.iter().zip(&asset.vpls).enumerate() {
            let slack = u64::from(v.texels) / 2 + 1;
            assert!(
                sum.abs_diff(u64::from(gibake_asset::SHARE_ONE)) <= slack,
                "{name}: VPL {i}'s texel shares add up to {sum}"
            );
        }
        for (i, v) in asset.vpls.iter().enumerate() {
            let e = (per_vpl[i] - flux_sum(v.flux)).abs() / flux_sum(v.flux).max(1e-30);
            assert!(
                e <= 1e-4,
                "{name}: VPL {i}'s texels carry {} W, the VPL {}",
                per_vpl[i],
                flux_sum(v.flux)
            );
        }
    }
}

/// A 10 m × 10 m plane at y = 0 (normal +y) with albedo `albedo`, lit by
/// `light`, seen by a camera.
fn plane_scene(albedo: f32, light: impl FnOnce(&mut Builder)) -> Scene {
    let mut b = Builder::new(1.0, "none");
    let g = quad_facing(
        DVec3::new(-5.0, 0.0, -5.0),
        DVec3::new(10.0, 0.0, 0.0),
        DVec3::new(0.0, 0.0, 10.0),
        1,
        DVec3::Y,
    );
    b.static_mesh("plane", &g, [albedo; 3]);
    light(&mut b);
    b.perspective(
        "camera",
        DVec3::new(0.0, 8.0, 12.0),
        DVec3::ZERO,
        0.8,
        0.1,
        100.0,
    );
    let scene = load_bytes(&b.finish(), "plane.glb");
    assert!(scene.dynamic_objects.is_empty());
    scene
}

/// Total flux per channel (f64) of the VPLs the clustering makes, before the
/// bake drops those whose light reaches nothing (the bake's front part).
fn total_cluster_flux(scene: &Scene, opts: &BakeOptions) -> DVec3 {
    let stat = static_only(scene);
    let rays = RayScene::build(&stat, 0.0);
    let view = LightView::for_scene(scene, opts.shadow_map_size).resized(opts.rsm_size);
    let rsm = render_rsm(&rays, scene.light(), &view, None);
    cluster(&rsm, opts.target)
        .vpls
        .iter()
        .map(|c| c.flux.as_dvec3())
        .sum()
}

/// A single plane bounces its light into the sky: the bake drops every VPL
/// (their hemispheres see nothing), stores no map and nothing for the
/// dynamic merge.
fn assert_plane_stores_nothing(asset: &Asset, what: &str) {
    assert!(
        asset.vpls.is_empty(),
        "{what}: {} VPLs kept, but a lone plane's bounce reaches nothing",
        asset.vpls.len()
    );
    assert!(!asset.manifest.has_dynamic && asset.rsm.is_none(), "{what}");
    assert_eq!(
        asset.manifest.map_count, 0,
        "{what}: a lone plane occludes nothing"
    );
    assert!(asset.vpl_maps.is_empty(), "{what}");
    assert!(asset.vpls.iter().all(|v| v.map == NO_MAP), "{what}");
}

#[test]
fn directional_light_on_a_plane_reflects_a_e_a_cos() {
    let (a, e) = (0.6f32, 3.0f64);
    let theta = 30f64.to_radians();
    let scene = plane_scene(a, |b| {
        b.directional(
            "sun",
            DVec3::new(0.0, 10.0, 0.0),
            DVec3::new(theta.sin(), -theta.cos(), 0.0),
            [1.0; 3],
            e,
        )
    });
    let asset = run_bake(&scene, &small_options());
    let expected = f64::from(a) * e * 100.0 * theta.cos();
    let got = total_cluster_flux(&scene, &small_options());
    for c in 0..3 {
        let err = (got[c] - expected).abs() / expected;
        if c == 0 {
            println!(
                "flux directional plane: {} VPLs kept, {:.4} W per channel, expected a·E·A·cos30° = {expected:.4} W, \
                 rel err {err:.2e}",
                asset.vpls.len(),
                got[c]
            );
        }
        assert!(err <= 0.01, "channel {c}: {} W vs {expected} W", got[c]);
    }
    assert_plane_stores_nothing(&asset, "directional plane");
}

#[test]
fn spot_light_on_a_plane_reflects_a_i_times_the_cone() {
    let (a, intensity, h) = (0.6f32, 10.0f64, 3.0f64);
    let (inner, outer) = (29.9f64.to_radians(), 30f64.to_radians());
    let scene = plane_scene(a, |b| {
        b.spot(
            "spot",
            DVec3::new(0.0, h, 0.0),
            DVec3::NEG_Y,
            [1.0; 3],
            intensity,
            inner,
            outer,
        )
    });
    // The cone's footprint (radius h·tan 30° ≈ 1.7 m) lies inside the plane.
    assert!(h * outer.tan() < 5.0);
    let asset = run_bake(&scene, &small_options());

    // ∫ att(ω) dω over the cone, glTF falloff as the scene implements it.
    let light = scene.light();
    let steps = 200_000;
    let d_theta = (outer * 1.001) / f64::from(steps);
    let solid: f64 = (0..steps)
        .map(|k| {
            let t = (f64::from(k) + 0.5) * d_theta;
            let dir = Vec3::new(t.sin() as f32, -(t.cos() as f32), 0.0);
            f64::from(light.spot_attenuation(dir)) * 2.0 * std::f64::consts::PI * t.sin() * d_theta
        })
        .sum();
    let cone = 2.0 * std::f64::consts::PI * (1.0 - outer.cos());
    let expected = f64::from(a) * intensity * solid;
    let got = total_cluster_flux(&scene, &small_options());
    for c in 0..3 {
        let err = (got[c] - expected).abs() / expected;
        if c == 0 {
            println!(
                "flux spot plane: {} VPLs kept, {:.5} W per channel, expected a·I·∫att dω = {expected:.5} W \
                 (∫att dω = {solid:.5} sr, hard cone {cone:.5} sr), rel err {err:.2e}",
                asset.vpls.len(),
                got[c]
            );
        }
        assert!(err <= 0.02, "channel {c}: {} W vs {expected} W", got[c]);
    }
    assert_plane_stores_nothing(&asset, "spot plane");
}

// ---------------------------------------------------------------------------
// 3. Scale invariance
// ---------------------------------------------------------------------------

#[test]
fn scaled_scenes_give_the_same_vpls() {
    let opts = |target| BakeOptions {
        rsm_size: 256,
        vpl_map_size: 64,
        shadow_map_size: 256,
        target,
        // The first bounce alone (what this checks).
        bounces: gibake_bake::later::Bounces::Count(1),
        later_vpls: None,
    };
    let unit = load_bytes(
        &gibake_scenegen::scaled("corner_bunny", 1.0).expect("corner_bunny"),
        "corner_bunny.glb",
    );
    let budget = run_bake(&unit, &opts(ClusterTarget::Count(250)));
    let t = budget.manifest.settings.threshold;
    let reference = run_bake(&unit, &opts(ClusterTarget::Threshold(t)));
    println!(
        "scale: Count(250) gave {} VPLs, threshold {t:e}; Threshold({t:e}) gives {} VPLs, {} maps",
        budget.vpls.len(),
        reference.vpls.len(),
        reference.manifest.map_count
    );
    assert!(
        budget.vpls.len().abs_diff(250) <= 5,
        "Count(250) gave {}",
        budget.vpls.len()
    );
    let diag = unit.static_bounds().diagonal();
    for s in [1e-3f32, 1e3] {
        let scene = load_bytes(
            &gibake_scenegen::scaled("corner_bunny", s).expect("corner_bunny"),
            "corner_bunny.glb",
        );
        let asset = run_bake(&scene, &opts(ClusterTarget::Threshold(t)));
        assert_eq!(
            asset.vpls.len(),
            reference.vpls.len(),
            "scale {s}: VPL count differs"
        );
        assert_eq!(
            asset.manifest.map_count, reference.manifest.map_count,
            "scale {s}: stored map count differs"
        );
        let (mut dp, mut dn, mut df) = (0.0f32, 0.0f32, 0.0f64);
        for (i, (v, r)) in asset.vpls.iter().zip(&reference.vpls).enumerate() {
            let p = Vec3::from_array(v.position) / s;
            let e = (p - Vec3::from_array(r.position)).length() / diag;
            dp = dp.max(e);
            assert!(
                e <= 1e-4,
                "scale {s}: VPL {i} position {p} vs {:?}",
                r.position
            );
            let e = (Vec3::from_array(v.normal) - Vec3::from_array(r.normal)).length();
            dn = dn.max(e);
            assert!(
                e <= 1e-4,
                "scale {s}: VPL {i} normal {:?} vs {:?}",
                v.normal,
                r.normal
            );
            assert_eq!(
                v.map == NO_MAP,
                r.map == NO_MAP,
                "scale {s}: VPL {i} map stored differs"
            );
            // Spot intensity scales by s², so flux does too.
            let f = flux_sum(v.flux) / f64::from(s) / f64::from(s);
            let e = (f - flux_sum(r.flux)).abs() / flux_sum(r.flux);
            df = df.max(e);
            assert!(
                e <= 1e-3,
                "scale {s}: VPL {i} flux/s² {f} vs {}",
                flux_sum(r.flux)
            );
        }
        println!(
            "scale {s:e}: {} VPLs, {} maps; max position error {dp:.2e} of the diagonal, max normal error {dn:.2e}, \
             max flux/s² error {df:.2e}",
            asset.vpls.len(),
            asset.manifest.map_count
        );
    }
}

// ---------------------------------------------------------------------------
// 4. Projection twin: GPU primary map vs CPU rays
// ---------------------------------------------------------------------------

#[test]
fn gpu_primary_map_matches_cpu_rays() {
    for name in SCENES {
        let (scene, asset) = small_bake(name);
        let size = small_options().shadow_map_size;
        assert_eq!(asset.primary_depth.size, size);
        let view = LightView::for_scene(scene, size);
        let stat = static_only(scene);
        let rays = RayScene::build(&stat, 0.0);
        let (mut hits, mut hit_ok, mut misses, mut miss_ok) = (0usize, 0usize, 0usize, 0usize);
        let mut worst = 0.0f32;
        for y in 0..size {
            for x in 0..size {
                let gpu_v = asset.primary_depth.data[(y * size + x) as usize];
                let (o, d) = view.texel_ray(x, y);
                match rays.intersect(o, d, f32::INFINITY) {
                    Some(h) => {
                        hits += 1;
                        let m = view.metric(h.position);
                        let e = (gpu_v - m).abs() / m.abs().max(f32::MIN_POSITIVE);
                        if e <= 1e-4 {
                            hit_ok += 1;
                            worst = worst.max(e);
                        }
                    }
                    None => {
                        misses += 1;
                        if gpu_v == f32::INFINITY {
                            miss_ok += 1;
                        }
                    }
                }
            }
        }
        let hit_pct = 100.0 * hit_ok as f64 / hits.max(1) as f64;
        let miss_pct = 100.0 * miss_ok as f64 / misses.max(1) as f64;
        println!(
            "projection twin {name}: {hits} hit texels, {hit_pct:.2}% within 1e-4 (largest error among them {worst:.1e}); \
             {misses} misses, {miss_pct:.2}% +inf on the GPU"
        );
        assert!(hits > 0, "{name}: the light sees nothing");
        assert!(hit_pct >= 99.0, "{name}: {hit_pct:.2}% of hit texels agree");
        if misses > 0 {
            assert!(
                miss_pct >= 99.0,
                "{name}: {miss_pct:.2}% of missed texels are +inf"
            );
        }
    }
}

// ---------------------------------------------------------------------------
// 5. Determinism, zero flux, what is not stored
// ---------------------------------------------------------------------------

/// Whether any texel ray of VPL `v`'s hemisphere map hits static geometry
/// (as the bake casts them).
fn hemisphere_sees_something(rays: &RayScene<'_>, v: &gibake_asset::VplRecord, size: u32) -> bool {
    let n = Vec3::from_array(v.normal);
    let origin = rays.offset_point(
        hemisphere::vpl_origin(Vec3::from_array(v.position), n, v.area),
        n,
    );
    (0..size).any(|y| {
        (0..size).any(|x| {
            rays.intersect(
                origin,
                hemisphere::texel_direction(n, x, y, size),
                f32::INFINITY,
            )
            .is_some()
        })
    })
}

#[test]
fn bake_is_deterministic_and_stores_only_what_is_needed() {
    let scene = load_bundled("sun");
    let opts = small_options();
    let a = run_bake(&scene, &opts);
    // Again, on one thread: no order-dependent reduction may change a bit.
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(1)
        .build()
        .expect("thread pool");
    let b = pool.install(|| run_bake(&scene, &opts));
    assert!(a == b, "two bakes of sun differ");
    // And the files written are byte-identical.
    let root = Path::new(env!("CARGO_TARGET_TMPDIR")).join("bake_determinism");
    let _ = std::fs::remove_dir_all(&root);
    std::fs::create_dir_all(&root).expect("temporary directory");
    let files = |asset: &Asset, dir: &str| {
        let dir = root.join(dir);
        gibake_asset::write(asset, &dir).expect("write asset");
        let mut entries: Vec<(String, Vec<u8>)> = std::fs::read_dir(&dir)
            .expect("asset directory")
            .map(|e| {
                let e = e.expect("entry");
                let name = e.file_name().to_string_lossy().into_owned();
                (name, std::fs::read(e.path()).expect("read"))
            })
            .collect();
        entries.sort();
        entries
    };
    let (fa, fb) = (files(&a, "a.gibake"), files(&b, "b.gibake"));
    assert!(
        fa.len() >= 4,
        "asset files: {:?}",
        fa.iter().map(|f| &f.0).collect::<Vec<_>>()
    );
    assert!(fa == fb, "two bakes of sun write different files");
    let _ = std::fs::remove_dir_all(&root);
    assert!(a.manifest.has_dynamic && a.rsm.is_some());

    for (name, asset) in [("sun", &a), ("corner_bunny", &small_bake("corner_bunny").1)] {
        for (i, v) in asset.vpls.iter().enumerate() {
            assert!(
                flux_sum(v.flux) > 0.0,
                "{name}: VPL {i} has zero flux: {v:?}"
            );
            assert!(v.texels > 0 && v.area > 0.0, "{name}: VPL {i}: {v:?}");
        }
    }

    // Without the moving objects: nothing for the dynamic merge.
    let stat = static_only(&scene);
    let s = run_bake(&stat, &opts);
    assert!(
        !s.manifest.has_dynamic,
        "static-only bake claims moving objects"
    );
    assert!(s.rsm.is_none(), "static-only bake stores an RSM");
    let size = s.manifest.settings.vpl_map_size;
    let texels = (size * size) as usize;
    assert_eq!(s.manifest.vpl_count as usize, s.vpls.len());
    assert_eq!(s.stored_map_count(), s.manifest.map_count as usize);
    assert_eq!(s.vpl_maps.count(), s.manifest.map_count);
    assert_eq!(s.vpl_maps.tile_size(), size);
    assert!(s.vpl_maps.maps().all(|m| m.len() == texels));
    // Map layers are used once each, in order.
    let layers: Vec<u32> = s
        .vpls
        .iter()
        .map(|v| v.map)
        .filter(|&m| m != NO_MAP)
        .collect();
    assert_eq!(layers, (0..s.manifest.map_count).collect::<Vec<_>>());
    for layer in 0..s.manifest.map_count {
        let map = s.vpl_map(layer).expect("stored layer");
        assert!(
            map.iter().any(|d| d.is_finite()),
            "stored map {layer} sees nothing: it should not be stored"
        );
    }
    // And a VPL without a map really sees nothing.
    let rays = RayScene::build(&stat, 0.0);
    let unstored: Vec<usize> = (0..s.vpls.len())
        .filter(|&i| s.vpls[i].map == NO_MAP)
        .collect();
    for &i in &unstored {
        assert!(
            !hemisphere_sees_something(&rays, &s.vpls[i], size),
            "VPL {i} has no map but its hemisphere sees static geometry"
        );
    }
    println!(
        "determinism sun: {} VPLs equal on 1 thread and many; static-only: {} VPLs, {} maps stored, {} VPLs see nothing",
        a.vpls.len(),
        s.vpls.len(),
        s.manifest.map_count,
        unstored.len()
    );
}

// ---------------------------------------------------------------------------
// 6. The paper's 664 VPLs at default sizes
// ---------------------------------------------------------------------------

#[test]
fn bake_of_664_vpls_at_default_sizes() {
    let scene = load_bundled("corner_bunny");
    let opts = BakeOptions {
        target: ClusterTarget::Count(664),
        ..BakeOptions::default()
    };
    assert_eq!(
        (opts.rsm_size, opts.vpl_map_size, opts.shadow_map_size),
        (512, 128, 2048)
    );
    let out = bake(gpu(), &scene, &opts, &NoProgress, "test").expect("bake");
    // The budget is the first bounce's; the later bounces' VPLs (a quarter
    // of it by default) come after them.
    let later = out.asset.manifest.later_vpls() as usize;
    assert!(
        later <= 166,
        "{later} later VPLs: over the default budget, a quarter of 664"
    );
    let n = out.asset.vpls.len() - later;
    let stages: Vec<String> = out
        .stages
        .iter()
        .map(|s| format!("{} {:.2}s", s.stage, s.seconds))
        .collect();
    println!(
        "664: {n} VPLs, {} maps, threshold {:e}; {}",
        out.asset.manifest.map_count,
        out.asset.manifest.settings.threshold,
        stages.join(", ")
    );
    assert!(
        n.abs_diff(664) as f64 <= 0.02 * 664.0,
        "Count(664) gave {n} VPLs"
    );
    assert_eq!(out.asset.manifest.vpl_count as usize, n + later);
    assert_eq!(out.asset.vpl_maps.count(), out.asset.manifest.map_count);
    assert_eq!(out.asset.vpl_maps.tile_size(), 128);
}
