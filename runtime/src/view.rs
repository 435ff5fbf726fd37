//! A view: one camera's G-buffer, shading and output. Everything here
//! depends on the output size; the light and GI data it shades with are
//! the renderer's, shared by every view.

use gibake_gpu::mesh::SceneGpu;

use crate::gbuffer::{Camera, GBuffer, GBufferPass};
use crate::interleave::{self, InterleavePass};
use crate::plan::{Pass, ViewPasses};
use crate::shade::{GpuViewParams, ShadePass, ViewInputs, uniform};
use crate::stats::Timer;
use crate::{CameraMatrices, OUTPUT_FORMAT, RuntimeError};

/// One view's resources.
pub(crate) struct View {
    /// [`crate::RenderSettings::interleave`] as asked (0: automatic).
    interleave_setting: u32,
    params: GpuViewParams,
    params_buf: wgpu::Buffer,
    camera: Camera,
    gbuffer: GBuffer,
    /// The caller's G-buffer views, when it provides them.
    external_gbuffer: Option<[wgpu::TextureView; 3]>,
    /// The interleave filter (interleave > 1 only).
    interleave: Option<InterleavePass>,
    /// The view's output (its own, or the caller's).
    output: wgpu::Texture,
    output_view: wgpu::TextureView,
    /// Shading's group 0.
    group: wgpu::BindGroup,
}

/// Checks an output size against the device.
pub(crate) fn check_size(
    device: &wgpu::Device,
    width: u32,
    height: u32,
) -> Result<(), RuntimeError> {
    let limit = device.limits().max_texture_dimension_2d;
    for (what, v) in [("width", width), ("height", height)] {
        if v == 0 {
            return Err(RuntimeError::InvalidSetting(format!(
                "{what} must be at least 1"
            )));
        }
        if v > limit {
            return Err(RuntimeError::DeviceLimit {
                what: format!("an output {what} of {v} pixels"),
                needed: u64::from(v),
                limit: u64::from(limit),
            });
        }
    }
    Ok(())
}

/// A view's own output texture.
fn own_output(device: &wgpu::Device, width: u32, height: u32) -> wgpu::Texture {
    gibake_gpu::util::texture_2d(
        device,
        "radiance",
        width,
        height,
        OUTPUT_FORMAT,
        wgpu::TextureUsages::STORAGE_BINDING
            | wgpu::TextureUsages::TEXTURE_BINDING
            | wgpu::TextureUsages::COPY_SRC,
    )
}

impl View {
    /// A `width × height` view (size checked by the caller) with its own
    /// G-buffer and output.
    pub(crate) fn new(
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        passes: (&ShadePass, &GBufferPass, &SceneGpu),
        size: [u32; 2],
        interleave_setting: u32,
    ) -> View {
        let (shade, gbuffer_pass, scene_gpu) = passes;
        let params = GpuViewParams {
            size,
            interleave: interleave::effective(interleave_setting, size[0], size[1]),
            _pad: 0,
        };
        let params_buf = uniform(device, "shade view params", &params);
        let gbuffer = GBuffer::new(device, size[0], size[1]);
        let output = own_output(device, size[0], size[1]);
        let output_view = output.create_view(&Default::default());
        let mut interleave = (params.interleave > 1)
            .then(|| InterleavePass::new(device, queue, size, params.interleave));
        let group = bind(
            device,
            shade,
            &params_buf,
            gbuffer.views.each_ref(),
            interleave.as_mut(),
            &output_view,
        );
        View {
            interleave_setting,
            params,
            params_buf,
            camera: gbuffer_pass.camera(device, scene_gpu),
            gbuffer,
            external_gbuffer: None,
            interleave,
            output,
            output_view,
            group,
        }
    }

    /// A new G-buffer and own output at `size` (the caller provides its
    /// G-buffer or output again); the camera stays.
    pub(crate) fn resize(
        &mut self,
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        shade: &ShadePass,
        size: [u32; 2],
    ) {
        self.params.size = size;
        self.params.interleave = interleave::effective(self.interleave_setting, size[0], size[1]);
        queue.write_buffer(&self.params_buf, 0, bytemuck::bytes_of(&self.params));
        self.gbuffer = GBuffer::new(device, size[0], size[1]);
        self.external_gbuffer = None;
        self.output = own_output(device, size[0], size[1]);
        self.output_view = self.output.create_view(&Default::default());
        self.interleave = (self.params.interleave > 1)
            .then(|| InterleavePass::new(device, queue, size, self.params.interleave));
        self.rebind(device, shade);
    }

    /// The output size.
    pub(crate) fn size(&self) -> (u32, u32) {
        (self.params.size[0], self.params.size[1])
    }

    /// The interleave factor in use.
    pub(crate) fn interleave(&self) -> u32 {
        self.params.interleave
    }

