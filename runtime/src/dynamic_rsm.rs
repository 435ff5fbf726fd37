//! Moving objects drawn from a light at the RSM resolution
//! (`dynamic_rsm.wgsl`), and the partial-occlusion pass that reads it
//! (`occlusion.wgsl`). Only built when the scene has moving objects. One
//! set of targets serves every light view the bounce is computed in (the
//! primary light's, and each other view the moving objects touch): each
//! view's RSM is drawn, read by its occlusion and dynamic VPLs, then the
//! next view's is drawn over it.

use gibake_gpu::mesh::{Draw, SceneGpu};
use gibake_gpu::util::{
    cleared_attachments, cleared_depth, draws_and_uniform_bind, draws_and_uniform_group,
    mesh_pipeline, texture_2d,
};
use gibake_gpu::{LightView, shaders};
use wgpu::util::DeviceExt;

/// The occlusion pass's WGSL: the shared in-front test, then its own.
pub(crate) const OCCLUSION_WGSL: &str = concat!(
    include_str!("moving.wgsl"),
    "\n",
    include_str!("occlusion.wgsl")
);

/// Target formats of the dynamic RSM.
pub(crate) const DYN_RSM_FORMATS: [wgpu::TextureFormat; 3] = [
    wgpu::TextureFormat::Rgba32Float,
    wgpu::TextureFormat::Rgba16Float,
    wgpu::TextureFormat::Rgba16Float,
];

/// One light view the moving objects' RSM is drawn from: its uniform and
/// the pass's group 0 with it.
pub(crate) struct RsmView {
    bind_group: wgpu::BindGroup,
    /// The light view (RSM size) uniform.
    pub(crate) view_buf: wgpu::Buffer,
}

/// The dynamic RSM pass and its targets.
pub(crate) struct DynamicRsmPass {
    pipeline: wgpu::RenderPipeline,
    layout: wgpu::BindGroupLayout,
    /// The view it was made for (the primary light's in a frame).
    pub(crate) own: RsmView,
    /// Targets in [`DYN_RSM_FORMATS`] order (read back by tests).
    #[cfg_attr(not(test), expect(dead_code))]
    pub(crate) textures: Vec<wgpu::Texture>,
    /// Their views.
    pub(crate) views: Vec<wgpu::TextureView>,
    depth_view: wgpu::TextureView,
    /// Size.
    pub(crate) size: u32,
}

/// `view`'s uniform (a light view at the RSM size).
fn view_uniform(device: &wgpu::Device, view: &LightView) -> wgpu::Buffer {
    device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
        label: Some("rsm light view"),
        contents: bytemuck::bytes_of(&view.to_gpu()),
        usage: wgpu::BufferUsages::UNIFORM,
    })
}

/// The square of a view's map that its occlusion test and clustering cover
/// this frame: `2^levels` texels from `origin` (texels past the map are
/// empty). The moving objects' footprint in the view ([`Window::around`]),
/// so that the per-texel passes, the quadtree and the dynamic VPL slots are
/// spent on them and not on the whole map.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) struct Window {
    /// First texel (x, y).
    pub origin: [u32; 2],
    /// log2 of the side.
    pub levels: u32,
}

impl Window {
    /// The whole `size²` map (rounded up to a power of two).
    pub(crate) fn whole(size: u32) -> Window {
        Window {
            origin: [0, 0],
            levels: size.max(1).next_power_of_two().trailing_zeros(),
        }
    }

    /// The smallest power-of-two square from `rect`'s corner that holds
    /// `rect` (`[x0, y0, x1, y1)`, texels of a `size²` map); the whole map
    /// if that square would be as large.
    pub(crate) fn around(rect: [u32; 4], size: u32) -> Window {
        let whole = Window::whole(size);
        let side = (rect[2].saturating_sub(rect[0]))
            .max(rect[3].saturating_sub(rect[1]))
            .max(1)
            .next_power_of_two();
        let levels = side.trailing_zeros();
        if levels >= whole.levels {
            return whole;
        }
        Window {
            origin: [rect[0], rect[1]],
            levels,
        }
    }
}

