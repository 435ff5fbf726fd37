//! Which part of a level the directional light's maps cover.
//!
//! A directional light's shadow map and RSM are orthographic views along
//! the light. Fitted to every vertex, one distant ground plane (a town's
//! 2 km outer ground, a skybox floor) makes every texel coarse: on a real
//! level the shadow texel grew to 1.3 m and the RSM texel to 5.3 m, and
//! shadows leaked. [`fit`] chooses the view's extent across the light (its
//! light-space `x, y`) from the geometry that matters:
//!
//! 1. a **bake volume** the artist gives ([`Scene::bake_volume`]: a glTF
//!    node marked `extras: {"bake_volume": true}`, or `--bake-volume`),
//!    else
//! 2. the static triangles **without outliers**. A triangle spanning at
//!    least a quarter of the full extent is *large*; the *core* is the
//!    extent of all the others. When the full extent is more than
//!    `OUTLIER_RATIO` = 64 times the core on an axis — or more than
//!    `GROUND_RATIO` = 8 times and the large triangles are a **ground**
//!    (all parallel within 10°: one plane, or parallel terraces) — the
//!    large triangles are outliers (a 2 km ground plane around a 100 m
//!    town); the view then covers the core grown by a quarter of its size
//!    per side,
//!    and the large triangles are clipped to it. Triangles wholly outside
//!    are left out: they get no shadow and no VPL (their direct light is
//!    unshadowed), and [`LightFit::left_out`] counts them for a warning.
//!    A room of six quads around a detailed object is at most a few times
//!    its core and keeps the full extent; a room 12× its one panel keeps it
//!    too (its walls are not parallel to its floor: the walls are where the
//!    panel's light lands, and the seeded generator's seed 4 failed ±5%
//!    when they were cut); a bare hall 64× wider than its one detailed
//!    statue would be cut — hence the warning, and the bake volume to say
//!    otherwise. Why a ground may go at 8×: the light a lit plane sends to
//!    a point at height `h` above it from beyond distance `R` is a fraction
//!    `h²/(h² + R²)` of what the whole plane sends, small once `R` is the
//!    core's quarter-size margin and `h` within the core; walls around the
//!    core face it and cannot be judged so. (That bound is for a receiver
//!    facing up; an object's *side* at height `h` gets about `1.3 h/R` of
//!    its ground light from beyond `R`, so objects on a cut ground lose some
//!    bounce light: 3–5% on the real levels where this rule cuts, measured
//!    by `rsm_ceiling` in gibake-eval; docs/method.md.)
//!
//! Either way the moving objects' swept bounds are added (the runtime merges
//! them into the same maps), and the depth range along the light always
//! covers *every* static surface, so a caster outside the fitted extent
//! still shadows what is inside it. An orthographic view keeps a caster
//! and its shadow at the same light-space `x, y`, so no shadow cast inside
//! the extent is lost. Everything is dimensionless (fractions of extents):
//! the same level in millimetres gets the same fit.
//!
//! Spot lights keep their cone (the map's extent is the cone, not the
//! geometry); their far plane covers every surface.

use gibake_scene::{Aabb, LightKind, Scene};
use glam::Vec3;

use crate::light_view::orthonormal_basis;

/// A triangle spanning at least this fraction of the full extent (on
/// either axis across the light) is large: a candidate outlier.
pub const LARGE_TRIANGLE: f32 = 0.25;

/// The full extent counts as outlier-free while it is at most this many
/// times the core (the extent of the triangles that are not large) on both
/// axes. It was 8: a generated room with one panel inside (the seeded
/// generator's seed 4) lost its floor and walls from the maps and its
/// indirect light fell outside ±5%; a level whose ground is 8–64× its
/// detailed part needs `--bake-volume`.
pub const OUTLIER_RATIO: f32 = 64.0;

/// The full extent counts as outlier-free while it is at most this many
/// times the core when the large triangles are a ground (all parallel
/// within `GROUND_COS`). A real town's 16-triangle outer ground is 16.8×
/// its houses and trees; the seeded generator's seed 4 (a room 12.5× its
/// panel) has walls, not a ground.
pub const GROUND_RATIO: f32 = 8.0;

/// Large triangles whose normals are all within this cosine (10°) of the
/// largest one's, either side, are a ground.
pub const GROUND_COS: f32 = 0.985;

