//! The hemisphere maps in their one layout, from the bake to the GPU: an
//! atlas ([`MapAtlas`]) of `count` square tiles, map `k` at column
//! `k % cols`, row `k / cols` of the `cols × rows` grid of
//! [`atlas_grid`]`(count)`, unused tiles +inf — the layout of
//! `vpl_maps.exr` (docs/asset-format.md), kept as it is in memory and
//! uploaded as it is by the runtime. Nothing between the bake and the GPU
//! re-packs the maps.

/// The atlas grid of `map_count` maps: `(cols, rows)` with
/// `cols = ceil(sqrt(map_count))` and `rows = ceil(map_count / cols)`;
/// `(0, 0)` for no maps. Map `k` sits at column `k % cols`, row `k / cols`.
pub fn atlas_grid(map_count: u32) -> (u32, u32) {
    let n = map_count as u64;
    if n == 0 {
        return (0, 0);
    }
    let mut c = (n as f64).sqrt() as u64;
    while c * c < n {
        c += 1;
    }
    while c > 1 && (c - 1) * (c - 1) >= n {
        c -= 1;
    }
    (c as u32, n.div_ceil(c) as u32)
}

/// Index, in the texels of the atlas of `count` tiles of `tile²` (row-major,
/// `cols · tile` wide), of texel `(x, y)` of tile `k`: the one layout of
/// every atlas file (`vpl_maps.exr`, `light_maps.exr`, `view_rsms.exr`).
pub(crate) fn atlas_index(tile: u32, count: u32, k: u32, x: u32, y: u32) -> usize {
    let (cols, _) = atlas_grid(count);
    let (s, w) = (tile as usize, cols as usize * tile as usize);
    let (cx, cy) = ((k % cols) as usize, (k / cols) as usize);
    (cy * s + y as usize) * w + cx * s + x as usize
}

/// The atlas texels of `tiles` (each `tile²` values, row-major), unused
/// tiles `fill`; `None` when a tile does not hold `tile²` values or the
/// atlas would not fit in memory's address range.
pub(crate) fn pack_tiles<T: Copy>(tile: u32, tiles: &[&[T]], fill: T) -> Option<Vec<T>> {
    let s = tile as usize;
    if tiles.iter().any(|t| t.len() != s.saturating_mul(s)) {
        return None;
    }
    let count = u32::try_from(tiles.len()).ok()?;
    let (cols, rows) = atlas_grid(count);
    let w = usize::try_from(u64::from(cols) * u64::from(tile)).ok()?;
    let h = usize::try_from(u64::from(rows) * u64::from(tile)).ok()?;
    let mut out = vec![fill; w.checked_mul(h)?];
    for (k, t) in tiles.iter().enumerate() {
        for y in 0..tile {
            let start = atlas_index(tile, count, k as u32, 0, y);
            let src = y as usize * s;
            out[start..start + s].copy_from_slice(&t[src..src + s]);
        }
    }
    Some(out)
}

/// A copy of tile `k` (`tile²` values, row-major) of the atlas `texels` of
/// `count` tiles (`k < count`, `texels` of the grid's size).
pub(crate) fn unpack_tile<T: Copy>(tile: u32, count: u32, texels: &[T], k: u32) -> Vec<T> {
    let s = tile as usize;
    let mut out = Vec::with_capacity(s * s);
    for y in 0..tile {
        let start = atlas_index(tile, count, k, 0, y);
        out.extend_from_slice(&texels[start..start + s]);
    }
    out
}

/// The first texel of a tile past the last of `count` whose value is not
/// `fill`, as `(tile, x, y)` in tile coordinates; `None` when every unused
/// tile holds `fill` only, as the layout requires.
pub(crate) fn unused_mismatch<T: PartialEq>(
    tile: u32,
    count: u32,
    texels: &[T],
    fill: &T,
) -> Option<(u32, u32, u32)> {
    let (cols, rows) = atlas_grid(count);
    let s = tile as usize;
    for k in count..cols.saturating_mul(rows) {
        for y in 0..tile {
            let start = atlas_index(tile, count, k, 0, y);
            if let Some(x) = texels[start..start + s].iter().position(|v| v != fill) {
                return Some((k, x as u32, y));
            }
        }
    }
    None
}

/// `count` square maps of `tile²` distances (+inf = no surface) in the atlas
/// layout. The texels are `width() × height()`, row-major, row 0 at the top.
#[derive(Clone, Debug, PartialEq)]
pub struct MapAtlas {
    tile: u32,
    count: u32,
    texels: Vec<f32>,
}

impl MapAtlas {
    /// No maps (of `tile²` texels).
    pub fn empty(tile: u32) -> MapAtlas {
        MapAtlas {
            tile,
            count: 0,
            texels: Vec::new(),
        }
    }

