//! Small in-memory assets shared by the integration tests.
#![allow(dead_code, missing_docs)]

use std::path::{Path, PathBuf};

use gibake_asset::*;

/// Deterministic pseudo-random numbers in [0, 1).
pub struct Rng(u64);

impl Rng {
    pub fn new(seed: u64) -> Rng {
        Rng(seed.wrapping_mul(0x9E37_79B9_7F4A_7C15) | 1)
    }
    pub fn next_u64(&mut self) -> u64 {
        self.0 ^= self.0 << 13;
        self.0 ^= self.0 >> 7;
        self.0 ^= self.0 << 17;
        self.0
    }
    pub fn f32(&mut self) -> f32 {
        (self.next_u64() >> 40) as f32 / (1u64 << 24) as f32
    }
    pub fn below(&mut self, n: usize) -> usize {
        (self.next_u64() % n as u64) as usize
    }
}

pub const SHADOW: u32 = 16;
pub const VPL_MAP: u32 = 8;
pub const RSM: u32 = 8;
pub const VPLS: usize = 10;
pub const LIGHT_MAP: u32 = 4;
/// The sample's first light's VPLs (the first records).
pub const FIRST_LIGHT_VPLS: usize = 6;

/// A small asset: 10 VPLs, 7 of them with a hemisphere map (5x5 grid would be
/// 3 cols x 3 rows), maps with some +inf texels; an RSM when `dynamic`.
pub fn sample_asset(dynamic: bool) -> Asset {
    let mut rng = Rng::new(7);
    let mut vpls = Vec::new();
    let mut layer = 0u32;
    for i in 0..VPLS {
        let has_map = i % 3 != 1;
        let map = if has_map {
            layer += 1;
            layer - 1
        } else {
            NO_MAP
        };
        vpls.push(VplRecord {
            position: [
                rng.f32() * 4.0 - 2.0,
                rng.f32() * 3.0,
                rng.f32() * 4.0 - 2.0,
            ],
            area: 0.01 + rng.f32() * 0.1,
            normal: [0.0, 1.0, 0.0],
            texels: 1 + rng.below(20) as u32,
            flux: [rng.f32(), rng.f32() * 0.5, rng.f32() * 0.25],
            map,
        });
    }
    // Near-field nodes: the VPL split in four on level 1, zeros below.
    let vpl_nodes: Vec<VplRecord> = vpls
        .iter()
        .flat_map(|v| {
            (0..gibake_asset::NODES_PER_VPL).map(move |k| {
                let mut r = VplRecord::EMPTY_NODE;
                if k < 4 {
                    r.position = v.position;
                    r.position[0] += k as f32 * 0.01;
                    r.area = v.area / 4.0;
                    r.normal = v.normal;
                    r.texels = 1;
                    r.flux = v.flux.map(|f| f / 4.0);
                }
                r
            })
        })
        .collect();
    let map_count = layer as usize;
    let texels = (VPL_MAP * VPL_MAP) as usize;
    let layers: Vec<f32> = (0..map_count * texels)
        .map(|_| {
            if rng.f32() < 0.3 {
                f32::INFINITY
            } else {
                0.1 + rng.f32() * 5.0
            }
        })
        .collect();
    let vpl_maps = MapAtlas::from_maps(VPL_MAP, layers.chunks(texels)).expect("maps of VPL_MAP²");
    let primary: Vec<f32> = (0..(SHADOW * SHADOW) as usize)
        .map(|_| {
            if rng.f32() < 0.1 {
                f32::INFINITY
            } else {
                1.0 + rng.f32() * 9.0
            }
        })
        .collect();
    let lm = (LIGHT_MAP * LIGHT_MAP) as usize;
    let light_texels: Vec<f32> = (0..4 * lm)
        .map(|_| {
            if rng.f32() < 0.25 {
                f32::INFINITY
            } else {
                0.5 + rng.f32() * 2.0
            }
        })
        .collect();
    let light_maps =
        MapAtlas::from_maps(LIGHT_MAP, light_texels.chunks(lm)).expect("maps of LIGHT_MAP²");
    let rsm = dynamic.then(|| {
        let n = (RSM * RSM) as usize;
        let metric = (0..n)
            .map(|_| {
                if rng.f32() < 0.2 {
                    f32::INFINITY
                } else {
                    1.0 + rng.f32()
                }
            })
            .collect();
        let flux: Vec<[f32; 3]> = (0..n).map(|_| [rng.f32(), rng.f32(), rng.f32()]).collect();
        let vpl = (0..n)
            .map(|_| {
                if rng.f32() < 0.2 {
                    u32::MAX
                } else {
                    // The first light's VPLs (the RSM is its).
                    rng.below(FIRST_LIGHT_VPLS) as u32
                }
            })
            .collect();
        RsmData::from_flux(RSM, metric, &flux, vpl, VPLS)
    });
    // Second origins (format 4.7): VPLs 0, 4 and 8 with a second map,
    // 2 and 6 with one that sees no surface, the others none.
    let mut lrng = Rng::new(11);
    let mut lower_texels: Vec<f32> = Vec::new();
    let vpl_lower: Vec<gibake_asset::LowerVpl> = vpls
        .iter()
        .enumerate()
        .map(|(i, v)| {
            let origin = [v.position[0], v.position[1] - 0.05, v.position[2]];
            match i % 4 {
                0 => {
                    let map = (lower_texels.len() / texels) as u32;
                    lower_texels.extend((0..texels).map(|_| {
                        if lrng.f32() < 0.4 {
                            f32::INFINITY
                        } else {
                            0.2 + lrng.f32() * 3.0
                        }
                    }));
                    gibake_asset::LowerVpl { origin, map }
                }
                2 => gibake_asset::LowerVpl {
                    origin,
                    map: NO_MAP,
                },
                _ => gibake_asset::LowerVpl::NONE,
            }
        })
        .collect();
    let vpl_lower_maps =
        MapAtlas::from_maps(VPL_MAP, lower_texels.chunks(texels)).expect("maps of VPL_MAP²");
    Asset {
        manifest: Manifest {
            provenance: Provenance {
                baker_version: "0.1.0".into(),
                scene_name: "corner.gltf".into(),
                adapter: "llvmpipe (LLVM 15.0.6, 256 bits)".into(),
                backend: "vulkan".into(),
                driver: "Mesa 22.3.6".into(),
            },
            settings: BakeSettings {
                rsm_size: RSM,
                vpl_map_size: VPL_MAP,
                shadow_map_size: SHADOW,
                threshold: 0.05,
                vpl_budget: Some(VPLS as u32),
            },
            static_scene_hash: [0xAB; 32],
            light_view: LightViewRecord {
                directional: false,
                view_proj: std::array::from_fn(|i| i as f32 * 0.25 - 1.0),
                origin: [0.0, 5.0, 0.0],
                direction: [0.0, -1.0, 0.0],
                texel_scale: 0.01,
                texel_area: 0.0001,
            },
            vpl_count: 0,
            map_count: 0,
            has_dynamic: false,
            files: vec![],
            lights: vec![
                gibake_asset::LightRecord {
                    name: "Key".into(),
                    kind: gibake_asset::LIGHT_SPOT,
                    color: [40.0, 38.0, 35.0],
                    position: [0.9, 2.3, 1.4],
                    direction: [-0.449, -0.648, -0.615],
                    inner_cone: 0.49,
                    outer_cone: 0.7,
                    range: 0.0,
                    vpls: FIRST_LIGHT_VPLS as u32,
                },
                gibake_asset::LightRecord {
                    name: "Lamp".into(),
                    kind: gibake_asset::LIGHT_POINT,
                    color: [8.0, 8.0, 9.0],
                    position: [0.0, 1.0, 0.0],
                    direction: [0.0, 0.0, -1.0],
                    inner_cone: 0.0,
                    outer_cone: 0.0,
                    range: 2.5,
                    vpls: 4,
                },
            ],
            // The lamp's six faces; the ±Y faces store no map.
            views: (0..6u32)
                .map(|face| gibake_asset::ViewRecord {
                    light: 1,
                    view: LightViewRecord {
                        directional: false,
                        view_proj: std::array::from_fn(|i| (i as f32 + face as f32) * 0.125),
                        origin: [0.0, 1.0, 0.0],
                        direction: [0.0, 0.0, 1.0],
                        texel_scale: 0.5,
                        texel_area: 0.25,
                    },
                    tile: [0, 1, NO_MAP, NO_MAP, 2, 3][face as usize],
                })
                .collect(),
            light_map_size: LIGHT_MAP,
            view_rsms: Vec::new(),
            ring_vpls: Vec::new(),
            scene_options: None,
            swept_bounds: None,
            later: None,
            lower_map_count: 0,
            later_sources: None,
        },
        vpl_coherence: vec![1.0; vpls.len() * gibake_asset::LEVEL3_NODES],
        vpl_lower,
        vpl_lower_maps,
        vpls,
        vpl_nodes,
        primary_depth: Map {
            size: SHADOW,
            data: primary,
        },
        vpl_maps,
        rsm,
        light_maps,
        view_rsms: Vec::new(),
    }
}

