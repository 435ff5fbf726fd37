//! Deferred shading pass (compute, `shade.wgsl`): direct light with the
//! merged primary shadow map, static VPLs with merged hemisphere maps and
//! partial occlusion, dynamic VPLs. Writes linear radiance (`Rgba32Float`),
//! or, interleaved, direct radiance and an irradiance estimate side by side
//! for [`crate::interleave::InterleavePass`] to filter.
//!
//! Two bind groups: group 0 is a view's (its G-buffer, size, interleave
//! factor and output), group 1 the renderer's light and GI data shared by
//! every view ([`GiInputs`], [`GpuGiParams`]).

use gibake_gpu::shaders;

use crate::plan::ShadeFlag;

/// The pass's WGSL: the flags (generated from [`ShadeFlag`]), the VPL and
/// dynamic VPL slot layouts it reads, the other lights
/// (`other_lights.wgsl`, or for a scene with one light
/// `other_lights_none.wgsl`: no binding, so that shading binds what
/// `downlevel_defaults` allow), then its own.
fn shade_wgsl(other_lights: bool) -> String {
    [
        ShadeFlag::wgsl().as_str(),
        gibake_gpu::vpl::VPL_WGSL,
        include_str!("dyn_vpl.wgsl"),
        include_str!("cascades.wgsl"),
        crate::gbuffer::LAYOUT_WGSL,
        if other_lights {
            include_str!("other_lights.wgsl")
        } else {
            include_str!("other_lights_none.wgsl")
        },
        include_str!("shade.wgsl"),
    ]
    .join("\n")
}

/// Output format of shading.
pub(crate) const RADIANCE_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Rgba32Float;

/// A view's parameters (`ViewParams` in `shade.wgsl`).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, bytemuck::Pod, bytemuck::Zeroable)]
pub(crate) struct GpuViewParams {
    /// Output size.
    pub size: [u32; 2],
    /// Interleave N: 1 shades every VPL at every pixel; N > 1 shades the
    /// VPLs `i ≡ k (mod N²)` at pixel `k = x mod N + N·(y mod N)` and writes
    /// direct radiance | irradiance side by side (see `interleave.rs`).
    pub interleave: u32,
    /// The depth of a G-buffer sample with no surface (0: reversed Z, as
    /// gibake's own; an engine's depth may be standard Z, 1).
    pub far_depth: f32,
    /// The camera: xyz its position; w the angle of one pixel (perspective)
    /// or minus one pixel's world size (orthographic): where the single
    /// primary map is fine against the pixel, cascades are not used.
    pub eye: [f32; 4],
    /// Clip → world of the frame's camera (the inverse of
    /// [`crate::CameraMatrices::view_proj`], inverted in f64): rebuilds each
    /// sample's world position from its depth (`gbuffer_position`).
    pub inv_view_proj: [[f32; 4]; 4],
    /// 1: `cs_main` leaves the later bounces' VPLs out and `cs_later`
    /// shades them on the half-resolution grid (see [`crate::View`]'s
    /// `set_later`); 0: every static VPL in `cs_main`.
    pub later_half: u32,
    pub _pad: [u32; 3],
}

