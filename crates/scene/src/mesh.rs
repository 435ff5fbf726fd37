//! Mesh helpers: bounds, normal generation, texture sampling.

use glam::{Mat4, Vec2, Vec3};

use crate::Texture;

/// An axis-aligned bounding box. [`Aabb::EMPTY`] has `min > max`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Aabb {
    /// Minimum corner.
    pub min: Vec3,
    /// Maximum corner.
    pub max: Vec3,
}

impl Aabb {
    /// The empty box (identity of [`Aabb::union`]).
    pub const EMPTY: Aabb = Aabb {
        min: Vec3::splat(f32::INFINITY),
        max: Vec3::splat(f32::NEG_INFINITY),
    };

    /// True if no point was added.
    pub fn is_empty(&self) -> bool {
        self.min.x > self.max.x
    }

    /// Grows the box to hold `p`.
    pub fn grow(&mut self, p: Vec3) {
        self.min = self.min.min(p);
        self.max = self.max.max(p);
    }

    /// The smallest box holding both.
    pub fn union(&self, o: &Aabb) -> Aabb {
        Aabb {
            min: self.min.min(o.min),
            max: self.max.max(o.max),
        }
    }

    /// Whether the ray `origin + t·dir`, `t > 0`, meets the box (slab test;
    /// a ray starting inside meets it). False for an empty box.
    pub fn ray_hits(&self, origin: Vec3, dir: Vec3) -> bool {
        self.ray_entry(origin, dir).is_some()
    }

    /// The `t ≥ 0` at which the ray `origin + t·dir` enters the box (0 if it
    /// starts inside), or `None` if it misses it or the box is empty.
    pub fn ray_entry(&self, origin: Vec3, dir: Vec3) -> Option<f32> {
        if self.is_empty() {
            return None;
        }
        let (mut t0, mut t1) = (0.0f32, f32::INFINITY);
        for k in 0..3 {
            let inv = 1.0 / dir[k];
            let (mut a, mut b) = (
                (self.min[k] - origin[k]) * inv,
                (self.max[k] - origin[k]) * inv,
            );
            if a > b {
                std::mem::swap(&mut a, &mut b);
            }
            // NaN (0 · ∞ for a ray in the slab's plane) leaves the bound as is.
            if a > t0 {
                t0 = a;
            }
            if b < t1 {
                t1 = b;
            }
        }
        (t0 <= t1).then_some(t0)
    }

    /// Centre of the box.
    pub fn center(&self) -> Vec3 {
        (self.min + self.max) * 0.5
    }

    /// Length of the diagonal (0 for an empty box).
    pub fn diagonal(&self) -> f32 {
        if self.is_empty() {
            0.0
        } else {
            (self.max - self.min).length()
        }
    }

    /// The box of the 8 transformed corners.
    pub fn transformed(&self, m: Mat4) -> Aabb {
        let mut b = Aabb::EMPTY;
        if self.is_empty() {
            return b;
        }
        for i in 0..8 {
            let c = Vec3::new(
                if i & 1 == 0 { self.min.x } else { self.max.x },
                if i & 2 == 0 { self.min.y } else { self.max.y },
                if i & 4 == 0 { self.min.z } else { self.max.z },
            );
            b.grow(m.transform_point3(c));
        }
        b
    }
}

/// Largest `|e₁ × e₂| / max|e|²` (the sine of a triangle's smallest angle,
/// about) of a triangle counted as degenerate: its vertices coincide or are
/// collinear to within f32 rounding. Dimensionless, so the same triangles
/// are dropped at every scene scale.
pub const DEGENERATE_SINE: f64 = 1e-6;

/// Whether the triangle `a, b, c` has (numerically) zero area: coincident or
/// collinear vertices, or non-finite coordinates. Computed in f64.
pub fn is_degenerate(a: Vec3, b: Vec3, c: Vec3) -> bool {
    let (a, b, c) = (a.as_dvec3(), b.as_dvec3(), c.as_dvec3());
    let (e1, e2, e3) = (b - a, c - a, c - b);
    let cross = e1.cross(e2).length();
    let longest = e1
        .length_squared()
        .max(e2.length_squared())
        .max(e3.length_squared());
    !(cross.is_finite() && longest.is_finite()) || cross <= DEGENERATE_SINE * longest
}

