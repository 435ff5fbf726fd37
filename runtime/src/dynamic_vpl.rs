//! Dynamic VPLs: the moving objects' part of the dynamic RSM clustered into
//! VPLs on the GPU, every frame, with no read-back (design brief, step 5,
//! "step 5 clusters on the GPU").
//!
//! The rule is the bake's (the docs of `gibake_bake::cluster`; its CPU twin
//! is `gibake_bake::cluster::cluster_cut`), applied to the texels of the
//! dynamic RSM ([`DynamicRsmPass`]) where a moving surface is nearer the
//! light than the static one:
//!
//! - a texel is **valid** iff the dynamic RSM has a surface there
//!   (metric below its `3e38` clear value) and `dyn_metric < static_metric −
//!   0.5 · footprint` (`moving_in_front` of `occlusion.wgsl`); it is **lit**
//!   iff valid with `flux.r + flux.g + flux.b > 0` (finite);
//! - its flux and area follow `gibake_bake::rsm::render_rsm`:
//!   `flux = albedo · color · attenuation(dir, d) · lv_texel_measure(dir)`,
//!   `area = measure · d² / max(cos, 0.05)` (spot; `d` the distance to the
//!   light) or `measure / max(cos, 0.05)` (directional), with `dir` the
//!   light → texel direction and `cos = normal · (−dir)`;
//! - a node splits iff it has ≥ 2 texels and a lit one, its depth is below
//!   `max_depth`, and it and all its ancestors score
//!   `S = max(D, Nn, M) · share ≥ threshold` (`share`: the node's `Σ flux`
//!   over the root's).
//!
//! # Passes (one compute pass, "dynamic vpls")
//!
//! 1. `cs_reduce`, once per level `d = L−1 … 6`, then `cs_reduce_top`
//!    once for levels `min(L, 6)−1 … 0` in one workgroup (`2^L`: the RSM size rounded
//!    up to a power of two; texels beyond the RSM are empty): node `i` of
//!    level `d` merges its four children `4i … 4i+3` (Morton order) in that
//!    order — Chan's mean/`M2` of the metric, and sums of lit count, normal,
//!    footprint, flux, `w·position`, `w·normal`, area (`w = r + g + b`).
//!    The texel level is not stored: it is computed from the RSM textures
//!    where it is read.
//! 2. `cs_slots`, one invocation per **slot**: every node of depth
//!    `0..=max_depth`, level by level, Morton order within a level (node
//!    `(d, i)` is slot `(4^d − 1)/3 + i`). The slot holds a VPL iff all its
//!    ancestors split, the node does not (or `d = max_depth`) and it has lit
//!    texels: position `Σ w·p / Σ w`, normal `normalize(Σ w·n)`, flux `Σ
//!    flux`, area `Σ area`, `normal.w = 1`. Otherwise the slot is zeroed.
//!
//! `max_depth = ceil(log4(max_vpls))` (at most `L`), so there are at most
//! `4^max_depth ≥ max_vpls` VPLs among [`DynamicVplPass::slots`] slots.
//!
//! Several light views ([`DynamicVplPass::bind`]: the other lights' views
//! moving objects touch) share the pipelines, the pyramid (scratch, each
//! view's clustering done before the next view's RSM is drawn) and one
//! slot buffer: each view writes the slot range of its position in the
//! frame (`Params::base`, [`DynamicVplPass::set_frame`]: the views
//! recorded this frame take the first ranges, so shading reads only
//! theirs); each view has its own light uniform and parameter blocks.
//! Everything is `f32` with a fixed reduction order and no atomics: the
//! output is bit-identical from run to run.

use gibake_gpu::shaders;
use wgpu::util::DeviceExt;

use crate::dynamic_rsm::{DynamicRsmPass, MAX_WINDOWS, RsmView, Window, Windows};

