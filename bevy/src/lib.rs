//! gibake in Bevy 0.20: baked global illumination of a level, with its
//! moving objects, added to each camera's HDR frame.
//!
//! ```no_run
//! use bevy::prelude::*;
//! use gibake_bevy::{GibakeCamera, GibakeLevel, GibakePlugin};
//!
//! fn setup(mut commands: Commands, assets: Res<AssetServer>) {
//!     // The level as Bevy spawns it, and its bake (`gibake bake level.glb -o level.gibake`).
//!     commands.spawn((
//!         WorldAssetRoot(assets.load(GltfAssetLabel::Scene(0).from_asset("level.glb"))),
//!         GibakeLevel::new(assets.load("level.gibake")),
//!     ));
//!     // A camera that gets gibake's light (HDR, prepasses, MSAA off come with it).
//!     commands.spawn((Camera3d::default(), GibakeCamera::default()));
//! }
//!
//! App::new()
//!     .add_plugins((DefaultPlugins, GibakePlugin::default()))
//!     .add_systems(Startup, setup)
//!     .run();
//! ```
//!
//! - [`asset`]: the `.gibake` loader on the `AssetServer`, and hot reload
//!   of a re-bake;
//! - [`level`]: [`GibakeLevel`] ties the spawned glTF scene and its asset to
//!   the runtime; [`GibakeObject`] marks its moving objects (found by node
//!   name), whose `GlobalTransform` and visibility go to the runtime;
//! - [`render`]: the runtime on Bevy's device and queue, a view per
//!   [`GibakeCamera`], recorded in Bevy's render graph.
//!
//! The crate's README is the integration guide: what the game must do
//! (lights, prepasses, camera settings) and must not.

pub mod asset;
pub mod level;
pub mod render;

use std::sync::{Arc, Mutex};
use std::time::Duration;

use bevy::app::{App, Plugin};
use bevy::asset::AssetApp;
use bevy::core_pipeline::schedule::{Core3d, camera_driver};
use bevy::pbr::DefaultOpaqueRendererMethod;
use bevy::prelude::*;
use bevy::render::extract_component::ExtractComponentPlugin;
use bevy::render::renderer::{RenderGraph, RenderGraphSystems};
use bevy::render::{ExtractSchedule, Render, RenderApp, RenderSystems};

pub use asset::{GibakeAsset, GibakeLoadError};
pub use gibake_runtime;
pub use gibake_runtime::{FrameStats, Pass};
pub use level::{BevyLight, GibakeLevel, GibakeLight, GibakeObject, bevy_light};
pub use render::{GibakeCamera, GibakeRender, camera_matrices};

/// What gibake adds to each [`GibakeCamera`]'s frame.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum GibakeMode {
    /// The indirect light only (the bounce off static surfaces, baked, and
    /// what moving objects change): the game's own lights give the direct
    /// light. The default.
    #[default]
    Indirect,
    /// Direct and indirect light of the baked lights, gibake's shadows
    /// included: for a game without Bevy lights of its own.
    Everything,
}

/// Run-time settings (a resource; change it at any time).
#[derive(Resource, Clone, Debug)]
pub struct GibakeSettings {
    /// Whether gibake adds anything (off: Bevy's frame as it is, and no
    /// GPU work for gibake).
    pub enabled: bool,
    /// What it adds.
    pub mode: GibakeMode,
    /// Interleaved sampling (1, 2, 4, 8; 0: automatic, 4×4 from 256²
    /// pixels): `RenderSettings::interleave`.
    pub interleave: u32,
}

impl Default for GibakeSettings {
    fn default() -> Self {
        GibakeSettings {
            enabled: true,
            mode: GibakeMode::Indirect,
            interleave: 0,
        }
    }
}

