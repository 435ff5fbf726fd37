//! `gibake-reference`: the CPU physics reference of gibake.
//!
//! A small path tracer over a [`gibake_scene::Scene`], limited to path depth 2
//! ([`Depth::Direct`]: light → surface → eye) or 3 ([`Depth::OneBounce`]:
//! light → surface → surface → eye). It shares no code with the GPU renderer;
//! with the bake it shares the scene importer (`gibake-scene`) and the ray
//! caster (`gibake-raycast`), nothing of the light transport. It follows the
//! same written conventions as the renderer (see `docs/reference.md`):
//!
//! - camera rays as in [`View`] (box pixel filter, `spp` jittered samples per
//!   pixel, stratified on a √spp grid, averaged); a miss is black;
//! - two-sided Lambertian surfaces, BRDF = albedo/π; the geometric normal is
//!   flipped to face the ray origin and the shading normal with it;
//! - the primary lights ([`Scene::lights`], one or many) are delta lights —
//!   spot, point (both with glTF's optional `range` window) or directional —
//!   never seen directly. The direct-light estimator is next-event estimation
//!   over **every** light at each shading point: [`irradiance`] is the sum of
//!   [`direct::light_irradiance`] over the lights, each with its own exact
//!   shadow ray (no light sampling, so no noise from the number of lights,
//!   and the cost grows linearly with it). The random numbers a path draws do
//!   not depend on the lights, so a render with several lights equals the
//!   sum of the single-light renders with the same seed to float rounding
//!   (`tests/many_lights.rs`);
//! - one bounce: a cosine-weighted direction about the shading normal (0 if
//!   below the geometric hemisphere), contribution `albedo(x) · L_direct(y)`,
//!   `L_direct(y)` again summed over every light;
//! - scale-invariant ray offsets (no epsilon in scene units), deterministic
//!   results independent of the thread count, never NaN or ∞.
//!
//! Ray casting is [`gibake_raycast`]'s [`RayScene`] (an obvhs CWBVH),
//! re-exported here; the direct-light estimate on top of it is [`direct`].

pub mod direct;
mod rng;
pub mod scenes;
mod view;

use std::path::PathBuf;
use std::sync::atomic::{AtomicU64, Ordering};

use gibake_image::Image;
use gibake_scene::Scene;
use glam::{DVec3, Vec3};
use rayon::prelude::*;

pub use direct::{direct_radiance, irradiance};
pub use gibake_raycast::{Hit, RayScene};
pub use view::View;

use rng::{Pcg32, cosine_hemisphere};

/// How long the traced light paths are.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Depth {
    /// Path depth 2: light → surface → eye (direct light only).
    Direct,
    /// Path depth 3: light → surface → surface → eye (direct + one bounce).
    OneBounce,
}

/// What to render.
#[derive(Clone, Debug, PartialEq)]
pub struct Settings {
    /// Output width in pixels (≥ 1).
    pub width: u32,
    /// Output height in pixels (≥ 1).
    pub height: u32,
    /// Samples per pixel (≥ 1).
    pub spp: u32,
    /// Scene time in seconds (animations sampled, clamped to their range).
    pub time: f32,
    /// Path depth.
    pub depth: Depth,
    /// Seed of the per-pixel random number generators.
    pub seed: u64,
}

impl Default for Settings {
    fn default() -> Self {
        Settings {
            width: 256,
            height: 256,
            spp: 256,
            time: 0.0,
            depth: Depth::OneBounce,
            seed: 0,
        }
    }
}

/// Why a reference image cannot be rendered.
#[derive(Debug, thiserror::Error)]
pub enum ReferenceError {
    /// The scene has no camera.
    #[error("{}: the scene has no camera; add one (a glTF camera node) to render a reference image", path.display())]
    NoCamera {
        /// The scene file.
        path: PathBuf,
    },
    /// Width or height is zero.
    #[error("image size {width}×{height} is empty: width and height must be at least 1")]
    EmptyImage {
        /// Requested width.
        width: u32,
        /// Requested height.
        height: u32,
    },
    /// Width × height is too large to hold in memory.
    #[error("image size {width}×{height} is too large (at most 2^28 pixels)")]
    ImageTooLarge {
        /// Requested width.
        width: u32,
        /// Requested height.
        height: u32,
    },
    /// `spp` is zero.
    #[error("samples per pixel must be at least 1 (got 0)")]
    ZeroSpp,
    /// The time is NaN or infinite.
    #[error("time {0} is not a finite number of seconds")]
    BadTime(f32),
    /// The scene's data is inconsistent (the importer normally rejects this).
    #[error("{}: {message}", path.display())]
    InvalidScene {
        /// The scene file.
        path: PathBuf,
        /// What is wrong.
        message: String,
    },
}

fn check_settings(settings: &Settings) -> Result<(), ReferenceError> {
    let (width, height) = (settings.width, settings.height);
    if width == 0 || height == 0 {
        return Err(ReferenceError::EmptyImage { width, height });
    }
    if width as u64 * height as u64 > 1 << 28 {
        return Err(ReferenceError::ImageTooLarge { width, height });
    }
    if settings.spp == 0 {
        return Err(ReferenceError::ZeroSpp);
    }
    if !settings.time.is_finite() {
        return Err(ReferenceError::BadTime(settings.time));
    }
    Ok(())
}

