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
//! Moving objects are merged into the views their bounds touch
//! ([`Pass::LightMerge`](crate::Pass::LightMerge)): a view their swept
//! bounds can enter ([`LightView::may_see`]) gets a shadow pass of its own
//! and a tile of a second atlas; each frame only the views their current
//! bounds touch are rendered, and shading takes the minimum with the
//! static map there (the primary light's z-min merge, per view). Only the
//! first light's bounce off moving objects is computed per frame (the
//! dynamic RSM); docs/method.md "Every light".

use gibake_asset::{Asset, NO_MAP, atlas_grid};
use gibake_gpu::mesh::{Draw, SceneGpu};
use gibake_gpu::passes::light_maps::{self, LightMaps};
use gibake_gpu::passes::shadow::ShadowPass;
use gibake_gpu::{GpuLightView, GpuPrimaryLight, LightView};
use gibake_scene::{Aabb, Scene};
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
    /// xy: the static map's first texel in the atlas (−1: none stored, no
    /// static surface in the view); zw: the moving objects' map's first
    /// texel in the moving atlas this frame (−1: not touched this frame).
    pub tile: [i32; 4],
}

/// A view: its light's index, the view, its map's origin in the atlas
/// (`None`: no map stored).
type ViewTile = (u32, LightView, Option<[i32; 2]>);

/// The views of the lights after the first (light index, view) and their
/// maps' size: the asset's, or without one those the runtime renders
/// (`LightView::of_light` at [`light_maps::light_map_size`], for a device
/// of any size).
pub(crate) fn views_of(
    scene: &Scene,
    asset: Option<&Asset>,
    shadow_map_size: u32,
) -> (Vec<(u32, LightView)>, u32) {
    match asset {
        Some(a) => {
            let size = a.manifest.light_map_size;
            let views = a
                .manifest
                .views
                .iter()
                .map(|v| (v.light, LightView::from_record(&v.view, size)))
                .collect();
            (views, size)
        }
        None => {
            let n = light_maps::view_count(scene);
            let (size, _) = light_maps::light_map_size(shadow_map_size, n, u32::MAX);
            let views = scene
                .lights
                .iter()
                .enumerate()
                .skip(light_maps::first_viewed_light(scene))
                .flat_map(|(k, l)| {
                    LightView::of_light(scene, l, size)
                        .into_iter()
                        .map(move |v| (k as u32, v))
                })
                .collect();
            (views, size)
        }
    }
}

/// The views (indices into `views`) moving objects within `swept` can
/// ever enter: the only ones that get a moving-objects map.
pub(crate) fn movable(views: &[(u32, LightView)], swept: &Aabb) -> Vec<usize> {
    if swept.is_empty() {
        return Vec::new();
    }
    (0..views.len())
        .filter(|&k| views[k].1.may_see(swept))
        .collect()
}

/// Moving objects into the views they can enter.
struct Merge {
    /// Per movable view: its index in the view array, its view, its pass.
    passes: Vec<(usize, LightView, ShadowPass)>,
    /// Their maps, one tile each (`R32Float`).
    atlas: wgpu::Texture,
    atlas_view: wgpu::TextureView,
    /// Tiles per atlas row.
    cols: u32,
    /// Which movable views this frame's moving objects touch.
    touched: Vec<bool>,
    /// Per movable view, the moving draws whose box it can see this frame
    /// (only those are drawn into it: the others' triangles would all be
    /// clipped).
    seen: Vec<Vec<u32>>,
}

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
    /// Bytes uploaded or rendered (and allocated for moving objects).
    pub bytes: u64,
    /// The views as uploaded (the moving tiles change per frame).
    gpu_views: Vec<GpuOtherView>,
    /// Moving objects into the views they touch (with the light merge).
    merge: Option<Merge>,
}

impl OtherLights {
    /// The lights after the first of `scene`, with their maps from `asset`
    /// (which was baked from this scene: its static hash covers every
    /// light), or rendered now at the size the bake would use; `None` for
    /// a scene with one light.
    /// With `merge` (the plan's light merge), moving objects get maps in
    /// the views their swept bounds can enter.
    pub(crate) fn new(
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        scene: &Scene,
        scene_gpu: &SceneGpu,
        asset: Option<&Asset>,
        shadow_map_size: u32,
        merge: bool,
    ) -> Result<Option<OtherLights>, RuntimeError> {
        if light_maps::view_count(scene) == 0 {
            return Ok(None);
        }
        let first_light = light_maps::first_viewed_light(scene);
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
        let mut gpu_lights = Vec::with_capacity(scene.lights.len());
        for (k, l) in scene.lights.iter().enumerate().skip(first_light) {
            let first = views.iter().position(|v| v.0 as usize == k);
            let count = views.iter().filter(|v| v.0 as usize == k).count();
            let Some(first) = first else {
                return Err(RuntimeError::InvalidSetting(format!(
                    "the asset has no shadow-map view of light '{}' (it was baked with other lights: re-bake it with this scene's lights)",
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
                    Some([x, y]) => [*x, *y, -1, -1],
                    None => [-1, -1, -1, -1],
                },
            })
            .collect();
        let storage = |label, contents: &[u8]| {
            device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
                label: Some(label),
                contents,
                usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_DST,
            })
        };
        let merge = if merge {
            let pairs: Vec<(u32, LightView)> = views.iter().map(|(l, v, _)| (*l, *v)).collect();
            Merge::new(
                device,
                scene_gpu,
                &pairs,
                &movable(&pairs, &scene.dynamic_swept_bounds()),
            )?
        } else {
            None
        };
        let merge_bytes = merge.as_ref().map_or(0, Merge::bytes);
        Ok(Some(OtherLights {
            lights: storage("other lights", bytemuck::cast_slice(&gpu_lights)),
            views: storage("other lights' views", bytemuck::cast_slice(&gpu_views)),
            maps: maps.create_view(&Default::default()),
            count: gpu_lights.len() as u32,
            bytes: bytes + merge_bytes,
            gpu_views,
            merge,
        }))
    }

