//! The reference's direct-light estimate: irradiance from the primary lights
//! at a surface point with its exact shadow ray, and the outgoing radiance
//! `albedo/π · E`. This is light transport, so it lives here and not in the
//! ray caster that the bake shares (`gibake-raycast`).

use gibake_raycast::{Hit, RayScene, sanitize};
use gibake_scene::{Light, LightKind};
use glam::Vec3;

/// Irradiance `E` (W/m², RGB) arriving from every primary light of `rs`'s
/// scene at surface point `p` with geometric normal `ng` and shading normal
/// `ns`, each shadowed: the sum of [`light_irradiance`] over the lights
/// (light transport is linear in the lights).
pub fn irradiance(rs: &RayScene<'_>, p: Vec3, ng: Vec3, ns: Vec3) -> Vec3 {
    let mut sum = glam::DVec3::ZERO;
    for light in &rs.scene().lights {
        sum += light_irradiance(rs, light, p, ng, ns).as_dvec3();
    }
    sanitize(sum)
}

/// Irradiance from one light at `p`, shadowed. The cosine is the shading
/// normal's, as engines use it: a light behind the geometric plane but in
/// front of the shading normal (the terminator of a smooth-shaded low-poly
/// surface) still lights the point if the shadow ray, offset to the light's
/// side of the surface, reaches it.
///
/// Spot and point: `E = I · attenuation(−ω, d) · max(0, ns·ω) / d²` (spot
/// falloff times glTF's range window, [`Light::attenuation`]).
/// Directional: `ω = −direction`, `E = E₀ · max(0, ns·ω)`.
pub fn light_irradiance(rs: &RayScene<'_>, light: &Light, p: Vec3, ng: Vec3, ns: Vec3) -> Vec3 {
    match light.kind {
        LightKind::Spot { .. } | LightKind::Point => {
            let l = light.position - p;
            let d2 = l.as_dvec3().length_squared();
            if !(d2 > 0.0 && d2.is_finite()) {
                return Vec3::ZERO;
            }
            let d = d2.sqrt();
            let w = (l.as_dvec3() / d).as_vec3();
            let cos_g = ng.dot(w);
            let cos_s = ns.dot(w).max(0.0);
            if cos_g.is_nan() || cos_s <= 0.0 {
                return Vec3::ZERO;
            }
            let att = light.attenuation(-w, d as f32);
            if att.is_nan() || att <= 0.0 {
                return Vec3::ZERO;
            }
            let origin = rs.offset_point(p, toward(ng, cos_g));
            let to_light = light.position - origin;
            let dist = to_light.length();
            if !(dist > 0.0 && dist.is_finite()) {
                return Vec3::ZERO;
            }
            // Stop a few ULPs short of the light, so a light lying on a
            // surface is not shadowed by that surface.
            let t_max = dist - rs.end_margin(light.position);
            if t_max > 0.0 && rs.occluded(origin, to_light / dist, t_max) {
                return Vec3::ZERO;
            }
            sanitize(light.color.as_dvec3() * (att as f64 * cos_s as f64 / d2))
        }
        LightKind::Directional => {
            let w = (-light.direction).normalize_or_zero();
            let cos_g = ng.dot(w);
            let cos_s = ns.dot(w).max(0.0);
            if cos_g.is_nan() || cos_s <= 0.0 {
                return Vec3::ZERO;
            }
            let origin = rs.offset_point(p, toward(ng, cos_g));
            if rs.occluded(origin, w, f32::INFINITY) {
                return Vec3::ZERO;
            }
            sanitize(light.color.as_dvec3() * cos_s as f64)
        }
    }
}

/// The geometric normal on the light's side (`cos_g = ng · ω`): the side a
/// shadow ray starts from.
fn toward(ng: Vec3, cos_g: f32) -> Vec3 {
    if cos_g < 0.0 { -ng } else { ng }
}

/// Outgoing radiance at `hit` due to the primary lights alone:
/// `albedo/π · E` ([`irradiance`], with the hit's normals).
pub fn direct_radiance(rs: &RayScene<'_>, hit: &Hit) -> Vec3 {
    let e = irradiance(rs, hit.position, hit.geometric_normal, hit.shading_normal);
    sanitize(hit.albedo.as_dvec3() * std::f64::consts::FRAC_1_PI * e.as_dvec3())
}
