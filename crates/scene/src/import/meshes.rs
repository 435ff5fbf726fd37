//! Meshes: reads a glTF mesh's triangle primitives (positions, normals,
//! texture coordinates, indices, material) and flattens static ones into
//! world space.

use glam::{Mat3, Mat4, Vec3};
use gltf::json;
use gltf::json::validation::Checked;

use super::accessors::{vec2s, vec3s};
use super::materials::albedo_info;
use super::texture_transform::UvTransform;
use super::{Ctx, MaterialTable, PrimData};
use crate::mesh::compute_normals;
use crate::{Mesh, SceneError};

impl<'a> Ctx<'a> {
    /// Reads all usable primitives of mesh `mi` (node-local space).
    pub(super) fn read_mesh(
        &mut self,
        mi: usize,
        node_label: &str,
        table: &mut MaterialTable,
    ) -> Result<Vec<(String, PrimData)>, SceneError> {
        let root = self.root;
        let mesh = root
            .meshes
            .get(mi)
            .ok_or_else(|| self.invalid(format!("mesh {mi} does not exist")))?;
        let mesh_label = self.mesh_name(mi);
        let mut out = Vec::new();
        for (pi, prim) in mesh.primitives.iter().enumerate() {
            let name = format!("{node_label}/{mesh_label}/{pi}");
            if let Some(p) = self.read_primitive(prim, &name, table)? {
                out.push((name, p));
            }
        }
        Ok(out)
    }