/// The pass's WGSL: the slot layout and the in-front test it shares, then
/// its own.
pub(crate) const DYNAMIC_VPL_WGSL: &str = concat!(
    include_str!("dyn_vpl.wgsl"),
    "\n",
    include_str!("moving.wgsl"),
    "\n",
    include_str!("dynamic_vpl.wgsl")
);

/// One dynamic VPL slot. Must match `DynVpl` in `shade.wgsl` and
/// `dynamic_vpl.wgsl` (48 bytes).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, bytemuck::Pod, bytemuck::Zeroable)]
pub(crate) struct GpuDynVpl {
    /// xyz position (flux-weighted mean), w = area.
    pub position: [f32; 4],
    /// xyz unit normal, w = 1 if this slot holds a VPL, else 0 (and the
    /// whole slot is zero).
    pub normal: [f32; 4],
    /// rgb flux, w = its lobe coherence `|Σ w·n| / Σ w` over its texels
    /// (shading draws it with the lobe of `shade.wgsl` `far_lobe`; 0 in an
    /// empty slot).
    pub flux: [f32; 4],
}

/// Bytes of one node of the moment pyramid (`Node` in the WGSL).
const NODE_BYTES: u64 = 80;
/// Stride of the per-dispatch parameter blocks (dynamic uniform offsets).
const PARAMS_STRIDE: u64 = 256;
/// Workgroup size of both entry points.
const WORKGROUP: u32 = 64;
/// Most workgroups along x in one dispatch (the rest go along y).
const MAX_GROUPS_X: u32 = 32768;

/// `Params` in the WGSL.
#[repr(C)]
#[derive(Clone, Copy, Debug, bytemuck::Pod, bytemuck::Zeroable)]
struct GpuParams {
    level: u32,
    levels: u32,
    size: u32,
    max_depth: u32,
    slots: u32,
    threshold: f32,
    base: u32,
    pad: u32,
    origin: [u32; 2],
    pad2: [u32; 2],
}

/// The slot-pyramid depth for `max_vpls` VPLs: `ceil(log4(max_vpls))`.
pub(crate) fn depth_for(max_vpls: u32) -> u32 {
    let mut d = 0;
    while d < 16 && (1u64 << (2 * d)) < u64::from(max_vpls) {
        d += 1;
    }
    d
}

/// Number of slots of depths `0..=max_depth`: `(4^(max_depth+1) − 1) / 3`.
pub(crate) fn slot_count(max_depth: u32) -> u32 {
    (((1u64 << (2 * (max_depth + 1))) - 1) / 3) as u32
}

/// One light view's clustering: its group 0 (its RSM view, baked metric,
/// light and parameter blocks).
pub(crate) struct VplView {
    bind_group: wgpu::BindGroup,
    params: wgpu::Buffer,
    /// Its deepest slot level (`ceil(log4(its most VPLs))`, at most `L`).
    max_depth: u32,
    /// Its slots: `(4^(max_depth + 1) − 1) / 3`.
    slots: u32,
}

/// The GPU clustering of the dynamic RSM into VPL slots.
pub(crate) struct DynamicVplPass {
    reduce: wgpu::ComputePipeline,
    /// Levels below [`TOP_LEVELS`] in one workgroup.
    reduce_top: wgpu::ComputePipeline,
    slots_pipeline: wgpu::ComputePipeline,
    layout: wgpu::BindGroupLayout,
    /// The view it was made for (slots `0..slots` until moved).
    own: VplView,
    nodes: wgpu::Buffer,
    /// Every view's slots ([`GpuDynVpl`]), each view's range in slot order
    /// (see the module docs). `STORAGE | COPY_SRC | COPY_DST`.
    pub(crate) vpls: wgpu::Buffer,
    shape: Shape,
}

