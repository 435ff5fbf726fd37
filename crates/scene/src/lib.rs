//! glTF 2.0 scene import for gibake.
//!
//! Turns a `.gltf` / `.glb` file into a flat [`Scene`] following the
//! conventions of `docs/method.md` (and the design brief):
//!
//! - **Primary lights**: every `KHR_lights_punctual` light (directional,
//!   spot, point), or the ones [`LoadOptions::lights`] names; the first
//!   directional light first, else the first spot. `color × intensity` is
//!   radiant intensity in W/sr (spot, point) or irradiance in W/m²
//!   (directional), linear RGB.
//! - **Dynamic objects**: a node is dynamic if it or an ancestor has
//!   `extras: {"dynamic": true}`, or if an animation channel targets it or an
//!   ancestor. Everything else is static and is flattened to world space.
//! - **Materials**: Lambertian, albedo = baseColorFactor × baseColorTexture
//!   (sRGB decoded to linear; `KHR_texture_transform` applied;
//!   `KHR_materials_pbrSpecularGlossiness`' diffuse when present).
//!   `alphaMode: MASK` cuts holes where alpha < alphaCutoff ([`AlphaMode`];
//!   `BLEND` is a mask at 0.5, warned). All other material inputs are
//!   ignored with a warning naming the material. Every surface is two-sided
//!   for light transport.
//! - **Compression**: meshopt-compressed buffers
//!   (`EXT_/KHR_meshopt_compression`), quantized attributes
//!   (`KHR_mesh_quantization`), WebP images (`EXT_texture_webp`) and
//!   `EXT_mesh_gpu_instancing` are decoded (see [`decode`]); Draco, KTX2 and
//!   AVIF are refused with the command that converts them. Every extension
//!   the file uses and gibake does not apply is named in a warning.
//! - **Geometry**: triangles only (other modes are skipped with a warning);
//!   missing normals are computed (area-weighted vertex normals).
//! - **Camera**: the first node (document order of the default scene's
//!   traversal) that carries a camera.
//!
//! Dynamic meshes are kept in their node's local space; [`Scene::dynamic_transform`]
//! samples the animation at any time, so the runtime can move them per frame.

// Without the importer, the animation parser's parts go unused.
#![cfg_attr(not(feature = "gltf"), allow(dead_code))]

mod animation;
#[cfg(feature = "gltf")]
pub mod decode;
mod error;
mod hash;
#[cfg(feature = "gltf")]
mod import;
pub mod limits;
mod mesh;
mod overrides;

pub use animation::{Animator, Trs};
pub use error::SceneError;
pub use hash::static_scene_hash;
#[cfg(feature = "gltf")]
pub use import::{LoadOptions, load, load_from_slice};
pub use limits::Limits;
pub use mesh::{Aabb, DEGENERATE_SINE, compute_normals, drop_degenerate, is_degenerate};
pub use overrides::{CameraChoice, Sun, glob_match};

use glam::{Mat4, Vec2, Vec3};

/// A primary light's kind, with its kind-specific parameters.
#[derive(Clone, Debug, PartialEq)]
pub enum LightKind {
    /// A spot light. `color` is radiant intensity (W/sr) on the axis.
    Spot {
        /// glTF `innerConeAngle`, radians.
        inner_cone: f32,
        /// glTF `outerConeAngle`, radians (0 < outer ≤ π/2).
        outer_cone: f32,
    },
    /// A directional light. `color` is irradiance (W/m²) on a surface facing it.
    Directional,
    /// A point light. `color` is radiant intensity (W/sr), the same in every
    /// direction.
    Point,
}

/// A fixed primary light: a glTF `KHR_lights_punctual` light.
#[derive(Clone, Debug, PartialEq)]
pub struct Light {
    /// Name from the glTF (or `light #i`).
    pub name: String,
    /// Spot, directional or point, with parameters.
    pub kind: LightKind,
    /// `color × intensity`, linear RGB: W/sr (spot, point) or W/m²
    /// (directional).
    pub color: Vec3,
    /// World-space position (meaningless for directional lights, kept for framing).
    pub position: Vec3,
    /// World-space unit direction the light points to (the node's −Z; a
    /// point light's first cube face looks along it).
    pub direction: Vec3,
    /// glTF `range` (spot and point lights): no light at or beyond this
    /// distance ([`Light::range_window`]). `None`: unbounded. Always `None`
    /// for directional lights.
    pub range: Option<f32>,
}

impl Light {
    /// The `(scale, offset)` of glTF's spot falloff (see
    /// [`Light::spot_attenuation`]); the one place they are computed, for the
    /// CPU and for the GPU light record. `(0, 1)` for directional lights.
    pub fn spot_scale_offset(&self) -> (f32, f32) {
        match self.kind {
            LightKind::Directional | LightKind::Point => (0.0, 1.0),
            LightKind::Spot {
                inner_cone,
                outer_cone,
            } => {
                let cos_outer = outer_cone.cos();
                let scale = 1.0 / (inner_cone.cos() - cos_outer).max(0.001);
                (scale, -cos_outer * scale)
            }
        }
    }

