//! The judge of the method's indirect light: for a scene, bake it, render
//! `full`, `rsm`, `naive` and `direct`, render the independent CPU
//! reference (one bounce and direct only; with
//! [`EvalSettings::every_bounce`] also every bounce), and compare the
//! indirect parts.
//!
//! Figures, per scene ([`IndirectEval`]):
//! - **mean indirect bias** per channel: `mean(ours) / mean(reference) − 1`
//!   over the image, where the indirect part is `full − direct` (`rsm −
//!   direct`) and the reference's is `one bounce − direct only`;
//! - **indirect error**: RMSE of the two indirect images after a box blur
//!   (radius [`EvalSettings::blur`]), so that the reference's own noise does
//!   not dominate, divided by the reference's mean indirect radiance
//!   (dimensionless);
//! - on scenes without moving objects, `naive` against `full` (they must
//!   agree) and whether every mode has indirect light;
//! - with [`EvalSettings::every_bounce`] ([`EveryBounceEval`]): the same
//!   bias and error against the every-bounce reference (`every bounce −
//!   direct only`), and the every-bounce ÷ one-bounce indirect ratio per
//!   channel. The tests judge against the one-bounce reference (the
//!   method's first bounce is the paper's; the later bounces are another
//!   issue's), so it is off by default: an every-bounce reference costs
//!   1.5–20× a one-bounce one (the bounces a path makes).
//!
//! Used by the tests (`tests/indirect_accuracy.rs`, 20 random seeds at a
//! small size) and by `gibake bench accuracy` (more seeds, full size).
//!
//! Also the tools' helpers around the runtime that a game does not need:
//! [`frame`] (render a scene's own frame, read an output back),
//! [`transport`] (the CPU twin of the shading's VPL transport),
//! [`moving`] (what moving objects change in a level's indirect light,
//! judged with correlated reference renders) and [`view_diff`] (the
//! image-space diff of two bakes of one level, `gibake diff --scene`).

pub mod bounce;
pub mod fit;
pub mod flip;
pub mod frame;
pub mod levels;
pub mod lights;
pub mod moving;
pub mod pareto;
pub mod transport;
pub mod view_diff;

use gibake_asset::Asset;
use gibake_gpu::GpuContext;
use gibake_image::Image;
use gibake_runtime::{Mode, RenderSettings};
use gibake_scene::Scene;
use glam::Vec3;

/// What to measure with.
#[derive(Clone, Debug)]
pub struct EvalSettings {
    /// Image width and height.
    pub size: u32,
    /// Reference samples per pixel (one-bounce image; the direct-only one
    /// uses a quarter).
    pub spp: u32,
    /// VPL budget of the bake.
    pub vpls: u32,
    /// RSM resolution.
    pub rsm_size: u32,
    /// Hemisphere map resolution.
    pub vpl_map_size: u32,
    /// Primary shadow map resolution (`gibake bake --shadow-map-size`).
    pub shadow_map_size: u32,
    /// Scene time.
    pub time: f32,
    /// Box-blur radius in pixels for the error.
    pub blur: u32,
    /// Supersampling of the GPU renders (the reference integrates each
    /// pixel's area).
    pub ssaa: u32,
    /// Most dynamic VPLs per frame.
    pub max_dynamic_vpls: u32,
    /// Shadow cascades of the direct light (automatic by default).
    pub cascades: gibake_runtime::Cascades,
    /// Whether the asset keeps the other lights' view RSMs (format 4.1:
    /// their bounce off moving objects); false measures what they change
    /// (the asset renders as a 4.0 asset did).
    pub light_bounce: bool,
    /// Whether [`levels::judge_level`] renders `naive` against `full`.
    /// `naive` re-renders every VPL map each frame: on lavapipe it is 90% of
    /// a judgement's time at 664 VPLs, so the suite's frame-level tests
    /// turn it off and check naive = full apart with fewer VPLs
    /// ([`levels::naive_against_full`]); the eval tools keep it.
    pub naive: bool,
    /// The runtime's near-field descent
    /// ([`RenderSettings::near_field_descent`]).
    pub near_field_descent: u32,
    /// The runtime's later-bounce near-field descent
    /// ([`RenderSettings::later_near_field_descent`]).
    pub later_near_field_descent: u32,
    /// With [`EvalSettings::every_bounce_bake`], also render the default
    /// bake at each of these later-bounce descents and judge each against
    /// the every-bounce reference ([`EveryBounceBake::later_descents`]):
    /// what the later VPLs' near-field trees buy.
    pub later_descent_sweep: Vec<u32>,
    /// The later bounces' VPL budget of the every-bounce bake (`gibake
    /// bake --later-vpls`; `None`: the default, a quarter of the first
    /// bounce's).
    pub later_vpls: Option<u32>,
    /// Also render the every-bounce reference ([`ReferenceImages::every`],
    /// same samples per pixel as the one-bounce image) and judge against
    /// it too ([`IndirectEval::every`]). Off by default (the tests judge
    /// the one-bounce method against the one-bounce reference); the eval
    /// tools turn it on.
    pub every_bounce: bool,
    /// With [`EvalSettings::every_bounce`], also bake with every bounce
    /// (the default of `gibake bake`) and judge its `full` against the
    /// every-bounce reference ([`EveryBounceEval::baked`]); the figures
    /// against one bounce stay those of the one-bounce bake. On in the
    /// eval tools.
    pub every_bounce_bake: bool,
    /// Whether the asset keeps its VPLs' second origins and maps (format
    /// 4.7, `gibake_bake::horizon`); false renders it as a 4.6 asset did
    /// (a receiver below a VPL's horizon answered by its first map's rim):
    /// what they change is measured against this ([`without_second_maps`]).
    pub second_maps: bool,
}

