//! The primary light's projection, defined once for the bake (RSM) and the
//! runtime (shadow map, dynamic RSM). [`LightView`] is the CPU twin of
//! `wgsl/projection.wgsl`; [`GpuLightView`] is its GPU layout.
//!
//! - **Spot**: perspective from the light position along its direction,
//!   field of view `2 × outer cone` (clamped to 2 × 80°: a single perspective
//!   map cannot hold a wider cone; light outside it counts as unshadowed).
//!   The stored metric is Euclidean distance to the light.
//! - **Point**: six such perspective views, the faces of a cube around the
//!   light (90° each, [`LightView::point_faces`]).
//! - **Directional**: orthographic along the light direction, fitted to the
//!   given bounds (static geometry plus the swept bounds of moving objects).
//!   The stored metric is the distance along the light direction from the
//!   front plane of the fitted box.
//!
//! Both use reversed Z (near → 1, far → 0) for depth ordering. Biases are in
//! units of the texel footprint at the receiver ([`LightView::footprint`]),
//! which scales with the scene, so nothing depends on scene units.

use gibake_asset::LightViewRecord;
use gibake_scene::{Aabb, Light, LightKind, Scene};
use glam::{Mat4, Vec3, Vec4};

/// Largest spot half-angle a single perspective map covers.
pub const MAX_SPOT_HALF_ANGLE: f32 = 80.0 * std::f32::consts::PI / 180.0;

/// A light's view for shadow maps and RSMs.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LightView {
    /// True for directional (orthographic) views.
    pub directional: bool,
    /// World → clip (reversed Z).
    pub view_proj: Mat4,
    /// Spot: light position. Directional: a point on the front plane.
    pub origin: Vec3,
    /// Unit direction the light points to.
    pub direction: Vec3,
    /// Spot: `2·tan(fov/2)/size` (footprint per unit distance).
    /// Directional: world size of one texel.
    pub texel_scale: f32,
    /// Map resolution (square).
    pub size: u32,
    /// Spot: world-space area of one texel at unit distance, per steradian is
    /// computed per texel in WGSL; directional: world area of one texel.
    pub texel_area: f32,
}

/// An orthonormal basis `(tangent, bitangent)` around unit `n`, continuous
/// and valid for every direction (Duff et al. 2017, "Building an Orthonormal
/// Basis, Revisited"). No fixed up vector, so nothing degenerates.
pub fn orthonormal_basis(n: Vec3) -> (Vec3, Vec3) {
    // `n.z >= 0` (not copysign): -0.0 must pick +1, as `select` does in WGSL.
    let sign = if n.z >= 0.0 { 1.0f32 } else { -1.0 };
    let a = -1.0 / (sign + n.z);
    let b = n.x * n.y * a;
    let t = Vec3::new(1.0 + sign * n.x * n.x * a, sign * b, -sign * n.x);
    let bt = Vec3::new(b, sign + n.y * n.y * a, -n.y);
    (t, bt)
}

/// Right-handed perspective projection (view looks down −Z) with reversed Z:
/// depth 1 at `near`, 0 at `far`, for the `[0, 1]` clip range of wgpu.
pub fn perspective_reversed_z(fov_y: f32, aspect: f32, near: f32, far: f32) -> Mat4 {
    let f = 1.0 / (0.5 * fov_y).tan();
    let a = near / (far - near);
    let b = near * far / (far - near);
    Mat4::from_cols(
        Vec4::new(f / aspect, 0.0, 0.0, 0.0),
        Vec4::new(0.0, f, 0.0, 0.0),
        Vec4::new(0.0, 0.0, a, -1.0),
        Vec4::new(0.0, 0.0, b, 0.0),
    )
}

/// Right-handed orthographic projection with reversed Z over
/// `[-half_w, half_w] × [-half_h, half_h] × [near, far]`.
pub fn orthographic_reversed_z(half_w: f32, half_h: f32, near: f32, far: f32) -> Mat4 {
    let r = 1.0 / (far - near);
    Mat4::from_cols(
        Vec4::new(1.0 / half_w, 0.0, 0.0, 0.0),
        Vec4::new(0.0, 1.0 / half_h, 0.0, 0.0),
        Vec4::new(0.0, 0.0, r, 0.0),
        Vec4::new(0.0, 0.0, far * r, 1.0),
    )
}

