//! Every render of `gibake bench` goes through this file: [`new_renderer`]
//! is the one place that creates a [`Renderer`], [`one_frame`] the one that
//! records and submits a frame, so that a change of the runtime API touches
//! only these two functions. Also the per-frame statistics (medians over
//! measured frames) and the side-by-side measurement of several
//! configurations.

use std::time::Instant;

use crate::error::{Context, bail};
use gibake_asset::Asset;
use gibake_gpu::GpuContext;
use gibake_image::Image;
use gibake_runtime::{FrameStats, Mode, Pass, RenderSettings, Renderer};
use gibake_scene::Scene;
use serde_json::{Value, json};

use super::{Bench, FRAME_STEP_S, median};

/// Creates a renderer for `scene` (the one place that does; the time of a
/// frame is set by [`one_frame`]).
pub(super) fn new_renderer(
    ctx: &GpuContext,
    scene: &Scene,
    asset: Option<&Asset>,
    settings: &RenderSettings,
) -> crate::Result<Renderer> {
    Renderer::new(&ctx.device, &ctx.queue, scene, asset, settings)
        .with_context(|| format!("setting up {}", scene.source.display()))
}

/// Medians over the measured frames of one configuration.
#[derive(Clone, Debug)]
pub(super) struct FrameSummary {
    pub(super) timing: String,
    pub(super) update_ms: f64,
    pub(super) shade_ms: f64,
    pub(super) gbuffer_ms: f64,
    pub(super) frame_ms: f64,
    pub(super) wall_ms: f64,
    pub(super) passes: Vec<(String, f64)>,
    pub(super) affected_maps: f64,
    /// Views of the lights after the first merged (moving objects in them).
    pub(super) light_views: f64,
    /// Views of the lights after the first whose bounce off moving objects
    /// was computed (`Pass::LightBounce`).
    pub(super) light_bounce_views: f64,
    pub(super) bounce_texels: f64,
    pub(super) update_draw_calls: f64,
    pub(super) draw_calls: f64,
    pub(super) static_vpls: u32,
    pub(super) dynamic_slots: u32,
    pub(super) frames: usize,
}

impl FrameSummary {
    pub(super) fn json(&self) -> Value {
        json!({
            "timing": self.timing,
            "frames": self.frames,
            "update_ms": self.update_ms,
            "shade_ms": self.shade_ms,
            "gbuffer_ms": self.gbuffer_ms,
            "frame_ms": self.frame_ms,
            "wall_ms": self.wall_ms,
            "passes_ms": self.passes.iter().map(|(n, ms)| json!({"pass": n, "ms": ms})).collect::<Vec<_>>(),
            "affected_maps": self.affected_maps,
            "light_views_merged": self.light_views,
            "light_views_bounced": self.light_bounce_views,
            "bounce_texels": self.bounce_texels,
            "update_draw_calls": self.update_draw_calls,
            "draw_calls": self.draw_calls,
            "static_vpls": self.static_vpls,
            "dynamic_vpl_slots": self.dynamic_slots,
        })
    }
}

pub(super) fn pass_ms(s: &FrameStats, pass: Pass) -> f64 {
    s.pass_ms(pass)
}

pub(super) fn summarize(frames: &[(FrameStats, f64)]) -> FrameSummary {
    let col = |f: &dyn Fn(&FrameStats) -> f64| -> f64 {
        median(&frames.iter().map(|(s, _)| f(s)).collect::<Vec<_>>())
    };
    let first = &frames[0].0;
    let names: Vec<Pass> = first.passes.iter().map(|(n, _)| *n).collect();
    FrameSummary {
        timing: first.timing.to_string(),
        update_ms: col(&|s| s.update_ms()),
        shade_ms: col(&shade_ms),
        gbuffer_ms: col(&|s| pass_ms(s, Pass::GBuffer)),
        frame_ms: col(&|s| s.frame_ms),
        wall_ms: median(&frames.iter().map(|(_, w)| *w).collect::<Vec<_>>()),
        passes: names
            .iter()
            .map(|n| (n.name().to_string(), col(&|s| pass_ms(s, *n))))
            .collect(),
        affected_maps: col(&|s| f64::from(s.affected_maps)),
        light_views: col(&|s| f64::from(s.light_views_merged)),
        light_bounce_views: col(&|s| f64::from(s.light_views_bounced)),
        bounce_texels: col(&|s| s.bounce_texels as f64),
        update_draw_calls: col(&|s| f64::from(s.update_draw_calls)),
        draw_calls: col(&|s| f64::from(s.draw_calls)),
        static_vpls: first.static_vpls,
        dynamic_slots: first.dynamic_vpl_slots,
        frames: frames.len(),
    }
}