fn texture_entry(binding: u32) -> wgpu::BindGroupLayoutEntry {
    wgpu::BindGroupLayoutEntry {
        binding,
        visibility: wgpu::ShaderStages::COMPUTE,
        ty: wgpu::BindingType::Texture {
            sample_type: wgpu::TextureSampleType::Float { filterable: false },
            view_dimension: wgpu::TextureViewDimension::D2,
            multisampled: false,
        },
        count: None,
    }
}

fn buffer_entry(
    binding: u32,
    ty: wgpu::BufferBindingType,
    dynamic: bool,
) -> wgpu::BindGroupLayoutEntry {
    wgpu::BindGroupLayoutEntry {
        binding,
        visibility: wgpu::ShaderStages::COMPUTE,
        ty: wgpu::BindingType::Buffer {
            ty,
            has_dynamic_offset: dynamic,
            min_binding_size: None,
        },
        count: None,
    }
}

/// Levels `0 … TOP_LEVELS − 1` of a window's pyramid (at most
/// `4^(TOP_LEVELS − 1)` = 1024 nodes, 16 per invocation of one workgroup of
/// 64: 1365 merges of four, microseconds on a GPU) are reduced by one
/// dispatch of `cs_reduce_top`; the levels above, one dispatch each. On
/// lavapipe a dispatch costs about 3 ms whatever its size, and four windows
/// of 64² took 28 of them (docs/results.md, "Moving objects far apart").
const TOP_LEVELS: u32 = 6;

/// Workgroups for `n` invocations, as `(x, y)`.
fn groups(n: u32) -> (u32, u32) {
    let g = n.div_ceil(WORKGROUP).max(1);
    if g <= MAX_GROUPS_X {
        (g, 1)
    } else {
        (MAX_GROUPS_X, g.div_ceil(MAX_GROUPS_X))
    }
}