/// The renderer's GI parameters (`GiParams` in `shade.wgsl`).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, bytemuck::Pod, bytemuck::Zeroable)]
pub(crate) struct GpuGiParams {
    /// [`ShadeFlag`] bits ([`crate::FramePlan::shade_flags`]).
    pub flags: u32,
    /// Number of static VPLs.
    pub n_static: u32,
    /// Hemisphere map size.
    pub map_size: u32,
    /// Tiles per merge-atlas row.
    pub atlas_cols: u32,
    /// Number of dynamic VPL slots.
    pub n_dynamic: u32,
    /// Tiles per row of the baked map atlas.
    pub static_cols: u32,
    /// Number of lights after the first (`other_lights`).
    pub n_other_lights: u32,
    /// The near-field descent in disk radii
    /// ([`crate::RenderSettings::near_field_descent`]).
    pub descent: u32,
    /// Tiles per row of the second maps' atlas (below the first in the
    /// baked map texture).
    pub lower_cols: u32,
    /// The texel row where the second maps' atlas starts.
    pub lower_row: u32,
    /// Index of the first later-bounce VPL (`n_static` without any: they
    /// are the last static VPLs).
    pub first_later: u32,
    /// The later VPLs' near-field descent in disk radii, 0: one disk each
    /// ([`crate::RenderSettings::later_near_field_descent`]).
    pub later_descent: u32,
    /// The later VPLs' flux scale this frame, per channel (w unused): what
    /// the moving objects absorb of the later bounces
    /// ([`crate::later_absorb`]); 1 without them.
    pub later_scale: [f32; 4],
}

/// A shading pipeline and its group-1 layout: the one-light variant, or the
/// one that binds the other lights' storage arrays.
struct Variant {
    pipeline: wgpu::ComputePipeline,
    gi_layout: wgpu::BindGroupLayout,
    module: wgpu::ShaderModule,
    layout: wgpu::PipelineLayout,
    /// `cs_later`, the later bounces at half resolution: made when a view
    /// first needs it ([`ShadePass::prepare_later`]).
    later: std::sync::OnceLock<wgpu::ComputePipeline>,
}

/// The shading pass: pipelines, bind group layouts, and what is bound where
/// a feature is absent (its fallbacks).
pub(crate) struct ShadePass {
    /// A scene with one light: four storage buffers.
    one: Variant,
    /// A scene with other lights (six storage buffers), made when first
    /// needed.
    many: std::sync::OnceLock<Variant>,
    /// Bound for absent storage inputs.
    fallback_buf: wgpu::Buffer,
    /// A 1×1 storage texture bound as the later bounces' output of a view
    /// that shades them with the rest (`ViewParams::later_half` 0).
    pub(crate) fallback_later: wgpu::TextureView,
    /// Bound when there are no dynamic VPLs (one empty slot).
    fallback_dyn_vpls: wgpu::Buffer,
    /// A 1×1 `R32Float` texture bound for absent maps.
    fallback_map: wgpu::TextureView,
    /// Bound without cascades (a zero count).
    fallback_cascades: wgpu::Buffer,
    /// Layout of group 0 (a view: G-buffer, params, output).
    view_layout: wgpu::BindGroupLayout,
    /// The views' composite pipelines (per target format and blend), made
    /// when first needed and shared by every view.
    pub(crate) composite: crate::composite::Pipelines,
    /// The views' G-buffer rebuild pipelines (per depth format), likewise.
    pub(crate) depth_gbuffer: crate::gbuffer_depth::Pipelines,
}

const COMPUTE: wgpu::ShaderStages = wgpu::ShaderStages::COMPUTE;

fn tex_entry(binding: u32) -> wgpu::BindGroupLayoutEntry {
    gibake_gpu::util::texture_entry(binding, COMPUTE, wgpu::TextureViewDimension::D2)
}

/// The G-buffer's packed normals (`Rg32Uint`) and albedo (`R32Uint`).
pub(crate) fn uint_tex_entry(binding: u32) -> wgpu::BindGroupLayoutEntry {
    wgpu::BindGroupLayoutEntry {
        ty: wgpu::BindingType::Texture {
            sample_type: wgpu::TextureSampleType::Uint,
            view_dimension: wgpu::TextureViewDimension::D2,
            multisampled: false,
        },
        ..tex_entry(binding)
    }
}

fn uniform_entry(binding: u32) -> wgpu::BindGroupLayoutEntry {
    gibake_gpu::util::uniform_entry(binding, COMPUTE)
}

fn storage_entry(binding: u32) -> wgpu::BindGroupLayoutEntry {
    gibake_gpu::util::storage_entry(binding, COMPUTE, true)
}

