//! `diff` and `inspect`.

use crate::common;

use common::*;
use gibake_asset::*;

#[test]
fn identical_assets_are_equal() {
    let a = sample_asset(true);
    for tol in [Tolerance::same_machine(), Tolerance::another_gpu()] {
        let r = diff(&a, &a, &tol);
        assert!(r.equal(), "{r}");
        assert!(r.to_string().starts_with("EQUAL"), "{r}");
        assert_eq!(r.vpls.matching, "index");
        assert_eq!(r.vpls.matched, VPLS);
        let names: Vec<&str> = r.maps.iter().map(|m| m.name.as_str()).collect();
        assert_eq!(
            names,
            [
                "primary_depth",
                "vpl_maps",
                "vpl_lower_maps",
                "light_maps",
                "rsm.D",
                "rsm.share",
                "rsm.vpl"
            ]
        );
        assert!(r.maps.iter().all(|m| m.over == 0 && m.max_abs == 0.0));
        let t = &r.trees;
        assert!(t.comparable && t.within_tolerance, "{r}");
        assert_eq!(t.pairs, VPLS);
        assert_eq!(t.nodes, (VPLS * NODES_PER_VPL) as u64);
        assert_eq!(t.coherences, (VPLS * LEVEL3_NODES) as u64);
    }
}

#[test]
fn a_changed_near_field_tree_or_coherence_is_reported() {
    let a = sample_asset(false);
    // A level-1 node of VPL 2 with more flux: the VPLs agree, the trees
    // do not (shading draws that node near a receiver).
    let mut b = a.clone();
    b.vpl_nodes[2 * NODES_PER_VPL + 1].flux[0] *= 1.5;
    let r = diff(&a, &b, &Tolerance::another_gpu());
    assert!(!r.equal(), "{r}");
    assert!(r.vpls.within_tolerance, "{r}");
    assert_eq!((r.trees.nodes_over, r.trees.coherences_over), (1, 0));
    assert_eq!(r.trees.worst_vpl, Some(2));
    assert!(
        r.differences
            .iter()
            .any(|d| d.starts_with("near-field trees")),
        "{r}"
    );
    assert!(r.to_string().contains("worst VPL A#2"), "{r}");

    // One level-3 coherence of VPL 4 lower: exact tolerance sees it, and
    // so does another GPU's at this size.
    let mut c = a.clone();
    c.vpl_coherence[4 * LEVEL3_NODES + 63] = 0.5;
    for tol in [Tolerance::same_machine(), Tolerance::another_gpu()] {
        let r = diff(&a, &c, &tol);
        assert!(!r.equal(), "{r}");
        assert_eq!((r.trees.nodes_over, r.trees.coherences_over), (0, 1));
        assert_eq!(r.trees.worst_vpl, Some(4));
        assert!((r.trees.max_coherence_diff - 0.5).abs() < 1e-6, "{r}");
    }
    // Within another GPU's 1e-3: equal for it, not for the same machine.
    let mut e = a.clone();
    e.vpl_coherence[LEVEL3_NODES] = 1.0 - 1e-5;
    assert!(diff(&a, &e, &Tolerance::another_gpu()).equal());
    assert!(!diff(&a, &e, &Tolerance::same_machine()).equal());

    // A 4.1 asset has no coherences and renders with 1: the same as an
    // asset whose coherences are all 1, not as one with a 0.5.
    let mut old = a.clone();
    old.vpl_coherence.clear();
    assert!(diff(&old, &a, &Tolerance::same_machine()).equal());
    assert_eq!(
        diff(&old, &c, &Tolerance::same_machine())
            .trees
            .coherences_over,
        1
    );

    // No trees in one of them: not comparable, a difference.
    let mut bare = a.clone();
    bare.vpl_nodes.clear();
    let r = diff(&a, &bare, &Tolerance::same_machine());
    assert!(!r.trees.comparable && !r.equal(), "{r}");
    assert!(
        r.to_string().contains("near-field trees: not comparable"),
        "{r}"
    );
}

#[test]
fn a_written_and_loaded_asset_equals_the_original() {
    let tmp = tempfile::tempdir().unwrap();
    let a = sample_asset(true);
    let dir = written(tmp.path(), &a);
    let b = load(&dir).unwrap();
    assert!(diff(&a, &b, &Tolerance::same_machine()).equal());
}