impl Default for EvalSettings {
    fn default() -> Self {
        EvalSettings {
            size: 64,
            spp: 256,
            vpls: 664,
            rsm_size: 512,
            vpl_map_size: 128,
            shadow_map_size: 2048,
            time: 0.5,
            blur: 1,
            ssaa: 2,
            max_dynamic_vpls: RenderSettings::default().max_dynamic_vpls,
            cascades: gibake_runtime::Cascades::Auto,
            light_bounce: true,
            naive: true,
            near_field_descent: RenderSettings::default().near_field_descent,
            later_near_field_descent: RenderSettings::default().later_near_field_descent,
            later_descent_sweep: Vec::new(),
            later_vpls: None,
            every_bounce: false,
            every_bounce_bake: false,
            second_maps: true,
        }
    }
}

/// Why an evaluation failed.
#[derive(Debug, thiserror::Error)]
pub enum EvalError {
    /// The bake failed.
    #[error(transparent)]
    Bake(#[from] gibake_bake::BakeError),
    /// Rendering failed.
    #[error(transparent)]
    Runtime(#[from] gibake_runtime::RuntimeError),
    /// The reference failed.
    #[error(transparent)]
    Reference(#[from] gibake_reference::ReferenceError),
}

/// The figures of one scene.
#[derive(Clone, Debug, serde::Serialize)]
pub struct IndirectEval {
    /// Scene name.
    pub name: String,
    /// VPLs baked.
    pub vpls: usize,
    /// Whether the scene has moving objects.
    pub has_dynamic: bool,
    /// Reference mean indirect radiance (RGB).
    pub ref_mean: [f32; 3],
    /// Standard error of the reference's mean indirect radiance, relative
    /// to it, per channel (from two independent halves of its samples).
    pub ref_noise: [f32; 3],
    /// `full`'s mean indirect bias per channel (0.05 = 5% too bright).
    pub full_bias: [f32; 3],
    /// `rsm`'s mean indirect bias per channel.
    pub rsm_bias: [f32; 3],
    /// `full`'s relative indirect error.
    pub full_err: f64,
    /// `rsm`'s relative indirect error.
    pub rsm_err: f64,
    /// rel MSE of `naive` against `full` (NaN where `naive` was not
    /// rendered: moving objects, or [`EvalSettings::naive`] off).
    pub naive_vs_full: f64,
    /// Per mode (`full`, `indirect`, `rsm`, and `naive` where rendered): mean indirect radiance
    /// (sum of channels) — all must be positive where the reference's is.
    pub mode_indirect: Vec<(String, f32)>,
    /// The figures against the every-bounce reference
    /// ([`EvalSettings::every_bounce`]; `None` when it was not rendered).
    pub every: Option<EveryBounceEval>,
}

/// `full` and `rsm` judged against the every-bounce reference (`every
/// bounce − direct only`), beside [`IndirectEval`]'s one-bounce figures.
#[derive(Clone, Debug, serde::Serialize)]
pub struct EveryBounceEval {
    /// The every-bounce reference's mean indirect radiance (RGB).
    pub ref_mean: [f32; 3],
    /// Its standard error, relative, per channel (two halves of its samples).
    pub ref_noise: [f32; 3],
    /// Every-bounce indirect ÷ one-bounce indirect, per channel: what the
    /// later bounces add (1: nothing).
    pub ratio: [f32; 3],
    /// `full`'s mean indirect bias against it, per channel.
    pub full_bias: [f32; 3],
    /// `rsm`'s mean indirect bias against it.
    pub rsm_bias: [f32; 3],
    /// `full`'s relative indirect error against it (blurred, as
    /// [`IndirectEval::full_err`]).
    pub full_err: f64,
    /// Bounce rays a path of the every-bounce reference made.
    pub mean_bounces: f64,
    /// Its paths cut at [`gibake_reference::MAX_BOUNCES`].
    pub capped: u64,
    /// The default bake (every bounce, `gibake bake` without `--bounces`)
    /// judged against it: `None` when not rendered.
    pub baked: Option<EveryBounceBake>,
}

/// `full` of the default bake — the first bounce's VPLs and the later
/// bounces' ([`gibake_bake::later`]) — against the every-bounce reference.
#[derive(Clone, Debug, serde::Serialize)]
pub struct EveryBounceBake {
    /// Its VPLs, the later bounces' included.
    pub vpls: usize,
    /// The later bounces' VPLs (0: left out).
    pub later_vpls: u32,
    /// Its bake time, seconds (the later bounces included).
    pub bake_s: f64,
    /// `full`'s mean indirect bias against the every-bounce reference.
    pub full_bias: [f32; 3],
    /// `full`'s relative indirect error against it (blurred).
    pub full_err: f64,
    /// [`EvalSettings::later_descent_sweep`]: per later-bounce descent,
    /// `full`'s bias and error as above.
    pub later_descents: Vec<(u32, [f32; 3], f64)>,
}

impl EveryBounceEval {
    /// The figures of `full` and `rsm` (indirect parts) against
    /// `reference` (the every-bounce reference's indirect part, with its
    /// noise and path stats) and `one` (the one-bounce reference's mean
    /// indirect radiance).
    pub fn new(
        full: &Image,
        rsm: &Image,
        reference: &EveryBounceImage,
        direct: &Image,
        one: Vec3,
        blur: u32,
    ) -> EveryBounceEval {
        let ind = reference.image.sub(direct);
        let rm = ind.mean();
        let tiny = Vec3::splat(f32::MIN_POSITIVE);
        EveryBounceEval {
            ref_mean: rm.to_array(),
            ref_noise: (reference.noise / rm.max(tiny)).to_array(),
            ratio: (rm / one.max(tiny)).to_array(),
            full_bias: bias(full.mean(), rm),
            rsm_bias: bias(rsm.mean(), rm),
            full_err: indirect_error(full, &ind, blur),
            mean_bounces: reference.stats.mean_bounces(),
            capped: reference.stats.capped,
            baked: None,
        }
    }

    /// Bakes `scene` with every bounce (the default of `gibake bake`),
    /// renders its `full` and adds it to the judgement against `reference`
    /// (`ref_direct`: the reference's direct light, `direct`: the
    /// renderer's, subtracted from `full`). Returns the judgement and the
    /// `full` image.
    pub fn with_default_bake(
        mut self,
        ctx: &GpuContext,
        scene: &Scene,
        s: &EvalSettings,
        reference: &EveryBounceImage,
        ref_direct: &Image,
        direct: &Image,
    ) -> Result<(EveryBounceEval, Image), EvalError> {
        let t = std::time::Instant::now();
        let asset = bake_bounces(ctx, scene, s, gibake_bake::later::Bounces::Every)?;
        let bake_s = t.elapsed().as_secs_f64();
        let full = render(ctx, scene, &asset, Mode::Full, s)?;
        let (ind, ref_ind) = (full.sub(direct), reference.image.sub(ref_direct));
        let mut later_descents = Vec::new();
        for &d in &s.later_descent_sweep {
            let sd = EvalSettings {
                later_near_field_descent: d,
                ..s.clone()
            };
            let ind = render(ctx, scene, &asset, Mode::Full, &sd)?.sub(direct);
            later_descents.push((
                d,
                bias(ind.mean(), ref_ind.mean()),
                indirect_error(&ind, &ref_ind, s.blur),
            ));
        }
        self.baked = Some(EveryBounceBake {
            vpls: asset.vpls.len(),
            later_vpls: asset.manifest.later_vpls(),
            bake_s,
            full_bias: bias(ind.mean(), ref_ind.mean()),
            full_err: indirect_error(&ind, &ref_ind, s.blur),
            later_descents,
        });
        Ok((self, full))
    }

    /// The part of [`IndirectEval::line`] it adds.
    pub fn line(&self) -> String {
        let pct =
            |b: [f32; 3]| format!("{:+.1}/{:+.1}/{:+.1}%", b[0] * 1e2, b[1] * 1e2, b[2] * 1e2);
        format!(
            "every bounce ×{:.2}/{:.2}/{:.2} of one: bias full {} rsm {} (ref ±{:.1}%, {:.1} bounces a path{}) err full {:.4}",
            self.ratio[0],
            self.ratio[1],
            self.ratio[2],
            pct(self.full_bias),
            pct(self.rsm_bias),
            300.0 * self.ref_noise.iter().fold(0f32, |a, b| a.max(*b)),
            self.mean_bounces,
            if self.capped > 0 {
                format!(", {} cut at the cap", self.capped)
            } else {
                String::new()
            },
            self.full_err,
        ) + &self.baked.as_ref().map_or(String::new(), |b| {
            format!(
                "; every-bounce bake ({} later VPLs): bias {} err {:.4}",
                b.later_vpls,
                pct(b.full_bias),
                b.full_err
            ) + &b
                .later_descents
                .iter()
                .map(|(d, bi, e)| format!("; later descent {d}: bias {} err {e:.4}", pct(*bi)))
                .collect::<String>()
        })
    }
}

impl IndirectEval {
    /// The largest absolute per-channel bias of `full`.
    pub fn worst_full_bias(&self) -> f32 {
        self.full_bias.iter().fold(0f32, |a, b| a.max(b.abs()))
    }

    /// Whether `full`'s mean indirect light is within `tol` (0.05 = ±5%)
    /// of the reference's in every channel, beyond three standard errors
    /// of the reference's own mean.
    pub fn full_bias_within(&self, tol: f32) -> bool {
        (0..3).all(|c| self.full_bias[c].abs() <= tol + 3.0 * self.ref_noise[c])
    }

    /// One line for logs: the figures against the one-bounce reference
    /// ("bias full … rsm …"), then, where rendered, those against the
    /// every-bounce reference ([`EveryBounceEval::line`]).
    pub fn line(&self) -> String {
        let pct =
            |b: [f32; 3]| format!("{:+.1}/{:+.1}/{:+.1}%", b[0] * 1e2, b[1] * 1e2, b[2] * 1e2);
        format!(
            "{:<44} vpls {:>4} | vs one bounce: bias full {} rsm {} (ref ±{:.1}%) | err full {:.4} rsm {:.4} ({:.2}×) | naive~full {}{}",
            self.name,
            self.vpls,
            pct(self.full_bias),
            pct(self.rsm_bias),
            300.0 * self.ref_noise.iter().fold(0f32, |a, b| a.max(*b)),
            self.full_err,
            self.rsm_err,
            self.full_err / self.rsm_err.max(1e-12),
            if self.naive_vs_full.is_nan() {
                "not rendered".to_string()
            } else {
                format!("{:.1e}", self.naive_vs_full)
            },
            self.every
                .as_ref()
                .map_or(String::new(), |e| format!(" | vs {}", e.line()))
        )
    }
}

/// Loads GLB bytes as a scene named `name`.
pub fn load(bytes: &[u8], name: &str) -> Scene {
    gibake_scene::load_from_slice(bytes, std::path::Path::new(name), &Default::default())
        .expect("generated scenes load")
}

/// A glTF file with every one of its lights, from a diagnostic's argument
/// `FILE.glb[:K]`: with `:K`, its light `K` alone. `None` when `spec`
/// names no glTF file (no `.gl` in it).
pub fn load_gltf_lights(spec: &str) -> Option<Scene> {
    if !spec.contains(".gl") {
        return None;
    }
    let (file, only) = match spec.rsplit_once(':') {
        Some((f, k)) if k.parse::<usize>().is_ok() => (f, k.parse::<usize>().ok()),
        _ => (spec, None),
    };
    let mut scene = gibake_scene::load(
        std::path::Path::new(file),
        &gibake_scene::LoadOptions::default(),
    )
    .expect("the file loads");
    if let Some(k) = only {
        scene.lights = vec![scene.lights[k].clone()];
    }
    Some(scene)
}

/// The random scene of `seed` and a name describing it.
pub fn random_scene(seed: u64) -> (Scene, String) {
    let (bytes, info) = gibake_scenegen::random(seed, &Default::default());
    let name = format!("seed {seed}: {info}");
    (load(&bytes, &format!("random_{seed}.glb")), name)
}

/// Bakes `scene` with the evaluation's settings.
pub fn bake(ctx: &GpuContext, scene: &Scene, s: &EvalSettings) -> Result<Asset, EvalError> {
    bake_bounces(ctx, scene, s, gibake_bake::later::Bounces::Count(1))
}

/// Bakes `scene` with the evaluation's settings and `bounces`
/// ([`bake`]: the first bounce alone, what the one-bounce judge checks).
pub fn bake_bounces(
    ctx: &GpuContext,
    scene: &Scene,
    s: &EvalSettings,
    bounces: gibake_bake::later::Bounces,
) -> Result<Asset, EvalError> {
    let opts = gibake_bake::BakeOptions {
        rsm_size: s.rsm_size,
        vpl_map_size: s.vpl_map_size,
        shadow_map_size: s.shadow_map_size,
        target: gibake_bake::cluster::ClusterTarget::Count(s.vpls),
        bounces,
        later_vpls: s.later_vpls,
    };
    let asset = gibake_bake::bake(ctx, scene, &opts, &gibake_bake::NoProgress, "eval")?.asset;
    let asset = if s.second_maps {
        asset
    } else {
        without_second_maps(asset)
    };
    Ok(if s.light_bounce {
        asset
    } else {
        without_view_rsms(asset)
    })
}

/// `asset` without its VPLs' second origins and maps (format 4.7), as a
/// 4.6 asset renders: a receiver below a VPL's horizon is looked up on its
/// first map's rim. What they change is measured against this.
pub fn without_second_maps(mut asset: Asset) -> Asset {
    asset.vpl_lower.clear();
    asset.vpl_lower_maps = gibake_asset::MapAtlas::empty(asset.manifest.settings.vpl_map_size);
    asset.manifest.lower_map_count = 0;
    asset
}

/// `asset` without the other lights' view RSMs (format 4.1), as a 4.0
/// bake renders: no bounce off moving objects in the lights after the
/// first. What they change is measured against this.
pub fn without_view_rsms(mut asset: Asset) -> Asset {
    asset.view_rsms.clear();
    asset.manifest.view_rsms.clear();
    asset
}

/// What the moving objects change in the reference's mean indirect light:
/// the reference of `scene` less that of its static part (per channel).
pub fn reference_moving_effect(scene: &Scene, s: &EvalSettings) -> Result<Vec3, EvalError> {
    let still = gibake_bake::static_only(scene);
    let mean = |scene: &Scene| -> Result<Vec3, EvalError> {
        Ok(reference_images(scene, s)?.indirect().mean())
    };
    Ok(mean(scene)? - mean(&still)?)
}

/// Renders one mode.
pub fn render(
    ctx: &GpuContext,
    scene: &Scene,
    asset: &Asset,
    mode: Mode,
    s: &EvalSettings,
) -> Result<Image, EvalError> {
    let rs = RenderSettings {
        width: s.size,
        height: s.size,
        mode,
        max_dynamic_vpls: s.max_dynamic_vpls,
        cascades: s.cascades,
        near_field_descent: s.near_field_descent,
        later_near_field_descent: s.later_near_field_descent,
        ..Default::default()
    };
    Ok(frame::render_image(
        &ctx.device,
        &ctx.queue,
        scene,
        Some(asset),
        &rs,
        s.time,
        s.ssaa,
    )?)
}

/// The reference's images: direct + one bounce (the mean of two independent
/// halves of the samples, seeds 0 and 1), direct only (seed 2), and the
/// standard error of the one-bounce image's mean per channel, estimated
/// from the two halves; with [`EvalSettings::every_bounce`], every bounce
/// too ([`reference_every_bounce`]).
pub struct ReferenceImages {
    /// Direct light plus one bounce (path depth 3).
    pub one_bounce: Image,
    /// Direct light only (path depth 2).
    pub direct: Image,
    /// Standard error of `one_bounce`'s mean radiance per channel.
    pub noise: Vec3,
    /// Direct light plus every bounce, where rendered.
    pub every: Option<EveryBounceImage>,
}

/// The every-bounce reference image ([`reference_every_bounce`]).
pub struct EveryBounceImage {
    /// Direct light plus every bounce: the mean of two halves of the
    /// samples, seeds 0 and 1 (the one-bounce halves' seeds: each path's
    /// first bounce is the one-bounce image's, so the two differ by the
    /// later bounces of the same paths, not by independent noise).
    pub image: Image,
    /// Standard error of its mean radiance per channel (the two halves).
    pub noise: Vec3,
    /// What its paths did (both halves).
    pub stats: gibake_reference::PathStats,
}

impl ReferenceImages {
    /// The indirect part: one bounce minus direct only.
    pub fn indirect(&self) -> Image {
        self.one_bounce.sub(&self.direct)
    }

    /// The every-bounce indirect part: every bounce minus direct only
    /// (`None` where it was not rendered).
    pub fn indirect_every(&self) -> Option<Image> {
        self.every.as_ref().map(|e| e.image.sub(&self.direct))
    }
}

/// The reference renders [`ReferenceImages`] is made of: the two halves of
/// the one-bounce samples (seeds 0 and 1) and the direct-only image (seed
/// 2, a quarter of the samples, at least 16). The same seeds for every
/// scene: renders of two scenes are correlated (`moving`).
pub fn reference_renders(scene: &Scene, s: &EvalSettings) -> Result<[Image; 3], EvalError> {
    let r = |depth, spp, seed| {
        gibake_reference::render(
            scene,
            &gibake_reference::Settings {
                width: s.size,
                height: s.size,
                spp,
                time: s.time,
                depth,
                seed,
            },
            &|_| {},
        )
    };
    let half = (s.spp / 2).max(1);
    Ok([
        r(gibake_reference::Depth::OneBounce, half, 0)?,
        r(gibake_reference::Depth::OneBounce, half, 1)?,
        r(gibake_reference::Depth::Direct, (s.spp / 4).max(16), 2)?,
    ])
}

/// The mean of two independent renders and the standard error of its mean
/// radiance per channel.
fn mean_of_halves(a: &Image, b: &Image) -> (Image, Vec3) {
    let mut full = Image::new(a.width, a.height);
    let mut var = Vec3::ZERO;
    for (k, (p, q)) in a.pixels.iter().zip(&b.pixels).enumerate() {
        full.pixels[k] = (*p + *q) * 0.5;
        // Var of the pixel's estimate ≈ (p − q)²/4.
        var += (*p - *q) * (*p - *q) * 0.25;
    }
    let n = a.pixels.len().max(1) as f32;
    (full, (var / (n * n)).map(f32::sqrt))
}

/// The direct-only reference image of [`reference_renders`] alone (seed 2,
/// a quarter of the samples, at least 16).
fn reference_renders_direct(scene: &Scene, s: &EvalSettings) -> Result<Image, EvalError> {
    Ok(gibake_reference::render(
        scene,
        &gibake_reference::Settings {
            width: s.size,
            height: s.size,
            spp: (s.spp / 4).max(16),
            time: s.time,
            depth: gibake_reference::Depth::Direct,
            seed: 2,
        },
        &|_| {},
    )?)
}

/// Renders the reference images of `scene` (see [`ReferenceImages`]).
pub fn reference_images(scene: &Scene, s: &EvalSettings) -> Result<ReferenceImages, EvalError> {
    let [a, b, direct] = reference_renders(scene, s)?;
    let (one_bounce, noise) = mean_of_halves(&a, &b);
    let every = if s.every_bounce {
        Some(reference_every_bounce(scene, s)?)
    } else {
        None
    };
    Ok(ReferenceImages {
        one_bounce,
        direct,
        noise,
        every,
    })
}

/// The every-bounce reference of `scene`: two halves of `s.spp` samples
/// per pixel ([`gibake_reference::Depth::Every`], seeds 0 and 1, as the
/// one-bounce halves of [`reference_renders`]).
pub fn reference_every_bounce(
    scene: &Scene,
    s: &EvalSettings,
) -> Result<EveryBounceImage, EvalError> {
    let half = (s.spp / 2).max(1);
    let mut stats = gibake_reference::PathStats::default();
    let mut r = |seed| -> Result<Image, EvalError> {
        let (img, st) = gibake_reference::render_with_stats(
            scene,
            &gibake_reference::Settings {
                width: s.size,
                height: s.size,
                spp: half,
                time: s.time,
                depth: gibake_reference::Depth::Every,
                seed,
            },
            &|_| {},
        )?;
        stats.paths += st.paths;
        stats.bounces += st.bounces;
        stats.capped += st.capped;
        Ok(img)
    };
    let (a, b) = (r(0)?, r(1)?);
    let (image, noise) = mean_of_halves(&a, &b);
    Ok(EveryBounceImage {
        image,
        noise,
        stats,
    })
}

/// The reference's indirect part (one bounce minus direct only) and the
/// standard error of its mean per channel (see [`reference_images`]).
pub fn reference_indirect(scene: &Scene, s: &EvalSettings) -> Result<(Image, Vec3), EvalError> {
    let r = reference_images(scene, s)?;
    Ok((r.indirect(), r.noise))
}

/// Box blur of radius `r` (clamped at the borders).
pub fn blur(img: &Image, r: u32) -> Image {
    let (w, h) = (img.width as i64, img.height as i64);
    let r = r as i64;
    let mut out = Image::new(img.width, img.height);
    for y in 0..h {
        for x in 0..w {
            let mut s = Vec3::ZERO;
            let mut n = 0.0;
            for yy in (y - r).max(0)..=(y + r).min(h - 1) {
                for xx in (x - r).max(0)..=(x + r).min(w - 1) {
                    s += img.get(xx as u32, yy as u32);
                    n += 1.0;
                }
            }
            out.set(x as u32, y as u32, s / n);
        }
    }
    out
}

/// Relative indirect error (see the module docs).
pub fn indirect_error(ours: &Image, reference: &Image, r: u32) -> f64 {
    let (a, b) = (blur(ours, r), blur(reference, r));
    let mut sq = 0.0f64;
    for (p, q) in a.pixels.iter().zip(&b.pixels) {
        sq += f64::from((*p - *q).length_squared());
    }
    let rmse = (sq / (3.0 * a.pixels.len().max(1) as f64)).sqrt();
    let m = reference.mean();
    let mean = f64::from(m.x + m.y + m.z) / 3.0;
    rmse / mean.max(f64::MIN_POSITIVE)
}

pub(crate) fn bias(ours: Vec3, reference: Vec3) -> [f32; 3] {
    let b = ours / reference.max(Vec3::splat(f32::MIN_POSITIVE)) - Vec3::ONE;
    b.to_array()
}

/// Evaluates `scene` (see the module docs); the `indirect` and `naive`
/// modes only if `with_naive` (for a scene without moving objects), and
/// `naive` only if [`EvalSettings::naive`] too (`naive_vs_full` is NaN
/// where it was not rendered; a test checks naive = full apart with fewer
/// VPLs: [`levels::naive_against_full`]).
pub fn evaluate(
    ctx: &GpuContext,
    scene: &Scene,
    name: &str,
    s: &EvalSettings,
    with_naive: bool,
) -> Result<IndirectEval, EvalError> {
    let reference = reference_indirect(scene, s)?;
    evaluate_with(ctx, scene, name, s, with_naive, reference)
}

/// Like [`evaluate`], but only if the reference can judge the scene: its
/// mean indirect radiance has a relative standard error at most
/// `max_noise` in every channel (a camera that sees almost no indirect
/// light gives a reference that is all noise). `None` otherwise, without
/// baking.
pub fn evaluate_if_judgeable(
    ctx: &GpuContext,
    scene: &Scene,
    name: &str,
    s: &EvalSettings,
    with_naive: bool,
    max_noise: f32,
) -> Result<Option<IndirectEval>, EvalError> {
    let reference = reference_indirect(scene, s)?;
    let m = reference.0.mean();
    let ok = (0..3).all(|c| m[c] > 0.0 && reference.1[c] <= max_noise * m[c]);
    if !ok {
        return Ok(None);
    }
    evaluate_with(ctx, scene, name, s, with_naive, reference).map(Some)
}

fn evaluate_with(
    ctx: &GpuContext,
    scene: &Scene,
    name: &str,
    s: &EvalSettings,
    with_naive: bool,
    (reference, noise): (Image, Vec3),
) -> Result<IndirectEval, EvalError> {
    let asset = bake(ctx, scene, s)?;
    let direct = render(ctx, scene, &asset, Mode::Direct, s)?;
    let full = render(ctx, scene, &asset, Mode::Full, s)?.sub(&direct);
    // `indirect` is full's indirect part (checked on static scenes).
    let indirect = if with_naive {
        render(ctx, scene, &asset, Mode::Indirect, s)?
    } else {
        full.clone()
    };
    let rsm = render(ctx, scene, &asset, Mode::Rsm, s)?.sub(&direct);
    let every = if s.every_bounce {
        let e = reference_every_bounce(scene, s)?;
        // The one-bounce indirect reference came as one image: its direct
        // part is rendered again here (the same seed, so the same image).
        let ref_direct = reference_renders_direct(scene, s)?;
        let judged = EveryBounceEval::new(&full, &rsm, &e, &ref_direct, reference.mean(), s.blur);
        Some(if s.every_bounce_bake {
            judged
                .with_default_bake(ctx, scene, s, &e, &ref_direct, &direct)?
                .0
        } else {
            judged
        })
    } else {
        None
    };
    // Naive re-renders every map each frame (slow); it must equal full.
    let naive = if with_naive && s.naive {
        Some(render(ctx, scene, &asset, Mode::Naive, s)?.sub(&direct))
    } else {
        None
    };
    let rm = reference.mean();
    let sum = |i: &Image| {
        let m = i.mean();
        m.x + m.y + m.z
    };
    Ok(IndirectEval {
        name: name.to_string(),
        vpls: asset.vpls.len(),
        has_dynamic: !scene.dynamic_objects.is_empty(),
        ref_mean: rm.to_array(),
        ref_noise: (noise / rm.max(Vec3::splat(f32::MIN_POSITIVE))).to_array(),
        full_bias: bias(full.mean(), rm),
        rsm_bias: bias(rsm.mean(), rm),
        full_err: indirect_error(&full, &reference, s.blur),
        rsm_err: indirect_error(&rsm, &reference, s.blur),
        naive_vs_full: naive
            .as_ref()
            .map_or(f64::NAN, |n| gibake_image::rel_mse(n, &full)),
        mode_indirect: [
            ("full".into(), sum(&full)),
            ("indirect".into(), sum(&indirect)),
            ("rsm".into(), sum(&rsm)),
        ]
        .into_iter()
        .chain(naive.as_ref().map(|n| ("naive".into(), sum(n))))
        .collect(),
        every,
    })
}