/// A uniform buffer holding `value`, writable.
pub(crate) fn uniform<T: bytemuck::Pod>(
    device: &wgpu::Device,
    label: &str,
    value: &T,
) -> wgpu::Buffer {
    use wgpu::util::DeviceExt;
    device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
        label: Some(label),
        contents: bytemuck::bytes_of(value),
        usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
    })
}

/// A view's inputs (group 0).
pub(crate) struct ViewInputs<'a> {
    /// The camera G-buffer's three views (see [`crate::GBUFFER_FORMATS`]:
    /// depth, normals, albedo).
    pub gbuffer: [&'a wgpu::TextureView; 3],
    /// [`GpuViewParams`] uniform.
    pub params: &'a wgpu::Buffer,
    /// Output radiance view (`Rgba32Float`, storage binding).
    pub output: &'a wgpu::TextureView,
    /// The later bounces' half-resolution estimates (`Rgba32Float`,
    /// storage binding; [`ShadePass::fallback_later`] where the view has
    /// none).
    pub later: &'a wgpu::TextureView,
}

/// Light and GI inputs (group 1); `None`: the feature is absent and the
/// pass binds its fallback.
pub(crate) struct GiInputs<'a> {
    /// Static primary shadow map (metric).
    pub primary_static: &'a wgpu::TextureView,
    /// Moving objects' primary shadow map (`None`: no moving objects).
    pub primary_dynamic: Option<&'a wgpu::TextureView>,
    /// `GpuPrimaryLight` uniform.
    pub light: &'a wgpu::Buffer,
    /// `GpuLightView` uniform of the primary maps.
    pub light_view: &'a wgpu::Buffer,
    /// [`GpuGiParams`] uniform.
    pub params: &'a wgpu::Buffer,
    /// Static VPLs ([`gibake_gpu::vpl::GpuVpl`]), then their near-field
    /// trees.
    pub vpls: Option<&'a wgpu::Buffer>,
    /// Per static VPL occluded fraction (fixed point 2^24).
    pub occlusion: Option<&'a wgpu::Buffer>,
    /// Per static VPL atlas tile or `u32::MAX`.
    pub vpl_tile: Option<&'a wgpu::Buffer>,
    /// Baked maps (2D atlas).
    pub static_maps: Option<&'a wgpu::TextureView>,
    /// Atlas of merged/re-rendered maps.
    pub atlas: Option<&'a wgpu::TextureView>,
    /// Dynamic VPL slots.
    pub dyn_vpls: Option<&'a wgpu::Buffer>,
    /// The cascades: `GpuCascades` uniform, static maps, moving maps.
    pub cascades: Option<CascadeBindings<'a>>,
    /// The lights after the first.
    pub other_lights: Option<&'a crate::other_lights::OtherLights>,
}

/// What shading binds of the cascades (see [`crate::cascades`]).
pub(crate) type CascadeBindings<'a> = (
    &'a wgpu::Buffer,
    Vec<&'a wgpu::TextureView>,
    Vec<&'a wgpu::TextureView>,
);