/// Most windows a view's clustering is split into ([`Windows`]).
pub(crate) const MAX_WINDOWS: usize = 4;

/// Where a view's dynamic VPLs are clustered this frame: one window, or —
/// when the moving objects in the view stand far apart — up to
/// [`MAX_WINDOWS`] disjoint windows, one per group of nearby objects, each
/// with a quarter of the view's slots ([`Windows::around`]).
///
/// One window over objects far apart is large, so its fixed slot pyramid
/// ends in coarse cells: a ball at each end of a sunlit level was one VPL
/// each. Four windows of depth `d − 1` fill the slot range of one of depth
/// `d` (`4 · (4^d − 1)/3 + 1 = (4^(d+1) − 1)/3`), so shading reads the same
/// slots; they are used only where each window's cells come out finer than
/// the one window's.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) struct Windows {
    list: [Window; MAX_WINDOWS],
    count: u32,
    /// The one window around every rectangle (a view of one slot clusters
    /// this one).
    pub union: Window,
}

impl Windows {
    /// One window.
    pub(crate) fn one(w: Window) -> Windows {
        Windows {
            list: [w; MAX_WINDOWS],
            count: 1,
            union: w,
        }
    }

    /// The windows, in the order their slot ranges follow each other.
    pub(crate) fn as_slice(&self) -> &[Window] {
        &self.list[..self.count as usize]
    }

    /// The windows of the moving objects' texel rectangles `rects` (each
    /// `[x0, y0, x1, y1)` of a `size²` map; at least one): rectangles whose
    /// windows ([`Window::around`]) overlap are grouped, then the two
    /// groups whose joint window is smallest, until at most
    /// [`MAX_WINDOWS`] disjoint windows are left (rectangle by rectangle,
    /// in order: linear in their number). They are kept when each is at
    /// most a quarter of the side of the one window around all the
    /// rectangles (so that at one depth less their cells are finer);
    /// otherwise that one window. Deterministic in the order of `rects`.
    pub(crate) fn around(rects: &[[u32; 4]], size: u32) -> Windows {
        let join = |a: [u32; 4], b: [u32; 4]| {
            [
                a[0].min(b[0]),
                a[1].min(b[1]),
                a[2].max(b[2]),
                a[3].max(b[3]),
            ]
        };
        let Some(all) = rects.iter().copied().reduce(join) else {
            return Windows::one(Window {
                origin: [0, 0],
                levels: 0,
            });
        };
        let union = Window::around(all, size);
        let overlap = |a: Window, b: Window| {
            let (sa, sb) = (1u64 << a.levels, 1u64 << b.levels);
            let (ax, ay) = (u64::from(a.origin[0]), u64::from(a.origin[1]));
            let (bx, by) = (u64::from(b.origin[0]), u64::from(b.origin[1]));
            ax < bx + sb && bx < ax + sa && ay < by + sb && by < ay + sa
        };
        // Incremental, so the work is linear in the rectangles: each one
        // joins the groups as a group of its own, then groups whose windows
        // overlap merge, then, past MAX_WINDOWS, the two whose joint window
        // is smallest; at most MAX_WINDOWS + 1 groups at any time.
        let pairs = |n: usize| (0..n).flat_map(move |i| (i + 1..n).map(move |j| (i, j)));
        // A fixed array: no allocation per view per frame.
        let mut store = [[0u32; 4]; MAX_WINDOWS + 1];
        let mut n = 0;
        for &r in rects {
            store[n] = r;
            n += 1;
            loop {
                let g = &store[..n];
                let mut w = [Window::whole(size); MAX_WINDOWS + 1];
                for (w, &g) in w.iter_mut().zip(g) {
                    *w = Window::around(g, size);
                }
                let pair = pairs(n).find(|&(i, j)| overlap(w[i], w[j])).or_else(|| {
                    (n > MAX_WINDOWS)
                        .then(|| {
                            pairs(n)
                                .min_by_key(|&(i, j)| Window::around(join(g[i], g[j]), size).levels)
                        })
                        .flatten()
                });
                let Some((i, j)) = pair else { break };
                store[i] = join(store[i], store[j]);
                store.copy_within(j + 1..n, j);
                n -= 1;
            }
        }
        let groups = &store[..n];
        let finer = groups
            .iter()
            .all(|&g| Window::around(g, size).levels + 1 < union.levels);
        if groups.len() < 2 || !finer {
            return Windows::one(union);
        }
        let mut list = [union; MAX_WINDOWS];
        for (slot, &g) in list.iter_mut().zip(groups) {
            *slot = Window::around(g, size);
        }
        Windows {
            list,
            count: groups.len() as u32,
            union,
        }
    }
}

