//! Reconstruction pass of interleaved VPL sampling (compute,
//! `interleave.wgsl`). With [`crate::RenderSettings::interleave`] `N > 1`
//! the shade pass gives each pixel of an N×N block a disjoint 1/N² subset
//! of the VPLs (scaled by N²) and writes direct radiance and that
//! irradiance estimate side by side into [`InterleavePass::shaded`]; this
//! pass filters the irradiance over the pixel's neighbours on the same
//! surface (normal and tangent-plane similarity, scale-invariant) and
//! writes the final radiance. With `N = 1` neither this pass nor its
//! texture exists.
//!
//! The later bounces at half resolution (an asset baked with every bounce;
//! [`crate::RenderSettings::later_full_resolution`] off): the shade pass's
//! `cs_later` writes their interleaved estimates on the half-resolution
//! grid into [`LaterHalf::raw`]; this pass first filters them on that grid
//! (`cs_later_filter`, into [`LaterHalf::filtered`]), then adds them to
//! each pixel from the samples around it. Their light is smooth, and a
//! later VPL tiles a wide stretch of the surfaces, so its near-field tree
//! descends almost everywhere: at a quarter of the samples it costs a
//! quarter (docs/method.md, "Every bounce" → "Frame cost: the later bounces at half resolution").

use gibake_gpu::shaders;

use crate::shade::{RADIANCE_FORMAT, later_grid, storage_texture_entry, uint_tex_entry};

/// The pass's WGSL: the G-buffer layout, then its own.
pub(crate) fn interleave_wgsl() -> String {
    format!(
        "{}\n{}",
        crate::gbuffer::LAYOUT_WGSL,
        include_str!("interleave.wgsl")
    )
}

/// The interleave values [`crate::RenderSettings::interleave`] accepts
/// (0: [`AUTO`]).
pub(crate) const VALID: [u32; 5] = [AUTO, 1, 2, 4, 8];

/// [`crate::RenderSettings::interleave`] = 0: chosen from the output size
/// by [`effective`].
pub(crate) const AUTO: u32 = 0;

/// Output pixels from which [`AUTO`] interleaves 4×4: 256². Measured
/// (`gibake bench interleave` and `quality`, docs/results.md): at 256² and
/// `--vpls 664`, N = 4 shades in 0.08–0.17× the time of N = 1 at 1.00–1.08×
/// its rel MSE and FLIP on the bundled scenes; at 64² the filter has too few
/// neighbours on a surface and N = 4 cost up to 1.40× the rel MSE, so
/// smaller outputs sum every VPL.
pub(crate) const AUTO_MIN_PIXELS: u64 = 256 * 256;

/// The interleave factor used for `setting` at `width × height`.
pub(crate) fn effective(setting: u32, width: u32, height: u32) -> u32 {
    match setting {
        AUTO if u64::from(width) * u64::from(height) >= AUTO_MIN_PIXELS => 4,
        AUTO => 1,
        n => n,
    }
}

/// The filter pass: pipeline, layout and the shade pass's intermediate
/// texture. It reads the view's own `ViewParams` uniform (size, N, the
/// camera that rebuilds positions from the depth).
pub(crate) struct InterleavePass {
    pipeline: wgpu::ComputePipeline,
    layout: wgpu::BindGroupLayout,
    /// `2·width × height` `Rgba32Float`: direct radiance in the left half,
    /// the interleaved irradiance estimate in the right half.
    pub(crate) shaded: wgpu::TextureView,
    group: Option<wgpu::BindGroup>,
    size: [u32; 2],
    /// The later bounces at half resolution, when the view shades them so.
    pub(crate) later: Option<LaterHalf>,
    /// A 1×1 texture bound as `later_in` without them.
    no_later: wgpu::TextureView,
}

/// The later bounces' half-resolution textures and filter.
pub(crate) struct LaterHalf {
    filter: wgpu::ComputePipeline,
    /// The shade pass's estimates, [`crate::shade::later_grid`] of the
    /// view's size, `Rgba32Float`.
    pub(crate) raw: wgpu::TextureView,
    /// Those estimates filtered on their grid.
    filtered: wgpu::TextureView,
    group: Option<wgpu::BindGroup>,
}

const COMPUTE: wgpu::ShaderStages = wgpu::ShaderStages::COMPUTE;

