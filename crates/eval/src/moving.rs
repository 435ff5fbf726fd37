//! What the moving objects change in the indirect light, judged on the
//! pixels that show the static level: the runtime against the reference.
//!
//! The moving objects change a level's indirect light two ways: they hide
//! the light that static VPLs would bounce (occlusion) and they bounce light
//! of their own (dynamic VPLs, in every light whose views they enter: asset
//! format 4.1). What they change is small against the level's own indirect
//! light, so a reference rendered twice with independent noise cannot show
//! it (a firefly next to a lamp moves the mean more than the balls do).
//!
//! [`moving_effect`] therefore measures it with **correlated sampling**: the
//! reference of the scene and of its static part are rendered with the same
//! seeds. The reference's random numbers do not depend on what a ray hits
//! (`gibake_reference`: a fixed count per sample), so a path that misses
//! the moving objects is the same path in both renders and cancels exactly;
//! what is left is the light of the paths the moving objects touch. And it
//! is measured only on the **pixels that show the static level** in every
//! sample (no primary ray on a moving object, [`static_pixels`]): a pixel
//! that shows a ball in one render and the floor in the other changes by
//! the floor's whole light, which is not what the moving objects do to the
//! level. The runtime's renders (with and without the view RSMs, and the
//! static part baked and rendered alike) are compared on the same pixels.

use gibake_asset::Asset;
use gibake_gpu::GpuContext;
use gibake_image::Image;
use gibake_reference::{RayScene, View};
use gibake_runtime::Mode;
use gibake_scene::{LightKind, Scene};
use glam::{DVec3, Vec3};

use crate::levels::LevelBall;
use crate::{EvalError, EvalSettings};

/// What the moving objects change in the mean indirect light of the pixels
/// that show the static level (per channel, radiance).
#[derive(Clone, Debug)]
pub struct MovingEffect {
    /// The reference's change (scene less its static part, same seeds).
    pub reference: Vec3,
    /// Standard error of `reference` (from its two independent halves).
    pub noise: Vec3,
    /// The runtime's change with the other lights' view RSMs.
    pub runtime: Vec3,
    /// The runtime's change without them (a 4.0 asset: only the first
    /// light's bounce off moving objects).
    pub without_view_rsms: Vec3,
    /// The static part's mean indirect light on those pixels (reference),
    /// the scale the change is read against.
    pub level: Vec3,
    /// Pixels that show the static level, and all pixels.
    pub pixels: (usize, usize),
    /// View RSMs the bake stored.
    pub view_rsms: usize,
    /// The changes as images (all pixels): reference, runtime, runtime
    /// without the view RSMs.
    pub images: [Image; 3],
}

impl MovingEffect {
    /// One line: the three changes, the noise and the pixels used.
    pub fn line(&self) -> String {
        let f = |v: Vec3| format!("{:+.5}/{:+.5}/{:+.5}", v.x, v.y, v.z);
        format!(
            "reference {} ± {} | runtime {} | without view RSMs {} | level's indirect {} | {} of {} pixels, {} view RSMs",
            f(self.reference),
            f(self.noise),
            f(self.runtime),
            f(self.without_view_rsms),
            f(self.level),
            self.pixels.0,
            self.pixels.1,
            self.view_rsms
        )
    }
}

/// One ball of radius `r` resting on whatever is straight below each point
/// and spot light of `scene` at time `t` (none under a light with nothing
/// below it), albedos red, green and grey in turn: moving props where a
/// level's lamps light them, placed by a rule rather than by hand.
pub fn balls_under_lamps(scene: &Scene, r: f32, t: f32) -> Vec<LevelBall> {
    let rs = RayScene::build(scene, t);
    let albedos = [[0.8, 0.2, 0.15], [0.2, 0.7, 0.3], [0.8, 0.8, 0.8]];
    let mut balls = Vec::new();
    for l in &scene.lights {
        if matches!(l.kind, LightKind::Directional) {
            continue;
        }
        if let Some(h) = rs.intersect(l.position, Vec3::NEG_Y, f32::INFINITY) {
            balls.push(LevelBall {
                center: (h.position + Vec3::Y * r).to_array(),
                radius: r,
                albedo: albedos[balls.len() % albedos.len()],
            });
        }
    }
    balls
}

