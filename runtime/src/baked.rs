//! A loaded `.gibake` asset on the GPU: static VPLs in the GPU's own
//! layout ([`GpuVpl`], each VPL's map origin computed here, once, for
//! shading and the merge alike), the baked hemisphere maps (one `R32Float`
//! 2D atlas in the asset's own tile layout, `gibake_asset::atlas_grid`), the
//! static primary shadow map and, only for scenes with moving objects, the
//! static RSM metric plus each texel's share of its VPL's flux (baked; for
//! partial occlusion). The second maps of the VPLs with a second origin
//! (format 4.7, `gibake_asset::LowerVpl`: the light below a VPL's horizon)
//! sit below the first maps' atlas in the same texture, in their own
//! atlas's layout, also uploaded as it is.

use gibake_asset::{Asset, LEVEL3_NODES, NODES_PER_VPL, VplRecord};
use gibake_gpu::LightView;
use gibake_gpu::vpl::{GpuVpl, NO_MAP};
use wgpu::util::DeviceExt;

use crate::RuntimeError;

/// RSM data for the dynamic merge.
pub(crate) struct RsmGpu {
    /// Static metric per texel (`R32Float`).
    pub static_metric: wgpu::TextureView,
    /// `(vpl, share)` per texel; share is fixed point (2^24 = the whole VPL).
    pub texel_info: wgpu::Buffer,
    /// The light view at the RSM resolution.
    pub view: LightView,
    /// Its light (index into the scene's lights).
    pub light: usize,
}

/// The asset's GPU resources.
pub(crate) struct BakedGpu {
    /// The VPLs as uploaded (CPU copy, for choosing the affected maps):
    /// `position` is the map origin.
    pub vpls: Vec<GpuVpl>,
    /// The later bounces' VPLs (format 4.6): the last of [`BakedGpu::vpls`]
    /// (`gibake_asset::Manifest::later_vpls`).
    pub later: u32,
    /// The light the surfaces reflect after each bounce of the bake's
    /// series and its rest (`gibake_asset::LaterRecord`), where the asset
    /// has later VPLs: what [`crate::later_absorb::later_scale`] weighs.
    pub later_series: Option<(Vec<[f32; 3]>, [f32; 3])>,
    /// Where the later VPLs' light came from (format 4.8;
    /// `gibake_asset::LaterSources`): what `later_occlusion.wgsl` weighs
    /// the first bounce's occluded shares by. `None`: the level's mean.
    pub later_sources: Option<gibake_asset::LaterSources>,
    /// [`BakedGpu::vpls`], then their near-field trees (`NODES_PER_VPL`
    /// [`GpuVpl`]s per VPL, in VPL order), then one far-field record per
    /// VPL (its own with `position` its far-field centre,
    /// `gibake_asset::far_field_centre`, and its facing shift,
    /// `gibake_asset::facing`), then its level-1 and level-2 nodes' facing
    /// shifts (`gibake_asset::FACINGS_PER_VPL − 1` records per VPL), then
    /// one second-map record per VPL (`position` its second origin,
    /// `normal` the opposite of its normal, `map` its second map's tile or
    /// `NO_MAP`, `texels` 1, or all zeros for a VPL without a second
    /// origin; shade.wgsl `lower_record`) (storage).
    pub vpl_buf: wgpu::Buffer,
    /// Baked hemisphere maps, one 2D atlas (one +inf tile when none is
    /// stored), the second maps' atlas below it from row
    /// [`BakedGpu::lower_row`].
    pub static_maps: wgpu::TextureView,
    /// Tiles per row of [`BakedGpu::static_maps`]'s first atlas.
    pub static_cols: u32,
    /// Tiles per row of the second maps' atlas (1 when there is none).
    pub lower_cols: u32,
    /// The texel row where the second maps' atlas starts.
    pub lower_row: u32,
    /// Per static VPL: its second map's frame (origin, normal: the
    /// opposite of the VPL's), where it has a second origin (for the
    /// merge).
    pub lower: Vec<Option<(glam::Vec3, glam::Vec3)>>,
    /// The baked maps' coarse cells for the merge (set by the world when
    /// it merges; `None` otherwise: nothing kept that is not used).
    pub map_cells: Option<crate::map_cells::MapCells>,
    /// Hemisphere map size.
    pub map_size: u32,
    /// Static primary shadow map.
    pub primary: wgpu::TextureView,
    /// The light view at the primary map's resolution.
    pub view: LightView,
    /// Present only when the asset holds RSM data (scene with moving objects).
    pub rsm: Option<RsmGpu>,
    /// The other lights' views with a stored static RSM (format 4.1), in
    /// the manifest's order.
    pub view_rsms: Vec<RsmGpu>,
    /// Bytes uploaded.
    pub bytes: u64,
}

