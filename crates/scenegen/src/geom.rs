//! Triangle-mesh construction in scene units at scale 1 (metres), in `f64`.
//!
//! Every generator here emits counter-clockwise front faces (seen from the side
//! the normal points to) and unit vertex normals. Coordinates stay in `f64`
//! until [`crate::gltf`] scales them and rounds them to `f32` once, so that a
//! scaled scene is the correctly rounded product of the unscaled one.

use std::collections::HashMap;

use glam::{DMat3, DVec3};

/// An indexed triangle list with per-vertex normals.
#[derive(Clone, Debug, Default)]
pub struct Geom {
    /// Vertex positions in metres (scale 1).
    pub pos: Vec<DVec3>,
    /// Unit vertex normals, one per position.
    pub nrm: Vec<DVec3>,
    /// Triangle vertex indices, three per triangle, counter-clockwise from the front.
    pub idx: Vec<u32>,
}

impl Geom {
    /// Number of triangles.
    pub fn triangles(&self) -> usize {
        self.idx.len() / 3
    }

    /// Appends `other`'s triangles to `self` (one mesh with both parts).
    pub fn append(&mut self, other: &Geom) {
        let base = u32::try_from(self.pos.len()).expect("mesh too large");
        self.pos.extend_from_slice(&other.pos);
        self.nrm.extend_from_slice(&other.nrm);
        self.idx.extend(other.idx.iter().map(|i| i + base));
    }

    /// Rotates the mesh by `rot` (a rotation matrix) about the origin, then translates it.
    pub fn rotated_translated(mut self, rot: DMat3, t: DVec3) -> Geom {
        for p in &mut self.pos {
            *p = rot * *p + t;
        }
        for n in &mut self.nrm {
            *n = (rot * *n).normalize();
        }
        self
    }
}

/// A planar parallelogram `o + a·u + b·v`, `a, b ∈ [0, 1]`, tessellated into a
/// `k × k` grid of cells (2·k² coplanar triangles). Its front face, and normal,
/// is on the side of `u × v`.
pub fn quad(o: DVec3, u: DVec3, v: DVec3, k: u32) -> Geom {
    let k = k.max(1);
    let n = u.cross(v).normalize();
    let mut g = Geom::default();
    for j in 0..=k {
        for i in 0..=k {
            let a = f64::from(i) / f64::from(k);
            let b = f64::from(j) / f64::from(k);
            g.pos.push(o + u * a + v * b);
            g.nrm.push(n);
        }
    }
    let row = k + 1;
    for j in 0..k {
        for i in 0..k {
            let v00 = j * row + i;
            let v10 = v00 + 1;
            let v01 = v00 + row;
            let v11 = v01 + 1;
            g.idx.extend_from_slice(&[v00, v10, v11, v00, v11, v01]);
        }
    }
    g
}

/// Like [`quad`], but with the front face toward `facing` (`u` and `v` are
/// swapped when `u × v` points away from it).
pub fn quad_facing(o: DVec3, u: DVec3, v: DVec3, k: u32, facing: DVec3) -> Geom {
    if u.cross(v).dot(facing) < 0.0 {
        quad(o, v, u, k)
    } else {
        quad(o, u, v, k)
    }
}

/// An axis-aligned box from `min` to `max` with outward faces, each face a
/// `k × k` grid. The bottom face (−Y) is left out when `bottom` is false (boxes
/// standing on a floor never show it).
pub fn aabox(min: DVec3, max: DVec3, k: u32, bottom: bool) -> Geom {
    let d = max - min;
    let mut g = Geom::default();
    for axis in 0..3 {
        for positive in [false, true] {
            if axis == 1 && !positive && !bottom {
                continue;
            }
            let (a1, a2) = ((axis + 1) % 3, (axis + 2) % 3);
            let mut o = min;
            if positive {
                o[axis] = max[axis];
            }
            let mut u = DVec3::ZERO;
            u[a1] = d[a1];
            let mut v = DVec3::ZERO;
            v[a2] = d[a2];
            let mut outward = DVec3::ZERO;
            outward[axis] = if positive { 1.0 } else { -1.0 };
            if u.cross(v).dot(outward) < 0.0 {
                std::mem::swap(&mut u, &mut v);
            }
            g.append(&quad(o, u, v, k));
        }
    }
    g
}