/// Whether each pixel of an `s.size²` image shows only the static level:
/// none of a 4×4 grid of primary rays over the pixel (its corners
/// included) hits a moving object at `s.time`.
pub fn static_pixels(scene: &Scene, s: &EvalSettings) -> Result<Vec<bool>, EvalError> {
    let view = View::from_scene(scene, s.time)?;
    let rs = RayScene::build(scene, s.time);
    let first_moving = scene.static_meshes.len() as u32;
    let n = s.size;
    let mut mask = Vec::with_capacity((n * n) as usize);
    for y in 0..n {
        for x in 0..n {
            let mut clear = true;
            'grid: for j in 0..4 {
                for i in 0..4 {
                    let (px, py) = (x as f32 + i as f32 / 3.0, y as f32 + j as f32 / 3.0);
                    let (o, d, t_min) = view.primary_ray(n, n, px, py);
                    if let Some(h) = rs.intersect_range(o, d, t_min, f32::INFINITY)
                        && h.mesh >= first_moving
                    {
                        clear = false;
                        break 'grid;
                    }
                }
            }
            mask.push(clear);
        }
    }
    Ok(mask)
}

/// Mean of `img` over the pixels where `mask` is true.
fn masked_mean(img: &Image, mask: &[bool]) -> Vec3 {
    let mut sum = DVec3::ZERO;
    let mut count = 0usize;
    for (p, &m) in img.pixels.iter().zip(mask) {
        if m {
            sum += p.as_dvec3();
            count += 1;
        }
    }
    (sum / count.max(1) as f64).as_vec3()
}

/// The reference's indirect images of `scene`: one per half of the
/// samples, each less the direct-only image ([`crate::reference_renders`]).
fn reference_halves(scene: &Scene, s: &EvalSettings) -> Result<[Image; 2], EvalError> {
    let [a, b, direct] = crate::reference_renders(scene, s)?;
    Ok([a.sub(&direct), b.sub(&direct)])
}

/// Measures what `scene`'s moving objects change in the mean indirect light
/// of the pixels that show the static level (see the module docs). Bakes
/// the scene; renders `Mode::Indirect` of the scene
/// with and without the view RSMs and of the static part; renders the
/// reference of both with the same seeds.
pub fn moving_effect(
    ctx: &GpuContext,
    scene: &Scene,
    s: &EvalSettings,
) -> Result<MovingEffect, EvalError> {
    let still = gibake_bake::static_only(scene);
    let mask = static_pixels(scene, s)?;
    let pixels = (mask.iter().filter(|m| **m).count(), mask.len());

    let [a, b] = reference_halves(scene, s)?;
    let [sa, sb] = reference_halves(&still, s)?;
    let (da, db) = (
        masked_mean(&a.sub(&sa), &mask),
        masked_mean(&b.sub(&sb), &mask),
    );
    // The standard error of the masked mean of (da + db)/2, per pixel
    // from the two halves' difference.
    let mut var = DVec3::ZERO;
    for (k, &m) in mask.iter().enumerate() {
        if m {
            let d = ((a.pixels[k] - sa.pixels[k]) - (b.pixels[k] - sb.pixels[k])).as_dvec3();
            var += d * d * 0.25;
        }
    }
    let n = pixels.0.max(1) as f64;
    let noise = (var / (n * n)).map(f64::sqrt).as_vec3();
    let level = (masked_mean(&sa, &mask) + masked_mean(&sb, &mask)) * 0.5;

    let indirect = |scene: &Scene, asset: &Asset| -> Result<Image, EvalError> {
        crate::render(ctx, scene, asset, Mode::Indirect, s)
    };
    let asset = crate::bake(
        ctx,
        scene,
        &EvalSettings {
            light_bounce: true,
            ..s.clone()
        },
    )?;
    let view_rsms = asset.view_rsms.len();
    // The static part rendered with the same asset: a bake of the static
    // part alone would fit the light views without the moving objects'
    // swept bounds, and its different VPLs would be counted as their effect.
    let base = indirect(&still, &asset)?;
    let runtime = indirect(scene, &asset)?.sub(&base);
    let without = indirect(scene, &crate::without_view_rsms(asset))?.sub(&base);
    let mut reference = a.sub(&sa);
    for (p, q) in reference.pixels.iter_mut().zip(&b.sub(&sb).pixels) {
        *p = (*p + *q) * 0.5;
    }
    Ok(MovingEffect {
        reference: (da + db) * 0.5,
        runtime: masked_mean(&runtime, &mask),
        without_view_rsms: masked_mean(&without, &mask),
        images: [reference, runtime, without],
        noise,
        level,
        pixels,
        view_rsms,
    })
}