#[test]
fn a_slightly_moved_vpl_is_reported() {
    let a = sample_asset(false);
    let mut b = a.clone();
    b.vpls[3].position[0] += 0.01;
    let r = diff(&a, &b, &Tolerance::same_machine());
    assert!(!r.equal());
    assert_eq!(r.vpls.matching, "index");
    assert_eq!(r.vpls.over_tolerance, 1);
    assert_eq!(r.vpls.worst[0].a, Some(3));
    assert_eq!(r.vpls.worst[0].b, Some(3));
    assert!(r.vpls.max_position_rel > 0.0);
    let text = r.to_string();
    assert!(text.contains("VPL A#3 / B#3"), "{text}");
    // Within 1e-3 of the diagonal for another GPU? 0.01 / ~6 is not.
    assert!(!diff(&a, &b, &Tolerance::another_gpu()).equal());
}

#[test]
fn a_far_moved_or_missing_vpl_is_unmatched() {
    let a = sample_asset(false);
    let mut b = a.clone();
    b.vpls[3].position = [1.9, 2.9, -1.9];
    let r = diff(&a, &b, &Tolerance::another_gpu());
    assert!(!r.equal());
    assert_eq!(r.vpls.matching, "nearest");
    assert_eq!((r.vpls.unmatched_a, r.vpls.unmatched_b), (1, 1));
    assert_eq!(r.vpls.matched, VPLS - 1);
    assert_eq!(r.vpls.worst[0].a, Some(3));
    assert_eq!(r.vpls.worst[1].b, Some(3));
    assert!(r.to_string().contains("VPL A#3 at"), "{r}");

    // One VPL dropped (and its map): the rest still match by position.
    let mut c = a.clone();
    c.vpls.remove(1); // VPL 1 has no map
    let r = diff(&a, &c, &Tolerance::same_machine());
    assert_eq!(
        (r.vpls.unmatched_a, r.vpls.unmatched_b, r.vpls.matched),
        (1, 0, VPLS - 1)
    );
    assert_eq!(r.vpls.worst[0].a, Some(1));
    let maps = r.maps.iter().find(|m| m.name == "vpl_maps").unwrap();
    assert!(maps.within_tolerance && maps.over == 0, "{r}");
    assert!(r.differences.iter().any(|d| d.contains("unmatched")), "{r}");
}

#[test]
fn changed_settings_and_scene_hash_are_reported() {
    let a = sample_asset(false);
    let mut b = a.clone();
    b.manifest.settings.threshold = 0.1;
    b.manifest.settings.vpl_budget = None;
    b.manifest.static_scene_hash[0] = 0;
    let r = diff(&a, &b, &Tolerance::another_gpu());
    assert!(!r.equal());
    let fields: Vec<&str> = r.settings.iter().map(|f| f.field.as_str()).collect();
    assert_eq!(fields, ["threshold", "vpl_budget"]);
    assert_eq!(
        (r.settings[0].a.as_str(), r.settings[0].b.as_str()),
        ("0.05", "0.1")
    );
    assert!(r.static_scene_hash.is_some());
    let text = r.to_string();
    assert!(text.contains("threshold 0.05 vs 0.1"), "{text}");
    // Different scenes lead: the first line and the first difference.
    assert!(text.starts_with("DIFFERENT (DIFFERENT SCENES)"), "{text}");
    assert!(r.differences[0].starts_with("different scenes"), "{r}");
    // Settings read as on the command line, never as Rust debug text.
    assert!(text.contains("vpl_budget --vpls"), "{text}");
    assert!(!text.contains("Some(") && !text.contains("None"), "{text}");
}

#[test]
fn provenance_counts_only_when_strict() {
    let a = sample_asset(false);
    let mut b = a.clone();
    b.manifest.provenance.adapter = "NVIDIA GeForce GTX 780".into();
    let r = diff(&a, &b, &Tolerance::same_machine());
    assert!(r.equal(), "{r}");
    assert_eq!(r.provenance.len(), 1);
    assert!(r.to_string().contains("GTX 780"));
    let strict = Tolerance {
        strict_provenance: true,
        ..Tolerance::same_machine()
    };
    let r = diff(&a, &b, &strict);
    assert!(!r.equal());
    assert!(r.differences[0].contains("adapter"), "{r}");
}