    /// What decides this view's passes.
    pub(crate) fn passes(&self) -> ViewPasses {
        ViewPasses {
            external_gbuffer: self.external_gbuffer.is_some(),
            interleave: self.params.interleave,
        }
    }

    /// Sets the frame's camera.
    pub(crate) fn set_camera(&self, queue: &wgpu::Queue, camera: &CameraMatrices) {
        queue.write_buffer(
            &self.camera.uniform_buf,
            0,
            bytemuck::bytes_of(&camera.to_gpu()),
        );
    }

    /// Renders into `texture` from now on (`None`: the view's own output).
    pub(crate) fn set_output(
        &mut self,
        device: &wgpu::Device,
        shade: &ShadePass,
        texture: Option<&wgpu::Texture>,
    ) -> Result<(), RuntimeError> {
        let (w, h) = self.size();
        if let Some(t) = texture {
            let problem = if t.format() != OUTPUT_FORMAT {
                Some(format!("format {:?}, needs {OUTPUT_FORMAT:?}", t.format()))
            } else if !t.usage().contains(wgpu::TextureUsages::STORAGE_BINDING) {
                Some("needs STORAGE_BINDING usage".to_string())
            } else if t.dimension() != wgpu::TextureDimension::D2 || t.sample_count() != 1 {
                Some("needs a single-sampled 2D texture".to_string())
            } else if (t.width(), t.height()) != (w, h) {
                Some(format!(
                    "{}×{}, the output is {w}×{h} (resize first)",
                    t.width(),
                    t.height()
                ))
            } else {
                None
            };
            if let Some(p) = problem {
                return Err(RuntimeError::OutputTarget(p));
            }
        }
        self.output = match texture {
            Some(t) => t.clone(),
            None => own_output(device, w, h),
        };
        self.output_view = self.output.create_view(&Default::default());
        self.rebind(device, shade);
        Ok(())
    }

    /// Shades the caller's G-buffer views from now on.
    pub(crate) fn use_external_gbuffer(
        &mut self,
        device: &wgpu::Device,
        shade: &ShadePass,
        views: [&wgpu::TextureView; 3],
    ) {
        self.external_gbuffer = Some(views.map(|v| v.clone()));
        self.rebind(device, shade);
    }

    /// Rebinds group 0 (and the interleave filter) to the current output
    /// and G-buffer (the caller's, if it provides one).
    fn rebind(&mut self, device: &wgpu::Device, shade: &ShadePass) {
        let g = self
            .external_gbuffer
            .as_ref()
            .unwrap_or(&self.gbuffer.views);
        self.group = bind(
            device,
            shade,
            &self.params_buf,
            g.each_ref(),
            self.interleave.as_mut(),
            &self.output_view,
        );
    }

    /// The view's own G-buffer.
    pub(crate) fn gbuffer(&self) -> &GBuffer {
        &self.gbuffer
    }

    /// The output texture.
    pub(crate) fn output(&self) -> &wgpu::Texture {
        &self.output
    }

    /// A view of the output texture.
    pub(crate) fn output_view(&self) -> &wgpu::TextureView {
        &self.output_view
    }

    /// Records the view's G-buffer (unless external), shading and filter.
    pub(crate) fn record(
        &self,
        encoder: &mut wgpu::CommandEncoder,
        (shade, gbuffer_pass, scene_gpu): (&ShadePass, &GBufferPass, &SceneGpu),
        gi_group: &wgpu::BindGroup,
        timer: &Timer,
    ) {
        if self.external_gbuffer.is_none() {
            let all = [&scene_gpu.static_draws[..], &scene_gpu.dynamic_draws[..]];
            gbuffer_pass.encode(
                encoder,
                &self.gbuffer,
                &self.camera,
                scene_gpu,
                &all,
                timer.render(Pass::GBuffer),
            );
        }
        shade.encode(
            encoder,
            &self.group,
            gi_group,
            self.params.size,
            timer.compute(Pass::Shade),
        );
        if let Some(il) = &self.interleave {
            il.encode(encoder, timer.compute(Pass::Interleave));
        }
    }
}

/// Group 0 of shading for this G-buffer and output; interleaved, shading
/// writes the filter's input, which the filter (bound here) resolves into
/// `output`.
fn bind(
    device: &wgpu::Device,
    shade: &ShadePass,
    params: &wgpu::Buffer,
    gbuffer: [&wgpu::TextureView; 3],
    interleave: Option<&mut InterleavePass>,
    output: &wgpu::TextureView,
) -> wgpu::BindGroup {
    let shade_out = match interleave {
        Some(il) => {
            il.bind(device, gbuffer, output);
            il.shaded.clone()
        }
        None => output.clone(),
    };
    shade.view_group(
        device,
        &ViewInputs {
            gbuffer,
            params,
            output: &shade_out,
        },
    )
}