/// A UV sphere of radius `r` around `center`: `segments` around the Y axis,
/// `rings` from pole to pole, single pole vertices (no degenerate triangles),
/// analytic normals.
pub fn uv_sphere(center: DVec3, r: f64, segments: u32, rings: u32) -> Geom {
    use std::f64::consts::PI;
    let (segments, rings) = (segments.max(3), rings.max(2));
    let mut g = Geom::default();
    // Vertex 0: north pole; then rings 1..rings-1; last: south pole.
    let mut push = |n: DVec3| {
        g.pos.push(center + n * r);
        g.nrm.push(n);
    };
    push(DVec3::Y);
    for j in 1..rings {
        let theta = PI * f64::from(j) / f64::from(rings);
        for i in 0..segments {
            let phi = 2.0 * PI * f64::from(i) / f64::from(segments);
            push(
                DVec3::new(
                    theta.sin() * phi.cos(),
                    theta.cos(),
                    theta.sin() * phi.sin(),
                )
                .normalize(),
            );
        }
    }
    push(DVec3::NEG_Y);
    let south = 1 + (rings - 1) * segments;
    // Index of ring j (0 = north pole, rings = south pole), segment i.
    let at = |j: u32, i: u32| -> u32 {
        if j == 0 {
            0
        } else if j == rings {
            south
        } else {
            1 + (j - 1) * segments + i % segments
        }
    };
    for j in 0..rings {
        for i in 0..segments {
            let (v00, v01, v10, v11) = (at(j, i), at(j, i + 1), at(j + 1, i), at(j + 1, i + 1));
            // (v00, v01, v10) is CCW from outside: dφ × dθ points outward.
            if j != 0 {
                g.idx.extend_from_slice(&[v00, v01, v10]);
            }
            if j != rings - 1 {
                g.idx.extend_from_slice(&[v01, v11, v10]);
            }
        }
    }
    g
}

/// Area-weighted smooth vertex normals of an indexed mesh.
pub fn smooth_normals(pos: &[DVec3], idx: &[u32]) -> Vec<DVec3> {
    let mut acc = vec![DVec3::ZERO; pos.len()];
    for t in idx.chunks_exact(3) {
        let (a, b, c) = (t[0] as usize, t[1] as usize, t[2] as usize);
        let n = (pos[b] - pos[a]).cross(pos[c] - pos[a]);
        acc[a] += n;
        acc[b] += n;
        acc[c] += n;
    }
    acc.into_iter()
        .map(|n| n.try_normalize().unwrap_or(DVec3::Y))
        .collect()
}

/// Splits every triangle into four at its edge midpoints, `levels` times.
/// The surface does not change (new vertices lie on the old flat triangles);
/// a midpoint's normal is the normalised mean of its edge's end normals.
pub fn subdivide(mut g: Geom, levels: u32) -> Geom {
    for _ in 0..levels {
        let mut mid: HashMap<(u32, u32), u32> = HashMap::new();
        let mut idx = Vec::with_capacity(g.idx.len() * 4);
        let tris: Vec<u32> = std::mem::take(&mut g.idx);
        for t in tris.chunks_exact(3) {
            let mut m = [0u32; 3];
            for e in 0..3 {
                let (a, b) = (t[e], t[(e + 1) % 3]);
                let key = (a.min(b), a.max(b));
                m[e] = *mid.entry(key).or_insert_with(|| {
                    let (a, b) = (a as usize, b as usize);
                    g.pos.push((g.pos[a] + g.pos[b]) * 0.5);
                    g.nrm
                        .push((g.nrm[a] + g.nrm[b]).try_normalize().unwrap_or(g.nrm[a]));
                    u32::try_from(g.pos.len() - 1).expect("mesh too large")
                });
            }
            idx.extend_from_slice(&[
                t[0], m[0], m[2], m[0], t[1], m[1], m[2], m[1], t[2], m[0], m[1], m[2],
            ]);
        }
        g.idx = idx;
    }
    g
}

/// The Stanford bunny as given in `assets/stanford-bunny.json` (Y up, its
/// original units), with smooth normals.
pub fn raw_bunny() -> Geom {
    let raw: serde_json::Value =
        serde_json::from_str(include_str!("../assets/stanford-bunny.json"))
            .expect("embedded bunny JSON is valid");
    let num = |v: &serde_json::Value| v.as_f64().expect("bunny: number");
    let pos: Vec<DVec3> = raw["positions"]
        .as_array()
        .expect("bunny: positions")
        .iter()
        .map(|p| DVec3::new(num(&p[0]), num(&p[1]), num(&p[2])))
        .collect();
    let idx: Vec<u32> = raw["cells"]
        .as_array()
        .expect("bunny: cells")
        .iter()
        .flat_map(|c| {
            (0..3).map(move |k| {
                u32::try_from(c[k].as_u64().expect("bunny: index")).expect("bunny: index")
            })
        })
        .collect();
    assert!(
        idx.iter().all(|&i| (i as usize) < pos.len()),
        "bunny: index out of range"
    );
    let nrm = smooth_normals(&pos, &idx);
    Geom { pos, nrm, idx }
}