impl DynamicVplPass {
    /// Creates the pass over `rsm`'s targets. `static_metric` is the baked
    /// static RSM metric (`R32Float`, same size), `light_buf` the
    /// `GpuPrimaryLight` uniform, `threshold` the bake's effective threshold
    /// (`manifest.settings.threshold`), `max_vpls` the most VPLs wanted
    /// (rounded up to a power of 4), `more_slots` the room the output has
    /// past this view's slots for the views bound later
    /// ([`DynamicVplPass::slots_for`] each).
    pub(crate) fn new(
        device: &wgpu::Device,
        rsm: &DynamicRsmPass,
        static_metric: &wgpu::TextureView,
        light_buf: &wgpu::Buffer,
        threshold: f32,
        max_vpls: u32,
        more_slots: u32,
    ) -> DynamicVplPass {
        let size = rsm.size.max(1);
        let levels = size.next_power_of_two().trailing_zeros();
        let max_depth = depth_for(max_vpls).min(levels);
        let slots = slot_count(max_depth);
        // Stored levels 0..levels (the texel level is read from the RSM).
        let stored = u64::from(slot_count(levels.max(1) - 1)) * u64::from(levels > 0);
        let nodes = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("dynamic VPL pyramid"),
            size: NODE_BYTES * stored.max(1),
            usage: wgpu::BufferUsages::STORAGE,
            mapped_at_creation: false,
        });
        let vpls = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("dynamic VPLs"),
            size: std::mem::size_of::<GpuDynVpl>() as u64
                * (u64::from(slots) + u64::from(more_slots)),
            usage: wgpu::BufferUsages::STORAGE
                | wgpu::BufferUsages::COPY_SRC
                | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        let storage = wgpu::BufferBindingType::Storage { read_only: false };
        let layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("dynamic vpls"),
            entries: &[
                texture_entry(0),
                texture_entry(1),
                texture_entry(2),
                texture_entry(3),
                buffer_entry(4, wgpu::BufferBindingType::Uniform, false),
                buffer_entry(5, wgpu::BufferBindingType::Uniform, false),
                buffer_entry(6, storage, false),
                buffer_entry(7, storage, false),
                buffer_entry(8, wgpu::BufferBindingType::Uniform, true),
            ],
        });
        let pl = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some("dynamic vpls"),
            bind_group_layouts: &[Some(&layout)],
            immediate_size: 0,
        });
        let module = shaders::module(device, "dynamic_vpl.wgsl", DYNAMIC_VPL_WGSL);
        let pipeline = |entry: &str| {
            device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
                label: Some("dynamic vpls"),
                layout: Some(&pl),
                module: &module,
                entry_point: Some(entry),
                compilation_options: Default::default(),
                cache: None,
            })
        };
        let shape = Shape {
            levels,
            size,
            threshold,
        };
        let own = vpl_view(
            device,
            (&layout, &nodes, &vpls),
            (&shape, max_depth),
            (rsm, &rsm.own),
            static_metric,
            light_buf,
        );
        DynamicVplPass {
            reduce: pipeline("cs_reduce"),
            reduce_top: pipeline("cs_reduce_top"),
            slots_pipeline: pipeline("cs_slots"),
            own,
            layout,
            nodes,
            vpls,
            shape,
        }
    }

    /// Group 0 for another light view: its [`RsmView`] and baked
    /// `static_metric`, its light (`GpuPrimaryLight` uniform), at most
    /// `max_vpls` VPLs (rounded up to a power of 4); its slots' place is
    /// set by [`DynamicVplPass::set_frame`] before it is recorded.
    pub(crate) fn bind(
        &self,
        device: &wgpu::Device,
        rsm: &DynamicRsmPass,
        view: &RsmView,
        static_metric: &wgpu::TextureView,
        light_buf: &wgpu::Buffer,
        max_vpls: u32,
    ) -> VplView {
        vpl_view(
            device,
            (&self.layout, &self.nodes, &self.vpls),
            (&self.shape, depth_for(max_vpls).min(self.shape.levels)),
            (rsm, view),
            static_metric,
            light_buf,
        )
    }

    /// The slots of a view of at most `max_vpls` VPLs on an RSM of
    /// `rsm_size`².
    pub(crate) fn slots_for(rsm_size: u32, max_vpls: u32) -> u32 {
        let levels = rsm_size.max(1).next_power_of_two().trailing_zeros();
        slot_count(depth_for(max_vpls).min(levels))
    }

    /// Number of slots in [`DynamicVplPass::vpls`] (`(4^(max_depth+1) − 1)/3`).
    #[cfg(test)]
    pub(crate) fn slots(&self) -> u32 {
        self.own.slots
    }

    /// Slots of `view`.
    pub(crate) fn slots_of(view: &VplView) -> u32 {
        view.slots
    }

    /// The deepest slot level (`ceil(log4(max_vpls))`, at most log2 of the
    /// RSM size rounded up to a power of two).
    #[cfg(test)]
    pub(crate) fn max_depth(&self) -> u32 {
        self.own.max_depth
    }

    /// Group 0 of the view it was made for (slots `0..slots` until moved).
    pub(crate) fn own_view(&self) -> &VplView {
        &self.own
    }

    /// Has `view` write its slots from slot `base` on and cluster the
    /// texels of `windows`, from the next recorded frame (its range must lie
    /// in the output; record it with the same windows). Several windows
    /// share the view's range: each has a quarter of it (one depth less),
    /// in order, the last one the remainder (written empty past its depth);
    /// a view of one slot clusters the windows' union.
    pub(crate) fn set_frame(
        &self,
        queue: &wgpu::Queue,
        view: &VplView,
        base: u32,
        windows: &Windows,
    ) {
        let blocks = param_blocks(
            &self.shape,
            (view.max_depth, view.slots),
            base,
            Self::windows_of(view, windows),
        );
        queue.write_buffer(&view.params, 0, &blocks);
    }

    /// The windows `view` clusters for `windows`.
    fn windows_of<'w>(view: &VplView, windows: &'w Windows) -> &'w [Window] {
        if view.max_depth == 0 {
            std::slice::from_ref(&windows.union)
        } else {
            windows.as_slice()
        }
    }

    /// Records the clustering of the view of `view` (after its dynamic RSM
    /// pass), into its slots, over `windows` (those its parameters were
    /// last set with, [`DynamicVplPass::set_frame`]).
    pub(crate) fn encode_from(
        &self,
        encoder: &mut wgpu::CommandEncoder,
        view: &VplView,
        windows: &Windows,
        ts: Option<wgpu::ComputePassTimestampWrites<'_>>,
    ) {
        let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
            label: Some("dynamic vpls"),
            timestamp_writes: ts,
        });
        let per_window = self.shape.levels + 1;
        let list = Self::windows_of(view, windows);
        for (k, window) in list.iter().enumerate() {
            // The pyramid is scratch: each window's reduction and slots
            // finish before the next window's reduction (dispatch order).
            let first = k as u32 * per_window;
            let offset = |block: u32| (PARAMS_STRIDE * u64::from(first + block)) as u32;
            let levels = window.levels.min(self.shape.levels);
            pass.set_pipeline(&self.reduce);
            for level in (TOP_LEVELS.min(levels)..levels).rev() {
                pass.set_bind_group(0, &view.bind_group, &[offset(level)]);
                let (x, y) = groups(1u32 << (2 * level));
                pass.dispatch_workgroups(x, y, 1);
            }
            // The last levels (1024 nodes and fewer) in one workgroup, from
            // its parameter block.
            if levels > 0 {
                pass.set_pipeline(&self.reduce_top);
                let top = TOP_LEVELS.min(levels) - 1;
                pass.set_bind_group(0, &view.bind_group, &[offset(top)]);
                pass.dispatch_workgroups(1, 1, 1);
            }
            pass.set_pipeline(&self.slots_pipeline);
            pass.set_bind_group(0, &view.bind_group, &[offset(self.shape.levels)]);
            let (_, slots) = window_slots((view.max_depth, view.slots), list.len(), k);
            let (x, y) = groups(slots);
            pass.dispatch_workgroups(x, y, 1);
        }
    }
}