    /// glTF's recommended spot falloff for a unit direction `dir_from_light`
    /// (from the light to the receiver). 1 for directional and point lights.
    ///
    /// `scale = 1 / max(0.001, cos(inner) − cos(outer))`,
    /// `offset = −cos(outer) · scale`, `att = saturate(cd · scale + offset)²`.
    pub fn spot_attenuation(&self, dir_from_light: Vec3) -> f32 {
        match self.kind {
            LightKind::Directional | LightKind::Point => 1.0,
            LightKind::Spot { .. } => {
                let (scale, offset) = self.spot_scale_offset();
                let cd = self.direction.dot(dir_from_light);
                let a = (cd * scale + offset).clamp(0.0, 1.0);
                a * a
            }
        }
    }

    /// glTF's recommended range window at distance `d` from the light:
    /// `saturate(1 − (d / range)⁴)`, 0 at and beyond `range` (no light
    /// there), 1 without a range. Dimensionless: the same at every scale.
    /// The one definition for the CPU; `light.wgsl` has the GPU's.
    pub fn range_window(&self, d: f32) -> f32 {
        match self.range {
            Some(r) if r > 0.0 => {
                let q = d / r;
                let q2 = q * q;
                (1.0 - q2 * q2).clamp(0.0, 1.0)
            }
            _ => 1.0,
        }
    }

    /// Spot falloff times range window: what multiplies `color / d²` for a
    /// receiver at distance `d` in unit direction `dir_from_light`. 1 for
    /// directional lights.
    pub fn attenuation(&self, dir_from_light: Vec3, d: f32) -> f32 {
        match self.kind {
            LightKind::Directional => 1.0,
            _ => self.spot_attenuation(dir_from_light) * self.range_window(d),
        }
    }

    /// Whether this light is a point light (an omnidirectional one).
    pub fn is_point(&self) -> bool {
        matches!(self.kind, LightKind::Point)
    }
}

/// Projection of a [`Camera`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Projection {
    /// Perspective with vertical field of view `yfov` (radians).
    Perspective {
        /// Vertical field of view, radians.
        yfov: f32,
        /// glTF `znear` (scene units).
        znear: f32,
        /// glTF `zfar`, `None` for infinite.
        zfar: Option<f32>,
    },
    /// Orthographic with half extents `xmag`, `ymag`.
    Orthographic {
        /// Half width.
        xmag: f32,
        /// Half height.
        ymag: f32,
        /// Near plane.
        znear: f32,
        /// Far plane.
        zfar: f32,
    },
}

/// The scene camera (aspect comes from the output size, not the file).
#[derive(Clone, Debug, PartialEq)]
pub struct Camera {
    /// Name from the glTF.
    pub name: String,
    /// Node index carrying the camera (may be animated).
    pub node: usize,
    /// Projection parameters.
    pub projection: Projection,
}

/// A decoded texture: RGBA8 texels whose RGB are sRGB-encoded.
#[derive(Clone, Debug, PartialEq)]
pub struct Texture {
    /// Width in texels.
    pub width: u32,
    /// Height in texels.
    pub height: u32,
    /// `width × height × 4` bytes, row 0 = first row of the image (v = 0).
    pub rgba8_srgb: Vec<u8>,
}

/// How a material's alpha shapes its surface (glTF `alphaMode`). Alpha is
/// baseColorFactor's alpha × the base colour texture's alpha (linear, not
/// sRGB-encoded), filtered like the albedo.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub enum AlphaMode {
    /// The surface is solid everywhere (glTF `OPAQUE`; alpha ignored).
    #[default]
    Opaque,
    /// The surface exists only where alpha ≥ `cutoff` (glTF `MASK`, and
    /// `BLEND` read as a mask at 0.5): holes everywhere else, in every map
    /// that sees the surface.
    Mask {
        /// glTF `alphaCutoff` (0.5 by default).
        cutoff: f32,
    },
}

/// A Lambertian material.
#[derive(Clone, Debug, PartialEq)]
pub struct Material {
    /// Name from the glTF.
    pub name: String,
    /// baseColorFactor RGB (linear).
    pub base_color: Vec3,
    /// Index into [`Scene::textures`] of the baseColorTexture, if any.
    pub texture: Option<usize>,
    /// baseColorFactor's alpha (1 for an opaque material).
    pub alpha: f32,
    /// Whether alpha cuts holes.
    pub alpha_mode: AlphaMode,
}

