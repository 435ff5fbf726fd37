//! glTF → [`Scene`].
//!
//! The file is parsed by gltf-json and validated with its checks, less the
//! ones that are stricter than glTF 2.0 ([`validation`]); everything after
//! that (buffer loading, accessor reading, hierarchy checks) is done here
//! with checked arithmetic, so that malformed input gives a [`SceneError`] naming
//! the file and never a panic. As a last line of defence the whole import runs
//! under `catch_unwind`.
//!
//! The stages, in the order [`load`] runs them, one submodule each:
//! - [`precheck`]: the GLB container (its chunks) and what gltf-json's
//!   validation would choke on (required extensions, unchecked indices);
//! - [`validation`]: the parse and the validation, where glTF 2.0 allows
//!   what gltf-json refuses (accessors without `bufferView`, integral
//!   numbers written as `4.0`, scenes without nodes, channels without a
//!   target node, enum values glTF does not define) and the rules of
//!   sparse accessors gltf-json leaves out;
//! - [`extensions`]: which glTF extensions are applied, warnings naming
//!   the others and what carries them, and the conversion command for the
//!   compressions gibake does not decode;
//! - [`uri`] and [`accessors`]: buffers (blob, external files, data URIs),
//!   buffer views and accessors, against the element budget; [`meshopt`]:
//!   meshopt-compressed buffer views, decoded once after loading;
//! - [`nodes`] and [`animation`]: the node hierarchy and rest matrices, the
//!   animation channels (sampled later by [`crate::Animator`]);
//! - this module's `Ctx::build`: the traversal that decides what is static
//!   and what moves, then assembles the [`Scene`];
//! - [`lights`] and [`cameras`]: the primary light and the camera;
//! - [`meshes`], [`materials`] and [`textures`]: primitives, materials and
//!   their decoded base-colour images; [`texture_transform`]:
//!   `KHR_texture_transform`, applied to the texture coordinates;
//!   [`instancing`]: `EXT_mesh_gpu_instancing`, expanded to one mesh per
//!   instance.
//!
//! `Ctx` holds the per-import state; each submodule adds the methods of its
//! stage to it.

mod accessors;
mod animation;
mod cameras;
mod extensions;
mod instancing;
mod lights;
mod materials;
mod meshes;
mod meshopt;
mod nodes;
mod precheck;
mod texture_transform;
mod textures;
mod uri;
mod validation;

use std::cell::Cell;
use std::collections::HashMap;
use std::panic::{AssertUnwindSafe, catch_unwind};
use std::path::{Path, PathBuf};

use glam::{Mat4, Vec2, Vec3};
use gltf::json;

use crate::animation::Animator;
use crate::limits::{self, FileRefusal, Limits};
use crate::mesh::{compute_normals, drop_degenerate};
use crate::overrides::{CameraChoice, Sun, glob_match};
use crate::{Aabb, DynamicObject, Material, Mesh, Scene, SceneError, Texture};
use nodes::{extras_dynamic, extras_flag};
use precheck::{precheck, split_glb};

/// Options for [`load`].
#[derive(Clone, Debug, Default)]
pub struct LoadOptions {
    /// `--light NAME` (repeatable): only these lights (by light name, else
    /// node name). Empty: every `KHR_lights_punctual` light on a node of
    /// the scene, point lights included. Either way [`Scene::lights`] holds
    /// the first directional light in file order first, else the first
    /// spot (the bake's and the runtime's primary light: full-size maps,
    /// cascades for a sun), then the others in file order.
    pub lights: Vec<String>,
    /// Resource budgets (file sizes, accessor elements, texels, animation
    /// work, where external URIs may point).
    pub limits: Limits,
    /// A directional primary light added to the level (`--sun`); it
    /// replaces the file's lights, which are then ignored with a warning.
    pub sun: Option<Sun>,
    /// Which camera renders the scene (`--camera NAME`, `--look-at`).
    pub camera: CameraChoice,
    /// Glob patterns on node names (`--dynamic`): a matching node and its
    /// descendants move (are left out of the static scene and the bake).
    pub dynamic: Vec<String>,
    /// The bake volume (`--bake-volume`, world space); replaces a volume
    /// marked in the file ([`Scene::bake_volume`]).
    pub bake_volume: Option<Aabb>,
}

