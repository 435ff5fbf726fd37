//! Round trip, determinism and the documented on-disk layout.

use crate::common;

use common::*;
use gibake_asset::*;

#[test]
fn round_trip_static_and_dynamic() {
    for dynamic in [false, true] {
        let tmp = tempfile::tempdir().unwrap();
        let asset = sample_asset(dynamic);
        let dir = written(tmp.path(), &asset);
        let loaded = load(&dir).unwrap();
        assert_eq!(loaded, as_written(&asset, &loaded));
        assert_eq!(loaded.manifest.vpl_count, VPLS as u32);
        assert_eq!(loaded.manifest.map_count, 7);
        assert_eq!(loaded.manifest.lower_map_count, 3);
        assert_eq!(loaded.manifest.has_dynamic, dynamic);
        let mut expect = vec![
            "light_maps.exr",
            "manifest.bin",
            "primary_depth.exr",
            "vpl_coherence.bin",
            "vpl_lower.bin",
            "vpl_lower_maps.exr",
            "vpl_maps.exr",
            "vpl_nodes.bin",
            "vpls.bin",
        ];
        if dynamic {
            expect.push("rsm.exr");
            expect.sort();
        }
        assert_eq!(file_names(&dir), expect);
        // Nothing else left next to it.
        assert_eq!(file_names(tmp.path()), vec!["scene.gibake"]);
        assert_eq!(load_manifest(&dir).unwrap(), loaded.manifest);
    }
}

#[test]
fn counts_are_filled_in_from_the_data() {
    let tmp = tempfile::tempdir().unwrap();
    let mut asset = sample_asset(true);
    asset.manifest.vpl_count = 999;
    asset.manifest.map_count = 3;
    asset.manifest.lower_map_count = 9;
    asset.manifest.has_dynamic = false;
    let dir = written(tmp.path(), &asset);
    let m = load_manifest(&dir).unwrap();
    assert_eq!(
        (m.vpl_count, m.map_count, m.lower_map_count, m.has_dynamic),
        (VPLS as u32, 7, 3, true)
    );
    let names: Vec<&str> = m.files.iter().map(|f| f.name.as_str()).collect();
    assert_eq!(
        names,
        [
            "vpls.bin",
            "vpl_nodes.bin",
            "primary_depth.exr",
            "vpl_coherence.bin",
            "vpl_maps.exr",
            "vpl_lower.bin",
            "vpl_lower_maps.exr",
            "rsm.exr",
            "light_maps.exr"
        ]
    );
    for f in &m.files {
        let bytes = std::fs::read(dir.join(&f.name)).unwrap();
        assert_eq!(f.size, bytes.len() as u64);
        assert_eq!(&f.blake3, blake3::hash(&bytes).as_bytes());
    }
}

#[test]
fn nothing_stored_that_is_not_needed() {
    let tmp = tempfile::tempdir().unwrap();
    let mut asset = sample_asset(false);
    asset.vpl_maps = MapAtlas::empty(asset.manifest.settings.vpl_map_size);
    for v in &mut asset.vpls {
        v.map = NO_MAP;
    }
    // No view holds a surface: no light map either.
    for v in &mut asset.manifest.views {
        v.tile = NO_MAP;
    }
    asset.light_maps = MapAtlas::empty(asset.manifest.light_map_size);
    // Second origins whose maps see no surface: no second map file.
    asset.vpl_lower_maps = MapAtlas::empty(asset.manifest.settings.vpl_map_size);
    for l in asset.vpl_lower.iter_mut().filter(|l| l.is_some()) {
        l.map = NO_MAP;
    }
    let dir = written(tmp.path(), &asset);
    assert_eq!(
        file_names(&dir),
        [
            "manifest.bin",
            "primary_depth.exr",
            "vpl_coherence.bin",
            "vpl_lower.bin",
            "vpl_nodes.bin",
            "vpls.bin"
        ]
    );
    let loaded = load(&dir).unwrap();
    assert_eq!(loaded.manifest.map_count, 0);
    assert_eq!(loaded.manifest.lower_map_count, 0);
    assert!(loaded.vpl_maps.is_empty() && loaded.rsm.is_none());
    assert!(loaded.light_maps.is_empty());
    assert_eq!(loaded.manifest.views.len(), 6, "the views are kept");
}