/// View matrix of an eye at `origin` looking along unit `dir`, with the
/// up axis from [`orthonormal_basis`] (valid for every direction).
pub fn look_to(origin: Vec3, dir: Vec3) -> Mat4 {
    // Camera looks down −Z: z axis = −dir; x, y from the continuous basis.
    let (t, b) = orthonormal_basis(dir);
    let z = -dir;
    let (x, y) = (t, b);
    // Make (x, y, z) right-handed.
    let (x, y) = if x.cross(y).dot(z) > 0.0 {
        (x, y)
    } else {
        (y, x)
    };
    Mat4::from_cols(
        x.extend(0.0),
        y.extend(0.0),
        z.extend(0.0),
        origin.extend(1.0),
    )
    .inverse()
}

impl LightView {
    /// The manifest record of this view: the one conversion into the asset's
    /// plain arrays (its `size` is stored separately, as the bake's
    /// `shadow_map_size`).
    pub fn record(&self) -> LightViewRecord {
        LightViewRecord {
            directional: self.directional,
            view_proj: self.view_proj.to_cols_array(),
            origin: self.origin.to_array(),
            direction: self.direction.to_array(),
            texel_scale: self.texel_scale,
            texel_area: self.texel_area,
        }
    }

    /// The view of manifest record `r` at map resolution `size` (the one
    /// conversion back; the runtime merges moving objects in exactly the
    /// projection of the bake).
    pub fn from_record(r: &LightViewRecord, size: u32) -> LightView {
        LightView {
            directional: r.directional,
            view_proj: Mat4::from_cols_array(&r.view_proj),
            origin: Vec3::from_array(r.origin),
            direction: Vec3::from_array(r.direction),
            texel_scale: r.texel_scale,
            size,
            texel_area: r.texel_area,
        }
    }

