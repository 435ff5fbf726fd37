//! Per-frame figures ([`FrameStats`]) and the GPU timer behind them.
//!
//! Each frame's counts are fixed by [`crate::Renderer::prepare`]; its pass
//! times come from timestamp queries (when the adapter has them; else one
//! wall time) resolved at the end of [`crate::Renderer::record`] into one
//! of [`FRAMES_IN_FLIGHT`] read-back buffers, which wgpu maps once the
//! frame's commands are submitted and done. Nothing waits inside a frame:
//! [`crate::Renderer::poll_stats`] returns the newest finished frame's
//! figures (frame N − k) without blocking, [`crate::Renderer::stats`] waits
//! for the last recorded frame (tools, tests).
//!
//! Timer slots are keyed by the typed [`Pass`] id the [`crate::FramePlan`]
//! defines: no pass is looked up by name.

use std::sync::Arc;
use std::sync::atomic::{AtomicU8, Ordering};
use std::time::Instant;

use crate::plan::Pass;

/// Read-back buffers in flight: figures are at most this many frames old
/// when the caller polls every frame.
pub const FRAMES_IN_FLIGHT: usize = 3;

/// How the pass times were measured.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Timing {
    /// GPU timestamp queries, per pass.
    #[default]
    GpuTimestamps,
    /// The adapter has no timestamp queries: one wall time from `prepare`
    /// until the frame's GPU work was seen done.
    Wall,
}

impl Timing {
    /// `"gpu timestamps"` or `"wall (no timestamp queries on this adapter)"`.
    pub fn name(self) -> &'static str {
        match self {
            Timing::GpuTimestamps => "gpu timestamps",
            Timing::Wall => "wall (no timestamp queries on this adapter)",
        }
    }
}

impl std::fmt::Display for Timing {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

impl serde::Serialize for Timing {
    fn serialize<S: serde::Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        s.serialize_str(self.name())
    }
}

/// Per-frame counts and times.
#[derive(Clone, Debug, Default, serde::Serialize)]
pub struct FrameStats {
    /// The frame these figures are of (counting prepares from 1).
    pub frame: u64,
    /// How the times were measured.
    pub timing: Timing,
    /// Per pass `(pass, milliseconds)`, in recording order: the update
    /// passes once, then each view's G-buffer, shading, filter and
    /// composite (GPU timestamps; empty with [`Timing::Wall`]).
    pub passes: Vec<(Pass, f64)>,
    /// Views rendered.
    pub views: u32,
    /// The frame's time: the sum of `passes`, or the wall time.
    pub frame_ms: f64,
    /// Static VPLs shaded.
    pub static_vpls: u32,
    /// Dynamic VPL slots shaded.
    pub dynamic_vpl_slots: u32,
    /// VPL maps into which moving objects were rasterized this frame.
    pub affected_maps: u32,
    /// VPL maps whose hemisphere a moving object reaches but whose baked
    /// surfaces hide it in every direction it covers: left out of the
    /// merge, the image unchanged (`map_cells`).
    pub hidden_maps: u32,
    /// Per moving object (declared ones, then spawned copies, as
    /// [`crate::Renderer`]'s handles): the VPL maps it was rasterized into
    /// this frame. A map two objects reach counts for each.
    pub merge_maps_per_object: Vec<u32>,
    /// The merge's rasterization instances this frame: one per (moving
    /// mesh, map, octahedron face it can touch), each drawing the mesh at
    /// its level of detail for that map — the merge's work.
    pub merge_instances: u32,
    /// (Map, moving draw) pairs the merge left out this frame as faint
    /// shadows ([`crate::RenderSettings::merge_cull_share`]).
    pub merge_faint_pairs: u32,
    /// The later bounces' VPLs' flux scale this frame (linear RGB; each
    /// VPL has its own, this is their flux-weighted mean): what the moving
    /// objects absorb of the light passed on between the static surfaces
    /// (`runtime/src/later_absorb.rs`); 1 without them or without later
    /// VPLs.
    pub later_scale: [f32; 3],
    /// Views that shaded the later bounces' VPLs on the half-resolution
    /// grid this frame ([`crate::RenderSettings::later_full_resolution`]
    /// off, an asset with later-bounce VPLs, interleave above 1); 0: every
    /// view shaded them at every pixel, or there were none.
    pub later_half_views: u32,
    /// Views of the lights after the first into which moving objects were
    /// rasterized this frame (the light merge's passes).
    pub light_views_merged: u32,
    /// The other lights' views whose bounce off moving objects was computed
    /// this frame ([`Pass::LightBounce`]: the views with a stored RSM the
    /// moving objects touch).
    pub light_views_bounced: u32,
    /// RSM texels the moving objects' occlusion test and dynamic-VPL
    /// clustering covered this frame, over every view whose bounce was
    /// computed (the sum of their windows' areas: the update's per-texel
    /// work, the same on any GPU).
    pub bounce_texels: u64,
    /// Draw calls recorded by the per-frame update (merge passes).
    pub update_draw_calls: u32,
    /// Draw calls in total.
    pub draw_calls: u32,
}