#[test]
fn empty_vpl_set_round_trips() {
    let tmp = tempfile::tempdir().unwrap();
    let mut asset = sample_asset(false);
    asset.vpls.clear();
    asset.vpl_nodes.clear();
    asset.vpl_coherence.clear();
    asset.vpl_lower.clear();
    asset.vpl_lower_maps = MapAtlas::empty(asset.manifest.settings.vpl_map_size);
    for l in &mut asset.manifest.lights {
        l.vpls = 0;
    }
    asset.vpl_maps = MapAtlas::empty(asset.manifest.settings.vpl_map_size);
    let dir = written(tmp.path(), &asset);
    let loaded = load(&dir).unwrap();
    assert!(loaded.vpls.is_empty());
    assert_eq!(std::fs::metadata(dir.join("vpls.bin")).unwrap().len(), 0);
}

#[test]
fn writing_twice_gives_identical_bytes() {
    let tmp = tempfile::tempdir().unwrap();
    let asset = sample_asset(true);
    let a = tmp.path().join("a.gibake");
    let b = tmp.path().join("b.gibake");
    write(&asset, &a).unwrap();
    write(&asset, &b).unwrap();
    let names = file_names(&a);
    assert_eq!(names, file_names(&b));
    for n in &names {
        let (x, y) = (
            std::fs::read(a.join(n)).unwrap(),
            std::fs::read(b.join(n)).unwrap(),
        );
        assert!(x == y, "{n} differs between two writes");
    }
    // Rewriting in place (replacing the asset) gives the same bytes too.
    let before = std::fs::read(a.join("vpl_maps.exr")).unwrap();
    write(&asset, &a).unwrap();
    assert_eq!(before, std::fs::read(a.join("vpl_maps.exr")).unwrap());
    // Loading and writing again is byte-identical as well.
    let c = tmp.path().join("c.gibake");
    write(&load(&a).unwrap(), &c).unwrap();
    for n in &names {
        assert_eq!(
            std::fs::read(a.join(n)).unwrap(),
            std::fs::read(c.join(n)).unwrap(),
            "{n}"
        );
    }
}

#[test]
fn atlas_grid_layout() {
    assert_eq!(atlas_grid(0), (0, 0));
    assert_eq!(atlas_grid(1), (1, 1));
    assert_eq!(atlas_grid(2), (2, 1));
    assert_eq!(atlas_grid(4), (2, 2));
    assert_eq!(atlas_grid(5), (3, 2));
    assert_eq!(atlas_grid(7), (3, 3));
    assert_eq!(atlas_grid(9), (3, 3));
    assert_eq!(atlas_grid(10), (4, 3));
    assert_eq!(atlas_grid(1_000_000), (1000, 1000));
    assert_eq!(atlas_grid(u32::MAX), (65536, 65536));
}

fn read_exr(path: &std::path::Path) -> exr::prelude::FlatImage {
    exr::prelude::read_all_flat_layers_from_file(path).expect("standard EXR reader")
}

fn channel<'a>(img: &'a exr::prelude::FlatImage, name: &str) -> &'a exr::prelude::FlatSamples {
    let layer = &img.layer_data[0];
    &layer
        .channel_data
        .list
        .iter()
        .find(|c| c.name.eq(name))
        .expect(name)
        .sample_data
}

#[test]
fn exr_files_have_the_documented_layout() {
    use exr::prelude::FlatSamples;
    let tmp = tempfile::tempdir().unwrap();
    let asset = sample_asset(true);
    let dir = written(tmp.path(), &asset);

    // primary_depth.exr: one f32 channel D, row 0 at the top.
    let img = read_exr(&dir.join("primary_depth.exr"));
    assert_eq!(img.layer_data.len(), 1);
    let layer = &img.layer_data[0];
    assert_eq!(layer.size.width(), SHADOW as usize);
    assert_eq!(layer.channel_data.list.len(), 1);
    let FlatSamples::F32(d) = channel(&img, "Z") else {
        panic!("D is not f32")
    };
    assert_eq!(d, &asset.primary_depth.data);

    // vpl_maps.exr: 7 maps in a 3x3 grid of 8x8 tiles, unused tiles +inf.
    let img = read_exr(&dir.join("vpl_maps.exr"));
    let layer = &img.layer_data[0];
    let (w, h) = (layer.size.width(), layer.size.height());
    assert_eq!((w, h), (24, 24));
    let FlatSamples::F32(atlas) = channel(&img, "Z") else {
        panic!("D is not f32")
    };
    let s = VPL_MAP as usize;
    let maps: Vec<Vec<f32>> = asset.vpl_maps.maps().collect();
    assert_eq!(maps.len(), 7);
    for k in 0..9usize {
        let map = maps.get(k);
        let (cx, cy) = (k % 3, k / 3);
        for y in 0..s {
            for x in 0..s {
                let v = atlas[(cy * s + y) * w + cx * s + x];
                if let Some(map) = map {
                    assert_eq!(v.to_bits(), map[y * s + x].to_bits());
                } else {
                    assert_eq!(v, f32::INFINITY);
                }
            }
        }
    }

    // rsm.exr: Z f32, share u32, vpl u32.
    let img = read_exr(&dir.join("rsm.exr"));
    let r = asset.rsm.as_ref().unwrap();
    let mut names: Vec<String> = img.layer_data[0]
        .channel_data
        .list
        .iter()
        .map(|c| c.name.to_string())
        .collect();
    names.sort();
    assert_eq!(names, ["Z", "share", "vpl"]);
    let FlatSamples::F32(m) = channel(&img, "Z") else {
        panic!()
    };
    assert_eq!(m, &r.metric);
    let FlatSamples::U32(share) = channel(&img, "share") else {
        panic!("share is not u32")
    };
    assert_eq!(share, &r.share);
    let FlatSamples::U32(v) = channel(&img, "vpl") else {
        panic!("vpl is not u32")
    };
    assert_eq!(v, &r.vpl);
}

