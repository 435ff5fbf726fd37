//! `gibake-raycast`: CPU ray casting over a [`Scene`] at one time: an obvhs
//! compressed wide BVH (CWBVH) over every triangle, watertight ray/triangle
//! tests, robust ray offsets, and the closest-hit / any-hit / visibility
//! queries built on them ([`RayScene`]).
//!
//! # Who uses it, and what that shares
//! Two crates cast rays on the CPU: the bake (`gibake-bake`: the reflective
//! shadow map is ray traced from the light, the VPL hemisphere maps measure
//! distances with rays) and the physics reference (`gibake-reference`: camera,
//! shadow and bounce rays). Both use this crate, so the product and its judge
//! share the scene importer *and* the geometry queries: a bug here (a missed
//! hit, a wrong normal, a leaking offset) would move both the same way and an
//! image comparison between them could not see it. What the judge does *not*
//! share with the bake is everything above the queries: the light transport
//! (the reference's direct-light estimate, its shadow rays and the bounce
//! integral live in `gibake-reference`), the GPU renderer and the VPL maps.
//! The queries themselves are checked against closed-form answers that do not
//! come from any renderer: the tests of this crate (`tests/analytic.rs`: hit
//! distances, normals and barycentrics on known triangles, shared edges,
//! scale invariance) and the analytic scenes of
//! `crates/reference/tests/physics.rs` (inverse-square spot, exact shadow
//! edge, closed box, quadrature of a one-bounce integral). See
//! `docs/reference.md`.
//!
//! # Scale invariance
//! Triangles are stored multiplied by a power of two `k` chosen so that the
//! largest absolute coordinate lies in `[0.5, 1)`. Multiplying by a power of
//! two is exact in floating point, so every intersection, every BVH bound and
//! every ray offset is computed on the same numbers whatever the scene's unit
//! (up to a power of two). The few constants of the traversal (obvhs clamps a
//! box entry distance at `f32::EPSILON`, pads flat boxes by `1e-20`) and of the
//! Wächter & Binder offset (its `1/32` and `1/65536`) thereby become relative
//! to the scene's size. Public methods take and return world coordinates.
//!
//! # Robustness
//! - Ray/triangle: Woop, Benthin & Wald 2013, "Watertight Ray/Triangle
//!   Intersection", two-sided, with a double-precision fallback on edges.
//! - Offsets: Wächter & Binder, "A Fast and Robust Method for Avoiding
//!   Self-Intersection" (Ray Tracing Gems, ch. 6): the hit point is
//!   reconstructed from barycentrics and moved along the geometric normal by
//!   256 float ULPs per unit normal component.
//! - Zero-area and non-finite triangles are dropped at build time; missing or
//!   degenerate shading normals fall back to the geometric normal.
//!
//! # Alpha
//! Triangles of an alpha-masked material (`alphaMode: MASK`, and `BLEND`
//! read as a mask) get an any-hit test: a hit where the material's alpha
//! (factor × texture, bilinear) is below its cutoff is skipped and the ray
//! goes on, in every query. The bake's RSM and VPL maps and the reference
//! thereby see the same holes the GPU passes cut with `alpha_keeps`.

use gibake_scene::Scene;
use glam::{DVec3, Mat3, Vec2, Vec3, Vec3A};
use obvhs::{
    BvhBuildParams,
    cwbvh::{CwBvh, builder::build_cwbvh_from_tris},
    ray::Ray,
    triangle::Triangle,
};

/// A ray/surface intersection, in world space. The geometric normal faces
/// the ray's origin, the shading normal lies on its side.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Hit {
    /// Distance along the ray, in units of the ray direction's length.
    pub t: f32,
    /// World position, reconstructed from the barycentrics (more accurate than
    /// `origin + t·dir`, as the ray offset requires).
    pub position: Vec3,
    /// Unit triangle normal, facing the ray origin.
    pub geometric_normal: Vec3,
    /// Unit interpolated vertex normal, flipped to the geometric normal's
    /// side (it may still point slightly away from the viewer near a smooth
    /// silhouette; that is kept).
    pub shading_normal: Vec3,
    /// Lambertian albedo at the hit ([`Scene::albedo`] of the mesh material at the
    /// interpolated texture coordinate).
    pub albedo: Vec3,
    /// Interpolated TEXCOORD_0, if the mesh has one.
    pub uv: Option<Vec2>,
    /// Barycentric weights of the triangle's three vertices.
    pub barycentrics: Vec3,
    /// Index of the hit triangle in the order of [`Scene::meshes_at`]
    /// (mesh by mesh, triangle by triangle, degenerate ones included).
    pub triangle: u32,
    /// Index of the mesh in [`Scene::meshes_at`].
    pub mesh: u32,
}

