//! The baked VPL maps in coarse cells, for the VPL-map merge: per map, the
//! largest distance each cell of its texels stores. A moving object whose
//! every covered direction already holds a static surface nearer than the
//! object's nearest point — a ball in the next room, inside a VPL's
//! hemisphere but behind the wall between them — cannot change that map:
//! shading takes `min(baked, merged)` texel by texel, and the merge
//! rasterizes exactly (a texel is written only where its centre ray hits
//! the object, with that ray's distance, `hemi_raster.wgsl`). So the merge
//! leaves such a map out ([`MapCells::hides`]): the same image for less
//! merge work. Built only for a renderer that merges (a scene with moving
//! objects, not `naive`).

use gibake_asset::Asset;
use gibake_gpu::hemisphere;
use gibake_gpu::vpl::NO_MAP;
use gibake_scene::Aabb;
use glam::{Vec2, Vec3};

use crate::baked::BakedGpu;

/// Cells per side of a map (fewer on a smaller map): 16 (8×8 texels of a
/// 128² map) leaves out a third more maps than 8 on the grid of rooms.
const CELLS: u32 = 16;

/// One cell's directions in the VPL frame (the same cells for every map).
#[derive(Clone, Copy, Debug)]
struct Cell {
    /// The mean of its texels' centre directions, unit.
    dir: Vec3,
    /// The largest angle from `dir` to one of its texels' centre
    /// directions, plus one texel's angular size.
    reach: f32,
    /// `cos reach`, `sin reach`.
    cos_reach: f32,
    sin_reach: f32,
}

/// The largest distance per cell of every map the merge draws into.
#[derive(Clone, Debug)]
pub(crate) struct MapCells {
    cells: Vec<Cell>,
    /// Per merge frame (the VPLs' first maps, then their second maps, as
    /// `VplMerge`'s frames): its cells' largest distances, or empty for a
    /// frame without a baked map (nothing hidden).
    max: Vec<Vec<f32>>,
    /// The same frames' cells' smallest distances (for [`MapCells::seen_share`]).
    min: Vec<Vec<f32>>,
}

/// Texel rows (or columns) of cell row (or column) `c` of `g` on a
/// `size²` map.
fn span(size: u32, g: u32, c: u32) -> std::ops::Range<u32> {
    (c * size / g)..((c + 1) * size / g)
}

/// The cells per side of a `size²` map and their directions in the VPL
/// frame, row-major.
fn cell_geometry(size: u32) -> (u32, Vec<Cell>) {
    let g = CELLS.min(size);
    let texel_angle = 2.83 / size as f32;
    let dir = |x: u32, y: u32| {
        let e = Vec2::new(
            (x as f32 + 0.5) / size as f32,
            (y as f32 + 0.5) / size as f32,
        ) * 2.0
            - Vec2::ONE;
        hemisphere::decode(e)
    };
    let mut cells = Vec::with_capacity((g * g) as usize);
    for cy in 0..g {
        for cx in 0..g {
            let texels: Vec<Vec3> = span(size, g, cy)
                .flat_map(|y| span(size, g, cx).map(move |x| dir(x, y)))
                .collect();
            let d = texels.iter().sum::<Vec3>().normalize_or(Vec3::Z);
            let reach = texels
                .iter()
                .map(|t| d.dot(*t).clamp(-1.0, 1.0).acos())
                .fold(0.0f32, f32::max);
            let reach = reach + texel_angle;
            cells.push(Cell {
                dir: d,
                reach,
                cos_reach: reach.cos(),
                sin_reach: reach.sin(),
            });
        }
    }
    (g, cells)
}