    /// Whether moving objects are merged into some view (the light merge).
    pub(crate) fn merges(&self) -> bool {
        self.merge.is_some()
    }

    /// The moving objects' maps (`None` without the light merge).
    pub(crate) fn moving_maps(&self) -> Option<&wgpu::TextureView> {
        self.merge.as_ref().map(|m| &m.atlas_view)
    }

    /// Picks the views this frame's moving objects (world `boxes`) touch
    /// and uploads where shading finds their maps; returns how many.
    pub(crate) fn prepare(&mut self, queue: &wgpu::Queue, boxes: &[Aabb]) -> u32 {
        let Some(m) = self.merge.as_mut() else {
            return 0;
        };
        let mut n = 0;
        for (i, (k, view, pass)) in m.passes.iter().enumerate() {
            let seen = &mut m.seen[i];
            seen.clear();
            seen.extend((0..boxes.len() as u32).filter(|&d| view.may_see(&boxes[d as usize])));
            let touched = !seen.is_empty();
            m.touched[i] = touched;
            let size = pass.view.size;
            let t = &mut self.gpu_views[*k].tile;
            if touched {
                n += 1;
                let i = i as u32;
                t[2] = ((i % m.cols) * size) as i32;
                t[3] = ((i / m.cols) * size) as i32;
            } else {
                t[2] = -1;
                t[3] = -1;
            }
        }
        queue.write_buffer(&self.views, 0, bytemuck::cast_slice(&self.gpu_views));
        n
    }

    /// Views the moving objects touch this frame.
    pub(crate) fn touched(&self) -> u32 {
        self.merge
            .as_ref()
            .map_or(0, |m| m.touched.iter().filter(|t| **t).count() as u32)
    }

    /// Records the light merge: the moving objects' `draws` into each view
    /// they touch this frame, each copied into its atlas tile.
    pub(crate) fn record(
        &self,
        encoder: &mut wgpu::CommandEncoder,
        scene_gpu: &SceneGpu,
        draws: &[Draw],
        timer: &crate::stats::Timer,
    ) {
        let Some(m) = &self.merge else { return };
        let touched: Vec<usize> = (0..m.passes.len()).filter(|&i| m.touched[i]).collect();
        for (j, &i) in touched.iter().enumerate() {
            let (_, _, pass) = &m.passes[i];
            let ts = timer.render_span(crate::Pass::LightMerge, j == 0, j + 1 == touched.len());
            let seen = m.seen[i].iter().filter_map(|&d| draws.get(d as usize));
            pass.encode(encoder, scene_gpu, seen, ts);
            light_maps::copy_to_tile(
                encoder,
                &pass.metric,
                &m.atlas,
                i as u32,
                m.cols,
                pass.view.size,
            );
        }
    }

    /// Draw calls of this frame's light merge (each touched view draws the
    /// moving draws it can see).
    pub(crate) fn draw_calls(&self) -> u32 {
        self.merge.as_ref().map_or(0, |m| {
            (0..m.passes.len())
                .filter(|&i| m.touched[i])
                .map(|i| m.seen[i].len() as u32)
                .sum()
        })
    }
}

impl Merge {
    /// A pass and a tile for each of `movable` (indices into `views`);
    /// `None` when there is none.
    fn new(
        device: &wgpu::Device,
        scene_gpu: &SceneGpu,
        views: &[(u32, LightView)],
        movable: &[usize],
    ) -> Result<Option<Merge>, RuntimeError> {
        let Some(&first) = movable.first() else {
            return Ok(None);
        };
        let size = views[first].1.size;
        let (cols, rows) = atlas_grid(movable.len() as u32);
        let max = device.limits().max_texture_dimension_2d;
        let (w, h) = (cols * size, rows * size);
        if w > max || h > max {
            return Err(RuntimeError::DeviceLimit {
                what: format!(
                    "the moving objects' shadow maps in {} views of the lights after the first ({size}² texels in {cols}×{rows} tiles)",
                    movable.len()
                ),
                needed: u64::from(w.max(h)),
                limit: u64::from(max),
            });
        }
        let atlas = gibake_gpu::util::texture_2d(
            device,
            "moving objects in the other lights' views",
            w,
            h,
            wgpu::TextureFormat::R32Float,
            wgpu::TextureUsages::TEXTURE_BINDING | wgpu::TextureUsages::COPY_DST,
        );
        let passes = movable
            .iter()
            .map(|&k| {
                (
                    k,
                    views[k].1,
                    ShadowPass::new(device, scene_gpu, views[k].1),
                )
            })
            .collect();
        Ok(Some(Merge {
            passes,
            atlas_view: atlas.create_view(&Default::default()),
            atlas,
            cols,
            touched: vec![false; movable.len()],
            seen: vec![Vec::new(); movable.len()],
        }))
    }

    /// Bytes: the atlas, and each pass's metric and depth targets.
    fn bytes(&self) -> u64 {
        let atlas = 4 * u64::from(self.atlas.width()) * u64::from(self.atlas.height());
        let per: u64 = self
            .passes
            .iter()
            .map(|(_, v, _)| 8 * u64::from(v.size) * u64::from(v.size))
            .sum();
        atlas + per
    }
}