impl DynamicRsmPass {
    /// Creates the pass for `view` (RSM resolution; its targets are
    /// `view.size`², which every other view bound must share).
    pub(crate) fn new(
        device: &wgpu::Device,
        scene_gpu: &SceneGpu,
        view: &LightView,
    ) -> DynamicRsmPass {
        let module =
            shaders::mesh_module(device, "dynamic_rsm.wgsl", include_str!("dynamic_rsm.wgsl"));
        let view_buf = view_uniform(device, view);
        let (layout, bind_group) =
            draws_and_uniform_group(device, "dynamic rsm", &scene_gpu.draw_data, &view_buf);
        let targets: Vec<Option<wgpu::ColorTargetState>> =
            DYN_RSM_FORMATS.iter().map(|f| Some((*f).into())).collect();
        let pipeline = mesh_pipeline(
            device,
            "dynamic rsm",
            &module,
            &[&layout, &scene_gpu.material_layout],
            &targets,
            wgpu::CompareFunction::Greater,
        );
        let size = view.size;
        let usage = wgpu::TextureUsages::RENDER_ATTACHMENT
            | wgpu::TextureUsages::TEXTURE_BINDING
            | wgpu::TextureUsages::COPY_SRC;
        let textures: Vec<_> = DYN_RSM_FORMATS
            .iter()
            .map(|f| texture_2d(device, "dynamic rsm", size, size, *f, usage))
            .collect();
        let views = textures
            .iter()
            .map(|t| t.create_view(&Default::default()))
            .collect();
        let depth = texture_2d(
            device,
            "dynamic rsm depth",
            size,
            size,
            wgpu::TextureFormat::Depth32Float,
            wgpu::TextureUsages::RENDER_ATTACHMENT,
        );
        DynamicRsmPass {
            pipeline,
            layout,
            own: RsmView {
                bind_group,
                view_buf,
            },
            textures,
            views,
            depth_view: depth.create_view(&Default::default()),
            size,
        }
    }

    /// Another light `view` to draw the same targets from (`view.size` is
    /// the pass's).
    pub(crate) fn bind(
        &self,
        device: &wgpu::Device,
        scene_gpu: &SceneGpu,
        view: &LightView,
    ) -> RsmView {
        debug_assert_eq!(view.size, self.size);
        let view_buf = view_uniform(device, view);
        let bind_group = draws_and_uniform_bind(
            device,
            "dynamic rsm",
            &self.layout,
            &scene_gpu.draw_data,
            &view_buf,
        );
        RsmView {
            bind_group,
            view_buf,
        }
    }

    /// Records the pass (the moving objects' `draws`) from its own view.
    #[cfg(test)]
    pub(crate) fn encode(
        &self,
        encoder: &mut wgpu::CommandEncoder,
        scene_gpu: &SceneGpu,
        draws: &[Draw],
        ts: Option<wgpu::RenderPassTimestampWrites<'_>>,
    ) {
        self.encode_from(encoder, scene_gpu, &self.own, draws, ts)
    }

