//! The VPL-map merge (design brief, step 3): which static VPL maps moving
//! objects reach, and rasterizing them there.
//!
//! [`VplMerge`] owns everything the merge needs: each VPL's map frame, the
//! merge atlas (grown when more maps are affected than ever before, checked
//! against the device's limits), the per-VPL tile table the shading reads,
//! and the rasterization pass with its job and instance tables. Per frame,
//! [`VplMerge::prepare`] computes, from the moving objects' world bounds,
//! the octahedron faces of each VPL map a draw can touch (face masks), the
//! VPLs that get a tile, each moving mesh's level of detail per map, and
//! uploads the tables (the atlas in the layout of [`crate::atlas`]);
//! [`VplMerge::record`] only records the one pass.
//!
//! A VPL with a second map (the light below its horizon,
//! `gibake_asset::LowerVpl`) has a second frame, its second origin and the
//! opposite of its normal, merged the same way: the tile table holds the
//! first maps' tiles, then the second maps' (`n_static + i` for VPL `i`).
//!
//! In `naive` mode every map gets a tile and every draw (static ones too) is
//! rasterized into it: the same code re-renders every map (the cost
//! baseline).

use std::ops::Range;

use gibake_gpu::mesh::{Draw, SceneGpu, lod_for};
use gibake_gpu::passes::hemi_raster::{GpuHemiJob, HemiAtlas, HemiRasterPass, face_mask};
use gibake_scene::Aabb;
use glam::{Mat4, Vec3};

use crate::RuntimeError;
use crate::baked::BakedGpu;

/// Merge state of one renderer.
pub(crate) struct VplMerge {
    /// Per static VPL: (map origin, normal), as uploaded ([`BakedGpu::vpls`]);
    /// then per static VPL its second map's frame, where it has one
    /// ([`BakedGpu::lower`]).
    frames: Vec<Option<(Vec3, Vec3)>>,
    /// Every map is re-rendered from all geometry (`naive`).
    naive: bool,
    map_size: u32,
    pass: HemiRasterPass,
    atlas: HemiAtlas,
    /// Per frame (static VPLs' maps, then their second maps): its atlas
    /// tile, or `u32::MAX` (baked map alone).
    tile_buf: wgpu::Buffer,
    jobs: Vec<GpuHemiJob>,
    tiles: Vec<u32>,
    /// This frame's `(index range, instance range)` draws.
    ranges: Vec<(Range<u32>, Range<u32>)>,
    affected: u32,
    /// The baked maps' cells ([`crate::map_cells`]): a map whose baked
    /// surfaces hide every moving object that reaches it gets no tile.
    /// `None` in `naive` mode.
    cells: Option<crate::map_cells::MapCells>,
    /// Maps some moving object reaches that their baked map hides, this
    /// frame.
    hidden: u32,
    /// Per moving object: the maps it is drawn into this frame.
    per_object: Vec<u32>,
    /// Rasterization instances this frame.
    instances: u32,
    /// Per frame: its VPL's flux (luminance; a second map its VPL's).
    weight: Vec<f32>,
    /// [`crate::RenderSettings::merge_cull_share`] (0 in `naive` mode).
    cull_share: f32,
    /// (Map, draw) pairs left out as faint this frame
    /// ([`crate::merge_cull`]).
    faint: u32,
    /// Per scene material ([`Draw::scene_material`]): its mean albedo (a
    /// moving draw's share of the later bounces it absorbs,
    /// [`crate::later_absorb`]).
    material_albedo: Vec<Vec3>,
    /// The first later-bounce VPL and the static VPLs' count.
    later_range: (usize, usize),
    /// This frame's losses ([`crate::later_absorb::absorbed`]).
    absorbed: crate::later_absorb::Absorbed,
}

/// A merge atlas for `capacity` tiles in the one atlas layout, or the
/// device limit it would exceed.
fn checked_atlas(
    device: &wgpu::Device,
    tile_size: u32,
    capacity: u32,
) -> Result<HemiAtlas, RuntimeError> {
    let (cols, rows) = crate::atlas::layout(device, "the merge atlas", capacity, tile_size)?;
    Ok(HemiAtlas::new(device, tile_size, cols, rows))
}

