//! Reading back generated GLB files: the JSON chunk, the BIN chunk, and
//! triangle counts of the static and dynamic parts (for tests and benchmarks;
//! not a glTF importer).

use serde_json::Value;

/// The parsed JSON chunk and the BIN chunk (empty if absent) of a GLB file.
pub fn split_glb(glb: &[u8]) -> Result<(Value, &[u8]), String> {
    let u32_at = |o: usize| -> Result<usize, String> {
        let b = glb.get(o..o + 4).ok_or("GLB truncated")?;
        Ok(u32::from_le_bytes([b[0], b[1], b[2], b[3]]) as usize)
    };
    if glb.get(0..4) != Some(b"glTF") || u32_at(4)? != 2 {
        return Err("not a glTF 2.0 GLB".into());
    }
    if u32_at(8)? != glb.len() {
        return Err("GLB length field does not match".into());
    }
    let json_len = u32_at(12)?;
    if glb.get(16..20) != Some(b"JSON") {
        return Err("first GLB chunk is not JSON".into());
    }
    let json_bytes = glb.get(20..20 + json_len).ok_or("JSON chunk truncated")?;
    let json: Value = serde_json::from_slice(json_bytes).map_err(|e| format!("JSON chunk: {e}"))?;
    let mut bin: &[u8] = &[];
    let o = 20 + json_len;
    if o < glb.len() {
        let len = u32_at(o)?;
        if glb.get(o + 4..o + 8) != Some(b"BIN\0") {
            return Err("second GLB chunk is not BIN".into());
        }
        bin = glb.get(o + 8..o + 8 + len).ok_or("BIN chunk truncated")?;
    }
    Ok((json, bin))
}

/// Triangle counts of a glTF document's default scene, split by the design's
/// rule: a node is dynamic if it or an ancestor is targeted by an animation
/// channel or has `extras.dynamic == true`.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct TriangleCounts {
    /// Triangles of static mesh instances.
    pub static_tris: u64,
    /// Triangles of dynamic mesh instances.
    pub dynamic_tris: u64,
}

/// Counts the triangles of every mesh instance in the GLB's default scene.
pub fn triangle_counts(glb: &[u8]) -> Result<TriangleCounts, String> {
    let (j, _) = split_glb(glb)?;
    let animated: Vec<u64> = j["animations"]
        .as_array()
        .into_iter()
        .flatten()
        .flat_map(|a| a["channels"].as_array().into_iter().flatten())
        .filter_map(|c| c["target"]["node"].as_u64())
        .collect();
    let mesh_tris = |m: u64| -> u64 {
        j["meshes"][m as usize]["primitives"]
            .as_array()
            .into_iter()
            .flatten()
            .map(|p| {
                let mode = p["mode"].as_u64().unwrap_or(4);
                let count = match p["indices"].as_u64() {
                    Some(a) => j["accessors"][a as usize]["count"].as_u64().unwrap_or(0),
                    None => {
                        let pos = p["attributes"]["POSITION"].as_u64().unwrap_or(u64::MAX);
                        j["accessors"][pos as usize]["count"].as_u64().unwrap_or(0)
                    }
                };
                if mode == 4 { count / 3 } else { 0 }
            })
            .sum()
    };
    let mut out = TriangleCounts::default();
    let scene = j["scene"].as_u64().unwrap_or(0) as usize;
    let mut stack: Vec<(u64, bool)> = j["scenes"][scene]["nodes"]
        .as_array()
        .into_iter()
        .flatten()
        .filter_map(Value::as_u64)
        .map(|n| (n, false))
        .collect();
    while let Some((n, parent_dynamic)) = stack.pop() {
        let node = &j["nodes"][n as usize];
        let dynamic = parent_dynamic
            || animated.contains(&n)
            || node["extras"]["dynamic"] == Value::Bool(true);
        if let Some(m) = node["mesh"].as_u64() {
            let t = mesh_tris(m);
            if dynamic {
                out.dynamic_tris += t;
            } else {
                out.static_tris += t;
            }
        }
        for c in node["children"]
            .as_array()
            .into_iter()
            .flatten()
            .filter_map(Value::as_u64)
        {
            stack.push((c, dynamic));
        }
    }
    Ok(out)
}