impl MapCells {
    /// The cells of `asset`'s maps, in the merge's frame order for `baked`
    /// (each VPL's first map, then each VPL's second map).
    pub(crate) fn new(asset: &Asset, baked: &BakedGpu) -> MapCells {
        let size = baked.map_size.max(1);
        let (g, cells) = cell_geometry(size);
        let cell_range = |map: Option<Vec<f32>>| -> (Vec<f32>, Vec<f32>) {
            let Some(m) = map else {
                return (Vec::new(), Vec::new());
            };
            let mut out = (
                Vec::with_capacity((g * g) as usize),
                Vec::with_capacity((g * g) as usize),
            );
            for cy in 0..g {
                for cx in 0..g {
                    let (mut mn, mut mx) = (f32::INFINITY, 0.0f32);
                    for y in span(size, g, cy) {
                        for x in span(size, g, cx) {
                            let v = m[(y * size + x) as usize];
                            // NaN counts as "nothing there": never hides.
                            let v = if v.is_nan() { f32::INFINITY } else { v };
                            mx = mx.max(v);
                            mn = mn.min(v);
                        }
                    }
                    out.0.push(mx);
                    out.1.push(mn);
                }
            }
            out
        };
        let first = baked.vpls.iter().map(|v| {
            (v.map != NO_MAP)
                .then(|| asset.vpl_maps.map(v.map))
                .flatten()
        });
        let second = (0..baked.vpls.len()).map(|i| {
            asset
                .vpl_lower
                .get(i)
                .filter(|l| l.is_some() && l.map < asset.manifest.lower_map_count)
                .and_then(|l| asset.vpl_lower_maps.map(l.map))
        });
        let (max, min) = first
            .chain(second)
            .map(|m| cell_range(m.filter(|m| m.len() == (size * size) as usize)))
            .unzip();
        MapCells { cells, max, min }
    }

    /// The share of the directions of box `b` (its bounding sphere) in
    /// which frame `frame`'s baked map (centred at `origin` around
    /// `normal`) holds no static surface nearer than `b`: what of the
    /// light the VPL sends towards `b` reaches it (a ball in the next room
    /// behind the wall: 0). An estimate: the cells whose centre direction
    /// lies within the sphere's cone (else the one nearest its centre's
    /// direction), each 1 where all its texels are farther than the
    /// sphere's nearest point, 0 where all are nearer, ½ between. 1
    /// without a baked map or round the origin.
    pub(crate) fn seen_share(&self, frame: usize, origin: Vec3, normal: Vec3, b: &Aabb) -> f32 {
        let (Some(max), Some(min)) = (
            self.max.get(frame).filter(|m| !m.is_empty()),
            self.min.get(frame).filter(|m| !m.is_empty()),
        ) else {
            return 1.0;
        };
        if b.is_empty() {
            return 0.0;
        }
        let c = (b.min + b.max) * 0.5;
        let r = (b.max - b.min).length() * 0.5;
        let v = c - origin;
        let d = v.length();
        if d.partial_cmp(&r) != Some(std::cmp::Ordering::Greater) || !r.is_finite() {
            return 1.0;
        }
        let nearest = d - r;
        let dl = hemisphere::to_local(normal, v / d);
        let cos_a = (1.0 - (r / d) * (r / d)).max(0.0).sqrt();
        let seen = |k: usize| {
            if max[k] < nearest {
                0.0
            } else if min[k] >= nearest {
                1.0
            } else {
                0.5
            }
        };
        let (mut sum, mut count) = (0.0f32, 0u32);
        let mut best = (f32::NEG_INFINITY, 0usize);
        for (k, cell) in self.cells.iter().enumerate() {
            let cos = dl.dot(cell.dir);
            if cos >= cos_a {
                sum += seen(k);
                count += 1;
            }
            if cos > best.0 {
                best = (cos, k);
            }
        }
        if count > 0 {
            sum / count as f32
        } else {
            seen(best.1)
        }
    }

