//! BLAKE3 hash of the static part of a scene: what a baked asset depends on.
//! Covers the primary lights, the bake volume, static meshes (positions,
//! normals, uvs, indices), their materials (albedo, alpha mode and cutoff)
//! and textures. Moving objects, the camera and animations are not part of
//! it: an asset stays valid when they change.
//!
//! What the importer applies at import is covered through the data it
//! produces: `KHR_texture_transform` through the transformed texture
//! coordinates, decoded meshopt/WebP data through the meshes and texels,
//! instancing through the expanded meshes. An opaque material hashes as it
//! did before alpha existed, so assets baked before it stay up to date.

use crate::{AlphaMode, LightKind, Scene};

/// Hash of the static part of `scene` (bit-exact over the f32 data).
pub fn static_scene_hash(scene: &Scene) -> [u8; 32] {
    let mut h = blake3::Hasher::new();
    h.update(b"gibake static scene v1");
    // The first light hashes as the single primary light always did (an
    // asset baked before lights had ranges or company stays up to date);
    // a range, a point light and every further light add their bytes.
    for (i, l) in scene.lights.iter().enumerate() {
        if i > 0 {
            h.update(b"light");
        }
        match l.kind {
            LightKind::Spot {
                inner_cone,
                outer_cone,
            } => {
                h.update(b"spot");
                h.update(&inner_cone.to_le_bytes());
                h.update(&outer_cone.to_le_bytes());
            }
            LightKind::Directional => {
                h.update(b"directional");
            }
            LightKind::Point => {
                h.update(b"point");
            }
        }
        for v in [l.color, l.position, l.direction] {
            for c in v.to_array() {
                h.update(&c.to_le_bytes());
            }
        }
        if let Some(r) = l.range {
            h.update(b"range");
            h.update(&r.to_le_bytes());
        }
    }
    if let Some(v) = &scene.bake_volume {
        h.update(b"bake volume");
        h.update(&f32_bytes(
            v.min.to_array().into_iter().chain(v.max.to_array()),
        ));
    }
    h.update(&(scene.static_meshes.len() as u64).to_le_bytes());
    for m in &scene.static_meshes {
        h.update(&(m.positions.len() as u64).to_le_bytes());
        h.update(&f32_bytes(m.positions.iter().flat_map(|p| p.to_array())));
        h.update(&f32_bytes(m.normals.iter().flat_map(|p| p.to_array())));
        if let Some(uv) = &m.uvs {
            h.update(&f32_bytes(uv.iter().flat_map(|p| p.to_array())));
        }
        h.update(&(m.indices.len() as u64).to_le_bytes());
        h.update(
            &m.indices
                .iter()
                .flat_map(|i| i.to_le_bytes())
                .collect::<Vec<u8>>(),
        );
        let mat = &scene.materials[m.material];
        h.update(&f32_bytes(mat.base_color.to_array()));
        if let AlphaMode::Mask { cutoff } = mat.alpha_mode {
            h.update(b"alpha mask");
            h.update(&f32_bytes([cutoff, mat.alpha]));
        }
        if let Some(t) = mat.texture {
            let t = &scene.textures[t];
            h.update(&t.width.to_le_bytes());
            h.update(&t.height.to_le_bytes());
            h.update(&t.rgba8_srgb);
        }
    }
    *h.finalize().as_bytes()
}

fn f32_bytes(v: impl IntoIterator<Item = f32>) -> Vec<u8> {
    v.into_iter().flat_map(|f| f.to_le_bytes()).collect()
}