/// The direction given to the BVH traversal: exact zero components (an
/// axis-aligned light, a sun at azimuth 0) become ±10⁻²⁰ times the largest
/// component, so that the box tests' `1/d` and `origin/d` stay finite (the
/// scene is normalised to coordinates below 1) and no `0 · ∞` or `∞ − ∞`
/// turns a slab test into NaN (which rejected every box: a sun at azimuth 0
/// lit nothing; a −0.0 component from a node rotation did the same). The
/// deflection, 10⁻²⁰ rad, is far below f32 resolution. The watertight
/// triangle test keeps the exact direction.
fn bvh_direction(d: Vec3A) -> Vec3A {
    let tiny = 1e-20 * d.abs().max_element();
    Vec3A::new(
        if d.x == 0.0 { tiny.copysign(d.x) } else { d.x },
        if d.y == 0.0 { tiny.copysign(d.y) } else { d.y },
        if d.z == 0.0 { tiny.copysign(d.z) } else { d.z },
    )
}

/// obvhs 0.4's box test ignores the ray's `tmin` and starts every box at
/// `EPSILON = 10⁻⁴` (in the scene's normalised units, `cwbvh/node.rs`): a
/// box the ray leaves before that is skipped, so a ray that starts within
/// 10⁻⁴ of the scene's size of a surface it points at (a bounce from near a
/// corner, a VPL's map origin beside a wall) went through it. The traversal
/// runs on the ray started this far behind its origin (its `t` range moved
/// by as much), and the exact triangle test on the ray itself: every box
/// the ray enters at `t ≥ 0` is entered past the epsilon.
const PULL_BACK: f32 = 4e-4;

/// The BVH traversal ray for `origin + t·dir`, `t ∈ (t_min, t_max)`
/// (scaled space), started [`PULL_BACK`] behind the origin, and how far
/// back in `t` units.
fn pulled_back(o: Vec3A, d: Vec3A, t_min: f32, t_max: f32) -> (Ray, f32) {
    let back = PULL_BACK / d.length();
    let back = if back.is_finite() { back } else { 0.0 };
    (
        Ray::new(o - d * back, bvh_direction(d), t_min + back, t_max + back),
        back,
    )
}

/// One triangle as stored for shading.
#[derive(Clone, Copy, Debug)]
struct Tri {
    /// Vertices multiplied by the scene scale `k`.
    v: [Vec3A; 3],
    /// Unit geometric normal (of the right-handed winding v0, v1, v2).
    ng: Vec3,
    /// World-space unit vertex normals (non-finite ones replaced by `ng`).
    n: [Vec3; 3],
    /// Texture coordinates, if the mesh has them.
    uv: Option<[Vec2; 3]>,
    /// Material index, `u32::MAX` when the mesh's index is out of range (albedo 0).
    material: u32,
    /// Triangle index in meshes_at order.
    id: u32,
    /// Mesh index in meshes_at order.
    mesh: u32,
    /// Whether the material is alpha-masked (hits are alpha-tested).
    masked: bool,
}

/// The BVH over all triangles of a scene at one time `t` (static meshes as
/// they are, dynamic meshes transformed to world space), with everything
/// needed to shade a hit.
pub struct RayScene<'s> {
    scene: &'s Scene,
    /// `None` when the scene has no usable triangle.
    bvh: Option<CwBvh>,
    /// Triangles in BVH leaf order (indexed by the traversal's primitive id).
    tris: Vec<Tri>,
    /// Power-of-two scale applied to stored positions.
    scale: f32,
    /// `1 / scale` (exact).
    inv_scale: f32,
}

