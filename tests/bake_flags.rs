//! Bake flags remembered (issue 49, item 6; asset format 4.4): `gibake
//! bake` records the scene flags it applied (`--sun`, `--dynamic`,
//! `--light`, `--bake-volume`, `--max-texture-size`), and `render` and
//! `view` apply them when given none of a kind — the case, a level
//! with a light of its own baked with `--sun` and rendered without it,
//! renders the image it renders with the flag given — and refuse flags
//! that differ, naming both. An asset of format 4.3 (nothing recorded)
//! still loads and renders with the flags given. The up-to-date check and
//! a sharded bake carry the flags too.

use crate::common;

use common::{Run, TINY_BAKE, run_command};

use std::path::{Path, PathBuf};

/// `gibake ARGS...`.
fn gibake(args: &[&dyn AsRef<std::ffi::OsStr>]) -> Run {
    let mut c = common::gibake();
    for a in args {
        c.arg(a.as_ref());
    }
    run_command(c)
}

/// The level: a spot light of its own, two panels and two moving balls.
fn level() -> PathBuf {
    common::data("occluded.glb")
}

/// Bakes the level into `dir/name` with the tiny settings and `flags`.
fn bake(dir: &Path, name: &str, flags: &[&str]) -> (PathBuf, Run) {
    let out = dir.join(name);
    let mut c = common::gibake();
    c.arg("bake").arg(level()).arg("-o").arg(&out);
    c.args(TINY_BAKE).args(flags);
    let r = run_command(c);
    (out, r)
}

/// A small `full` frame of the level with `asset` and `flags`, into `out`.
fn render(asset: &Path, out: &Path, flags: &[&str]) -> Run {
    let mut c = common::gibake();
    c.arg("render").arg(level()).arg("--bake").arg(asset);
    c.args([
        "--width",
        "24",
        "--height",
        "16",
        "--ssaa",
        "1",
        "--shadow-map-size",
        "128",
        "--interleave",
        "1",
        "--time",
        "0.5",
    ]);
    c.args(flags).arg("-o").arg(out);
    run_command(c)
}

fn ok(r: &Run) {
    assert_eq!(r.code, Some(0), "{r}");
    assert!(!r.stderr.contains("panicked"), "{r}");
}

fn refused(r: &Run, needles: &[&str]) {
    assert_eq!(r.code, Some(2), "{r}");
    for n in needles {
        assert!(r.stderr.contains(n), "stderr does not say `{n}`\n{r}");
    }
    assert!(!r.stderr.contains("panicked"), "{r}");
}

/// The line render and view print when they apply the bake's flags.
const APPLYING: &str = "applying the bake's";

/// The case: a level with a light of its own, baked with `--sun`,
/// rendered without it. It renders (with one line saying what it applied),
/// and the frame is the one rendered with the flag given, bit for bit.
/// `--dynamic` likewise, and both together, given in part.
#[test]
fn a_level_baked_with_sun_and_dynamic_renders_without_them() {
    let work = tempfile::tempdir().unwrap();
    let w = work.path();
    for (name, flags, applied) in [
        (
            "sun",
            vec!["--sun", "173,60"],
            "applying the bake's --sun 173,60 (recorded in",
        ),
        (
            "dynamic",
            vec!["--dynamic", "hidden_panel_*"],
            "applying the bake's --dynamic 'hidden_panel_*' (recorded in",
        ),
        (
            "both",
            vec![
                "--dynamic",
                "hidden_panel_*",
                "--sun",
                "200,45",
                "--sun-irradiance",
                "3",
            ],
            "applying the bake's --sun 200,45 --sun-irradiance 3 --dynamic 'hidden_panel_*' (recorded in",
        ),
    ] {
        let (asset, r) = bake(w, &format!("{name}.gibake"), &flags);
        ok(&r);
        let inspect = gibake(&[&"inspect", &asset]);
        ok(&inspect);
        assert!(
            inspect.stdout.contains("  scene flags: --"),
            "{name}: inspect does not show the flags\n{inspect}"
        );
        let without = w.join(format!("{name}_without.exr"));
        let r = render(&asset, &without, &[]);
        ok(&r);
        assert!(
            r.stderr.contains(applied),
            "{name}: `{applied}` not said\n{r}"
        );
        assert_eq!(r.stderr.matches(APPLYING).count(), 1, "{r}");
        let with = w.join(format!("{name}_with.exr"));
        let r = render(&asset, &with, &flags);
        ok(&r);
        assert!(
            !r.stderr.contains(APPLYING),
            "{name}: nothing to apply\n{r}"
        );
        let (a, b) = (
            std::fs::read(&without).unwrap(),
            std::fs::read(&with).unwrap(),
        );
        assert!(
            a == b,
            "{name}: the frame without the flags differs from the one with them"
        );
    }
    // Given in part: the rest applied, and only the rest said.
    let asset = w.join("both.gibake");
    let part = w.join("part.exr");
    let r = render(&asset, &part, &["--sun", "200,45", "--sun-irradiance", "3"]);
    ok(&r);
    assert!(
        r.stderr
            .contains("applying the bake's --dynamic 'hidden_panel_*' (recorded in"),
        "{r}"
    );
    assert_eq!(
        std::fs::read(&part).unwrap(),
        std::fs::read(w.join("both_with.exr")).unwrap()
    );
    // The viewer applies them as well (its GPU report needs no window).
    let r = gibake(&[&"view", &level(), &"--bake", &asset, &"--gpu-report"]);
    ok(&r);
    assert!(
        r.stderr.contains(
            "applying the bake's --sun 200,45 --sun-irradiance 3 --dynamic 'hidden_panel_*'"
        ),
        "{r}"
    );
}

