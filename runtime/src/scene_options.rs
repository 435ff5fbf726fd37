//! The scene options an asset was baked with ([`crate::SceneOptions`], format
//! 4.4: a sun added to the level, moving objects marked by name, the lights
//! kept, the bake volume, the largest texture side) between the asset and
//! the importer's [`LoadOptions`](crate::LoadOptions).
//!
//! Each of them changes the static scene, so a level loaded without the
//! ones its asset was baked with is another scene (the renderer refuses
//! it: the static-scene hash differs). [`load_scene_for`] loads a level
//! with its asset's options applied wherever the caller's options give none
//! ([`crate::SceneOptions::resolve`]); an option given that differs from the
//! asset's is an error naming both.

use gibake_asset::SunOption;
use gibake_scene::{Aabb, Sun};
use glam::Vec3;

/// The importer's sun of a recorded one.
pub fn sun_of(s: &SunOption) -> Sun {
    Sun {
        azimuth_deg: s.azimuth_deg,
        elevation_deg: s.elevation_deg,
        irradiance: s.irradiance,
        color: Vec3::from(s.color),
    }
}

/// The record of the importer's sun.
pub fn sun_option(s: &Sun) -> SunOption {
    SunOption {
        azimuth_deg: s.azimuth_deg,
        elevation_deg: s.elevation_deg,
        irradiance: s.irradiance,
        color: s.color.to_array(),
    }
}

/// The record of a bake volume (min x, y, z, max x, y, z).
pub fn bake_volume_option(b: &Aabb) -> [f32; 6] {
    let (n, x) = (b.min, b.max);
    [n.x, n.y, n.z, x.x, x.y, x.z]
}

/// The bake volume of a record.
pub fn bake_volume_of(v: &[f32; 6]) -> Aabb {
    Aabb {
        min: Vec3::new(v[0], v[1], v[2]),
        max: Vec3::new(v[3], v[4], v[5]),
    }
}

/// The scene options of the importer's `options` (what a bake of the scene
/// loaded with them records; canonical form). Its limits' default largest
/// texture side ([`gibake_asset::DEFAULT_MAX_TEXTURE_SIZE`]) counts as none
/// given.
#[cfg(feature = "gltf-import")]
pub fn scene_options_of(options: &crate::LoadOptions) -> crate::SceneOptions {
    crate::SceneOptions {
        sun: options.sun.as_ref().map(sun_option),
        dynamic: options.dynamic.clone(),
        lights: options.lights.clone(),
        bake_volume: options.bake_volume.as_ref().map(bake_volume_option),
        max_texture_size: Some(options.limits.max_texture_size),
    }
    .normalized()
}

/// `options` with its scene options replaced by `scene` (camera and other
/// limits kept).
#[cfg(feature = "gltf-import")]
pub fn with_scene_options(
    options: &crate::LoadOptions,
    scene: &crate::SceneOptions,
) -> crate::LoadOptions {
    let mut o = options.clone();
    o.sun = scene.sun.as_ref().map(sun_of);
    o.dynamic = scene.dynamic.clone();
    o.lights = scene.lights.clone();
    o.bake_volume = scene.bake_volume.as_ref().map(bake_volume_of);
    o.limits.max_texture_size = scene
        .max_texture_size
        .unwrap_or(gibake_asset::DEFAULT_MAX_TEXTURE_SIZE);
    o
}

/// The importer's options for loading the level of `asset`: `options`
/// with the asset's recorded scene options applied where `options` gives
/// none of their kind ([`crate::SceneOptions::resolve`]), and the resolution
/// (which recorded options were applied: say so). An asset that records
/// none (format 4.3 or older) leaves `options` as they are.
#[cfg(feature = "gltf-import")]
pub fn load_options_for(
    asset: &crate::Asset,
    options: &crate::LoadOptions,
) -> Result<(crate::LoadOptions, gibake_asset::Resolution), gibake_asset::OptionsConflict> {
    let r = crate::SceneOptions::resolve(asset.scene_options(), &scene_options_of(options))?;
    Ok((with_scene_options(options, &r.options), r))
}

/// Loads the level at `path` for `asset`: with [`load_options_for`]'s
/// options (the asset's recorded scene options wherever `options` gives
/// none), so that its static part is the one baked.
/// [`crate::RuntimeError::SceneOptions`] when `options` gives one that
/// differs from the asset's; [`crate::RuntimeError::Scene`] when the file
/// cannot be loaded.
#[cfg(feature = "gltf-import")]
pub fn load_scene_for(
    path: &std::path::Path,
    asset: &crate::Asset,
    options: &crate::LoadOptions,
) -> Result<crate::Scene, crate::RuntimeError> {
    let (options, _) = load_options_for(asset, options)?;
    Ok(gibake_scene::load(path, &options)?)
}

#[cfg(all(test, feature = "gltf-import"))]
mod tests {
    use super::*;

    #[test]
    fn load_options_and_records_convert_both_ways() {
        let given = crate::LoadOptions {
            sun: Some(Sun {
                azimuth_deg: 173.0,
                elevation_deg: 60.0,
                irradiance: 2.0,
                color: Vec3::new(1.0, 0.5, 0.25),
            }),
            dynamic: vec!["b*".into(), "a*".into()],
            lights: vec!["Key".into()],
            bake_volume: Some(Aabb {
                min: Vec3::new(-1.0, 0.0, -1.0),
                max: Vec3::ONE,
            }),
            ..Default::default()
        };
        let o = scene_options_of(&given);
        assert_eq!(o.dynamic, vec!["a*", "b*"], "canonical");
        assert_eq!(o.max_texture_size, None, "the default is none given");
        assert_eq!(o.bake_volume, Some([-1.0, 0.0, -1.0, 1.0, 1.0, 1.0]));
        let back = with_scene_options(&Default::default(), &o);
        assert_eq!(back.sun, given.sun);
        assert_eq!(back.bake_volume, given.bake_volume);
        assert_eq!(back.lights, given.lights);
        assert_eq!(scene_options_of(&back), o);
        let mut small = crate::LoadOptions::default();
        small.limits.max_texture_size = 1024;
        assert_eq!(scene_options_of(&small).max_texture_size, Some(1024));
        assert!(scene_options_of(&Default::default()).is_empty());
    }
}