/// Exact `2^e` for `e` in the normal exponent range.
fn pow2(e: i32) -> f32 {
    f32::from_bits(((e.clamp(-126, 127) + 127) as u32) << 23)
}

/// Wächter & Binder's `offset_ray` (Ray Tracing Gems, ch. 6), in the scaled
/// coordinates (|p| ≲ 1): moves `p` off its surface along `n` by 256 ULPs
/// per unit normal component (an absolute `n/65536` near the origin).
fn offset_ray_scaled(p: Vec3, n: Vec3) -> Vec3 {
    const ORIGIN: f32 = 1.0 / 32.0;
    const FLOAT_SCALE: f32 = 1.0 / 65536.0;
    const INT_SCALE: f32 = 256.0;
    let comp = |p: f32, n: f32| -> f32 {
        if p.abs() < ORIGIN {
            p + FLOAT_SCALE * n
        } else {
            let of_i = (INT_SCALE * n) as i32;
            let bits = p.to_bits() as i32;
            f32::from_bits(bits.wrapping_add(if p < 0.0 { -of_i } else { of_i }) as u32)
        }
    };
    Vec3::new(comp(p.x, n.x), comp(p.y, n.y), comp(p.z, n.z))
}

/// Replaces NaN by 0 and clamps ±∞ to ±`f32::MAX`, per component.
pub fn sanitize(v: DVec3) -> Vec3 {
    let f = |x: f64| -> f32 {
        if x.is_nan() {
            0.0
        } else {
            x.clamp(-(f32::MAX as f64), f32::MAX as f64) as f32
        }
    };
    Vec3::new(f(v.x), f(v.y), f(v.z))
}

/// Per-ray constants of the watertight test.
struct WatertightRay {
    org: Vec3A,
    kx: usize,
    ky: usize,
    kz: usize,
    sx: f32,
    sy: f32,
    sz: f32,
}

impl WatertightRay {
    fn new(org: Vec3A, dir: Vec3A) -> Self {
        let a = dir.abs();
        let kz = if a.x > a.y {
            if a.x > a.z { 0 } else { 2 }
        } else if a.y > a.z {
            1
        } else {
            2
        };
        let mut kx = (kz + 1) % 3;
        let mut ky = (kx + 1) % 3;
        if dir[kz] < 0.0 {
            std::mem::swap(&mut kx, &mut ky);
        }
        WatertightRay {
            org,
            kx,
            ky,
            kz,
            sx: dir[kx] / dir[kz],
            sy: dir[ky] / dir[kz],
            sz: 1.0 / dir[kz],
        }
    }

    /// Two-sided watertight intersection; `Some((t, barycentrics))` with
    /// `t_min < t < t_max` (strict).
    fn intersect(&self, v: &[Vec3A; 3], t_min: f32, t_max: f32) -> Option<(f32, Vec3)> {
        let (kx, ky, kz) = (self.kx, self.ky, self.kz);
        let a = v[0] - self.org;
        let b = v[1] - self.org;
        let c = v[2] - self.org;
        let ax = a[kx] - self.sx * a[kz];
        let ay = a[ky] - self.sy * a[kz];
        let bx = b[kx] - self.sx * b[kz];
        let by = b[ky] - self.sy * b[kz];
        let cx = c[kx] - self.sx * c[kz];
        let cy = c[ky] - self.sy * c[kz];
        let mut u = cx * by - cy * bx;
        let mut vv = ax * cy - ay * cx;
        let mut w = bx * ay - by * ax;
        if u == 0.0 || vv == 0.0 || w == 0.0 {
            u = (cx as f64 * by as f64 - cy as f64 * bx as f64) as f32;
            vv = (ax as f64 * cy as f64 - ay as f64 * cx as f64) as f32;
            w = (bx as f64 * ay as f64 - by as f64 * ax as f64) as f32;
        }
        if (u < 0.0 || vv < 0.0 || w < 0.0) && (u > 0.0 || vv > 0.0 || w > 0.0) {
            return None;
        }
        let det = u + vv + w;
        if det == 0.0 || !det.is_finite() {
            return None;
        }
        let az = self.sz * a[kz];
        let bz = self.sz * b[kz];
        let cz = self.sz * c[kz];
        let t_scaled = u * az + vv * bz + w * cz;
        let rcp = 1.0 / det;
        let t = t_scaled * rcp;
        if !(t > t_min && t < t_max) {
            return None;
        }
        Some((t, Vec3::new(u * rcp, vv * rcp, w * rcp)))
    }
}

