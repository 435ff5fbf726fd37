//! Cascaded shadow maps for the direct light of a directional primary light
//! on a large level.
//!
//! The baked primary map is one orthographic map over the whole level
//! (2048² by default): on a 98 m arena its texel is ~5 cm, coarse next to
//! what a camera standing in the level sees a few metres away. Cascades
//! add, per frame, `count` maps of `size²` along the light, each fitted to
//! a slice of the **main view's** frustum:
//!
//! - **splits**: the practical split scheme (Zhang et al. 2006), a blend of
//!   logarithmic and uniform splits ([`SPLIT_LAMBDA`]) from the camera's
//!   near plane to the farthest corner of the level's light box (a
//!   distance, whichever way the camera looks: turning does not resize the
//!   cascades); a level wholly behind the camera gets none;
//! - **no shimmer**: each slice is bounded by a sphere (its size does not
//!   change when the camera turns), the radius rounded up to a quarter
//!   octave, and the map's centre snapped to whole texels in light space,
//!   so a still surface stays on the same texel grid while the camera
//!   moves;
//! - **drawn from** the static draws the runtime already holds
//!   ([`SceneGpu::static_draws`]) — again only when a cascade's snapped
//!   view changes (a still camera redraws nothing) — and the moving
//!   objects, every frame, into a map of their own per cascade: shading
//!   takes the minimum (the same z-min merge as the primary map);
//! - **sampled** (`cascades.wgsl`) with the one `lv_visibility` of
//!   `projection.wgsl` (same 2×2 PCF and receiver-plane test, biases in
//!   texel footprints): the finest cascade whose map holds the point, where
//!   the primary map's texel there exceeds a quarter of the view's pixel
//!   footprint (`CASCADE_PIXEL_FRACTION`), else the baked primary map.
//!   Other views use the main view's cascades the same way.
//!
//! **When** ([`choose`], [`crate::Cascades::Auto`]): a scale-free
//! comparison of the single map's texel `t` with the camera pixel's
//! footprint at the level's detail distance `L·θ`, where `L` is the
//! area-weighted median size (√area) of the static triangles — the scale
//! the level is built at, which a player's camera sees from a few of — and
//! `θ = 2·tan(fov/2)/height` is the angle of one output pixel (the
//! scene camera's field of view, else 60°, and the settings' height).
//! Cascades are on when `t > COARSE · L·θ`. A room around a bunny has
//! `t/(L·θ)` below 1; the arena about 10. Count and resolution come from
//! the same ratio ([`layout_for`]). Spot lights keep their single map.

use std::sync::atomic::{AtomicBool, Ordering};

use bytemuck::Zeroable;
use gibake_gpu::mesh::{Draw, SceneGpu};
use gibake_gpu::passes::shadow::ShadowPass;
use gibake_gpu::{GpuLightView, LightView, orthonormal_basis};
use gibake_scene::{LightKind, Projection, Scene};
use glam::Vec3;

use crate::CameraMatrices;
use crate::settings::Cascades;

/// Most cascades (the shading binds this many maps).
pub const MAX_CASCADES: usize = 4;

/// Cascades are on when the single map's texel exceeds this many camera
/// pixels at the level's detail distance.
pub const COARSE: f32 = 1.0;

/// Blend of logarithmic (1) and uniform (0) splits.
pub const SPLIT_LAMBDA: f32 = 0.8;

/// Field of view assumed when the scene has no camera (60°).
const DEFAULT_FOV: f32 = std::f32::consts::FRAC_PI_3;

/// How many cascades of which resolution a renderer draws.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct CascadeLayout {
    /// Number of cascades (1 ..= 4).
    pub count: u32,
    /// Resolution of each (square).
    pub size: u32,
}

/// The area-weighted median size (√area) of `scene`'s static triangles: the
/// scale the level is built at. `None` without any triangle of area.
pub fn detail_scale(scene: &Scene) -> Option<f32> {
    let mut tris: Vec<(f32, f32)> = Vec::new();
    for m in &scene.static_meshes {
        for t in m.indices.chunks_exact(3) {
            let p = |i: u32| m.positions.get(i as usize).copied().unwrap_or(Vec3::ZERO);
            let a = 0.5 * (p(t[1]) - p(t[0])).cross(p(t[2]) - p(t[0])).length();
            if a.is_finite() && a > 0.0 {
                tris.push((a.sqrt(), a));
            }
        }
    }
    tris.sort_by(|x, y| x.0.total_cmp(&y.0));
    let total: f64 = tris.iter().map(|t| f64::from(t.1)).sum();
    let mut acc = 0.0f64;
    for (s, a) in &tris {
        acc += f64::from(*a);
        if acc >= 0.5 * total {
            return Some(*s);
        }
    }
    None
}