/// Checks the data [`RayScene::build`] would otherwise silently skip.
fn check_scene(scene: &Scene) -> Result<(), ReferenceError> {
    let bad = |message: String| ReferenceError::InvalidScene {
        path: scene.source.clone(),
        message,
    };
    for mesh in scene.static_meshes.iter().chain(&scene.dynamic_meshes) {
        if mesh.material >= scene.materials.len() {
            return Err(bad(format!(
                "mesh {:?} uses material {} but the scene has {} materials",
                mesh.name,
                mesh.material,
                scene.materials.len()
            )));
        }
        if let Some(i) = mesh
            .indices
            .iter()
            .find(|&&i| i as usize >= mesh.positions.len())
        {
            return Err(bad(format!(
                "mesh {:?}: index {i} out of range ({} vertices)",
                mesh.name,
                mesh.positions.len()
            )));
        }
        if mesh
            .positions
            .iter()
            .chain(&mesh.normals)
            .any(|p| !p.is_finite())
        {
            return Err(bad(format!(
                "mesh {:?} has non-finite vertex data",
                mesh.name
            )));
        }
    }
    if scene.lights.is_empty() {
        return Err(bad("the scene has no primary light".into()));
    }
    for l in &scene.lights {
        if !(l.color.is_finite()
            && l.position.is_finite()
            && l.direction.is_finite()
            && l.range.is_none_or(|r| r.is_finite() && r > 0.0))
        {
            return Err(bad(format!("light {:?} has non-finite parameters", l.name)));
        }
    }
    Ok(())
}

/// Renders the reference image of `scene` from its camera at `settings.time`.
///
/// `progress` is called (from worker threads) with the number of rows
/// finished so far, once per row. The result is bit-identical for the same
/// inputs whatever the number of rayon threads.
pub fn render(
    scene: &Scene,
    settings: &Settings,
    progress: &(dyn Fn(u64) + Sync),
) -> Result<Image, ReferenceError> {
    check_settings(settings)?;
    let view = View::from_scene(scene, settings.time)?;
    check_scene(scene)?;
    let rs = RayScene::build(scene, settings.time);
    render_view(&rs, &view, settings, progress)
}

/// Renders `rs` (built at `settings.time`) from an explicit `view`: the same as
/// [`render`] for scenes without a camera node (hand-built test scenes).
pub fn render_view(
    rs: &RayScene<'_>,
    view: &View,
    settings: &Settings,
    progress: &(dyn Fn(u64) + Sync),
) -> Result<Image, ReferenceError> {
    check_settings(settings)?;
    let (w, h) = (settings.width, settings.height);
    let rows_done = AtomicU64::new(0);
    let rows: Vec<Vec<Vec3>> = (0..h)
        .into_par_iter()
        .map(|y| {
            let row: Vec<Vec3> = (0..w)
                .map(|x| render_pixel(rs, view, settings, x, y))
                .collect();
            let done = rows_done.fetch_add(1, Ordering::Relaxed) + 1;
            progress(done);
            row
        })
        .collect();
    Ok(Image {
        width: w,
        height: h,
        pixels: rows.into_iter().flatten().collect(),
    })
}

/// The box-filtered estimate of pixel `(x, y)`.
fn render_pixel(rs: &RayScene<'_>, view: &View, s: &Settings, x: u32, y: u32) -> Vec3 {
    let index = y as u64 * s.width as u64 + x as u64;
    let mut rng = Pcg32::for_pixel(s.seed, index);
    // Stratify the first n² samples on an n×n grid, the rest uniformly.
    let n = (s.spp as f64).sqrt().floor() as u32;
    let strata = n * n;
    let below_one = 1.0 - f32::EPSILON / 2.0;
    let mut sum = DVec3::ZERO;
    for i in 0..s.spp {
        let (r1, r2) = (rng.next_f32(), rng.next_f32());
        let (u, v) = if i < strata {
            (
                ((i % n) as f32 + r1) / n as f32,
                ((i / n) as f32 + r2) / n as f32,
            )
        } else {
            (r1, r2)
        };
        let (px, py) = (x as f32 + u.min(below_one), y as f32 + v.min(below_one));
        let (origin, dir, t_min) = view.primary_ray(s.width, s.height, px, py);
        sum += sample_radiance(rs, origin, dir, t_min, s.depth, &mut rng).as_dvec3();
    }
    gibake_raycast::sanitize(sum / s.spp as f64)
}

/// Radiance along one camera ray: direct light at the first hit plus, for
/// [`Depth::OneBounce`], one cosine-sampled indirect vertex.
fn sample_radiance(
    rs: &RayScene<'_>,
    origin: Vec3,
    dir: Vec3,
    t_min: f32,
    depth: Depth,
    rng: &mut Pcg32,
) -> Vec3 {
    let Some(hit) = rs.intersect_range(origin, dir, t_min, f32::INFINITY) else {
        return Vec3::ZERO;
    };
    let mut l = direct_radiance(rs, &hit);
    if depth == Depth::OneBounce {
        let (u1, u2) = (rng.next_f32(), rng.next_f32());
        if hit.albedo != Vec3::ZERO {
            let d = cosine_hemisphere(hit.shading_normal, u1, u2);
            if hit.geometric_normal.dot(d) > 0.0 {
                let o = rs.offset_point(hit.position, hit.geometric_normal);
                if let Some(y) = rs.intersect(o, d, f32::INFINITY) {
                    l += hit.albedo * direct_radiance(rs, &y);
                }
            }
        }
    }
    gibake_raycast::sanitize(l.as_dvec3())
}