#[test]
fn vpls_bin_is_a_little_endian_array() {
    let tmp = tempfile::tempdir().unwrap();
    let asset = sample_asset(false);
    let dir = written(tmp.path(), &asset);
    let bytes = std::fs::read(dir.join("vpls.bin")).unwrap();
    assert_eq!(bytes.len(), 48 * VPLS);
    assert_eq!(std::mem::size_of::<VplRecord>(), 48);
    let word = |i: usize, k: usize| {
        u32::from_le_bytes(
            bytes[48 * i + 4 * k..48 * i + 4 * k + 4]
                .try_into()
                .unwrap(),
        )
    };
    for (i, v) in asset.vpls.iter().enumerate() {
        assert_eq!(word(i, 0), v.position[0].to_bits());
        assert_eq!(word(i, 3), v.area.to_bits());
        assert_eq!(word(i, 5), v.normal[1].to_bits());
        assert_eq!(word(i, 7), v.texels);
        assert_eq!(word(i, 10), v.flux[2].to_bits());
        assert_eq!(word(i, 11), v.map);
    }
}

#[test]
fn manifest_bin_has_the_documented_layout() {
    let tmp = tempfile::tempdir().unwrap();
    let asset = sample_asset(false);
    let dir = written(tmp.path(), &asset);
    let bytes = std::fs::read(dir.join("manifest.bin")).unwrap();
    assert_eq!(&bytes[..8], b"GIBAKE\0\x01");
    assert_eq!(u16::from_le_bytes([bytes[8], bytes[9]]), FORMAT_MAJOR);
    assert_eq!(u16::from_le_bytes([bytes[10], bytes[11]]), FORMAT_MINOR);
    let len = u64::from_le_bytes(bytes[12..20].try_into().unwrap()) as usize;
    assert_eq!(bytes.len(), 20 + len + 32);
    assert_eq!(
        &bytes[20 + len..],
        blake3::hash(&bytes[..20 + len]).as_bytes()
    );
    // Payload: provenance strings first, each a varint length + UTF-8.
    let p = &bytes[20..20 + len];
    assert_eq!(p[0], 5);
    assert_eq!(&p[1..6], b"0.1.0");
    assert_eq!(p[6] as usize, "corner.gltf".len());
    assert_eq!(&p[7..18], b"corner.gltf");
    // ... then the file list, whose last entry ends with its 32-byte hash,
    // then the lights: a varint count, each light's name, kind (u8), nine
    // f32 of colour, position and direction, three of cones and range, and
    // its VPL count (a varint); then the views: a varint count, each one's
    // light (varint), view (a bool and 24 f32) and tile (varint: one byte
    // below 251, five for NO_MAP); then light_map_size (varint); then
    // (4.1) the view_rsms vector.
    let m = load_manifest(&dir).unwrap();
    let hash = &m.files.last().unwrap().blake3;
    let end_of_files = p
        .windows(32)
        .position(|w| w == hash)
        .expect("the last file's hash is in the payload")
        + 32;
    assert_eq!(usize::from(p[end_of_files]), m.lights.len());
    assert!(m.lights.iter().all(|l| l.vpls <= 250), "one-byte varints");
    let light_bytes: usize = m
        .lights
        .iter()
        .map(|l| 1 + l.name.len() + 1 + 12 * 4 + 1)
        .sum();
    let end_of_lights = end_of_files + 1 + light_bytes;
    let last = m.lights.last().expect("the sample has lights");
    assert_eq!(
        &p[end_of_lights - 5..end_of_lights - 1],
        &last.range.to_le_bytes()
    );
    assert_eq!(u32::from(p[end_of_lights - 1]), last.vpls);
    assert_eq!(m.lights, asset.manifest.lights);
    assert_eq!(usize::from(p[end_of_lights]), m.views.len());
    let view_bytes: usize = m
        .views
        .iter()
        .map(|v| 1 + 1 + 24 * 4 + if v.tile == NO_MAP { 5 } else { 1 })
        .sum();
    // Then (4.1) view_rsms: a varint count (0 here) and its varint
    // indices; then (4.3) ring_vpls: a varint count (0 here) and counts;
    // then (4.4) scene_options: an Option tag (0 here: not recorded);
    // then (4.5) swept_bounds: a varint count (0 here: not recorded);
    // then (4.6) later: an Option tag (0 here: the first bounce alone);
    // then (4.7) lower_map_count, a varint (3 here); then (4.8)
    // later_sources: an Option tag (0 here: no later bounces).
    assert_eq!(
        end_of_lights + 1 + view_bytes + 1 + 1 + 1 + 1 + 1 + 1 + 1 + 1,
        len
    );
    assert_eq!(u32::from(p[len - 8]), m.light_map_size);
    assert_eq!(p[len - 7], 0, "no view RSMs");
    assert_eq!(p[len - 6], 0, "no ring VPLs");
    assert_eq!(p[len - 5], 0, "no scene options recorded");
    assert_eq!(p[len - 4], 0, "no swept bounds");
    assert_eq!(p[len - 3], 0, "no later bounces");
    assert_eq!(u32::from(p[len - 2]), m.lower_map_count);
    assert_eq!(p[len - 1], 0, "no later sources");
    assert_eq!(m.lower_map_count, 3);
    assert_eq!(m.views, asset.manifest.views);
}