    /// Records the pass from `view` (made by [`DynamicRsmPass::bind`]),
    /// drawing `draws`.
    pub(crate) fn encode_from<'d>(
        &self,
        encoder: &mut wgpu::CommandEncoder,
        scene_gpu: &SceneGpu,
        view: &RsmView,
        draws: impl IntoIterator<Item = &'d Draw>,
        ts: Option<wgpu::RenderPassTimestampWrites<'_>>,
    ) {
        let clears = [
            wgpu::Color {
                r: 0.0,
                g: 0.0,
                b: 0.0,
                a: 3.0e38,
            },
            wgpu::Color::TRANSPARENT,
            wgpu::Color::TRANSPARENT,
        ];
        let mut pass = encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
            label: Some("dynamic rsm"),
            color_attachments: &cleared_attachments(self.views.iter().zip(clears)),
            depth_stencil_attachment: Some(cleared_depth(&self.depth_view, 0.0)),
            timestamp_writes: ts,
            occlusion_query_set: None,
            multiview_mask: None,
        });
        pass.set_pipeline(&self.pipeline);
        pass.set_bind_group(0, &view.bind_group, &[]);
        scene_gpu.draw(&mut pass, draws, true);
    }
}

/// The partial-occlusion pass: one occluded sum per static VPL, shared by
/// every light view the bounce is computed in (a VPL belongs to one view,
/// so each view adds only to its own VPLs' sums).
pub(crate) struct OcclusionPass {
    pipeline: wgpu::ComputePipeline,
    /// The view it was made for.
    own: OcclusionView,
    /// Per static VPL occluded share (u32, fixed point 2^24), cleared each
    /// frame; then per later VPL four f32 (as bits): the share of its
    /// light it keeps from what moving objects absorb, per channel
    /// ([`crate::later_absorb`], written by the CPU each frame).
    pub(crate) occluded: wgpu::Buffer,
    /// Static VPLs: the cleared part's length in u32.
    pub(crate) vpl_count: u32,
    size: u32,
}

/// One light view's occlusion test: its group 0 and the windows it tests
/// this frame (`windows` in `occlusion.wgsl`).
pub(crate) struct OcclusionView {
    group: wgpu::BindGroup,
    window_buf: wgpu::Buffer,
}

impl OcclusionPass {
    /// Creates the pass for `rsm`'s own view. `texel_info` holds `(vpl,
    /// share)` per RSM texel.
    pub(crate) fn new(
        device: &wgpu::Device,
        static_metric: &wgpu::TextureView,
        rsm: &DynamicRsmPass,
        texel_info: &wgpu::Buffer,
        (vpl_count, later): (u32, u32),
    ) -> OcclusionPass {
        let module = shaders::module(device, "occlusion.wgsl", OCCLUSION_WGSL);
        let occluded = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("occluded shares"),
            size: 4 * (u64::from(vpl_count) + 4 * u64::from(later)).max(1),
            usage: wgpu::BufferUsages::STORAGE
                | wgpu::BufferUsages::COPY_DST
                | wgpu::BufferUsages::COPY_SRC,
            mapped_at_creation: false,
        });
        let pipeline = device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
            label: Some("occlusion"),
            layout: None,
            module: &module,
            entry_point: Some("cs_main"),
            compilation_options: Default::default(),
            cache: None,
        });
        OcclusionPass {
            own: occlusion_view(
                device,
                &pipeline,
                static_metric,
                rsm,
                &rsm.own,
                texel_info,
                &occluded,
            ),
            pipeline,
            occluded,
            vpl_count,
            size: rsm.size,
        }
    }

    /// Another view's test (its baked metric and texel shares, its
    /// [`RsmView`]), adding to the same sums.
    pub(crate) fn bind(
        &self,
        device: &wgpu::Device,
        static_metric: &wgpu::TextureView,
        rsm: &DynamicRsmPass,
        view: &RsmView,
        texel_info: &wgpu::Buffer,
    ) -> OcclusionView {
        occlusion_view(
            device,
            &self.pipeline,
            static_metric,
            rsm,
            view,
            texel_info,
            &self.occluded,
        )
    }

    /// The test of the view it was made for.
    pub(crate) fn own_view(&self) -> &OcclusionView {
        &self.own
    }

    /// Has `view` test the texels of `windows` from the next recorded
    /// frame (record it with the same windows). They are disjoint, so each
    /// texel is counted once.
    pub(crate) fn set_window(&self, queue: &wgpu::Queue, view: &OcclusionView, windows: &Windows) {
        queue.write_buffer(
            &view.window_buf,
            0,
            bytemuck::bytes_of(&GpuOcclusionWindows::new(windows.as_slice())),
        );
    }

    /// Records one invocation per texel of `windows` (as set with
    /// [`OcclusionPass::set_window`]) of the view of `view`, adding to the
    /// sums (the caller clears them once per frame): one dispatch, `z`
    /// the window.
    pub(crate) fn encode_from(
        &self,
        encoder: &mut wgpu::CommandEncoder,
        view: &OcclusionView,
        windows: &Windows,
        ts: Option<wgpu::ComputePassTimestampWrites<'_>>,
    ) {
        let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
            label: Some("occlusion"),
            timestamp_writes: ts,
        });
        pass.set_pipeline(&self.pipeline);
        pass.set_bind_group(0, &view.group, &[]);
        let list = windows.as_slice();
        let side = list
            .iter()
            .map(|w| (1u32 << w.levels).min(self.size.max(1)))
            .max()
            .unwrap_or(1);
        pass.dispatch_workgroups(side.div_ceil(8), side.div_ceil(8), list.len() as u32);
    }
}