/// Flags that differ from the bake's are refused before anything is
/// rendered, naming the bake's and the ones given; so are flags the bake
/// did not have. Nothing is written.
#[test]
fn flags_that_differ_from_the_bake_are_refused_naming_both() {
    let work = tempfile::tempdir().unwrap();
    let w = work.path();
    let (asset, r) = bake(
        w,
        "a.gibake",
        &["--sun", "173,60", "--dynamic", "hidden_panel_*"],
    );
    ok(&r);
    let out = w.join("f.exr");
    let r = render(&asset, &out, &["--sun", "10,60"]);
    refused(
        &r,
        &[
            "a.gibake was baked with --sun 173,60 --dynamic 'hidden_panel_*', but `render` was given --sun 10,60 (--sun differs)",
            "give `render` the same ones, or none of them (the bake's are then applied), or re-bake",
        ],
    );
    let r = render(
        &asset,
        &out,
        &["--sun", "173,60", "--dynamic", "ball_*", "--light", "spot"],
    );
    refused(
        &r,
        &["was given --sun 173,60 --dynamic 'ball_*' --light spot (--dynamic, --light differ)"],
    );
    assert!(!out.exists(), "a refused render wrote its frame");
    let r = gibake(&[
        &"view",
        &level(),
        &"--bake",
        &asset,
        &"--sun-irradiance",
        &"2",
        &"--sun",
        &"173,60",
        &"--gpu-report",
    ]);
    refused(
        &r,
        &["but `view` was given --sun 173,60 --sun-irradiance 2 (--sun differs)"],
    );
    // An asset baked with none: a flag given is refused too.
    let (plain, r) = bake(w, "plain.gibake", &[]);
    ok(&r);
    let r = render(&plain, &out, &["--sun", "173,60"]);
    refused(
        &r,
        &[
            "plain.gibake was baked with none of --sun, --dynamic, --light, --bake-volume or --max-texture-size",
        ],
    );
    assert!(!out.exists());
}

/// An asset whose manifest a 4.3 writer wrote records no flags: it loads,
/// renders with the bake's flags given (the same frame as the 4.4 asset),
/// and without them is refused naming both ways out; `gibake bake` with
/// the flags re-bakes it to record them.
#[test]
fn an_asset_of_format_4_3_renders_with_the_flags_given() {
    let work = tempfile::tempdir().unwrap();
    let w = work.path();
    // (An asset of format 4.3 is the first bounce alone: `--bounces 1`.)
    let (asset, r) = bake(w, "new.gibake", &["--sun", "173,60", "--bounces", "1"]);
    ok(&r);
    // (Nor has it second maps, format 4.7: the frame to match is the same
    // asset's as a 4.6 writer wrote it, flags recorded.)
    let mut m = gibake_asset::load_manifest(&asset).unwrap();
    std::fs::write(
        asset.join(gibake_asset::FILE_MANIFEST),
        gibake_asset::testing::manifest_bytes_4_6(&m).unwrap(),
    )
    .unwrap();
    let current = w.join("current.exr");
    ok(&render(&asset, &current, &[]));
    assert!(m.scene_options.is_some());
    m.scene_options = None;
    m.swept_bounds = None;
    std::fs::write(
        asset.join(gibake_asset::FILE_MANIFEST),
        gibake_asset::testing::manifest_bytes_4_3(&m).unwrap(),
    )
    .unwrap();
    let bytes = std::fs::read(asset.join(gibake_asset::FILE_MANIFEST)).unwrap();
    assert_eq!(u16::from_le_bytes([bytes[10], bytes[11]]), 3);
    let inspect = gibake(&[&"inspect", &asset]);
    ok(&inspect);
    assert!(
        inspect.stdout.contains("  scene flags: not recorded"),
        "{inspect}"
    );
    let old = w.join("old.exr");
    let r = render(&asset, &old, &["--sun", "173,60"]);
    ok(&r);
    assert!(!r.stderr.contains(APPLYING), "{r}");
    assert!(
        std::fs::read(&old).unwrap() == std::fs::read(&current).unwrap(),
        "the 4.3 asset renders another frame"
    );
    let r = render(&asset, &w.join("none.exr"), &[]);
    refused(
        &r,
        &[
            "was baked from a different static scene",
            "re-bake it, or, if it was baked with --sun, --dynamic, --light, --bake-volume or --max-texture-size, give the same ones (an asset before format 4.4 does not record them)",
        ],
    );
    // Baked again with the flag: re-baked to record it, then up to date.
    let (_, r) = bake(w, "new.gibake", &["--sun", "173,60"]);
    ok(&r);
    assert!(
        r.stderr.contains(
            "the asset does not record its scene flags (format 4.3 or older): re-baked to record --sun 173,60"
        ),
        "{r}"
    );
    let (_, r) = bake(w, "new.gibake", &["--sun", "173,60"]);
    ok(&r);
    assert!(r.stderr.contains("up to date"), "{r}");
    // A 4.3 asset baked without flags has no flag to record. (Its level's
    // balls move, and an asset before format 4.5 does not record their
    // swept bounds, on which its VPLs depend: that alone re-bakes it once.)
    let (plain, r) = bake(w, "plain.gibake", &["--bounces", "1"]);
    ok(&r);
    let mut m = gibake_asset::load_manifest(&plain).unwrap();
    m.scene_options = None;
    m.swept_bounds = None;
    std::fs::write(
        plain.join(gibake_asset::FILE_MANIFEST),
        gibake_asset::testing::manifest_bytes_4_3(&m).unwrap(),
    )
    .unwrap();
    let (_, r) = bake(w, "plain.gibake", &[]);
    ok(&r);
    assert!(
        r.stderr
            .contains("does not record the moving objects' swept bounds")
            && !r.stderr.contains("scene flags"),
        "{r}"
    );
    let (_, r) = bake(w, "plain.gibake", &[]);
    ok(&r);
    assert!(r.stderr.contains("up to date"), "{r}");
}