#[test]
fn same_machine_is_exact_another_gpu_is_not() {
    let a = sample_asset(true);
    let mut b = a.clone();
    // Tiny relative changes everywhere.
    for x in b
        .primary_depth
        .data
        .iter_mut()
        .chain(b.vpl_maps.texels_mut())
    {
        *x *= 1.0 + 1e-5;
    }
    for v in &mut b.vpls {
        v.flux[0] *= 1.0 + 1e-5;
        v.position[1] += 1e-5;
        v.normal = [0.0, 1.0, 1e-4];
    }
    b.manifest.light_view.texel_scale *= 1.0 + 1e-6;
    let r = diff(&a, &b, &Tolerance::same_machine());
    assert!(!r.equal(), "{r}");
    assert!(
        r.maps
            .iter()
            .any(|m| m.name == "primary_depth" && !m.within_tolerance)
    );
    assert!(!r.light_view.is_empty());
    let r = diff(&a, &b, &Tolerance::another_gpu());
    assert!(r.equal(), "{r}");
    assert!(r.maps[0].max_abs > 0.0 && r.maps[0].rmse > 0.0);

    // A few texels far off: within 0.5 % → equal; more → different.
    let n = b.primary_depth.data.len(); // 256 texels: 1 is 0.39 %
    let mut c = a.clone();
    c.primary_depth.data[7] = 1000.0;
    assert!(diff(&a, &c, &Tolerance::another_gpu()).equal());
    c.primary_depth.data[8] = 1000.0;
    let r = diff(&a, &c, &Tolerance::another_gpu());
    assert!(!r.equal());
    assert_eq!(r.maps[0].over, 2);
    assert!((r.maps[0].over_fraction - 2.0 / n as f64).abs() < 1e-12);
}

#[test]
fn infinity_matches_infinity_but_not_a_finite_value() {
    let a = sample_asset(false);
    let i = a
        .primary_depth
        .data
        .iter()
        .position(|x| x.is_infinite())
        .unwrap();
    // The first finite texel of map `layer`.
    let (layer, j) = a
        .vpl_maps
        .maps()
        .enumerate()
        .find_map(|(k, m)| m.iter().position(|x| x.is_finite()).map(|j| (k as u32, j)))
        .unwrap();
    let mut b = a.clone();
    b.primary_depth.data[i] = 5.0;
    let mut map = b.vpl_maps.map(layer).unwrap();
    map[j] = f32::INFINITY;
    b.vpl_maps.set_map(layer, &map);
    let r = diff(
        &a,
        &b,
        &Tolerance {
            max_texels_over: 0.5,
            ..Tolerance::another_gpu()
        },
    );
    let p = &r.maps[0];
    assert_eq!((p.over, p.inf_mismatch, p.max_abs), (1, 1, 0.0));
    let m = &r.maps[1];
    assert_eq!((m.over, m.inf_mismatch), (1, 1));
    // The changed map belongs to the VPL with that map.
    let vpl = a.vpls.iter().position(|v| v.map == layer).unwrap();
    assert_eq!(m.worst_vpl, Some(vpl));
    assert!(diff(&a, &b, &Tolerance::same_machine()).differences.len() == 2);
}

#[test]
fn a_missing_map_counts_as_all_infinite() {
    let mut a = sample_asset(false);
    // Make layer 0 entirely +inf, then store it as NO_MAP in B.
    let t = (VPL_MAP * VPL_MAP) as usize;
    a.vpl_maps.set_map(0, &vec![f32::INFINITY; t]);
    let mut b = a.clone();
    let rest: Vec<Vec<f32>> = a.vpl_maps.maps().skip(1).collect();
    b.vpl_maps = MapAtlas::from_maps(VPL_MAP, rest.iter().map(|m| m.as_slice())).unwrap();
    for v in &mut b.vpls {
        v.map = match v.map {
            0 => NO_MAP,
            NO_MAP => NO_MAP,
            k => k - 1,
        };
    }
    let r = diff(&a, &b, &Tolerance::same_machine());
    assert!(r.equal(), "{r}");
}