/// Removes the degenerate triangles ([`is_degenerate`]) of an indexed
/// triangle list (indices must be in range); returns how many it removed.
/// GPU rasterizers interpolate a zero-area triangle's attributes with a
/// division by zero (NaN in a map), ray casters skip it: dropping it at
/// import keeps every pass in agreement.
pub fn drop_degenerate(positions: &[Vec3], indices: &mut Vec<u32>) -> usize {
    let before = indices.len() / 3;
    let mut kept = Vec::with_capacity(indices.len());
    for t in indices.chunks_exact(3) {
        let p = |k: usize| positions[t[k] as usize];
        if !is_degenerate(p(0), p(1), p(2)) {
            kept.extend_from_slice(t);
        }
    }
    *indices = kept;
    before - indices.len() / 3
}

/// Area-weighted vertex normals for an indexed triangle list. Vertices whose
/// adjacent triangles are all degenerate get the first non-degenerate face
/// normal of the mesh (or +Y if there is none), so the result is always unit
/// length and finite.
pub fn compute_normals(positions: &[Vec3], indices: &[u32]) -> Vec<Vec3> {
    let mut acc = vec![Vec3::ZERO; positions.len()];
    let mut fallback = None;
    for t in indices.chunks_exact(3) {
        let (a, b, c) = (t[0] as usize, t[1] as usize, t[2] as usize);
        // Cross product of edges = 2 × area × unit normal: area weighting for free.
        let n = (positions[b] - positions[a]).cross(positions[c] - positions[a]);
        if n.is_finite() && n.length_squared() > 0.0 {
            fallback.get_or_insert(n.normalize());
            acc[a] += n;
            acc[b] += n;
            acc[c] += n;
        }
    }
    let fallback = fallback.unwrap_or(Vec3::Y);
    acc.into_iter()
        .map(|n| n.try_normalize().unwrap_or(fallback))
        .collect()
}

fn srgb_to_linear(c: u8) -> f32 {
    let c = c as f32 / 255.0;
    if c <= 0.04045 {
        c / 12.92
    } else {
        ((c + 0.055) / 1.055).powf(2.4)
    }
}

/// Bilinear sample (repeat wrap, texel centres at half-integers, sRGB decoded
/// before filtering) — the same filter as a `Rgba8UnormSrgb` GPU texture with
/// a linear, repeating sampler and no mipmaps.
pub fn sample_bilinear_srgb(t: &Texture, uv: Vec2) -> Vec3 {
    sample_bilinear(t, uv, Vec3::ONE, |p| {
        Vec3::new(
            srgb_to_linear(p[0]),
            srgb_to_linear(p[1]),
            srgb_to_linear(p[2]),
        )
    })
}

/// Bilinear sample of the alpha channel (linear in an sRGB texture), with
/// the filter of [`sample_bilinear_srgb`].
pub fn sample_bilinear_alpha(t: &Texture, uv: Vec2) -> f32 {
    sample_bilinear(t, uv, 1.0, |p| p[3] as f32 / 255.0)
}

/// The bilinear filter shared by the samplers above: `texel` decodes one
/// RGBA8 texel; `fallback` is returned for an empty texture or a
/// non-finite coordinate.
fn sample_bilinear<T>(t: &Texture, uv: Vec2, fallback: T, texel: impl Fn(&[u8]) -> T) -> T
where
    T: Copy
        + std::ops::Mul<f32, Output = T>
        + std::ops::Add<Output = T>
        + std::ops::Sub<Output = T>,
{
    let (w, h) = (t.width as i64, t.height as i64);
    if w == 0 || h == 0 || t.rgba8_srgb.len() < (w * h * 4) as usize {
        return fallback;
    }
    let x = uv.x * t.width as f32 - 0.5;
    let y = uv.y * t.height as f32 - 0.5;
    if !x.is_finite() || !y.is_finite() {
        return fallback;
    }
    let (x0, y0) = (x.floor(), y.floor());
    let (fx, fy) = (x - x0, y - y0);
    let at = |xi: i64, yi: i64| {
        let xi = xi.rem_euclid(w) as usize;
        let yi = yi.rem_euclid(h) as usize;
        let o = (yi * t.width as usize + xi) * 4;
        texel(&t.rgba8_srgb[o..o + 4])
    };
    // glam's `lerp`, operation for operation: a + (b − a)·f.
    let lerp = |a: T, b: T, f: f32| a + (b - a) * f;
    let (xi, yi) = (x0 as i64, y0 as i64);
    let top = lerp(at(xi, yi), at(xi + 1, yi), fx);
    let bot = lerp(at(xi, yi + 1), at(xi + 1, yi + 1), fx);
    lerp(top, bot, fy)
}
