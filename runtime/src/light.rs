//! The primary light on the GPU: its radiometry and light-view uniforms
//! and the static primary shadow map — the baked one, or (without an
//! asset, `direct` mode) one rendered here once from the static geometry.

use gibake_gpu::mesh::SceneGpu;
use gibake_gpu::passes::shadow::ShadowPass;
use gibake_gpu::{GpuPrimaryLight, LightView};
use gibake_scene::Scene;
use wgpu::util::DeviceExt;

use crate::baked::BakedGpu;

/// A primary light of the scene, as a game sees it ([`crate::Renderer::lights`]).
#[derive(Clone, Debug, PartialEq)]
pub struct LightInfo {
    /// glTF light name.
    pub name: String,
    /// Spot, directional or point, with parameters.
    pub kind: gibake_scene::LightKind,
    /// `color × intensity`: W/sr (spot, point) or W/m² (directional).
    pub color: glam::Vec3,
    /// World position.
    pub position: glam::Vec3,
    /// World unit direction it points to.
    pub direction: glam::Vec3,
    /// glTF range, world units.
    pub range: Option<f32>,
    /// VPLs baked from it: its share of the budget (`None` without an
    /// asset).
    pub vpls: Option<u32>,
    /// Whether this renderer shades its direct light: every light of the
    /// scene (each with its static shadow maps; moving a light is a
    /// re-bake).
    pub shaded: bool,
    /// Whether its bounce off moving objects is computed per frame (a
    /// dynamic RSM, the occlusion of its static VPLs and dynamic VPLs): the
    /// first light when it is a spot or directional light, and every light
    /// with a view whose static RSM the asset stores (format 4.1: the views
    /// moving objects can enter; [`crate::Pass::LightBounce`], only in the
    /// views they touch each frame). Moving objects cast shadows in every
    /// light (each view they touch is merged).
    pub dynamic_bounce: bool,
}

impl LightInfo {
    /// The lights of `scene`, with their VPL counts from `asset`'s records
    /// (matched by name).
    pub(crate) fn of(scene: &Scene, asset: Option<&gibake_asset::Asset>) -> Vec<LightInfo> {
        scene
            .lights
            .iter()
            .enumerate()
            .map(|(i, l)| LightInfo {
                name: l.name.clone(),
                kind: l.kind.clone(),
                color: l.color,
                position: l.position,
                direction: l.direction,
                range: l.range,
                vpls: asset.and_then(|a| {
                    a.manifest
                        .lights
                        .iter()
                        .find(|r| r.name == l.name)
                        .map(|r| r.vpls)
                }),
                shaded: true,
                dynamic_bounce: (i == 0 && has_primary(scene))
                    || asset.is_some_and(|a| {
                        let m = &a.manifest;
                        m.view_rsms.iter().any(|&v| {
                            m.views
                                .get(v as usize)
                                .is_some_and(|r| r.light as usize == i)
                        })
                    }),
            })
            .collect()
    }
}

/// Whether the scene's first light has the primary maps (a spot or
/// directional light; a point light first is shaded by its six faces
/// among the other lights, [`crate::other_lights`]).
pub(crate) fn has_primary(scene: &Scene) -> bool {
    gibake_gpu::passes::light_maps::first_viewed_light(scene) == 1
}

/// Whether some light after the first (those `other_lights` shades) has a
/// glTF `range` or is a spot: only those can be culled per tile in shading
/// ([`crate::ShadeFlag::CullLights`]).
pub(crate) fn other_lights_can_cull(scene: &Scene) -> bool {
    scene
        .lights
        .iter()
        .skip(gibake_gpu::passes::light_maps::first_viewed_light(scene))
        .any(|l| {
            l.range.is_some_and(|r| r.is_finite() && r > 0.0)
                || matches!(l.kind, gibake_scene::LightKind::Spot { .. })
        })
}

/// The primary light's GPU resources.
pub(crate) struct PrimaryLight {
    /// The primary maps' light view.
    pub view: LightView,
    /// The static primary shadow map (metric).
    pub static_map: wgpu::TextureView,
    /// Keeps a map rendered here alive.
    _own_static: Option<ShadowPass>,
    /// `GpuPrimaryLight` uniform.
    pub light_buf: wgpu::Buffer,
    /// `GpuLightView` uniform of the primary maps.
    pub view_buf: wgpu::Buffer,
}

impl PrimaryLight {
    /// The baked static map, or one of `shadow_map_size²` rendered now.
    pub(crate) fn new(
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        scene: &Scene,
        scene_gpu: &SceneGpu,
        baked: Option<&BakedGpu>,
        shadow_map_size: u32,
    ) -> PrimaryLight {
        let (view, static_map, own) = match baked {
            Some(b) => (b.view, b.primary.clone(), None),
            None => {
                let view = LightView::for_scene(scene, shadow_map_size);
                let pass = ShadowPass::new(device, scene_gpu, view);
                let mut enc = device.create_command_encoder(&Default::default());
                pass.encode(&mut enc, scene_gpu, &scene_gpu.static_draws, None);
                queue.submit([enc.finish()]);
                (view, pass.metric_view.clone(), Some(pass))
            }
        };
        let uniform = |label, contents: &[u8]| {
            device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
                label: Some(label),
                contents,
                usage: wgpu::BufferUsages::UNIFORM,
            })
        };
        // A point light first has no primary map: it is shaded with its six
        // faces among the other lights, and this uniform lights nothing.
        let mut gpu = GpuPrimaryLight::new(scene.light());
        if !has_primary(scene) {
            gpu.color = [0.0; 4];
        }
        PrimaryLight {
            view,
            static_map,
            _own_static: own,
            light_buf: uniform("primary light", bytemuck::bytes_of(&gpu)),
            view_buf: uniform("primary light view", bytemuck::bytes_of(&view.to_gpu())),
        }
    }
}