/// Bind group entries from `(binding, resource)` pairs.
fn entries<'a, const N: usize>(
    r: [(u32, wgpu::BindingResource<'a>); N],
) -> [wgpu::BindGroupEntry<'a>; N] {
    r.map(|(binding, resource)| wgpu::BindGroupEntry { binding, resource })
}

impl Variant {
    /// The pipeline and group-1 layout with (`many`) or without the other
    /// lights' storage arrays (bindings 21 and 22).
    fn new(device: &wgpu::Device, view_layout: &wgpu::BindGroupLayout, many: bool) -> Variant {
        let module = shaders::module(device, "shade.wgsl", &shade_wgsl(many));
        let mut gi_entries = vec![
            storage_entry(0),
            storage_entry(1),
            storage_entry(2),
            tex_entry(3),
            tex_entry(4),
            storage_entry(5),
            tex_entry(7),
            tex_entry(8),
            uniform_entry(9),
            uniform_entry(10),
            uniform_entry(11),
            uniform_entry(12),
        ];
        gi_entries.extend((13..=20).map(tex_entry));
        if many {
            gi_entries.extend([
                storage_entry(21),
                storage_entry(22),
                tex_entry(23),
                tex_entry(24),
            ]);
        }
        let gi_layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("shade gi"),
            entries: &gi_entries,
        });
        let pl = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some("shade"),
            bind_group_layouts: &[Some(view_layout), Some(&gi_layout)],
            immediate_size: 0,
        });
        let pipeline = device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
            label: Some("shade"),
            layout: Some(&pl),
            module: &module,
            entry_point: Some("cs_main"),
            compilation_options: Default::default(),
            cache: None,
        });
        Variant {
            pipeline,
            gi_layout,
            module,
            layout: pl,
            later: std::sync::OnceLock::new(),
        }
    }

    /// The `cs_later` pipeline, made on first use.
    fn later(&self, device: &wgpu::Device) -> &wgpu::ComputePipeline {
        self.later.get_or_init(|| {
            device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
                label: Some("shade later bounces"),
                layout: Some(&self.layout),
                module: &self.module,
                entry_point: Some("cs_later"),
                compilation_options: Default::default(),
                cache: None,
            })
        })
    }
}