/// The up-to-date check compares the recorded flags, in canonical form:
/// the same patterns in another order are up to date; `--light spot` on a
/// level whose only light is `spot` bakes the same static scene but records
/// another flag, so it re-bakes saying why.
#[test]
fn the_up_to_date_check_compares_the_flags() {
    let work = tempfile::tempdir().unwrap();
    let w = work.path();
    let (asset, r) = bake(
        w,
        "a.gibake",
        &[
            "--dynamic",
            "hidden_panel_b*",
            "--dynamic",
            "hidden_panel_y*",
        ],
    );
    ok(&r);
    let first = std::fs::read(asset.join(gibake_asset::FILE_MANIFEST)).unwrap();
    let (_, r) = bake(
        w,
        "a.gibake",
        &[
            "--dynamic",
            "hidden_panel_y*",
            "--dynamic",
            "hidden_panel_b*",
        ],
    );
    ok(&r);
    assert!(
        r.stderr
            .contains("up to date (same static-scene hash, scene flags"),
        "{r}"
    );
    let (plain, r) = bake(w, "p.gibake", &[]);
    ok(&r);
    let (_, r) = bake(w, "p.gibake", &["--light", "spot"]);
    ok(&r);
    assert!(
        r.stderr.contains(
            "reason: scene flags changed (none of --sun, --dynamic, --light, --bake-volume or --max-texture-size → --light spot; the asset records them)"
        ),
        "{r}"
    );
    let m = gibake_asset::load_manifest(&plain).unwrap();
    assert_eq!(m.scene_options.unwrap().lights, vec!["spot"]);
    // A forced re-bake of the first: the same bytes (deterministic).
    let (_, r) = bake(
        w,
        "a.gibake",
        &[
            "--dynamic",
            "hidden_panel_y*",
            "--dynamic",
            "hidden_panel_b*",
            "--force",
        ],
    );
    ok(&r);
    assert_eq!(
        std::fs::read(asset.join(gibake_asset::FILE_MANIFEST)).unwrap(),
        first
    );
}

/// A sharded bake records the flags in its parts; the merge is the single
/// bake's asset, byte for byte, and renders without the flags.
#[test]
fn a_sharded_bake_records_the_flags() {
    let work = tempfile::tempdir().unwrap();
    let w = work.path();
    let flags = ["--sun", "173,60", "--dynamic", "hidden_panel_*"];
    let (single, r) = bake(w, "single.gibake", &flags);
    ok(&r);
    let mut parts = Vec::new();
    for k in 0..2 {
        let shard = format!("{k}/2");
        let mut f = flags.to_vec();
        f.extend(["--shard", &shard]);
        let (part, r) = bake(w, &format!("part{k}"), &f);
        ok(&r);
        parts.push(part);
    }
    let merged = w.join("merged.gibake");
    let r = gibake(&[&"merge", &parts[1], &parts[0], &"-o", &merged]);
    ok(&r);
    for e in std::fs::read_dir(&single).unwrap() {
        let name = e.unwrap().file_name();
        assert_eq!(
            std::fs::read(single.join(&name)).unwrap(),
            std::fs::read(merged.join(&name)).unwrap(),
            "{name:?} of the merge differs from the single bake's"
        );
    }
    let r = render(&merged, &w.join("m.exr"), &[]);
    ok(&r);
    assert!(r.stderr.contains(APPLYING), "{r}");
}