impl<'s> RayScene<'s> {
    /// Builds the BVH over every triangle of `scene` at `time` seconds
    /// ([`Scene::meshes_at`]): static meshes as stored, dynamic meshes moved by
    /// their world matrix (normals by its inverse transpose).
    ///
    /// Never panics on bad data: triangles with an index out of range, a
    /// non-finite vertex or zero area are skipped; a mesh whose material index
    /// is out of range gets albedo 0 (`gibake_reference::render` reports both
    /// as errors before building).
    pub fn build(scene: &'s Scene, time: f32) -> RayScene<'s> {
        let meshes = scene.meshes_at(time);
        // World-space triangles first, to find the scale.
        struct Raw {
            p: [Vec3; 3],
            n: [Vec3; 3],
            uv: Option<[Vec2; 3]>,
            material: u32,
            id: u32,
            mesh: u32,
        }
        let mut raw = Vec::new();
        let mut max_abs = 0.0f32;
        let mut tri_id = 0u32;
        for (mesh_index, (mesh, world)) in meshes.iter().enumerate() {
            let is_identity = *world == glam::Mat4::IDENTITY;
            let normal_matrix = Mat3::from_mat4(*world).inverse().transpose();
            let material = if mesh.material < scene.materials.len() {
                mesh.material as u32
            } else {
                u32::MAX
            };
            for tri in mesh.indices.chunks_exact(3) {
                let id = tri_id;
                tri_id = tri_id.wrapping_add(1);
                let idx = [tri[0] as usize, tri[1] as usize, tri[2] as usize];
                if idx.iter().any(|&i| i >= mesh.positions.len()) {
                    continue;
                }
                let p = idx.map(|i| {
                    if is_identity {
                        mesh.positions[i]
                    } else {
                        world.transform_point3(mesh.positions[i])
                    }
                });
                if !p.iter().all(|q| q.is_finite()) {
                    continue;
                }
                let n = idx.map(|i| {
                    let n = mesh.normals.get(i).copied().unwrap_or(Vec3::ZERO);
                    if is_identity { n } else { normal_matrix * n }
                });
                let uv = mesh.uvs.as_ref().and_then(|uvs| {
                    if idx.iter().all(|&i| i < uvs.len()) {
                        Some(idx.map(|i| uvs[i]))
                    } else {
                        None
                    }
                });
                for q in &p {
                    max_abs = max_abs.max(q.abs().max_element());
                }
                raw.push(Raw {
                    p,
                    n,
                    uv,
                    material,
                    id,
                    mesh: mesh_index as u32,
                });
            }
        }
        // k = 2^-e with max_abs·k in [0.5, 1).
        let scale = if max_abs > 0.0 && max_abs.is_finite() {
            let e = max_abs.log2().floor() as i32 + 1;
            pow2(-e.clamp(-120, 120))
        } else {
            1.0
        };
        let inv_scale = 1.0 / scale;

        let mut tris = Vec::with_capacity(raw.len());
        for r in &raw {
            let v = r.p.map(|q| Vec3A::from(q * scale));
            let cross = (v[1] - v[0]).cross(v[2] - v[0]);
            let len = cross.length();
            if !(len > 0.0 && len.is_finite()) {
                continue;
            }
            let ng = Vec3::from(cross / len);
            if !ng.is_finite() {
                continue;
            }
            let n = r.n.map(|n| {
                let n = n.normalize_or_zero();
                if n == Vec3::ZERO { ng } else { n }
            });
            let masked = scene
                .materials
                .get(r.material as usize)
                .is_some_and(|m| m.cutoff().is_some());
            tris.push(Tri {
                v,
                ng,
                n,
                uv: r.uv,
                material: r.material,
                id: r.id,
                mesh: r.mesh,
                masked,
            });
        }

        let bvh = if tris.is_empty() {
            None
        } else {
            let obv: Vec<Triangle> = tris
                .iter()
                .map(|t| Triangle {
                    v0: t.v[0],
                    v1: t.v[1],
                    v2: t.v[2],
                })
                .collect();
            let bvh = build_cwbvh_from_tris(
                &obv,
                BvhBuildParams::medium_build(),
                &mut std::time::Duration::default(),
            );
            // Reorder the triangles into leaf order so the traversal's id indexes them directly.
            tris = bvh
                .primitive_indices
                .iter()
                .map(|&i| tris[i as usize])
                .collect();
            Some(bvh)
        };
        RayScene {
            scene,
            bvh,
            tris,
            scale,
            inv_scale,
        }
    }

    /// The scene this was built from.
    pub fn scene(&self) -> &'s Scene {
        self.scene
    }