/// The light view stored in a manifest, at `size`.
pub(crate) fn light_view(asset: &Asset, size: u32) -> LightView {
    LightView::from_record(
        &asset.manifest.light_view,
        asset.manifest.settings.shadow_map_size,
    )
    .resized(size)
}

pub(crate) fn r32_texture(
    device: &wgpu::Device,
    queue: &wgpu::Queue,
    label: &str,
    width: u32,
    height: u32,
    data: &[f32],
) -> wgpu::Texture {
    device.create_texture_with_data(
        queue,
        &wgpu::TextureDescriptor {
            label: Some(label),
            size: wgpu::Extent3d {
                width,
                height,
                depth_or_array_layers: 1,
            },
            mip_level_count: 1,
            sample_count: 1,
            dimension: wgpu::TextureDimension::D2,
            format: wgpu::TextureFormat::R32Float,
            usage: wgpu::TextureUsages::TEXTURE_BINDING | wgpu::TextureUsages::COPY_SRC,
            view_formats: &[],
        },
        wgpu::util::TextureDataOrder::LayerMajor,
        bytemuck::cast_slice(data),
    )
}

impl BakedGpu {
    /// Uploads `asset`.
    pub(crate) fn new(
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        asset: &Asset,
    ) -> Result<BakedGpu, RuntimeError> {
        let m = &asset.manifest;
        let max = device.limits().max_texture_dimension_2d;
        // The baked maps as one 2D atlas in the asset's own layout (a 2D
        // atlas holds far more maps than a texture array has layers).
        let s = m.settings.vpl_map_size;
        let (cols, rows) = crate::atlas::layout(
            device,
            "the asset's VPL map atlas (bake fewer VPLs or smaller maps)",
            m.map_count,
            s,
        )?;
        // The asset's atlas as it is; one +inf tile when no map is stored.
        let one_tile;
        let atlas: &[f32] = if m.map_count == 0 {
            one_tile = vec![f32::INFINITY; (s as usize) * (s as usize)];
            &one_tile
        } else if asset.vpl_maps.count() == m.map_count && asset.vpl_maps.tile_size() == s {
            asset.vpl_maps.texels()
        } else {
            return Err(RuntimeError::InvalidSetting(format!(
                "the asset holds {} maps of {}² for {} maps of {s}²",
                asset.vpl_maps.count(),
                asset.vpl_maps.tile_size(),
                m.map_count
            )));
        };
        let (w, h) = (cols * s, rows * s);
        // The second maps' atlas, below the first.
        let lm = &asset.vpl_lower_maps;
        let lower_count = m.lower_map_count;
        if lm.count() != lower_count || (lower_count > 0 && lm.tile_size() != s) {
            return Err(RuntimeError::InvalidSetting(format!(
                "the asset holds {} second maps of {}² for {lower_count} maps of {s}²",
                lm.count(),
                lm.tile_size()
            )));
        }
        let (lower_cols, lower_rows) = if lower_count == 0 {
            (1, 0)
        } else {
            crate::atlas::layout(
                device,
                "the asset's second VPL map atlas (bake fewer VPLs or smaller maps)",
                lower_count,
                s,
            )?
        };
        let (tw, th) = (w.max(lower_cols * s), h + lower_rows * s);
        if th > max {
            return Err(RuntimeError::DeviceLimit {
                what: format!(
                    "the asset's VPL maps and second maps in one texture ({} and {lower_count} maps of {s}²; bake fewer VPLs or smaller maps)",
                    m.map_count
                ),
                needed: u64::from(th),
                limit: u64::from(max),
            });
        }
        let static_maps = if lower_count == 0 {
            r32_texture(device, queue, "baked VPL maps", w, h, atlas)
        } else {
            let t = device.create_texture(&wgpu::TextureDescriptor {
                label: Some("baked VPL maps and second maps"),
                size: wgpu::Extent3d {
                    width: tw,
                    height: th,
                    depth_or_array_layers: 1,
                },
                mip_level_count: 1,
                sample_count: 1,
                dimension: wgpu::TextureDimension::D2,
                format: wgpu::TextureFormat::R32Float,
                usage: wgpu::TextureUsages::TEXTURE_BINDING
                    | wgpu::TextureUsages::COPY_SRC
                    | wgpu::TextureUsages::COPY_DST,
                view_formats: &[],
            });
            for (texels, width, height, row) in
                [(atlas, w, h, 0), (lm.texels(), lm.width(), lm.height(), h)]
            {
                queue.write_texture(
                    wgpu::TexelCopyTextureInfo {
                        texture: &t,
                        mip_level: 0,
                        origin: wgpu::Origin3d { x: 0, y: row, z: 0 },
                        aspect: wgpu::TextureAspect::All,
                    },
                    bytemuck::cast_slice(texels),
                    wgpu::TexelCopyBufferLayout {
                        offset: 0,
                        bytes_per_row: Some(4 * width),
                        rows_per_image: Some(height),
                    },
                    wgpu::Extent3d {
                        width,
                        height,
                        depth_or_array_layers: 1,
                    },
                );
            }
            t
        }
        .create_view(&Default::default());
        let pd = &asset.primary_depth;
        let rsm_size = asset.rsm.as_ref().map(|r| r.size).unwrap_or(0);
        for (what, size) in [
            ("the baked primary shadow map", pd.size),
            ("the baked RSM", rsm_size),
        ] {
            if size > max {
                return Err(RuntimeError::DeviceLimit {
                    what: format!("{what} ({size}² texels)"),
                    needed: u64::from(size),
                    limit: u64::from(max),
                });
            }
        }
        let primary = r32_texture(
            device,
            queue,
            "baked primary shadow map",
            pd.size,
            pd.size,
            &pd.data,
        )
        .create_view(&Default::default());
        // On the GPU a VPL's position is its map origin (position lifted
        // along the normal, `hemisphere::vpl_origin`), computed once here
        // rather than per pixel and VPL in the shader; a record with no
        // stored map says so; its `texels` carries its far-field lobe
        // coherence, from its own near-field tree (`GpuVpl::texels`).
        // Each VPL's lobes and facing shifts, from its tree with the
        // level-3 normals weighted by their texels' coherence
        // (`gibake_asset::tree_lobes`): sums over its texels.
        // A VPL on a light's outer rings or of the later bounces is lifted
        // by one of its members' radius (`Manifest::origin_lift_flags`,
        // `hemisphere::record_origin`).
        let lobes = asset.tree_lobes();
        let ring = m.origin_lift_flags();
        let vpls: Vec<GpuVpl> = asset
            .vpls
            .iter()
            .zip(lobes.iter().map(|l| l.vpl))
            .zip(&ring)
            .map(|((v, lobe), &ring)| {
                let o = gibake_gpu::hemisphere::record_origin(v, ring);
                GpuVpl {
                    position: o.to_array(),
                    map: if v.map < m.map_count { v.map } else { NO_MAP },
                    texels: gibake_gpu::vpl::lobe_fixed(lobe),
                    ..gpu_vpl(v)
                }
            })
            .collect();
        // A node's `texels` carries its lobe coherence (`GpuVpl::texels`; at
        // least 1, as 0 marks an empty node): a level-1 or level-2 node's
        // from the texels under it, a level-3 node's its texels' own
        // (`Asset::vpl_coherence`; 1, its cosine lobe, for an asset without).
        let nodes: Vec<GpuVpl> = asset
            .vpl_nodes
            .chunks(NODES_PER_VPL)
            .zip(&lobes)
            .enumerate()
            .flat_map(|(i, (tree, lobes))| {
                let (lobes, level3) = (&lobes.nodes, asset.level3_coherence(i));
                tree.iter().enumerate().map(move |(k, n)| {
                    let mut g = gpu_vpl(n);
                    let c = match k.checked_sub(NODES_PER_VPL - LEVEL3_NODES) {
                        Some(j) => level3.get(j).copied(),
                        None => lobes.get(k).copied(),
                    };
                    if let Some(c) = c.filter(|_| n.texels != 0) {
                        g.texels = gibake_gpu::vpl::lobe_fixed(c).max(1);
                    }
                    g
                })
            })
            .collect();
        // Where each VPL is drawn from afar: its texels' centroid
        // (`gibake_asset::far_field_centre`), else its map origin; the rest
        // of the record is its own facing shift's F, by columns in
        // `normal`, `flux` and (`area`, `texels`, `map`) as f32 bits
        // (shade.wgsl `far_facing`).
        let far: Vec<GpuVpl> = vpls
            .iter()
            .zip(asset.far_field_centres())
            .zip(&lobes)
            .map(|((v, c), l)| {
                let [c0, c1, c2] = l.facings[0].cols;
                GpuVpl {
                    position: c.unwrap_or(v.position),
                    area: c2[0],
                    normal: c0,
                    texels: c2[1].to_bits(),
                    flux: c1,
                    map: c2[2].to_bits(),
                }
            })
            .collect();
        // The level-1 and level-2 nodes' facing shifts (FACING_NODES per
        // VPL), F by columns in `position`, `normal` and `flux` (shade.wgsl
        // `node_facing`).
        let node_facings: Vec<GpuVpl> = lobes
            .iter()
            .flat_map(|l| {
                l.facings[1..].iter().map(|f| GpuVpl {
                    position: f.cols[0],
                    area: 0.0,
                    normal: f.cols[1],
                    texels: 0,
                    flux: f.cols[2],
                    map: NO_MAP,
                })
            })
            .collect();
        // Each VPL's second map (shade.wgsl `lower_record`): its second
        // origin, the opposite of its normal, its tile in the second atlas
        // (NO_MAP: it sees no surface), `texels` 1; all zeros without one
        // (an asset of format 4.6 or older has none).
        let lower: Vec<Option<(glam::Vec3, glam::Vec3)>> = (0..asset.vpls.len())
            .map(|i| {
                let l = asset.vpl_lower.get(i).filter(|l| l.is_some())?;
                let n = -glam::Vec3::from_array(asset.vpls[i].normal);
                Some((glam::Vec3::from_array(l.origin), n))
            })
            .collect();
        let lower_records: Vec<GpuVpl> = lower
            .iter()
            .enumerate()
            .map(|(i, l)| match l {
                Some((o, n)) => GpuVpl {
                    position: o.to_array(),
                    area: 0.0,
                    normal: n.to_array(),
                    texels: 1,
                    flux: [0.0; 3],
                    map: match asset.vpl_lower[i].map {
                        t if t < lower_count => t,
                        _ => NO_MAP,
                    },
                },
                None => GpuVpl::default(),
            })
            .collect();
        // The VPLs, then their near-field trees (NODES_PER_VPL records per
        // VPL, as stored), then their far-field records, then their nodes'
        // facing shifts, then their second maps' records, in one storage
        // buffer: shading binds four.
        let records = [
            vpls.as_slice(),
            nodes.as_slice(),
            far.as_slice(),
            node_facings.as_slice(),
            lower_records.as_slice(),
        ]
        .concat();
        let vpl_bytes = std::mem::size_of_val(records.as_slice()) as u64;
        let max_binding = device.limits().max_storage_buffer_binding_size;
        if vpl_bytes > max_binding {
            return Err(RuntimeError::DeviceLimit {
                what: format!(
                    "the asset's {} VPLs, their near-field nodes, far-field, facing and second-map records (bytes in one storage binding; bake fewer VPLs)",
                    vpls.len()
                ),
                needed: vpl_bytes,
                limit: max_binding,
            });
        }
        let vpl_buf = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some("static VPLs, near-field nodes, far-field and facing records"),
            contents: if records.is_empty() {
                &[0u8; 48]
            } else {
                bytemuck::cast_slice(&records)
            },
            usage: wgpu::BufferUsages::STORAGE,
        });
        let mut bytes =
            (atlas.len() * 4 + lm.texels().len() * 4 + pd.data.len() * 4) as u64 + vpl_bytes;
        let rsm = asset.rsm.as_ref().map(|r| {
            let g = rsm_gpu(device, queue, r, vpls.len(), light_view(asset, r.size), 0);
            bytes += g.1;
            g.0
        });
        let m = &asset.manifest;
        let view_rsms = m
            .view_rsms
            .iter()
            .zip(&asset.view_rsms)
            .filter_map(|(&v, r)| {
                let rec = m.views.get(v as usize)?;
                let view =
                    LightView::from_record(&rec.view, m.light_map_size.max(1)).resized(r.size);
                let g = rsm_gpu(device, queue, r, vpls.len(), view, rec.light as usize);
                bytes += g.1;
                Some(g.0)
            })
            .collect();
        Ok(BakedGpu {
            later: m.later_vpls(),
            later_series: m
                .later
                .as_ref()
                .filter(|_| m.later_vpls() > 0)
                .map(|l| (l.per_bounce.clone(), l.tail)),
            later_sources: m.later_sources.clone(),
            vpls,
            vpl_buf,
            static_maps,
            static_cols: cols,
            lower_cols,
            lower_row: h,
            lower,
            map_cells: None,
            map_size: s,
            primary,
            view: light_view(asset, pd.size),
            rsm,
            view_rsms,
            bytes,
        })
    }
}

