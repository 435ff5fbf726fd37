//! The bake's method revision ([`gibake_bake::BAKE_METHOD`]) against what a
//! bake writes: small bakes of bundled scenes (a spot light; every light
//! of a room with a spot and two point lights), each with the first bounce
//! alone (`--bounces 1`, the paper's method) and with every bounce (the
//! default), their VPLs, near-field trees, hemisphere maps and (revision 8)
//! second origins and maps hashed, held to the hashes recorded for the
//! current revision. The one-bounce VPLs, trees and first maps are held
//! apart too: `--bounces 1` writes what the first bounce alone wrote when
//! they were recorded (revision 6's until revision 9 moved the finest
//! nodes across a step), whatever the later bounces (issue 50) do, and the
//! second origins (revision 8) only add to it.
//! These are the parts computed on the CPU by rays and the
//! clustering, the same on every adapter; the GPU's shadow maps are left
//! out.
//!
//! When this fails after a change that meant to change the bake, bump
//! `BAKE_METHOD` in crates/bake/src/lib.rs (assets of the older method then
//! read as stale: "baker version changed (… → …+bake.N): the bake's method
//! was revised") and record the new revision and hashes below. When it
//! fails after a change that did not mean to, the bake changed by accident.
//!
//! Runs on the GPU (lavapipe in CI; the shadow map is a GPU pass); without
//! an adapter it fails with a message saying what to install.

use std::path::Path;

use gibake_asset::Asset;
use gibake_bake::cluster::ClusterTarget;
use gibake_bake::{BAKE_METHOD, BakeOptions, NoProgress, bake};
use gibake_gpu::GpuContext;
use gibake_scene::LoadOptions;

/// The revision these hashes belong to, and the hash of each scene's bake:
/// (scene, `--bounces 1`, the default).
/// Revisions 10 (the surfels' share of a small triangle, the later VPLs'
/// finest nodes on their surfels) and 11 (where the later light came from,
/// format 4.8) changed the later bounces alone: the `--bounces 1` hashes
/// are revision 9's.
const RECORDED: (u32, [(&str, &str, &str); 2]) = (
    11,
    [
        ("corner_bunny", "10081d0c84b86e69", "66299a2ca949833b"),
        ("lamps", "ce446a26d1373b12", "af218d4f49b29a3d"),
    ],
);

/// The first bounce alone's hashes without the second origins and maps:
/// `--bounces 1` writes them whatever the later bounces do. Revision 6's
/// until revision 9, which moved the finest near-field nodes whose texels
/// lie on two surfaces a step apart onto the one that carries most of
/// their light (`gibake_bake::near_field::Anchors`; issue 49, item 2);
/// revision 6's were 468d0ace1f351ccc and c7cf9c94ae279309.
const ONE_BOUNCE_BEFORE: [(&str, &str); 2] = [
    ("corner_bunny", "677b07061ac331db"),
    ("lamps", "dd53cdd3f559407c"),
];

/// BLAKE3 of the VPL records, the near-field trees, their level-3
/// coherences, the hemisphere maps and, with `lower`, the second origins
/// and maps, every float by its bits.
fn hash(asset: &Asset, lower: bool) -> String {
    let mut h = blake3::Hasher::new();
    for v in asset.vpls.iter().chain(&asset.vpl_nodes) {
        for f in v
            .position
            .iter()
            .chain(&[v.area])
            .chain(&v.normal)
            .chain(&v.flux)
        {
            h.update(&f.to_bits().to_le_bytes());
        }
        h.update(&v.texels.to_le_bytes());
        h.update(&v.map.to_le_bytes());
    }
    for c in &asset.vpl_coherence {
        h.update(&c.to_bits().to_le_bytes());
    }
    h.update(&asset.vpl_maps.tile_size().to_le_bytes());
    h.update(&asset.vpl_maps.count().to_le_bytes());
    for t in asset.vpl_maps.texels() {
        h.update(&t.to_bits().to_le_bytes());
    }
    // Revision 8: the second origins and maps (gibake_bake::horizon).
    if lower {
        for l in &asset.vpl_lower {
            for f in l.origin {
                h.update(&f.to_bits().to_le_bytes());
            }
            h.update(&l.map.to_le_bytes());
        }
        h.update(&asset.vpl_lower_maps.count().to_le_bytes());
        for t in asset.vpl_lower_maps.texels() {
            h.update(&t.to_bits().to_le_bytes());
        }
    }
    // Revision 11: where the later light came from (format 4.8).
    if let Some(s) = &asset.manifest.later_sources {
        for (g, w) in &s.first {
            h.update(&g.to_le_bytes());
            h.update(&w.to_bits().to_le_bytes());
        }
        for (g, w) in &s.weights {
            h.update(&g.to_le_bytes());
            h.update(&w.to_bits().to_le_bytes());
        }
    }
    h.finalize().to_hex()[..16].to_string()
}