/// The angle of one output pixel of the scene's camera (60° without one) at
/// an output `height` pixels tall; for an orthographic camera, the world
/// size of one pixel (returned as `Err`).
fn pixel_footprint(scene: &Scene, height: u32) -> Result<f32, f32> {
    let h = height.max(1) as f32;
    match scene.camera.as_ref().map(|c| &c.projection) {
        Some(Projection::Orthographic { ymag, .. }) => Err(2.0 * ymag / h),
        Some(Projection::Perspective { yfov, .. }) => Ok(2.0 * (0.5 * yfov).tan() / h),
        None => Ok(2.0 * (0.5 * DEFAULT_FOV).tan() / h),
    }
}

/// `t / (L·θ)`: the single primary map's texel against a camera pixel at the
/// level's detail distance (see the module docs). `None` when it cannot be
/// said (no static triangle of area).
pub fn coarseness(scene: &Scene, primary: &LightView, height: u32) -> Option<f32> {
    let l = detail_scale(scene)?;
    let pixel = match pixel_footprint(scene, height) {
        Ok(theta) => l * theta,
        Err(world) => world,
    };
    let r = primary.texel_scale / pixel;
    r.is_finite().then_some(r)
}

/// Count and resolution from the coarseness ratio `r` (or a forced
/// `size`): each cascade about 4× the depth of the last, so enough of them
/// that the finest is about `r` times finer than the single map, 2 to 4;
/// 1024² (2048² from `r` ≥ 16 on).
pub fn layout_for(r: f32, size: u32) -> CascadeLayout {
    let count = (1.0 + r.max(1.0).log(4.0).ceil()).clamp(2.0, MAX_CASCADES as f32) as u32;
    let size = match size {
        0 if r >= 16.0 => 2048,
        0 => 1024,
        s => s,
    };
    CascadeLayout { count, size }
}

/// The cascades a renderer of `scene` draws (`None`: the single map alone):
/// never for a spot light; [`Cascades::Auto`] by [`coarseness`] >
/// [`COARSE`].
pub fn choose(
    setting: Cascades,
    scene: &Scene,
    primary: &LightView,
    height: u32,
    size: u32,
) -> Option<CascadeLayout> {
    if !matches!(scene.light().kind, LightKind::Directional) || !primary.directional {
        return None;
    }
    let r = coarseness(scene, primary, height);
    match setting {
        Cascades::Off => None,
        Cascades::On => Some(layout_for(r.unwrap_or(1.0), size)),
        Cascades::Auto => r.filter(|r| *r > COARSE).map(|r| layout_for(r, size)),
    }
}

/// The level's box along the light: its eight world corners and its
/// light-space depth range (from the primary view, which covers every
/// static surface along the light and the moving objects' swept bounds).
#[derive(Clone, Copy, Debug)]
pub(crate) struct LevelBox {
    dir: Vec3,
    corners: [Vec3; 8],
    z: (f32, f32),
}

impl LevelBox {
    /// The box of the primary light view.
    pub(crate) fn of(primary: &LightView) -> LevelBox {
        let inv = primary.view_proj.inverse();
        let dir = primary.direction.normalize();
        let mut corners = [Vec3::ZERO; 8];
        let mut z = (f32::INFINITY, f32::NEG_INFINITY);
        for (i, c) in corners.iter_mut().enumerate() {
            let ndc = Vec3::new(
                if i & 1 == 0 { -1.0 } else { 1.0 },
                if i & 2 == 0 { -1.0 } else { 1.0 },
                if i & 4 == 0 { 0.0 } else { 1.0 },
            );
            *c = inv.project_point3(ndc);
            let d = c.dot(dir);
            z = (z.0.min(d), z.1.max(d));
        }
        LevelBox { dir, corners, z }
    }
}