    /// The light's view fitted to `bounds` (must include every surface that
    /// can cast a shadow or receive light), with a `size × size` map. A
    /// point light's is one cube face, the one along its `direction`;
    /// [`LightView::point_faces`] gives the six that cover its sphere. A
    /// spot or point light's far plane stops at its range.
    pub fn new(light: &Light, bounds: &Aabb, size: u32) -> LightView {
        let dir = light.direction.normalize();
        let size_f = size as f32;
        let half = match light.kind {
            LightKind::Spot { outer_cone, .. } => Some(outer_cone.clamp(1e-3, MAX_SPOT_HALF_ANGLE)),
            // One cube face: the 90° square frustum along `direction`
            // ([`LightView::point_faces`] gives all six).
            LightKind::Point => Some(std::f32::consts::FRAC_PI_4),
            LightKind::Directional => None,
        };
        match half {
            Some(half) => {
                let view = look_to(light.position, dir);
                let mut far = 0.0f32;
                for i in 0..8 {
                    let c = corner(bounds, i);
                    far = far.max((c - light.position).length());
                }
                if let Some(r) = light.range {
                    far = far.min(r);
                }
                let far = (far * 1.01).max(f32::MIN_POSITIVE);
                let near = far * 1e-5;
                let proj = perspective_reversed_z(2.0 * half, 1.0, near, far);
                let texel_scale = 2.0 * half.tan() / size_f;
                LightView {
                    directional: false,
                    view_proj: proj * view,
                    origin: light.position,
                    direction: dir,
                    texel_scale,
                    size,
                    texel_area: texel_scale * texel_scale,
                }
            }
            None => {
                let (t, b) = orthonormal_basis(dir);
                let (mut lo, mut hi) = (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY));
                for i in 0..8 {
                    let c = corner(bounds, i);
                    let l = Vec3::new(c.dot(t), c.dot(b), c.dot(dir));
                    lo = lo.min(l);
                    hi = hi.max(l);
                }
                LightView::directional(dir, lo, hi, size)
            }
        }
    }

    /// The six cube faces of a point light at `light.position`, looking
    /// along +X, −X, +Y, −Y, +Z, −Z (world axes), each a 90° square
    /// perspective view fitted to `bounds` like a spot's. Together they
    /// cover the sphere once: a direction belongs to the face of its largest
    /// absolute component, the frustum of that face (the omnidirectional
    /// layout, docs/method.md "Point lights"). Works for any light kind's
    /// position; only point lights use it.
    pub fn point_faces(light: &Light, bounds: &Aabb, size: u32) -> [LightView; 6] {
        let face = |dir: Vec3| {
            LightView::new(
                &Light {
                    kind: LightKind::Point,
                    direction: dir,
                    ..light.clone()
                },
                bounds,
                size,
            )
        };
        [
            face(Vec3::X),
            face(Vec3::NEG_X),
            face(Vec3::Y),
            face(Vec3::NEG_Y),
            face(Vec3::Z),
            face(Vec3::NEG_Z),
        ]
    }

    /// The view of `scene`'s light with a `size × size` map: a directional
    /// light's extent chosen by [`crate::light_fit::fit`] (a bake volume, or
    /// the static geometry without outliers, plus the moving objects' swept
    /// bounds), a spot light's cone reaching every surface. The one
    /// definition of "the light view of a scene", for the bake and for the
    /// runtime's direct mode without an asset.
    pub fn for_scene(scene: &Scene, size: u32) -> LightView {
        match crate::light_fit::fit(scene) {
            Some(f) => {
                LightView::directional(scene.light().direction.normalize(), f.lo, f.hi, size)
            }
            None => LightView::new(scene.light(), &scene.full_bounds(), size),
        }
    }

    /// Every view of `light` (one of `scene.lights`) with `size × size`
    /// maps: a spot's one, a directional light's fitted one (as
    /// [`LightView::for_scene`]), a point light's six cube faces. The one
    /// definition of "a light's views" for the bake of every light.
    pub fn of_light(scene: &Scene, light: &Light, size: u32) -> Vec<LightView> {
        match light.kind {
            LightKind::Point => LightView::point_faces(light, &scene.full_bounds(), size).to_vec(),
            _ => match crate::light_fit::fit_light(scene, light) {
                Some(f) => vec![LightView::directional(
                    light.direction.normalize(),
                    f.lo,
                    f.hi,
                    size,
                )],
                None => vec![LightView::new(light, &scene.full_bounds(), size)],
            },
        }
    }

    /// An orthographic view along unit `dir` covering the light-space box
    /// `[lo, hi]` (`x, y` along [`orthonormal_basis`] of `dir`, `z` along
    /// `dir`) with a 1% margin.
    pub fn directional(dir: Vec3, lo: Vec3, hi: Vec3, size: u32) -> LightView {
        let (t, b) = orthonormal_basis(dir);
        // Margins per direction: across the light 1% of the wider side,
        // along it 1% of the depth range (a deep level must not widen the
        // map).
        let across = (hi.x - lo.x).max(hi.y - lo.y).max(f32::MIN_POSITIVE);
        let half_w = across * 0.5 * 1.02;
        let depth_margin = (hi.z - lo.z).max(across * 1e-3) * 0.01;
        let cx = (lo.x + hi.x) * 0.5;
        let cy = (lo.y + hi.y) * 0.5;
        let front = lo.z - depth_margin;
        let depth = hi.z - lo.z + 2.0 * depth_margin;
        let origin = t * cx + b * cy + dir * front;
        let view = look_to(origin, dir);
        let proj = orthographic_reversed_z(half_w, half_w, 0.0, depth);
        let texel = 2.0 * half_w / size as f32;
        LightView {
            directional: true,
            view_proj: proj * view,
            origin,
            direction: dir,
            texel_scale: texel,
            size,
            texel_area: texel * texel,
        }
    }

    /// The same view with a `size × size` map (texel scale and area rescaled).
    pub fn resized(&self, size: u32) -> LightView {
        let r = self.size as f32 / size.max(1) as f32;
        LightView {
            size,
            texel_scale: self.texel_scale * r,
            texel_area: self.texel_area * r * r,
            ..*self
        }
    }

    /// The stored shadow metric of a world point (see module docs).
    pub fn metric(&self, p: Vec3) -> f32 {
        if self.directional {
            (p - self.origin).dot(self.direction)
        } else {
            (p - self.origin).length()
        }
    }

    /// Whether anything inside `bounds` may be in this view's map: false
    /// only when the box lies wholly outside one plane of the view's
    /// frustum (left, right, bottom, top, near, far), or wholly behind a
    /// perspective view's eye. Conservative (a box beside a frustum's edge
    /// may still say true). What decides which views a moving object is
    /// merged into; an empty box is in no view.
    pub fn may_see(&self, bounds: &Aabb) -> bool {
        self.clip_corners(bounds)
            .is_some_and(|clip| sees_clip(&clip))
    }

    /// The clip-space corners of `bounds` (`None` for an empty box).
    fn clip_corners(&self, bounds: &Aabb) -> Option<[Vec4; 8]> {
        bounds
            .min
            .cmple(bounds.max)
            .all()
            .then(|| std::array::from_fn(|i| self.view_proj * corner(bounds, i).extend(1.0)))
    }

    /// The texels `[x0, x1) × [y0, y1)` of the map that `bounds` can cover
    /// (every texel whose centre the part of the box on the far side of the
    /// near plane may project to, plus one texel of margin: the
    /// rasterizer clips the rest), or `None` when the view cannot see the
    /// box ([`LightView::may_see`]) or none of it lies beyond the near
    /// plane. A box around a spot's or point face's eye gives the whole
    /// map; one that reaches behind the eye beside it, only what its part in
    /// front covers.
    pub fn texel_rect(&self, bounds: &Aabb) -> Option<[u32; 4]> {
        let clip = self.clip_corners(bounds).filter(sees_clip)?;
        let n = self.size as f32;
        let whole = Some([0, 0, self.size, self.size]);
        if clip.iter().any(|c| !c.is_finite()) {
            return whole;
        }
        // Reversed Z: the near plane is z = w, the kept side w − z ≥ 0 (a
        // point behind a perspective eye has w < 0 < z).
        let side = |c: &Vec4| c.w - c.z;
        let (mut lo, mut hi) = (
            glam::Vec2::splat(f32::INFINITY),
            glam::Vec2::splat(f32::NEG_INFINITY),
        );
        let mut add = |c: Vec4| {
            // On the near plane w is the near distance (> 0); a point
            // there that is not (rounding at the eye) makes it unbounded.
            let in_front = c.w > 1e-6 * c.truncate().length().max(f32::MIN_POSITIVE);
            if !in_front {
                lo = glam::Vec2::NEG_INFINITY;
                hi = glam::Vec2::INFINITY;
                return;
            }
            let ndc = c.truncate() / c.w;
            let t = glam::Vec2::new(ndc.x * 0.5 + 0.5, 0.5 - ndc.y * 0.5) * n;
            lo = lo.min(t);
            hi = hi.max(t);
        };
        for c in &clip {
            if side(c) >= 0.0 {
                add(*c);
            }
        }
        // The box's edges that cross the near plane, where they cross it.
        for (i, j) in BOX_EDGES {
            let (di, dj) = (side(&clip[i]), side(&clip[j]));
            if (di >= 0.0) != (dj >= 0.0) {
                let t = di / (di - dj);
                add(clip[i] + (clip[j] - clip[i]) * t);
            }
        }
        if lo.x > hi.x || lo.y > hi.y {
            return None;
        }
        if !(lo.is_finite() && hi.is_finite()) {
            return whole;
        }
        let clamp = |v: f32| v.clamp(0.0, n) as u32;
        let (x0, y0) = (clamp(lo.x.floor() - 1.0), clamp(lo.y.floor() - 1.0));
        let (x1, y1) = (clamp(hi.x.ceil() + 1.0), clamp(hi.y.ceil() + 1.0));
        (x1 > x0 && y1 > y0).then_some([x0, y0, x1, y1])
    }

    /// World size of one map texel at `p`.
    pub fn footprint(&self, p: Vec3) -> f32 {
        if self.directional {
            self.texel_scale
        } else {
            self.metric(p) * self.texel_scale
        }
    }

    /// Continuous texel coordinates of `p` (x right, y down, texel centres at
    /// half-integers), or `None` if behind a spot light.
    pub fn texel_coords(&self, p: Vec3) -> Option<glam::Vec2> {
        let c = self.view_proj * p.extend(1.0);
        if c.w <= 0.0 {
            return None;
        }
        let ndc = c.truncate() / c.w;
        let uv = glam::Vec2::new(ndc.x * 0.5 + 0.5, 0.5 - ndc.y * 0.5);
        Some(uv * self.size as f32)
    }

    /// The ray through the centre of texel `(x, y)`: `(origin, unit
    /// direction)`. Spot: from the light; directional: from the front plane.
    pub fn texel_ray(&self, x: u32, y: u32) -> (Vec3, Vec3) {
        let n = self.size as f32;
        let ndc = glam::Vec2::new(
            (x as f32 + 0.5) / n * 2.0 - 1.0,
            1.0 - (y as f32 + 0.5) / n * 2.0,
        );
        let inv = self.view_proj.inverse();
        let near = inv.project_point3(ndc.extend(1.0));
        let far = inv.project_point3(ndc.extend(0.0));
        if self.directional {
            (near, self.direction)
        } else {
            (self.origin, (far - near).normalize())
        }
    }

    /// Solid angle (spot) or perpendicular area (directional) of texel
    /// `(x, y)`: `texel_scale² · cos³θ` around the spot axis, `texel_scale²`
    /// for directional lights. CPU twin of `lv_texel_measure` in WGSL.
    pub fn texel_measure(&self, dir: Vec3) -> f32 {
        if self.directional {
            self.texel_area
        } else {
            let c = dir.dot(self.direction).max(0.0);
            self.texel_area * c * c * c
        }
    }

    /// GPU layout of this view.
    pub fn to_gpu(&self) -> GpuLightView {
        GpuLightView {
            view_proj: self.view_proj.to_cols_array_2d(),
            origin: self
                .origin
                .extend(if self.directional { 1.0 } else { 0.0 })
                .to_array(),
            direction: self.direction.extend(self.texel_scale).to_array(),
            params: Vec4::new(
                self.size as f32,
                1.0 / self.size as f32,
                self.texel_area,
                0.0,
            )
            .to_array(),
        }
    }
}