impl FrameStats {
    /// Sum of the update passes ([`Pass::is_update`]: everything but the
    /// views' G-buffer, shading and interleave filter).
    pub fn update_ms(&self) -> f64 {
        self.passes
            .iter()
            .filter(|(p, _)| p.is_update())
            .map(|(_, t)| t)
            .sum()
    }

    /// Milliseconds of `pass`, summed over the views (0 when the frame did
    /// not record it).
    pub fn pass_ms(&self, pass: Pass) -> f64 {
        self.passes
            .iter()
            .filter(|(p, _)| *p == pass)
            .map(|(_, t)| t)
            .sum()
    }
}

/// A read-back slot's state (shared with wgpu's map callback).
const IDLE: u8 = 0;
const PENDING: u8 = 1;
const MAPPED: u8 = 2;
const FAILED: u8 = 3;

/// One frame in flight.
struct Slot {
    readback: Option<wgpu::Buffer>,
    state: Arc<AtomicU8>,
    /// When the frame's GPU work was seen done (wall timing).
    done: Arc<std::sync::Mutex<Option<Instant>>>,
    stats: FrameStats,
    /// The passes recorded, with the view each belongs to.
    passes: Vec<(Pass, Option<u32>)>,
    started: Option<Instant>,
}

/// The ring of frames in flight and the timestamp queries.
pub(crate) struct Timer {
    queries: Option<Queries>,
    slots: Vec<Slot>,
    /// The slot of the frame last prepared, if any.
    current: Option<usize>,
    frame: u64,
    /// The counts of the frame last prepared.
    counts: FrameStats,
    latest: Option<FrameStats>,
}

struct Queries {
    set: wgpu::QuerySet,
    resolve: wgpu::Buffer,
    period_ns: f64,
    /// Passes that can be timed per frame.
    capacity: u32,
}

/// Passes timed per frame: every pass of four views.
const PASSES: u32 = 4 * Pass::ALL.len() as u32;

impl Timer {
    /// A timer with GPU timestamps when the device has them.
    pub(crate) fn new(device: &wgpu::Device, queue: &wgpu::Queue) -> Timer {
        let queries = device
            .features()
            .contains(wgpu::Features::TIMESTAMP_QUERY)
            .then(|| Queries {
                set: device.create_query_set(&wgpu::QuerySetDescriptor {
                    label: Some("pass timestamps"),
                    ty: wgpu::QueryType::Timestamp,
                    count: 2 * PASSES,
                }),
                resolve: device.create_buffer(&wgpu::BufferDescriptor {
                    label: Some("timestamp resolve"),
                    size: 16 * u64::from(PASSES),
                    usage: wgpu::BufferUsages::QUERY_RESOLVE | wgpu::BufferUsages::COPY_SRC,
                    mapped_at_creation: false,
                }),
                period_ns: f64::from(queue.get_timestamp_period()),
                capacity: PASSES,
            });
        let slots = (0..FRAMES_IN_FLIGHT)
            .map(|_| Slot {
                readback: queries.as_ref().map(|_| {
                    device.create_buffer(&wgpu::BufferDescriptor {
                        label: Some("timestamp readback"),
                        size: 16 * u64::from(PASSES),
                        usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
                        mapped_at_creation: false,
                    })
                }),
                state: Arc::new(AtomicU8::new(IDLE)),
                done: Arc::default(),
                stats: FrameStats::default(),
                passes: Vec::new(),
                started: None,
            })
            .collect();
        Timer {
            queries,
            slots,
            current: None,
            frame: 0,
            counts: FrameStats::default(),
            latest: None,
        }
    }

