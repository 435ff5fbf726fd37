//! Test helpers: build small glTF files in memory (JSON with a base64 data-URI
//! buffer, or GLB), and a tiny uncompressed PNG encoder for texture tests.

#![allow(dead_code)]

use std::path::Path;

use gibake_scene::{LoadOptions, Scene, SceneError};
use serde_json::{Value, json};

/// Standard base64 with padding.
pub fn base64(data: &[u8]) -> String {
    const A: &[u8; 64] = b"ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
    let mut out = String::with_capacity(data.len().div_ceil(3) * 4);
    for c in data.chunks(3) {
        let b = [c[0], *c.get(1).unwrap_or(&0), *c.get(2).unwrap_or(&0)];
        let n = (b[0] as u32) << 16 | (b[1] as u32) << 8 | b[2] as u32;
        out.push(A[(n >> 18) as usize & 63] as char);
        out.push(A[(n >> 12) as usize & 63] as char);
        out.push(if c.len() > 1 {
            A[(n >> 6) as usize & 63] as char
        } else {
            '='
        });
        out.push(if c.len() > 2 {
            A[n as usize & 63] as char
        } else {
            '='
        });
    }
    out
}

/// Builds a glTF document with one binary buffer.
pub struct Builder {
    pub json: Value,
    pub bin: Vec<u8>,
}

fn push(v: &mut Value, key: &str, item: Value) -> usize {
    let arr = v
        .as_object_mut()
        .unwrap()
        .entry(key)
        .or_insert_with(|| json!([]));
    let arr = arr.as_array_mut().unwrap();
    arr.push(item);
    arr.len() - 1
}

impl Default for Builder {
    fn default() -> Self {
        Self::new()
    }
}

impl Builder {
    pub fn new() -> Builder {
        Builder {
            json: json!({ "asset": { "version": "2.0" }, "scene": 0, "scenes": [ { "nodes": [] } ] }),
            bin: Vec::new(),
        }
    }

    /// Appends bytes (4-aligned) as a new buffer view; returns its index.
    pub fn view(&mut self, bytes: &[u8]) -> usize {
        while !self.bin.len().is_multiple_of(4) {
            self.bin.push(0);
        }
        let off = self.bin.len();
        self.bin.extend_from_slice(bytes);
        push(
            &mut self.json,
            "bufferViews",
            json!({ "buffer": 0, "byteOffset": off, "byteLength": bytes.len() }),
        )
    }

    /// A float accessor of the given type ("SCALAR", "VEC2", "VEC3", "VEC4").
    pub fn floats(&mut self, data: &[f32], ty: &str) -> usize {
        let dims = match ty {
            "SCALAR" => 1,
            "VEC2" => 2,
            "VEC3" => 3,
            _ => 4,
        };
        let bytes: Vec<u8> = data.iter().flat_map(|f| f.to_le_bytes()).collect();
        let v = self.view(&bytes);
        // min/max (required for POSITION), ignoring non-finite values.
        let mut min = vec![0.0f32; dims];
        let mut max = vec![0.0f32; dims];
        for d in 0..dims {
            let vals = data.iter().skip(d).step_by(dims).filter(|x| x.is_finite());
            min[d] = vals.clone().fold(f32::INFINITY, |a, &b| a.min(b));
            max[d] = vals.fold(f32::NEG_INFINITY, |a, &b| a.max(b));
            if !min[d].is_finite() {
                (min[d], max[d]) = (0.0, 0.0);
            }
        }
        push(
            &mut self.json,
            "accessors",
            json!({ "bufferView": v, "componentType": 5126, "count": data.len() / dims, "type": ty, "min": min, "max": max }),
        )
    }

    pub fn vec3s(&mut self, data: &[[f32; 3]]) -> usize {
        let flat: Vec<f32> = data.iter().flatten().copied().collect();
        self.floats(&flat, "VEC3")
    }