impl Material {
    /// An opaque material of constant or textured albedo.
    pub fn opaque(name: impl Into<String>, base_color: Vec3, texture: Option<usize>) -> Material {
        Material {
            name: name.into(),
            base_color,
            texture,
            alpha: 1.0,
            alpha_mode: AlphaMode::Opaque,
        }
    }

    /// The alpha cutoff, or `None` for an opaque material.
    pub fn cutoff(&self) -> Option<f32> {
        match self.alpha_mode {
            AlphaMode::Opaque => None,
            AlphaMode::Mask { cutoff } => Some(cutoff),
        }
    }

    /// The glTF rule, the one definition on the CPU (the GPU's is
    /// `alpha_keeps` in `gibake-gpu`'s `wgsl/mesh.wgsl`): a surface point of
    /// alpha `alpha` exists unless the material is masked and `alpha <
    /// cutoff`.
    pub fn keeps(&self, alpha: f32) -> bool {
        match self.alpha_mode {
            AlphaMode::Opaque => true,
            AlphaMode::Mask { cutoff } => alpha >= cutoff,
        }
    }
}

/// One triangle mesh (one glTF primitive).
#[derive(Clone, Debug, PartialEq)]
pub struct Mesh {
    /// `node name/mesh name/primitive index`, for messages.
    pub name: String,
    /// Positions: world space for static meshes, node-local for dynamic ones.
    pub positions: Vec<Vec3>,
    /// Unit normals in the same space as `positions` (computed if missing).
    pub normals: Vec<Vec3>,
    /// TEXCOORD_0, present iff the material has a texture.
    pub uvs: Option<Vec<Vec2>>,
    /// Triangle list, counter-clockwise front faces.
    pub indices: Vec<u32>,
    /// Index into [`Scene::materials`].
    pub material: usize,
}

/// A moving object: one glTF node with a mesh, moved as a rigid body.
#[derive(Clone, Debug, PartialEq)]
pub struct DynamicObject {
    /// Node name.
    pub name: String,
    /// glTF node index (for [`Scene::dynamic_transform`]).
    pub node: usize,
    /// Indices into [`Scene::dynamic_meshes`] that belong to this object.
    pub meshes: Vec<usize>,
    /// Local-space bounds of all its meshes.
    pub local_bounds: Aabb,
}

/// A flattened glTF scene, ready for baking, rendering and reference tracing.
#[derive(Clone, Debug)]
pub struct Scene {
    /// Source file, for messages.
    pub source: std::path::PathBuf,
    /// The primary lights (never empty): the first directional light first,
    /// else the first spot, then the others in file order
    /// ([`crate::LoadOptions::lights`]).
    pub lights: Vec<Light>,
    /// The first camera, if the file has one.
    pub camera: Option<Camera>,
    /// Materials referenced by meshes.
    pub materials: Vec<Material>,
    /// Decoded textures referenced by materials.
    pub textures: Vec<Texture>,
    /// Static meshes in world space.
    pub static_meshes: Vec<Mesh>,
    /// Dynamic meshes in node-local space.
    pub dynamic_meshes: Vec<Mesh>,
    /// Moving objects (each owns some of `dynamic_meshes`).
    pub dynamic_objects: Vec<DynamicObject>,
    /// Node hierarchy and animations, for sampling transforms at any time.
    pub animator: Animator,
    /// Warnings gathered while importing (skipped primitives, ignored inputs).
    pub warnings: Vec<String>,
    /// The part of the level a directional light's maps cover across the
    /// light (world space): a node marked `extras: {"bake_volume": true}`
    /// or `--bake-volume`. `None`: chosen from the geometry without
    /// outliers (`gibake_gpu::light_fit`). Part of the static-scene hash.
    pub bake_volume: Option<Aabb>,
}

impl Scene {
    /// The first primary light: the one whose maps are the primary ones (a
    /// directional light first, else a spot,
    /// [`crate::LoadOptions::lights`]).
    pub fn light(&self) -> &Light {
        &self.lights[0]
    }

    /// World matrix of dynamic object `i` at time `t` seconds (each animation
    /// clamped to its own range).
    pub fn dynamic_transform(&self, i: usize, t: f32) -> Mat4 {
        self.animator.world_matrix(self.dynamic_objects[i].node, t)
    }

    /// World matrices of every moving object at time `t`, in object order
    /// (the one definition of "the transforms at time t").
    pub fn dynamic_transforms(&self, t: f32) -> Vec<Mat4> {
        (0..self.dynamic_objects.len())
            .map(|i| self.dynamic_transform(i, t))
            .collect()
    }

