//! A tiny, fully specified random number generator (PCG32, O'Neill 2014)
//! and the sampling helpers the path tracer needs.
//!
//! The reference must be bit-identical run to run and independent of the
//! number of threads, so every pixel owns its own generator, seeded from
//! `(settings.seed, pixel index)` through SplitMix64. No global state.

use glam::Vec3;

/// SplitMix64 finaliser: a good 64-bit mixing function for seeding.
pub(crate) fn splitmix64(mut z: u64) -> u64 {
    z = z.wrapping_add(0x9E37_79B9_7F4A_7C15);
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^ (z >> 31)
}

/// PCG32 (XSH-RR output, 64-bit LCG state) with a selectable stream.
#[derive(Clone, Debug)]
pub(crate) struct Pcg32 {
    state: u64,
    inc: u64,
}

impl Pcg32 {
    const MULT: u64 = 6_364_136_223_846_793_005;

    /// `pcg32_srandom_r(initstate, initseq)`.
    pub(crate) fn new(init_state: u64, init_seq: u64) -> Self {
        let mut rng = Pcg32 {
            state: 0,
            inc: (init_seq << 1) | 1,
        };
        rng.next_u32();
        rng.state = rng.state.wrapping_add(init_state);
        rng.next_u32();
        rng
    }

    /// The generator of pixel `index` for a render seeded with `seed`.
    pub(crate) fn for_pixel(seed: u64, index: u64) -> Self {
        Pcg32::new(
            splitmix64(seed ^ splitmix64(index)),
            splitmix64(index.wrapping_add(seed.rotate_left(32))),
        )
    }

    /// Next 32 uniformly distributed bits.
    pub(crate) fn next_u32(&mut self) -> u32 {
        let old = self.state;
        self.state = old.wrapping_mul(Self::MULT).wrapping_add(self.inc);
        let xorshifted = (((old >> 18) ^ old) >> 27) as u32;
        let rot = (old >> 59) as u32;
        xorshifted.rotate_right(rot)
    }

    /// Uniform float in `[0, 1)` (24 random bits, never 1.0).
    pub(crate) fn next_f32(&mut self) -> f32 {
        (self.next_u32() >> 8) as f32 * (1.0 / 16_777_216.0)
    }
}

/// An orthonormal basis `(t, b)` completing unit vector `n` (Duff et al. 2017,
/// "Building an Orthonormal Basis, Revisited"): no degenerate direction.
pub(crate) fn orthonormal_basis(n: Vec3) -> (Vec3, Vec3) {
    let sign = 1.0f32.copysign(n.z);
    let a = -1.0 / (sign + n.z);
    let b = n.x * n.y * a;
    (
        Vec3::new(1.0 + sign * n.x * n.x * a, sign * b, -sign * n.x),
        Vec3::new(b, sign + n.y * n.y * a, -n.y),
    )
}

/// A cosine-distributed unit direction about unit vector `n` (pdf = cos θ / π)
/// from two uniform numbers in `[0, 1)`.
pub(crate) fn cosine_hemisphere(n: Vec3, u1: f32, u2: f32) -> Vec3 {
    let r = u1.sqrt();
    let phi = std::f32::consts::TAU * u2;
    let (s, c) = phi.sin_cos();
    let z = (1.0 - u1).max(0.0).sqrt();
    let (t, b) = orthonormal_basis(n);
    (t * (r * c) + b * (r * s) + n * z).normalize_or(n)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn pcg32_reference_sequence() {
        // Values of the PCG reference implementation (pcg32-demo, seed 42, stream 54).
        let mut r = Pcg32::new(42, 54);
        let expected = [
            0xa15c02b7u32,
            0x7b47f409,
            0xba1d3330,
            0x83d2f293,
            0xbfa4784b,
            0xcbed606e,
        ];
        for e in expected {
            assert_eq!(r.next_u32(), e);
        }
    }

    #[test]
    fn floats_in_unit_interval() {
        let mut r = Pcg32::for_pixel(7, 3);
        for _ in 0..10_000 {
            let x = r.next_f32();
            assert!((0.0..1.0).contains(&x));
        }
    }

    #[test]
    fn basis_is_orthonormal() {
        for n in [
            Vec3::Z,
            -Vec3::Z,
            Vec3::X,
            Vec3::new(1.0, 2.0, -3.0).normalize(),
            Vec3::new(0.0, 1e-8, -1.0).normalize(),
        ] {
            let (t, b) = orthonormal_basis(n);
            assert!((t.length() - 1.0).abs() < 1e-5 && (b.length() - 1.0).abs() < 1e-5);
            assert!(t.dot(n).abs() < 1e-5 && b.dot(n).abs() < 1e-5 && t.dot(b).abs() < 1e-5);
        }
    }

    #[test]
    fn cosine_sampling_mean_cosine() {
        // E[cos θ] under pdf cos θ/π over the hemisphere is 2/3.
        let n = Vec3::new(0.3, -0.5, 0.8).normalize();
        let mut r = Pcg32::new(1, 2);
        let k = 200_000;
        let mut s = 0.0f64;
        for _ in 0..k {
            let d = cosine_hemisphere(n, r.next_f32(), r.next_f32());
            assert!(d.dot(n) >= -1e-6);
            s += d.dot(n) as f64;
        }
        assert!((s / k as f64 - 2.0 / 3.0).abs() < 3e-3);
    }
}