    pub fn indices_u32(&mut self, data: &[u32]) -> usize {
        let bytes: Vec<u8> = data.iter().flat_map(|f| f.to_le_bytes()).collect();
        let v = self.view(&bytes);
        push(
            &mut self.json,
            "accessors",
            json!({ "bufferView": v, "componentType": 5125, "count": data.len(), "type": "SCALAR" }),
        )
    }

    pub fn indices_u16(&mut self, data: &[u16]) -> usize {
        let bytes: Vec<u8> = data.iter().flat_map(|f| f.to_le_bytes()).collect();
        let v = self.view(&bytes);
        push(
            &mut self.json,
            "accessors",
            json!({ "bufferView": v, "componentType": 5123, "count": data.len(), "type": "SCALAR" }),
        )
    }

    /// A mesh with one primitive made of raw JSON.
    pub fn mesh_raw(&mut self, name: &str, primitive: Value) -> usize {
        push(
            &mut self.json,
            "meshes",
            json!({ "name": name, "primitives": [primitive] }),
        )
    }

    /// A mesh with one triangle primitive.
    pub fn mesh(
        &mut self,
        name: &str,
        positions: &[[f32; 3]],
        indices: Option<&[u32]>,
        normals: Option<&[[f32; 3]]>,
        material: Option<usize>,
    ) -> usize {
        let p = self.vec3s(positions);
        let mut prim = json!({ "attributes": { "POSITION": p } });
        if let Some(n) = normals {
            let n = self.vec3s(n);
            prim["attributes"]["NORMAL"] = json!(n);
        }
        if let Some(i) = indices {
            let i = self.indices_u16(&i.iter().map(|&x| x as u16).collect::<Vec<_>>());
            prim["indices"] = json!(i);
        }
        if let Some(m) = material {
            prim["material"] = json!(m);
        }
        self.mesh_raw(name, prim)
    }

    /// A 2×2 quad in the XZ plane at y = 0, facing +Y (counter-clockwise seen from above).
    pub fn quad(&mut self, name: &str, with_normals: bool) -> usize {
        let pos = [
            [-1.0, 0.0, -1.0],
            [-1.0, 0.0, 1.0],
            [1.0, 0.0, 1.0],
            [1.0, 0.0, -1.0],
        ];
        let nrm = [[0.0, 1.0, 0.0]; 4];
        self.mesh(
            name,
            &pos,
            Some(&[0, 1, 2, 0, 2, 3]),
            if with_normals { Some(&nrm) } else { None },
            None,
        )
    }

    pub fn node(&mut self, node: Value) -> usize {
        push(&mut self.json, "nodes", node)
    }

    pub fn root(&mut self, node: usize) {
        self.json["scenes"][0]["nodes"]
            .as_array_mut()
            .unwrap()
            .push(json!(node));
    }

    pub fn child(&mut self, parent: usize, child: usize) {
        let p = &mut self.json["nodes"][parent];
        let c = p
            .as_object_mut()
            .unwrap()
            .entry("children")
            .or_insert_with(|| json!([]));
        c.as_array_mut().unwrap().push(json!(child));
    }

    /// Adds a node with a mesh at the scene root.
    pub fn root_mesh_node(&mut self, name: &str, mesh: usize) -> usize {
        let n = self.node(json!({ "name": name, "mesh": mesh }));
        self.root(n);
        n
    }

    pub fn light(&mut self, light: Value) -> usize {
        let ext = self
            .json
            .as_object_mut()
            .unwrap()
            .entry("extensions")
            .or_insert_with(|| json!({}));
        let l = ext
            .as_object_mut()
            .unwrap()
            .entry("KHR_lights_punctual")
            .or_insert_with(|| json!({ "lights": [] }));
        let arr = l["lights"].as_array_mut().unwrap();
        arr.push(light);
        let used = self
            .json
            .as_object_mut()
            .unwrap()
            .entry("extensionsUsed")
            .or_insert_with(|| json!([]));
        if used.as_array().unwrap().is_empty() {
            used.as_array_mut()
                .unwrap()
                .push(json!("KHR_lights_punctual"));
        }
        self.json["extensions"]["KHR_lights_punctual"]["lights"]
            .as_array()
            .unwrap()
            .len()
            - 1
    }