/// Whether a box whose clip-space corners are `clip` may be in the view:
/// not wholly outside one plane of its frustum ([`LightView::may_see`]).
fn sees_clip(clip: &[Vec4; 8]) -> bool {
    // Reversed Z in wgpu's [0, 1]: inside is −w ≤ x, y ≤ w, 0 ≤ z ≤ w.
    let outside = [
        |c: &Vec4| c.x < -c.w,
        |c: &Vec4| c.x > c.w,
        |c: &Vec4| c.y < -c.w,
        |c: &Vec4| c.y > c.w,
        |c: &Vec4| c.z < 0.0,
        |c: &Vec4| c.z > c.w,
    ];
    !outside.iter().any(|plane| clip.iter().all(plane))
}

/// The twelve edges of a box, as pairs of [`corner`] indices (bit k of the
/// index picks min or max along axis k).
const BOX_EDGES: [(usize, usize); 12] = [
    (0, 1),
    (2, 3),
    (4, 5),
    (6, 7),
    (0, 2),
    (1, 3),
    (4, 6),
    (5, 7),
    (0, 4),
    (1, 5),
    (2, 6),
    (3, 7),
];

fn corner(b: &Aabb, i: usize) -> Vec3 {
    Vec3::new(
        if i & 1 == 0 { b.min.x } else { b.max.x },
        if i & 2 == 0 { b.min.y } else { b.max.y },
        if i & 4 == 0 { b.min.z } else { b.max.z },
    )
}

