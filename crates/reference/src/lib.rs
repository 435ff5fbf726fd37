//! `gibake-reference`: the CPU physics reference of gibake.
//!
//! A small path tracer over a [`gibake_scene::Scene`]: direct light alone
//! ([`Depth::Direct`], path depth 2: light → surface → eye), direct + one
//! bounce ([`Depth::OneBounce`], path depth 3: light → surface → surface →
//! eye), the first `n` bounces ([`Depth::Bounces`]) or every bounce
//! ([`Depth::Every`]: unbounded depth, Russian roulette from bounce
//! [`ROULETTE_FROM`] on, survival by throughput, unbiased up to the cap of
//! [`MAX_BOUNCES`] bounces a path). It shares no code with the GPU renderer;
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
//!   `L_direct(y)` again summed over every light; later bounces repeat that
//!   step from `y` with the throughput (the product of the albedos), adding
//!   next-event estimation at every vertex; [`Depth::Bounces`]`(0)` and `(1)`
//!   render as [`Depth::Direct`] and [`Depth::OneBounce`], bit for bit;
//! - every bounce: after bounce [`ROULETTE_FROM`] a path survives with
//!   probability `q = min(1, max channel of its throughput)` and its
//!   throughput is divided by `q` (unbiased); a path that reaches
//!   [`MAX_BOUNCES`] stops there and is counted ([`PathStats::capped`]): a
//!   closed space with albedo 1 has no finite answer, and the image is then
//!   the sum of the first [`MAX_BOUNCES`] bounces;
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
    /// Direct light and the first `n` bounces (path depth `n + 2`), exactly:
    /// Russian roulette after bounce [`ROULETTE_FROM`] (unbiased), no cap
    /// but `n` itself, at most [`MAX_BOUNCES`] (more is
    /// [`ReferenceError::TooManyBounces`]). `Bounces(0)` renders as
    /// [`Depth::Direct`] and `Bounces(1)` as [`Depth::OneBounce`], bit for
    /// bit.
    Bounces(u32),
    /// Every bounce: unbounded depth, Russian roulette after bounce
    /// [`ROULETTE_FROM`], survival by throughput (unbiased). A path that
    /// reaches [`MAX_BOUNCES`] bounces stops there and is counted in
    /// [`PathStats::capped`]: only a scene that traps light (albedo 1 or
    /// more in a closed space, whose answer is infinite, or very nearly 1)
    /// has such paths, and its image is then the sum of the first
    /// [`MAX_BOUNCES`] bounces.
    Every,
}

/// The most bounces a path follows ([`Depth::Every`]'s cap and the largest
/// [`Depth::Bounces`]): 1024.
///
/// A path in a closed space of albedo ρ carries `ρᵏ` of its light after k
/// bounces, so the cap leaves out `ρ^1024` of the answer: 3·10⁻⁵ at
/// ρ = 0.99, 0.36 at ρ = 0.999; at ρ = 1 the answer is infinite and the
/// image is 1025 times the first bounce's mean (direct + 1024 bounces),
/// finite. The cap bounds a render's time at 1024 bounce rays (and their
/// shadow rays) per sample, about 500 times a one-bounce render's, however
/// the scene traps light.
pub const MAX_BOUNCES: u32 = 1024;

/// Bounces every path follows before Russian roulette may end it: 3.
///
/// The first bounces carry most of an ordinary level's indirect light (the
/// first alone is 2/3 of it in the bundled living room: docs/reference.md),
/// and a path that is always traced through them keeps their noise free of
/// roulette's; after three bounces of ordinary albedos (0.3–0.8) the
/// throughput is 0.03–0.5, so roulette ends paths in proportion to what
/// they can still carry. Where the albedo is 1 (the white arena, whose
/// first bounce is 1/21 of its indirect light) the throughput stays 1 and
/// roulette ends nothing: such a path ends when it escapes, or at
/// [`MAX_BOUNCES`]. `Bounces(n)` for `n ≤ 3` never draws a roulette
/// number, so a pixel's first sample traces the first bounces of
/// [`Depth::Every`]'s with the same seed (the later samples' positions
/// follow the numbers the longer paths drew).
pub const ROULETTE_FROM: u32 = 3;

