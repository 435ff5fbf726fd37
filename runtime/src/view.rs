//! A view: one camera's G-buffer, shading and output. Everything here
//! depends on the output size; the light and GI data a view shades with
//! are the renderer's, shared by every view ([`crate::Renderer::add_view`]).

use gibake_gpu::mesh::{Draw, SceneGpu};

use crate::composite::{Blend, CompositePass};
use crate::gbuffer::{Camera, GBuffer, GBufferPass};
use crate::gbuffer_depth::{DepthGBuffer, DepthGBufferPass};
use crate::interleave::{self, InterleavePass};
use crate::plan::{Pass, ViewPasses};
use crate::shade::{GpuViewParams, ShadePass, ViewInputs, uniform};
use crate::stats::Timer;
use crate::{CameraMatrices, OUTPUT_FORMAT, RuntimeError};

/// A view of one [`crate::Renderer`] (from [`crate::Renderer::add_view`];
/// [`ViewId::MAIN`] is the one [`crate::Renderer::new`] creates).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct ViewId(pub(crate) u32);

impl ViewId {
    /// The view created with the renderer (never removed).
    pub const MAIN: ViewId = ViewId(0);
}

/// Where a view's frame goes ([`crate::Renderer::set_view_output`]).
#[derive(Clone, Copy, Debug)]
pub enum OutputTarget<'a> {
    /// The view's own [`crate::OUTPUT_FORMAT`] texture (the default).
    Own,
    /// The caller's texture of the view's size: an [`crate::OUTPUT_FORMAT`]
    /// texture with `STORAGE_BINDING` usage is shaded into directly; an
    /// `Rgba16Float` or `Rgba32Float` one with `RENDER_ATTACHMENT` usage
    /// gets the radiance written by a composite pass.
    Texture(&'a wgpu::Texture),
    /// Added onto the caller's HDR render target of the view's size
    /// (`Rgba16Float`, or `Rgba32Float` with the `FLOAT32_BLENDABLE`
    /// feature; `RENDER_ATTACHMENT` usage): for a game that lights its own
    /// frame (typically `Mode::Indirect` onto its own direct light).
    Add(&'a wgpu::Texture),
    /// As [`OutputTarget::Add`], the radiance times a factor: the engine's
    /// exposure, for an engine whose own lights are written exposed (Bevy
    /// multiplies every light by its camera's `exposure`). Finite and not
    /// negative.
    AddScaled(&'a wgpu::Texture, f32),
}

/// Where a view's G-buffer comes from.
enum Source {
    /// Rendered by the view's G-buffer pass.
    Own,
    /// The caller's, in gibake's layout, shaded as it is.
    Views(Box<[wgpu::TextureView; 3]>),
    /// The caller's depth and albedo, its normals (repacked unless packed).
    Depth(Box<DepthGBufferPass>),
}

/// One view's resources.
pub(crate) struct View {
    /// [`crate::RenderSettings::interleave`] as asked (0: automatic).
    interleave_setting: u32,
    params: GpuViewParams,
    params_buf: wgpu::Buffer,
    camera: Camera,
    gbuffer: GBuffer,
    source: Source,
    /// The interleave filter (interleave > 1 only).
    interleave: Option<InterleavePass>,
    /// The view's own radiance texture ([`crate::OUTPUT_FORMAT`]).
    own: wgpu::Texture,
    /// The texture shading writes: the own one or the caller's storage
    /// texture.
    radiance: wgpu::Texture,
    radiance_view: wgpu::TextureView,
    /// Into the caller's render target, when it gave one.
    composite: Option<CompositePass>,
    /// Shading's group 0.
    group: wgpu::BindGroup,
    /// The camera of the last prepared frame (a G-buffer source given
    /// between `prepare` and `record` rebuilds with it).
    last_camera: Option<CameraMatrices>,
}

/// Checks an output size (with its interleave setting: the interleaved
/// shading target is twice as wide) against the device.
pub(crate) fn check_size(
    device: &wgpu::Device,
    width: u32,
    height: u32,
    interleave_setting: u32,
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
    if interleave::effective(interleave_setting, width, height) > 1
        && u64::from(width) * 2 > u64::from(limit)
    {
        return Err(RuntimeError::DeviceLimit {
            what: format!(
                "the interleaved shading target of a {width}-pixel-wide output (twice as wide; interleave 1 needs none)"
            ),
            needed: 2 * u64::from(width),
            limit: u64::from(limit),
        });
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

/// Checks that the caller's `t` can be shaded into directly.
fn check_storage_target(t: &wgpu::Texture, (w, h): (u32, u32)) -> Result<(), RuntimeError> {
    let problem = if t.dimension() != wgpu::TextureDimension::D2 || t.sample_count() != 1 {
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
    match problem {
        Some(p) => Err(RuntimeError::OutputTarget(p)),
        None => Ok(()),
    }
}

/// The shared passes a view records with.
pub(crate) type Passes<'a> = (&'a ShadePass, &'a GBufferPass, &'a SceneGpu);

impl View {
    /// A `width × height` view (size checked by the caller) with its own
    /// G-buffer and output.
    pub(crate) fn new(
        device: &wgpu::Device,
        (shade, gbuffer_pass, scene_gpu): Passes<'_>,
        size: [u32; 2],
        interleave_setting: u32,
    ) -> View {
        let params = GpuViewParams {
            size,
            interleave: interleave::effective(interleave_setting, size[0], size[1]),
            far_depth: 0.0,
            eye: [0.0; 4],
            inv_view_proj: glam::Mat4::IDENTITY.to_cols_array_2d(),
            later_half: 0,
            _pad: [0; 3],
        };
        let params_buf = uniform(device, "shade view params", &params);
        let gbuffer = GBuffer::new(device, size[0], size[1]);
        let own = own_output(device, size[0], size[1]);
        let radiance_view = own.create_view(&Default::default());
        let mut interleave =
            (params.interleave > 1).then(|| InterleavePass::new(device, size, false));
        let group = bind(
            device,
            shade,
            &params_buf,
            gbuffer.views.each_ref(),
            interleave.as_mut(),
            &radiance_view,
        );
        View {
            interleave_setting,
            params,
            params_buf,
            camera: gbuffer_pass.camera(device, scene_gpu),
            gbuffer,
            source: Source::Own,
            interleave,
            radiance: own.clone(),
            own,
            radiance_view,
            composite: None,
            group,
            last_camera: None,
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
        self.params.far_depth = 0.0;
        // Half-resolution later bounces need the interleave filter.
        let later = self.params.later_half != 0 && self.params.interleave > 1;
        self.params.later_half = u32::from(later);
        queue.write_buffer(&self.params_buf, 0, bytemuck::bytes_of(&self.params));
        self.gbuffer = GBuffer::new(device, size[0], size[1]);
        self.source = Source::Own;
        self.own = own_output(device, size[0], size[1]);
        self.radiance = self.own.clone();
        self.radiance_view = self.radiance.create_view(&Default::default());
        self.composite = None;
        self.interleave =
            (self.params.interleave > 1).then(|| InterleavePass::new(device, size, later));
        self.rebind(device, shade);
    }

    /// Shades the later bounces' VPLs on the half-resolution grid when
    /// `want` (the asset has them, [`crate::RenderSettings::
    /// later_full_resolution`] is off) and the view is interleaved (the
    /// filter brings them up to full resolution); with the rest of the VPLs
    /// otherwise. Makes or drops their textures when that changes; returns
    /// whether the view shades them at half resolution.
    pub(crate) fn set_later(
        &mut self,
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        shade: &ShadePass,
        want: bool,
    ) -> bool {
        let later = want && self.params.interleave > 1;
        if later != (self.params.later_half != 0) {
            self.params.later_half = u32::from(later);
            queue.write_buffer(&self.params_buf, 0, bytemuck::bytes_of(&self.params));
            self.interleave = (self.params.interleave > 1)
                .then(|| InterleavePass::new(device, self.params.size, later));
            self.rebind(device, shade);
        }
        later
    }

    /// Re-creates the camera's bind group over a new scene's meshes (after
    /// [`crate::Renderer::set_asset`]); the camera matrices come with the
    /// next frame.
    pub(crate) fn set_scene(
        &mut self,
        device: &wgpu::Device,
        gbuffer_pass: &GBufferPass,
        scene_gpu: &SceneGpu,
    ) {
        self.camera = gbuffer_pass.camera(device, scene_gpu);
    }

    /// [`crate::RenderSettings::interleave`] as asked for this view.
    pub(crate) fn interleave_setting(&self) -> u32 {
        self.interleave_setting
    }

    /// The output size.
    pub(crate) fn size(&self) -> (u32, u32) {
        (self.params.size[0], self.params.size[1])
    }

    /// The interleave factor in use.
    pub(crate) fn interleave(&self) -> u32 {
        self.params.interleave
    }

    /// Whether the view draws the scene into its G-buffer.
    pub(crate) fn draws_gbuffer(&self) -> bool {
        matches!(self.source, Source::Own)
    }

    /// What decides this view's passes.
    pub(crate) fn passes(&self) -> ViewPasses {
        ViewPasses {
            gbuffer: match &self.source {
                Source::Own => true,
                Source::Views(_) => false,
                Source::Depth(p) => p.has_pass(),
            },
            interleave: self.params.interleave,
            composite: self.composite.is_some(),
        }
    }

    /// Sets the frame's camera.
    pub(crate) fn set_camera(&mut self, queue: &wgpu::Queue, camera: &CameraMatrices) {
        // One pixel's angle (or size): 2 / (|clip y row| · height).
        let vp = camera.view_proj;
        let f = glam::Vec3::new(vp.x_axis.y, vp.y_axis.y, vp.z_axis.y).length();
        let pixel = 2.0 / (f * self.params.size[1].max(1) as f32);
        let w = if camera.orthographic { -pixel } else { pixel };
        self.params.eye = camera
            .position
            .extend(if w.is_finite() { w } else { 0.0 })
            .to_array();
        self.params.inv_view_proj = camera.inv_view_proj().to_cols_array_2d();
        queue.write_buffer(&self.params_buf, 0, bytemuck::bytes_of(&self.params));
        queue.write_buffer(
            &self.camera.uniform_buf,
            0,
            bytemuck::bytes_of(&camera.to_gpu()),
        );
        if let Source::Depth(p) = &mut self.source {
            p.set_camera(queue, camera);
        }
        self.last_camera = Some(*camera);
    }

    /// Sends the frame to `target` from now on.
    pub(crate) fn set_output(
        &mut self,
        device: &wgpu::Device,
        shade: &ShadePass,
        target: OutputTarget<'_>,
    ) -> Result<(), RuntimeError> {
        let (w, h) = self.size();
        let composite = |t: &wgpu::Texture, blend, scale: f32| {
            crate::composite::check_target(device, t, (w, h), blend)?;
            if !(scale.is_finite() && scale >= 0.0) {
                return Err(RuntimeError::InvalidSetting(format!(
                    "the scale of an added output must be finite and not negative, not {scale}"
                )));
            }
            Ok::<_, RuntimeError>(Some((t.clone(), blend, scale)))
        };
        let storage = |t: &wgpu::Texture| {
            t.format() == OUTPUT_FORMAT && t.usage().contains(wgpu::TextureUsages::STORAGE_BINDING)
        };
        // Check first; change nothing on an error.
        let (direct, into) = match target {
            OutputTarget::Own => (None, None),
            OutputTarget::Texture(t) if storage(t) => {
                check_storage_target(t, (w, h))?;
                (Some(t.clone()), None)
            }
            OutputTarget::Texture(t) => (None, composite(t, Blend::Replace, 1.0)?),
            OutputTarget::Add(t) => (None, composite(t, Blend::Add, 1.0)?),
            OutputTarget::AddScaled(t, s) => (None, composite(t, Blend::Add, s)?),
        };
        let radiance = direct.unwrap_or_else(|| self.own.clone());
        // The same radiance into the same target: only the scale can
        // change (an engine handing its target every frame).
        if radiance == self.radiance {
            match (&mut self.composite, &into) {
                (None, None) => return Ok(()),
                (Some(c), Some((t, blend, scale))) if c.writes(t, *blend) => {
                    c.set_scale(*scale);
                    return Ok(());
                }
                _ => {}
            }
        }
        let changed = radiance != self.radiance;
        if changed {
            self.radiance = radiance;
            self.radiance_view = self.radiance.create_view(&Default::default());
        }
        self.composite = into.map(|(t, blend, scale)| {
            CompositePass::new(
                device,
                &shade.composite,
                &self.radiance_view,
                &t,
                blend,
                scale,
            )
        });
        if changed {
            self.rebind(device, shade);
        }
        Ok(())
    }

    /// Shades the caller's G-buffer views (gibake's layout) from now on.
    pub(crate) fn use_gbuffer_views(
        &mut self,
        device: &wgpu::Device,
        shade: &ShadePass,
        views: [&wgpu::TextureView; 3],
    ) {
        self.source = Source::Views(Box::new(views.map(|v| v.clone())));
        self.set_far_depth(device, 0.0);
        self.rebind(device, shade);
    }

    /// The depth of "no surface" in the view's G-buffer: a new uniform
    /// (no queue at hand; the caller rebinds), holding the prepared camera.
    fn set_far_depth(&mut self, device: &wgpu::Device, far_depth: f32) {
        if self.params.far_depth != far_depth {
            self.params.far_depth = far_depth;
            self.params_buf = uniform(device, "shade view params", &self.params);
        }
    }

    /// Rebuilds the G-buffer from the caller's depth, normals and albedo
    /// every frame from now on.
    pub(crate) fn use_depth_gbuffer(
        &mut self,
        device: &wgpu::Device,
        shade: &ShadePass,
        src: &DepthGBuffer<'_>,
    ) -> Result<(), RuntimeError> {
        let pass = DepthGBufferPass::new(
            device,
            &shade.depth_gbuffer,
            src,
            &self.gbuffer,
            self.size(),
            self.last_camera.as_ref(),
        )?;
        self.set_far_depth(device, pass.far_depth());
        self.source = Source::Depth(Box::new(pass));
        // Shading reads the engine's depth and albedo: group 0 follows them.
        self.rebind(device, shade);
        Ok(())
    }

    /// Rebinds group 0 (and the interleave filter) to the current output
    /// and G-buffer (the caller's, if it provides one).
    fn rebind(&mut self, device: &wgpu::Device, shade: &ShadePass) {
        let g: [&wgpu::TextureView; 3] = match &self.source {
            Source::Views(v) => v.each_ref(),
            Source::Depth(p) => p.views(&self.gbuffer),
            Source::Own => self.gbuffer.views.each_ref(),
        };
        self.group = bind(
            device,
            shade,
            &self.params_buf,
            g,
            self.interleave.as_mut(),
            &self.radiance_view,
        );
    }

    /// The camera of the last prepared frame.
    pub(crate) fn last_camera(&self) -> Option<&CameraMatrices> {
        self.last_camera.as_ref()
    }

    /// The depth shading reads and its "no surface" value: the engine's
    /// (`use_depth_gbuffer`) or the view's own (reversed Z, 0).
    pub(crate) fn shaded_depth(&self) -> (&wgpu::Texture, f32) {
        match &self.source {
            Source::Depth(p) => (p.depth(), p.far_depth()),
            _ => (self.gbuffer.depth(), 0.0),
        }
    }

    /// The view's own G-buffer.
    pub(crate) fn gbuffer(&self) -> &GBuffer {
        &self.gbuffer
    }

    /// The view's radiance texture.
    pub(crate) fn output(&self) -> &wgpu::Texture {
        &self.radiance
    }

    /// A view of [`View::output`].
    pub(crate) fn output_view(&self) -> &wgpu::TextureView {
        &self.radiance_view
    }

    /// Records the view's G-buffer (unless the caller's is used as it is),
    /// shading, filter and composite. `k` is the view's rank this frame.
    pub(crate) fn record(
        &self,
        encoder: &mut wgpu::CommandEncoder,
        (shade, gbuffer_pass, scene_gpu): Passes<'_>,
        moving: &[Draw],
        gi: &crate::shade::ShadeGi,
        timer: &Timer,
        k: u32,
    ) {
        let k = Some(k);
        match &self.source {
            Source::Own => {
                let all = [&scene_gpu.static_draws[..], moving];
                gbuffer_pass.encode(
                    encoder,
                    &self.gbuffer,
                    &self.camera,
                    scene_gpu,
                    &all,
                    timer.render(Pass::GBuffer, k),
                );
            }
            Source::Depth(p) => p.encode(encoder, timer.compute(Pass::GBuffer, k)),
            Source::Views(_) => {}
        }
        shade.encode(
            encoder,
            &self.group,
            gi,
            (
                self.params.size,
                self.params.interleave,
                self.params.later_half != 0,
            ),
            timer.compute(Pass::Shade, k),
        );
        if let Some(il) = &self.interleave {
            il.encode(encoder, timer.compute(Pass::Interleave, k));
        }
        if let Some(c) = &self.composite {
            c.encode(encoder, timer.render(Pass::Composite, k));
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
    let (shade_out, later) = match interleave {
        Some(il) => {
            il.bind(device, gbuffer, params, output);
            let later = il.later.as_ref().map(|l| l.raw.clone());
            (il.shaded.clone(), later)
        }
        None => (output.clone(), None),
    };
    shade.view_group(
        device,
        &ViewInputs {
            gbuffer,
            params,
            output: &shade_out,
            later: later.as_ref().unwrap_or(&shade.fallback_later),
        },
    )
}