/// GPU layout of [`LightView`]. Must match `LightView` in `wgsl/projection.wgsl`.
#[repr(C)]
#[derive(Clone, Copy, Debug, bytemuck::Pod, bytemuck::Zeroable)]
pub struct GpuLightView {
    /// World → clip.
    pub view_proj: [[f32; 4]; 4],
    /// xyz origin, w = 1 directional / 0 spot.
    pub origin: [f32; 4],
    /// xyz direction, w = texel scale.
    pub direction: [f32; 4],
    /// x size, y 1/size, z texel area, w unused.
    pub params: [f32; 4],
}

/// GPU layout of the primary light's radiometry. Must match `PrimaryLight`
/// in `wgsl/light.wgsl`.
#[repr(C)]
#[derive(Clone, Copy, Debug, bytemuck::Pod, bytemuck::Zeroable)]
pub struct GpuPrimaryLight {
    /// xyz position, w = 1 directional / 0 spot.
    pub position: [f32; 4],
    /// xyz unit direction the light points to.
    pub direction: [f32; 4],
    /// rgb: W/sr (spot) or W/m² (directional).
    pub color: [f32; 4],
    /// x: spot scale, y: spot offset (glTF falloff), z: range (0: none), w
    /// unused.
    pub spot: [f32; 4],
}

