//! Stiff and extreme scenes (issue 11, item 4), every render mode, against
//! `gibake reference`. Each scene is built here with the scenegen glTF
//! writer, baked and rendered through the `gibake` binary at small sizes
//! (48 × 48, 64 VPLs, small maps) so the whole file runs in well under two
//! minutes on lavapipe.
//!
//! Every output of every mode must be finite. Where a reference exists, the
//! relative MSE of `full` against the one-bounce reference (and of `direct`
//! against the direct-only reference) must stay under the case's bound; the
//! bounds and the values measured when they were set are in
//! docs/robustness.md ("Stiff cases").
//!
//! Every scene carries one small moving ball away from the light, so every
//! case also runs the per-frame merge; scenes without moving objects are
//! judged in tests/indirect_accuracy.rs.

use crate::common;

use std::path::{Path, PathBuf};

use common::{Run, run_command};
use gibake_image::{Image, rel_mse};
use gibake_scenegen::{geom, gltf::Builder};
use glam::DVec3;

const W: &str = "48";
/// The bake's settings: the first bounce alone (`--bounces 1`), judged
/// against the one-bounce reference; the later bounces' stiff cases (a
/// white room, albedo 0.99 and 1, 1 mm and 1 km) are
/// crates/bake/tests/later.rs's, their accuracy tests/every_bounce_accuracy.rs's.
const BAKE: [&str; 10] = [
    "--vpls",
    "64",
    "--rsm-size",
    "128",
    "--vpl-map-size",
    "32",
    "--shadow-map-size",
    "512",
    "--bounces",
    "1",
];
const MODES: [&str; 5] = ["full", "direct", "indirect", "rsm", "naive"];

fn gibake(args: &[&dyn AsRef<std::ffi::OsStr>]) -> Run {
    let mut c = common::gibake();
    for a in args {
        c.arg(a);
    }
    run_command(c)
}

fn ok(r: &Run) {
    assert_eq!(r.code, Some(0), "{r}");
}

/// Parameters of the base scene: a concave corner (floor, back wall, left
/// wall) lit by a spot, seen by a camera.
#[derive(Clone)]
struct Params {
    scale: f64,
    intensity: f64,
    albedo: f32,
    outer_deg: f64,
    /// Directional light at this elevation above the floor (degrees) instead of the spot.
    grazing_deg: Option<f64>,
    /// Spot pointing straight up (it sees no static geometry).
    light_up: bool,
    /// A moving ball almost touching the back wall, in the light.
    touching: bool,
    /// A moving box enclosing the light.
    cover_light: bool,
    /// A 1e4-unit floor beside a 1e-2 box instead of the corner.
    mixed: bool,
    /// One static triangle instead of the corner.
    one_triangle: bool,
    /// A floor split by a thin partition, both halves sunlit, a box
    /// facing the partition on one side, instead of the corner.
    partition: bool,
    /// The reference's samples per pixel.
    reference_spp: u32,
    /// Bake with every bounce (the default) instead of `--bounces 1`.
    every_bounce: bool,
}

impl Default for Params {
    fn default() -> Self {
        Params {
            scale: 1.0,
            intensity: 20.0,
            albedo: 0.7,
            outer_deg: 40.0,
            grazing_deg: None,
            light_up: false,
            touching: false,
            cover_light: false,
            mixed: false,
            one_triangle: false,
            partition: false,
            reference_spp: 64,
            every_bounce: false,
        }
    }
}

const LIGHT: DVec3 = DVec3::new(0.5, 2.5, 1.0);

/// The base scene's 3 × 3 floor at y = 0.
fn floor(b: &mut Builder, albedo: [f32; 3]) {
    let g = geom::quad_facing(
        DVec3::new(-1.5, 0.0, -1.5),
        DVec3::X * 3.0,
        DVec3::Z * 3.0,
        4,
        DVec3::Y,
    );
    b.static_mesh("floor", &g, albedo);
}

