//! The one VPL-map atlas layout, from the bake to the GPU: map `k` of `n`
//! sits at column `k % cols`, row `k / cols` of a `cols × rows` grid with
//! `(cols, rows) = gibake_asset::atlas_grid(n)` — the layout of the asset's
//! `vpl_maps` file, uploaded as it is, and of the merge atlas. Checked
//! against the device's largest 2D texture here, once per atlas.

use crate::RuntimeError;

/// The grid of an atlas of `count` (at least 1) maps of `tile²` texels, or
/// the device limit it exceeds; `what` names the atlas in the error.
pub(crate) fn layout(
    device: &wgpu::Device,
    what: &str,
    count: u32,
    tile: u32,
) -> Result<(u32, u32), RuntimeError> {
    let (cols, rows) = gibake_asset::atlas_grid(count.max(1));
    let max = u64::from(device.limits().max_texture_dimension_2d);
    let needed = u64::from(cols.max(rows)) * u64::from(tile);
    if needed > max {
        return Err(RuntimeError::DeviceLimit {
            what: format!("{what} ({count} VPL maps of {tile}² texels in {cols}×{rows} tiles)"),
            needed,
            limit: max,
        });
    }
    Ok((cols, rows))
}
