//! Where reflected light can go: the part of a surface point's hemisphere
//! that sees the static geometry or the moving objects' swept bounds.
//!
//! Light a surface reflects into the sky reaches nothing. On a level lit
//! from outside — a sun over an arena with roof openings, a town — most of
//! the primary light's flux lands on roofs and open ground whose
//! hemisphere is mostly sky, while the light that matters bounces off a
//! small sunlit patch inside. Two measurements steer the VPL budget there:
//!
//! - [`texel_reach`](Reach::texel_reach): per RSM texel, the fraction of `RAYS_PER_TEXEL`
//!   cosine-distributed rays about its normal that hit something. The
//!   clustering spends its budget by each node's *reaching* flux
//!   `Σ flux · reach` instead of its flux (cluster.rs, "VPLs where the light
//!   goes").
//! - [`sees_anything`](Reach::sees_anything): whether a VPL's hemisphere, probed with the map
//!   projection at `PROBE_SIZE²` directions from its map origin, sees any
//!   static surface or the moving objects' swept bounds. A VPL that sees
//!   nothing carries light to nothing and is dropped before its map, its
//!   near-field tree and its runtime cost exist.
//!
//! Together they are [`Reach::keeps`], the bake's rule for which VPLs it
//! keeps, and a `--vpls N` budget counts exactly the VPLs it keeps
//! ([`crate::cluster::Keep`]; cluster.rs, "Budget").
//!
//! **Aimed rays.** Uniform directions miss what subtends less than one of
//! them: from far ground beyond a sun's view (a light's outer rings,
//! crates/bake/src/rings.rs) the level's objects are a few metres tall
//! 30–50 m away, under 4° above the horizon, and both the texels' four
//! rays each and the origin's 256 directions missed them. On the Blenvy
//! level 31 VPLs were dropped that way, all of them ring VPLs of the sun,
//! and their light is 0.5% of what the camera's receivers get (`lights_twin
//! data/lights/blenvy_start_level/StartLevel.glb --size 48 --split`,
//! "texels of kept VPLs / all" −0.5% → +0.0%). So a VPL the uniform probe
//! finds blind is asked once more with rays aimed at every static mesh's
//! bounds in front of its plane (each box's centre and its eight corners
//! pulled half-way in, [`aim_targets`]; at most [`MAX_AIMED_MESHES`]
//! meshes, the largest) and at the moving objects' swept box: a VPL is
//! dropped only if none of them meets anything. A VPL that truly faces
//! nothing (an outer wall over empty space: the rooms level's 260, the
//! living room's 51) has no box in front of it, or none it sees, and is
//! dropped as before.
//!
//! All are deterministic (fixed directions per texel from a hash of its
//! index; targets in mesh order) and scale-invariant (directions and box
//! points move with the scene; ray offsets are the ray caster's, relative
//! to the scene's size).

use gibake_gpu::hemisphere;
use gibake_raycast::RayScene;
use gibake_scene::Aabb;
use glam::Vec3;

/// Rays per RSM texel for [`texel_reach`](Reach::texel_reach) (2 × 2 strata).
pub const RAYS_PER_TEXEL: u32 = 4;

/// Directions per axis of a VPL's [`sees_anything`](Reach::sees_anything) probe (the hemisphere
/// map's projection at this size: 256 directions, texel centres).
pub const PROBE_SIZE: u32 = 16;

/// At most this many static meshes (the largest by their bounds'
/// diagonal) get aimed rays in [`Reach::sees_anything`]: nine rays each,
/// so a blind VPL costs at most 4617 more rays however many meshes a level
/// has.
pub const MAX_AIMED_MESHES: usize = 512;

/// What reflected light can reach: the static geometry (through `rays`) and
/// the moving objects' swept bounds (empty box: none). Made by
/// [`Reach::new`], which derives the aimed rays' targets from both: change
/// neither afterwards.
pub struct Reach<'a, 's> {
    /// The static geometry.
    pub rays: &'a RayScene<'s>,
    /// Where moving objects can be over the animation.
    pub moving: Aabb,
    /// Points [`Reach::sees_anything`] aims at ([`aim_targets`]).
    targets: Vec<Vec3>,
}