fn build(p: &Params) -> Vec<u8> {
    let mut b = Builder::new(p.scale, "move");
    let a = [p.albedo; 3];
    if p.one_triangle {
        let g = geom::Geom {
            pos: vec![
                DVec3::new(-1.0, 0.0, 1.0),
                DVec3::new(1.0, 0.0, 1.0),
                DVec3::new(0.0, 0.0, -1.0),
            ],
            nrm: vec![DVec3::Y; 3],
            idx: vec![0, 1, 2],
        };
        b.static_mesh("triangle", &g, a);
    } else if p.partition {
        floor(&mut b, a);
        // 1 cm thick, 0.5 tall, across the whole floor.
        let wall = geom::aabox(
            DVec3::new(-0.005, 0.0, -1.5),
            DVec3::new(0.005, 0.5, 1.5),
            2,
            false,
        );
        b.static_mesh("partition", &wall, a);
        let boxg = geom::aabox(
            DVec3::new(0.25, 0.0, -0.3),
            DVec3::new(0.6, 0.35, 0.3),
            2,
            false,
        );
        b.static_mesh("box", &boxg, a);
    } else if p.mixed {
        let floor = geom::quad_facing(
            DVec3::new(-5e3, 0.0, -5e3),
            DVec3::X * 1e4,
            DVec3::Z * 1e4,
            1,
            DVec3::Y,
        );
        b.static_mesh("huge_floor", &floor, a);
        let tiny = geom::aabox(DVec3::new(0.0, 0.0, 0.0), DVec3::splat(1e-2), 1, false);
        b.static_mesh("tiny_box", &tiny, a);
        let wall = geom::quad_facing(
            DVec3::new(-1.5, 0.0, -1.5),
            DVec3::X * 3.0,
            DVec3::Y * 2.0,
            1,
            DVec3::Z,
        );
        b.static_mesh("wall", &wall, a);
    } else {
        floor(&mut b, a);
        let back = geom::quad_facing(
            DVec3::new(-1.5, 0.0, -1.5),
            DVec3::X * 3.0,
            DVec3::Y * 2.0,
            4,
            DVec3::Z,
        );
        b.static_mesh("back", &back, a);
        let left = geom::quad_facing(
            DVec3::new(-1.5, 0.0, -1.5),
            DVec3::Z * 3.0,
            DVec3::Y * 2.0,
            4,
            DVec3::X,
        );
        b.static_mesh("left", &left, a);
    }
    // The moving object of the scene (see the file's documentation).
    let (geo, path) = if p.touching {
        let r = 0.2;
        let c = DVec3::new(-0.3, 0.4, -1.5 + r + 1e-3);
        (geom::uv_sphere(DVec3::ZERO, r, 16, 10), [c, c])
    } else if p.cover_light {
        let g = geom::aabox(DVec3::splat(-0.2), DVec3::splat(0.2), 1, true);
        (g, [LIGHT, LIGHT])
    } else {
        let c = DVec3::new(1.3, 0.03, 1.3);
        (geom::uv_sphere(DVec3::ZERO, 0.03, 8, 6), [c, c])
    };
    let g = b.geometry(&geo);
    let mat = b.material("mover", [0.5, 0.5, 0.5]);
    let mesh = b.mesh("mover", g, mat);
    b.dynamic_mesh("mover", mesh, &[0.0, 1.0], &path);
    if p.partition {
        // Falling along the partition (its shadow 2.5 cm wide): both
        // halves lit up to it; the box's face towards it (x = 0.25) gets
        // no direct light, only the bounce from its own side's floor.
        let dir = DVec3::new(-0.05, -1.0, -0.4).normalize();
        b.directional(
            "sun",
            DVec3::new(-1.0, 3.0, 0.0),
            dir,
            [1.0; 3],
            p.intensity / 4.0,
        );
    } else if let Some(elev) = p.grazing_deg {
        let e = elev.to_radians();
        let dir = DVec3::new(-e.cos(), -e.sin(), -0.2).normalize();
        b.directional(
            "sun",
            DVec3::new(2.0, 2.0, 0.0),
            dir,
            [1.0; 3],
            p.intensity / 4.0,
        );
    } else {
        let target = if p.light_up {
            LIGHT + DVec3::Y
        } else {
            DVec3::new(-0.3, 0.0, -0.5)
        };
        let outer = p.outer_deg.to_radians();
        b.spot(
            "spot",
            LIGHT,
            target - LIGHT,
            [1.0; 3],
            p.intensity,
            outer * 0.8,
            outer,
        );
    }
    // The partition's camera looks from above the gap between the
    // partition and the box onto the box's face that looks at it.
    let (eye, target) = if p.partition {
        (DVec3::new(0.05, 1.1, 0.6), DVec3::new(0.3, 0.15, 0.0))
    } else {
        (DVec3::new(0.6, 1.3, 3.0), DVec3::new(-0.3, 0.5, -0.5))
    };
    b.perspective("camera", eye, target, 55f64.to_radians(), 0.05, 1e5);
    b.finish()
}