/// Loads a `.gltf` (with its external buffers/images) or `.glb` file.
pub fn load(path: &Path, options: &LoadOptions) -> Result<Scene, SceneError> {
    let bytes =
        limits::read_regular(path, options.limits.max_input_bytes).map_err(|e| match e {
            FileRefusal::Io(source) => SceneError::Io {
                path: path.to_path_buf(),
                source,
            },
            e => SceneError::Invalid {
                path: path.to_path_buf(),
                message: e.to_string(),
            },
        })?;
    load_from_slice(&bytes, path, options)
}

/// Loads a glTF held in memory. `path` is used for messages and to resolve
/// relative URIs of external buffers and images.
pub fn load_from_slice(
    bytes: &[u8],
    path: &Path,
    options: &LoadOptions,
) -> Result<Scene, SceneError> {
    match catch_unwind(AssertUnwindSafe(|| import(bytes, path, options))) {
        Ok(result) => result,
        Err(_) => Err(SceneError::Invalid {
            path: path.to_path_buf(),
            message:
                "internal error while importing this file (a bug in gibake-scene, please report it)"
                    .into(),
        }),
    }
}

/// The whole import, stage by stage (see the module docs); runs under
/// [`load_from_slice`]'s `catch_unwind`.
fn import(bytes: &[u8], path: &Path, options: &LoadOptions) -> Result<Scene, SceneError> {
    let container = split_glb(bytes, path)?;
    // Parse, run our own checks on what the gltf crate's validation would
    // choke on (or reject for the wrong reason), then validate with the
    // rules of glTF 2.0 where gltf-json's are stricter (`validation`).
    let (mut root, relaxed) =
        validation::parse(container.json).map_err(|source| SceneError::Gltf {
            path: path.to_path_buf(),
            source,
        })?;
    let extension_warnings = extensions::unapplied_warnings(&root);
    precheck(&mut root, path)?;
    validation::validate(&root, &relaxed, path)?;
    let document = gltf::Document::from_json_without_validation(root);
    let base = match path.parent() {
        Some(p) if !p.as_os_str().is_empty() => p.to_path_buf(),
        _ => PathBuf::from("."),
    };
    let mut ctx = Ctx {
        path,
        base,
        document: &document,
        root: document.as_json(),
        buffers: Vec::new(),
        decoded: HashMap::new(),
        warnings: Vec::new(),
        limits: &options.limits,
        elements_read: Cell::new(0),
        texels_decoded: Cell::new(0),
        nodeless_channels: relaxed.nodeless_channels,
    };
    for w in extension_warnings {
        ctx.warn(w);
    }
    ctx.load_buffers(container.bin.map(<[u8]>::to_vec))?;
    ctx.decode_meshopt_views()?;
    ctx.build(options)
}

/// One primitive's data as read from the file (node-local space).
#[derive(Clone)]
struct PrimData {
    positions: Vec<Vec3>,
    normals: Option<Vec<Vec3>>,
    uvs: Option<Vec<Vec2>>,
    indices: Vec<u32>,
    material: usize,
}

/// The state of one import: the parsed document, its loaded buffers, the
/// warnings gathered so far and the budgets charged against [`Limits`].
/// Each submodule adds the methods of its stage.
struct Ctx<'a> {
    path: &'a Path,
    base: PathBuf,
    document: &'a gltf::Document,
    root: &'a json::Root,
    buffers: Vec<gltf::buffer::Data>,
    /// Decoded meshopt-compressed buffer views, by view index.
    decoded: HashMap<usize, Vec<u8>>,
    warnings: Vec<String>,
    limits: &'a Limits,
    /// Accessor elements read so far (against `limits.max_elements`).
    elements_read: Cell<u64>,
    /// Texels decoded so far (against `limits.max_texels`).
    texels_decoded: Cell<u64>,
    /// Animation channels `(animation, channel)` without a target node
    /// (`validation::Relaxed`): ignored.
    nodeless_channels: std::collections::HashSet<(usize, usize)>,
}

