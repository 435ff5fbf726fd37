//! A level tied to the runtime, in the main world: [`GibakeLevel`] on the
//! entity that holds the glTF scene Bevy spawns (its `WorldAssetRoot`),
//! gibake's own view of the same file (a `gibake_runtime::Scene`, loaded
//! on a task once the asset is there and again after each re-bake), the
//! level's moving objects found by node name ([`GibakeObject`]) and what
//! goes to the render world each frame (their `GlobalTransform` and
//! whether they are shown).
//!
//! Bevy and gibake read the same glTF file: Bevy spawns its nodes (a
//! `Name` each), gibake flattens it for the runtime (its static part must
//! be the one the asset was baked from; the runtime checks the hash). The
//! asset's recorded scene options (`--sun`, `--dynamic`, ...) are applied
//! to gibake's load (`load_scene_for`), so the moving objects are the ones
//! the bake left out of the static scene.

use std::path::PathBuf;
use std::sync::Arc;

use bevy::prelude::*;
use bevy::render::Extract;
use bevy::tasks::{AsyncComputeTaskPool, Task};
use bevy::world_serialization::WorldAssetRoot;

use crate::asset::GibakeAsset;
use crate::{GibakeSettings, GibakeShared};

/// Ties a level to gibake: put it on the entity that spawns the level's
/// glTF scene (`WorldAssetRoot(asset_server.load(GltfAssetLabel::Scene(0)
/// .from_asset("level.glb")))`), with the handle of the level's bake.
///
/// The level must stay where its file puts it: the entity's transform is
/// the identity (a baked level cannot move; the plugin says so and adds
/// nothing otherwise). One level at a time is lit (the first).
#[derive(Component, Clone, Debug)]
pub struct GibakeLevel {
    /// The bake of this level (`asset_server.load("level.gibake")`).
    pub asset: Handle<GibakeAsset>,
    /// The glTF file the asset was baked from, as an asset path under the
    /// file source's root; `None`: the file of the entity's
    /// `WorldAssetRoot`.
    pub scene: Option<String>,
    /// Spawn Bevy lights matching the lights the level was baked with
    /// (children of the level's entity, [`GibakeLight`]; see
    /// [`bevy_light`]), so that Bevy's direct light is the one whose
    /// bounce gibake adds. Off: the game spawns its own, the same.
    pub spawn_lights: bool,
}

impl GibakeLevel {
    /// The level of the entity's `WorldAssetRoot`, baked as `asset`, with
    /// Bevy lights matching the bake's.
    pub fn new(asset: Handle<GibakeAsset>) -> GibakeLevel {
        GibakeLevel {
            asset,
            scene: None,
            spawn_lights: true,
        }
    }
}

/// A Bevy light the plugin spawned for one of the level's baked lights
/// (its index in the runtime's `lights()`).
#[derive(Component, Clone, Copy, Debug)]
pub struct GibakeLight(pub usize);

/// The Bevy light of a gibake light, in Bevy's units, placed by the
/// returned transform (the light looks down its −Z, as glTF's).
///
/// gibake takes a glTF light's `color × intensity` numerically: W/m² of
/// irradiance for a directional light, W/sr of intensity for a spot or
/// point light. Bevy's lights are photometric and its shader divides a
/// point or spot light's `intensity` (lumens) by 4π: a directional light
/// of `illuminance = E` and a point light of `intensity = 4π·I` light
/// exactly as gibake's (the colour carries the rest, its largest component
/// 1). Their image values are then the same numbers, times the camera's
/// exposure on both sides (`tests/conventions.rs`). A spot light's cone
/// is glTF's (inner and outer angles); Bevy's spot falloff between them is
/// its own, and a `range` bounds a Bevy light with its own window: close
/// to glTF's, not equal.
pub fn bevy_light(light: &gibake_runtime::Light) -> (BevyLight, Transform) {
    let c = light.color;
    let m = c.max_element().max(f32::MIN_POSITIVE);
    let color = Color::linear_rgb(c.x / m, c.y / m, c.z / m);
    let up = if light.direction.y.abs() > 0.99 {
        Vec3::Z
    } else {
        Vec3::Y
    };
    let transform = Transform::from_translation(light.position).looking_to(light.direction, up);
    let range = light.range.unwrap_or(1.0e4);
    let four_pi = 4.0 * std::f32::consts::PI;
    let l = match light.kind {
        gibake_runtime::LightKind::Directional => BevyLight::Directional(DirectionalLight {
            color,
            illuminance: m,
            shadow_maps_enabled: true,
            ..Default::default()
        }),
        gibake_runtime::LightKind::Point => BevyLight::Point(PointLight {
            color,
            intensity: m * four_pi,
            range,
            shadow_maps_enabled: true,
            ..Default::default()
        }),
        gibake_runtime::LightKind::Spot {
            inner_cone,
            outer_cone,
        } => BevyLight::Spot(SpotLight {
            color,
            intensity: m * four_pi,
            range,
            inner_angle: inner_cone,
            outer_angle: outer_cone,
            shadow_maps_enabled: true,
            ..Default::default()
        }),
    };
    (l, transform)
}