impl ShadePass {
    /// Creates the pass.
    pub(crate) fn new(device: &wgpu::Device) -> ShadePass {
        let view_layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("shade view"),
            entries: &[
                tex_entry(0),
                uint_tex_entry(1),
                uint_tex_entry(2),
                uniform_entry(3),
                storage_texture_entry(4),
                storage_texture_entry(5),
            ],
        });
        let one = Variant::new(device, &view_layout, false);
        let storage = |label, size| {
            device.create_buffer(&wgpu::BufferDescriptor {
                label: Some(label),
                size,
                usage: wgpu::BufferUsages::STORAGE,
                mapped_at_creation: false,
            })
        };
        ShadePass {
            one,
            many: std::sync::OnceLock::new(),
            composite: Default::default(),
            depth_gbuffer: Default::default(),
            fallback_buf: storage("absent GI input", 64),
            fallback_later: gibake_gpu::util::texture_2d(
                device,
                "no half-resolution later bounces",
                1,
                1,
                RADIANCE_FORMAT,
                wgpu::TextureUsages::STORAGE_BINDING,
            )
            .create_view(&Default::default()),
            fallback_dyn_vpls: storage("no dynamic VPLs", 48),
            fallback_map: gibake_gpu::util::texture_2d(
                device,
                "absent map",
                1,
                1,
                wgpu::TextureFormat::R32Float,
                wgpu::TextureUsages::TEXTURE_BINDING,
            )
            .create_view(&Default::default()),
            fallback_cascades: uniform(
                device,
                "no cascades",
                &<crate::cascades::GpuCascades as bytemuck::Zeroable>::zeroed(),
            ),
            view_layout,
        }
    }

    /// The variant for a scene with (`many`) or without other lights.
    fn variant(&self, device: &wgpu::Device, many: bool) -> &Variant {
        if many {
            self.many
                .get_or_init(|| Variant::new(device, &self.view_layout, true))
        } else {
            &self.one
        }
    }

    /// Bind group 0 of a view.
    pub(crate) fn view_group(&self, device: &wgpu::Device, i: &ViewInputs<'_>) -> wgpu::BindGroup {
        let tv = wgpu::BindingResource::TextureView;
        device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("shade view"),
            layout: &self.view_layout,
            entries: &entries([
                (0, tv(i.gbuffer[0])),
                (1, tv(i.gbuffer[1])),
                (2, tv(i.gbuffer[2])),
                (3, i.params.as_entire_binding()),
                (4, tv(i.output)),
                (5, tv(i.later)),
            ]),
        })
    }

    /// Bind group 1, with fallbacks for what `i` lacks.
    pub(crate) fn gi_group<'a>(
        &'a self,
        device: &wgpu::Device,
        i: &GiInputs<'a>,
    ) -> wgpu::BindGroup {
        let fb = &self.fallback_buf;
        let fm = &self.fallback_map;
        let buf = |b: Option<&'a wgpu::Buffer>| b.unwrap_or(fb).as_entire_binding();
        let map =
            |m: Option<&'a wgpu::TextureView>| wgpu::BindingResource::TextureView(m.unwrap_or(fm));
        let dyn_vpls = i.dyn_vpls.unwrap_or(&self.fallback_dyn_vpls);
        let (cascades, cs, cm) = match &i.cascades {
            Some((u, s, m)) => (*u, s.as_slice(), m.as_slice()),
            None => (&self.fallback_cascades, &[][..], &[][..]),
        };
        let cmap = |v: &[&'a wgpu::TextureView], k: usize| map(v.get(k).copied());
        let other = i.other_lights;
        let mut entries = Vec::from(entries([
            (0, buf(i.vpls)),
            (1, buf(i.occlusion)),
            (2, buf(i.vpl_tile)),
            (3, map(i.static_maps)),
            (4, map(i.atlas)),
            (5, dyn_vpls.as_entire_binding()),
            (7, map(Some(i.primary_static))),
            // Without moving objects shading never reads it (no
            // `FLAG_DYN_PRIMARY`): the static map stands in.
            (8, map(Some(i.primary_dynamic.unwrap_or(i.primary_static)))),
            (9, i.light.as_entire_binding()),
            (10, i.light_view.as_entire_binding()),
            (11, i.params.as_entire_binding()),
            (12, cascades.as_entire_binding()),
            (13, cmap(cs, 0)),
            (14, cmap(cs, 1)),
            (15, cmap(cs, 2)),
            (16, cmap(cs, 3)),
            (17, cmap(cm, 0)),
            (18, cmap(cm, 1)),
            (19, cmap(cm, 2)),
            (20, cmap(cm, 3)),
        ]));
        // The other lights: only in the variant that has them.
        if let Some(o) = other {
            entries.extend(self::entries([
                (21, o.lights.as_entire_binding()),
                (22, o.views.as_entire_binding()),
                (23, map(Some(&o.maps))),
                (24, map(o.moving_maps())),
            ]));
        }
        device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("shade gi"),
            layout: &self.variant(device, other.is_some()).gi_layout,
            entries: &entries,
        })
    }

    /// Makes the `cs_later` pipeline of `gi`'s variant (before a view
    /// records with `later_half`).
    pub(crate) fn prepare_later(&self, device: &wgpu::Device, gi: &ShadeGi) {
        self.variant(device, gi.many).later(device);
    }

    /// Records the pass (with the variant `gi` was made for); `later_half`:
    /// also the later bounces on the half-resolution grid, in the same
    /// pass (after [`ShadePass::prepare_later`]).
    pub(crate) fn encode(
        &self,
        encoder: &mut wgpu::CommandEncoder,
        view: &wgpu::BindGroup,
        gi: &ShadeGi,
        (size, interleave, later_half): ([u32; 2], u32, bool),
        timestamps: Option<wgpu::ComputePassTimestampWrites<'_>>,
    ) {
        let variant = match (gi.many, self.many.get()) {
            (true, Some(v)) => v,
            _ => &self.one,
        };
        let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
            label: Some("shade"),
            timestamp_writes: timestamps,
        });
        pass.set_pipeline(&variant.pipeline);
        pass.set_bind_group(0, view, &[]);
        pass.set_bind_group(1, &gi.group, &[]);
        let [x, y] = workgroups(size, interleave);
        pass.dispatch_workgroups(x, y, 1);
        debug_assert!(
            !later_half || variant.later.get().is_some(),
            "made in Renderer::prepare"
        );
        if later_half && let Some(later) = variant.later.get() {
            pass.set_pipeline(later);
            let [x, y] = workgroups(later_grid(size), interleave);
            pass.dispatch_workgroups(x, y, 1);
        }
    }
}

