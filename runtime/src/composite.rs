//! The composite pass (`composite.wgsl`): a view's radiance written into,
//! or added onto, the caller's render target of a float format —
//! `Rgba16Float` (the usual HDR target) or `Rgba32Float` — when the caller
//! does not hand over an `Rgba32Float` storage texture to shade into
//! directly. Adding is for a game that lights its own frame (typically
//! `Mode::Indirect` onto its own direct light).

use crate::RuntimeError;

/// How the view's radiance reaches the caller's target.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Blend {
    /// Overwrite (alpha 1).
    Replace,
    /// `target += radiance` (alpha kept).
    Add,
}

/// The pass for one target.
pub(crate) struct CompositePass {
    pipeline: wgpu::RenderPipeline,
    group: wgpu::BindGroup,
    target: wgpu::TextureView,
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

impl CompositePass {
    /// The pass from `radiance` (the view's `Rgba32Float` output) into
    /// `target` (checked by [`check_target`]).
    pub(crate) fn new(
        device: &wgpu::Device,
        radiance: &wgpu::TextureView,
        target: &wgpu::Texture,
        blend: Blend,
    ) -> CompositePass {
        let module = device.create_shader_module(wgpu::ShaderModuleDescriptor {
            label: Some("composite.wgsl"),
            source: wgpu::ShaderSource::Wgsl(include_str!("composite.wgsl").into()),
        });
        let add = wgpu::BlendComponent {
            src_factor: wgpu::BlendFactor::One,
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
        let pipeline = device.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
            label: Some("composite"),
            layout: None,
            vertex: wgpu::VertexState {
                module: &module,
                entry_point: Some("vs_main"),
                compilation_options: Default::default(),
                buffers: &[],
            },
            primitive: Default::default(),
            depth_stencil: None,
            multisample: Default::default(),
            fragment: Some(wgpu::FragmentState {
                module: &module,
                entry_point: Some("fs_main"),
                compilation_options: Default::default(),
                targets: &[Some(wgpu::ColorTargetState {
                    format: target.format(),
                    blend,
                    write_mask: wgpu::ColorWrites::ALL,
                })],
            }),
            multiview_mask: None,
            cache: None,
        });
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
            target: target.create_view(&Default::default()),
        }
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
