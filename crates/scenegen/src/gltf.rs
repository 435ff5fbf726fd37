//! A small glTF 2.0 / GLB writer on top of `gltf-json`'s typed structures.
//!
//! The [`Builder`] takes everything in metres at scale 1 and applies the
//! scene scale `s` itself, in one place, so no scene can forget a quantity:
//! vertex positions, node and animation translations, camera `znear`/`zfar`,
//! orthographic `xmag`/`ymag` and light `range`s are multiplied by `s`, spot
//! and point intensities (W/sr) by `s²`; directions, angles, colours,
//! albedos, times and directional irradiance are left as they are. Output is
//! deterministic: typed structs serialise their fields in declaration order,
//! there are no maps whose order could depend on features, and all
//! arithmetic is done in `f64` and rounded to `f32` once.

use glam::{DMat3, DQuat, DVec3};
use gltf_json as json;
use json::validation::Checked::Valid;
use json::validation::USize64;
use json::{Index, accessor, animation, buffer, camera, material, mesh, scene};

use crate::geom::Geom;

/// Accessors of one vertex/index set, shareable by several meshes.
#[derive(Clone, Copy, Debug)]
pub struct GeomRef {
    pos: Index<json::Accessor>,
    nrm: Index<json::Accessor>,
    idx: Index<json::Accessor>,
}

/// Builds one glTF asset with a single scene whose nodes are all roots.
pub struct Builder {
    s: f64,
    root: json::Root,
    bin: Vec<u8>,
    nodes: Vec<Index<json::Node>>,
    anim_channels: Vec<animation::Channel>,
    anim_samplers: Vec<animation::Sampler>,
    anim_name: String,
}