impl Depth {
    /// The most bounces a path follows: 0, 1, `n` or [`MAX_BOUNCES`].
    pub fn max_bounces(self) -> u32 {
        match self {
            Depth::Direct => 0,
            Depth::OneBounce => 1,
            Depth::Bounces(n) => n,
            Depth::Every => MAX_BOUNCES,
        }
    }
}

/// What the paths of a render did (sums over every camera sample; integer
/// sums, the same whatever the thread count).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct PathStats {
    /// Camera samples traced (`width · height · spp`).
    pub paths: u64,
    /// Bounce rays traced (each with a shadow ray per light at its hit).
    pub bounces: u64,
    /// Paths of [`Depth::Every`] that reached [`MAX_BOUNCES`] and were cut
    /// there (the light they still carried is left out).
    pub capped: u64,
}

impl PathStats {
    fn add(&mut self, o: PathStats) {
        self.paths += o.paths;
        self.bounces += o.bounces;
        self.capped += o.capped;
    }

    /// Bounce rays per camera sample.
    pub fn mean_bounces(&self) -> f64 {
        self.bounces as f64 / self.paths.max(1) as f64
    }

    /// The fraction of paths cut at [`MAX_BOUNCES`].
    pub fn capped_fraction(&self) -> f64 {
        self.capped as f64 / self.paths.max(1) as f64
    }
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
    /// [`Depth::Bounces`] beyond [`MAX_BOUNCES`].
    #[error(
        "{bounces} bounces is more than the reference follows (at most {max}; every bounce: `Depth::Every`)"
    )]
    TooManyBounces {
        /// Requested bounces.
        bounces: u32,
        /// [`MAX_BOUNCES`].
        max: u32,
    },
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
    if let Depth::Bounces(n) = settings.depth
        && n > MAX_BOUNCES
    {
        return Err(ReferenceError::TooManyBounces {
            bounces: n,
            max: MAX_BOUNCES,
        });
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
    render_with_stats(scene, settings, progress).map(|(image, _)| image)
}

/// [`render`], and what its paths did ([`PathStats`]: how many reached
/// [`MAX_BOUNCES`], for a warning).
pub fn render_with_stats(
    scene: &Scene,
    settings: &Settings,
    progress: &(dyn Fn(u64) + Sync),
) -> Result<(Image, PathStats), ReferenceError> {
    check_settings(settings)?;
    let view = View::from_scene(scene, settings.time)?;
    check_scene(scene)?;
    let rs = RayScene::build(scene, settings.time);
    render_view_with_stats(&rs, &view, settings, progress)
}

/// Renders `rs` (built at `settings.time`) from an explicit `view`: the same as
/// [`render`] for scenes without a camera node (hand-built test scenes).
pub fn render_view(
    rs: &RayScene<'_>,
    view: &View,
    settings: &Settings,
    progress: &(dyn Fn(u64) + Sync),
) -> Result<Image, ReferenceError> {
    render_view_with_stats(rs, view, settings, progress).map(|(image, _)| image)
}

/// [`render_view`], and what its paths did ([`PathStats`]).
pub fn render_view_with_stats(
    rs: &RayScene<'_>,
    view: &View,
    settings: &Settings,
    progress: &(dyn Fn(u64) + Sync),
) -> Result<(Image, PathStats), ReferenceError> {
    check_settings(settings)?;
    let (w, h) = (settings.width, settings.height);
    let rows_done = AtomicU64::new(0);
    let rows: Vec<(Vec<Vec3>, PathStats)> = (0..h)
        .into_par_iter()
        .map(|y| {
            let mut stats = PathStats::default();
            let row: Vec<Vec3> = (0..w)
                .map(|x| render_pixel(rs, view, settings, x, y, &mut stats))
                .collect();
            let done = rows_done.fetch_add(1, Ordering::Relaxed) + 1;
            progress(done);
            (row, stats)
        })
        .collect();
    let mut stats = PathStats::default();
    let mut pixels = Vec::with_capacity(w as usize * h as usize);
    for (row, s) in rows {
        pixels.extend(row);
        stats.add(s);
    }
    Ok((
        Image {
            width: w,
            height: h,
            pixels,
        },
        stats,
    ))
}