/// Growth of the core on each side when outliers are cut, as a fraction of
/// its size.
pub const OUTLIER_MARGIN: f32 = 0.25;

/// At most this many outer rings ([`LightFit::rings`]): ring `j` is `2^j`
/// times the view's width, so four cover a ground 16 times the view. Beyond
/// that a ground sends an object's side (height `h`) about `1.3 h / R` of
/// its light from beyond `R`: under 2% of an object as tall as a sixteenth
/// of the view is wide.
pub const MAX_RINGS: u32 = 4;

/// Where the view's extent across the light came from.
#[derive(Clone, Debug, PartialEq)]
pub enum FitSource {
    /// Every static surface (no outlier, or a spot light).
    All,
    /// The scene's bake volume.
    BakeVolume,
    /// The static triangles without outliers.
    WithoutOutliers,
}

/// A directional view's box in light space: `x, y` across the light (along
/// [`orthonormal_basis`] of its direction), `z` along it.
#[derive(Clone, Debug, PartialEq)]
pub struct LightFit {
    /// Light-space minimum.
    pub lo: Vec3,
    /// Light-space maximum.
    pub hi: Vec3,
    /// What decided `x, y`.
    pub source: FitSource,
    /// Static triangles wholly outside the extent across the light.
    pub left_out: usize,
    /// The first mesh with a triangle left out, for messages.
    pub left_out_mesh: Option<String>,
    /// Static triangles the extent across the light cuts (partly inside,
    /// partly outside: a ground plane round the core). Their part outside
    /// gets no shadow and reflects no VPL light, and the sides of objects
    /// near the extent's edge lose that part's bounce (module docs).
    pub clipped: usize,
    /// The first mesh with a triangle cut, for messages.
    pub clipped_mesh: Option<String>,
    /// The wider side across the light of every static surface (what
    /// [`LightFit::width`] is when nothing is cut).
    pub full_width: f32,
    /// Light-space `x, y` extent of every static surface (`z` unused).
    pub full_lo: Vec3,
    /// See [`LightFit::full_lo`].
    pub full_hi: Vec3,
    /// Whether what the extent cuts is a ground (the large triangles all
    /// parallel, [`GROUND_COS`]) rather than other outliers.
    pub ground: bool,
}

impl LightFit {
    /// The world-space width of the wider side across the light.
    pub fn width(&self) -> f32 {
        (self.hi.x - self.lo.x).max(self.hi.y - self.lo.y)
    }

    /// How many **outer rings** the cut ground gets (docs/method.md, "Outer
    /// rings"): none unless the extent cut a ground ([`LightFit::ground`],
    /// [`FitSource::WithoutOutliers`], a triangle clipped), else the fewest
    /// doublings of the view's square ([`LightFit::ring_box`]) that cover
    /// every static surface across the light, at most [`MAX_RINGS`].
    /// Outliers that are not a ground (a skybox, walls far away) get none:
    /// a ring's texels are taken to lie on flat ground (their VPLs' map
    /// origins sit one texel above it).
    pub fn rings(&self) -> u32 {
        self.rings_needed().min(MAX_RINGS)
    }

    /// Whether [`LightFit::rings`] cover every static surface across the
    /// light (false when [`MAX_RINGS`] stopped them short).
    pub fn rings_cover_all(&self) -> bool {
        self.rings_needed() <= MAX_RINGS
    }

    /// [`LightFit::rings`] without the [`MAX_RINGS`] cap (at most 31).
    fn rings_needed(&self) -> u32 {
        if self.source != FitSource::WithoutOutliers || !self.ground || self.clipped == 0 {
            return 0;
        }
        let c = (self.lo + self.hi) * 0.5;
        let half = 0.5 * self.width();
        let need = [
            c.x - self.full_lo.x,
            self.full_hi.x - c.x,
            c.y - self.full_lo.y,
            self.full_hi.y - c.y,
        ]
        .into_iter()
        .fold(0.0f32, f32::max);
        let mut rings = 0;
        while rings < 31 && half * (1u32 << rings) as f32 * 1.02 < need {
            rings += 1;
        }
        rings
    }

