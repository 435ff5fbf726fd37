//! The level a hot-reloaded asset needs. An asset re-baked with other
//! scene options (format 4.4: another `--sun`, other moving props, ...) was
//! baked from another static scene than the one on screen: when the viewer
//! knows how the level was loaded ([`Reimport`]: its file and the options
//! the user gave), it loads it again with the new asset's options
//! ([`gibake_runtime::SceneOptions::resolve`], as `gibake view` did at
//! start); options the user gave that differ from the new asset's are
//! refused, naming both.

use std::path::{Path, PathBuf};

use gibake_runtime::scene_options::{scene_options_of, with_scene_options};
use gibake_runtime::{LoadOptions, Scene, SceneOptions};

/// How the level was loaded: what loading it again needs.
#[derive(Clone, Debug)]
pub struct Reimport {
    /// The glTF file.
    pub path: PathBuf,
    /// The importer's options as the user gave them (before an asset's
    /// recorded scene options were applied).
    pub options: LoadOptions,
}

impl Reimport {
    /// The scene options the level is loaded with for an asset that
    /// records `recorded` (`None`: nothing recorded): the user's, and the
    /// recorded ones of every kind the user gave none of; the message of
    /// `gibake view` when the user's differ.
    pub(crate) fn options_for(
        &self,
        recorded: Option<&SceneOptions>,
        asset_dir: &Path,
    ) -> Result<SceneOptions, String> {
        SceneOptions::resolve(recorded, &scene_options_of(&self.options))
            .map(|r| r.options)
            .map_err(|c| c.flags_message(&asset_dir.display().to_string(), "view"))
    }
}

/// The level for a reloaded asset at `asset_dir` that records `recorded`,
/// when the one on screen was loaded with `loaded_with` (`None`: not
/// known): `Ok((None, with))` keeps the scene on screen (loaded with the
/// same options `with`, or no way to load it again: `with` is
/// `loaded_with`); `Ok((Some(scene), with))` is the level loaded again
/// with `with`. A message when the user's options conflict with the
/// asset's or the file cannot be loaded.
pub(crate) fn level_for(
    reimport: Option<&Reimport>,
    recorded: Option<&SceneOptions>,
    loaded_with: Option<&SceneOptions>,
    asset_dir: &Path,
) -> Result<(Option<Scene>, Option<SceneOptions>), String> {
    let Some(r) = reimport else {
        return Ok((None, loaded_with.cloned()));
    };
    let with = r.options_for(recorded, asset_dir)?;
    if loaded_with.is_some_and(|l| l.same(&with)) {
        return Ok((None, Some(with)));
    }
    let scene = gibake_scene::load(&r.path, &with_scene_options(&r.options, &with))
        .map_err(|e| e.to_string())?;
    Ok((Some(scene), Some(with)))
}

#[cfg(test)]
mod tests {
    use super::*;
    use gibake_runtime::SunOption;

    fn level() -> Reimport {
        Reimport {
            path: Path::new(env!("CARGO_MANIFEST_DIR")).join("../../data/occluded.glb"),
            options: LoadOptions::default(),
        }
    }

    fn sun(azimuth_deg: f32) -> SceneOptions {
        SceneOptions {
            sun: Some(SunOption {
                azimuth_deg,
                elevation_deg: 60.0,
                irradiance: 1.0,
                color: [1.0; 3],
            }),
            ..Default::default()
        }
    }

    #[test]
    fn a_reload_baked_with_other_flags_loads_the_level_again() {
        let dir = Path::new("level.gibake");
        let r = level();
        // Baked with the same flags as the level on screen: kept.
        let (scene, with) = level_for(Some(&r), Some(&sun(173.0)), Some(&sun(173.0)), dir).unwrap();
        assert!(scene.is_none());
        assert_eq!(with, Some(sun(173.0)));
        // Re-baked with another sun: the level again, lit by it.
        let (scene, with) = level_for(Some(&r), Some(&sun(90.0)), Some(&sun(173.0)), dir).unwrap();
        let scene = scene.expect("loaded again");
        assert_eq!(scene.lights.len(), 1);
        assert_eq!(scene.lights[0].name, "--sun");
        assert_eq!(with, Some(sun(90.0)));
        // Re-baked without flags: the level as exported (its spot).
        let (scene, with) = level_for(
            Some(&r),
            Some(&SceneOptions::default()),
            Some(&sun(90.0)),
            dir,
        )
        .unwrap();
        assert_eq!(scene.expect("loaded again").lights[0].name, "spot");
        assert_eq!(with, Some(SceneOptions::default()));
        // A reloaded asset that records nothing: the user's options.
        let (scene, with) = level_for(Some(&r), None, Some(&sun(90.0)), dir).unwrap();
        assert!(scene.is_some());
        assert_eq!(with, Some(SceneOptions::default()));
        // No way to load it again: the scene on screen.
        let (scene, with) = level_for(None, Some(&sun(90.0)), Some(&sun(173.0)), dir).unwrap();
        assert!(scene.is_none());
        assert_eq!(with, Some(sun(173.0)));
    }

    #[test]
    fn flags_given_to_view_that_differ_from_the_reloaded_asset_are_refused() {
        let mut r = level();
        r.options.sun = Some(gibake_scene::Sun::new(173.0, 60.0));
        let e = level_for(
            Some(&r),
            Some(&sun(90.0)),
            Some(&sun(173.0)),
            Path::new("l.gibake"),
        )
        .unwrap_err();
        assert!(
            e.contains("l.gibake was baked with --sun 90,60")
                && e.contains("`view` was given --sun 173,60 (--sun differs)"),
            "{e}"
        );
    }
}