/// `OcclusionWindows` in occlusion.wgsl (must match): up to
/// [`MAX_WINDOWS`] windows (first texel, side) and how many are in use.
#[repr(C)]
#[derive(Clone, Copy, Debug, bytemuck::Pod, bytemuck::Zeroable)]
struct GpuOcclusionWindows {
    w: [[u32; 4]; MAX_WINDOWS],
    count: [u32; 4],
}

impl GpuOcclusionWindows {
    fn new(list: &[Window]) -> GpuOcclusionWindows {
        let mut g = GpuOcclusionWindows {
            w: [[0; 4]; MAX_WINDOWS],
            count: [list.len().min(MAX_WINDOWS) as u32, 0, 0, 0],
        };
        for (slot, w) in g.w.iter_mut().zip(list) {
            *slot = [w.origin[0], w.origin[1], 1u32 << w.levels.min(31), 0];
        }
        g
    }
}

fn occlusion_view(
    device: &wgpu::Device,
    pipeline: &wgpu::ComputePipeline,
    static_metric: &wgpu::TextureView,
    rsm: &DynamicRsmPass,
    view: &RsmView,
    texel_info: &wgpu::Buffer,
    occluded: &wgpu::Buffer,
) -> OcclusionView {
    let whole = GpuOcclusionWindows::new(&[Window::whole(rsm.size)]);
    let window_buf = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
        label: Some("occlusion windows"),
        contents: bytemuck::bytes_of(&whole),
        usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
    });
    let group = device.create_bind_group(&wgpu::BindGroupDescriptor {
        label: Some("occlusion"),
        layout: &pipeline.get_bind_group_layout(0),
        entries: &[
            wgpu::BindGroupEntry {
                binding: 0,
                resource: wgpu::BindingResource::TextureView(static_metric),
            },
            wgpu::BindGroupEntry {
                binding: 1,
                resource: wgpu::BindingResource::TextureView(&rsm.views[0]),
            },
            wgpu::BindGroupEntry {
                binding: 2,
                resource: texel_info.as_entire_binding(),
            },
            wgpu::BindGroupEntry {
                binding: 3,
                resource: occluded.as_entire_binding(),
            },
            wgpu::BindGroupEntry {
                binding: 4,
                resource: view.view_buf.as_entire_binding(),
            },
            wgpu::BindGroupEntry {
                binding: 5,
                resource: window_buf.as_entire_binding(),
            },
        ],
    });
    OcclusionView { group, window_buf }
}

#[cfg(test)]
mod tests {
    use super::{MAX_WINDOWS, Window, Windows};