#[test]
fn the_bake_method_revision_matches_what_a_bake_writes() {
    let ctx = GpuContext::new(&Default::default()).unwrap_or_else(|e| {
        panic!(
            "this test needs a GPU adapter ({e}); on Debian/Ubuntu \
             `apt-get install mesa-vulkan-drivers` gives the lavapipe software GPU"
        )
    });
    let one = BakeOptions {
        rsm_size: 128,
        vpl_map_size: 16,
        shadow_map_size: 256,
        target: ClusterTarget::Count(48),
        bounces: gibake_bake::later::Bounces::Count(1),
        later_vpls: None,
    };
    let every = BakeOptions {
        bounces: gibake_bake::later::Bounces::Every,
        ..one.clone()
    };
    let mut got = Vec::new();
    let mut firsts = Vec::new();
    for (name, _, _) in RECORDED.1 {
        let path = Path::new(concat!(env!("CARGO_MANIFEST_DIR"), "/../../data"))
            .join(format!("{name}.glb"));
        let scene = gibake_scene::load(&path, &LoadOptions::default())
            .unwrap_or_else(|e| panic!("load {}: {e}", path.display()));
        let [(h1, first), (h, _)] = [&one, &every].map(|opts| {
            let asset = bake(&ctx, &scene, opts, &NoProgress, "test")
                .unwrap_or_else(|e| panic!("bake of {name}: {e}"))
                .asset;
            (hash(&asset, true), hash(&asset, false))
        });
        got.push((name, h1, h));
        firsts.push(first);
    }
    for ((name, before), h1) in ONE_BOUNCE_BEFORE.iter().zip(&firsts) {
        assert_eq!(
            before, h1,
            "--bounces 1 of data/{name}.glb no longer writes the first bounce recorded here \
             (hash {h1}, recorded {before}): the first bounce changed"
        );
    }
    let table: Vec<String> = got
        .iter()
        .map(|(n, h1, h)| format!("(\"{n}\", \"{h1}\", \"{h}\")"))
        .collect();
    assert_eq!(
        RECORDED.0,
        BAKE_METHOD,
        "BAKE_METHOD is {BAKE_METHOD} but the hashes here are revision {}'s: record this \
         revision's, RECORDED = ({BAKE_METHOD}, [{}])",
        RECORDED.0,
        table.join(", ")
    );
    for ((name, want1, want), (_, have1, have)) in RECORDED.1.iter().zip(&got) {
        assert_eq!(
            (want1.to_string(), want.to_string()),
            (have1.clone(), have.clone()),
            "the bake of data/{name}.glb changed (hash {have}, revision {BAKE_METHOD} recorded \
             {want}). If that was meant, bump gibake_bake::BAKE_METHOD (crates/bake/src/lib.rs) \
             so that assets of the older method re-bake, and record RECORDED = \
             ({}, [{}]) here; if not, the bake changed by accident",
            BAKE_METHOD + 1,
            table.join(", ")
        );
    }
}