    /// Adds a moving object made of `meshes` (node-local positions, each with
    /// its own material), placed at the fixed world matrix `world` until a
    /// renderer moves it; returns its index in [`Scene::dynamic_objects`].
    /// For tests and tools that give a level moving objects its file lacks;
    /// degenerate triangles are dropped as the importer drops them.
    pub fn add_dynamic_object(
        &mut self,
        name: &str,
        meshes: Vec<(Mesh, Material)>,
        world: Mat4,
    ) -> usize {
        let node = self.animator.push_fixed_node(world);
        let mut object = DynamicObject {
            name: name.to_string(),
            node,
            meshes: Vec::new(),
            local_bounds: Aabb::EMPTY,
        };
        for (mut mesh, material) in meshes {
            mesh::drop_degenerate(&mesh.positions, &mut mesh.indices);
            for p in &mesh.positions {
                object.local_bounds.grow(*p);
            }
            mesh.material = self.materials.len();
            self.materials.push(material);
            object.meshes.push(self.dynamic_meshes.len());
            self.dynamic_meshes.push(mesh);
        }
        self.dynamic_objects.push(object);
        self.dynamic_objects.len() - 1
    }

    /// World matrix of the camera node at time `t`.
    pub fn camera_transform(&self, t: f32) -> Option<Mat4> {
        self.camera
            .as_ref()
            .map(|c| self.animator.world_matrix(c.node, t))
    }

    /// Bounds of the static geometry (world space).
    pub fn static_bounds(&self) -> Aabb {
        let mut b = Aabb::EMPTY;
        for m in &self.static_meshes {
            for p in &m.positions {
                b.grow(*p);
            }
        }
        b
    }

    /// Bounds of dynamic object `i` at time `t` (world space, the transformed local box).
    pub fn dynamic_bounds(&self, i: usize, t: f32) -> Aabb {
        self.dynamic_objects[i]
            .local_bounds
            .transformed(self.dynamic_transform(i, t))
    }

    /// Bounds swept by all dynamic objects over the whole animation range
    /// (sampled at every keyframe time and at least 64 steps).
    pub fn dynamic_swept_bounds(&self) -> Aabb {
        let mut b = Aabb::EMPTY;
        if self.dynamic_objects.is_empty() {
            return b;
        }
        for t in self.animator.sample_times(64) {
            for i in 0..self.dynamic_objects.len() {
                b = b.union(&self.dynamic_bounds(i, t));
            }
        }
        b
    }

    /// Static bounds united with the swept bounds of the moving objects.
    pub fn full_bounds(&self) -> Aabb {
        self.static_bounds().union(&self.dynamic_swept_bounds())
    }

    /// Every mesh of the scene at time `t` in world space, static first, as
    /// `(mesh, world matrix)` pairs (identity for static meshes).
    pub fn meshes_at(&self, t: f32) -> Vec<(&Mesh, Mat4)> {
        let mut out: Vec<(&Mesh, Mat4)> = self
            .static_meshes
            .iter()
            .map(|m| (m, Mat4::IDENTITY))
            .collect();
        for (i, o) in self.dynamic_objects.iter().enumerate() {
            let w = self.dynamic_transform(i, t);
            for &mi in &o.meshes {
                out.push((&self.dynamic_meshes[mi], w));
            }
        }
        out
    }

    /// Albedo (linear RGB) of material `m` at texture coordinate `uv`
    /// (bilinear, repeat wrap, sRGB decoded before filtering). Used by the CPU
    /// reference; the GPU samples the same texture with the same filter.
    pub fn albedo(&self, material: usize, uv: Option<Vec2>) -> Vec3 {
        let m = &self.materials[material];
        match (m.texture, uv) {
            (Some(t), Some(uv)) => m.base_color * mesh::sample_bilinear_srgb(&self.textures[t], uv),
            _ => m.base_color,
        }
    }

    /// Alpha of material `material` at `uv`: baseColorFactor's alpha ×
    /// the texture's alpha (bilinear, repeat wrap, like the GPU's sampler;
    /// alpha is linear in an sRGB texture).
    pub fn alpha(&self, material: usize, uv: Option<Vec2>) -> f32 {
        let m = &self.materials[material];
        match (m.texture, uv) {
            (Some(t), Some(uv)) => m.alpha * mesh::sample_bilinear_alpha(&self.textures[t], uv),
            _ => m.alpha,
        }
    }

    /// Whether the surface of material `material` exists at `uv`
    /// ([`Material::keeps`] of [`Scene::alpha`]); always true for opaque
    /// materials, without sampling.
    pub fn alpha_keeps(&self, material: usize, uv: Option<Vec2>) -> bool {
        let m = &self.materials[material];
        match m.alpha_mode {
            AlphaMode::Opaque => true,
            AlphaMode::Mask { .. } => m.keeps(self.alpha(material, uv)),
        }
    }

    /// Total static and dynamic triangle counts.
    pub fn triangle_counts(&self) -> (usize, usize) {
        let s = self.static_meshes.iter().map(|m| m.indices.len() / 3).sum();
        let d = self
            .dynamic_meshes
            .iter()
            .map(|m| m.indices.len() / 3)
            .sum();
        (s, d)
    }
}