/// Degenerate triangles dropped so far (one warning for all of them).
#[derive(Default)]
struct DegenerateCount {
    count: usize,
    meshes: usize,
    first: String,
}

impl DegenerateCount {
    fn note(&mut self, dropped: usize, mesh: &str) {
        if dropped > 0 {
            if self.count == 0 {
                self.first = mesh.to_string();
            }
            self.count += dropped;
            self.meshes += 1;
        }
    }
}

/// Per-import state for materials and textures.
#[derive(Default)]
struct MaterialTable {
    materials: Vec<Material>,
    textures: Vec<Texture>,
    /// (glTF material, textured) → scene material. Texture transforms live
    /// in the meshes' texture coordinates, so they do not split materials.
    by_key: HashMap<(Option<usize>, bool), usize>,
    /// glTF image → scene texture.
    by_image: HashMap<usize, usize>,
    /// glTF materials whose ignored inputs have been warned about.
    warned: std::collections::HashSet<Option<usize>>,
}

impl<'a> Ctx<'a> {
    fn invalid(&self, message: impl Into<String>) -> SceneError {
        SceneError::Invalid {
            path: self.path.to_path_buf(),
            message: message.into(),
        }
    }

    fn acc_err(&self, name: &str, acc: usize, what: &str, e: String) -> SceneError {
        self.invalid(format!("mesh {name}: {what} (accessor {acc}): {e}"))
    }

    fn not_supported(&self, message: impl Into<String>) -> SceneError {
        SceneError::NotSupported {
            path: self.path.to_path_buf(),
            message: message.into(),
        }
    }

    fn warn(&mut self, message: impl Into<String>) {
        let message = message.into();
        tracing::warn!("{}: {}", self.path.display(), message);
        self.warnings.push(message);
    }

    fn node_name(&self, i: usize) -> String {
        match self.root.nodes.get(i).and_then(|n| n.name.as_deref()) {
            Some(n) => format!("'{n}'"),
            None => format!("#{i}"),
        }
    }

    fn mesh_name(&self, i: usize) -> String {
        match self.root.meshes.get(i).and_then(|n| n.name.as_deref()) {
            Some(n) => n.to_string(),
            None => format!("mesh #{i}"),
        }
    }

    /// Per node: whether a `--dynamic` pattern matches its name. A pattern
    /// that matches no node is an error (a typo would silently bake the
    /// object as static).
    fn marked_dynamic(&self, patterns: &[String]) -> Result<Vec<bool>, SceneError> {
        let nodes = &self.root.nodes;
        let mut marked = vec![false; nodes.len()];
        for pat in patterns {
            let mut any = false;
            for (i, n) in nodes.iter().enumerate() {
                if n.name.as_deref().is_some_and(|name| glob_match(pat, name)) {
                    marked[i] = true;
                    any = true;
                }
            }
            if !any {
                let mut names: Vec<&str> = nodes
                    .iter()
                    .filter(|n| n.mesh.is_some() || n.children.is_some())
                    .filter_map(|n| n.name.as_deref())
                    .take(12)
                    .collect();
                names.dedup();
                return Err(self.invalid(format!(
                    "--dynamic '{pat}' matches no node name (patterns use * and ?; some node names: {})",
                    if names.is_empty() { "none are named".to_string() } else { names.join(", ") }
                )));
            }
        }
        Ok(marked)
    }