/// `extras: {"dynamic": true}`.
fn dynamic_extras() -> json::Extras {
    Some(json::extras::RawValue::from_string(r#"{"dynamic":true}"#.to_owned()).expect("valid JSON"))
}

/// Rounds an `f64` to the nearest `f32`.
fn f(x: f64) -> f32 {
    x as f32
}

fn v3(v: DVec3) -> [f32; 3] {
    [f(v.x), f(v.y), f(v.z)]
}

/// The rotation that turns a node's −Z axis toward `dir`, keeping its +Y axis
/// as close to world +Y as possible (world +X is used when `dir` is vertical).
pub fn look_rotation(dir: DVec3) -> DQuat {
    let z = -dir.normalize();
    let up = if z.cross(DVec3::Y).length() < 1e-6 {
        DVec3::X
    } else {
        DVec3::Y
    };
    let x = up.cross(z).normalize();
    let y = z.cross(x);
    DQuat::from_mat3(&DMat3::from_cols(x, y, z)).normalize()
}

impl Builder {
    /// A new asset at scene scale `scale` (1 = metres as given), whose
    /// animation (if any) will be called `anim_name`.
    pub fn new(scale: f64, anim_name: &str) -> Builder {
        let root = json::Root {
            asset: json::Asset {
                generator: Some(format!("gibake-scenegen {}", env!("CARGO_PKG_VERSION"))),
                version: "2.0".to_owned(),
                ..Default::default()
            },
            ..Default::default()
        };
        Builder {
            s: scale,
            root,
            bin: Vec::new(),
            nodes: Vec::new(),
            anim_channels: Vec::new(),
            anim_samplers: Vec::new(),
            anim_name: anim_name.to_owned(),
        }
    }

    /// Appends raw little-endian data as a new buffer view (4-byte aligned).
    fn view(&mut self, bytes: &[u8], target: Option<buffer::Target>) -> Index<buffer::View> {
        debug_assert!(self.bin.len().is_multiple_of(4));
        let offset = self.bin.len();
        self.bin.extend_from_slice(bytes);
        while !self.bin.len().is_multiple_of(4) {
            self.bin.push(0);
        }
        self.root.push(buffer::View {
            buffer: Index::new(0),
            byte_length: USize64::from(bytes.len()),
            byte_offset: Some(USize64::from(offset)),
            byte_stride: None,
            name: None,
            target: target.map(Valid),
            extensions: None,
            extras: None,
        })
    }

    /// A float accessor (`VEC3` or `SCALAR`) with exact min/max.
    fn float_accessor(
        &mut self,
        data: &[f32],
        n: usize,
        target: Option<buffer::Target>,
    ) -> Index<json::Accessor> {
        let count = data.len() / n;
        let mut lo = vec![f32::INFINITY; n];
        let mut hi = vec![f32::NEG_INFINITY; n];
        for c in data.chunks_exact(n) {
            for k in 0..n {
                lo[k] = lo[k].min(c[k]);
                hi[k] = hi[k].max(c[k]);
            }
        }
        let bytes: Vec<u8> = data.iter().flat_map(|x| x.to_le_bytes()).collect();
        let view = self.view(&bytes, target);
        self.root.push(json::Accessor {
            buffer_view: Some(view),
            byte_offset: None,
            count: USize64::from(count),
            component_type: Valid(accessor::GenericComponentType(accessor::ComponentType::F32)),
            extensions: None,
            extras: None,
            type_: Valid(if n == 3 {
                accessor::Type::Vec3
            } else {
                accessor::Type::Scalar
            }),
            min: Some(serde_json::json!(lo)),
            max: Some(serde_json::json!(hi)),
            name: None,
            normalized: false,
            sparse: None,
        })
    }

    /// Uploads a mesh's vertices (scaled) and indices; returns accessors that
    /// any number of meshes may share.
    pub fn geometry(&mut self, g: &Geom) -> GeomRef {
        let pos: Vec<f32> = g.pos.iter().flat_map(|p| v3(*p * self.s)).collect();
        let nrm: Vec<f32> = g.nrm.iter().flat_map(|n| v3(*n)).collect();
        let pos = self.float_accessor(&pos, 3, Some(buffer::Target::ArrayBuffer));
        let nrm = self.float_accessor(&nrm, 3, Some(buffer::Target::ArrayBuffer));
        let bytes: Vec<u8> = g.idx.iter().flat_map(|i| i.to_le_bytes()).collect();
        let view = self.view(&bytes, Some(buffer::Target::ElementArrayBuffer));
        let idx = self.root.push(json::Accessor {
            buffer_view: Some(view),
            byte_offset: None,
            count: USize64::from(g.idx.len()),
            component_type: Valid(accessor::GenericComponentType(accessor::ComponentType::U32)),
            extensions: None,
            extras: None,
            type_: Valid(accessor::Type::Scalar),
            min: None,
            max: None,
            name: None,
            normalized: false,
            sparse: None,
        });
        GeomRef { pos, nrm, idx }
    }

    /// A Lambertian material: `baseColorFactor = (rgb, 1)`, metallic 0, roughness 1.
    pub fn material(&mut self, name: &str, rgb: [f32; 3]) -> Index<json::Material> {
        self.root.push(json::Material {
            name: Some(name.to_owned()),
            pbr_metallic_roughness: material::PbrMetallicRoughness {
                base_color_factor: material::PbrBaseColorFactor([rgb[0], rgb[1], rgb[2], 1.0]),
                metallic_factor: material::StrengthFactor(0.0),
                roughness_factor: material::StrengthFactor(1.0),
                ..Default::default()
            },
            ..Default::default()
        })
    }

    /// A mesh of one triangle primitive.
    pub fn mesh(
        &mut self,
        name: &str,
        g: GeomRef,
        mat: Index<json::Material>,
    ) -> Index<json::Mesh> {
        let mut attributes = std::collections::BTreeMap::new();
        attributes.insert(Valid(mesh::Semantic::Positions), g.pos);
        attributes.insert(Valid(mesh::Semantic::Normals), g.nrm);
        self.root.push(json::Mesh {
            extensions: None,
            extras: None,
            name: Some(name.to_owned()),
            primitives: vec![mesh::Primitive {
                attributes,
                extensions: None,
                extras: None,
                indices: Some(g.idx),
                material: Some(mat),
                mode: Valid(mesh::Mode::Triangles),
                targets: None,
            }],
            weights: None,
        })
    }

    fn node(&mut self, n: json::Node) -> Index<json::Node> {
        let i = self.root.push(n);
        self.nodes.push(i);
        i
    }

    /// A static mesh node: identity transform, vertices already in world space.
    pub fn static_mesh(&mut self, name: &str, g: &Geom, rgb: [f32; 3]) -> Index<json::Node> {
        let gr = self.geometry(g);
        let mat = self.material(name, rgb);
        let mesh = self.mesh(name, gr, mat);
        self.node(json::Node {
            mesh: Some(mesh),
            name: Some(name.to_owned()),
            ..Default::default()
        })
    }

    /// A dynamic mesh node (marked `extras: {"dynamic": true}`) whose
    /// translation follows `path` (positions in metres at the `times`, LINEAR).
    /// Its rest translation is the path's first key.
    pub fn dynamic_mesh(
        &mut self,
        name: &str,
        mesh: Index<json::Mesh>,
        times: &[f64],
        path: &[DVec3],
    ) -> Index<json::Node> {
        assert_eq!(times.len(), path.len());
        let node = self.node(json::Node {
            mesh: Some(mesh),
            name: Some(name.to_owned()),
            translation: Some(v3(path[0] * self.s)),
            extras: dynamic_extras(),
            ..Default::default()
        });
        let t: Vec<f32> = times.iter().map(|t| f(*t)).collect();
        let input = self.float_accessor(&t, 1, None);
        let out: Vec<f32> = path.iter().flat_map(|p| v3(*p * self.s)).collect();
        let output = self.float_accessor(&out, 3, None);
        let sampler = Index::push(
            &mut self.anim_samplers,
            animation::Sampler {
                extensions: None,
                extras: None,
                input,
                interpolation: Valid(animation::Interpolation::Linear),
                output,
            },
        );
        self.anim_channels.push(animation::Channel {
            sampler,
            target: animation::Target {
                extensions: None,
                extras: None,
                node,
                path: Valid(animation::Property::Translation),
            },
            extensions: None,
            extras: None,
        });
        node
    }

    /// A light node at `pos`; `dir` (if any) turns the node's −Z toward it
    /// (a point light's node has no rotation).
    fn light(
        &mut self,
        name: &str,
        pos: DVec3,
        dir: Option<DVec3>,
        light: json::extensions::scene::khr_lights_punctual::Light,
    ) {
        let light = self.root.push(light);
        let rotation = dir.map(|d| {
            let rot = look_rotation(d);
            scene::UnitQuaternion([f(rot.x), f(rot.y), f(rot.z), f(rot.w)])
        });
        // The struct has one more field when gltf-json's `extensions` feature
        // is on (features unify across a workspace): keep the struct update.
        #[allow(clippy::needless_update)]
        let ext = json::extensions::scene::Node {
            khr_lights_punctual: Some(
                json::extensions::scene::khr_lights_punctual::KhrLightsPunctual { light },
            ),
            ..Default::default()
        };
        self.node(json::Node {
            name: Some(name.to_owned()),
            translation: Some(v3(pos * self.s)),
            rotation,
            extensions: Some(ext),
            ..Default::default()
        });
        if !self
            .root
            .extensions_used
            .iter()
            .any(|e| e == "KHR_lights_punctual")
        {
            self.root
                .extensions_used
                .push("KHR_lights_punctual".to_owned());
        }
    }

    /// A spot light at `pos` aimed along `dir`; `intensity` is the radiant
    /// intensity (W/sr) at scale 1 — it is multiplied by `s²` so that
    /// irradiance `I·cos/d²` at scaled distances is unchanged.
    #[allow(clippy::too_many_arguments)]
    pub fn spot(
        &mut self,
        name: &str,
        pos: DVec3,
        dir: DVec3,
        color: [f32; 3],
        intensity: f64,
        inner: f64,
        outer: f64,
    ) {
        self.spot_with_range(name, pos, dir, color, intensity, inner, outer, None);
    }

    /// [`Builder::spot`] with a glTF `range` (metres at scale 1, multiplied
    /// by `s`; `None`: unbounded, no `range` written).
    #[allow(clippy::too_many_arguments)]
    pub fn spot_with_range(
        &mut self,
        name: &str,
        pos: DVec3,
        dir: DVec3,
        color: [f32; 3],
        intensity: f64,
        inner: f64,
        outer: f64,
        range: Option<f64>,
    ) {
        self.lamp(
            name,
            pos,
            color,
            intensity,
            range,
            Some((dir, inner, outer)),
        );
    }

    /// A point light at `pos`: `intensity` is the radiant intensity (W/sr)
    /// at scale 1, the same in every direction, multiplied by `s²` as for
    /// [`Builder::spot`]; `range` is glTF's `range` (metres at scale 1,
    /// multiplied by `s`; `None`: unbounded, no `range` written). The node
    /// has no rotation.
    pub fn point(
        &mut self,
        name: &str,
        pos: DVec3,
        color: [f32; 3],
        intensity: f64,
        range: Option<f64>,
    ) {
        self.lamp(name, pos, color, intensity, range, None);
    }

    /// A spot (`spot`: direction, inner and outer cone angles) or point
    /// light: intensity (W/sr) scaled by `s²`, range by `s`.
    fn lamp(
        &mut self,
        name: &str,
        pos: DVec3,
        color: [f32; 3],
        intensity: f64,
        range: Option<f64>,
        spot: Option<(DVec3, f64, f64)>,
    ) {
        use json::extensions::scene::khr_lights_punctual as kl;
        self.light(
            name,
            pos,
            spot.map(|(dir, _, _)| dir),
            kl::Light {
                color,
                extensions: None,
                extras: None,
                intensity: f(intensity * self.s * self.s),
                name: Some(name.to_owned()),
                range: range.map(|r| f(r * self.s)),
                spot: spot.map(|(_, inner, outer)| kl::Spot {
                    inner_cone_angle: f(inner),
                    outer_cone_angle: f(outer),
                }),
                type_: Valid(if spot.is_some() {
                    kl::Type::Spot
                } else {
                    kl::Type::Point
                }),
            },
        );
    }

    /// A directional light shining along `dir` with irradiance `irradiance`
    /// (W/m², unchanged by scale); `pos` only places the node.
    pub fn directional(
        &mut self,
        name: &str,
        pos: DVec3,
        dir: DVec3,
        color: [f32; 3],
        irradiance: f64,
    ) {
        use json::extensions::scene::khr_lights_punctual as kl;
        self.light(
            name,
            pos,
            Some(dir),
            kl::Light {
                color,
                extensions: None,
                extras: None,
                intensity: f(irradiance),
                name: Some(name.to_owned()),
                range: None,
                spot: None,
                type_: Valid(kl::Type::Directional),
            },
        );
    }

    fn camera_node(&mut self, name: &str, eye: DVec3, target: DVec3, cam: json::Camera) {
        let cam = self.root.push(cam);
        let rot = look_rotation(target - eye);
        self.node(json::Node {
            camera: Some(cam),
            name: Some(name.to_owned()),
            translation: Some(v3(eye * self.s)),
            rotation: Some(scene::UnitQuaternion([
                f(rot.x),
                f(rot.y),
                f(rot.z),
                f(rot.w),
            ])),
            ..Default::default()
        });
    }

    /// A perspective camera at `eye` looking at `target`; `yfov` in radians,
    /// no aspect ratio (it comes from the output size).
    pub fn perspective(
        &mut self,
        name: &str,
        eye: DVec3,
        target: DVec3,
        yfov: f64,
        znear: f64,
        zfar: f64,
    ) {
        let cam = json::Camera {
            name: Some(name.to_owned()),
            orthographic: None,
            perspective: Some(camera::Perspective {
                aspect_ratio: None,
                yfov: f(yfov),
                zfar: Some(f(zfar * self.s)),
                znear: f(znear * self.s),
                extensions: None,
                extras: None,
            }),
            type_: Valid(camera::Type::Perspective),
            extensions: None,
            extras: None,
        };
        self.camera_node(name, eye, target, cam);
    }

    /// An orthographic camera at `eye` looking at `target`, half-extents
    /// `xmag`/`ymag` in metres.
    #[allow(clippy::too_many_arguments)]
    pub fn orthographic(
        &mut self,
        name: &str,
        eye: DVec3,
        target: DVec3,
        xmag: f64,
        ymag: f64,
        znear: f64,
        zfar: f64,
    ) {
        let s = self.s;
        let cam = json::Camera {
            name: Some(name.to_owned()),
            orthographic: Some(camera::Orthographic {
                xmag: f(xmag * s),
                ymag: f(ymag * s),
                zfar: f(zfar * s),
                znear: f(znear * s),
                extensions: None,
                extras: None,
            }),
            perspective: None,
            type_: Valid(camera::Type::Orthographic),
            extensions: None,
            extras: None,
        };
        self.camera_node(name, eye, target, cam);
    }

    /// Finishes the asset and returns the GLB bytes.
    pub fn finish(mut self) -> Vec<u8> {
        if !self.anim_channels.is_empty() {
            let a = json::Animation {
                extensions: None,
                extras: None,
                channels: std::mem::take(&mut self.anim_channels),
                name: Some(self.anim_name.clone()),
                samplers: std::mem::take(&mut self.anim_samplers),
            };
            self.root.push(a);
        }
        let nodes = std::mem::take(&mut self.nodes);
        let sc = self.root.push(json::Scene {
            extensions: None,
            extras: None,
            name: Some("scene".to_owned()),
            nodes,
        });
        self.root.scene = Some(sc);
        self.root.push(json::Buffer {
            byte_length: USize64::from(self.bin.len()),
            name: None,
            uri: None,
            extensions: None,
            extras: None,
        });
        let mut json_bytes = self.root.to_vec().expect("glTF JSON serialises");
        while !json_bytes.len().is_multiple_of(4) {
            json_bytes.push(b' ');
        }
        write_glb(&json_bytes, &self.bin)
    }
}

/// Packs a (4-byte padded) JSON chunk and a (4-byte padded) BIN chunk into GLB.
fn write_glb(json_chunk: &[u8], bin: &[u8]) -> Vec<u8> {
    let le = |x: usize| {
        u32::try_from(x)
            .expect("GLB larger than 4 GiB")
            .to_le_bytes()
    };
    let total = 12 + 8 + json_chunk.len() + if bin.is_empty() { 0 } else { 8 + bin.len() };
    let mut out = Vec::with_capacity(total);
    out.extend_from_slice(b"glTF");
    out.extend_from_slice(&2u32.to_le_bytes());
    out.extend_from_slice(&le(total));
    out.extend_from_slice(&le(json_chunk.len()));
    out.extend_from_slice(b"JSON");
    out.extend_from_slice(json_chunk);
    if !bin.is_empty() {
        out.extend_from_slice(&le(bin.len()));
        out.extend_from_slice(b"BIN\0");
        out.extend_from_slice(bin);
    }
    debug_assert_eq!(out.len(), total);
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn look_rotation_maps_neg_z_to_dir() {
        for d in [
            DVec3::new(1.0, -2.0, 0.5),
            DVec3::NEG_Y,
            DVec3::Y,
            DVec3::X,
            DVec3::NEG_Z,
        ] {
            let q = look_rotation(d);
            assert!((q * DVec3::NEG_Z - d.normalize()).length() < 1e-12, "{d}");
            // Camera up stays in the vertical plane through dir (no roll).
            let x = q * DVec3::X;
            if d.cross(DVec3::Y).length() > 1e-6 {
                assert!(x.y.abs() < 1e-12);
            }
        }
    }
}
