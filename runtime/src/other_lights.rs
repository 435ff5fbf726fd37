//! The lights after the first on the GPU: each one's radiometry and the
//! views of its static shadow maps ([`GpuOtherLight`], [`GpuOtherView`]),
//! and the maps themselves in one `R32Float` atlas — the asset's
//! `light_maps.exr` as it is (asset format 4.0), or, without an asset
//! (`direct` mode), rendered here once from the static geometry
//! ([`gibake_gpu::passes::light_maps::LightMaps`]). Shading adds each
//! light's direct light with its map (a point light's face picked by the
//! receiver's direction, `shade.wgsl`). A scene with one light has none of
//! this: no buffer, no texture (the shader's fallbacks are bound).
//!
//! Moving objects do not enter these maps yet: they cast shadows in the
//! first light only, and only the first light's bounce off them is
//! computed per frame (docs/method.md "Every light").

use gibake_asset::{Asset, NO_MAP, atlas_grid};
use gibake_gpu::mesh::SceneGpu;
use gibake_gpu::passes::light_maps::{self, LightMaps};
use gibake_gpu::{GpuLightView, GpuPrimaryLight, LightView};
use gibake_scene::Scene;
use wgpu::util::DeviceExt;

use crate::RuntimeError;

/// One light after the first. Must match `OtherLight` in `shade.wgsl`.
#[repr(C)]
#[derive(Clone, Copy, Debug, bytemuck::Pod, bytemuck::Zeroable)]
pub(crate) struct GpuOtherLight {
    /// Its radiometry (the primary light's layout).
    pub light: GpuPrimaryLight,
    /// x: its first view in the view array; y: its view count (6: a point
    /// light's cube faces +X, −X, +Y, −Y, +Z, −Z); zw unused.
    pub views: [u32; 4],
}

/// One view of a light after the first. Must match `OtherView` in
/// `shade.wgsl`.
#[repr(C)]
#[derive(Clone, Copy, Debug, bytemuck::Pod, bytemuck::Zeroable)]
pub(crate) struct GpuOtherView {
    /// The view its map was rendered with.
    pub view: GpuLightView,
    /// xy: the map's first texel in the atlas; z: 1 when a map is stored,
    /// 0 when none is (no surface in the view: unshadowed); w unused.
    pub tile: [i32; 4],
}

/// A view: its light's index, the view, its map's origin in the atlas
/// (`None`: no map stored).
type ViewTile = (u32, LightView, Option<[i32; 2]>);

/// The GPU resources of the lights after the first.
pub(crate) struct OtherLights {
    /// [`GpuOtherLight`]s (storage).
    pub lights: wgpu::Buffer,
    /// [`GpuOtherView`]s (storage).
    pub views: wgpu::Buffer,
    /// Their static shadow maps (metric).
    pub maps: wgpu::TextureView,
    /// Number of lights after the first.
    pub count: u32,
    /// Bytes uploaded or rendered.
    pub bytes: u64,
}

impl OtherLights {
    /// The lights after the first of `scene`, with their maps from `asset`
    /// (which was baked from this scene: its static hash covers every
    /// light), or rendered now at the size the bake would use; `None` for
    /// a scene with one light.
    pub(crate) fn new(
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        scene: &Scene,
        scene_gpu: &SceneGpu,
        asset: Option<&Asset>,
        shadow_map_size: u32,
    ) -> Result<Option<OtherLights>, RuntimeError> {
        if scene.lights.len() < 2 {
            return Ok(None);
        }
        let max = device.limits().max_texture_dimension_2d;
        // (light, view, tile origin or None), the atlas and its bytes.
        let (views, maps, bytes): (Vec<ViewTile>, _, u64) = match asset {
            Some(a) => {
                let m = &a.manifest;
                let size = m.light_map_size;
                let stored = a.light_maps.count();
                let (cols, rows) = atlas_grid(stored.max(1));
                let (w, h) = (cols * size.max(1), rows * size.max(1));
                if w > max || h > max {
                    return Err(RuntimeError::DeviceLimit {
                        what: format!(
                            "the asset's {stored} shadow maps of the lights after the first ({size}² texels in {cols}×{rows} tiles)"
                        ),
                        needed: u64::from(w.max(h)),
                        limit: u64::from(max),
                    });
                }
                let one = [f32::INFINITY];
                let texels = if stored == 0 {
                    &one[..]
                } else {
                    a.light_maps.texels()
                };
                let (w, h) = if stored == 0 { (1, 1) } else { (w, h) };
                let tex = crate::baked::r32_texture(
                    device,
                    queue,
                    "other lights' shadow maps",
                    w,
                    h,
                    texels,
                );
                let views = m
                    .views
                    .iter()
                    .map(|v| {
                        let origin = (v.tile != NO_MAP).then(|| {
                            [
                                ((v.tile % cols) * size) as i32,
                                ((v.tile / cols) * size) as i32,
                            ]
                        });
                        (v.light, LightView::from_record(&v.view, size), origin)
                    })
                    .collect();
                (views, tex, 4 * u64::from(w) * u64::from(h))
            }
            None => {
                let n = light_maps::view_count(scene);
                let (size, _) = light_maps::light_map_size(shadow_map_size, n, max);
                let lm = LightMaps::render(device, queue, scene, scene_gpu, size, &|| {})?;
                let views = lm
                    .views
                    .iter()
                    .enumerate()
                    .map(|(k, (light, view))| {
                        let k = k as u32;
                        let origin = [((k % lm.cols) * size) as i32, ((k / lm.cols) * size) as i32];
                        (*light, *view, Some(origin))
                    })
                    .collect();
                let bytes = lm.bytes();
                (views, lm.atlas, bytes)
            }
        };
        let mut gpu_lights = Vec::with_capacity(scene.lights.len() - 1);
        for (k, l) in scene.lights.iter().enumerate().skip(1) {
            let first = views.iter().position(|v| v.0 as usize == k);
            let count = views.iter().filter(|v| v.0 as usize == k).count();
            let Some(first) = first else {
                return Err(RuntimeError::InvalidSetting(format!(
                    "the asset has no shadow-map view of light '{}' (it was baked with other lights: re-bake with --all-lights)",
                    l.name
                )));
            };
            gpu_lights.push(GpuOtherLight {
                light: GpuPrimaryLight::new(l),
                views: [first as u32, count as u32, 0, 0],
            });
        }
        let gpu_views: Vec<GpuOtherView> = views
            .iter()
            .map(|(_, v, origin)| GpuOtherView {
                view: v.to_gpu(),
                tile: match origin {
                    Some([x, y]) => [*x, *y, 1, 0],
                    None => [0, 0, 0, 0],
                },
            })
            .collect();
        let storage = |label, contents: &[u8]| {
            device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
                label: Some(label),
                contents,
                usage: wgpu::BufferUsages::STORAGE,
            })
        };
        Ok(Some(OtherLights {
            lights: storage("other lights", bytemuck::cast_slice(&gpu_lights)),
            views: storage("other lights' views", bytemuck::cast_slice(&gpu_views)),
            maps: maps.create_view(&Default::default()),
            count: gpu_lights.len() as u32,
            bytes,
        }))
    }
}