/// Outgoing radiance at the surface point `hit` towards where its ray came
/// from: its direct light plus the bounces `depth` asks for, counted from
/// `hit` ([`Depth::OneBounce`]: `albedo · L_direct` of one cosine-sampled
/// point it sees). One path, with its own generator seeded from `seed`
/// (deterministic); `stats` adds what it did. The tools that judge the
/// indirect light at a pixel's centre (`gibake-eval`) average many of
/// these at the points a receiver sees.
pub fn hit_radiance(
    rs: &RayScene<'_>,
    hit: &Hit,
    depth: Depth,
    seed: u64,
    stats: &mut PathStats,
) -> Vec3 {
    let mut rng = Pcg32::new(rng::splitmix64(seed), rng::splitmix64(!seed));
    let max = depth.max_bounces().min(MAX_BOUNCES);
    let (l, s) = trace_path(rs, *hit, max, depth == Depth::Every, &mut rng);
    stats.add(s);
    l
}

/// The box-filtered estimate of pixel `(x, y)`.
fn render_pixel(
    rs: &RayScene<'_>,
    view: &View,
    s: &Settings,
    x: u32,
    y: u32,
    stats: &mut PathStats,
) -> Vec3 {
    let index = y as u64 * s.width as u64 + x as u64;
    let mut rng = Pcg32::for_pixel(s.seed, index);
    // Stratify the first n² samples on an n×n grid, the rest uniformly.
    let n = (s.spp as f64).sqrt().floor() as u32;
    let strata = n * n;
    let below_one = 1.0 - f32::EPSILON / 2.0;
    let max = s.depth.max_bounces();
    let every = s.depth == Depth::Every;
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
        stats.paths += 1;
        if let Some(hit) = rs.intersect_range(origin, dir, t_min, f32::INFINITY) {
            let (l, st) = trace_path(rs, hit, max, every, &mut rng);
            stats.add(st);
            sum += l.as_dvec3();
        }
    }
    gibake_raycast::sanitize(sum / s.spp as f64)
}

/// Radiance leaving `hit` along the ray that found it: direct light there
/// plus up to `max` cosine-sampled bounces, next-event estimation at every
/// vertex, Russian roulette after bounce [`ROULETTE_FROM`]. With `every`,
/// a path still going at `max` counts as capped. The returned stats count
/// bounces and caps (not the path itself).
///
/// Direct light and the first bounce are summed in f32 exactly as the
/// one-bounce reference always has (`L_direct(x) + albedo(x) · L_direct(y)`,
/// so [`Depth::OneBounce`] is unchanged bit for bit); later bounces in f64
/// with an f64 throughput, clamped to the f32 range (an albedo above 1
/// cannot overflow it into ∞ or NaN).
fn trace_path(
    rs: &RayScene<'_>,
    mut hit: Hit,
    max: u32,
    every: bool,
    rng: &mut Pcg32,
) -> (Vec3, PathStats) {
    let mut stats = PathStats::default();
    let mut first = direct_radiance(rs, &hit);
    let mut later = DVec3::ZERO;
    let mut beta = DVec3::ONE;
    for bounce in 1..=max {
        let (u1, u2) = (rng.next_f32(), rng.next_f32());
        if hit.albedo == Vec3::ZERO {
            break;
        }
        let d = cosine_hemisphere(hit.shading_normal, u1, u2);
        if hit.geometric_normal.dot(d) <= 0.0 {
            break;
        }
        let o = rs.offset_point(hit.position, hit.geometric_normal);
        stats.bounces += 1;
        let Some(y) = rs.intersect(o, d, f32::INFINITY) else {
            break;
        };
        if bounce == 1 {
            first += hit.albedo * direct_radiance(rs, &y);
        } else {
            later += beta * hit.albedo.as_dvec3() * direct_radiance(rs, &y).as_dvec3();
        }
        beta = (beta * hit.albedo.as_dvec3()).min(DVec3::splat(f32::MAX as f64));
        hit = y;
        if bounce == max {
            // Still going: cut here (for `every`, by the cap).
            stats.capped += u64::from(every);
        } else if bounce >= ROULETTE_FROM {
            let q = beta.max_element().min(1.0);
            if f64::from(rng.next_f32()) >= q {
                break;
            }
            beta /= q;
        }
    }
    let l = gibake_raycast::sanitize(first.as_dvec3() + later);
    (l, stats)
}
