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
