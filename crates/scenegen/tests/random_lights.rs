//! Tests of the multi-light scenes: `random_lights` is deterministic per
//! seed, its scenes import with every light and cover the kinds, ranges and
//! rooms the module docs promise; the bundled `lamps` scene is what
//! `data/lamps.glb` holds and imports with its three lamps (and, with
//! `--light spot_lamp`, with its one spot).

use std::collections::HashSet;
use std::path::Path;

use gibake_scene::{LightKind, LoadOptions, Scene, load_from_slice};
use gibake_scenegen::inspect::split_glb;
use gibake_scenegen::{Params, RandomLightsInfo, random_lights};

const SEEDS: u64 = 64;

fn import_with(bytes: &[u8], name: &str, lights: &[&str]) -> Scene {
    load_from_slice(
        bytes,
        Path::new(name),
        &LoadOptions {
            lights: lights.iter().map(|l| l.to_string()).collect(),
            ..Default::default()
        },
    )
    .unwrap_or_else(|e| panic!("{name}: import failed: {e}"))
}

fn import(bytes: &[u8], name: &str) -> Scene {
    import_with(bytes, name, &[])
}

fn kind(k: &LightKind) -> &'static str {
    match k {
        LightKind::Spot { .. } => "spot",
        LightKind::Directional => "directional",
        LightKind::Point => "point",
    }
}