/// The views of [`sample_asset_with_view_rsms`] that store an RSM (the
/// lamp's faces +X, +Z, −Z): three tiles in a 2 × 2 grid, one unused.
pub const VIEW_RSMS: [u32; 3] = [1, 4, 5];

/// [`sample_asset`]`(true)` with format 4.1's view RSMs: the RSMs of the
/// views [`VIEW_RSMS`] (all the lamp's, light 1: its VPLs are records
/// `FIRST_LIGHT_VPLS..VPLS`), `RSM²` each, with empty texels, texels of no
/// VPL and shares from the flux.
pub fn sample_asset_with_view_rsms() -> Asset {
    let mut asset = sample_asset(true);
    let mut rng = Rng::new(99);
    let n = (RSM * RSM) as usize;
    asset.manifest.view_rsms = VIEW_RSMS.to_vec();
    asset.view_rsms = VIEW_RSMS
        .iter()
        .map(|_| {
            let metric: Vec<f32> = (0..n)
                .map(|_| {
                    if rng.f32() < 0.2 {
                        f32::INFINITY
                    } else {
                        0.5 + rng.f32() * 2.0
                    }
                })
                .collect();
            let flux: Vec<[f32; 3]> = (0..n).map(|_| [rng.f32(), rng.f32(), rng.f32()]).collect();
            let vpl = metric
                .iter()
                .map(|m| {
                    if m.is_infinite() || rng.f32() < 0.1 {
                        u32::MAX
                    } else {
                        (FIRST_LIGHT_VPLS + rng.below(VPLS - FIRST_LIGHT_VPLS)) as u32
                    }
                })
                .collect();
            RsmData::from_flux(RSM, metric, &flux, vpl, VPLS)
        })
        .collect();
    asset
}

