//! The `.gibake` asset on Bevy's `AssetServer`: [`GibakeAsset`], its
//! loader, and the watch that brings a re-bake into a running game.
//!
//! A `.gibake` asset is a directory (`manifest.bin`, EXR maps, VPL
//! records), read by `gibake_asset::load` (checksums, versions, values; a
//! read that meets a re-bake's swap is done again). The loader takes the
//! path the game gives (`asset_server.load("level.gibake")`), resolves it
//! under the file source's root and reads the directory from disk: a
//! `.gibake` asset loads from the file system (the default asset source),
//! not from an embedded or web source.
//!
//! **Hot reload.** `gibake bake` writes a new asset beside the old one and
//! swaps the two directories in one step. Bevy's file watcher reports that
//! swap as folder events (`RenamedFolder`, `AddedFolder`), and Bevy reloads
//! on folder events only what was loaded with `load_folder`: an asset at
//! the directory's path is not reloaded by Bevy itself. So, when the app
//! watches for changes (`AssetPlugin::watch_for_changes_override`, or the
//! `file_watcher` feature, which this crate enables), the plugin watches
//! each loaded asset's `manifest.bin` (its file identity, size and time,
//! at most every [`crate::GibakePlugin::reload_poll`]) and asks the
//! `AssetServer` to reload that path: the load goes through the loader and
//! the asset server as any reload does, the handles stay, and the level
//! takes the new asset with `Renderer::set_asset` (see `level.rs`).

use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::time::{Duration, Instant, SystemTime};

use bevy::asset::io::Reader;
use bevy::asset::{AssetLoader, AssetPath, LoadContext};
use bevy::prelude::*;

/// A baked level (`gibake bake`'s output), loaded by the asset server.
#[derive(Asset, TypePath, Clone)]
pub struct GibakeAsset {
    /// The asset as `gibake_runtime::load_asset` reads it.
    pub asset: Arc<gibake_runtime::Asset>,
    /// Where it was read from (the directory on disk).
    pub dir: PathBuf,
}

/// Why a `.gibake` asset did not load.
#[derive(Debug, thiserror::Error)]
pub enum GibakeLoadError {
    /// The asset server's path has no directory on disk (not the file
    /// source).
    #[error(
        "{path}: a .gibake asset loads from the file system (the default asset source); this path has no directory under {root}"
    )]
    NotOnDisk {
        /// The asset path.
        path: String,
        /// The file source's root.
        root: PathBuf,
    },
    /// gibake's own loader refused it (the message names the file).
    #[error(transparent)]
    Asset(#[from] gibake_runtime::AssetError),
}

/// Loads `.gibake` directories.
#[derive(TypePath)]
pub struct GibakeLoader {
    /// The file source's root on disk.
    pub(crate) root: PathBuf,
}

impl AssetLoader for GibakeLoader {
    type Asset = GibakeAsset;
    type Settings = ();
    type Error = GibakeLoadError;

    async fn load(
        &self,
        _reader: &mut dyn Reader,
        _settings: &(),
        load_context: &mut LoadContext<'_>,
    ) -> Result<GibakeAsset, GibakeLoadError> {
        // The reader is the directory itself: gibake reads its files.
        let path = load_context.path().path().to_path_buf();
        let dir = self.root.join(&path);
        if !dir.join("manifest.bin").is_file() && !dir.is_dir() {
            return Err(GibakeLoadError::NotOnDisk {
                path: path.display().to_string(),
                root: self.root.clone(),
            });
        }
        // On the asset server's IO task: reading and checking a few MB.
        let asset = gibake_runtime::load_asset(&dir)?;
        Ok(GibakeAsset {
            asset: Arc::new(asset),
            dir,
        })
    }

    fn extensions(&self) -> &[&str] {
        &["gibake"]
    }
}

/// What identifies one version of an asset on disk: its manifest's file
/// identity, size and modification time (a re-bake swaps in a new
/// directory, so the identity changes even within one second).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) struct Stamp {
    ino: u64,
    len: u64,
    modified: Option<SystemTime>,
}

pub(crate) fn stamp(dir: &Path) -> Option<Stamp> {
    let m = std::fs::metadata(dir.join("manifest.bin")).ok()?;
    #[cfg(unix)]
    let ino = std::os::unix::fs::MetadataExt::ino(&m);
    #[cfg(not(unix))]
    let ino = 0;
    Some(Stamp {
        ino,
        len: m.len(),
        modified: m.modified().ok(),
    })
}

/// The watch of the loaded assets' manifests.
#[derive(Resource)]
pub(crate) struct ReloadWatch {
    pub(crate) every: Duration,
    pub(crate) last: Option<Instant>,
    /// Per loaded asset: its path for the asset server, its directory and
    /// the manifest's stamp when it was loaded.
    pub(crate) seen: Vec<(
        AssetId<GibakeAsset>,
        AssetPath<'static>,
        PathBuf,
        Option<Stamp>,
    )>,
}

/// Records each loaded asset's stamp; asks the asset server to reload an
/// asset whose manifest changed since.
pub(crate) fn watch_for_rebakes(
    mut watch: ResMut<ReloadWatch>,
    mut events: MessageReader<AssetEvent<GibakeAsset>>,
    assets: Res<Assets<GibakeAsset>>,
    server: Res<AssetServer>,
) {
    for e in events.read() {
        match e {
            AssetEvent::Added { id } | AssetEvent::Modified { id } => {
                let (Some(a), Some(path)) = (assets.get(*id), server.get_path(*id)) else {
                    continue;
                };
                let s = stamp(&a.dir);
                watch.seen.retain(|(i, ..)| i != id);
                watch.seen.push((*id, path.into_owned(), a.dir.clone(), s));
            }
            AssetEvent::Removed { id } | AssetEvent::Unused { id } => {
                watch.seen.retain(|(i, ..)| i != id);
            }
            _ => {}
        }
    }
    let now = Instant::now();
    if watch
        .last
        .is_some_and(|t| now.duration_since(t) < watch.every)
    {
        return;
    }
    watch.last = Some(now);
    for (_, path, dir, was) in &mut watch.seen {
        let s = stamp(dir);
        // Absent for a moment (a fallback swap's two renames): wait.
        if s.is_some() && s != *was {
            info!("gibake: {} was re-baked; reloading it", path);
            *was = s;
            server.reload(path.clone());
        }
    }
}