/// The half-resolution grid of the later bounces (`cs_later`): sample
/// `(i, j)` stands for pixel `(2i, 2j)`.
pub(crate) fn later_grid(size: [u32; 2]) -> [u32; 2] {
    size.map(|v| v.div_ceil(2))
}

/// A write-only `Rgba32Float` storage texture binding.
pub(crate) fn storage_texture_entry(binding: u32) -> wgpu::BindGroupLayoutEntry {
    wgpu::BindGroupLayoutEntry {
        binding,
        visibility: COMPUTE,
        ty: wgpu::BindingType::StorageTexture {
            access: wgpu::StorageTextureAccess::WriteOnly,
            format: RADIANCE_FORMAT,
            view_dimension: wgpu::TextureViewDimension::D2,
        },
        count: None,
    }
}

/// Workgroups of the shade pass (8×8 invocations each) for an output of
/// `size` at `interleave` N. At N = 1 one invocation per pixel in image
/// order. At N > 1 the grid is deinterleaved: N × N planes, plane (a, b)
/// holding the pixels (a + N·i, b + N·j) that shade the same VPL subset,
/// each plane rounded up to whole workgroups, so that no workgroup mixes
/// subsets (neighbouring invocations then read the same VPLs and take the
/// same near-field branches instead of N² different ones). Must match
/// `cs_main` in shade.wgsl.
pub(crate) fn workgroups(size: [u32; 2], interleave: u32) -> [u32; 2] {
    let n = interleave.max(1);
    let groups = |extent: u32| {
        if n == 1 {
            extent.div_ceil(8)
        } else {
            n * extent.div_ceil(n).div_ceil(8)
        }
    };
    [groups(size[0]), groups(size[1])]
}

/// The renderer's shading inputs shared by every view: the GI parameters
/// and bind group 1.
pub(crate) struct ShadeGi {
    params: GpuGiParams,
    params_buf: wgpu::Buffer,
    /// Bind group 1.
    pub group: wgpu::BindGroup,
    /// Whether it binds the other lights (the pass's variant with them).
    many: bool,
    /// The later VPLs' flux scale as `FrameStats` reports it: the level-wide
    /// factor times their flux-weighted mean own factor.
    later_reported: [f32; 3],
}

/// What group 1 is built from.
pub(crate) struct GiSources<'a> {
    /// The frame plan (flags).
    pub plan: &'a crate::FramePlan,
    /// The asset on the GPU.
    pub baked: Option<&'a crate::baked::BakedGpu>,
    /// The primary light.
    pub light: &'a crate::light::PrimaryLight,
    /// The per-frame update.
    pub moving: &'a crate::moving::MovingPasses,
    /// The cascades, when planned.
    pub cascades: Option<&'a crate::cascades::CascadePasses>,
    /// The lights after the first, when the scene has them.
    pub other_lights: Option<&'a crate::other_lights::OtherLights>,
}

impl ShadeGi {
    /// Parameters and group 1 for `s`.
    pub(crate) fn new(device: &wgpu::Device, shade: &ShadePass, s: &GiSources<'_>) -> ShadeGi {
        let params = GpuGiParams {
            flags: s.plan.shade_flags(),
            n_static: s.baked.map_or(0, |b| b.vpls.len() as u32),
            map_size: s.baked.map_or(1, |b| b.map_size),
            atlas_cols: s.moving.atlas_cols(),
            n_dynamic: s.moving.dynamic_vpl_slots(),
            static_cols: s.baked.map_or(1, |b| b.static_cols),
            n_other_lights: s.other_lights.map_or(0, |o| o.count),
            descent: s.plan.near_field_descent(),
            lower_cols: s.baked.map_or(1, |b| b.lower_cols),
            lower_row: s.baked.map_or(0, |b| b.lower_row),
            first_later: s
                .baked
                .map_or(0, |b| (b.vpls.len() as u32).saturating_sub(b.later)),
            later_descent: s.plan.later_near_field_descent(),
            later_scale: [1.0; 4],
        };
        let params_buf = uniform(device, "shade gi params", &params);
        let group = Self::group(device, shade, s, &params_buf);
        ShadeGi {
            params,
            params_buf,
            group,
            many: s.other_lights.is_some(),
            later_reported: [1.0; 3],
        }
    }