/// What the render world reports back.
#[derive(Clone, Debug, Default)]
pub struct GibakeReport {
    /// The newest per-pass GPU times (`Renderer::poll_stats`, a few frames
    /// old, never waited for).
    pub stats: Option<FrameStats>,
    /// The last error (a bake that does not fit the level, a device limit,
    /// ...); `None` while all is well.
    pub error: Option<String>,
    /// Frames prepared with gibake's light.
    pub frames: u64,
    /// Re-baked assets taken by the running renderer.
    pub reloads: u64,
    /// Whether the last re-bake kept the moving objects' handles (the same
    /// objects by name: `Reload::HandlesKept`).
    pub handles_kept: Option<bool>,
}

/// The render world's report, readable in the main world
/// (`Res<GibakeShared>`, then [`GibakeShared::report`]).
#[derive(Resource, Clone, Default)]
pub struct GibakeShared(Arc<Mutex<GibakeReport>>);

impl GibakeShared {
    /// A copy of the current report.
    pub fn report(&self) -> GibakeReport {
        self.0.lock().unwrap_or_else(|e| e.into_inner()).clone()
    }

    pub(crate) fn set(&self, f: impl FnOnce(&mut GibakeReport)) {
        f(&mut self.0.lock().unwrap_or_else(|e| e.into_inner()));
    }
}

/// The plugin. Add it after `DefaultPlugins` (it needs the asset, render
/// and core pipeline plugins).
#[derive(Clone, Debug)]
pub struct GibakePlugin {
    /// How often a loaded asset's manifest is checked for a re-bake when
    /// the app watches for changes (see [`asset`]).
    pub reload_poll: Duration,
    /// Make deferred the default opaque rendering method
    /// (`DefaultOpaqueRendererMethod::deferred()`): Bevy's deferred
    /// G-buffer is where gibake reads the albedo. Off: the game sets it, or
    /// its cameras use `GibakeCamera { own_gbuffer: true }`.
    pub deferred: bool,
}

impl Default for GibakePlugin {
    fn default() -> Self {
        GibakePlugin {
            reload_poll: Duration::from_millis(500),
            deferred: true,
        }
    }
}

impl Plugin for GibakePlugin {
    fn build(&self, app: &mut App) {
        let (root, watching) = match app.get_added_plugins::<AssetPlugin>().first() {
            Some(p) => (
                bevy::asset::io::file::FileAssetReader::get_base_path().join(&p.file_path),
                p.watch_for_changes_override.unwrap_or(true),
            ),
            None => panic!("GibakePlugin needs the AssetPlugin (DefaultPlugins) added before it"),
        };
        let shared = GibakeShared::default();
        app.init_asset::<GibakeAsset>()
            .register_asset_loader(asset::GibakeLoader { root: root.clone() })
            .insert_resource(level::AssetRoot(root))
            .init_resource::<GibakeSettings>()
            .insert_resource(shared.clone())
            .add_plugins(ExtractComponentPlugin::<GibakeCamera>::default())
            .add_systems(
                Update,
                (
                    level::load_level_scenes,
                    level::tag_level_objects,
                    level::spawn_level_lights,
                )
                    .chain(),
            );
        if watching {
            app.insert_resource(asset::ReloadWatch {
                every: self.reload_poll,
                last: None,
                seen: Vec::new(),
            })
            .add_systems(Update, asset::watch_for_rebakes);
        }
        if self.deferred {
            app.insert_resource(DefaultOpaqueRendererMethod::deferred());
        }
        let Some(render_app) = app.get_sub_app_mut(RenderApp) else {
            return;
        };
        render_app
            .insert_resource(shared)
            .init_resource::<level::ExtractedGibake>()
            .init_resource::<render::GibakeRender>()
            .add_systems(ExtractSchedule, level::extract_level)
            .add_systems(
                Render,
                render::prepare.in_set(RenderSystems::PrepareBindGroups),
            )
            .add_systems(
                RenderGraph,
                (
                    render::record_update
                        .in_set(RenderGraphSystems::Render)
                        .before(camera_driver),
                    render::record_finish
                        .in_set(RenderGraphSystems::Render)
                        .after(camera_driver),
                ),
            )
            .add_systems(Core3d, render::view_system_config());
    }
}