/// The cascades' light views for `camera` over `level` (empty when the
/// level is not in front of the camera).
pub(crate) fn fit(
    camera: &CameraMatrices,
    level: &LevelBox,
    layout: CascadeLayout,
) -> Vec<LightView> {
    let fwd = camera.forward.normalize();
    let pos = camera.position;
    let inv = camera.view_proj.inverse();
    // Near-plane corners (reversed Z: near at depth 1).
    let near_pts: Vec<Vec3> = [(-1.0, -1.0), (1.0, -1.0), (-1.0, 1.0), (1.0, 1.0)]
        .iter()
        .map(|&(x, y)| inv.project_point3(Vec3::new(x, y, 1.0)))
        .collect();
    if near_pts.iter().any(|p| !p.is_finite()) {
        return Vec::new();
    }
    let near = near_pts
        .iter()
        .map(|p| (*p - pos).dot(fwd))
        .fold(f32::INFINITY, f32::min);
    // The level in front of the camera at all?
    let ahead = level
        .corners
        .iter()
        .map(|c| (*c - pos).dot(fwd))
        .fold(f32::NEG_INFINITY, f32::max);
    // The splits run to the farthest corner whichever way the camera
    // looks: turning must not resize the cascades (that would shimmer).
    let far = level
        .corners
        .iter()
        .map(|c| (*c - pos).length())
        .fold(0.0f32, f32::max);
    if !(near.is_finite() && far.is_finite()) || ahead <= near || far <= near * 1.001 {
        return Vec::new();
    }
    let near = near.max(far * 1e-6);
    // The slice point of near corner `p` at view depth `d`.
    let at = |p: Vec3, d: f32| -> Vec3 {
        if camera.orthographic {
            p + fwd * (d - (p - pos).dot(fwd))
        } else {
            let r = p - pos;
            pos + r * (d / r.dot(fwd))
        }
    };
    let n = layout.count as f32;
    let split = |i: u32| -> f32 {
        let f = i as f32 / n;
        SPLIT_LAMBDA * near * (far / near).powf(f)
            + (1.0 - SPLIT_LAMBDA) * (near + (far - near) * f)
    };
    let (t, b) = orthonormal_basis(level.dir);
    let size = layout.size as f32;
    (0..layout.count)
        .map(|i| {
            let (d0, d1) = (split(i), split(i + 1));
            let pts: Vec<Vec3> = near_pts
                .iter()
                .flat_map(|&p| [at(p, d0), at(p, d1)])
                .collect();
            let centre = pts.iter().copied().sum::<Vec3>() / pts.len() as f32;
            let r = pts
                .iter()
                .map(|p| (*p - centre).length())
                .fold(0.0f32, f32::max)
                .max(f32::MIN_POSITIVE);
            // A quarter octave up: the size changes rarely as the camera
            // moves, never as it turns.
            let r = 2f32.powf((4.0 * r.log2()).ceil() / 4.0);
            // `LightView::directional` widens by 2%: its texel is this.
            let texel = 2.0 * r * 1.02 / size;
            let snap = |v: f32| (v / texel).round() * texel;
            let (cx, cy) = (snap(centre.dot(t)), snap(centre.dot(b)));
            LightView::directional(
                level.dir,
                Vec3::new(cx - r, cy - r, level.z.0),
                Vec3::new(cx + r, cy + r, level.z.1),
                layout.size,
            )
        })
        .collect()
}

/// The cascades' uniform. Must match `Cascades` in `cascades.wgsl`.
#[repr(C)]
#[derive(Clone, Copy, Debug, bytemuck::Pod, bytemuck::Zeroable)]
pub(crate) struct GpuCascades {
    /// The cascades' views, finest first.
    pub views: [GpuLightView; MAX_CASCADES],
    /// Cascades in use this frame (0: the primary map alone).
    pub count: u32,
    /// 1: moving objects have their own maps (min-merged at shading).
    pub merge: u32,
    /// Padding (16-byte struct size).
    pub _pad: [u32; 2],
}

/// The cascades of one renderer: per cascade a static map (redrawn when
/// its view changes) and, with moving objects, a map of them (every frame).
pub(crate) struct CascadePasses {
    layout: CascadeLayout,
    level: LevelBox,
    statics: Vec<ShadowPass>,
    moving: Vec<ShadowPass>,
    /// Views in use (`count` of them this frame).
    views: Vec<LightView>,
    count: u32,
    /// Per cascade: its static map is not drawn for its current view.
    stale: Vec<bool>,
    /// Set by `record`: the last prepared frame was recorded.
    recorded: AtomicBool,
    uniform: wgpu::Buffer,
}