    fn group(
        device: &wgpu::Device,
        shade: &ShadePass,
        s: &GiSources<'_>,
        params: &wgpu::Buffer,
    ) -> wgpu::BindGroup {
        let m = s.moving.outputs();
        shade.gi_group(
            device,
            &GiInputs {
                primary_static: &s.light.static_map,
                primary_dynamic: m.primary_dynamic,
                light: &s.light.light_buf,
                light_view: &s.light.view_buf,
                params,
                vpls: s.baked.map(|b| &b.vpl_buf),
                occlusion: m.occlusion,
                vpl_tile: m.vpl_tile,
                static_maps: s.baked.map(|b| &b.static_maps),
                atlas: m.atlas,
                dyn_vpls: m.dyn_vpls,
                cascades: s.cascades.map(crate::cascades::CascadePasses::bindings),
                other_lights: s.other_lights,
            },
        )
    }

    /// Rebinds after the merge atlas was re-created.
    pub(crate) fn atlas_changed(
        &mut self,
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        shade: &ShadePass,
        s: &GiSources<'_>,
    ) {
        self.params.atlas_cols = s.moving.atlas_cols();
        queue.write_buffer(&self.params_buf, 0, bytemuck::bytes_of(&self.params));
        self.group = Self::group(device, shade, s, &self.params_buf);
    }

    /// Shades the first `n` dynamic VPL slots from the next frame on (the
    /// views whose bounce the frame computes; written only when it
    /// changes).
    pub(crate) fn set_dynamic_slots(&mut self, queue: &wgpu::Queue, n: u32) {
        if self.params.n_dynamic != n {
            self.params.n_dynamic = n;
            queue.write_buffer(&self.params_buf, 0, bytemuck::bytes_of(&self.params));
        }
    }

    /// Scales the later VPLs' flux from the next frame on by `s` (written
    /// only when it changes); `reported`: the whole scale, `s` times the
    /// later VPLs' own factors' flux-weighted mean, for `FrameStats`.
    pub(crate) fn set_later_scale(
        &mut self,
        queue: &wgpu::Queue,
        s: glam::Vec3,
        reported: glam::Vec3,
    ) {
        self.later_reported = reported.to_array();
        let v = [s.x, s.y, s.z, 1.0];
        if self.params.later_scale != v {
            self.params.later_scale = v;
            queue.write_buffer(&self.params_buf, 0, bytemuck::bytes_of(&self.params));
        }
    }

    /// The later VPLs' flux scale in use, their own factors' flux-weighted
    /// mean included.
    pub(crate) fn later_scale(&self) -> [f32; 3] {
        self.later_reported
    }

    /// Static VPLs shaded.
    pub(crate) fn static_vpls(&self) -> u32 {
        self.params.n_static
    }

    /// Whether the static VPLs end with the later bounces' (which a view
    /// may shade at half resolution).
    pub(crate) fn has_later(&self) -> bool {
        self.params.flags & crate::plan::ShadeFlag::StaticVpl as u32 != 0
            && self.params.first_later < self.params.n_static
    }
}

