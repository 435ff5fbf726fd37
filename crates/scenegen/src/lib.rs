//! Generator of gibake's bundled glTF scenes (`data/*.glb`).
//!
//! Four scenes, each a function from [`Params`] to GLB bytes. Three with one
//! primary light, listed by [`all`]:
//! - [`corner_bunny`]: the paper's experiment — a floor and two walls forming a
//!   corner, the Stanford bunny, 13 small balls circling it, one spot light.
//! - [`occluded`]: the paper's Fig. 10 situation — brightly coloured panels lit
//!   by the spot light but hidden from the visible receivers by a tall wall,
//!   so VPLs without visibility leak their colour.
//! - [`sun`]: a directional light over a ground plane, static blocks, three
//!   moving objects.
//!
//! And one with several primary lights, kept out of [`all`] (the bake and
//! the runtime take one light so far, and the tests that bake or judge
//! every scene of [`all`] import with the default, one-light options),
//! listed by [`multi_light`]:
//! - [`lamps`]: a room lit by a ceiling spot with a glTF `range` and two
//!   point lamps (one with a range), static blocks, three moving balls.
//!
//! And [`skylight_gallery`], a level built to break the VPL budget of
//! method revisions before 6, made in memory for the tests (not bundled).
//!
//! Seeded random scenes: [`random()`] (one spot or directional light) and
//! [`random_lights()`] (1–8 lights of all three kinds, interiors and
//! exteriors).
//!
//! Units are metres, Y is up; lights and cameras look down their node's −Z
//! (glTF conventions; point lights' nodes have no rotation). Moving objects are nodes targeted by one LINEAR
//! translation animation that loops every [`LOOP_SECONDS`] seconds, and are
//! also marked `extras: {"dynamic": true}`. All output is deterministic: the
//! same parameters give the same bytes.
//!
//! The binary `gibake-scenegen [OUT_DIR]` writes the default variants
//! (`Params::default()`) to `OUT_DIR` (default `data/`).

mod corner_bunny;
mod gallery;
pub mod geom;
pub mod gltf;
pub mod inspect;
mod lamps;
mod occluded;
pub mod random;
pub mod random_lights;
mod sun;

pub use random::{RandomInfo, random};
pub use random_lights::{LightInfo, RandomLightsInfo, random_lights};

/// Period of every bundled scene's animation loop, in seconds.
pub const LOOP_SECONDS: f64 = 4.0;

/// Parameters of a generated scene variant.
///
/// # Scale
/// `scale` multiplies every length in the scene by `s`: vertex positions,
/// node translations (meshes, lights, cameras), animation translation keys,
/// camera `znear`/`zfar` and orthographic `xmag`/`ymag`. Angles, directions,
/// rotations, colours, albedos and animation times are unchanged.
///
/// The image is kept identical too: a spot or point light's `intensity` is
/// radiant intensity `I` in W/sr, and the irradiance it gives is
/// `E = I·cos θ / d²`; scaling every distance `d` by `s` would divide `E` by
/// `s²`, so the intensity is multiplied by `s²`, and a light's glTF `range`
/// (a distance) by `s`. A directional light's intensity is an
/// irradiance (W/m²), independent of distance, and stays as it is. Since
/// radiance reflected by a Lambertian surface depends only on irradiance and
/// albedo, and one-bounce transport between surfaces (`cos·cos·dA/d²`) is
/// invariant under uniform scaling, every pixel of the scaled scene seen from
/// the scaled camera has the same radiance.
///
/// # Heavy
/// `heavy = N` makes the static part about `N×` (at least `N×`) as many
/// triangles without changing the image beyond rounding: planar static
/// surfaces (walls, floors, boxes, panels) are split into grids of small
/// coplanar triangles, and the bunny's triangles are split at their edge
/// midpoints (flat, so the surface is unchanged). Dynamic objects are not
/// touched. `heavy = 0` is treated as 1.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Params {
    /// Uniform scale of the whole scene (1 = metres as designed). Must be
    /// finite and positive.
    pub scale: f32,
    /// Static-detail multiplier (1 = the bundled scenes).
    pub heavy: u32,
}

impl Default for Params {
    fn default() -> Self {
        Params {
            scale: 1.0,
            heavy: 1,
        }
    }
}

impl Params {
    /// The scale as `f64`, checked.
    ///
    /// # Panics
    /// If `scale` is not finite and positive.
    fn s(&self) -> f64 {
        assert!(
            self.scale.is_finite() && self.scale > 0.0,
            "scene scale must be finite and positive, got {}",
            self.scale
        );
        f64::from(self.scale)
    }