/// What one case produced.
struct Outcome {
    vpls: Option<u64>,
    images: Vec<(&'static str, Image)>,
    reference: Image,
    reference_direct: Image,
    bake: Run,
}

impl Outcome {
    fn image(&self, mode: &str) -> &Image {
        &self
            .images
            .iter()
            .find(|(m, _)| *m == mode)
            .expect("mode rendered")
            .1
    }
}

fn read(p: &Path) -> Image {
    Image::read_exr(p).unwrap_or_else(|e| panic!("{}: {e}", p.display()))
}

/// Bakes and renders `p` in every mode, and renders both references.
fn run_case(name: &str, p: &Params) -> Outcome {
    // GIBAKE_STIFF_KEEP=1 keeps each case's scene, asset and images (the
    // directory is printed) to look at.
    let keep = std::env::var_os("GIBAKE_STIFF_KEEP").is_some();
    let dir = tempfile::Builder::new()
        .prefix(&format!("stiff_{name}_"))
        .disable_cleanup(keep)
        .tempdir()
        .expect("tempdir");
    if keep {
        eprintln!("{name}: kept in {}", dir.path().display());
    }
    let scene = dir.path().join(format!("{name}.glb"));
    std::fs::write(&scene, build(p)).expect("write scene");
    let asset = dir.path().join("a.gibake");
    let mut args: Vec<&dyn AsRef<std::ffi::OsStr>> =
        vec![&"bake", &scene, &"-o", &asset, &"--json"];
    // BAKE ends with `--bounces 1`.
    let bake_flags = if p.every_bounce {
        &BAKE[..BAKE.len() - 2]
    } else {
        &BAKE[..]
    };
    for a in bake_flags {
        args.push(a);
    }
    let bake = gibake(&args);
    let vpls = serde_json::from_str::<serde_json::Value>(&bake.stdout)
        .ok()
        .and_then(|v| v["vpls"].as_u64());
    let mut images = Vec::new();
    for mode in MODES {
        if bake.code != Some(0) && mode != "direct" {
            continue;
        }
        let out: PathBuf = dir.path().join(format!("{mode}.exr"));
        let mut args: Vec<&dyn AsRef<std::ffi::OsStr>> = vec![
            &"render",
            &scene,
            &"--mode",
            &mode,
            &"--width",
            &W,
            &"--height",
            &W,
            &"--ssaa",
            &"1",
            &"--shadow-map-size",
            &"512",
            &"-o",
            &out,
        ];
        if bake.code == Some(0) {
            args.push(&"--bake");
            args.push(&asset);
        }
        let r = gibake(&args);
        ok(&r);
        images.push((mode, read(&out)));
    }
    let spp = p.reference_spp.to_string();
    let mut refs = [false, true].iter().map(|&direct_only| {
        let out = dir.path().join(format!("ref{direct_only}.exr"));
        let mut args: Vec<&dyn AsRef<std::ffi::OsStr>> = vec![
            &"reference",
            &scene,
            &"--width",
            &W,
            &"--height",
            &W,
            &"--spp",
            &spp,
            &"-o",
            &out,
        ];
        // The one-bounce reference: the method is judged against direct
        // + one bounce until the later bounces are baked.
        if direct_only {
            args.push(&"--direct-only");
        } else {
            args.push(&"--bounces");
            args.push(&"1");
        }
        ok(&gibake(&args));
        read(&out)
    });
    let (reference, reference_direct) = (refs.next().expect("ref"), refs.next().expect("ref"));
    let o = Outcome {
        vpls,
        images,
        reference,
        reference_direct,
        bake,
    };
    for (mode, img) in &o.images {
        assert!(img.all_finite(), "{name}: --mode {mode} is not finite");
    }
    assert!(o.reference.all_finite(), "{name}: reference not finite");
    o
}

/// `rel_mse` of the full and direct images against their references,
/// printed (captured by the harness, shown with --nocapture).
fn errors(name: &str, o: &Outcome) -> (f64, f64) {
    let full = rel_mse(o.image("full"), &o.reference);
    let direct = rel_mse(o.image("direct"), &o.reference_direct);
    eprintln!(
        "{name}: full rel MSE {full:.4}, direct rel MSE {direct:.4}, VPLs {:?}",
        o.vpls
    );
    (full, direct)
}

fn check_against_reference(name: &str, p: &Params, full_bound: f64, direct_bound: f64) {
    let o = run_case(name, p);
    ok(&o.bake);
    let (full, direct) = errors(name, &o);
    assert!(
        full <= full_bound,
        "{name}: full rel MSE {full} > {full_bound}"
    );
    assert!(
        direct <= direct_bound,
        "{name}: direct rel MSE {direct} > {direct_bound}"
    );
}

/// A thin partition (1 cm, 0.5 tall) across a sunlit floor whose two
/// halves are lit up to it, and a box on one side whose face towards the
/// partition (25 cm from it) gets no direct light, seen from above the
/// gap. The finest near-field nodes' light skips the map test near them
/// (docs/method.md, "Finest nodes near their receiver"), so the other
/// side's floor could light the face through the partition. Where the
/// reference has no direct light (the face, 78 pixels), `full`'s indirect
/// light is held to 1.12× the reference's. Measured at these settings
/// (48², 64 VPLs: about three times the default's VPL radius; a 256-spp
/// reference, as a 64-spp one's seeds alone move the figure by ±0.04:
/// docs/robustness.md): 1.055 with the rule built (the open share fading
/// from the node's own near field to its parent's), 1.160 with the finest
/// nodes never map-tested; full rel MSE 0.018, direct 0.029. (Against
/// the 64-spp reference, session 16: 1.072 built, 0.921 with every node
/// map-tested, 1.179 finest nodes never tested, 1.404 no near-field node
/// tested.)
#[test]
fn thin_partition_between_lit_floors() {
    let p = Params {
        partition: true,
        reference_spp: 256,
        ..Params::default()
    };
    let o = run_case("partition", &p);
    ok(&o.bake);
    let (full, direct) = errors("partition", &o);
    let (f, d) = (o.image("full"), o.image("direct"));
    let (r, rd) = (&o.reference, &o.reference_direct);
    let (mut sf, mut sr, mut n) = (0.0f64, 0.0f64, 0u32);
    for y in 0..r.height {
        for x in 0..r.width {
            if rd.get(x, y).max_element() < 1e-4 {
                sf += f64::from((f.get(x, y) - d.get(x, y)).element_sum());
                sr += f64::from((r.get(x, y) - rd.get(x, y)).element_sum());
                n += 1;
            }
        }
    }
    let ratio = sf / sr;
    eprintln!(
        "partition: indirect where the reference has no direct light ({n} px): full / reference {ratio:.3}"
    );
    assert!(
        n >= 50 && sr > 0.0,
        "partition: {n} unlit pixels, reference {sr}"
    );
    assert!(
        ratio <= 1.12,
        "partition: full's indirect light {ratio:.3}× the reference's where it has no direct light"
    );
    assert!(full <= 0.04, "partition: full rel MSE {full}");
    assert!(direct <= 0.05, "partition: direct rel MSE {direct}");
}

#[test]
fn concave_corner() {
    check_against_reference("corner", &Params::default(), 0.02, 0.003);
}

#[test]
fn grazing_light_85_and_89_degrees() {
    for elev in [5.0, 1.0] {
        let p = Params {
            grazing_deg: Some(elev),
            ..Params::default()
        };
        check_against_reference(&format!("grazing{}", 90.0 - elev), &p, 0.1, 0.04);
    }
}

#[test]
fn spot_cone_wider_than_150_degrees() {
    let p = Params {
        outer_deg: 80.0,
        ..Params::default()
    };
    check_against_reference("wide_spot", &p, 0.06, 0.04);
}

#[test]
fn moving_object_almost_touching_a_lit_wall() {
    let p = Params {
        touching: true,
        ..Params::default()
    };
    check_against_reference("touching", &p, 0.02, 0.004);
}

#[test]
fn walls_of_1e4_beside_1e_2() {
    let p = Params {
        mixed: true,
        ..Params::default()
    };
    check_against_reference("mixed_scales", &p, 0.015, 0.005);
}

#[test]
fn one_static_triangle() {
    let p = Params {
        one_triangle: true,
        ..Params::default()
    };
    check_against_reference("one_triangle", &p, 0.025, 0.025);
}

#[test]
fn same_scene_at_1e_minus_4_1_and_1e4() {
    let base = run_case("scale1", &Params::default());
    ok(&base.bake);
    for s in [1e-4, 1e4] {
        let name = format!("scale{s:e}");
        let o = run_case(
            &name,
            &Params {
                scale: s,
                ..Params::default()
            },
        );
        ok(&o.bake);
        assert_eq!(o.vpls, base.vpls, "{name}: VPL count differs from scale 1");
        for mode in MODES {
            let e = rel_mse(o.image(mode), base.image(mode));
            eprintln!("{name}: --mode {mode} rel MSE against scale 1: {e:.2e}");
            assert!(e <= 1e-6, "{name}: --mode {mode} differs from scale 1: {e}");
        }
    }
}

#[test]
fn intensity_1e_minus_6_and_1e6_scales_linearly() {
    let base = run_case("intensity20", &Params::default());
    ok(&base.bake);
    for i in [1e-6, 1e6] {
        let name = format!("intensity{i:e}");
        let o = run_case(
            &name,
            &Params {
                intensity: i,
                ..Params::default()
            },
        );
        ok(&o.bake);
        assert_eq!(o.vpls, base.vpls, "{name}: VPL count");
        for mode in MODES {
            let img = o.image(mode);
            let mut scaled = Image::new(img.width, img.height);
            for y in 0..img.height {
                for x in 0..img.width {
                    scaled.set(x, y, img.get(x, y) * (20.0 / i) as f32);
                }
            }
            let e = rel_mse(&scaled, base.image(mode));
            eprintln!("{name}: --mode {mode} rel MSE of image·20/I against I = 20: {e:.2e}");
            assert!(e <= 1e-9, "{name}: --mode {mode} not linear: {e}");
        }
    }
}

#[test]
fn albedo_0_and_1_everywhere() {
    let o = run_case(
        "albedo0",
        &Params {
            albedo: 0.0,
            ..Params::default()
        },
    );
    // Nothing to bounce: the bake says so (exit 2, one message), and direct
    // light renders black without an asset.
    eprintln!("albedo0: bake exit {:?}", o.bake.code);
    if o.bake.code == Some(0) {
        let m = o.image("indirect").mean();
        assert!(m.max_element() <= 1e-6, "albedo 0: indirect mean {m}");
    } else {
        assert_eq!(o.bake.code, Some(2), "{}", o.bake);
        assert!(o.bake.stderr.contains("albedo0.glb"), "{}", o.bake);
    }
    let d = o.image("direct").mean();
    assert!(d.max_element() <= 1e-6, "albedo 0: direct mean {d}");
    check_against_reference(
        "albedo1",
        &Params {
            albedo: 1.0,
            ..Params::default()
        },
        0.04,
        0.002,
    );
}

#[test]
fn a_moving_object_covering_the_light() {
    let open = run_case("open", &Params::default());
    let o = run_case(
        "covered",
        &Params {
            cover_light: true,
            ..Params::default()
        },
    );
    ok(&o.bake);
    let (full, direct) = errors("covered", &o);
    let lit = open.image("full").mean().max_element();
    let left = o.image("full").mean().max_element();
    eprintln!("covered: full mean {left:.3e} against {lit:.3e} uncovered");
    assert!(
        left <= 0.02 * lit,
        "covered light still lights: {left} vs {lit}"
    );
    assert!(full <= 0.01 && direct <= 0.001, "covered: {full} {direct}");
}

/// The same with every bounce (the default bake): the later bounces' VPLs
/// lose the share of the first bounce's light the moving box takes
/// (`later_occlusion.wgsl`); without that they kept 9% of the uncovered
/// light.
#[test]
fn a_moving_object_covering_the_light_darkens_the_later_bounces() {
    let every = |p: Params| Params {
        every_bounce: true,
        ..p
    };
    let open = run_case("open_every", &every(Params::default()));
    let o = run_case(
        "covered_every",
        &every(Params {
            cover_light: true,
            ..Params::default()
        }),
    );
    ok(&open.bake);
    ok(&o.bake);
    let later = |r: &Run| {
        serde_json::from_str::<serde_json::Value>(&r.stdout)
            .ok()
            .and_then(|v| v["later"]["vpls"].as_u64())
            .unwrap_or(0)
    };
    assert!(later(&o.bake) > 0, "no later VPL to test: {}", o.bake);
    let lit = open.image("full").mean().max_element();
    let left = o.image("full").mean().max_element();
    eprintln!("covered, every bounce: full mean {left:.3e} against {lit:.3e} uncovered");
    assert!(
        left <= 0.02 * lit,
        "covered light still lights through the later bounces: {left} vs {lit}"
    );
}

#[test]
fn a_light_that_sees_no_static_geometry() {
    let o = run_case(
        "light_up",
        &Params {
            light_up: true,
            ..Params::default()
        },
    );
    // The bake has nothing to bounce: exit 2 naming the scene; direct renders.
    assert_eq!(o.bake.code, Some(2), "{}", o.bake);
    assert!(o.bake.stderr.contains("light_up.glb"), "{}", o.bake);
    assert!(!o.bake.stderr.contains("panicked"), "{}", o.bake);
    let m = o.image("direct").mean();
    assert!(m.max_element() <= 1e-6, "direct mean {m}");
}