/// The points a blind VPL's aimed rays go to: for each static mesh of
/// `rays`' scene (at most [`MAX_AIMED_MESHES`], the largest by their
/// bounds' diagonal, ties in mesh order) and for the moving objects' swept
/// box `moving` (if not empty), the box's centre and its eight corners
/// pulled half-way to it. Meshes with no finite vertex give none.
pub fn aim_targets(rays: &RayScene<'_>, moving: Aabb) -> Vec<Vec3> {
    let mut boxes: Vec<Aabb> = rays
        .scene()
        .static_meshes
        .iter()
        .map(|m| {
            let mut b = Aabb::EMPTY;
            for p in m.positions.iter().filter(|p| p.is_finite()) {
                b.grow(*p);
            }
            b
        })
        .filter(|b| !b.is_empty())
        .collect();
    if boxes.len() > MAX_AIMED_MESHES {
        // Stable: equal diagonals keep mesh order.
        boxes.sort_by(|a, b| b.diagonal().total_cmp(&a.diagonal()));
        boxes.truncate(MAX_AIMED_MESHES);
    }
    if !moving.is_empty() && moving.min.is_finite() && moving.max.is_finite() {
        boxes.push(moving);
    }
    let mut out = Vec::with_capacity(boxes.len() * 9);
    for b in &boxes {
        let c = b.center();
        out.push(c);
        for k in 0..8u32 {
            let corner = Vec3::new(
                if k & 1 == 0 { b.min.x } else { b.max.x },
                if k & 2 == 0 { b.min.y } else { b.max.y },
                if k & 4 == 0 { b.min.z } else { b.max.z },
            );
            out.push((c + corner) * 0.5);
        }
    }
    out
}

/// SplitMix64 finaliser (seeds the per-texel jitter).
pub(crate) fn mix(mut z: u64) -> u64 {
    z = z.wrapping_add(0x9E37_79B9_7F4A_7C15);
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^ (z >> 31)
}

/// An orthonormal basis `(t, b)` completing unit `n` (Duff et al. 2017).
fn basis(n: Vec3) -> (Vec3, Vec3) {
    let sign = 1.0f32.copysign(n.z);
    let a = -1.0 / (sign + n.z);
    let b = n.x * n.y * a;
    (
        Vec3::new(1.0 + sign * n.x * n.x * a, sign * b, -sign * n.x),
        Vec3::new(b, sign + n.y * n.y * a, -n.y),
    )
}

/// Cosine-distributed direction about `n` for `(u1, u2) ∈ [0, 1)²`
/// (Malley: a uniform disk sample lifted to the hemisphere).
pub(crate) fn cosine_direction(n: Vec3, u1: f32, u2: f32) -> Vec3 {
    let r = u1.sqrt();
    let phi = std::f32::consts::TAU * u2;
    let (t, b) = basis(n);
    let z = (1.0 - u1).max(0.0).sqrt();
    (t * (r * phi.cos()) + b * (r * phi.sin()) + n * z).normalize_or_zero()
}

impl<'a, 's> Reach<'a, 's> {
    /// What reflected light can reach in `rays`' scene, with the moving
    /// objects' swept bounds `moving` (empty: none); computes the aimed
    /// rays' targets ([`aim_targets`]) once.
    pub fn new(rays: &'a RayScene<'s>, moving: Aabb) -> Self {
        let targets = aim_targets(rays, moving);
        Reach {
            rays,
            moving,
            targets,
        }
    }

    /// Whether the ray from `origin` (already offset off its surface) along
    /// `dir` meets the static geometry or the swept bounds.
    fn hits(&self, origin: Vec3, dir: Vec3) -> bool {
        self.moving.ray_hits(origin, dir) || self.rays.occluded(origin, dir, f32::INFINITY)
    }