impl InterleavePass {
    /// Creates the pass and its intermediate texture for `size`, with the
    /// later bounces' half-resolution textures when `later`.
    pub(crate) fn new(device: &wgpu::Device, size: [u32; 2], later: bool) -> InterleavePass {
        let module = shaders::module(device, "interleave.wgsl", &interleave_wgsl());
        use wgpu::TextureViewDimension::D2;
        let tex = |b| gibake_gpu::util::texture_entry(b, COMPUTE, D2);
        let layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("interleave"),
            entries: &[
                tex(0),
                uint_tex_entry(1),
                uint_tex_entry(2),
                tex(3),
                gibake_gpu::util::uniform_entry(4, COMPUTE),
                storage_texture_entry(5),
                tex(6),
            ],
        });
        let pl = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some("interleave"),
            bind_group_layouts: &[Some(&layout)],
            immediate_size: 0,
        });
        let entry = |label, entry_point| {
            device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
                label: Some(label),
                layout: Some(&pl),
                module: &module,
                entry_point: Some(entry_point),
                compilation_options: Default::default(),
                cache: None,
            })
        };
        let target = |label, [w, h]: [u32; 2], usage| {
            gibake_gpu::util::texture_2d(device, label, w, h, RADIANCE_FORMAT, usage)
                .create_view(&Default::default())
        };
        let rw = wgpu::TextureUsages::STORAGE_BINDING | wgpu::TextureUsages::TEXTURE_BINDING;
        let later = later.then(|| LaterHalf {
            filter: entry("interleave later bounces", "cs_later_filter"),
            raw: target("later bounces, half resolution", later_grid(size), rw),
            filtered: target("later bounces, filtered", later_grid(size), rw),
            group: None,
        });
        InterleavePass {
            pipeline: entry("interleave", "cs_main"),
            layout,
            shaded: target("interleaved shading", [size[0] * 2, size[1]], rw),
            group: None,
            size,
            later,
            no_later: target(
                "no later bounces",
                [1, 1],
                wgpu::TextureUsages::TEXTURE_BINDING,
            ),
        }
    }

    /// Binds the G-buffer views, the view's `ViewParams` and the final
    /// output (again after the G-buffer changes).
    pub(crate) fn bind(
        &mut self,
        device: &wgpu::Device,
        gbuffer: [&wgpu::TextureView; 3],
        params: &wgpu::Buffer,
        output: &wgpu::TextureView,
    ) {
        let tv = wgpu::BindingResource::TextureView;
        let group = |label, input, out, later_in| {
            let entries = [
                (0, tv(gbuffer[0])),
                (1, tv(gbuffer[1])),
                (2, tv(gbuffer[2])),
                (3, tv(input)),
                (4, params.as_entire_binding()),
                (5, tv(out)),
                (6, tv(later_in)),
            ]
            .map(|(binding, resource)| wgpu::BindGroupEntry { binding, resource });
            device.create_bind_group(&wgpu::BindGroupDescriptor {
                label: Some(label),
                layout: &self.layout,
                entries: &entries,
            })
        };
        let later_in = self.later.as_ref().map_or(&self.no_later, |l| &l.filtered);
        self.group = Some(group("interleave", &self.shaded, output, later_in));
        if let Some(l) = &self.later {
            let g = group(
                "interleave later bounces",
                &l.raw,
                &l.filtered,
                &self.no_later,
            );
            self.later.as_mut().expect("just matched").group = Some(g);
        }
    }

    /// Records the pass.
    pub(crate) fn encode(
        &self,
        encoder: &mut wgpu::CommandEncoder,
        timestamps: Option<wgpu::ComputePassTimestampWrites<'_>>,
    ) {
        let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
            label: Some("interleave"),
            timestamp_writes: timestamps,
        });
        if let Some(l) = &self.later {
            // Its own dispatch, so its writes are seen by the next one.
            let [w, h] = later_grid(self.size);
            pass.set_pipeline(&l.filter);
            pass.set_bind_group(0, l.group.as_ref().expect("bound with the view"), &[]);
            pass.dispatch_workgroups(w.div_ceil(8), h.div_ceil(8), 1);
        }
        pass.set_pipeline(&self.pipeline);
        pass.set_bind_group(0, self.group.as_ref().expect("bound in Renderer::new"), &[]);
        pass.dispatch_workgroups(self.size[0].div_ceil(8), self.size[1].div_ceil(8), 1);
    }
}

#[cfg(test)]
mod auto_tests {
    use super::*;

    /// Automatic interleave: 4×4 from 256² pixels on, the exact sum below;
    /// explicit factors pass through.
    #[test]
    fn auto_follows_the_output_size() {
        assert_eq!(effective(AUTO, 256, 256), 4);
        assert_eq!(effective(AUTO, 1280, 720), 4);
        assert_eq!(effective(AUTO, 255, 256), 1);
        assert_eq!(effective(AUTO, 64, 64), 1);
        assert_eq!(effective(AUTO, u32::MAX, u32::MAX), 4);
        for n in [1, 2, 4, 8] {
            assert_eq!(effective(n, 64, 64), n);
            assert_eq!(effective(n, 1024, 1024), n);
        }
    }
}