    /// The light-space box of ring `ring`'s view (0: the view's own square
    /// extent): the square `2^ring` times the wider side of
    /// [`LightFit::lo`]..[`LightFit::hi`], about its centre, with the same
    /// depth range. [`crate::LightView::directional`] of it is `2^ring`
    /// times the view's width, its texels aligned with the view's, so each
    /// ring's texels tile the part of its square that the next smaller one
    /// leaves out.
    pub fn ring_box(&self, ring: u32) -> (Vec3, Vec3) {
        let c = (self.lo + self.hi) * 0.5;
        let h = 0.5 * self.width() * (1u32 << ring.min(31)) as f32;
        (
            Vec3::new(c.x - h, c.y - h, self.lo.z),
            Vec3::new(c.x + h, c.y + h, self.hi.z),
        )
    }
}

fn to_light(p: Vec3, t: Vec3, b: Vec3, d: Vec3) -> Vec3 {
    Vec3::new(p.dot(t), p.dot(b), p.dot(d))
}

fn grow(lo: &mut Vec3, hi: &mut Vec3, p: Vec3) {
    *lo = lo.min(p);
    *hi = hi.max(p);
}

fn box_corners(b: &Aabb) -> impl Iterator<Item = Vec3> + '_ {
    (0..8).map(move |i| {
        Vec3::new(
            if i & 1 == 0 { b.min.x } else { b.max.x },
            if i & 2 == 0 { b.min.y } else { b.max.y },
            if i & 4 == 0 { b.min.z } else { b.max.z },
        )
    })
}

/// Whether the large triangles (their unnormalised normals) are a ground:
/// all parallel, either side, within [`GROUND_COS`] of the largest one's.
/// Zero-area triangles do not count; none left is no ground.
fn is_ground(normals: &[Vec3]) -> bool {
    let Some(reference) = normals
        .iter()
        .copied()
        .max_by(|a, b| a.length_squared().total_cmp(&b.length_squared()))
        .and_then(|n| n.try_normalize())
    else {
        return false;
    };
    normals.iter().all(|n| match n.try_normalize() {
        Some(u) => u.dot(reference).abs() >= GROUND_COS,
        None => true,
    })
}

/// The light-space box of the first light's view of `scene` when it is
/// directional ([`fit_light`]).
pub fn fit(scene: &Scene) -> Option<LightFit> {
    fit_light(scene, scene.light())
}