/// One of Bevy's light components.
#[derive(Clone, Debug)]
pub enum BevyLight {
    /// A sun.
    Directional(DirectionalLight),
    /// A point light.
    Point(PointLight),
    /// A spot light.
    Spot(SpotLight),
}

/// A moving object of the level, by the name of the glTF node gibake knows
/// it by (a node the bake left out of the static scene: `extras:
/// {"dynamic": true}`, animated, or matched by `--dynamic`).
///
/// The plugin puts one on each such node of the spawned level; its
/// `GlobalTransform` goes to the runtime every frame, and its
/// `InheritedVisibility` shows or hides it. A game that spawns another
/// copy puts [`GibakeObject::copy_of`] on the copy's root: a new object for
/// the runtime (`Renderer::spawn`), removed when the entity despawns.
#[derive(Component, Clone, Debug, PartialEq, Eq)]
#[require(Transform, Visibility)]
pub struct GibakeObject {
    name: String,
    declared: bool,
}

impl GibakeObject {
    /// A copy of the level's moving object `name`, spawned by the game.
    pub fn copy_of(name: impl Into<String>) -> GibakeObject {
        GibakeObject {
            name: name.into(),
            declared: false,
        }
    }

    /// The node name of the object (or of the one this is a copy of).
    pub fn name(&self) -> &str {
        &self.name
    }

    /// Whether this is the level's own node (not a copy).
    pub fn is_declared(&self) -> bool {
        self.declared
    }
}

/// The plugin's state of a level (on the level's entity).
#[derive(Component, Default)]
pub(crate) struct LevelState {
    /// The asset the scene below was loaded for.
    for_asset: Option<Arc<gibake_runtime::Asset>>,
    task: Option<Task<Result<gibake_runtime::Scene, String>>>,
    /// Each new (scene, asset) pair counts one up.
    pub(crate) generation: u64,
    pub(crate) scene: Option<Arc<gibake_runtime::Scene>>,
    pub(crate) asset: Option<Arc<gibake_runtime::Asset>>,
    /// The declared objects' names not yet found among the level's nodes.
    missing: Vec<String>,
    /// The generation whose lights are spawned.
    lights_for: u64,
    moved_warned: bool,
}

/// The file source's root on disk.
#[derive(Resource, Clone)]
pub(crate) struct AssetRoot(pub(crate) PathBuf);

/// Starts gibake's load of a level's glTF whenever its asset is loaded or
/// reloaded; takes the result when the task is done.
pub(crate) fn load_level_scenes(
    mut commands: Commands,
    mut levels: Query<(
        Entity,
        &GibakeLevel,
        Option<&WorldAssetRoot>,
        Option<&mut LevelState>,
    )>,
    assets: Res<Assets<GibakeAsset>>,
    root: Res<AssetRoot>,
    shared: Res<GibakeShared>,
) {
    for (entity, level, world_root, state) in &mut levels {
        let Some(mut state) = state else {
            commands.entity(entity).insert(LevelState::default());
            continue;
        };
        if let Some(task) = &mut state.task {
            let Some(result) = bevy::tasks::futures::check_ready(task) else {
                continue;
            };
            state.task = None;
            match result {
                Ok(scene) => {
                    state.missing = scene
                        .dynamic_objects
                        .iter()
                        .map(|o| o.name.clone())
                        .collect();
                    state.scene = Some(Arc::new(scene));
                    state.asset = state.for_asset.clone();
                    state.generation += 1;
                    shared.set(|s| s.error = None);
                }
                Err(e) => {
                    error!("gibake: {e}");
                    shared.set(|s| s.error = Some(e));
                }
            }
            continue;
        }
        let Some(asset) = assets.get(&level.asset) else {
            continue;
        };
        if state
            .for_asset
            .as_ref()
            .is_some_and(|a| Arc::ptr_eq(a, &asset.asset))
        {
            continue;
        }
        let scene_path = match (&level.scene, world_root) {
            (Some(p), _) => p.clone(),
            (None, Some(r)) => match r.0.path() {
                Some(p) => p.path().to_string_lossy().into_owned(),
                None => {
                    warn_once!(
                        "gibake: the level's WorldAssetRoot has no path; set GibakeLevel::scene"
                    );
                    continue;
                }
            },
            (None, None) => {
                warn_once!(
                    "gibake: a GibakeLevel needs a WorldAssetRoot on its entity or GibakeLevel::scene"
                );
                continue;
            }
        };
        let path = root.0.join(&scene_path);
        let a = asset.asset.clone();
        state.for_asset = Some(a.clone());
        state.task = Some(AsyncComputeTaskPool::get().spawn(async move {
            gibake_runtime::load_scene_for(&path, &a, &Default::default())
                .map_err(|e| e.to_string())
        }));
    }
}