impl VplMerge {
    /// The merge for `baked`'s VPLs; `scene_diagonal` scales the depth.
    pub(crate) fn new(
        device: &wgpu::Device,
        scene_gpu: &SceneGpu,
        baked: &BakedGpu,
        scene_diagonal: f32,
        naive: bool,
        cull_share: f32,
        material_albedo: Vec<Vec3>,
    ) -> Result<VplMerge, RuntimeError> {
        let lum = |f: [f32; 3]| {
            let l = 0.2126 * f[0] + 0.7152 * f[1] + 0.0722 * f[2];
            if l.is_finite() { l.max(0.0) } else { 0.0 }
        };
        let flux: Vec<f32> = baked.vpls.iter().map(|v| lum(v.flux)).collect();
        let weight: Vec<f32> = flux
            .iter()
            .copied()
            .chain(flux.iter().copied().take(baked.lower.len()))
            .collect();
        let frames: Vec<Option<(Vec3, Vec3)>> = baked
            .vpls
            .iter()
            .map(|v| Some((v.position(), v.normal())))
            .chain(baked.lower.iter().copied())
            .collect();
        let n = frames.len() as u32;
        let maps = frames.iter().flatten().count() as u32;
        let capacity = if naive { maps } else { maps.min(64) };
        let atlas = checked_atlas(device, baked.map_size, capacity)?;
        let diag = scene_diagonal.max(f32::MIN_POSITIVE);
        let pass = HemiRasterPass::new(device, scene_gpu, 1.0 / (4.0 * diag));
        let tile_buf = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("VPL tiles"),
            size: 4 * u64::from(n.max(1)),
            usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        Ok(VplMerge {
            frames,
            naive,
            map_size: baked.map_size,
            pass,
            atlas,
            tile_buf,
            jobs: Vec::new(),
            tiles: vec![u32::MAX; n as usize],
            ranges: Vec::new(),
            affected: 0,
            cells: if naive { None } else { baked.map_cells.clone() },
            hidden: 0,
            per_object: Vec::new(),
            instances: 0,
            weight,
            cull_share: if naive { 0.0 } else { cull_share },
            faint: 0,
            material_albedo,
            later_range: (
                baked.vpls.len().saturating_sub(baked.later as usize),
                baked.vpls.len(),
            ),
            absorbed: Default::default(),
        })
    }

    /// The merge atlas (`R32Float` distances).
    pub(crate) fn atlas_view(&self) -> &wgpu::TextureView {
        &self.atlas.view
    }

    /// Tiles per atlas row.
    pub(crate) fn atlas_cols(&self) -> u32 {
        self.atlas.cols
    }

    /// Per static VPL: its tile or `u32::MAX`.
    pub(crate) fn tile_buf(&self) -> &wgpu::Buffer {
        &self.tile_buf
    }

    /// VPL maps that get a tile this frame.
    pub(crate) fn affected(&self) -> u32 {
        self.affected
    }

    /// Per moving object: the maps it is drawn into this frame.
    pub(crate) fn per_object(&self) -> &[u32] {
        &self.per_object
    }

    /// This frame's share of each transfer between surfaces the moving
    /// objects absorb: of the first bounce's light, of the later bounces'
    /// ([`crate::later_absorb`]).
    pub(crate) fn later_absorbed(&self) -> &crate::later_absorb::Absorbed {
        &self.absorbed
    }

    /// (Map, draw) pairs left out as faint this frame.
    pub(crate) fn faint(&self) -> u32 {
        self.faint
    }

    /// Rasterization instances this frame.
    pub(crate) fn instances(&self) -> u32 {
        self.instances
    }

    /// Maps a moving object reaches that their baked map hides (no tile)
    /// this frame.
    pub(crate) fn hidden(&self) -> u32 {
        self.hidden
    }

    /// Draw calls [`VplMerge::record`] records.
    pub(crate) fn draw_calls(&self) -> u32 {
        if self.affected == 0 {
            return 0;
        }
        self.ranges.iter().filter(|(_, r)| !r.is_empty()).count() as u32
    }

