//! `KHR_texture_transform`: an affine map of the texture coordinates a
//! texture is sampled with (offset, rotation, scale, and an optional
//! `texCoord` override). gibake samples one texture per material (the base
//! colour, or the specular-glossiness diffuse), so the map is applied once,
//! at import, to the coordinates of every primitive drawn with it: the
//! bake, the runtime and the CPU reference all see the transformed
//! coordinates, and the static-scene hash covers them (it hashes every
//! static mesh's coordinates).
//!
//! Convention (the extension's README, its example, Khronos' sample viewer
//! and three.js agree): `uv' = T · R · S · uv`, with `S = diag(scale)`,
//! `R` mapping `(u, v)` to `(cos·u + sin·v, −sin·u + cos·v)` and `T` adding
//! `offset`. The README's example — offset (0, 1), rotation π/2, scale
//! (0.5, 0.5) uses "only the lower left quadrant of the source image,
//! rotated clockwise 90°" — is a test (`tests/import.rs`).

use glam::Vec2;
use gltf::json;

/// An affine map of texture coordinates.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) struct UvTransform {
    /// Images of the unit vectors u and v (columns of the linear part).
    cu: Vec2,
    cv: Vec2,
    offset: Vec2,
}

impl UvTransform {
    /// The map of a texture reference's `KHR_texture_transform` and the
    /// `texCoord` set it overrides, or `Err` naming a non-finite parameter.
    /// `Ok(None)` when the reference has no transform.
    pub(super) fn of(
        info: &json::texture::Info,
    ) -> Result<Option<(UvTransform, Option<u32>)>, String> {
        let Some(t) = info
            .extensions
            .as_ref()
            .and_then(|e| e.texture_transform.as_ref())
        else {
            return Ok(None);
        };
        let [ox, oy] = t.offset.0;
        let r = t.rotation.0;
        let [sx, sy] = t.scale.0;
        if ![ox, oy, r, sx, sy].iter().all(|x| x.is_finite()) {
            return Err(format!(
                "KHR_texture_transform has a non-finite parameter (offset [{ox}, {oy}], rotation {r}, scale [{sx}, {sy}])"
            ));
        }
        let (s, c) = r.sin_cos();
        Ok(Some((
            UvTransform {
                cu: Vec2::new(c * sx, -s * sx),
                cv: Vec2::new(s * sy, c * sy),
                offset: Vec2::new(ox, oy),
            },
            t.tex_coord,
        )))
    }

    /// The transformed coordinate.
    pub(super) fn apply(&self, uv: Vec2) -> Vec2 {
        self.cu * uv.x + self.cv * uv.y + self.offset
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn info(offset: [f32; 2], rotation: f32, scale: [f32; 2]) -> json::texture::Info {
        let v = serde_json::json!({ "index": 0, "extensions": { "KHR_texture_transform": {
            "offset": offset, "rotation": rotation, "scale": scale, "texCoord": 1 } } });
        serde_json::from_value(v).expect("texture info")
    }

    #[test]
    fn readme_example_selects_the_lower_left_quadrant() {
        let (t, set) = UvTransform::of(&info([0.0, 1.0], std::f32::consts::FRAC_PI_2, [0.5, 0.5]))
            .expect("finite")
            .expect("transform");
        assert_eq!(set, Some(1));
        for (uv, want) in [
            (Vec2::new(0.0, 0.0), Vec2::new(0.0, 1.0)),
            (Vec2::new(1.0, 0.0), Vec2::new(0.0, 0.5)),
            (Vec2::new(0.0, 1.0), Vec2::new(0.5, 1.0)),
            (Vec2::new(1.0, 1.0), Vec2::new(0.5, 0.5)),
        ] {
            let got = t.apply(uv);
            assert!((got - want).length() < 1e-6, "{uv} → {got}, want {want}");
        }
    }

    #[test]
    fn non_finite_parameters_are_refused() {
        let mut i = info([0.0, 0.0], 0.0, [1.0, 1.0]);
        i.extensions
            .as_mut()
            .and_then(|e| e.texture_transform.as_mut())
            .expect("transform")
            .scale
            .0[0] = f32::INFINITY;
        assert!(UvTransform::of(&i).is_err());
    }
}