#[cfg(test)]
mod tests {
    #[test]
    fn runtime_shaders_validate() {
        use gibake_gpu::shaders::{compose, compose_mesh, validate};
        for (name, src) in [
            ("shade.wgsl", compose(&super::shade_wgsl(false))),
            (
                "shade.wgsl (other lights)",
                compose(&super::shade_wgsl(true)),
            ),
            (
                "gbuffer.wgsl",
                compose_mesh(&format!(
                    "{}\n{}",
                    crate::gbuffer::LAYOUT_WGSL,
                    include_str!("gbuffer.wgsl")
                )),
            ),
            (
                "dynamic_rsm.wgsl",
                compose_mesh(include_str!("dynamic_rsm.wgsl")),
            ),
            (
                "occlusion.wgsl",
                compose(crate::dynamic_rsm::OCCLUSION_WGSL),
            ),
            (
                "later_occlusion.wgsl",
                compose(crate::later_occlusion::LATER_OCCLUSION_WGSL),
            ),
            (
                "interleave.wgsl",
                compose(&crate::interleave::interleave_wgsl()),
            ),
        ] {
            if let Err(e) = validate(&src) {
                panic!("{name} does not validate:\n{e}");
            }
        }
    }

    /// The WGSL has no flag constant of its own: every `FLAG_` it uses is
    /// generated from `ShadeFlag`.
    #[test]
    fn shade_wgsl_defines_no_flag_by_hand() {
        let own = include_str!("../src/shade.wgsl");
        assert!(!own.contains("const FLAG_"), "shade.wgsl defines a flag");
        assert!(own.contains("FLAG_DIRECT"));
    }

    /// The pixel an invocation shades, as `cs_main` in shade.wgsl computes
    /// it (the test's twin of the WGSL).
    fn pixel_of(gid: [u32; 2], size: [u32; 2], n: u32) -> [u32; 2] {
        if n == 1 {
            return gid;
        }
        let plane = |s: u32| s.div_ceil(n).div_ceil(8) * 8;
        let p = |g: u32, s: u32| g / plane(s) + n * (g % plane(s));
        [p(gid[0], size[0]), p(gid[1], size[1])]
    }

    /// The deinterleaved dispatch shades every pixel exactly once, and at
    /// N > 1 each 8×8 workgroup shades pixels of one VPL subset only.
    #[test]
    fn the_shade_grid_covers_every_pixel_once_one_subset_per_workgroup() {
        let sizes = [[1, 1], [7, 9], [8, 8], [33, 17], [203, 157], [256, 256]];
        // The later bounces' half-resolution grids too (`cs_later`): each
        // sample's pixel (2i, 2j) inside the image, every pixel column and
        // row within one sample of one.
        for size in sizes {
            let [w, h] = super::later_grid(size);
            assert!(2 * (w - 1) < size[0] && 2 * (h - 1) < size[1], "{size:?}");
            assert!(2 * w >= size[0] && 2 * h >= size[1], "{size:?}");
        }
        for size in sizes.into_iter().chain(sizes.map(super::later_grid)) {
            for n in [1, 2, 4, 8] {
                let [gx, gy] = super::workgroups(size, n);
                let mut seen = vec![0u8; (size[0] * size[1]) as usize];
                for wy in 0..gy {
                    for wx in 0..gx {
                        let mut subsets = std::collections::BTreeSet::new();
                        for ly in 0..8 {
                            for lx in 0..8 {
                                let [x, y] = pixel_of([wx * 8 + lx, wy * 8 + ly], size, n);
                                if x < size[0] && y < size[1] {
                                    seen[(y * size[0] + x) as usize] += 1;
                                    subsets.insert((x % n, y % n));
                                }
                            }
                        }
                        assert!(
                            subsets.len() <= 1,
                            "{size:?} N={n}: a workgroup mixes subsets"
                        );
                    }
                }
                assert!(
                    seen.iter().all(|&c| c == 1),
                    "{size:?} N={n}: a pixel is shaded {} times",
                    seen.iter().find(|&&c| c != 1).unwrap()
                );
            }
        }
    }
}