    /// Plans and uploads this frame's merge for the `moving` draws shown at
    /// `transforms` (one per dynamic object). Returns whether the atlas was
    /// re-created (the caller rebinds it); an atlas over the device's limits
    /// is an error and leaves the old one in place.
    pub(crate) fn prepare(
        &mut self,
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        scene_gpu: &SceneGpu,
        moving: &[Draw],
        transforms: &[Mat4],
    ) -> Result<bool, RuntimeError> {
        let draws: Vec<&Draw> = if self.naive {
            scene_gpu.static_draws.iter().chain(moving).collect()
        } else {
            moving.iter().collect()
        };
        let boxes: Vec<Aabb> = draws
            .iter()
            .map(|d| match d.object.and_then(|o| transforms.get(o)) {
                Some(m) => d.bounds.transformed(*m),
                None => d.bounds,
            })
            .collect();
        // masks[v][k]: faces of frame v's map that draw k can touch (none
        // for a VPL without a second map, nor where the baked map hides
        // the draw in every direction it covers: map_cells.rs).
        let mut hidden = 0;
        let mut masks: Vec<Vec<u32>> = self
            .frames
            .iter()
            .enumerate()
            .map(|(v, f)| match f {
                Some((o, n)) => {
                    let mut reached = false;
                    let m: Vec<u32> = boxes
                        .iter()
                        .map(|bx| match face_mask(bx, *o, *n) {
                            0 => 0,
                            m => {
                                reached = true;
                                let hid =
                                    self.cells.as_ref().is_some_and(|c| c.hides(v, *o, *n, bx));
                                if hid { 0 } else { m }
                            }
                        })
                        .collect();
                    if reached && m.iter().all(|&m| m == 0) {
                        hidden += 1;
                    }
                    m
                }
                None => vec![0; boxes.len()],
            })
            .collect();
        // What the moving objects take from the later bounces: every map
        // they reach, the faint ones too.
        self.absorbed = if self.later_range.0 < self.later_range.1 {
            let albedo: Vec<Option<Vec3>> = draws
                .iter()
                .map(|d| {
                    d.object.map(|_| {
                        let a = self.material_albedo.get(d.scene_material);
                        a.copied().unwrap_or(Vec3::ONE)
                    })
                })
                .collect();
            // Each draw's surface in the world (its transform's scale
            // squared, as a uniform scale).
            let area: Vec<f32> = draws
                .iter()
                .map(|d| {
                    let m = d.object.and_then(|o| transforms.get(o));
                    let det = m.map_or(1.0, |m| glam::Mat3::from_mat4(*m).determinant().abs());
                    d.area * det.powf(2.0 / 3.0)
                })
                .collect();
            let frames = &self.frames;
            let cells = self.cells.as_ref();
            crate::later_absorb::absorbed(
                &masks,
                &self.weight,
                self.later_range,
                &albedo,
                // What the object takes of the VPL's light: its share of
                // the emitter's flux, times the share of its directions
                // the baked surfaces leave open (an object behind a wall,
                // seen through the map's coarse cells: little or none).
                |v, k| match frames[v] {
                    Some((o, n)) => {
                        let f = crate::merge_cull::intercepted_by_area(o, n, &boxes[k], area[k]);
                        if f > 0.0 {
                            f * cells.map_or(1.0, |c| c.seen_share(v, o, n, &boxes[k]))
                        } else {
                            f
                        }
                    }
                    None => 0.0,
                },
            )
        } else {
            Default::default()
        };
        // Each draw's faintest shadows, within the setting's share of its
        // light.
        self.faint = crate::merge_cull::leave_out_faint(
            &mut masks,
            &self.frames,
            &self.weight,
            &boxes,
            self.cull_share,
        );
        // Full: only maps some moving object reaches get a tile.
        let chosen: Vec<u32> = (0..self.frames.len() as u32)
            .filter(|&v| {
                self.frames[v as usize].is_some()
                    && (self.naive || masks[v as usize].iter().any(|&m| m != 0))
            })
            .collect();
        // Plan everything first; nothing changes unless it all fits.
        let atlas = if chosen.len() as u32 > self.atlas.capacity {
            let maps = self.frames.iter().flatten().count() as u32;
            let cap = (chosen.len() as u32).next_power_of_two().min(maps);
            Some(checked_atlas(device, self.map_size, cap)?)
        } else {
            None
        };
        let layout = atlas.as_ref().unwrap_or(&self.atlas);
        let mut jobs = Vec::with_capacity(chosen.len());
        let mut tiles = vec![u32::MAX; self.frames.len()];
        for (slot, &v) in chosen.iter().enumerate() {
            let Some((o, n)) = self.frames[v as usize] else {
                continue;
            };
            let t = layout.tile_origin(slot as u32);
            jobs.push(GpuHemiJob {
                origin: o.extend(0.0).to_array(),
                normal: n.extend(0.0).to_array(),
                tile: [t[0], t[1], 0, 0],
            });
            tiles[v as usize] = slot as u32;
        }
        // Moving meshes use the level of detail matched to their size in
        // each map; instances are grouped per (draw, level).
        let mut instances: Vec<[u32; 4]> = Vec::new();
        let mut ranges = Vec::new();
        for (k, d) in draws.iter().enumerate() {
            let levels: Vec<usize> = chosen
                .iter()
                .map(|&v| {
                    if d.object.is_some() {
                        let o = self.frames[v as usize].map_or(Vec3::ZERO, |f| f.0);
                        lod_for(&boxes[k], o, self.map_size, d.lods.len())
                    } else {
                        0
                    }
                })
                .collect();
            for (level, lod) in d.lods.iter().enumerate() {
                let start = instances.len() as u32;
                for (slot, &v) in chosen.iter().enumerate() {
                    let m = masks[v as usize][k];
                    if levels[slot] != level || m == 0 {
                        continue;
                    }
                    for face in 0..4 {
                        if m & (1 << face) != 0 {
                            instances.push([d.id, slot as u32, face, 0]);
                        }
                    }
                }
                ranges.push((lod.clone(), start..instances.len() as u32));
            }
        }
        // The job and instance tables grow to the next power of two.
        let max_binding = device.limits().max_storage_buffer_binding_size;
        for (what, count, stride) in [
            ("the merge's job table", jobs.len() as u64, 48u64),
            ("the merge's instance table", instances.len() as u64, 16u64),
        ] {
            let bytes = count.next_power_of_two() * stride;
            if bytes > max_binding {
                return Err(RuntimeError::DeviceLimit {
                    what: format!("{what} ({count} entries, bytes in one storage binding)"),
                    needed: bytes,
                    limit: max_binding,
                });
            }
        }
        let grown = atlas.is_some();
        if let Some(a) = atlas {
            self.atlas = a;
        }
        self.jobs = jobs;
        self.tiles = tiles;
        self.ranges = ranges;
        queue.write_buffer(&self.tile_buf, 0, bytemuck::cast_slice(&self.tiles));
        self.pass.set_work(
            device,
            queue,
            scene_gpu,
            &self.atlas,
            &self.jobs,
            &instances,
        );
        self.affected = chosen.len() as u32;
        self.hidden = hidden;
        self.instances = instances.len() as u32;
        // Per object, the maps one of its draws is drawn into (an object of
        // several draws counted once a map: `last` is the map it was last
        // counted for).
        let mut per_object = vec![0u32; transforms.len()];
        let mut last = vec![u32::MAX; transforms.len()];
        for &v in &chosen {
            for (k, d) in draws.iter().enumerate() {
                if let Some(o) = d.object.filter(|&o| o < per_object.len())
                    && masks[v as usize][k] != 0
                    && last[o] != v
                {
                    last[o] = v;
                    per_object[o] += 1;
                }
            }
        }
        self.per_object = per_object;
        Ok(grown)
    }

    /// Records the merge pass (nothing when no map is affected). Returns the
    /// number of draw calls.
    pub(crate) fn record(
        &self,
        encoder: &mut wgpu::CommandEncoder,
        ts: Option<wgpu::RenderPassTimestampWrites<'_>>,
    ) -> u32 {
        if self.affected == 0 {
            return 0;
        }
        self.pass
            .encode(encoder, &self.atlas, &self.ranges, true, ts)
    }
}

#[cfg(test)]
#[path = "merge_tests.rs"]
mod tests;