    /// `heavy`, at least 1.
    fn heavy(&self) -> u32 {
        self.heavy.max(1)
    }
}

/// A scene generator: parameters to GLB bytes.
pub type SceneFn = fn(&Params) -> Vec<u8>;

/// The paper's experiment: a corner of three walls, the Stanford bunny, 13
/// moving balls, a spot light from the front above. See `data/README.md`.
///
/// # Panics
/// If `p.scale` is not finite and positive (as every scene function).
pub fn corner_bunny(p: &Params) -> Vec<u8> {
    corner_bunny::build(p)
}

/// The paper's Fig. 10 situation: coloured panels lit by a spot light but
/// hidden from the visible floor by a tall wall, one visible coloured panel,
/// two moving balls.
pub fn occluded(p: &Params) -> Vec<u8> {
    occluded::build(p)
}

/// A directional (sun) light over a ground plane with static blocks, a
/// sliding box and two bouncing balls.
pub fn sun(p: &Params) -> Vec<u8> {
    sun::build(p)
}

/// A room lit by three lamps: a ceiling spot (glTF `range` 6 m), a hanging
/// point lamp (no range) and a low point lamp (range 2.5 m); four static
/// blocks, three balls on LINEAR loops; all three lamps are primary lights.
pub fn lamps(p: &Params) -> Vec<u8> {
    lamps::build(p)
}

/// A level built to break a VPL budget, not bundled: a hall whose roof has
/// an opening, on a wide ground (outer rings), a sun through the opening,
/// two moving balls (issue 49; `crates/scenegen/src/gallery.rs`).
pub fn skylight_gallery(p: &Params) -> Vec<u8> {
    gallery::build(p)
}

/// Every bundled scene with exactly one primary light (a spot or a
/// directional light): its name (the file is `data/NAME.glb`) and generator.
/// The scenes with several lights are in [`multi_light`].
pub fn all() -> Vec<(&'static str, SceneFn)> {
    vec![
        ("corner_bunny", corner_bunny as SceneFn),
        ("occluded", occluded as SceneFn),
        ("sun", sun as SceneFn),
    ]
}

/// The bundled scenes with several primary lights (point lights among
/// them), also written to `data/NAME.glb`; kept out of [`all`] until the
/// bake and the runtime take every light.
pub fn multi_light() -> Vec<(&'static str, SceneFn)> {
    vec![("lamps", lamps as SceneFn)]
}

/// The generator of the bundled scene called `name` (in [`all`] or
/// [`multi_light`]), if there is one.
pub fn by_name(name: &str) -> Option<SceneFn> {
    all()
        .into_iter()
        .chain(multi_light())
        .find(|(n, _)| *n == name)
        .map(|(_, f)| f)
}

/// The bundled scene `name` uniformly scaled by `scale` (see [`Params`]),
/// or `None` if there is no such scene.
pub fn scaled(name: &str, scale: f32) -> Option<Vec<u8>> {
    by_name(name).map(|f| {
        f(&Params {
            scale,
            ..Params::default()
        })
    })
}

/// Keys `0, Δt, …, LOOP_SECONDS` of a loop sampled `n` times (`n + 1` keys,
/// the last equal in position to the first).
fn loop_times(n: u32) -> Vec<f64> {
    (0..=n)
        .map(|i| LOOP_SECONDS * f64::from(i) / f64::from(n))
        .collect()
}

/// The smallest `k ≥ 1` with `k² ≥ x`.
fn ceil_sqrt(x: u64) -> u32 {
    let mut k = (x as f64).sqrt() as u64;
    while k * k < x {
        k += 1;
    }
    while k > 1 && (k - 1) * (k - 1) >= x {
        k -= 1;
    }
    u32::try_from(k.max(1)).expect("grid too fine")
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ceil_sqrt_is_exact() {
        assert_eq!(ceil_sqrt(0), 1);
        assert_eq!(ceil_sqrt(1), 1);
        assert_eq!(ceil_sqrt(2), 2);
        assert_eq!(ceil_sqrt(4), 2);
        assert_eq!(ceil_sqrt(20), 5);
        assert_eq!(ceil_sqrt(25), 5);
        assert_eq!(ceil_sqrt(26), 6);
    }

    #[test]
    fn names_resolve() {
        assert_eq!(all().len(), 3);
        assert!(by_name("sun").is_some() && by_name("nope").is_none());
        assert!(by_name("lamps").is_some() && scaled("lamps", 2.0).is_some());
        assert!(scaled("nope", 2.0).is_none());
    }

    #[test]
    #[should_panic(expected = "finite and positive")]
    fn bad_scale_panics() {
        sun(&Params {
            scale: 0.0,
            heavy: 1,
        });
    }
}