    /// Objects far apart get a window each, disjoint, each holding its
    /// rectangles and a quarter of the one window's side at most; objects
    /// close together, or too many groups, merge; one rectangle is one
    /// window.
    #[test]
    fn windows_split_objects_far_apart() {
        let size = 512;
        let holds = |w: Window, r: [u32; 4]| {
            let side = 1u32 << w.levels;
            w.origin[0] <= r[0]
                && w.origin[1] <= r[1]
                && w.origin[0] + side >= r[2]
                && w.origin[1] + side >= r[3]
        };
        // One ball at each end of the map: two small windows.
        let far = [[10, 10, 22, 22], [480, 400, 492, 412]];
        let w = Windows::around(&far, size);
        assert_eq!(w.as_slice().len(), 2, "{w:?}");
        assert_eq!(w.union, Window::around([10, 10, 492, 412], size));
        for (win, r) in w.as_slice().iter().zip(&far) {
            assert!(holds(*win, *r) && win.levels + 1 < w.union.levels, "{w:?}");
        }
        // Two balls side by side: one window.
        let near = [[10, 10, 22, 22], [24, 10, 36, 22]];
        assert_eq!(Windows::around(&near, size).as_slice().len(), 1);
        assert_eq!(
            Windows::around(&near[..1], size).as_slice(),
            &[Window::around(near[0], size)]
        );
        // Nine balls on a grid: at most four disjoint windows holding all.
        let grid: Vec<[u32; 4]> = (0..9)
            .map(|k| {
                let (x, y) = (20 + 200 * (k % 3), 20 + 200 * (k / 3));
                [x, y, x + 8, y + 8]
            })
            .collect();
        let w = Windows::around(&grid, size);
        let list = w.as_slice();
        assert!((1..=MAX_WINDOWS).contains(&list.len()), "{w:?}");
        for r in &grid {
            assert!(list.iter().any(|win| holds(*win, *r)), "{r:?} in {w:?}");
        }
        for i in 0..list.len() {
            for j in i + 1..list.len() {
                let (a, b) = (list[i], list[j]);
                let (sa, sb) = (1u32 << a.levels, 1u32 << b.levels);
                let apart = a.origin[0] + sa <= b.origin[0]
                    || b.origin[0] + sb <= a.origin[0]
                    || a.origin[1] + sa <= b.origin[1]
                    || b.origin[1] + sb <= a.origin[1];
                assert!(apart, "{a:?} and {b:?} overlap");
            }
        }
        // Deterministic.
        assert_eq!(Windows::around(&grid, size), w);
        // Many objects: linear work, still at most four windows holding
        // every rectangle.
        let many: Vec<[u32; 4]> = (0..20_000u32)
            .map(|k| {
                let (x, y) = ((k * 7919) % 500, (k * 104_729) % 500);
                [x, y, x + 4, y + 4]
            })
            .collect();
        let w = Windows::around(&many, size);
        assert!(w.as_slice().len() <= MAX_WINDOWS);
        for r in many.iter().step_by(97) {
            assert!(
                w.as_slice().iter().any(|win| holds(*win, *r)),
                "{r:?} in {w:?}"
            );
        }
    }

    /// A window holds its rectangle, is a power of two, and is the whole
    /// map (from texel 0) once it would be as large; a rectangle at the
    /// map's edge keeps its corner (texels past the map are empty).
    #[test]
    fn window_holds_its_rectangle() {
        for (rect, size) in [
            ([10, 20, 13, 24], 512),
            ([0, 0, 1, 1], 512),
            ([500, 505, 512, 512], 512),
            ([3, 3, 200, 40], 512),
            ([0, 0, 300, 10], 512),
            ([5, 5, 90, 90], 100),
        ] {
            let w = Window::around(rect, size);
            let side = 1u32 << w.levels;
            assert!(
                w.origin[0] <= rect[0]
                    && w.origin[1] <= rect[1]
                    && w.origin[0] + side >= rect[2]
                    && w.origin[1] + side >= rect[3],
                "{rect:?} in a {size}² map: {w:?}"
            );
            if side >= size {
                assert_eq!(w, Window::whole(size), "{rect:?}");
            } else {
                assert!(side < 2 * (rect[2] - rect[0]).max(rect[3] - rect[1]).max(1));
            }
        }
        assert_eq!(Window::whole(512).levels, 9);
        assert_eq!(Window::whole(100).levels, 7);
        assert_eq!(Window::around([500, 505, 512, 512], 512).origin, [500, 505]);
    }
}