    /// The maps of `maps`, in order (tile `k` = the `k`-th map); `None`
    /// when a map does not hold `tile²` values or the atlas would not fit
    /// in memory's address range.
    pub fn from_maps<'a>(tile: u32, maps: impl IntoIterator<Item = &'a [f32]>) -> Option<MapAtlas> {
        let maps: Vec<&[f32]> = maps.into_iter().collect();
        let s = tile as usize;
        if maps.iter().any(|m| m.len() != s.saturating_mul(s)) {
            return None;
        }
        let count = u32::try_from(maps.len()).ok()?;
        let mut atlas = MapAtlas::filled(tile, count)?;
        for (k, m) in maps.iter().enumerate() {
            atlas.set_map(k as u32, m);
        }
        Some(atlas)
    }

    /// `count` maps of `tile²` texels, all +inf.
    fn filled(tile: u32, count: u32) -> Option<MapAtlas> {
        let (cols, rows) = atlas_grid(count);
        let w = usize::try_from(u64::from(cols) * u64::from(tile)).ok()?;
        let h = usize::try_from(u64::from(rows) * u64::from(tile)).ok()?;
        Some(MapAtlas {
            tile,
            count,
            texels: vec![f32::INFINITY; w.checked_mul(h)?],
        })
    }

    /// An atlas of `count` maps from its texels (`width × height` of the
    /// grid, e.g. decoded from `vpl_maps.exr`); `None` when their number
    /// does not fit.
    pub fn from_texels(tile: u32, count: u32, texels: Vec<f32>) -> Option<MapAtlas> {
        let (cols, rows) = atlas_grid(count);
        let n = u64::from(cols) * u64::from(tile) * u64::from(rows) * u64::from(tile);
        (texels.len() as u64 == n).then_some(MapAtlas {
            tile,
            count,
            texels,
        })
    }

    /// Side of one map.
    pub fn tile_size(&self) -> u32 {
        self.tile
    }

    /// Number of maps.
    pub fn count(&self) -> u32 {
        self.count
    }

    /// Whether it holds no map.
    pub fn is_empty(&self) -> bool {
        self.count == 0
    }

    /// `(cols, rows)` of the grid ([`atlas_grid`]).
    pub fn grid(&self) -> (u32, u32) {
        atlas_grid(self.count)
    }

    /// Width in texels (`cols · tile`).
    pub fn width(&self) -> u32 {
        self.grid().0 * self.tile
    }

    /// Height in texels (`rows · tile`).
    pub fn height(&self) -> u32 {
        self.grid().1 * self.tile
    }

    /// Every texel, row-major (unused tiles +inf).
    pub fn texels(&self) -> &[f32] {
        &self.texels
    }

    /// Every texel, to change in place.
    pub fn texels_mut(&mut self) -> &mut [f32] {
        &mut self.texels
    }

    /// Index in [`MapAtlas::texels`] of texel `(x, y)` of map `k`.
    fn index(&self, k: u32, x: u32, y: u32) -> usize {
        atlas_index(self.tile, self.count, k, x, y)
    }

    /// A copy of map `k` (`tile²` values, row-major), `None` past the count.
    pub fn map(&self, k: u32) -> Option<Vec<f32>> {
        if k >= self.count {
            return None;
        }
        let s = self.tile as usize;
        let mut out = Vec::with_capacity(s * s);
        for y in 0..self.tile {
            let start = self.index(k, 0, y);
            out.extend_from_slice(&self.texels[start..start + s]);
        }
        Some(out)
    }

    /// The first texel of a tile past the last map that is not +inf, as
    /// `(tile, x, y, value)` in tile coordinates; `None` when every unused
    /// tile is +inf, as the layout requires.
    pub fn finite_unused_texel(&self) -> Option<(u32, u32, u32, f32)> {
        unused_mismatch(self.tile, self.count, &self.texels, &f32::INFINITY)
            .map(|(k, x, y)| (k, x, y, self.texels[self.index(k, x, y)]))
    }

    /// Copies of every map, in order.
    pub fn maps(&self) -> impl Iterator<Item = Vec<f32>> + '_ {
        (0..self.count).filter_map(|k| self.map(k))
    }

    /// Overwrites map `k` (`k < count`) with `values` (`tile²`, row-major).
    pub fn set_map(&mut self, k: u32, values: &[f32]) {
        let s = self.tile as usize;
        assert!(
            k < self.count && values.len() == s * s,
            "map {k} out of range"
        );
        for y in 0..self.tile {
            let start = self.index(k, 0, y);
            let src = y as usize * s;
            self.texels[start..start + s].copy_from_slice(&values[src..src + s]);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn grid_is_the_smallest_square_ish() {
        assert_eq!(atlas_grid(0), (0, 0));
        assert_eq!(atlas_grid(1), (1, 1));
        assert_eq!(atlas_grid(7), (3, 3));
        assert_eq!(atlas_grid(9), (3, 3));
        assert_eq!(atlas_grid(10), (4, 3));
        assert_eq!(atlas_grid(664), (26, 26));
    }

    #[test]
    fn maps_round_trip_through_the_layout() {
        let maps: Vec<Vec<f32>> = (0..7)
            .map(|k| (0..4).map(|i| (10 * k + i) as f32).collect())
            .collect();
        let a = MapAtlas::from_maps(2, maps.iter().map(|m| m.as_slice())).unwrap();
        assert_eq!((a.width(), a.height(), a.count()), (6, 6, 7));
        // Map 4 sits at column 1, row 1: texel (1, 0) at atlas (3, 2).
        assert_eq!(a.texels()[2 * 6 + 3], 41.0);
        // Unused tiles are +inf.
        assert!(a.texels()[5 * 6 + 5].is_infinite());
        assert_eq!(a.maps().collect::<Vec<_>>(), maps);
        assert_eq!(a.map(7), None);
        let b = MapAtlas::from_texels(2, 7, a.texels().to_vec()).unwrap();
        assert_eq!(a, b);
        assert!(MapAtlas::from_texels(2, 7, vec![0.0; 35]).is_none());
        assert!(MapAtlas::from_maps(2, [[0.0f32; 3].as_slice()]).is_none());
    }
}