/// `(kind, range)` pairs, sorted.
fn sorted(mut v: Vec<(&'static str, Option<f64>)>) -> Vec<(&'static str, Option<f64>)> {
    v.sort_by(|a, b| a.partial_cmp(b).expect("no NaN range"));
    v
}

/// The lights of an imported scene as sorted `(kind, range)` pairs.
fn imported_lights(scene: &Scene) -> Vec<(&'static str, Option<f64>)> {
    sorted(
        scene
            .lights
            .iter()
            .map(|l| (kind(&l.kind), l.range.map(f64::from)))
            .collect(),
    )
}

/// The same kinds, with the same ranges up to `f32` rounding (the importer
/// takes the range through the node's world transform).
fn same_lights(a: &[(&'static str, Option<f64>)], b: &[(&'static str, Option<f64>)]) -> bool {
    a.len() == b.len()
        && a.iter().zip(b).all(|(x, y)| {
            x.0 == y.0
                && match (x.1, y.1) {
                    (None, None) => true,
                    (Some(p), Some(q)) => (p - q).abs() <= 1e-5 * p.abs().max(q.abs()),
                    _ => false,
                }
        })
}

/// Every number of every light is finite and in its domain.
fn check_light_parameters(scene: &Scene, what: &str) {
    for l in &scene.lights {
        let n = &l.name;
        assert!(
            l.color.is_finite() && l.color.min_element() >= 0.0 && l.color.max_element() > 0.0,
            "{what}: {n}: colour {}",
            l.color
        );
        assert!(l.position.is_finite(), "{what}: {n}: position");
        assert!(
            l.direction.is_finite() && (l.direction.length() - 1.0).abs() < 1e-4,
            "{what}: {n}: direction {}",
            l.direction
        );
        if let Some(r) = l.range {
            assert!(r.is_finite() && r > 0.0, "{what}: {n}: range {r}");
        }
        match l.kind {
            LightKind::Spot {
                inner_cone,
                outer_cone,
            } => assert!(
                inner_cone.is_finite()
                    && outer_cone.is_finite()
                    && 0.0 <= inner_cone
                    && inner_cone <= outer_cone
                    && outer_cone > 0.0
                    && outer_cone <= std::f32::consts::FRAC_PI_2,
                "{what}: {n}: cones {inner_cone} {outer_cone}"
            ),
            LightKind::Directional => {
                assert!(l.range.is_none(), "{what}: {n}: directional with a range");
            }
            LightKind::Point => {}
        }
    }
}

#[test]
fn same_seed_same_bytes_and_seeds_differ() {
    let p = Params::default();
    for seed in [0, 7, 12345, u64::MAX] {
        let (a, ia) = random_lights(seed, &p);
        let (b, ib) = random_lights(seed, &p);
        assert!(a == b, "seed {seed}: bytes differ between two runs");
        assert_eq!(ia, ib);
    }
    let all: HashSet<Vec<u8>> = (0..SEEDS).map(|s| random_lights(s, &p).0).collect();
    assert_eq!(all.len(), SEEDS as usize, "two seeds gave the same scene");
}

#[test]
fn every_seed_imports_with_all_its_lights_and_the_seeds_cover_the_cases() {
    let mut infos: Vec<RandomLightsInfo> = Vec::new();
    let mut ranged = HashSet::new();
    let mut unranged = HashSet::new();
    for seed in 0..SEEDS {
        let (bytes, info) = random_lights(seed, &Params::default());
        let what = format!("seed {seed} ({info})");
        let scene = import(&bytes, &format!("random_lights_{seed}.glb"));
        let n = scene.lights.len();
        assert!((1..=8).contains(&n), "{what}: {n} lights");
        let expected = sorted(info.lights.iter().map(|l| (l.kind, l.range)).collect());
        let got = imported_lights(&scene);
        assert!(
            same_lights(&got, &expected),
            "{what}: imported {got:?}, generated {expected:?}"
        );
        check_light_parameters(&scene, &what);
        assert!(info.count("directional") <= 2, "{what}");
        if info.interior {
            assert!(
                info.count("spot") + info.count("point") >= 1,
                "{what}: an interior without a lamp"
            );
            assert!(info.count("directional") <= 1, "{what}");
        }
        assert_eq!(
            scene.dynamic_objects.len(),
            info.moving as usize,
            "{what}: moving objects"
        );
        assert!(scene.camera.is_some(), "{what}: no camera");
        for l in &info.lights {
            if l.kind == "directional" {
                assert!((0.05..10.0).contains(&l.intensity), "{what}");
            } else {
                assert!((10.0..200.0).contains(&l.intensity), "{what}");
                if l.range.is_some() {
                    ranged.insert(l.kind);
                } else {
                    unranged.insert(l.kind);
                }
            }
        }
        infos.push(info);
    }
    for k in ["directional", "spot", "point"] {
        assert!(infos.iter().any(|i| i.count(k) > 0), "no {k} light");
    }
    for k in ["spot", "point"] {
        assert!(ranged.contains(k), "no {k} light with a range");
        assert!(unranged.contains(k), "no {k} light without a range");
    }
    assert!(infos.iter().any(|i| i.interior) && infos.iter().any(|i| !i.interior));
    for room in ["ground", "wall", "corner", "three_walls", "hall", "room"] {
        assert!(infos.iter().any(|i| i.room == room), "no {room}");
    }
    assert!(infos.iter().any(|i| i.skylight), "no skylight");
    assert!(
        infos
            .iter()
            .any(|i| i.interior && i.count("directional") == 1),
        "no sunlit interior"
    );
    assert!(
        infos
            .iter()
            .any(|i| !i.interior && i.count("directional") >= 1 && i.lights.len() >= 3),
        "no exterior with a sun and lamps"
    );
    assert!(infos.iter().any(|i| i.lights.len() == 1));
    assert!(infos.iter().any(|i| i.lights.len() == 8));
    assert!(infos.iter().any(|i| i.moving == 0) && infos.iter().any(|i| i.moving >= 8));
}

/// Scaling by `s` multiplies lamp intensities by `s²` and ranges and
/// positions by `s`; directional irradiance stays.
#[test]
fn scaled_random_lights_scale_intensity_and_range() {
    let s = 10.0f32;
    for seed in 0..8 {
        let (a, info) = random_lights(seed, &Params::default());
        let (b, _) = random_lights(
            seed,
            &Params {
                scale: s,
                ..Params::default()
            },
        );
        let (a, b) = (import(&a, "a.glb").lights, import(&b, "b.glb").lights);
        assert_eq!(a.len(), b.len());
        for (la, lb) in a.iter().zip(&b) {
            let what = format!("seed {seed} ({info}): {}", la.name);
            assert_eq!(la.name, lb.name);
            let f = if la.kind == LightKind::Directional {
                1.0
            } else {
                s * s
            };
            assert!(
                (lb.color - la.color * f).abs().max_element() <= 1e-5 * lb.color.max_element(),
                "{what}: {} vs {}",
                la.color,
                lb.color
            );
            match (la.range, lb.range) {
                (None, None) => {}
                (Some(x), Some(y)) => assert!((y - x * s).abs() <= 1e-5 * y, "{what}"),
                _ => panic!("{what}: range appears or vanishes when scaled"),
            }
            if la.kind != LightKind::Directional {
                assert!(
                    (lb.position - la.position * s).abs().max_element()
                        <= 1e-5 * lb.position.abs().max_element().max(1.0),
                    "{what}"
                );
            }
        }
    }
}

#[test]
fn heavy_random_lights_import() {
    for seed in 0..4 {
        let (bytes, info) = random_lights(
            seed,
            &Params {
                heavy: 9,
                ..Params::default()
            },
        );
        let scene = import(&bytes, "heavy.glb");
        assert_eq!(scene.lights.len(), info.lights.len());
    }
}

fn committed_lamps() -> Vec<u8> {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../data/lamps.glb");
    std::fs::read(&path).unwrap_or_else(|e| {
        panic!(
            "{}: {e} (run `cargo run -p gibake-scenegen`)",
            path.display()
        )
    })
}

/// `data/lamps.glb` is what the generator writes (the binary's output is
/// checked in `tests/scenes.rs` with every bundled scene), small, and not in
/// the one-light list.
#[test]
fn committed_lamps_is_reproducible() {
    let bytes = gibake_scenegen::lamps(&Params::default());
    assert!(
        bytes == committed_lamps(),
        "data/lamps.glb differs from the generator's output: run `cargo run -p gibake-scenegen` and commit"
    );
    assert!(bytes.len() < 200_000, "lamps.glb is {} bytes", bytes.len());
    let f = gibake_scenegen::by_name("lamps").expect("lamps is listed");
    assert!(f(&Params::default()) == bytes);
    assert!(
        gibake_scenegen::multi_light()
            .iter()
            .any(|(n, _)| *n == "lamps")
    );
    assert!(gibake_scenegen::all().iter().all(|(n, _)| *n != "lamps"));
}

#[test]
fn lamps_imports_with_every_light_and_with_one() {
    let bytes = committed_lamps();
    let scene = import(&bytes, "lamps.glb");
    check_light_parameters(&scene, "lamps");
    let got = imported_lights(&scene);
    assert!(
        same_lights(
            &got,
            &[("point", None), ("point", Some(2.5)), ("spot", Some(6.0))]
        ),
        "{got:?}"
    );
    assert_eq!(scene.dynamic_objects.len(), 3);
    assert!(scene.camera.is_some());

    // `--light spot_lamp` keeps the spot and warns about the rest.
    let one = import_with(&bytes, "lamps.glb", &["spot_lamp"]);
    assert_eq!(one.lights.len(), 1);
    assert_eq!(one.lights[0].name, "spot_lamp");
    assert!(matches!(one.lights[0].kind, LightKind::Spot { .. }));
    assert!(one.lights[0].range.is_some_and(|r| (r - 6.0).abs() < 1e-5));
    assert!(
        one.warnings
            .iter()
            .any(|w| w.contains("point_lamp") && w.contains("point_lamp_low")),
        "{:?}",
        one.warnings
    );
}

/// Point lights' nodes carry no rotation (the spot's does); the lamps'
/// JSON is otherwise held to the bundled scenes' contract and scaling in
/// `tests/scenes.rs`.
#[test]
fn lamps_point_lights_have_no_rotation() {
    let (j, _) = split_glb(&gibake_scenegen::lamps(&Params::default())).unwrap();
    let lights = j["extensions"]["KHR_lights_punctual"]["lights"]
        .as_array()
        .unwrap();
    assert_eq!(lights.len(), 3);
    for l in lights {
        let node = j["nodes"]
            .as_array()
            .unwrap()
            .iter()
            .find(|n| n["name"] == l["name"])
            .unwrap();
        assert_eq!(
            node.get("rotation").is_none(),
            l["type"] == "point",
            "{node}"
        );
    }
}