/// Window `k` of `n` of a view of `(max_depth, slots)`: its deepest slot
/// level and its slot count (one window: the view's; several: one depth
/// less each, the last one taking what is left of the range).
fn window_slots((max_depth, slots): (u32, u32), n: usize, k: usize) -> (u32, u32) {
    if n <= 1 || max_depth == 0 {
        return (max_depth, slots);
    }
    let each = slot_count(max_depth - 1);
    if k + 1 == n {
        (max_depth - 1, slots - each * (n as u32 - 1))
    } else {
        (max_depth - 1, each)
    }
}

/// The pyramid's shape and the clustering's rule, the same for every view.
struct Shape {
    levels: u32,
    size: u32,
    threshold: f32,
}

fn texture_binding(binding: u32, view: &wgpu::TextureView) -> wgpu::BindGroupEntry<'_> {
    wgpu::BindGroupEntry {
        binding,
        resource: wgpu::BindingResource::TextureView(view),
    }
}

/// Group 0 of one view (see [`DynamicVplPass::bind`]); `shared` is the
/// pass's layout, pyramid and slot buffer.
fn vpl_view(
    device: &wgpu::Device,
    shared: (&wgpu::BindGroupLayout, &wgpu::Buffer, &wgpu::Buffer),
    (shape, max_depth): (&Shape, u32),
    (rsm, view): (&DynamicRsmPass, &RsmView),
    static_metric: &wgpu::TextureView,
    light_buf: &wgpu::Buffer,
) -> VplView {
    let slots = slot_count(max_depth);
    let (layout, nodes, vpls) = shared;
    let params = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
        label: Some("dynamic VPL params"),
        contents: &param_blocks(shape, (max_depth, slots), 0, &[Window::whole(shape.size)]),
        usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
    });
    let bind_group = device.create_bind_group(&wgpu::BindGroupDescriptor {
        label: Some("dynamic vpls"),
        layout,
        entries: &[
            texture_binding(0, &rsm.views[0]),
            texture_binding(1, &rsm.views[1]),
            texture_binding(2, &rsm.views[2]),
            texture_binding(3, static_metric),
            wgpu::BindGroupEntry {
                binding: 4,
                resource: view.view_buf.as_entire_binding(),
            },
            wgpu::BindGroupEntry {
                binding: 5,
                resource: light_buf.as_entire_binding(),
            },
            wgpu::BindGroupEntry {
                binding: 6,
                resource: nodes.as_entire_binding(),
            },
            wgpu::BindGroupEntry {
                binding: 7,
                resource: vpls.as_entire_binding(),
            },
            wgpu::BindGroupEntry {
                binding: 8,
                resource: wgpu::BindingResource::Buffer(wgpu::BufferBinding {
                    buffer: &params,
                    offset: 0,
                    size: wgpu::BufferSize::new(std::mem::size_of::<GpuParams>() as u64),
                }),
            },
        ],
    });
    VplView {
        bind_group,
        params,
        max_depth,
        slots,
    }
}

