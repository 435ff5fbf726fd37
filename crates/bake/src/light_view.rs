//! The light view as the asset stores it: the one conversion each way
//! between [`gibake_gpu::LightView`] (what the passes render with) and
//! [`gibake_asset::LightViewRecord`] (plain arrays in the manifest, so the
//! runtime merges moving objects in exactly the projection of the bake).

use gibake_asset::{LightViewRecord, Manifest};
use gibake_gpu::LightView;
use glam::{Mat4, Vec3};

/// The manifest record of `view` (its `size` is stored separately, as
/// `BakeSettings::shadow_map_size`).
pub fn light_view_record(view: &LightView) -> LightViewRecord {
    LightViewRecord {
        directional: view.directional,
        view_proj: view.view_proj.to_cols_array(),
        origin: view.origin.to_array(),
        direction: view.direction.to_array(),
        texel_scale: view.texel_scale,
        texel_area: view.texel_area,
    }
}

/// The light view of record `r` at map resolution `size`.
pub fn light_view_from_record(r: &LightViewRecord, size: u32) -> LightView {
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

/// The light view stored in an asset (for `shadow_map_size`).
pub fn light_view_of(m: &Manifest) -> LightView {
    light_view_from_record(&m.light_view, m.settings.shadow_map_size)
}

#[cfg(test)]
mod tests {
    use super::*;
    use gibake_scene::{Aabb, Light, LightKind};

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
        };
        let sun = Light {
            kind: LightKind::Directional,
            ..spot.clone()
        };
        for light in [spot, sun] {
            let view = LightView::new(&light, &bounds, 512);
            let record = light_view_record(&view);
            let back = light_view_from_record(&record, 512);
            assert_eq!(back, view);
            assert_eq!(light_view_record(&back), record);
        }
    }
}