impl CascadePasses {
    /// The maps of `layout` (moving-object maps when `moving`).
    pub(crate) fn new(
        device: &wgpu::Device,
        scene_gpu: &SceneGpu,
        primary: &LightView,
        layout: CascadeLayout,
        moving: bool,
    ) -> CascadePasses {
        let level = LevelBox::of(primary);
        // A placeholder view until the first camera.
        let first = primary.resized(layout.size);
        let make = |_| ShadowPass::new(device, scene_gpu, first);
        let statics = (0..layout.count).map(make).collect();
        let moving = if moving {
            (0..layout.count).map(make).collect()
        } else {
            Vec::new()
        };
        CascadePasses {
            layout,
            level,
            statics,
            moving,
            views: vec![first; layout.count as usize],
            count: 0,
            stale: vec![true; layout.count as usize],
            recorded: AtomicBool::new(true),
            uniform: crate::shade::uniform(device, "cascades", &GpuCascades::zeroed()),
        }
    }

    /// Fits the cascades to `camera` and uploads what changed.
    pub(crate) fn prepare(&mut self, queue: &wgpu::Queue, camera: &CameraMatrices) {
        let fitted = fit(camera, &self.level, self.layout);
        let fresh = self.recorded.swap(false, Ordering::AcqRel);
        for (k, v) in fitted.iter().enumerate() {
            let changed = *v != self.views[k];
            self.stale[k] = changed || (self.stale[k] && !fresh);
            if changed {
                self.views[k] = *v;
                let g = v.to_gpu();
                queue.write_buffer(&self.statics[k].uniform_buf, 0, bytemuck::bytes_of(&g));
                if let Some(m) = self.moving.get(k) {
                    queue.write_buffer(&m.uniform_buf, 0, bytemuck::bytes_of(&g));
                }
            }
        }
        self.count = fitted.len() as u32;
        let mut gpu = GpuCascades::zeroed();
        for (k, v) in self.views.iter().enumerate() {
            gpu.views[k] = v.to_gpu();
        }
        gpu.count = self.count;
        gpu.merge = u32::from(!self.moving.is_empty());
        queue.write_buffer(&self.uniform, 0, bytemuck::bytes_of(&gpu));
    }

    /// Whether [`CascadePasses::record`] draws anything this frame.
    pub(crate) fn draws(&self) -> bool {
        self.count > 0
            && (!self.moving.is_empty() || self.stale[..self.count as usize].iter().any(|s| *s))
    }

    /// Render passes this frame: the stale static maps, then every moving
    /// map; the first and last carry the pass's timestamps.
    pub(crate) fn record(
        &self,
        encoder: &mut wgpu::CommandEncoder,
        scene_gpu: &SceneGpu,
        moving_draws: &[Draw],
        ts: Option<wgpu::RenderPassTimestampWrites<'_>>,
    ) {
        self.recorded.store(true, Ordering::Release);
        let n = self.count as usize;
        let mut jobs: Vec<(&ShadowPass, &[Draw])> = Vec::new();
        for k in 0..n {
            if self.stale[k] {
                jobs.push((&self.statics[k], &scene_gpu.static_draws));
            }
        }
        for m in self.moving.iter().take(n) {
            jobs.push((m, moving_draws));
        }
        let last = jobs.len().saturating_sub(1);
        for (i, (pass, draws)) in jobs.iter().enumerate() {
            // The first pass writes the beginning, the last the end; wgpu
            // refuses a write with neither.
            let t = ts.as_ref().filter(|_| i == 0 || i == last).map(|t| {
                wgpu::RenderPassTimestampWrites {
                    query_set: t.query_set,
                    beginning_of_pass_write_index: t
                        .beginning_of_pass_write_index
                        .filter(|_| i == 0),
                    end_of_pass_write_index: t.end_of_pass_write_index.filter(|_| i == last),
                }
            });
            pass.encode(encoder, scene_gpu, draws.iter(), t);
        }
    }

    /// What shading binds: the uniform, the static maps and the moving maps
    /// (the static ones stand in where there are none).
    pub(crate) fn bindings(
        &self,
    ) -> (
        &wgpu::Buffer,
        Vec<&wgpu::TextureView>,
        Vec<&wgpu::TextureView>,
    ) {
        let statics: Vec<_> = self.statics.iter().map(|p| &p.metric_view).collect();
        let moving = if self.moving.is_empty() {
            statics.clone()
        } else {
            self.moving.iter().map(|p| &p.metric_view).collect()
        };
        (&self.uniform, statics, moving)
    }