    pub(super) fn read_primitive(
        &mut self,
        prim: &json::mesh::Primitive,
        name: &str,
        table: &mut MaterialTable,
    ) -> Result<Option<PrimData>, SceneError> {
        use json::mesh::{Mode, Semantic};
        let mode = match prim.mode {
            Checked::Valid(m) => m,
            Checked::Invalid => {
                self.warn(format!("mesh {name}: invalid primitive mode, skipped"));
                return Ok(None);
            }
        };
        if !matches!(
            mode,
            Mode::Triangles | Mode::TriangleStrip | Mode::TriangleFan
        ) {
            self.warn(format!(
                "mesh {name}: primitive mode {mode:?} is not triangles, skipped"
            ));
            return Ok(None);
        }
        if prim.targets.as_ref().is_some_and(|t| !t.is_empty()) {
            self.warn(format!("mesh {name}: morph targets ignored"));
        }
        let attr = |s: Semantic| prim.attributes.get(&Checked::Valid(s)).map(|i| i.value());
        let Some(pos_acc) = attr(Semantic::Positions) else {
            self.warn(format!("mesh {name}: primitive has no POSITION, skipped"));
            return Ok(None);
        };
        let (pos, vcount) = self
            .read_floats(pos_acc, 3)
            .map_err(|e| self.acc_err(name, pos_acc, "POSITION", e))?;
        if let Some(bad) = pos.iter().position(|x| !x.is_finite()) {
            return Err(self.acc_err(
                name,
                pos_acc,
                "POSITION",
                format!("vertex {} is not finite (NaN or infinite)", bad / 3),
            ));
        }
        let positions = vec3s(&pos);

        // Indices.
        let raw_indices: Vec<u32> = match prim.indices {
            Some(ia) => {
                let ia = ia.value();
                let raw = self
                    .read_accessor(ia)
                    .map_err(|e| self.acc_err(name, ia, "indices", e))?;
                if raw.dims != 1 {
                    return Err(self.acc_err(
                        name,
                        ia,
                        "indices",
                        "indices must be scalars".into(),
                    ));
                }
                let idx = raw
                    .uints()
                    .map_err(|e| self.acc_err(name, ia, "indices", e))?;
                if let Some(&bad) = idx.iter().find(|&&i| i as usize >= vcount) {
                    return Err(self.acc_err(
                        name,
                        ia,
                        "indices",
                        format!("index {bad} is out of range ({vcount} vertices)"),
                    ));
                }
                idx
            }
            None => {
                let n = u32::try_from(vcount).map_err(|_| {
                    self.acc_err(name, pos_acc, "POSITION", "too many vertices".into())
                })?;
                (0..n).collect()
            }
        };
        let mut indices = match mode {
            Mode::Triangles => {
                if !raw_indices.len().is_multiple_of(3) {
                    self.warn(format!(
                        "mesh {name}: {} indices is not a multiple of 3, the last {} ignored",
                        raw_indices.len(),
                        raw_indices.len() % 3
                    ));
                }
                let mut v = raw_indices;
                v.truncate(v.len() / 3 * 3);
                v
            }
            Mode::TriangleStrip => {
                let mut v = Vec::with_capacity(raw_indices.len().saturating_sub(2) * 3);
                for i in 0..raw_indices.len().saturating_sub(2) {
                    if i % 2 == 0 {
                        v.extend_from_slice(&[
                            raw_indices[i],
                            raw_indices[i + 1],
                            raw_indices[i + 2],
                        ]);
                    } else {
                        v.extend_from_slice(&[
                            raw_indices[i],
                            raw_indices[i + 2],
                            raw_indices[i + 1],
                        ]);
                    }
                }
                v
            }
            _ => {
                // Triangle fan.
                let mut v = Vec::with_capacity(raw_indices.len().saturating_sub(2) * 3);
                for i in 0..raw_indices.len().saturating_sub(2) {
                    v.extend_from_slice(&[raw_indices[i + 1], raw_indices[i + 2], raw_indices[0]]);
                }
                v
            }
        };
        if indices.is_empty() {
            self.warn(format!("mesh {name}: primitive has no triangles, skipped"));
            return Ok(None);
        }
        indices.shrink_to_fit();

        // Normals.
        let normals = match attr(Semantic::Normals) {
            None => None,
            Some(na) => {
                let (nf, ncount) = self
                    .read_floats(na, 3)
                    .map_err(|e| self.acc_err(name, na, "NORMAL", e))?;
                if ncount != vcount {
                    return Err(self.acc_err(
                        name,
                        na,
                        "NORMAL",
                        format!("{ncount} normals for {vcount} vertices"),
                    ));
                }
                let nv = vec3s(&nf);
                let unit: Option<Vec<Vec3>> = nv.iter().map(|n| n.try_normalize()).collect();
                if unit.is_none() {
                    self.warn(format!(
                        "mesh {name}: NORMAL (accessor {na}) has zero or non-finite normals, recomputed"
                    ));
                }
                unit
            }
        };

        // Material and texture coordinates (KHR_texture_transform applied).
        let mat_index = prim.material.map(|m| m.value());
        let mut tex = None;
        if let Some(mi) = mat_index {
            let m = self.root.materials.get(mi).ok_or_else(|| {
                self.invalid(format!("mesh {name}: material {mi} does not exist"))
            })?;
            if let Some(info) = albedo_info(m) {
                let (transform, set) = match UvTransform::of(info) {
                    Ok(Some((t, set))) => (Some(t), set.unwrap_or(info.tex_coord)),
                    Ok(None) => (None, info.tex_coord),
                    Err(e) => {
                        let mname = m.name.clone().unwrap_or_else(|| format!("material #{mi}"));
                        return Err(self.invalid(format!("material '{mname}': {e}")));
                    }
                };
                tex = Some((info.index.value(), set, transform));
            }
        }
        let mut uvs = None;
        if let Some((_, set, transform)) = tex {
            match attr(Semantic::TexCoords(set)) {
                None => {
                    self.warn(format!(
                        "mesh {name}: the material has a base colour texture but the primitive has no TEXCOORD_{set}; drawn untextured"
                    ));
                }
                Some(ua) => {
                    let what = format!("TEXCOORD_{set}");
                    let (uf, ucount) = self
                        .read_floats(ua, 2)
                        .map_err(|e| self.acc_err(name, ua, &what, e))?;
                    if ucount != vcount {
                        return Err(self.acc_err(
                            name,
                            ua,
                            &what,
                            format!("{ucount} texture coordinates for {vcount} vertices"),
                        ));
                    }
                    let mut uv = vec2s(&uf);
                    if let Some(t) = transform {
                        for x in &mut uv {
                            *x = t.apply(*x);
                        }
                    }
                    if uv.iter().any(|x| !x.is_finite()) {
                        return Err(self.acc_err(
                            name,
                            ua,
                            &what,
                            "texture coordinates are not finite (after KHR_texture_transform)"
                                .into(),
                        ));
                    }
                    uvs = Some(uv);
                }
            }
        }
        let material = self.material(
            mat_index,
            if uvs.is_some() {
                tex.map(|t| t.0)
            } else {
                None
            },
            table,
        )?;
        Ok(Some(PrimData {
            positions,
            normals,
            uvs,
            indices,
            material,
        }))
    }

    /// Flattens a primitive to world space with `world`.
    pub(super) fn flatten(
        &self,
        name: String,
        p: PrimData,
        world: Mat4,
    ) -> Result<Mesh, SceneError> {
        let positions: Vec<Vec3> = p
            .positions
            .iter()
            .map(|&q| world.transform_point3(q))
            .collect();
        if positions.iter().any(|q| !q.is_finite()) {
            return Err(self.invalid(format!(
                "mesh {name}: world-space positions overflow (node transforms too large)"
            )));
        }
        let mut indices = p.indices;
        let m3 = Mat3::from_mat4(world);
        let det = m3.determinant();
        if det < 0.0 {
            for t in indices.chunks_exact_mut(3) {
                t.swap(1, 2);
            }
        }
        let normal_matrix = m3.inverse().transpose();
        let normals = match p.normals {
            Some(nr) if det != 0.0 && normal_matrix.is_finite() => {
                let out: Vec<Vec3> = nr
                    .iter()
                    .map(|&n| (normal_matrix * n).normalize_or_zero())
                    .collect();
                if out.iter().all(|n| n.length_squared() > 0.0) {
                    out
                } else {
                    compute_normals(&positions, &indices)
                }
            }
            _ => compute_normals(&positions, &indices),
        };
        Ok(Mesh {
            name,
            positions,
            normals,
            uvs: p.uvs,
            indices,
            material: p.material,
        })
    }
}