/// Puts [`GibakeObject`] on the spawned level's nodes that are gibake's
/// moving objects (by name, the first node of each name), as they appear;
/// warns once when the level's root is not at the identity.
pub(crate) fn tag_level_objects(
    mut commands: Commands,
    mut levels: Query<(Entity, &mut LevelState, &GlobalTransform), With<GibakeLevel>>,
    children: Query<&Children>,
    names: Query<(&Name, Has<GibakeObject>)>,
) {
    for (entity, mut state, transform) in &mut levels {
        if !state.moved_warned && !transform.affine().abs_diff_eq(Default::default(), 1e-5) {
            state.moved_warned = true;
            error!(
                "gibake: a baked level cannot move; its entity's transform must be the identity (it is {:?}); gibake adds nothing to this level",
                transform.compute_transform()
            );
        }
        if state.missing.is_empty() {
            continue;
        }
        for e in children.iter_descendants(entity) {
            let Ok((name, tagged)) = names.get(e) else {
                continue;
            };
            if let Some(k) = state.missing.iter().position(|m| m == name.as_str()) {
                let name = state.missing.swap_remove(k);
                if !tagged {
                    commands.entity(e).insert(GibakeObject {
                        name,
                        declared: true,
                    });
                }
            }
        }
    }
}

/// Spawns Bevy lights matching a level's baked lights (again after a
/// re-bake: a moved light is a re-bake).
pub(crate) fn spawn_level_lights(
    mut commands: Commands,
    mut levels: Query<(Entity, &GibakeLevel, &mut LevelState)>,
    lights: Query<(Entity, &ChildOf), With<GibakeLight>>,
) {
    for (entity, level, mut state) in &mut levels {
        if !level.spawn_lights || state.lights_for == state.generation {
            continue;
        }
        let Some(scene) = state.scene.clone() else {
            continue;
        };
        state.lights_for = state.generation;
        for (light, parent) in &lights {
            if parent.parent() == entity {
                commands.entity(light).despawn();
            }
        }
        for (i, l) in scene.lights.iter().enumerate() {
            let (light, transform) = bevy_light(l);
            let mut e = commands.spawn((GibakeLight(i), transform, ChildOf(entity)));
            match light {
                BevyLight::Directional(d) => e.insert(d),
                BevyLight::Point(p) => e.insert(p),
                BevyLight::Spot(s) => e.insert(s),
            };
        }
    }
}

/// A level as the render world sees it.
#[derive(Clone)]
pub(crate) struct ExtractedLevel {
    pub(crate) generation: u64,
    pub(crate) scene: Arc<gibake_runtime::Scene>,
    pub(crate) asset: Arc<gibake_runtime::Asset>,
}

/// A moving object as the render world sees it.
#[derive(Clone, Debug)]
pub(crate) struct ExtractedObject {
    pub(crate) entity: Entity,
    pub(crate) name: String,
    pub(crate) declared: bool,
    pub(crate) matrix: Mat4,
    pub(crate) visible: bool,
}

/// What the render world gets each frame.
#[derive(Resource, Default)]
pub(crate) struct ExtractedGibake {
    pub(crate) level: Option<ExtractedLevel>,
    pub(crate) objects: Vec<ExtractedObject>,
    pub(crate) settings: GibakeSettings,
}

pub(crate) fn extract_level(
    levels: Extract<Query<(&LevelState, &GlobalTransform), With<GibakeLevel>>>,
    objects: Extract<
        Query<(
            Entity,
            &GibakeObject,
            &GlobalTransform,
            &InheritedVisibility,
        )>,
    >,
    settings: Extract<Res<GibakeSettings>>,
    mut out: ResMut<ExtractedGibake>,
) {
    out.settings = settings.clone();
    out.level = levels.iter().find_map(|(s, t)| {
        let ok = t.affine().abs_diff_eq(Default::default(), 1e-5);
        match (&s.scene, &s.asset) {
            (Some(scene), Some(asset)) if ok => Some(ExtractedLevel {
                generation: s.generation,
                scene: scene.clone(),
                asset: asset.clone(),
            }),
            _ => None,
        }
    });
    out.objects.clear();
    out.objects
        .extend(objects.iter().map(|(e, o, t, v)| ExtractedObject {
            entity: e,
            name: o.name.clone(),
            declared: o.declared,
            matrix: t.to_matrix(),
            visible: v.get(),
        }));
}
