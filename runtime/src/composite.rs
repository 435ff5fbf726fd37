//! The composite pass (`composite.wgsl`): a view's radiance written into,
//! or added onto, the caller's render target of a float format —
//! `Rgba16Float` (the usual HDR target) or `Rgba32Float` — when the caller
//! does not hand over an `Rgba32Float` storage texture to shade into
//! directly. Adding is for a game that lights its own frame (typically
//! `Mode::Indirect` onto its own direct light), scaled by the engine's
//! exposure where it has one (the blend constant: no uniform, no new bind
//! group when only the scale changes).
//!
//! The pipelines are made once per (target format, blend) and kept
//! ([`Pipelines`]): a caller whose target changes every frame (an engine's
//! pooled or ping-pong HDR textures) hands the new one to `set_output`
//! each frame and pays for a texture view and a bind group, never for a
//! pipeline again.

use std::sync::{Mutex, OnceLock};

use crate::RuntimeError;

/// How the view's radiance reaches the caller's target.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Blend {
    /// Overwrite (alpha 1).
    Replace,
    /// `target += scale · radiance` (alpha kept; the scale is the blend
    /// constant, 1 for a plain add).
    Add,
}

/// The pass for one target.
pub(crate) struct CompositePass {
    pipeline: wgpu::RenderPipeline,
    group: wgpu::BindGroup,
    /// The caller's texture and a view of it.
    texture: wgpu::Texture,
    target: wgpu::TextureView,
    kind: Blend,
    /// The blend constant of [`Blend::Add`].
    scale: f32,
}

/// The composite pipelines of one renderer, made when first needed.
#[derive(Default)]
pub(crate) struct Pipelines {
    module: OnceLock<wgpu::ShaderModule>,
    made: Mutex<Vec<(wgpu::TextureFormat, Blend, wgpu::RenderPipeline)>>,
}

impl Pipelines {
    /// The pipeline writing `format` with `blend` (made once).
    fn get(
        &self,
        device: &wgpu::Device,
        format: wgpu::TextureFormat,
        blend: Blend,
    ) -> wgpu::RenderPipeline {
        let mut made = self.made.lock().unwrap_or_else(|e| e.into_inner());
        if let Some((_, _, p)) = made.iter().find(|(f, b, _)| *f == format && *b == blend) {
            return p.clone();
        }
        let module = self.module.get_or_init(|| {
            device.create_shader_module(wgpu::ShaderModuleDescriptor {
                label: Some("composite.wgsl"),
                source: wgpu::ShaderSource::Wgsl(include_str!("composite.wgsl").into()),
            })
        });
        let p = pipeline(device, module, format, blend);
        made.push((format, blend, p.clone()));
        p
    }
}