impl GpuPrimaryLight {
    /// From the scene's light.
    pub fn new(light: &Light) -> Self {
        let (dir_flag, scale, offset) = match light.kind {
            LightKind::Directional => (1.0, 0.0, 1.0),
            LightKind::Spot { .. } | LightKind::Point => {
                let (scale, offset) = light.spot_scale_offset();
                (0.0, scale, offset)
            }
        };
        GpuPrimaryLight {
            position: light.position.extend(dir_flag).to_array(),
            direction: light.direction.normalize().extend(0.0).to_array(),
            color: light.color.extend(0.0).to_array(),
            spot: [scale, offset, light.range.unwrap_or(0.0), 0.0],
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A box's texel rectangle holds the texel of every point of the box
    /// (sampled), is much smaller than the map for a small box, is the
    /// whole map for a box around a spot's eye, and is `None` for a box
    /// the view cannot see.
    #[test]
    fn texel_rect_holds_the_box() {
        let spot = Light {
            name: "spot".into(),
            kind: LightKind::Spot {
                inner_cone: 0.3,
                outer_cone: 0.6,
            },
            color: Vec3::ONE,
            position: Vec3::new(0.0, 5.0, 0.0),
            direction: Vec3::NEG_Y,
            range: None,
        };
        let scene = Aabb {
            min: Vec3::new(-10.0, 0.0, -10.0),
            max: Vec3::new(10.0, 1.0, 10.0),
        };
        let sun = LightView::directional(
            Vec3::new(0.3, -1.0, 0.2).normalize(),
            scene.min,
            scene.max,
            256,
        );
        for view in [LightView::new(&spot, &scene, 256), sun] {
            let ball = Aabb {
                min: Vec3::new(0.5, 0.0, -0.7),
                max: Vec3::new(1.1, 0.6, -0.1),
            };
            let [x0, y0, x1, y1] = view.texel_rect(&ball).expect("the view sees the ball");
            assert!(
                (x1 - x0) * (y1 - y0) < 256 * 256 / 16,
                "{:?}",
                [x0, y0, x1, y1]
            );
            for i in 0..1000 {
                let f = |k: u32| ((i * k) % 97) as f32 / 96.0;
                let p = ball.min + (ball.max - ball.min) * Vec3::new(f(13), f(29), f(61));
                let t = view.texel_coords(p).expect("in front");
                let (x, y) = (t.x.floor() as u32, t.y.floor() as u32);
                assert!(x0 <= x && x < x1 && y0 <= y && y < y1, "{p} at ({x}, {y})");
            }
            let far = Aabb {
                min: Vec3::splat(1e3),
                max: Vec3::splat(1e3 + 1.0),
            };
            assert_eq!(view.texel_rect(&far), None);
        }
        let view = LightView::new(&spot, &scene, 256);
        let around_eye = Aabb {
            min: Vec3::new(-1.0, 4.0, -1.0),
            max: Vec3::new(1.0, 6.0, 1.0),
        };
        assert_eq!(view.texel_rect(&around_eye), Some([0, 0, 256, 256]));
        // Beside the eye, reaching behind its plane: only the part beyond
        // the near plane counts (the rasterizer clips the rest), so not
        // the whole map, and every point of the box the map shows is in it.
        let beside = Aabb {
            min: Vec3::new(0.3, 3.5, -0.2),
            max: Vec3::new(0.6, 5.5, 0.1),
        };
        let [x0, y0, x1, y1] = view.texel_rect(&beside).expect("the spot sees it");
        assert!(
            (x1 - x0) * (y1 - y0) < 256 * 256 / 2,
            "{:?}",
            [x0, y0, x1, y1]
        );
        let mut shown = 0;
        for i in 0..4000 {
            let f = |k: u32| ((i * k) % 997) as f32 / 996.0;
            let p = beside.min + (beside.max - beside.min) * Vec3::new(f(13), f(29), f(61));
            let c = view.view_proj * p.extend(1.0);
            if !(c.w > 0.0 && c.z <= c.w) {
                continue;
            }
            let Some(t) = view.texel_coords(p) else {
                continue;
            };
            if t.x < 0.0 || t.y < 0.0 || t.x >= 256.0 || t.y >= 256.0 {
                continue;
            }
            shown += 1;
            let (x, y) = (t.x.floor() as u32, t.y.floor() as u32);
            assert!(x0 <= x && x < x1 && y0 <= y && y < y1, "{p} at ({x}, {y})");
        }
        assert!(shown > 100, "{shown} points of the box in the map");
        // Wholly behind the eye: not seen.
        let behind = Aabb {
            min: Vec3::new(-0.5, 5.5, -0.5),
            max: Vec3::new(0.5, 6.0, 0.5),
        };
        assert_eq!(view.texel_rect(&behind), None);
    }

    /// A point light's six faces cover every direction exactly once: the
    /// texel coordinates of a point seen from the light fall inside exactly
    /// one face's map (ties on the faces' shared edges aside), and the
    /// faces' texel solid angles sum to 4π.
    #[test]
    fn point_faces_tile_the_sphere() {
        let bounds = Aabb {
            min: Vec3::splat(-10.0),
            max: Vec3::splat(10.0),
        };
        let light = Light {
            name: "bulb".into(),
            kind: LightKind::Point,
            color: Vec3::ONE,
            position: Vec3::new(0.3, -0.2, 0.1),
            direction: Vec3::NEG_Z,
            range: None,
        };
        let size = 32;
        let faces = LightView::point_faces(&light, &bounds, size);
        // A Fibonacci sphere of directions, none on a face edge.
        let n = 2000;
        for i in 0..n {
            let z = 1.0 - (2.0 * i as f32 + 1.0) / n as f32;
            let r = (1.0 - z * z).sqrt();
            let phi = i as f32 * 2.399_963;
            let d = Vec3::new(r * phi.cos(), r * phi.sin(), z);
            let a = d.abs();
            let m = a.max_element();
            let sorted = {
                let mut v = a.to_array();
                v.sort_by(f32::total_cmp);
                v
            };
            if sorted[2] - sorted[1] < 1e-3 * m {
                continue;
            }
            let p = light.position + d * 3.0;
            let inside = faces
                .iter()
                .filter(|f| {
                    f.texel_coords(p).is_some_and(|c| {
                        c.x >= 0.0 && c.y >= 0.0 && c.x <= size as f32 && c.y <= size as f32
                    }) && f.direction.dot(d) > 0.0
                })
                .count();
            assert_eq!(inside, 1, "direction {d}");
        }
        let mut total = 0.0f64;
        for f in &faces {
            for y in 0..size {
                for x in 0..size {
                    let (o, d) = f.texel_ray(x, y);
                    assert_eq!(o, light.position);
                    total += f64::from(f.texel_measure(d));
                }
            }
        }
        let rel = (total / (4.0 * std::f64::consts::PI) - 1.0).abs();
        assert!(rel < 2e-3, "Σ texel solid angles = {total}, 4π·(1 ± {rel})");
    }

    /// A box in front of a face is seen by it (and by no face it lies
    /// wholly behind), a box beyond the range by none, an empty box by
    /// none; a directional view sees what its fitted box holds.
    #[test]
    fn may_see_culls_boxes_outside_a_view() {
        let bounds = Aabb {
            min: Vec3::splat(-10.0),
            max: Vec3::splat(10.0),
        };
        let light = Light {
            name: "bulb".into(),
            kind: LightKind::Point,
            color: Vec3::ONE,
            position: Vec3::ZERO,
            direction: Vec3::NEG_Z,
            range: Some(5.0),
        };
        let faces = LightView::point_faces(&light, &bounds, 64);
        let ball = |c: Vec3| Aabb {
            min: c - 0.2,
            max: c + 0.2,
        };
        // +X, −X, +Y, −Y, +Z, −Z
        let seen = |b: &Aabb| faces.iter().map(|f| f.may_see(b)).collect::<Vec<_>>();
        assert_eq!(
            seen(&ball(Vec3::new(3.0, 0.0, 0.0))),
            [true, false, false, false, false, false]
        );
        assert_eq!(
            seen(&ball(Vec3::new(0.0, -2.0, 0.0))),
            [false, false, false, true, false, false]
        );
        // On the +X/+Y edge: both faces (conservative, never neither).
        let edge = seen(&ball(Vec3::new(2.0, 2.0, 0.0)));
        assert!(edge[0] && edge[2], "{edge:?}");
        // Beyond the range (5.05 with the margin): no face.
        assert!(seen(&ball(Vec3::new(0.0, 0.0, -7.0))).iter().all(|s| !s));
        assert!(seen(&Aabb::EMPTY).iter().all(|s| !s));
        // A sun's view sees inside its fitted box, not beside it.
        let sun = Light {
            kind: LightKind::Directional,
            direction: Vec3::new(0.3, -1.0, 0.2).normalize(),
            range: None,
            ..light.clone()
        };
        let small = Aabb {
            min: Vec3::splat(-1.0),
            max: Vec3::splat(1.0),
        };
        let v = LightView::new(&sun, &small, 64);
        assert!(v.may_see(&ball(Vec3::ZERO)));
        assert!(!v.may_see(&ball(Vec3::new(30.0, 0.0, 0.0))));
    }

    /// A range shortens a spot or point light's view: its far plane stops
    /// just past the range.
    #[test]
    fn range_bounds_the_far_plane() {
        let bounds = Aabb {
            min: Vec3::splat(-100.0),
            max: Vec3::splat(100.0),
        };
        let mut light = Light {
            name: "bulb".into(),
            kind: LightKind::Point,
            color: Vec3::ONE,
            position: Vec3::ZERO,
            direction: Vec3::NEG_Z,
            range: Some(2.0),
        };
        let v = LightView::new(&light, &bounds, 64);
        // Beyond 2.02 along the axis the clip depth is behind the far plane.
        let depth = |v: &LightView, t: f32| {
            let c = v.view_proj * (Vec3::NEG_Z * t).extend(1.0);
            c.z / c.w
        };
        assert!(depth(&v, 1.9) > 0.0);
        assert!(depth(&v, 2.1) < 0.0);
        light.range = None;
        let v = LightView::new(&light, &bounds, 64);
        assert!(depth(&v, 100.0) > 0.0);
    }

    /// Record → view → record is the identity, bit for bit, for both kinds.
    #[test]
    fn record_round_trip() {
        let bounds = Aabb {
            min: Vec3::new(-2.0, -0.5, -3.0),
            max: Vec3::new(4.0, 3.0, 1.0),
        };
        let spot = Light {
            name: "spot".into(),
            kind: LightKind::Spot {
                inner_cone: 0.3,
                outer_cone: 0.6,
            },
            color: Vec3::ONE,
            position: Vec3::new(0.5, 5.0, 0.25),
            direction: Vec3::new(0.1, -1.0, 0.05).normalize(),
            range: None,
        };
        let sun = Light {
            kind: LightKind::Directional,
            ..spot.clone()
        };
        for light in [spot, sun] {
            let view = LightView::new(&light, &bounds, 512);
            let back = LightView::from_record(&view.record(), 512);
            assert_eq!(back, view);
            assert_eq!(back.record(), view.record());
        }
    }

    #[test]
    fn basis_of_negative_zero_z_matches_wgsl() {
        // WGSL's `select(-1.0, 1.0, n.z >= 0.0)` gives +1 for -0.0.
        let (t, b) = orthonormal_basis(Vec3::new(1.0, 0.0, -0.0));
        let (t2, b2) = orthonormal_basis(Vec3::new(1.0, 0.0, 0.0));
        assert_eq!((t, b), (t2, b2));
    }

    #[test]
    fn basis_is_orthonormal_for_every_axis_and_near_poles() {
        for n in [
            Vec3::X,
            Vec3::Y,
            Vec3::Z,
            -Vec3::X,
            -Vec3::Y,
            -Vec3::Z,
            Vec3::new(1e-8, 0.0, -1.0).normalize(),
        ] {
            let (t, b) = orthonormal_basis(n);
            assert!(
                (t.length() - 1.0).abs() < 1e-5 && (b.length() - 1.0).abs() < 1e-5,
                "{n}"
            );
            assert!(
                t.dot(b).abs() < 1e-5 && t.dot(n).abs() < 1e-5 && b.dot(n).abs() < 1e-5,
                "{n}"
            );
        }
    }

    fn spot(pos: Vec3, dir: Vec3) -> Light {
        Light {
            name: "s".into(),
            kind: LightKind::Spot {
                inner_cone: 0.3,
                outer_cone: 0.6,
            },
            color: Vec3::ONE,
            position: pos,
            direction: dir,
            range: None,
        }
    }

    #[test]
    fn spot_axis_projects_to_the_map_centre_and_scales_invariantly() {
        for s in [1e-3f32, 1.0, 1e3] {
            let l = spot(Vec3::new(0.0, 2.0, 0.0) * s, -Vec3::Y);
            let b = Aabb {
                min: Vec3::splat(-1.0) * s,
                max: Vec3::splat(1.0) * s,
            };
            let v = LightView::new(&l, &b, 512);
            let c = v.texel_coords(Vec3::ZERO).unwrap();
            assert!((c - glam::Vec2::splat(256.0)).length() < 1e-2, "{c}");
            let p = Vec3::new(0.3, 0.0, -0.2) * s;
            let c = v.texel_coords(p).unwrap();
            let v1 = LightView::new(
                &spot(Vec3::new(0.0, 2.0, 0.0), -Vec3::Y),
                &Aabb {
                    min: Vec3::splat(-1.0),
                    max: Vec3::ONE,
                },
                512,
            );
            let c1 = v1.texel_coords(p / s).unwrap();
            assert!((c - c1).length() < 1e-2, "{c} {c1}");
            assert!(
                (v.footprint(p) / s - v1.footprint(p / s)).abs()
                    < 1e-6 * v1.footprint(p / s).max(1.0)
            );
        }
    }

    #[test]
    fn directional_fit_contains_the_bounds() {
        let l = Light {
            name: "d".into(),
            kind: LightKind::Directional,
            color: Vec3::ONE,
            position: Vec3::ZERO,
            direction: Vec3::new(0.3, -1.0, 0.2).normalize(),
            range: None,
        };
        let b = Aabb {
            min: Vec3::new(-5.0, 0.0, -3.0),
            max: Vec3::new(4.0, 2.0, 6.0),
        };
        let v = LightView::new(&l, &b, 256);
        for i in 0..8 {
            let c = v.texel_coords(corner(&b, i)).unwrap();
            assert!(c.x > 0.0 && c.x < 256.0 && c.y > 0.0 && c.y < 256.0, "{c}");
            let clip = v.view_proj * corner(&b, i).extend(1.0);
            assert!(clip.z / clip.w > 0.0 && clip.z / clip.w < 1.0);
            assert!(v.metric(corner(&b, i)) > 0.0);
        }
    }
}
