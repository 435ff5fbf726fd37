//! The static shadow maps of the lights after the first (the primary
//! light's map is [`super::shadow::ShadowPass`]'s own; a point light first
//! has none and is one of these, [`first_viewed_light`]): every view of
//! every such light ([`LightView::of_light`]: a point light's six cube faces, a
//! spot's or sun's one) rendered by the shadow pass at one resolution
//! ([`light_map_size`]) into one `R32Float` atlas, view `k` at tile `k` of
//! [`gibake_asset::atlas_grid`]. The bake reads it back and stores the
//! maps that hold a surface (`light_maps.exr`, asset format 4.0); the
//! runtime without an asset shades with it as it is.

use gibake_asset::atlas_grid;
use gibake_scene::{LightKind, Scene};

use super::shadow::ShadowPass;
use crate::mesh::SceneGpu;
use crate::{GpuError, LightView, util};

/// Most texels all the later lights' maps may hold together: 2²⁶ (256 MiB
/// of f32), so that 64 point lights (384 faces) still fit in memory.
pub const MAX_LIGHT_MAP_TEXELS: u64 = 1 << 26;

/// The first light whose maps are views of this pass: the lights after
/// the first (whose map is the primary shadow map, with moving objects
/// merged and a dynamic RSM), or every light when the first is a point
/// light (six faces: it has no primary map of its own).
pub fn first_viewed_light(scene: &Scene) -> usize {
    match scene.lights.first().map(|l| &l.kind) {
        Some(LightKind::Point) => 0,
        _ => 1,
    }
}

/// How many views the lights of this pass have
/// ([`first_viewed_light`] on).
pub fn view_count(scene: &Scene) -> usize {
    scene
        .lights
        .iter()
        .skip(first_viewed_light(scene))
        .map(|l| match l.kind {
            LightKind::Point => 6,
            _ => 1,
        })
        .sum()
}

/// The resolution of the later lights' maps: half the primary shadow map's
/// (a lamp's view spans less of the level than the sun's or the key
/// light's), halved again until all `views` fit in
/// [`MAX_LIGHT_MAP_TEXELS`] and their atlas in `max_dim` texels a side; at
/// least 64 (or the primary's, if smaller). Returns the size and whether a
/// cap lowered it.
pub fn light_map_size(shadow_map_size: u32, views: usize, max_dim: u32) -> (u32, bool) {
    let floor = shadow_map_size.min(64);
    let mut size = (shadow_map_size / 2).max(floor);
    let (cols, rows) = atlas_grid(views as u32);
    let fits = |s: u32| {
        let s = u64::from(s);
        views as u64 * s * s <= MAX_LIGHT_MAP_TEXELS
            && u64::from(cols.max(rows)) * s <= u64::from(max_dim)
    };
    let mut capped = false;
    while size > floor && !fits(size) {
        size /= 2;
        capped = true;
    }
    (size.max(floor), capped)
}

/// Every view of `scene.lights[1..]` and its static shadow map, in one
/// atlas (view `k` at tile `k`).
pub struct LightMaps {
    /// `(light index, view)` per view, in light order (a point light's
    /// faces in [`LightView::point_faces`]' order).
    pub views: Vec<(u32, LightView)>,
    /// Side of every map.
    pub size: u32,
    /// The atlas (`R32Float`, metric; `f32::MAX` where no surface is).
    pub atlas: wgpu::Texture,
    /// Tiles per row of [`LightMaps::atlas`].
    pub cols: u32,
}

impl LightMaps {
    /// Renders the maps of every view of `scene.lights[1..]` at `size`²
    /// from `scene_gpu`'s static draws; `progress` is called once per
    /// view. With no such light, a 1×1 atlas and no views.
    pub fn render(
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        scene: &Scene,
        scene_gpu: &SceneGpu,
        size: u32,
        progress: &dyn Fn(),
    ) -> Result<LightMaps, GpuError> {
        let views: Vec<(u32, LightView)> = scene
            .lights
            .iter()
            .enumerate()
            .skip(first_viewed_light(scene))
            .flat_map(|(k, l)| {
                LightView::of_light(scene, l, size)
                    .into_iter()
                    .map(move |v| (k as u32, v))
            })
            .collect();
        let (cols, rows) = atlas_grid(views.len() as u32);
        let max = device.limits().max_texture_dimension_2d;
        let (w, h) = (cols.max(1) * size, rows.max(1) * size);
        if w > max || h > max {
            return Err(GpuError::Operation(format!(
                "the other lights' {} shadow maps of {size}² need a {w}×{h} atlas; this device allows {max}",
                views.len()
            )));
        }
        let atlas = util::texture_2d(
            device,
            "other lights' shadow maps",
            w,
            h,
            wgpu::TextureFormat::R32Float,
            wgpu::TextureUsages::TEXTURE_BINDING
                | wgpu::TextureUsages::COPY_DST
                | wgpu::TextureUsages::COPY_SRC,
        );
        let mut pass: Option<ShadowPass> = None;
        for (k, (_, view)) in views.iter().enumerate() {
            let pass = match &mut pass {
                Some(p) => {
                    p.set_view(queue, *view);
                    p
                }
                None => pass.insert(ShadowPass::new(device, scene_gpu, *view)),
            };
            let mut enc = device.create_command_encoder(&Default::default());
            pass.encode(&mut enc, scene_gpu, &scene_gpu.static_draws, None);
            copy_to_tile(&mut enc, &pass.metric, &atlas, k as u32, cols, size);
            queue.submit([enc.finish()]);
            progress();
        }
        Ok(LightMaps {
            views,
            size,
            atlas,
            cols,
        })
    }

    /// Bytes the atlas holds.
    pub fn bytes(&self) -> u64 {
        4 * u64::from(self.atlas.width()) * u64::from(self.atlas.height())
    }
}

/// Records the copy of `map` (`size²`) into tile `k` of `atlas` (`cols`
/// tiles per row): the one place a view's map enters an atlas.
pub fn copy_to_tile(
    encoder: &mut wgpu::CommandEncoder,
    map: &wgpu::Texture,
    atlas: &wgpu::Texture,
    k: u32,
    cols: u32,
    size: u32,
) {
    encoder.copy_texture_to_texture(
        map.as_image_copy(),
        wgpu::TexelCopyTextureInfo {
            texture: atlas,
            mip_level: 0,
            origin: wgpu::Origin3d {
                x: (k % cols) * size,
                y: (k / cols) * size,
                z: 0,
            },
            aspect: wgpu::TextureAspect::All,
        },
        wgpu::Extent3d {
            width: size,
            height: size,
            depth_or_array_layers: 1,
        },
    );
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn size_halves_until_the_views_fit() {
        assert_eq!(light_map_size(2048, 1, 16384), (1024, false));
        assert_eq!(light_map_size(2048, 64, 16384), (1024, false));
        // 384 faces (64 point lights): 384 · 512² = 1.5 · 2²⁶ > cap → 256.
        assert_eq!(light_map_size(2048, 384, 16384), (256, true));
        assert_eq!(light_map_size(2048, 1 << 20, 16384), (64, true));
        // 64 views of 1024² make an 8192² atlas: a 4096 device halves it.
        assert_eq!(light_map_size(2048, 64, 4096), (512, true));
        assert_eq!(light_map_size(32, 6, 16384), (32, false));
        assert_eq!(light_map_size(1, 6, 16384), (1, false));
    }
}