/// The light-space box of directional light `light`'s view of `scene` (see
/// the module docs). `None` for spot and point lights and scenes without
/// static vertices.
pub fn fit_light(scene: &Scene, light: &gibake_scene::Light) -> Option<LightFit> {
    if !matches!(light.kind, LightKind::Directional) {
        return None;
    }
    let d = light.direction.normalize();
    let (t, b) = orthonormal_basis(d);
    let (mut lo, mut hi) = (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY));
    // Every triangle's light-space box, and its (unnormalised) normal.
    let mut boxes = Vec::new();
    let mut normals = Vec::new();
    for m in &scene.static_meshes {
        for tri in m.indices.chunks_exact(3) {
            let [a, b2, c] = [0, 1, 2].map(|k| m.positions[tri[k] as usize]);
            normals.push((b2 - a).cross(c - a));
            let (mut tlo, mut thi) = (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY));
            for &i in tri {
                grow(
                    &mut tlo,
                    &mut thi,
                    to_light(m.positions[i as usize], t, b, d),
                );
            }
            grow(&mut lo, &mut hi, tlo);
            grow(&mut lo, &mut hi, thi);
            boxes.push((tlo, thi));
        }
    }
    if !lo.is_finite() || boxes.is_empty() {
        return None;
    }
    let moving = scene.dynamic_swept_bounds();
    let (mut mlo, mut mhi) = (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY));
    if !moving.is_empty() {
        for c in box_corners(&moving) {
            grow(&mut mlo, &mut mhi, to_light(c, t, b, d));
        }
    }
    // Across the light: the volume, or the static extent without outliers.
    let mut ground = false;
    let (mut xy_lo, mut xy_hi, source) = if let Some(v) = &scene.bake_volume {
        let (mut vlo, mut vhi) = (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY));
        for c in box_corners(v) {
            grow(&mut vlo, &mut vhi, to_light(c, t, b, d));
        }
        (vlo, vhi, FitSource::BakeVolume)
    } else {
        let full = hi - lo;
        let (mut clo, mut chi) = (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY));
        let mut large = Vec::new();
        for ((tlo, thi), n) in boxes.iter().zip(&normals) {
            let e = *thi - *tlo;
            if e.x < LARGE_TRIANGLE * full.x && e.y < LARGE_TRIANGLE * full.y {
                grow(&mut clo, &mut chi, *tlo);
                grow(&mut clo, &mut chi, *thi);
            } else {
                large.push(*n);
            }
        }
        let core = chi - clo;
        let beyond = |ratio: f32| full.x > ratio * core.x || full.y > ratio * core.y;
        ground = is_ground(&large);
        let outliers =
            clo.is_finite() && (beyond(OUTLIER_RATIO) || (beyond(GROUND_RATIO) && ground));
        if outliers {
            let m = core.max(Vec3::splat(core.x.max(core.y))) * OUTLIER_MARGIN;
            (
                (clo - m).max(lo),
                (chi + m).min(hi),
                FitSource::WithoutOutliers,
            )
        } else {
            (lo, hi, FitSource::All)
        }
    };
    if !moving.is_empty() {
        xy_lo = xy_lo.min(mlo);
        xy_hi = xy_hi.max(mhi);
    }
    // Along the light: every static surface and the moving objects.
    let (z_lo, z_hi) = if moving.is_empty() {
        (lo.z, hi.z)
    } else {
        (lo.z.min(mlo.z), hi.z.max(mhi.z))
    };
    let (mut left_out, mut clipped) = (0, 0);
    let (mut left_out_mesh, mut clipped_mesh) = (None, None);
    if source != FitSource::All {
        let mut k = 0;
        for m in &scene.static_meshes {
            for _ in m.indices.chunks_exact(3) {
                let (tlo, thi) = boxes[k];
                k += 1;
                if thi.x < xy_lo.x || tlo.x > xy_hi.x || thi.y < xy_lo.y || tlo.y > xy_hi.y {
                    left_out += 1;
                    left_out_mesh.get_or_insert_with(|| m.name.clone());
                } else if tlo.x < xy_lo.x || thi.x > xy_hi.x || tlo.y < xy_lo.y || thi.y > xy_hi.y {
                    clipped += 1;
                    clipped_mesh.get_or_insert_with(|| m.name.clone());
                }
            }
        }
    }
    Some(LightFit {
        lo: Vec3::new(xy_lo.x, xy_lo.y, z_lo),
        hi: Vec3::new(xy_hi.x, xy_hi.y, z_hi),
        source,
        left_out,
        left_out_mesh,
        clipped,
        clipped_mesh,
        full_width: (hi.x - lo.x).max(hi.y - lo.y),
        full_lo: lo,
        full_hi: hi,
        ground,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use gibake_scene::{Animator, Light, Material, Mesh};

    /// A quad `[x0, x1] × [z0, z1]` at height `y` as two triangles.
    fn quad(x0: f32, x1: f32, z0: f32, z1: f32, y: f32) -> Mesh {
        Mesh {
            name: format!("quad {x0}..{x1}"),
            positions: vec![
                Vec3::new(x0, y, z0),
                Vec3::new(x1, y, z0),
                Vec3::new(x1, y, z1),
                Vec3::new(x0, y, z1),
            ],
            normals: vec![Vec3::Y; 4],
            uvs: None,
            indices: vec![0, 2, 1, 0, 3, 2],
            material: 0,
        }
    }

    /// `n × n` small quads over `[-half, half]²` (a detailed core).
    fn detail(half: f32, n: u32, y: f32) -> Vec<Mesh> {
        let s = 2.0 * half / n as f32;
        (0..n * n)
            .map(|k| {
                let (i, j) = ((k % n) as f32, (k / n) as f32);
                let x0 = -half + i * s;
                let z0 = -half + j * s;
                quad(
                    x0,
                    x0 + s * 0.8,
                    z0,
                    z0 + s * 0.8,
                    y + (k % 3) as f32 * 0.1 * s,
                )
            })
            .collect()
    }

    fn scene(meshes: Vec<Mesh>, scale: f32) -> Scene {
        let meshes = meshes
            .into_iter()
            .map(|mut m| {
                for p in &mut m.positions {
                    *p *= scale;
                }
                m
            })
            .collect();
        Scene {
            source: "fit".into(),
            lights: vec![Light {
                name: "sun".into(),
                kind: LightKind::Directional,
                color: Vec3::ONE,
                position: Vec3::ZERO,
                direction: Vec3::new(0.3, -0.8, 0.2).normalize(),
                range: None,
            }],
            camera: None,
            materials: vec![Material::opaque("grey", Vec3::splat(0.5), None)],
            textures: vec![],
            static_meshes: meshes,
            dynamic_meshes: vec![],
            dynamic_objects: vec![],
            animator: Animator::default(),
            warnings: vec![],
            bake_volume: None,
        }
    }

    #[test]
    fn a_lone_plane_and_a_room_around_detail_keep_the_full_extent() {
        let plane = fit(&scene(vec![quad(-5.0, 5.0, -5.0, 5.0, 0.0)], 1.0)).unwrap();
        assert_eq!(plane.source, FitSource::All);
        // A 4 m floor (two large triangles) around a 1 m detailed object.
        let mut room = detail(0.5, 8, 0.0);
        room.push(quad(-2.0, 2.0, -2.0, 2.0, 0.0));
        let f = fit(&scene(room, 1.0)).unwrap();
        assert_eq!(f.source, FitSource::All);
        assert_eq!(f.left_out, 0);
    }

    #[test]
    fn a_distant_ground_plane_is_left_out_at_every_scale() {
        let mut town = detail(60.0, 12, 0.0);
        // 12 km of ground around 120 m of detail: 100× (over OUTLIER_RATIO).
        town.push(quad(-6000.0, 6000.0, -6000.0, 6000.0, -0.5));
        let f = fit(&scene(town.clone(), 1.0)).unwrap();
        assert_eq!(f.source, FitSource::WithoutOutliers);
        let all = fit(&scene(
            vec![quad(-6000.0, 6000.0, -6000.0, 6000.0, -0.5)],
            1.0,
        ))
        .unwrap();
        assert!(
            f.width() < 0.2 * all.width(),
            "fitted {} against the plane's {}",
            f.width(),
            all.width()
        );
        // The plane's two triangles overlap the core: clipped, not left out.
        assert_eq!((f.left_out, f.clipped), (0, 2));
        assert_eq!(f.clipped_mesh.as_deref(), Some("quad -6000..6000"));
        assert!((f.full_width - all.width()).abs() <= 1e-3 * all.width());
        for s in [1e-3f32, 1e3] {
            let g = fit(&scene(town.clone(), s)).unwrap();
            assert_eq!(g.source, f.source, "scale {s}");
            assert!(
                ((g.width() / s) / f.width() - 1.0).abs() < 1e-4,
                "scale {s}"
            );
        }
    }

    /// A closed box `[-h, h]³` of six quads (twelve large triangles).
    fn room(h: f32) -> Vec<Mesh> {
        let q = |p: [Vec3; 4]| Mesh {
            name: "wall".into(),
            positions: p.to_vec(),
            normals: vec![Vec3::Y; 4],
            uvs: None,
            indices: vec![0, 1, 2, 0, 2, 3],
            material: 0,
        };
        let v = |x: f32, y: f32, z: f32| Vec3::new(x, y, z) * h;
        vec![
            q([
                v(-1., -1., -1.),
                v(1., -1., -1.),
                v(1., -1., 1.),
                v(-1., -1., 1.),
            ]),
            q([
                v(-1., 1., -1.),
                v(-1., 1., 1.),
                v(1., 1., 1.),
                v(1., 1., -1.),
            ]),
            q([
                v(-1., -1., -1.),
                v(-1., -1., 1.),
                v(-1., 1., 1.),
                v(-1., 1., -1.),
            ]),
            q([
                v(1., -1., -1.),
                v(1., 1., -1.),
                v(1., 1., 1.),
                v(1., -1., 1.),
            ]),
            q([
                v(-1., -1., -1.),
                v(-1., 1., -1.),
                v(1., 1., -1.),
                v(1., -1., -1.),
            ]),
            q([
                v(-1., -1., 1.),
                v(1., -1., 1.),
                v(1., 1., 1.),
                v(-1., 1., 1.),
            ]),
        ]
    }

    #[test]
    fn a_ground_is_cut_at_8x_and_a_room_is_not() {
        // 16× a town's core: its ground (two parallel triangles) is cut…
        let mut town = detail(60.0, 12, 0.0);
        town.push(quad(-960.0, 960.0, -960.0, 960.0, -0.5));
        let f = fit(&scene(town, 1.0)).unwrap();
        assert_eq!(f.source, FitSource::WithoutOutliers);
        // …under the 8× ground ratio, not below it.
        let mut yard = detail(60.0, 12, 0.0);
        yard.push(quad(-300.0, 300.0, -300.0, 300.0, -0.5));
        assert_eq!(fit(&scene(yard, 1.0)).unwrap().source, FitSource::All);
        // A room 16× its one small panel keeps its walls: they are not a
        // ground (seed 4 of the generator failed when they were cut).
        let mut walls = room(8.0);
        walls.push(quad(-0.5, 0.5, -0.5, 0.5, -7.0));
        let f = fit(&scene(walls, 1.0)).unwrap();
        assert_eq!(f.source, FitSource::All, "a room's walls were cut");
        assert_eq!(f.left_out, 0);
    }

    #[test]
    fn a_cut_ground_gets_outer_rings_and_nothing_else_does() {
        // 16× a town's core: four rings (16× the view) cover its ground.
        let mut town = detail(60.0, 12, 0.0);
        town.push(quad(-960.0, 960.0, -960.0, 960.0, -0.5));
        for s in [1e-3f32, 1.0, 1e3] {
            let f = fit(&scene(town.clone(), s)).unwrap();
            assert!(f.ground, "scale {s}");
            assert_eq!((f.rings(), f.rings_cover_all()), (4, true), "scale {s}");
            // Ring j is 2^j times the view's square, about its centre, and
            // its view's texels are 2^j times as wide.
            let view = |(lo, hi): (Vec3, Vec3)| {
                crate::LightView::directional(Vec3::new(0.3, -1.0, 0.2).normalize(), lo, hi, 512)
            };
            let v0 = view(f.ring_box(0));
            for j in 1..=4u32 {
                let (lo, hi) = f.ring_box(j);
                assert!(((hi.x - lo.x) / f.width() - (1u32 << j) as f32).abs() < 1e-5);
                assert!(
                    ((lo + hi) * 0.5 - (f.lo + f.hi) * 0.5).truncate().length()
                        <= 1e-5 * f.width() * 16.0
                );
                let r = view((lo, hi)).texel_scale / v0.texel_scale;
                assert!((r - (1u32 << j) as f32).abs() < 1e-4, "ring {j}: {r}");
            }
        }
        // 100×: four rings do not reach the ground's edge.
        let mut wide = detail(60.0, 12, 0.0);
        wide.push(quad(-6000.0, 6000.0, -6000.0, 6000.0, -0.5));
        let f = fit(&scene(wide, 1.0)).unwrap();
        assert_eq!((f.rings(), f.rings_cover_all()), (MAX_RINGS, false));
        // Nothing cut, or outliers that are not a ground: no ring.
        let mut yard = detail(60.0, 12, 0.0);
        yard.push(quad(-300.0, 300.0, -300.0, 300.0, -0.5));
        assert_eq!(fit(&scene(yard, 1.0)).unwrap().rings(), 0);
        let mut far_walls = room(5000.0);
        far_walls.extend(detail(60.0, 12, 0.0));
        let f = fit(&scene(far_walls, 1.0)).unwrap();
        assert_eq!(f.source, FitSource::WithoutOutliers);
        assert!(!f.ground);
        assert_eq!(f.rings(), 0);
    }

    #[test]
    fn a_bake_volume_decides_the_extent_and_counts_what_it_leaves_out() {
        let mut meshes = detail(10.0, 6, 0.0);
        meshes.push(quad(40.0, 41.0, 40.0, 41.0, 0.0));
        let mut s = scene(meshes, 1.0);
        s.bake_volume = Some(Aabb {
            min: Vec3::new(-10.0, -1.0, -10.0),
            max: Vec3::new(10.0, 1.0, 10.0),
        });
        let f = fit(&s).unwrap();
        assert_eq!(f.source, FitSource::BakeVolume);
        assert_eq!(f.left_out, 2, "the far quad's two triangles");
        assert!(f.left_out_mesh.unwrap().starts_with("quad 40"));
    }
}