    /// Number of triangles in the BVH (zero-area and invalid ones excluded).
    pub fn triangle_count(&self) -> usize {
        match &self.bvh {
            Some(b) => {
                let mut ids: Vec<u32> = b.primitive_indices.clone();
                ids.sort_unstable();
                ids.dedup();
                ids.len()
            }
            None => 0,
        }
    }

    /// Moves a world-space point `p` off its surface along `n` (which need
    /// not be unit; zero means "no offset") by a few float ULPs, scale-invariantly.
    pub fn offset_point(&self, p: Vec3, n: Vec3) -> Vec3 {
        offset_ray_scaled(p * self.scale, n) * self.inv_scale
    }

    /// Closest hit along `origin + t·dir` with `t_min < t < t_max` (all in world
    /// units of `dir`'s length), in scaled space; `(tri index, t_scaled, bary)`.
    fn closest_scaled(
        &self,
        origin: Vec3,
        dir: Vec3,
        t_min: f32,
        t_max: f32,
    ) -> Option<(usize, f32, Vec3)> {
        let bvh = self.bvh.as_ref()?;
        if !(dir.is_finite() && origin.is_finite())
            || dir == Vec3::ZERO
            || t_max.is_nan()
            || t_min.is_nan()
        {
            return None;
        }
        let o = Vec3A::from(origin * self.scale);
        // Zero components, of either sign, are handled by `bvh_direction`.
        let d = Vec3A::from(dir);
        let t_min = t_min.max(0.0) * self.scale;
        let t_max = t_max * self.scale;
        if t_max.is_nan() || t_max <= t_min {
            return None;
        }
        let wt = WatertightRay::new(o, d);
        let (ray, back) = pulled_back(o, d, t_min, t_max);
        let mut best: Option<(usize, f32, Vec3)> = None;
        let mut hit = obvhs::ray::RayHit::none();
        bvh.ray_traverse(ray, &mut hit, |r, id| {
            match wt.intersect(&self.tris[id].v, t_min, r.tmax - back) {
                Some((t, b)) if self.alpha_keeps(id, b) => {
                    best = Some((id, t, b));
                    t + back
                }
                _ => f32::INFINITY,
            }
        });
        best
    }

    /// The any-hit alpha test: whether triangle `id` (leaf order) exists at
    /// barycentrics `b` ([`Scene::alpha_keeps`] at the interpolated texture
    /// coordinate). Always true for opaque materials. Every query (closest
    /// hit, occlusion, visibility) passes through holes the test cuts.
    fn alpha_keeps(&self, id: usize, b: Vec3) -> bool {
        let tri = &self.tris[id];
        if !tri.masked {
            return true;
        }
        let uv = tri.uv.map(|uv| uv[0] * b.x + uv[1] * b.y + uv[2] * b.z);
        self.scene.alpha_keeps(tri.material as usize, uv)
    }

    /// Closest hit in `(0, t_max)` along `origin + t·dir` (world space; `dir`
    /// need not be unit, `t` is in its units). `origin` should already be
    /// offset off any surface it lies on ([`RayScene::offset_point`]).
    pub fn intersect(&self, origin: Vec3, dir: Vec3, t_max: f32) -> Option<Hit> {
        self.intersect_range(origin, dir, 0.0, t_max)
    }

