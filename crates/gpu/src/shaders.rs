//! Shared WGSL, composed by concatenation.
//!
//! Each shared file holds one concern — `common.wgsl` (constants, helpers),
//! `light.wgsl` (primary-light radiometry), `projection.wgsl` (the light
//! view of shadow maps and RSMs) — and a pass's own `.wgsl` file, kept next
//! to the Rust that owns it, is appended after the parts it needs. One WGSL
//! definition of each projection thus serves both the bake and the runtime.

/// Constants and helpers.
pub const COMMON: &str = include_str!("wgsl/common.wgsl");
/// Primary-light radiometry (needs [`COMMON`]).
pub const LIGHT: &str = include_str!("wgsl/light.wgsl");
/// Light-view projection and shadow lookup (needs [`COMMON`]).
pub const PROJECTION: &str = include_str!("wgsl/projection.wgsl");

/// VPL hemisphere-map projection (needs [`COMMON`]).
pub const HEMISPHERE: &str = include_str!("wgsl/hemisphere.wgsl");

/// The shared parts in dependency order, for [`compose`].
pub const SHARED: &[&str] = &[COMMON, LIGHT, PROJECTION, HEMISPHERE];

/// Concatenates the shared WGSL with a pass's own source.
pub fn compose(own: &str) -> String {
    let mut s = String::new();
    for part in SHARED {
        s.push_str(part);
        s.push('\n');
    }
    s.push_str(own);
    s
}

/// [`compose`] for a pass that draws scene meshes: the shared parts, the
/// mesh interface (`mesh.wgsl`: vertex input, per-draw data), then `own`.
pub fn compose_mesh(own: &str) -> String {
    compose(&format!("{}\n{own}", crate::mesh::MESH_WGSL))
}

/// Creates a shader module from a mesh-drawing pass's WGSL
/// ([`compose_mesh`]).
pub fn mesh_module(device: &wgpu::Device, label: &str, own: &str) -> wgpu::ShaderModule {
    device.create_shader_module(wgpu::ShaderModuleDescriptor {
        label: Some(label),
        source: wgpu::ShaderSource::Wgsl(compose_mesh(own).into()),
    })
}

/// Creates a shader module from a pass's WGSL composed with the shared parts.
pub fn module(device: &wgpu::Device, label: &str, own: &str) -> wgpu::ShaderModule {
    device.create_shader_module(wgpu::ShaderModuleDescriptor {
        label: Some(label),
        source: wgpu::ShaderSource::Wgsl(compose(own).into()),
    })
}

/// Parses and validates composed WGSL with naga (used by every crate's
/// shader tests; returns the error text on failure).
pub fn validate(source: &str) -> Result<naga::Module, String> {
    let module = naga::front::wgsl::parse_str(source).map_err(|e| e.emit_to_string(source))?;
    let mut v = naga::valid::Validator::new(
        naga::valid::ValidationFlags::all(),
        naga::valid::Capabilities::all(),
    );
    v.validate(&module).map_err(|e| e.emit_to_string(source))?;
    Ok(module)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn pass_shaders_validate() {
        for (name, own) in [
            ("shadow.wgsl", include_str!("passes/shadow.wgsl")),
            ("hemi_raster.wgsl", include_str!("passes/hemi_raster.wgsl")),
        ] {
            if let Err(e) = validate(&compose_mesh(own)) {
                panic!("{name} does not validate:\n{e}");
            }
        }
    }

    #[test]
    fn shared_wgsl_validates() {
        // A trivial entry point so that every shared function gets type-checked.
        let probe = r#"
@group(0) @binding(0) var<uniform> lv: LightView;
@group(0) @binding(1) var<uniform> pl: PrimaryLight;
@group(0) @binding(2) var map: texture_2d<f32>;
@group(0) @binding(3) var<storage, read_write> out: array<f32>;
@compute @workgroup_size(1)
fn main() {
    let p = vec3<f32>(1.0, 2.0, 3.0);
    let inc = light_incident(pl, p);
    out[0] = lv_visibility(lv, map, map, true, vec4<i32>(0), p, vec3<f32>(0.0, 1.0, 0.0), inc.wi) + inc.irradiance.x;
    out[1] = oct_decode(oct_encode(normalize(p))).x;
    out[2] = hemi_texel_coords(normalize(p), hemi_decode(vec2<f32>(0.1, 0.2)), 128.0).x;
    out[3] = vpl_origin(p, normalize(p), 2.0).x;
}
"#;
        if let Err(e) = validate(&compose(probe)) {
            panic!("shared WGSL does not validate:\n{e}");
        }
    }
}