/// A stored RSM on the GPU (its metric texture and texel shares) and the
/// bytes uploaded.
fn rsm_gpu(
    device: &wgpu::Device,
    queue: &wgpu::Queue,
    r: &gibake_asset::RsmData,
    vpl_count: usize,
    view: LightView,
    light: usize,
) -> (RsmGpu, u64) {
    let metric = r32_texture(device, queue, "baked RSM metric", r.size, r.size, &r.metric)
        .create_view(&Default::default());
    // (VPL, its share of the VPL's flux) per texel, as baked.
    let info: Vec<[u32; 2]> = r
        .vpl
        .iter()
        .zip(&r.share)
        .map(|(&v, &share)| {
            if (v as usize) < vpl_count {
                [v, share]
            } else {
                [u32::MAX, 0]
            }
        })
        .collect();
    let texel_info = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
        label: Some("RSM texel shares"),
        contents: bytemuck::cast_slice(&info),
        usage: wgpu::BufferUsages::STORAGE,
    });
    let bytes = (r.metric.len() * 4 + info.len() * 8) as u64;
    (
        RsmGpu {
            static_metric: metric,
            texel_info,
            view,
            light,
        },
        bytes,
    )
}

/// A record of the asset's layout in the GPU's (the same values).
fn gpu_vpl(v: &VplRecord) -> GpuVpl {
    GpuVpl {
        position: v.position,
        area: v.area,
        normal: v.normal,
        texels: v.texels,
        flux: v.flux,
        map: v.map,
    }
}
