//! The reflective shadow map (RSM) of the static geometry, as read back to
//! the CPU for clustering.

use crate::reach::Reach;
use gibake_gpu::LightView;
use gibake_raycast::RayScene;
use gibake_scene::Light;
use glam::Vec3;
use rayon::prelude::*;

/// A reflective shadow map: one entry per texel, row-major, row 0 at the
/// top (texel `(x, y)` is at index `y * size + x`). A texel with no surface
/// has `metric = f32::INFINITY` and zeros elsewhere.
#[derive(Clone, Debug)]
pub struct Rsm {
    /// Width and height in texels.
    pub size: u32,
    /// The light view it was rendered with.
    pub view: LightView,
    /// The projection's metric (distance to a spot light; depth along a
    /// directional light), `INFINITY` where no surface.
    pub metric: Vec<f32>,
    /// World position of the surface seen by the texel.
    pub position: Vec<Vec3>,
    /// Unit geometric normal of that surface, facing the light: the normal
    /// the texel emits about. A Lambertian surface's radiance leaves the
    /// facet that is there, so its intensity towards `ω` is `Φ/π ·
    /// max(n_g·ω, 0)`, as the reference's bounce has it; the shading normal
    /// sets only its irradiance, hence [`Rsm::flux`].
    pub normal: Vec<Vec3>,
    /// Reflected flux (W, linear RGB): spot `albedo · I(ω) · Ω_texel`,
    /// directional `albedo · E · A_texel`.
    pub flux: Vec<Vec3>,
    /// Surface area the texel covers (world units²).
    pub area: Vec<f32>,
    /// Fraction of the texel's reflected light that reaches a surface
    /// ([`crate::reach`]; 1 where it was not measured). The clustering
    /// spends its budget by `flux · reach`.
    pub reach: Vec<f32>,
}

impl Rsm {
    /// A `size²` map of `view` where no texel sees a surface (reach 1).
    pub fn empty(size: u32, view: LightView) -> Rsm {
        let n = (size as usize) * (size as usize);
        Rsm {
            size,
            view,
            metric: vec![f32::INFINITY; n],
            position: vec![Vec3::ZERO; n],
            normal: vec![Vec3::ZERO; n],
            flux: vec![Vec3::ZERO; n],
            area: vec![0.0; n],
            reach: vec![1.0; n],
        }
    }

    /// Whether texel `i` sees a surface.
    pub fn is_valid(&self, i: usize) -> bool {
        self.metric[i].is_finite()
    }

    /// World size of one texel at texel `i`'s surface (see
    /// [`LightView::footprint`]).
    pub fn footprint(&self, i: usize) -> f32 {
        self.view.footprint(self.position[i])
    }
}

/// One RSM texel: metric, position, normal, flux, area, reach.
type TexelSample = (f32, Vec3, Vec3, Vec3, f32, f32);

/// Smallest cosine between a surface and the light used for the area a
/// texel covers (dimensionless, so scale-invariant): grazing texels would
/// otherwise claim unbounded area.
pub const MIN_AREA_COSINE: f32 = 0.05;

/// Renders the RSM of the static geometry in `rays` by casting one ray per
/// texel centre (exact and deterministic on every machine). Radiometry:
/// spot and point `Φ = albedo · I(ω) · att(ω, d) · Ω_texel · s`, directional `Φ = albedo · E ·
/// A_texel · s`, `s = cos_s / cos_g` the shading normal's cosine over the
/// geometric one (1 on flat-shaded surfaces; at most `1/MIN_AREA_COSINE`);
/// area `= Ω·d²/cos θ` (spot) or `A_texel/cos θ` (directional), with
/// `cos θ ≥` [`MIN_AREA_COSINE`]. With `reach`, each lit texel's
/// [`Rsm::reach`] is measured ([`Reach::texel_reach`]); without, it is 1.
pub fn render_rsm(
    rays: &RayScene<'_>,
    light: &Light,
    view: &LightView,
    reach: Option<&Reach<'_, '_>>,
) -> Rsm {
    render_rsm_masked(rays, light, view, reach, &|_, _| false)
}

/// [`render_rsm`] with the texels `(x, y)` for which `masked` holds left
/// empty (no surface, no ray cast): an outer ring's part that the next
/// smaller view covers ([`crate::rings`]).
pub fn render_rsm_masked(
    rays: &RayScene<'_>,
    light: &Light,
    view: &LightView,
    reach: Option<&Reach<'_, '_>>,
    masked: &(dyn Fn(u32, u32) -> bool + Sync),
) -> Rsm {
    let size = view.size;
    let n = (size * size) as usize;
    let rows: Vec<Vec<TexelSample>> = (0..size)
        .into_par_iter()
        .map(|y| {
            (0..size)
                .map(|x| {
                    let (o, d) = view.texel_ray(x, y);
                    let hit = if masked(x, y) {
                        None
                    } else {
                        rays.intersect(o, d, f32::INFINITY)
                    };
                    let Some(hit) = hit else {
                        return (f32::INFINITY, Vec3::ZERO, Vec3::ZERO, Vec3::ZERO, 0.0, 0.0);
                    };
                    let p = hit.position;
                    let ns = hit.shading_normal;
                    let cos_g = hit.geometric_normal.dot(-d);
                    // The shading normal's irradiance over the geometric
                    // area (as the reference and the runtime shade):
                    // cos_s / cos_g, 1 on flat-shaded surfaces, bounded.
                    let shading = (ns.dot(-d).max(0.0) / cos_g.max(f32::MIN_POSITIVE))
                        .min(1.0 / MIN_AREA_COSINE);
                    let cos_a = cos_g.max(MIN_AREA_COSINE);
                    let measure = view.texel_measure(d);
                    let (flux, area) = if view.directional {
                        (
                            hit.albedo * light.color * (measure * shading),
                            measure / cos_a,
                        )
                    } else {
                        let dist = (p - light.position).length();
                        let i = light.color * light.attenuation(d, dist);
                        (
                            hit.albedo * i * (measure * shading),
                            measure * dist * dist / cos_a,
                        )
                    };
                    let flux = if flux.is_finite() { flux } else { Vec3::ZERO };
                    let area = if area.is_finite() { area } else { 0.0 };
                    let lit = flux.max_element() > 0.0;
                    let r = match reach {
                        Some(r) if lit => {
                            let index = u64::from(y) * u64::from(size) + u64::from(x);
                            r.texel_reach(index, p, hit.geometric_normal)
                        }
                        _ => 1.0,
                    };
                    (view.metric(p), p, hit.geometric_normal, flux, area, r)
                })
                .collect()
        })
        .collect();
    let mut rsm = Rsm {
        size,
        view: *view,
        metric: Vec::with_capacity(n),
        position: Vec::with_capacity(n),
        normal: Vec::with_capacity(n),
        flux: Vec::with_capacity(n),
        area: Vec::with_capacity(n),
        reach: Vec::with_capacity(n),
    };
    for row in rows {
        for (m, p, nn, f, a, r) in row {
            rsm.metric.push(m);
            rsm.position.push(p);
            rsm.normal.push(nn);
            rsm.flux.push(f);
            rsm.area.push(a);
            rsm.reach.push(r);
        }
    }
    rsm
}