    /// Whether frame `frame`'s baked map (centred at `origin` around
    /// `normal`) holds, in every direction the box `b` can cover, a surface
    /// nearer than any point of `b`: then drawing `b` into the map changes
    /// nothing. Conservative: `b` by its bounding sphere, each cell by its
    /// largest distance and a cone round its directions.
    pub(crate) fn hides(&self, frame: usize, origin: Vec3, normal: Vec3, b: &Aabb) -> bool {
        let Some(max) = self.max.get(frame).filter(|m| !m.is_empty()) else {
            return false;
        };
        if b.is_empty() {
            return true;
        }
        let c = (b.min + b.max) * 0.5;
        let r = (b.max - b.min).length() * 0.5;
        let v = c - origin;
        let d = v.length();
        if d.partial_cmp(&r) != Some(std::cmp::Ordering::Greater) || !r.is_finite() {
            return false;
        }
        let nearest = d - r;
        let dl = hemisphere::to_local(normal, v / d);
        // The object's cone (half-angle α) meets a cell's (reach ρ) where
        // the angle θ between their axes is at most α + ρ, i.e.
        // cos θ ≥ cos α cos ρ − sin α sin ρ (while α + ρ < π).
        let (sin_a, alpha) = (r / d, (r / d).asin());
        let cos_a = (1.0 - sin_a * sin_a).max(0.0).sqrt();
        self.cells.iter().zip(max).all(|(cell, &m)| {
            let meets = alpha + cell.reach >= std::f32::consts::PI
                || dl.dot(cell.dir) >= cos_a * cell.cos_reach - sin_a * cell.sin_reach;
            !meets || m < nearest
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Cells of one map of `size²` texels, every texel `dist`, around +z.
    fn one_map(size: u32, dist: f32) -> MapCells {
        let (g, cells) = cell_geometry(size);
        MapCells {
            cells,
            max: vec![vec![dist; (g * g) as usize]],
            min: vec![vec![dist; (g * g) as usize]],
        }
    }

    /// The cell whose directions are nearest the map's normal.
    fn straight_up(m: &MapCells) -> usize {
        m.cells
            .iter()
            .enumerate()
            .max_by(|a, b| a.1.dir.z.total_cmp(&b.1.dir.z))
            .map(|(k, _)| k)
            .unwrap()
    }

    fn cube(c: Vec3, h: f32) -> Aabb {
        Aabb {
            min: c - Vec3::splat(h),
            max: c + Vec3::splat(h),
        }
    }

    #[test]
    fn an_object_behind_the_walls_is_hidden_one_in_front_is_not() {
        // Walls 2 away in every direction.
        let m = one_map(32, 2.0);
        let (o, n) = (Vec3::ZERO, Vec3::Z);
        assert!(m.hides(0, o, n, &cube(Vec3::new(0.5, 0.0, 4.0), 0.5)));
        assert!(!m.hides(0, o, n, &cube(Vec3::new(0.5, 0.0, 1.0), 0.3)));
        // Straddling the wall: part of it is nearer.
        assert!(!m.hides(0, o, n, &cube(Vec3::new(0.0, 0.0, 2.2), 0.5)));
        // Round the origin: never hidden.
        assert!(!m.hides(0, o, n, &cube(Vec3::ZERO, 0.5)));
    }

    #[test]
    fn one_open_cell_in_the_objects_directions_shows_it() {
        let mut m = one_map(32, 2.0);
        // A window: the cell straight up sees nothing.
        let up = straight_up(&m);
        m.max[0][up] = f32::INFINITY;
        assert!(!m.hides(0, Vec3::ZERO, Vec3::Z, &cube(Vec3::new(0.0, 0.0, 5.0), 0.5)));
        // Sideways, away from the window, the walls still hide it.
        assert!(m.hides(0, Vec3::ZERO, Vec3::Z, &cube(Vec3::new(5.0, 0.0, 0.5), 0.3)));
    }

    /// Behind the walls nothing of the light towards it reaches a box; in
    /// front of them all of it; a window in its directions lets some by.
    #[test]
    fn the_seen_share_follows_the_walls() {
        let mut m = one_map(32, 2.0);
        let (o, n) = (Vec3::ZERO, Vec3::Z);
        let far = cube(Vec3::new(0.0, 0.0, 5.0), 0.5);
        assert_eq!(m.seen_share(0, o, n, &far), 0.0);
        assert_eq!(
            m.seen_share(0, o, n, &cube(Vec3::new(0.5, 0.0, 1.0), 0.3)),
            1.0
        );
        let up = straight_up(&m);
        m.max[0][up] = f32::INFINITY;
        m.min[0][up] = f32::INFINITY;
        let s = m.seen_share(0, o, n, &far);
        assert!(s > 0.0 && s < 1.0, "{s}");
        // No baked map: all of it.
        assert_eq!(m.seen_share(1, o, n, &far), 1.0);
    }

    #[test]
    fn no_baked_map_hides_nothing() {
        let m = MapCells {
            cells: one_map(16, 1.0).cells,
            max: vec![Vec::new()],
            min: vec![Vec::new()],
        };
        assert!(!m.hides(0, Vec3::ZERO, Vec3::Z, &cube(Vec3::new(0.0, 0.0, 9.0), 0.1)));
        assert!(!m.hides(5, Vec3::ZERO, Vec3::Z, &cube(Vec3::new(0.0, 0.0, 9.0), 0.1)));
    }

    #[test]
    fn every_scale_alike() {
        for s in [1e-3f32, 1.0, 1e3] {
            let m = one_map(32, 2.0 * s);
            assert!(m.hides(
                0,
                Vec3::ZERO,
                Vec3::Z,
                &cube(Vec3::new(0.5, 0.0, 4.0) * s, 0.5 * s)
            ));
            assert!(!m.hides(
                0,
                Vec3::ZERO,
                Vec3::Z,
                &cube(Vec3::new(0.5, 0.0, 1.0) * s, 0.3 * s)
            ));
        }
    }
}