    /// Adds a light and a root node carrying it; returns the node.
    pub fn light_node(&mut self, light: Value, node: Value) -> usize {
        let l = self.light(light);
        let mut node = node;
        node["extensions"] = json!({ "KHR_lights_punctual": { "light": l } });
        let n = self.node(node);
        self.root(n);
        n
    }

    pub fn camera(&mut self, camera: Value) -> usize {
        push(&mut self.json, "cameras", camera)
    }

    pub fn animation(&mut self, anim: Value) -> usize {
        push(&mut self.json, "animations", anim)
    }

    pub fn material(&mut self, m: Value) -> usize {
        push(&mut self.json, "materials", m)
    }

    /// Adds an embedded PNG image (data URI) and a texture for it; returns the texture.
    pub fn png_texture(&mut self, png: &[u8]) -> usize {
        let img = push(
            &mut self.json,
            "images",
            json!({ "uri": format!("data:image/png;base64,{}", base64(png)) }),
        );
        push(&mut self.json, "textures", json!({ "source": img }))
    }

    /// The document with the buffer embedded as a data URI.
    pub fn json_with_data_uri(&self) -> Value {
        let mut j = self.json.clone();
        if !self.bin.is_empty() {
            j["buffers"] = json!([{
                "byteLength": self.bin.len(),
                "uri": format!("data:application/octet-stream;base64,{}", base64(&self.bin)),
            }]);
        }
        j
    }

    /// `.gltf` bytes (JSON, data-URI buffer).
    pub fn gltf(&self) -> Vec<u8> {
        serde_json::to_vec_pretty(&self.json_with_data_uri()).unwrap()
    }

    /// `.glb` bytes (buffer in the BIN chunk).
    pub fn glb(&self) -> Vec<u8> {
        let mut j = self.json.clone();
        let mut bin = self.bin.clone();
        while !bin.len().is_multiple_of(4) {
            bin.push(0);
        }
        if !bin.is_empty() {
            j["buffers"] = json!([{ "byteLength": self.bin.len() }]);
        }
        let mut js = serde_json::to_vec(&j).unwrap();
        while !js.len().is_multiple_of(4) {
            js.push(b' ');
        }
        let total = 12 + 8 + js.len() + if bin.is_empty() { 0 } else { 8 + bin.len() };
        let mut out = Vec::with_capacity(total);
        out.extend_from_slice(b"glTF");
        out.extend_from_slice(&2u32.to_le_bytes());
        out.extend_from_slice(&(total as u32).to_le_bytes());
        out.extend_from_slice(&(js.len() as u32).to_le_bytes());
        out.extend_from_slice(b"JSON");
        out.extend_from_slice(&js);
        if !bin.is_empty() {
            out.extend_from_slice(&(bin.len() as u32).to_le_bytes());
            out.extend_from_slice(b"BIN\0");
            out.extend_from_slice(&bin);
        }
        out
    }

    pub fn load(&self) -> Result<Scene, SceneError> {
        self.load_with(&LoadOptions::default())
    }

    pub fn load_with(&self, options: &LoadOptions) -> Result<Scene, SceneError> {
        gibake_scene::load_from_slice(&self.gltf(), Path::new("test_scene.gltf"), options)
    }
}

/// The standard spot light: red-ish colour × intensity 10, cone 0.2 / 0.5.
pub fn spot_light() -> Value {
    json!({ "name": "Key", "type": "spot", "color": [1.0, 0.5, 0.25], "intensity": 10.0,
            "spot": { "innerConeAngle": 0.2, "outerConeAngle": 0.5 } })
}