/// The other lights' shadow maps are compared view by view; a view that
/// stores no map counts as all-infinite; other views are not comparable.
#[test]
fn light_maps_are_compared_view_by_view() {
    let a = sample_asset(false);
    let mut b = a.clone();
    let mut texels = b.light_maps.texels().to_vec();
    let k = texels.iter().position(|t| t.is_finite()).unwrap();
    texels[k] += 1.0;
    b.light_maps = MapAtlas::from_texels(LIGHT_MAP, 4, texels).unwrap();
    let r = diff(&a, &b, &Tolerance::same_machine());
    let l = r.maps.iter().find(|m| m.name == "light_maps").unwrap();
    assert_eq!(l.over, 1, "{r}");
    assert!(!r.equal());
    let mut c = a.clone();
    c.manifest.views.pop();
    let r = diff(&a, &c, &Tolerance::same_machine());
    assert!(
        r.differences.iter().any(|d| d.contains("light_maps")),
        "{r}"
    );
}

#[test]
fn rsm_presence_and_channels_are_compared() {
    let a = sample_asset(true);
    let mut b = a.clone();
    b.rsm = None;
    let r = diff(&a, &b, &Tolerance::another_gpu());
    assert!(!r.equal());
    assert!(
        r.differences
            .iter()
            .any(|d| d.contains("rsm") && d.contains("A only")),
        "{r}"
    );
    let mut c = a.clone();
    let before = (
        c.rsm.as_ref().unwrap().vpl[0],
        c.rsm.as_ref().unwrap().vpl[1],
    );
    c.rsm.as_mut().unwrap().vpl[0] = 3;
    c.rsm.as_mut().unwrap().vpl[1] = 4;
    let changed = u64::from(before.0 != 3) + u64::from(before.1 != 4);
    let r = diff(&a, &c, &Tolerance::same_machine());
    let v = r.maps.iter().find(|m| m.name == "rsm.vpl").unwrap();
    // Indices are compared as VPLs, not as numbers: a count, no "max abs".
    assert_eq!(v.over, changed, "{r}");
    assert!(!v.within_tolerance && v.max_abs == 0.0, "{r}");
}

#[test]
fn diff_images_are_written_for_differing_maps_only() {
    use exr::prelude::*;
    let tmp = tempfile::tempdir().unwrap();
    let a = sample_asset(true);
    assert!(write_diff_images(&a, &a, tmp.path()).unwrap().is_empty());
    let mut b = a.clone();
    b.primary_depth.data[5] += 2.0;
    let k = a.vpls[0].map;
    let mut map = b.vpl_maps.map(k).unwrap();
    map[9] = if map[9].is_finite() {
        map[9] + 0.5
    } else {
        1.0
    };
    b.vpl_maps.set_map(k, &map);
    let out = tmp.path().join("diff");
    let files = write_diff_images(&a, &b, &out).unwrap();
    let names: Vec<String> = files
        .iter()
        .map(|p| p.file_name().unwrap().to_string_lossy().into_owned())
        .collect();
    assert_eq!(names, ["primary_depth.diff.exr", "vpl_maps.diff.exr"]);
    let img = read_all_flat_layers_from_file(&files[0]).unwrap();
    let FlatSamples::F32(d) = &img.layer_data[0].channel_data.list[0].sample_data else {
        panic!()
    };
    assert!((d[5] - 2.0).abs() < 1e-5 && d.iter().filter(|&&x| x != 0.0).count() == 1);
    let img = read_all_flat_layers_from_file(&files[1]).unwrap();
    let FlatSamples::F32(d) = &img.layer_data[0].channel_data.list[0].sample_data else {
        panic!()
    };
    // Tile 0 (VPL 0's map) holds the one difference, at (1, 1).
    let w = img.layer_data[0].size.width();
    assert!(d[w + 1] > 0.0);
    assert_eq!(d.iter().filter(|&&x| x != 0.0 && x.is_finite()).count(), 1);
}