    /// Closest hit with `t_min < t < t_max` (camera rays start at the near plane).
    pub fn intersect_range(&self, origin: Vec3, dir: Vec3, t_min: f32, t_max: f32) -> Option<Hit> {
        let (i, t_scaled, b) = self.closest_scaled(origin, dir, t_min, t_max)?;
        let tri = &self.tris[i];
        let p_scaled = Vec3::from(tri.v[0] * b.x + tri.v[1] * b.y + tri.v[2] * b.z);
        let mut ng = tri.ng;
        let mut ns = (tri.n[0] * b.x + tri.n[1] * b.y + tri.n[2] * b.z).normalize_or_zero();
        if ns == Vec3::ZERO || !ns.is_finite() {
            ns = ng;
        }
        if ng.dot(-dir) < 0.0 {
            ng = -ng;
        }
        // The shading normal on the geometric normal's side: a mesh wound
        // clockwise or under a mirroring transform (its winding normal and
        // vertex normals disagree) shades like the original, as the
        // runtime's G-buffer does.
        if ns.dot(ng) < 0.0 {
            ns = -ns;
        }
        let uv = tri.uv.map(|uv| uv[0] * b.x + uv[1] * b.y + uv[2] * b.z);
        let albedo = if tri.material == u32::MAX {
            Vec3::ZERO
        } else {
            let a = self.scene.albedo(tri.material as usize, uv);
            if a.is_finite() {
                a.max(Vec3::ZERO)
            } else {
                Vec3::ZERO
            }
        };
        Some(Hit {
            t: t_scaled * self.inv_scale,
            position: p_scaled * self.inv_scale,
            geometric_normal: ng,
            shading_normal: ns,
            albedo,
            uv,
            barycentrics: b,
            triangle: tri.id,
            mesh: tri.mesh,
        })
    }

    /// True if any surface lies along `origin + t·dir` for `0 < t < t_max`.
    pub fn occluded(&self, origin: Vec3, dir: Vec3, t_max: f32) -> bool {
        let Some(bvh) = self.bvh.as_ref() else {
            return false;
        };
        if !(dir.is_finite() && origin.is_finite()) || dir == Vec3::ZERO || t_max.is_nan() {
            return false;
        }
        let o = Vec3A::from(origin * self.scale);
        // Zero components, of either sign, are handled by `bvh_direction`.
        let d = Vec3A::from(dir);
        let t_max = t_max * self.scale;
        if t_max.is_nan() || t_max <= 0.0 {
            return false;
        }
        let wt = WatertightRay::new(o, d);
        let (ray, back) = pulled_back(o, d, 0.0, t_max);
        !bvh.ray_traverse_miss(ray, |r, id| {
            match wt.intersect(&self.tris[id].v, 0.0, r.tmax - back) {
                Some((t, b)) if self.alpha_keeps(id, b) => t + back,
                _ => f32::INFINITY,
            }
        })
    }

    /// Robust visibility between two surface points: each end is offset off
    /// its surface along its normal, on the side facing the other point (a
    /// zero normal means a point in free space, e.g. a light), then the open
    /// segment between the offset points is tested.
    pub fn visible(&self, a: Vec3, a_normal: Vec3, b: Vec3, b_normal: Vec3) -> bool {
        let d = b - a;
        let na = if a_normal.dot(d) < 0.0 {
            -a_normal
        } else {
            a_normal
        };
        let nb = if b_normal.dot(-d) < 0.0 {
            -b_normal
        } else {
            b_normal
        };
        let a2 = self.offset_point(a, na);
        let b2 = self.offset_point(b, nb);
        let seg = b2 - a2;
        let len = seg.length();
        if !(len > 0.0 && len.is_finite()) {
            return true;
        }
        !self.occluded(a2, seg / len, len)
    }

    /// How far short of `target` a shadow ray toward it stops: about 512
    /// ULPs of the target's (scaled) coordinates, at least `2⁻¹⁹` of the
    /// scene scale, so a light lying on a surface is not shadowed by that
    /// surface. Scale-invariant like every other offset here.
    pub fn end_margin(&self, target: Vec3) -> f32 {
        let lp = (target * self.scale).abs().max_element().max(1.0 / 32.0);
        lp * pow2(-14) * self.inv_scale
    }
}