/// Checks that `t` can take a `w × h` view's radiance with `blend`.
pub(crate) fn check_target(
    device: &wgpu::Device,
    t: &wgpu::Texture,
    (w, h): (u32, u32),
    blend: Blend,
) -> Result<(), RuntimeError> {
    use wgpu::TextureFormat as F;
    let problem = if !matches!(t.format(), F::Rgba16Float | F::Rgba32Float) {
        Some(format!(
            "format {:?}; a render target needs Rgba16Float or Rgba32Float",
            t.format()
        ))
    } else if blend == Blend::Add
        && t.format() == F::Rgba32Float
        && !device
            .features()
            .contains(wgpu::Features::FLOAT32_BLENDABLE)
    {
        Some("adding into an Rgba32Float target needs the FLOAT32_BLENDABLE feature; use Rgba16Float".into())
    } else if !t.usage().contains(wgpu::TextureUsages::RENDER_ATTACHMENT) {
        Some("needs RENDER_ATTACHMENT usage".into())
    } else if t.dimension() != wgpu::TextureDimension::D2 || t.sample_count() != 1 {
        Some("needs a single-sampled 2D texture".into())
    } else if (t.width(), t.height()) != (w, h) {
        Some(format!(
            "{}×{}, the view is {w}×{h} (resize first)",
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

fn pipeline(
    device: &wgpu::Device,
    module: &wgpu::ShaderModule,
    format: wgpu::TextureFormat,
    blend: Blend,
) -> wgpu::RenderPipeline {
    let add = wgpu::BlendComponent {
        src_factor: wgpu::BlendFactor::Constant,
        dst_factor: wgpu::BlendFactor::One,
        operation: wgpu::BlendOperation::Add,
    };
    let keep = wgpu::BlendComponent {
        src_factor: wgpu::BlendFactor::Zero,
        dst_factor: wgpu::BlendFactor::One,
        operation: wgpu::BlendOperation::Add,
    };
    let blend = match blend {
        Blend::Replace => None,
        Blend::Add => Some(wgpu::BlendState {
            color: add,
            alpha: keep,
        }),
    };
    device.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
        label: Some("composite"),
        layout: None,
        vertex: wgpu::VertexState {
            module,
            entry_point: Some("vs_main"),
            compilation_options: Default::default(),
            buffers: &[],
        },
        primitive: Default::default(),
        depth_stencil: None,
        multisample: Default::default(),
        fragment: Some(wgpu::FragmentState {
            module,
            entry_point: Some("fs_main"),
            compilation_options: Default::default(),
            targets: &[Some(wgpu::ColorTargetState {
                format,
                blend,
                write_mask: wgpu::ColorWrites::ALL,
            })],
        }),
        multiview_mask: None,
        cache: None,
    })
}

impl CompositePass {
    /// The pass from `radiance` (the view's `Rgba32Float` output) into
    /// `target` (checked by [`check_target`]), `scale` times the radiance
    /// when adding.
    pub(crate) fn new(
        device: &wgpu::Device,
        pipelines: &Pipelines,
        radiance: &wgpu::TextureView,
        target: &wgpu::Texture,
        blend: Blend,
        scale: f32,
    ) -> CompositePass {
        let pipeline = pipelines.get(device, target.format(), blend);
        let group = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("composite"),
            layout: &pipeline.get_bind_group_layout(0),
            entries: &[wgpu::BindGroupEntry {
                binding: 0,
                resource: wgpu::BindingResource::TextureView(radiance),
            }],
        });
        CompositePass {
            pipeline,
            group,
            texture: target.clone(),
            target: target.create_view(&Default::default()),
            kind: blend,
            scale,
        }
    }

    /// Whether this pass already writes `target` with `blend` (then only
    /// its scale may need changing).
    pub(crate) fn writes(&self, target: &wgpu::Texture, blend: Blend) -> bool {
        self.texture == *target && self.kind == blend
    }

    /// Changes the scale of an added radiance (nothing else is made).
    pub(crate) fn set_scale(&mut self, scale: f32) {
        self.scale = scale;
    }

    /// Records the pass.
    pub(crate) fn encode(
        &self,
        encoder: &mut wgpu::CommandEncoder,
        ts: Option<wgpu::RenderPassTimestampWrites<'_>>,
    ) {
        let mut pass = encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
            label: Some("composite"),
            color_attachments: &[Some(wgpu::RenderPassColorAttachment {
                view: &self.target,
                depth_slice: None,
                resolve_target: None,
                ops: wgpu::Operations {
                    load: wgpu::LoadOp::Load,
                    store: wgpu::StoreOp::Store,
                },
            })],
            depth_stencil_attachment: None,
            timestamp_writes: ts,
            occlusion_query_set: None,
            multiview_mask: None,
        });
        pass.set_pipeline(&self.pipeline);
        pass.set_bind_group(0, &self.group, &[]);
        let s = f64::from(self.scale);
        pass.set_blend_constant(wgpu::Color {
            r: s,
            g: s,
            b: s,
            a: s,
        });
        pass.draw(0..3, 0..1);
    }
}

#[cfg(test)]
mod tests {
    #[test]
    fn composite_shader_validates() {
        if let Err(e) = gibake_gpu::shaders::validate(include_str!("composite.wgsl")) {
            panic!("composite.wgsl does not validate:\n{e}");
        }
    }
}