    /// Starts frame N + 1 with its counts and the passes it records. A slot
    /// whose frame is still in flight after [`FRAMES_IN_FLIGHT`] frames is
    /// skipped: that frame gets no figures.
    pub(crate) fn begin(&mut self, stats: FrameStats, passes: Vec<(Pass, Option<u32>)>) {
        self.collect();
        self.frame += 1;
        self.counts = FrameStats {
            frame: self.frame,
            timing: if self.queries.is_some() {
                Timing::GpuTimestamps
            } else {
                Timing::Wall
            },
            ..stats
        };
        let k = (self.frame as usize) % FRAMES_IN_FLIGHT;
        let slot = &mut self.slots[k];
        if slot.state.load(Ordering::Acquire) != IDLE {
            self.current = None;
            return;
        }
        slot.stats = self.counts.clone();
        slot.passes = passes;
        slot.started = Some(Instant::now());
        *slot.done.lock().unwrap_or_else(|e| e.into_inner()) = None;
        self.current = Some(k);
    }

    /// Timestamp writes of compute pass `pass` when it is one of several
    /// passes timed as one span (see [`Timer::render_span`]).
    pub(crate) fn compute_span(
        &self,
        pass: Pass,
        first: bool,
        last: bool,
    ) -> Option<wgpu::ComputePassTimestampWrites<'_>> {
        let (set, i) = self.query(pass, None)?;
        (first || last).then_some(wgpu::ComputePassTimestampWrites {
            query_set: set,
            beginning_of_pass_write_index: first.then_some(i),
            end_of_pass_write_index: last.then_some(i + 1),
        })
    }

    /// Timestamp writes of render pass `pass` (of `view`) this frame.
    pub(crate) fn render(
        &self,
        pass: Pass,
        view: Option<u32>,
    ) -> Option<wgpu::RenderPassTimestampWrites<'_>> {
        let (set, i) = self.query(pass, view)?;
        Some(wgpu::RenderPassTimestampWrites {
            query_set: set,
            beginning_of_pass_write_index: Some(i),
            end_of_pass_write_index: Some(i + 1),
        })
    }

    /// Timestamp writes of one of several render passes that together
    /// make `pass` this frame (no view): the first writes its beginning,
    /// the last its end.
    pub(crate) fn render_span(
        &self,
        pass: Pass,
        first: bool,
        last: bool,
    ) -> Option<wgpu::RenderPassTimestampWrites<'_>> {
        let (set, i) = self.query(pass, None)?;
        (first || last).then_some(wgpu::RenderPassTimestampWrites {
            query_set: set,
            beginning_of_pass_write_index: first.then_some(i),
            end_of_pass_write_index: last.then_some(i + 1),
        })
    }

    /// Timestamp writes of compute pass `pass` (of `view`) this frame.
    pub(crate) fn compute(
        &self,
        pass: Pass,
        view: Option<u32>,
    ) -> Option<wgpu::ComputePassTimestampWrites<'_>> {
        let (set, i) = self.query(pass, view)?;
        Some(wgpu::ComputePassTimestampWrites {
            query_set: set,
            beginning_of_pass_write_index: Some(i),
            end_of_pass_write_index: Some(i + 1),
        })
    }

    /// The query set and the first query of `pass` of `view` this frame
    /// (its rank among the passes the frame records; past the query set's
    /// capacity a pass is not timed).
    fn query(&self, pass: Pass, view: Option<u32>) -> Option<(&wgpu::QuerySet, u32)> {
        let q = self.queries.as_ref()?;
        let slot = &self.slots[self.current?];
        let rank = slot.passes.iter().position(|p| *p == (pass, view))? as u32;
        (rank < q.capacity).then_some((&q.set, 2 * rank))
    }

    /// Ends the frame's commands: resolves its timestamps and has wgpu map
    /// them once the encoder's commands are submitted and done.
    pub(crate) fn finish(&self, encoder: &mut wgpu::CommandEncoder) {
        let Some(k) = self.current else { return };
        let slot = &self.slots[k];
        if slot.state.load(Ordering::Acquire) != IDLE {
            return; // recorded twice: the first recording is timed
        }
        slot.state.store(PENDING, Ordering::Release);
        let state = slot.state.clone();
        let done = slot.done.clone();
        let callback = move |ok: bool| {
            *done.lock().unwrap_or_else(|e| e.into_inner()) = Some(Instant::now());
            state.store(if ok { MAPPED } else { FAILED }, Ordering::Release);
        };
        match (&self.queries, &slot.readback) {
            (Some(q), Some(readback)) => {
                let n = 2 * (slot.passes.len() as u32).min(q.capacity);
                let bytes = 8 * u64::from(n.max(1));
                if n > 0 {
                    encoder.resolve_query_set(&q.set, 0..n, &q.resolve, 0);
                    encoder.copy_buffer_to_buffer(&q.resolve, 0, readback, 0, bytes);
                }
                encoder.map_buffer_on_submit(readback, wgpu::MapMode::Read, ..bytes, move |r| {
                    callback(r.is_ok())
                });
            }
            _ => encoder.on_submitted_work_done(move || callback(true)),
        }
    }

    /// Reads every finished slot; keeps the newest figures.
    fn collect(&mut self) {
        for slot in &mut self.slots {
            match slot.state.load(Ordering::Acquire) {
                MAPPED => {}
                FAILED => {
                    slot.state.store(IDLE, Ordering::Release);
                    continue;
                }
                _ => continue,
            }
            let mut stats = slot.stats.clone();
            match (&self.queries, &slot.readback) {
                (Some(q), Some(readback)) => {
                    let n = slot.passes.len().min(q.capacity as usize);
                    let bytes = 16 * n.max(1) as u64;
                    if let Ok(data) = readback.slice(..bytes).get_mapped_range() {
                        let t: &[u64] = bytemuck::cast_slice(&data);
                        stats.passes = slot.passes[..n]
                            .iter()
                            .enumerate()
                            .map(|(k, &(p, _))| {
                                let dt = t[2 * k + 1].saturating_sub(t[2 * k]);
                                (p, dt as f64 * q.period_ns * 1e-6)
                            })
                            .collect();
                    }
                    readback.unmap();
                    stats.frame_ms = stats.passes.iter().map(|(_, t)| t).sum();
                }
                _ => {
                    let done = *slot.done.lock().unwrap_or_else(|e| e.into_inner());
                    stats.frame_ms = match (slot.started, done) {
                        (Some(s), Some(d)) => d.duration_since(s).as_secs_f64() * 1e3,
                        _ => 0.0,
                    };
                }
            }
            slot.state.store(IDLE, Ordering::Release);
            if self.latest.as_ref().is_none_or(|l| l.frame < stats.frame) {
                self.latest = Some(stats);
            }
        }
    }

    /// The newest finished frame's figures, without waiting (`None` until a
    /// frame has finished on the GPU). Polls the device once.
    pub(crate) fn poll(&mut self, device: &wgpu::Device) -> Option<FrameStats> {
        let _ = device.poll(wgpu::PollType::Poll);
        self.collect();
        self.latest.clone()
    }

    /// The last recorded frame's figures: waits for the GPU. The counts
    /// alone (no times) when the frame was not recorded and submitted.
    pub(crate) fn wait(&mut self, device: &wgpu::Device) -> FrameStats {
        let _ = device.poll(wgpu::PollType::wait_indefinitely());
        self.collect();
        match &self.latest {
            Some(l) if l.frame == self.frame => l.clone(),
            _ => self.counts.clone(),
        }
    }
}
