//! The judge's every-bounce reference (issue 50), on the CPU: what
//! `EvalSettings::every_bounce` adds to the reference images and the
//! figures, and that it is off by default (the suite's accuracy tests judge
//! the one-bounce method against the one-bounce reference, unchanged).

use crate::common;

use gibake_eval::{EvalSettings, EveryBounceEval, reference_images};
use gibake_image::Image;
use glam::Vec3;

fn corner_bunny() -> gibake_scene::Scene {
    gibake_scene::load(&common::data("corner_bunny.glb"), &Default::default())
        .expect("corner_bunny loads")
}

#[test]
fn every_bounce_reference_is_off_by_default_and_adds_later_bounces() {
    let scene = corner_bunny();
    let s = EvalSettings {
        size: 16,
        spp: 32,
        ..Default::default()
    };
    assert!(!s.every_bounce, "the tests judge against one bounce");
    let one = reference_images(&scene, &s).expect("reference");
    assert!(one.every.is_none() && one.indirect_every().is_none());
    let both = reference_images(
        &scene,
        &EvalSettings {
            every_bounce: true,
            ..s.clone()
        },
    )
    .expect("reference");
    // The one-bounce images are the same renders either way.
    assert_eq!(both.one_bounce, one.one_bounce);
    assert_eq!(both.direct, one.direct);
    let every = both.every.as_ref().expect("every bounce rendered");
    assert!(every.image.all_finite());
    assert_eq!(every.stats.paths, 16 * 16 * 32);
    assert_eq!(every.stats.capped, 0);
    // On the mean, strictly more light than one bounce: the walls and the
    // floor of corner_bunny bounce it on.
    let (ind_one, ind_every) = (one.indirect().mean(), both.indirect_every().unwrap().mean());
    let ratio = ind_every / ind_one;
    eprintln!(
        "corner_bunny 16², 32 spp: every ÷ one bounce indirect {ratio}, {:.2} bounce rays a path",
        every.stats.mean_bounces()
    );
    assert!(
        ratio.min_element() > 1.05 && ratio.max_element() < 3.0,
        "{ratio}"
    );
    assert!(every.stats.mean_bounces() > 1.0);
    assert!(every.noise.max_element() > 0.0 && every.noise.is_finite());
}

#[test]
fn every_bounce_figures_against_both_references() {
    // A method that equals the one-bounce reference's indirect light is
    // 0% off it, and 1/ratio − 1 off the every-bounce reference.
    let scene = corner_bunny();
    let s = EvalSettings {
        size: 12,
        spp: 16,
        every_bounce: true,
        ..Default::default()
    };
    let r = reference_images(&scene, &s).expect("reference");
    let one = r.indirect();
    let every = r.every.as_ref().expect("every bounce rendered");
    let half: Image = {
        let mut h = one.clone();
        h.pixels.iter_mut().for_each(|p| *p *= 0.5);
        h
    };
    let e = EveryBounceEval::new(&one, &half, every, &r.direct, one.mean(), 1);
    let ratio = Vec3::from(e.ratio);
    let expect = (Vec3::ONE / ratio - Vec3::ONE).to_array();
    for c in 0..3 {
        assert!(
            (e.full_bias[c] - expect[c]).abs() < 1e-5,
            "{:?} vs {expect:?}",
            e.full_bias
        );
        assert!(
            (e.rsm_bias[c] - (0.5 * (1.0 + expect[c]) - 1.0)).abs() < 1e-5,
            "{:?}",
            e.rsm_bias
        );
        assert!(e.full_bias[c] < 0.0, "the later bounces are missing");
    }
    assert!(e.full_err > 0.0 && e.full_err.is_finite());
    let line = e.line();
    assert!(
        line.contains("every bounce ×") && line.contains("bounces a path"),
        "{line}"
    );
}

#[test]
fn every_bounce_samples_share_the_one_bounce_samples() {
    // The pixel-centre judge (`lights`): the every-bounce samples visit the
    // same secondary hits with the same direct radiance, and add light.
    let scene = corner_bunny();
    let rays = gibake_reference::RayScene::build(&scene, 0.0);
    let cam = gibake_reference::View::from_scene(&scene, 0.0).expect("camera");
    let (mut n, mut more) = (0, 0);
    let mut stats = gibake_reference::PathStats::default();
    for p in [20u32, 95, 140, 200] {
        let Some(h) = gibake_eval::bounce::pixel_hit(&rays, &cam, 16, p) else {
            continue;
        };
        let mut one = Vec::new();
        gibake_eval::bounce::one_bounce_samples(&rays, &h, p, 4, |y, l| one.push((y.position, l)));
        let mut every = Vec::new();
        gibake_eval::bounce::every_bounce_samples(&rays, &h, p, 4, &mut stats, |y, l, le| {
            every.push((y.position, l, le))
        });
        assert_eq!(one.len(), every.len());
        for ((p1, l1), (p2, l2, le)) in one.iter().zip(&every) {
            assert_eq!((p1, l1), (p2, l2));
            assert!(le.is_finite() && (*le - *l2).min_element() >= -1e-6 * l2.max_element());
            more += usize::from(le.max_element() > l2.max_element());
        }
        n += one.len();
    }
    assert!(n > 20 && more > 0, "{n} samples, {more} brighter");
    assert!(stats.bounces > 0 && stats.paths == 0);
}