    /// The fraction of texel `index`'s reflected light that reaches
    /// something: `RAYS_PER_TEXEL` stratified cosine-distributed rays about
    /// the geometric normal `ng` (facing the light: the normal the texel
    /// emits about, [`crate::rsm::Rsm::normal`]) from `p`, offset along it.
    pub fn texel_reach(&self, index: u64, p: Vec3, ng: Vec3) -> f32 {
        let origin = self.rays.offset_point(p, ng);
        let h = mix(index);
        let (j1, j2) = (
            (h >> 40) as f32 * (1.0 / 16_777_216.0),
            ((h >> 16) & 0xff_ffff) as f32 * (1.0 / 16_777_216.0),
        );
        let mut hit = 0u32;
        for k in 0..RAYS_PER_TEXEL {
            let (sx, sy) = ((k % 2) as f32, (k / 2) as f32);
            let d = cosine_direction(ng, (sx + j1) * 0.5, (sy + j2) * 0.5);
            if d.dot(ng) > 0.0 && self.hits(origin, d) {
                hit += 1;
            }
        }
        hit as f32 / RAYS_PER_TEXEL as f32
    }

    /// Whether the VPL of cluster `c` sees anything: [`Reach::sees_anything`]
    /// from its map origin ([`hemisphere::vpl_origin`] of its anchor).
    /// `ring`: the cluster lies on an outer ring, its origin one texel's
    /// radius off its surface ([`gibake_asset::VplRecord::map_origin_area`]).
    pub fn sees_cluster(&self, c: &crate::cluster::Cluster, ring: bool) -> bool {
        let origin = hemisphere::record_origin(&c.record(), ring);
        self.sees_anything(origin, c.normal)
    }

    /// Whether the bakes keep the VPL of cluster `c`, whose texels'
    /// reaching flux is `reaching` ([`crate::cluster::Clustering::reaching_flux`]):
    /// a VPL that sees nothing carries light to nothing and is dropped,
    /// but "nothing" must hold for its texels' rays too. The origin's probe
    /// ([`PROBE_SIZE`]² directions) misses what subtends less than one of
    /// its directions — an object 20 diameters away over open ground — and
    /// the texels of VPLs it dropped carried 1.9% of the light the Blenvy
    /// sun's texels send to the camera's receivers (3.2% of a lamp's at 166
    /// VPLs: `lights_twin … --split`); every texel's own
    /// [`RAYS_PER_TEXEL`] rays ([`texel_reach`](Self::texel_reach)) are
    /// thousands per VPL, from the surface itself.
    pub fn keeps(&self, c: &crate::cluster::Cluster, reaching: f64, ring: bool) -> bool {
        reaching > 0.0 || self.sees_cluster(c, ring)
    }

    /// Drops the VPLs of `clusters` that [`Reach::keeps`] does not keep
    /// (`reaching`: each one's reaching flux, `ring`: they lie on an outer
    /// ring) and returns how many. A `Count` budget counted exactly the
    /// kept ones ([`crate::cluster::Keep`]).
    pub fn retain(
        &self,
        clusters: &mut crate::cluster::Clustering,
        reaching: &[f64],
        ring: bool,
    ) -> usize {
        clusters.retain(|i, c| self.keeps(c, reaching[i], ring))
    }

    /// Whether a VPL at `origin` (its map origin, off its surface) with
    /// normal `n` sees anything in its hemisphere (see the module docs).
    pub fn sees_anything(&self, origin: Vec3, n: Vec3) -> bool {
        let origin = self.rays.offset_point(origin, n);
        (0..PROBE_SIZE * PROBE_SIZE).any(|k| {
            let d = hemisphere::texel_direction(n, k % PROBE_SIZE, k / PROBE_SIZE, PROBE_SIZE);
            self.hits(origin, d)
        }) || self.targets.iter().any(|&t| {
            // Aimed rays (module docs): only at points in front of the
            // VPL's plane, its hemisphere.
            let d = t - origin;
            let l = d.length();
            d.dot(n) > 0.0 && l > 0.0 && l.is_finite() && self.hits(origin, d / l)
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn cosine_directions_are_unit_and_above() {
        for n in [Vec3::Y, Vec3::NEG_Z, Vec3::new(0.3, -0.5, 0.8).normalize()] {
            for i in 0..64 {
                let d = cosine_direction(n, (i % 8) as f32 / 8.0, (i / 8) as f32 / 8.0);
                assert!((d.length() - 1.0).abs() < 1e-5);
                assert!(d.dot(n) >= -1e-6, "{d} below {n}");
            }
        }
    }
}