/// The parameter blocks of a view of `(max_depth, slots)` writing its slots
/// from `base` on, clustering `windows` ([`window_slots`] each, one after
/// another): for window `k`, block `k·(L + 1) + d` (`d` < the window's
/// levels) for cs_reduce writing level d, block `k·(L + 1) + L` for
/// cs_slots (its depth this frame at most the window's levels; its slots
/// past it are written empty), `L = shape.levels`.
fn param_blocks(shape: &Shape, view: (u32, u32), base: u32, windows: &[Window]) -> Vec<u8> {
    let per_window = u64::from(shape.levels + 1);
    let mut blocks = vec![0u8; (PARAMS_STRIDE * per_window) as usize * MAX_WINDOWS];
    let mut first_slot = base;
    for (k, window) in windows.iter().enumerate().take(MAX_WINDOWS) {
        let (max_depth, slots) = window_slots(view, windows.len(), k);
        let levels = window.levels.min(shape.levels);
        for level in (0..levels).chain(std::iter::once(shape.levels)) {
            let p = GpuParams {
                level,
                levels,
                size: shape.size,
                max_depth: max_depth.min(levels),
                slots,
                threshold: shape.threshold,
                base: first_slot,
                pad: 0,
                origin: window.origin,
                pad2: [0; 2],
            };
            let at = (PARAMS_STRIDE * (k as u64 * per_window + u64::from(level))) as usize;
            blocks[at..at + std::mem::size_of::<GpuParams>()]
                .copy_from_slice(bytemuck::bytes_of(&p));
        }
        first_slot += slots;
    }
    blocks
}

#[cfg(test)]
#[path = "dynamic_vpl_tests.rs"]
mod gpu_tests;

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn dynamic_vpl_shader_validates() {
        use gibake_gpu::shaders::{compose, validate};
        if let Err(e) = validate(&compose(DYNAMIC_VPL_WGSL)) {
            panic!("dynamic_vpl.wgsl does not validate:\n{e}");
        }
    }

    #[test]
    fn slot_arithmetic() {
        assert_eq!(depth_for(0), 0);
        assert_eq!(depth_for(1), 0);
        assert_eq!(depth_for(2), 1);
        assert_eq!(depth_for(4), 1);
        assert_eq!(depth_for(5), 2);
        assert_eq!(depth_for(64), 3);
        assert_eq!(depth_for(65), 4);
        assert_eq!(slot_count(0), 1);
        assert_eq!(slot_count(1), 5);
        assert_eq!(slot_count(3), 85);
        assert_eq!(std::mem::size_of::<GpuDynVpl>(), 48);
        assert_eq!(std::mem::size_of::<GpuParams>(), 48);
    }
}