/// `manifest.bin` with its payload replaced by `payload` and minor `minor`
/// (length and checksum recomputed).
fn rewrap(bytes: &[u8], payload: &[u8], minor: u16) -> Vec<u8> {
    let mut out = bytes[..20].to_vec();
    out[10..12].copy_from_slice(&minor.to_le_bytes());
    out[12..20].copy_from_slice(&(payload.len() as u64).to_le_bytes());
    out.extend_from_slice(payload);
    let h = blake3::hash(&out);
    out.extend_from_slice(h.as_bytes());
    out
}

/// A 3.x asset is refused, saying to re-bake; a 4.0 manifest whose views
/// are cut short is refused; a newer minor's appended bytes are ignored.
#[test]
fn older_majors_are_refused_and_cut_manifests_too() {
    let tmp = tempfile::tempdir().unwrap();
    let asset = sample_asset(false);
    let dir = written(tmp.path(), &asset);
    let path = dir.join("manifest.bin");
    let bytes = std::fs::read(&path).unwrap();
    let len = u64::from_le_bytes(bytes[12..20].try_into().unwrap()) as usize;
    let p = bytes[20..20 + len].to_vec();

    let mut old = rewrap(&bytes, &p, 1);
    old[8..10].copy_from_slice(&3u16.to_le_bytes());
    let h = blake3::hash(&old[..old.len() - 32]);
    let n = old.len();
    old[n - 32..].copy_from_slice(h.as_bytes());
    std::fs::write(&path, &old).unwrap();
    let e = load_manifest(&dir).expect_err("a 3.1 manifest");
    assert!(
        e.to_string().contains("3.1") && e.to_string().contains("re-bake"),
        "{e}"
    );

    std::fs::write(&path, rewrap(&bytes, &p[..len - 3], FORMAT_MINOR)).unwrap();
    let e = load_manifest(&dir).expect_err("views cut short");
    assert!(e.to_string().contains("damaged manifest payload"), "{e}");

    let mut more = p.clone();
    more.extend_from_slice(&[7, 7, 7]);
    std::fs::write(&path, rewrap(&bytes, &more, FORMAT_MINOR + 1)).unwrap();
    let m = load_manifest(&dir).expect("a newer minor's additions are ignored");
    assert_eq!(m.views, asset.manifest.views);
}