/// A builder holding a floor quad, a spot light 5 units up pointing down, and a camera.
pub fn basic() -> Builder {
    let mut b = Builder::new();
    let q = b.quad("Floor", true);
    b.root_mesh_node("FloorNode", q);
    // Rotation of −90° about X maps −Z to −Y: the light points down.
    let s = std::f32::consts::FRAC_1_SQRT_2;
    b.light_node(spot_light(), json!({ "name": "LightNode", "translation": [0.0, 5.0, 0.0], "rotation": [-s, 0.0, 0.0, s] }));
    let c = b.camera(json!({ "name": "Cam", "type": "perspective", "perspective": { "yfov": 0.8, "znear": 0.1, "zfar": 100.0 } }));
    let n = b.node(json!({ "name": "CamNode", "camera": c, "translation": [0.0, 1.0, 5.0] }));
    b.root(n);
    b
}

/// Asserts that the error's message contains every needle (case-sensitive).
pub fn assert_err_contains(r: Result<Scene, SceneError>, needles: &[&str]) -> SceneError {
    match r {
        Ok(_) => panic!("expected an error containing {needles:?}, got Ok"),
        Err(e) => {
            let msg = e.to_string();
            for n in needles {
                assert!(
                    msg.contains(n),
                    "error message {msg:?} does not contain {n:?}"
                );
            }
            e
        }
    }
}

// ------------------------------------------------------------------ tiny PNG

fn crc32(data: &[u8]) -> u32 {
    let mut crc = 0xffff_ffffu32;
    for &b in data {
        crc ^= b as u32;
        for _ in 0..8 {
            crc = if crc & 1 != 0 {
                (crc >> 1) ^ 0xedb8_8320
            } else {
                crc >> 1
            };
        }
    }
    !crc
}

fn adler32(data: &[u8]) -> u32 {
    let (mut a, mut b) = (1u32, 0u32);
    for &x in data {
        a = (a + x as u32) % 65521;
        b = (b + a) % 65521;
    }
    b << 16 | a
}

/// An uncompressed (stored-deflate) 8-bit PNG; `channels` 3 = RGB, 4 = RGBA.
pub fn png(width: u32, height: u32, channels: u8, pixels: &[u8]) -> Vec<u8> {
    let mut raw = Vec::new();
    let row = width as usize * channels as usize;
    for y in 0..height as usize {
        raw.push(0); // filter: none
        raw.extend_from_slice(&pixels[y * row..(y + 1) * row]);
    }
    let mut z = vec![0x78, 0x01];
    let chunks: Vec<&[u8]> = raw.chunks(65535).collect();
    for (i, c) in chunks.iter().enumerate() {
        z.push(if i + 1 == chunks.len() { 1 } else { 0 });
        z.extend_from_slice(&(c.len() as u16).to_le_bytes());
        z.extend_from_slice(&(!(c.len() as u16)).to_le_bytes());
        z.extend_from_slice(c);
    }
    z.extend_from_slice(&adler32(&raw).to_be_bytes());
    let mut out = b"\x89PNG\r\n\x1a\n".to_vec();
    let mut chunk = |ty: &[u8], data: &[u8]| {
        out.extend_from_slice(&(data.len() as u32).to_be_bytes());
        let mut c = ty.to_vec();
        c.extend_from_slice(data);
        out.extend_from_slice(&c);
        out.extend_from_slice(&crc32(&c).to_be_bytes());
    };
    let mut ihdr = Vec::new();
    ihdr.extend_from_slice(&width.to_be_bytes());
    ihdr.extend_from_slice(&height.to_be_bytes());
    ihdr.extend_from_slice(&[8, if channels == 4 { 6 } else { 2 }, 0, 0, 0]);
    chunk(b"IHDR", &ihdr);
    chunk(b"IDAT", &z);
    chunk(b"IEND", &[]);
    out
}