#[test]
fn reports_serialise_to_json() {
    let a = sample_asset(true);
    let mut b = a.clone();
    b.vpls[2].flux[2] = 9.0;
    let r = diff(&a, &b, &Tolerance::another_gpu());
    let json = serde_json::to_value(&r).unwrap();
    assert_eq!(json["vpls"]["over_tolerance"], 1);
    assert_eq!(json["vpls"]["worst"][0]["a"], 2);
    assert_eq!(json["tolerance"]["vpl_normal_deg"], 1.0);
    assert_eq!(json["trees"]["within_tolerance"], true);
    assert!(!json["differences"].as_array().unwrap().is_empty());
}

#[test]
fn inspect_reports_counts_sizes_and_statistics() {
    let tmp = tempfile::tempdir().unwrap();
    let a = sample_asset(true);
    let dir = written(tmp.path(), &a);
    let loaded = load(&dir).unwrap();
    let i = inspect(&loaded);
    assert_eq!((i.vpl_count, i.map_count, i.vpls_without_map), (VPLS, 7, 3));
    assert!(i.has_dynamic);
    // File sizes are the real ones, manifest.bin included.
    let on_disk: u64 = file_names(&dir)
        .iter()
        .map(|n| std::fs::metadata(dir.join(n)).unwrap().len())
        .sum();
    assert_eq!(i.total_bytes, on_disk);
    assert_eq!(i.files.len(), 10);
    assert!(i.files.iter().any(|f| f.name == "light_maps.exr"));
    assert!(i.files.iter().any(|f| f.name == "vpl_lower_maps.exr"));
    assert_eq!((i.vpls_with_lower, i.lower_map_count), (5, 3));
    assert!(i.files.iter().any(|f| f.name == "vpl_coherence.bin"));
    assert_eq!((i.views, i.light_maps_stored), (6, 4));
    assert_eq!(i.files[0].name, "manifest.bin");
    assert_eq!(
        i.files[0].bytes,
        std::fs::metadata(dir.join("manifest.bin")).unwrap().len()
    );
    let total_r: f64 = a.vpls.iter().map(|v| v.flux[0] as f64).sum();
    assert!((i.total_flux[0] - total_r).abs() < 1e-9);
    assert!(i.flux_luminance.min <= i.flux_luminance.median);
    assert!(i.flux_luminance.median <= i.flux_luminance.max);
    assert_eq!(i.area.count, VPLS);
    assert!(i.primary_depth.covered_fraction > 0.5 && i.primary_depth.covered_fraction < 1.0);

    let text = i.to_string();
    assert!(
        text.contains("VPLs: 10 (7 hemisphere maps stored, 3 VPLs see no surface"),
        "{text}"
    );
    assert!(
        text.contains("corner.gltf") && text.contains("llvmpipe"),
        "{text}"
    );
    assert!(text.contains("rsm.exr") && text.contains("total"), "{text}");
    let json = serde_json::to_value(&i).unwrap();
    assert_eq!(json["vpl_count"], 10);
    assert_eq!(json["map_count"], 7);
    assert_eq!(json["settings"]["vpl_map_size"], VPL_MAP);

    let s = inspect(&sample_asset(false)).to_string();
    assert!(s.contains("not stored (no moving objects)"), "{s}");
}

#[test]
fn the_scene_diagonal_is_the_scenes_not_the_vpl_samples() {
    // Two bakes of one scene with other VPLs: one yardstick, from the light
    // view (fitted to the scene), whatever the VPLs are.
    let mut a = sample_asset(false);
    // An orthographic light view of the box [-2, 2]² × [0, 4].
    let mut m = [0f32; 16];
    (m[0], m[5], m[10], m[15]) = (0.5, 0.5, 0.25, 1.0);
    a.manifest.light_view.view_proj = m;
    let mut b = a.clone();
    b.vpls.truncate(b.vpls.len() / 2);
    let mut c = a.clone();
    for v in &mut c.vpls {
        v.position[0] *= 0.5;
    }
    let tol = Tolerance::another_gpu();
    let d1 = diff(&a, &b, &tol).vpls.scene_diagonal;
    let d2 = diff(&a, &c, &tol).vpls.scene_diagonal;
    let d3 = diff(&a, &a, &tol).vpls.scene_diagonal;
    assert_eq!(d1.to_bits(), d2.to_bits());
    assert_eq!(d1.to_bits(), d3.to_bits());
    assert!((d1 - 48f64.sqrt()).abs() < 1e-9, "{d1}");
}