/// The bunny scaled to `height` metres, turned by `yaw` radians about +Y, its
/// lowest point on y = 0 and the centre of its horizontal bounds at
/// (`cx`, `cz`).
pub fn bunny(height: f64, yaw: f64, cx: f64, cz: f64) -> Geom {
    let mut g = raw_bunny();
    let (lo, hi) = bounds(&g.pos);
    let s = height / (hi.y - lo.y);
    let rot = DMat3::from_rotation_y(yaw);
    for p in &mut g.pos {
        *p = rot * (*p * s);
    }
    for n in &mut g.nrm {
        *n = (rot * *n).normalize();
    }
    let (lo, hi) = bounds(&g.pos);
    let t = DVec3::new(cx - 0.5 * (lo.x + hi.x), -lo.y, cz - 0.5 * (lo.z + hi.z));
    for p in &mut g.pos {
        *p += t;
    }
    g
}

/// Component-wise minimum and maximum of `pts` (which must not be empty).
pub fn bounds(pts: &[DVec3]) -> (DVec3, DVec3) {
    pts.iter().fold(
        (DVec3::splat(f64::INFINITY), DVec3::splat(f64::NEG_INFINITY)),
        |(lo, hi), p| (lo.min(*p), hi.max(*p)),
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Every triangle's geometric normal agrees with its vertex normals, and
    /// there are no degenerate triangles.
    fn check_orientation(g: &Geom) {
        assert_eq!(g.pos.len(), g.nrm.len());
        for t in g.idx.chunks_exact(3) {
            let [a, b, c] = [t[0], t[1], t[2]].map(|i| i as usize);
            let n = (g.pos[b] - g.pos[a]).cross(g.pos[c] - g.pos[a]);
            assert!(n.length() > 0.0, "degenerate triangle {t:?}");
            let vn = g.nrm[a] + g.nrm[b] + g.nrm[c];
            assert!(
                n.normalize().dot(vn.normalize()) > 0.0,
                "triangle {t:?} faces away from its normals"
            );
        }
        for n in &g.nrm {
            assert!((n.length() - 1.0).abs() < 1e-9);
        }
    }

    #[test]
    fn primitives_are_outward_and_ccw() {
        check_orientation(&quad(DVec3::ZERO, DVec3::X, DVec3::NEG_Z, 3));
        check_orientation(&aabox(DVec3::ZERO, DVec3::new(1.0, 2.0, 3.0), 2, true));
        check_orientation(&uv_sphere(DVec3::ONE, 0.1, 16, 12));
        check_orientation(&subdivide(uv_sphere(DVec3::ONE, 0.1, 8, 6), 2));
        let q = quad(DVec3::ZERO, DVec3::X, DVec3::NEG_Z, 1);
        assert_eq!(q.nrm[0], DVec3::Y);
    }

    #[test]
    fn box_normals_point_out() {
        let g = aabox(DVec3::ZERO, DVec3::ONE, 1, true);
        let c = DVec3::splat(0.5);
        for (p, n) in g.pos.iter().zip(&g.nrm) {
            assert!((*p - c).dot(*n) > 0.0);
        }
        assert_eq!(g.triangles(), 12);
        assert_eq!(aabox(DVec3::ZERO, DVec3::ONE, 2, false).triangles(), 5 * 8);
    }

    #[test]
    fn sphere_counts() {
        let g = uv_sphere(DVec3::ZERO, 1.0, 16, 12);
        assert_eq!(g.pos.len(), 2 + 11 * 16);
        assert_eq!(g.triangles(), 2 * 16 + 10 * 32);
    }

    #[test]
    fn bunny_is_y_up_and_placed() {
        let raw = raw_bunny();
        assert_eq!(raw.pos.len(), 1839);
        assert_eq!(raw.triangles(), 3674);
        check_orientation(&raw);
        let (lo, hi) = bounds(&raw.pos);
        // Y up: the model stands on a flat base at y ≈ 0 (many vertices there).
        assert!(lo.y.abs() < 0.01 * (hi.y - lo.y));
        assert!(
            raw.pos
                .iter()
                .filter(|p| p.y < lo.y + 0.05 * (hi.y - lo.y))
                .count()
                > 100
        );
        let b = bunny(0.6, 1.0, -0.4, -0.3);
        let (lo, hi) = bounds(&b.pos);
        assert!((hi.y - 0.6).abs() < 1e-12 && lo.y == 0.0);
        assert!((lo.x + hi.x + 0.8).abs() < 1e-12 && (lo.z + hi.z + 0.6).abs() < 1e-12);
        check_orientation(&b);
        let s = subdivide(b, 1);
        assert_eq!(s.triangles(), 4 * 3674);
        check_orientation(&s);
    }
}