/// `asset` as `load` returns it after `write`: counts filled in, `files` from disk.
pub fn as_written(asset: &Asset, loaded: &Asset) -> Asset {
    let mut a = asset.clone();
    a.manifest.vpl_count = a.vpls.len() as u32;
    a.manifest.map_count = a.stored_map_count() as u32;
    a.manifest.lower_map_count = a.vpl_lower_maps.count();
    a.manifest.has_dynamic = a.rsm.is_some();
    a.manifest.files = loaded.manifest.files.clone();
    a
}

/// `asset` as it loads from a manifest of format 4.6 or older (what
/// `testing::manifest_bytes_4_6` and the older writers list): no second
/// origins or maps (format 4.7), their files not listed.
pub fn without_4_7(asset: &Asset) -> Asset {
    let mut a = asset.clone();
    a.vpl_lower.clear();
    a.vpl_lower_maps = MapAtlas::empty(a.manifest.settings.vpl_map_size);
    a.manifest.lower_map_count = 0;
    a.manifest
        .files
        .retain(|f| f.name != FILE_VPL_LOWER && f.name != FILE_VPL_LOWER_MAPS);
    a
}

/// Writes `asset` to `<tmp>/scene.gibake` and returns the path.
pub fn written(tmp: &Path, asset: &Asset) -> PathBuf {
    let dir = tmp.join("scene.gibake");
    write(asset, &dir).expect("write");
    dir
}

/// The names of the files in `dir`, sorted.
pub fn file_names(dir: &Path) -> Vec<String> {
    let mut v: Vec<String> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    v.sort();
    v
}

/// Rewrites `manifest.bin` in `dir` with `f` applied to the manifest
/// (re-encoded, valid checksum).
pub fn edit_manifest(dir: &Path, f: impl FnOnce(&mut Manifest)) {
    // Decoded without checking its values, so that it works on manifests
    // `load_manifest` would refuse.
    let bytes = std::fs::read(dir.join("manifest.bin")).unwrap();
    let (mut m, _minor) = testing::decode_manifest_unchecked(&bytes).expect("manifest payload");
    f(&mut m);
    std::fs::write(
        dir.join("manifest.bin"),
        testing::manifest_bytes(&m).unwrap(),
    )
    .unwrap();
}

/// Replaces file `name` in `dir` by `bytes` and updates its manifest entry so
/// that the checksums pass (to reach the parsers behind them).
pub fn replace_signed(dir: &Path, name: &str, bytes: &[u8]) {
    std::fs::write(dir.join(name), bytes).unwrap();
    edit_manifest(dir, |m| {
        let e = m.files.iter_mut().find(|e| e.name == name).unwrap();
        e.size = bytes.len() as u64;
        e.blake3 = *blake3::hash(bytes).as_bytes();
    });
}

/// `manifest.bin` bytes `bytes` with the payload cut to its first `keep`
/// bytes and `tail` appended (length and checksum recomputed): to reach the
/// decoder of what a minor appends.
pub fn with_payload_tail(bytes: &[u8], keep: usize, tail: &[u8]) -> Vec<u8> {
    let mut out = bytes[..20].to_vec();
    let mut p = bytes[20..20 + keep].to_vec();
    p.extend_from_slice(tail);
    out[12..20].copy_from_slice(&(p.len() as u64).to_le_bytes());
    out.extend_from_slice(&p);
    let h = *blake3::hash(&out).as_bytes();
    out.extend_from_slice(&h);
    out
}