    fn build(mut self, options: &LoadOptions) -> Result<Scene, SceneError> {
        let root = self.root;
        let scene_index = match root.scene {
            Some(s) => s.value(),
            None if !root.scenes.is_empty() => 0,
            None => return Err(self.invalid("the file has no scene")),
        };
        let scene = root
            .scenes
            .get(scene_index)
            .ok_or_else(|| self.invalid(format!("scene {scene_index} does not exist")))?;

        let parents = self.parents()?;
        let rest = self.rest_matrices()?;
        let channels = self.channels()?;
        let total_keys: u64 = channels.iter().map(|c| c.times.len() as u64).sum();
        let mut animator = Animator::new(parents.clone(), rest, channels);
        let marked = self.marked_dynamic(&options.dynamic)?;

        // Depth-first traversal in document order, computing dynamic flags.
        let n = root.nodes.len();
        let mut order = Vec::new();
        let mut dynamic = vec![false; n];
        let mut visited = vec![false; n];
        let mut stack: Vec<(usize, bool)> = Vec::new();
        for r in scene.nodes.iter().rev() {
            let r = r.value();
            if r >= n {
                return Err(self.invalid(format!(
                    "scene {scene_index} lists node {r}, which does not exist"
                )));
            }
            if let Some(p) = parents[r] {
                return Err(self.invalid(format!(
                    "scene root node {} is also a child of node {}",
                    self.node_name(r),
                    self.node_name(p)
                )));
            }
            stack.push((r, false));
        }
        while let Some((v, parent_dynamic)) = stack.pop() {
            if visited[v] {
                continue;
            }
            visited[v] = true;
            let d = parent_dynamic
                || marked[v]
                || extras_dynamic(&root.nodes[v].extras)
                || animator.is_animated(v);
            dynamic[v] = d;
            order.push(v);
            for c in root.nodes[v].children.iter().flatten().rev() {
                stack.push((c.value(), d));
            }
        }

        let lights = self.primary_lights(&order, &dynamic, &animator, options)?;
        let camera = self.camera(&order, &options.camera, &mut animator)?;

        let mut table = MaterialTable::default();
        let mut degenerate = DegenerateCount::default();
        let mut static_meshes = Vec::new();
        let mut dynamic_meshes = Vec::new();
        let mut dynamic_objects = Vec::new();
        let mut volume = Aabb::EMPTY;
        for &v in &order {
            let node = &root.nodes[v];
            if extras_flag(&node.extras, "bake_volume") {
                // A bake volume: its mesh's bounds, or the unit cube
                // [−1, 1]³ of an empty (as Blender draws an empty cube),
                // in world space; not geometry.
                let world = animator.world_matrix(v, 0.0);
                let local = match node.mesh.map(|m| m.value()) {
                    Some(mi) => {
                        let node_label = node.name.clone().unwrap_or_else(|| format!("node #{v}"));
                        let mut b = Aabb::EMPTY;
                        for (_, p) in self.read_mesh(mi, &node_label, &mut table)? {
                            for q in p.positions {
                                b.grow(q);
                            }
                        }
                        b
                    }
                    None => Aabb {
                        min: Vec3::splat(-1.0),
                        max: Vec3::ONE,
                    },
                };
                volume = volume.union(&local.transformed(world));
                continue;
            }
            let Some(mesh_index) = node.mesh.map(|m| m.value()) else {
                continue;
            };
            if node.skin.is_some() {
                self.warn(format!(
                    "node {}: skin ignored, the mesh is rendered rigid",
                    self.node_name(v)
                ));
            }
            let node_label = match &node.name {
                Some(nm) => nm.clone(),
                None => format!("node #{v}"),
            };
            let instances = self.instances(v)?;
            let prims = self.read_mesh(mesh_index, &node_label, &mut table)?;
            if let Some(inst) = &instances {
                let vertices = prims.iter().map(|(_, p)| p.positions.len()).sum();
                self.charge_instances(v, inst.len(), vertices)?;
            }
            // Each instance of EXT_mesh_gpu_instancing is its own mesh.
            let copies = |name: &str| -> Vec<(String, Mat4)> {
                match &instances {
                    None => vec![(name.to_string(), Mat4::IDENTITY)],
                    Some(inst) => inst
                        .iter()
                        .enumerate()
                        .map(|(k, m)| (format!("{name}#{k}"), *m))
                        .collect(),
                }
            };
            if dynamic[v] {
                let mut object = DynamicObject {
                    name: node_label.clone(),
                    node: v,
                    meshes: Vec::new(),
                    local_bounds: Aabb::EMPTY,
                };
                for (name, p) in prims {
                    let meshes = if instances.is_none() {
                        let normals = match p.normals {
                            Some(nr) => nr,
                            None => compute_normals(&p.positions, &p.indices),
                        };
                        vec![Mesh {
                            name,
                            positions: p.positions,
                            normals,
                            uvs: p.uvs,
                            indices: p.indices,
                            material: p.material,
                        }]
                    } else {
                        let mut out = Vec::new();
                        for (n, m) in copies(&name) {
                            out.push(self.flatten(n, p.clone(), m)?);
                        }
                        out
                    };
                    for mut mesh in meshes {
                        let dropped = drop_degenerate(&mesh.positions, &mut mesh.indices);
                        degenerate.note(dropped, &mesh.name);
                        if mesh.indices.is_empty() {
                            continue;
                        }
                        for &q in &mesh.positions {
                            object.local_bounds.grow(q);
                        }
                        object.meshes.push(dynamic_meshes.len());
                        dynamic_meshes.push(mesh);
                    }
                }
                if !object.meshes.is_empty() {
                    dynamic_objects.push(object);
                }
            } else {
                let world = animator.world_matrix(v, 0.0);
                for (name, p) in prims {
                    let meshes = if instances.is_none() {
                        vec![self.flatten(name, p, world)?]
                    } else {
                        let mut out = Vec::new();
                        for (n, m) in copies(&name) {
                            out.push(self.flatten(n, p.clone(), world * m)?);
                        }
                        out
                    };
                    for mut mesh in meshes {
                        let dropped = drop_degenerate(&mesh.positions, &mut mesh.indices);
                        degenerate.note(dropped, &mesh.name);
                        if !mesh.indices.is_empty() {
                            static_meshes.push(mesh);
                        }
                    }
                }
            }
        }

        if degenerate.count > 0 {
            self.warn(format!(
                "skipped {} degenerate triangle(s) (zero area: coincident or collinear vertices) in {} mesh(es), first in {}",
                degenerate.count, degenerate.meshes, degenerate.first
            ));
        }

        let work = total_keys.saturating_mul(dynamic_objects.len() as u64);
        if work > self.limits.max_animation_work {
            return Err(self.invalid(format!(
                "{total_keys} animation keyframes × {} moving objects = {work}, over the animation work limit of {} (raise it with --max-animation-work)",
                dynamic_objects.len(),
                self.limits.max_animation_work
            )));
        }

        let static_triangles: usize = static_meshes
            .iter()
            .map(|m: &Mesh| m.indices.len() / 3)
            .sum();
        if static_triangles == 0 {
            return Err(self.invalid(
                "no static triangles: the scene needs static geometry (everything is dynamic, skipped or empty)",
            ));
        }

        let bake_volume = match options.bake_volume {
            Some(v) => Some(v),
            None if !volume.is_empty() => Some(volume),
            None => None,
        };
        if let Some(v) = &bake_volume
            && !(v.min.is_finite() && v.max.is_finite() && v.min.cmplt(v.max).all())
        {
            return Err(self.invalid(format!(
                    "the bake volume ({}, {}, {})..({}, {}, {}) must be finite with min < max on every axis",
                    v.min.x, v.min.y, v.min.z, v.max.x, v.max.y, v.max.z
                )));
        }
        Ok(Scene {
            source: self.path.to_path_buf(),
            lights,
            camera,
            materials: table.materials,
            textures: table.textures,
            static_meshes,
            dynamic_meshes,
            dynamic_objects,
            animator,
            warnings: self.warnings,
            bake_volume,
        })
    }
}