    /// Draw calls this frame records.
    pub(crate) fn draw_calls(&self, static_draws: u32, moving_draws: u32) -> u32 {
        let n = self.count as usize;
        let stale = self.stale[..n].iter().filter(|s| **s).count() as u32;
        let moving = if self.moving.is_empty() { 0 } else { n as u32 };
        stale * static_draws + moving * moving_draws
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::{Mat4, Quat};

    fn primary() -> LightView {
        LightView::directional(
            Vec3::new(0.4, -0.7, 0.3).normalize(),
            Vec3::new(-100.0, -100.0, -50.0),
            Vec3::new(100.0, 100.0, 50.0),
            2048,
        )
    }

    fn camera(eye: Vec3, yaw: f32) -> CameraMatrices {
        let m = Mat4::from_rotation_translation(Quat::from_rotation_y(yaw), eye);
        CameraMatrices::perspective(m, 1.0, 16.0 / 9.0, 0.1)
    }

    const LAYOUT: CascadeLayout = CascadeLayout {
        count: 4,
        size: 1024,
    };

    /// The fractional texel position of a fixed world point: the same in
    /// every frame means the grid did not move under it (no shimmer).
    fn phase(v: &LightView, p: Vec3) -> glam::Vec2 {
        let c = v.texel_coords(p).unwrap();
        c - c.floor()
    }

    #[test]
    fn cascades_keep_their_texel_grid_and_size_as_the_camera_moves_and_turns() {
        let level = LevelBox::of(&primary());
        let a = fit(&camera(Vec3::new(1.0, 1.7, 2.0), 0.3), &level, LAYOUT);
        let b = fit(&camera(Vec3::new(1.013, 1.7, 2.021), 0.3), &level, LAYOUT);
        let c = fit(&camera(Vec3::new(1.0, 1.7, 2.0), 1.1), &level, LAYOUT);
        assert_eq!(a.len(), 4);
        let p = Vec3::new(3.3, 0.2, -7.9);
        let mut same_size = 0;
        for k in 0..4 {
            assert_eq!(
                a[k].texel_scale, c[k].texel_scale,
                "turning resized cascade {k}"
            );
            if a[k].texel_scale == b[k].texel_scale {
                same_size += 1;
                let d = phase(&a[k], p) - phase(&b[k], p);
                assert!(
                    d.abs().max_element() < 1e-2,
                    "cascade {k}: grid moved by {d}"
                );
            }
        }
        assert!(
            same_size >= 3,
            "a 2 cm step resized {} cascades",
            4 - same_size
        );
        // Finest first.
        assert!(a.windows(2).all(|w| w[0].texel_scale < w[1].texel_scale));
    }

    #[test]
    fn every_point_of_the_frustum_is_in_some_cascade() {
        let level = LevelBox::of(&primary());
        let cam = camera(Vec3::new(-20.0, 2.0, 10.0), 0.7);
        let views = fit(&cam, &level, LAYOUT);
        let inv = cam.view_proj.inverse();
        for i in 0..=8 {
            for j in 0..=8 {
                let ndc = Vec3::new(i as f32 / 4.0 - 1.0, j as f32 / 4.0 - 1.0, 1.0);
                let near = inv.project_point3(ndc);
                let dir = (near - cam.position).normalize();
                for d in [0.2f32, 1.0, 5.0, 20.0, 80.0] {
                    let p = cam.position + dir * d;
                    let inside = views.iter().any(|v| {
                        let c = v.texel_coords(p).unwrap();
                        c.min_element() >= 3.0 && c.max_element() <= v.size as f32 - 3.0
                    });
                    assert!(inside, "{p} at depth {d} is in no cascade");
                }
            }
        }
    }

    #[test]
    fn a_level_behind_the_camera_gets_no_cascades() {
        let level = LevelBox::of(&primary());
        // 1 km away, looking away from the level.
        let cam = camera(Vec3::new(0.0, 0.0, 1000.0), std::f32::consts::PI);
        assert!(cam.forward.z > 0.99);
        assert!(fit(&cam, &level, LAYOUT).is_empty());
    }

    #[test]
    fn layout_grows_with_the_ratio() {
        assert_eq!(
            layout_for(1.5, 0),
            CascadeLayout {
                count: 2,
                size: 1024
            }
        );
        assert_eq!(layout_for(10.0, 0).count, 3);
        assert_eq!(
            layout_for(100.0, 0),
            CascadeLayout {
                count: 4,
                size: 2048
            }
        );
        assert_eq!(layout_for(100.0, 512).size, 512);
    }
}