/// Prepares, records, submits and waits for one frame at `t`; returns its stats and wall ms.
pub(super) fn one_frame(
    ctx: &GpuContext,
    r: &mut Renderer,
    scene: &Scene,
    t: f32,
) -> crate::Result<(FrameStats, f64)> {
    let start = Instant::now();
    r.prepare_at_time(&ctx.device, &ctx.queue, scene, t)?;
    let mut enc = ctx.device.create_command_encoder(&Default::default());
    r.record(&mut enc);
    ctx.queue.submit([enc.finish()]);
    let stats = r.stats(&ctx.device);
    Ok((stats, start.elapsed().as_secs_f64() * 1e3))
}

/// One configuration to measure: a scene, its asset, the settings and how
/// many frames.
pub(super) struct Config<'a> {
    pub(super) scene: &'a Scene,
    pub(super) asset: Option<&'a Asset>,
    pub(super) settings: RenderSettings,
    pub(super) frames: u32,
}

/// Measures several configurations side by side: every renderer is created
/// and gets one warm-up frame (not counted; the first frame pays for
/// first-touch memory), then frame `f` (t = f/30 s) is rendered by each
/// configuration in turn, so that a change in machine load hits all of them
/// alike. Returns the per-configuration medians.
pub(super) fn measure_all(
    ctx: &GpuContext,
    configs: &[Config<'_>],
    on_frame: &dyn Fn(),
) -> crate::Result<Vec<FrameSummary>> {
    let mut live = Vec::with_capacity(configs.len());
    for c in configs {
        let mut r = new_renderer(ctx, c.scene, c.asset, &c.settings)?;
        one_frame(ctx, &mut r, c.scene, 0.0)?;
        on_frame();
        live.push((r, Vec::new()));
    }
    let most = configs.iter().map(|c| c.frames).max().unwrap_or(0);
    for f in 0..most {
        for (c, (r, out)) in configs.iter().zip(live.iter_mut()) {
            if f < c.frames {
                out.push(one_frame(ctx, r, c.scene, f as f32 * FRAME_STEP_S)?);
                on_frame();
            }
        }
    }
    Ok(live.iter().map(|(_, out)| summarize(out)).collect())
}

/// Shade time of a frame: the shade pass plus the interleave filter that
/// reconstructs its sum (0 at interleave 1).
pub(super) fn shade_ms(s: &FrameStats) -> f64 {
    pass_ms(s, Pass::Shade) + pass_ms(s, Pass::Interleave)
}

/// Renders one frame of `mode` at `size`² (ssaa `ssaa`, interleave
/// `interleave`) at time `t` and measures it: a warm-up frame first (the
/// first frame pays for first-touch memory) unless `b.quick`, then the
/// measured one, read back and checked finite.
#[allow(clippy::too_many_arguments)]
pub(super) fn render_measured(
    b: &Bench,
    scene: &Scene,
    asset: Option<&Asset>,
    mode: Mode,
    size: u32,
    ssaa: u32,
    interleave: u32,
    t: f32,
) -> crate::Result<(Image, FrameStats)> {
    let settings = RenderSettings {
        width: size * ssaa,
        height: size * ssaa,
        shadow_map_size: 2048,
        mode,
        max_dynamic_vpls: 64,
        interleave,
        max_spawned: 0,
        ..Default::default()
    };
    let mut r = new_renderer(&b.ctx, scene, asset, &settings)?;
    if !b.quick {
        one_frame(&b.ctx, &mut r, scene, t)?;
    }
    let (stats, _) = one_frame(&b.ctx, &mut r, scene, t)?;
    let img = gibake_eval::frame::read_output(&r, &b.ctx.device, &b.ctx.queue, ssaa)?;
    if !img.all_finite() {
        bail!(
            "{}: mode {mode:?} (interleave {interleave}) rendered non-finite pixels",
            scene.source.display()
        );
    }
    Ok((img, stats))
}

/// Sum of every pass of a frame (ms).
pub(super) fn frame_total(s: &FrameStats) -> f64 {
    s.frame_ms
}
