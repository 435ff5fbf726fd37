//! End-to-end tests of the `gibake` CLI's success paths: help, `render
//! --mode direct` (EXR, PNG, sequences, stats), `reference`, scale
//! invariance, and `bake` / `diff` / `inspect` (determinism, settings
//! changes, JSON output). Images are tiny so each call is fast on lavapipe.

use crate::common;

use common::{Run, run_command};

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

/// Small settings so every GPU call takes well under a second on lavapipe.
const TINY_BAKE: [&str; 6] = [
    "--vpls",
    "16",
    "--vpl-map-size",
    "16",
    "--shadow-map-size",
    "256",
];

/// Runs `gibake` with the given arguments (anything `AsRef<OsStr>`).
macro_rules! gibake {
    ($($a:expr),* $(,)?) => {{
        let mut c = common::gibake();
        $( c.arg($a); )*
        run_command(c)
    }};
}

fn assert_ok(r: &Run) {
    assert_eq!(r.code, Some(0), "{r}");
    assert!(!r.stderr.contains("panicked"), "{r}");
}

/// `gibake render SCENE --mode direct` at `size`² with `extra` flags.
fn render_direct(scene: &Path, out: &Path, size: u32, extra: &[&str]) -> Run {
    let mut c = common::gibake();
    c.arg("render")
        .arg(scene)
        .args([
            "--mode",
            "direct",
            "--shadow-map-size",
            "512",
            "--ssaa",
            "1",
        ])
        .arg("--width")
        .arg(size.to_string())
        .arg("--height")
        .arg(size.to_string())
        .args(extra)
        .arg("-o")
        .arg(out);
    run_command(c)
}

fn read_exr(p: &Path) -> gibake_image::Image {
    gibake_image::Image::read_exr(p)
        .unwrap_or_else(|e| panic!("{}: not a readable EXR: {e}", p.display()))
}

/// Checks the image is finite and not black.
fn assert_sane(img: &gibake_image::Image, what: &str) {
    assert!(img.all_finite(), "{what}: non-finite pixels");
    let m = img.mean();
    assert!(m.min_element() >= 0.0, "{what}: negative mean radiance {m}");
    assert!(m.max_element() > 0.0, "{what}: black image");
}

/// The per-frame entries of a `--stats` file: `frames` (one object per
/// frame) or `frame_seconds` (one number per frame). Checks what each entry
/// holds: finite non-negative times, the frame's output file and time.
fn check_stats_frames(json: &serde_json::Value, outputs: &[&str], times: &[f64]) {
    let frames = json["frames"]
        .as_array()
        .or_else(|| json["frame_seconds"].as_array())
        .unwrap_or_else(|| panic!("stats have no per-frame list (`frames`)\n{json:#}"));
    assert_eq!(
        frames.len(),
        outputs.len(),
        "one stats entry per frame\n{json:#}"
    );
    let seconds_ok = |v: &serde_json::Value| v.as_f64().is_some_and(|t| t.is_finite() && t >= 0.0);
    for (i, f) in frames.iter().enumerate() {
        if f.is_number() {
            assert!(seconds_ok(f), "frame {i}: bad time {f}\n{json:#}");
            continue;
        }
        assert!(f.is_object(), "frame {i}: {f}\n{json:#}");
        let mut timed = false;
        for key in ["wall_seconds", "seconds", "frame_seconds"] {
            if !f[key].is_null() {
                assert!(seconds_ok(&f[key]), "frame {i}: bad {key}\n{json:#}");
                timed = true;
            }
        }
        assert!(timed, "frame {i} has no timing\n{json:#}");
        if let Some(out) = f["output"].as_str() {
            assert!(
                out.ends_with(outputs[i]),
                "frame {i}: output {out}, expected {}\n{json:#}",
                outputs[i]
            );
        }
        if let Some(t) = f["time"].as_f64() {
            assert!(
                (t - times[i]).abs() < 1e-4,
                "frame {i}: time {t}, expected {}\n{json:#}",
                times[i]
            );
        }
    }
}

fn list_dir(dir: &Path) -> Vec<String> {
    let mut v: Vec<String> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    v.sort();
    v
}

// ---------------------------------------------------------------------------
// Help.

#[test]
fn help_of_every_subcommand() {
    let cases: &[(&[&str], &[&str])] = &[
        (
            &["--help"],
            &[
                "bake",
                "render",
                "reference",
                "diff",
                "inspect",
                "demo",
                "bench",
            ],
        ),
        (
            &["render", "--help"],
            &[
                "--bake", "--time", "--width", "--height", "--mode", "--output", "--frames",
                "--fps", "--stats", "--ssaa", "--light", "direct", "full", "indirect", "rsm",
                "naive",
            ],
        ),
        (
            &["reference", "--help"],
            &[
                "--time",
                "--width",
                "--height",
                "--spp",
                "--bounces",
                "every bounce",
                "--direct-only",
                "--output",
                "--light",
            ],
        ),
        (
            &["bake", "--help"],
            &[
                "--output",
                "--vpls",
                "--threshold",
                "--rsm-size",
                "--vpl-map-size",
                "--json",
                "--light",
            ],
        ),
        (
            &["diff", "--help"],
            &[
                "--json",
                "--tolerance",
                "--images",
                "same-machine",
                "another-gpu",
            ],
        ),
        (&["inspect", "--help"], &["--json"]),
        (&["demo", "--help"], &["--output"]),
        (&["bench", "--help"], &["usage"]),
        (&["help", "bake"], &["--vpls", "--threshold"]),
    ];
    let mut failures = Vec::new();
    for (args, needles) in cases {
        let mut c = common::gibake();
        c.args(*args);
        let r = run_command(c);
        if r.code != Some(0) {
            failures.push(format!("exit {:?}\n{r}", r.code));
            continue;
        }
        let text = r.stdout.to_lowercase();
        for n in *needles {
            if !text.contains(&n.to_lowercase()) {
                failures.push(format!("`gibake {}` does not mention {n}", args.join(" ")));
            }
        }
    }
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}

#[test]
fn version_flag() {
    let r = gibake!("--version");
    assert_ok(&r);
    assert!(r.stdout.contains("gibake"), "{r}");
}

// ---------------------------------------------------------------------------
// render / reference.

#[test]
fn render_direct_writes_exr_and_png() {
    let out = tempfile::tempdir().unwrap();
    let exr = out.path().join("frame.exr");
    let r = render_direct(&common::data("corner_bunny.glb"), &exr, 32, &[]);
    assert_ok(&r);
    let img = read_exr(&exr);
    assert_eq!((img.width, img.height), (32, 32));
    assert_sane(&img, "render --mode direct");

    let png = out.path().join("frame.png");
    let r = render_direct(&common::data("corner_bunny.glb"), &png, 32, &[]);
    assert_ok(&r);
    let bytes = std::fs::read(&png).unwrap();
    assert!(
        bytes.starts_with(b"\x89PNG\r\n\x1a\n"),
        "{}: not a PNG",
        png.display()
    );
    // IHDR: width and height, big-endian, at bytes 16..24.
    let w = u32::from_be_bytes(bytes[16..20].try_into().unwrap());
    let h = u32::from_be_bytes(bytes[20..24].try_into().unwrap());
    assert_eq!((w, h), (32, 32));
    // Only the two outputs, no temporary files.
    assert_eq!(
        list_dir(out.path()),
        vec!["frame.exr".to_string(), "frame.png".to_string()]
    );
}

#[test]
fn render_direct_non_square_and_ssaa() {
    let out = tempfile::tempdir().unwrap();
    let exr = out.path().join("wide.exr");
    let mut c = common::gibake();
    c.arg("render").arg(common::data("sun.glb")).args([
        "--mode",
        "direct",
        "--width",
        "40",
        "--height",
        "24",
        "--ssaa",
        "2",
        "--shadow-map-size",
        "512",
        "--time",
        "1.5",
        "-o",
    ]);
    c.arg(&exr);
    let r = run_command(c);
    assert_ok(&r);
    let img = read_exr(&exr);
    assert_eq!((img.width, img.height), (40, 24));
    assert_sane(&img, "sun.glb 40×24 ssaa 2");
}

#[test]
fn render_sequence_replaces_hashes() {
    let out = tempfile::tempdir().unwrap();
    let pattern = out.path().join("seq_###.exr");
    let stats = out.path().join("stats.json");
    let r = render_direct(
        &common::data("corner_bunny.glb"),
        &pattern,
        16,
        &[
            "--frames",
            "3",
            "--fps",
            "10",
            "--stats",
            stats.to_str().unwrap(),
        ],
    );
    assert_ok(&r);
    assert_eq!(
        list_dir(out.path()),
        ["seq_000.exr", "seq_001.exr", "seq_002.exr", "stats.json"]
            .map(String::from)
            .to_vec(),
        "{r}"
    );
    for f in ["seq_000.exr", "seq_001.exr", "seq_002.exr"] {
        assert_sane(&read_exr(&out.path().join(f)), f);
    }
    let json: serde_json::Value =
        serde_json::from_slice(&std::fs::read(&stats).unwrap()).expect("stats JSON parses");
    check_stats_frames(
        &json,
        &["seq_000.exr", "seq_001.exr", "seq_002.exr"],
        &[0.0, 0.1, 0.2],
    );
}

#[test]
fn render_stats_json() {
    let out = tempfile::tempdir().unwrap();
    let stats = out.path().join("stats.json");
    let r = render_direct(
        &common::data("occluded.glb"),
        &out.path().join("f.exr"),
        16,
        &["--time", "0.25", "--stats", stats.to_str().unwrap()],
    );
    assert_ok(&r);
    let json: serde_json::Value =
        serde_json::from_slice(&std::fs::read(&stats).unwrap()).expect("stats JSON parses");
    assert_eq!(json["mode"], "direct", "{json}");
    assert!(
        json["adapter"].as_str().is_some_and(|a| !a.is_empty()),
        "{json}"
    );
    for (key, want) in [("width", 16), ("height", 16)] {
        if !json[key].is_null() {
            assert_eq!(json[key].as_u64(), Some(want), "{key}\n{json:#}");
        }
    }
    check_stats_frames(&json, &["f.exr"], &[0.25]);
}

#[test]
fn reference_direct_only_writes_exr() {
    let out = tempfile::tempdir().unwrap();
    let exr = out.path().join("ref.exr");
    let r = gibake!(
        "reference",
        common::data("corner_bunny.glb"),
        "--direct-only",
        "--spp",
        "4",
        "--width",
        "24",
        "--height",
        "16",
        "-o",
        &exr
    );
    assert_ok(&r);
    let img = read_exr(&exr);
    assert_eq!((img.width, img.height), (24, 16));
    assert_sane(&img, "reference --direct-only");
    assert_eq!(list_dir(out.path()), vec!["ref.exr".to_string()]);
}

/// `reference` shades every lamp of the multi-light scene by default: no
/// lamp is ignored, and the image is the sum of its lights (here: brighter
/// than the spot alone, everywhere on average, and the direct image equals
/// the sum of the per-light images, each picked with `--light`, up to
/// rounding). `--all-lights`, once needed for this, is still accepted and
/// changes nothing.
#[test]
fn reference_shades_every_lamp_by_default() {
    let out = tempfile::tempdir().unwrap();
    let run = |name: &str, extra: &[&str]| {
        let p = out.path().join(name);
        let mut c = common::gibake();
        c.arg("reference")
            .arg(common::data("lamps.glb"))
            .args([
                "--direct-only",
                "--spp",
                "2",
                "--width",
                "16",
                "--height",
                "12",
            ])
            .args(extra)
            .arg("-o")
            .arg(&p);
        let r = run_command(c);
        assert_ok(&r);
        (r, read_exr(&p))
    };
    let (r, all) = run("all.exr", &[]);
    assert!(!r.stderr.contains("ignoring"), "{r}");
    assert_sane(&all, "reference");
    let (_, legacy) = run("legacy.exr", &["--all-lights"]);
    assert_eq!(legacy.pixels, all.pixels, "--all-lights changes nothing");
    let (r, spot) = run("spot.exr", &["--light", "spot_lamp"]);
    assert!(r.stderr.contains("ignoring"), "{r}");
    let mut sum = spot.clone();
    for lamp in ["point_lamp", "point_lamp_low"] {
        let (_, one) = run(&format!("{lamp}.exr"), &["--light", lamp]);
        for (s, o) in sum.pixels.iter_mut().zip(&one.pixels) {
            *s += *o;
        }
    }
    let mean = |img: &gibake_image::Image| {
        img.pixels
            .iter()
            .map(|v| v.as_dvec3().element_sum())
            .sum::<f64>()
    };
    assert!(mean(&all) > mean(&spot) * 1.05, "the point lamps add light");
    for (k, (a, s)) in all.pixels.iter().zip(&sum.pixels).enumerate() {
        assert!(
            (*a - *s).abs().max_element() <= 1e-5 * a.max_element().max(1e-6),
            "pixel {k}: all lights {a}, sum of each {s}"
        );
    }
}

/// `reference --bounces`: the default is every bounce (more light than one
/// bounce in the bundled corner); `--bounces 1` writes what `reference`
/// always wrote before every bounce existed (the library's one-bounce
/// render, bit for bit); `--bounces 0` is `--direct-only`.
#[test]
fn reference_bounces() {
    let out = tempfile::tempdir().unwrap();
    let scene = common::data("corner_bunny.glb");
    let run = |name: &str, extra: &[&str]| {
        let p = out.path().join(name);
        let mut c = common::gibake();
        c.arg("reference")
            .arg(&scene)
            .args([
                "--spp", "4", "--width", "24", "--height", "16", "--seed", "3",
            ])
            .args(extra)
            .arg("-o")
            .arg(&p);
        let r = run_command(c);
        assert_ok(&r);
        (r, read_exr(&p))
    };
    let (r, every) = run("every.exr", &[]);
    assert!(r.stderr.contains("every bounce"), "{r}");
    assert!(!r.stderr.contains("warning"), "{r}");
    assert_sane(&every, "reference");
    let (_, all) = run("all.exr", &["--bounces", "all"]);
    assert_eq!(all.pixels, every.pixels, "the default is --bounces all");
    let (r, one) = run("one.exr", &["--bounces", "1"]);
    assert!(r.stderr.contains("direct + one bounce"), "{r}");
    let loaded = gibake_scene::load(&scene, &Default::default()).expect("corner_bunny loads");
    let library = gibake_reference::render(
        &loaded,
        &gibake_reference::Settings {
            width: 24,
            height: 16,
            spp: 4,
            time: 0.0,
            depth: gibake_reference::Depth::OneBounce,
            seed: 3,
        },
        &|_| {},
    )
    .expect("reference");
    assert_eq!(
        one.pixels, library.pixels,
        "--bounces 1 is the one-bounce reference"
    );
    let (_, zero) = run("zero.exr", &["--bounces", "0"]);
    let (_, direct) = run("direct.exr", &["--direct-only"]);
    assert_eq!(zero.pixels, direct.pixels, "--bounces 0 is --direct-only");
    let (_, three) = run("three.exr", &["--bounces", "3"]);
    let sum = |i: &gibake_image::Image| i.mean().element_sum();
    assert!(
        sum(&direct) < sum(&one) && sum(&one) < sum(&three) && sum(&three) < sum(&every),
        "each bounce adds light: {} {} {} {}",
        sum(&direct),
        sum(&one),
        sum(&three),
        sum(&every)
    );
}

/// A closed box of glTF's default material (albedo 1) with a lamp inside:
/// every bounce has no finite answer there. `reference` does not hang: its
/// paths stop at 1024 bounces, a quick probe warns before the render and
/// the render says how many paths were cut, and the image is finite.
#[test]
fn reference_of_a_white_closed_box_warns_and_ends() {
    use gibake_scenegen::geom;
    use glam::DVec3;
    let dir = tempfile::tempdir().unwrap();
    let mut b = gibake_scenegen::gltf::Builder::new(1.0, "none");
    let room = geom::aabox(DVec3::splat(-1.0), DVec3::splat(1.0), 1, true);
    b.static_mesh("room", &room, [1.0; 3]);
    b.point("lamp", DVec3::new(0.2, 0.3, -0.1), [1.0; 3], 1.0, None);
    b.perspective(
        "camera",
        DVec3::ZERO,
        DVec3::new(-1.0, -0.5, -1.0),
        1.2,
        0.01,
        100.0,
    );
    let scene = dir.path().join("white_box.glb");
    std::fs::write(&scene, b.finish()).unwrap();
    let exr = dir.path().join("ref.exr");
    let t = std::time::Instant::now();
    let r = gibake!(
        "reference",
        &scene,
        "--spp",
        "1",
        "--width",
        "8",
        "--height",
        "8",
        "-o",
        &exr
    );
    assert_ok(&r);
    assert!(t.elapsed().as_secs() < 60, "{r}");
    assert!(r.stderr.contains("quick probe"), "{r}");
    assert!(r.stderr.contains("reached 1024 bounces"), "{r}");
    assert!(r.stderr.contains("--bounces N"), "{r}");
    let img = read_exr(&exr);
    assert_sane(&img, "white box");
    // Each of the ~1024 bounces adds about the first's light again.
    let (_, one) = {
        let p = dir.path().join("one.exr");
        let r = gibake!(
            "reference",
            &scene,
            "--spp",
            "1",
            "--width",
            "8",
            "--height",
            "8",
            "--bounces",
            "1",
            "-o",
            &p
        );
        assert_ok(&r);
        assert!(!r.stderr.contains("warning"), "{r}");
        (r, read_exr(&p))
    };
    let ratio = img.mean().x / one.mean().x;
    assert!(
        ratio > 200.0 && ratio.is_finite(),
        "every ÷ one bounce {ratio}"
    );
}

#[test]
fn reference_is_deterministic_for_a_seed() {
    let out = tempfile::tempdir().unwrap();
    let mut imgs = Vec::new();
    for name in ["a.exr", "b.exr"] {
        let p = out.path().join(name);
        let r = gibake!(
            "reference",
            common::data("sun.glb"),
            "--spp",
            "2",
            "--width",
            "12",
            "--height",
            "12",
            "--seed",
            "5",
            "-o",
            &p
        );
        assert_ok(&r);
        imgs.push(read_exr(&p));
    }
    assert_eq!(imgs[0], imgs[1], "same seed, different images");
}

#[test]
fn render_is_scale_invariant() {
    let dir = tempfile::tempdir().unwrap();
    let mut imgs = Vec::new();
    for scale in [1.0f32, 1000.0, 0.001] {
        let glb = gibake_scenegen::scaled("corner_bunny", scale).expect("corner_bunny exists");
        let scene = dir.path().join(format!("corner_bunny_x{scale}.glb"));
        std::fs::write(&scene, glb).unwrap();
        let exr = dir.path().join(format!("x{scale}.exr"));
        let r = render_direct(&scene, &exr, 32, &[]);
        assert_ok(&r);
        let img = read_exr(&exr);
        assert_sane(&img, &format!("scale {scale}"));
        imgs.push((scale, img));
    }
    let base = &imgs[0].1;
    let mut report = Vec::new();
    for (scale, img) in &imgs[1..] {
        let e = gibake_image::rel_mse(img, base);
        report.push(format!("scale {scale}: rel MSE {e:.2e} against scale 1"));
    }
    eprintln!("{}", report.join("\n"));
    for ((_, img), line) in imgs[1..].iter().zip(&report) {
        assert!(
            gibake_image::rel_mse(img, base) <= 1e-3,
            "{line}\n{}",
            report.join("\n")
        );
    }
}

// ---------------------------------------------------------------------------
// bake / diff / inspect.

/// Bakes `scene` into `dir/name` with the tiny settings, `--rsm-size rsm` and
/// `extra` flags.
fn bake(scene: &Path, dir: &Path, name: &str, rsm: u32, extra: &[&str]) -> (PathBuf, Run) {
    let asset = dir.join(name);
    let mut c = common::gibake();
    c.arg("bake")
        .arg(scene)
        .arg("-o")
        .arg(&asset)
        .args(TINY_BAKE)
        .arg("--rsm-size")
        .arg(rsm.to_string())
        .args(extra);
    let r = run_command(c);
    assert_ok(&r);
    assert!(asset.join("manifest.bin").is_file(), "no manifest.bin\n{r}");
    (asset, r)
}

fn read_all(dir: &Path) -> BTreeMap<String, Vec<u8>> {
    list_dir(dir)
        .into_iter()
        .map(|n| (n.clone(), std::fs::read(dir.join(&n)).unwrap()))
        .collect()
}

#[test]
fn bake_is_byte_identical_and_diff_says_equal() {
    let work = tempfile::tempdir().unwrap();
    let scene = common::data("corner_bunny.glb");
    let (a, _) = bake(&scene, work.path(), "a.gibake", 64, &[]);
    let (b, _) = bake(&scene, work.path(), "b.gibake", 64, &[]);
    let (fa, fb) = (read_all(&a), read_all(&b));
    assert_eq!(
        fa.keys().collect::<Vec<_>>(),
        fb.keys().collect::<Vec<_>>(),
        "the two bakes hold different files"
    );
    for (name, bytes) in &fa {
        assert!(
            bytes == &fb[name],
            "{name} differs between two identical bakes ({} vs {} bytes)",
            bytes.len(),
            fb[name].len()
        );
    }
    // Only the assets in the work dir: no temporary leftovers.
    assert_eq!(
        list_dir(work.path()),
        vec!["a.gibake".to_string(), "b.gibake".to_string()]
    );

    let r = gibake!("diff", &a, &b);
    assert_ok(&r);
    let r = gibake!("diff", &a, &b, "--json");
    assert_ok(&r);
    let _: serde_json::Value =
        serde_json::from_str(&r.stdout).unwrap_or_else(|e| panic!("diff --json: {e}\n{r}"));
    let r = gibake!("diff", &a, &b, "--tolerance", "another-gpu");
    assert_ok(&r);

    // Baking again over an existing asset replaces it, with the same bytes.
    let (a2, _) = bake(&scene, work.path(), "a.gibake", 64, &[]);
    assert_eq!(
        read_all(&a2),
        fa,
        "re-baking over an existing asset changed it"
    );
    assert_eq!(
        list_dir(work.path()),
        vec!["a.gibake".to_string(), "b.gibake".to_string()]
    );
}

#[test]
fn diff_reports_a_changed_setting() {
    let work = tempfile::tempdir().unwrap();
    let scene = common::data("corner_bunny.glb");
    let (a, _) = bake(&scene, work.path(), "rsm64.gibake", 64, &[]);
    let (b, _) = bake(&scene, work.path(), "rsm32.gibake", 32, &[]);
    let r = gibake!("diff", &a, &b);
    assert_eq!(
        r.code,
        Some(1),
        "diff of different settings must exit 1\n{r}"
    );
    assert!(
        r.stdout.contains("rsm_size") || r.stdout.contains("rsm-size"),
        "diff does not name the setting\n{r}"
    );
    let r = gibake!("diff", &a, &b, "--json");
    assert_eq!(r.code, Some(1), "{r}");
    let json: serde_json::Value =
        serde_json::from_str(&r.stdout).unwrap_or_else(|e| panic!("diff --json: {e}\n{r}"));
    assert!(
        json.to_string().contains("rsm_size"),
        "diff --json does not name the setting\n{r}"
    );
    // A tolerance preset does not excuse a settings difference.
    let r = gibake!("diff", &a, &b, "--tolerance", "another-gpu");
    assert_eq!(r.code, Some(1), "{r}");
    // --images writes only into the named directory.
    let images = work.path().join("diff_images");
    let r = gibake!("diff", &a, &b, "--images", &images);
    assert_eq!(r.code, Some(1), "{r}");
}

#[test]
fn inspect_json_has_the_vpl_count() {
    let work = tempfile::tempdir().unwrap();
    let (asset, r) = bake(
        &common::data("corner_bunny.glb"),
        work.path(),
        "c.gibake",
        64,
        &["--json"],
    );
    let baked: serde_json::Value =
        serde_json::from_str(&r.stdout).unwrap_or_else(|e| panic!("bake --json: {e}\n{r}"));
    let vpls = baked["vpls"]
        .as_u64()
        .unwrap_or_else(|| panic!("bake --json has no vpls count\n{r}"));
    assert!(vpls > 0, "{r}");
    // --vpls 16: 16 first-bounce VPLs in the asset, within 2
    // (docs/method.md, bake section 3, "Budget"), and the later bounces'
    // after them (a quarter as many at most).
    let first = baked["first_bounce_vpls"]
        .as_u64()
        .unwrap_or_else(|| panic!("bake --json has no first_bounce_vpls\n{r}"));
    assert!(
        (14..=18).contains(&first),
        "asked for 16 VPLs, got {first}\n{r}"
    );
    assert_eq!(
        vpls,
        first + baked["later"]["vpls"].as_u64().unwrap_or(0),
        "{r}"
    );

    let r = gibake!("inspect", &asset, "--json");
    assert_ok(&r);
    let info: serde_json::Value =
        serde_json::from_str(&r.stdout).unwrap_or_else(|e| panic!("inspect --json: {e}\n{r}"));
    assert_eq!(
        info["vpl_count"].as_u64(),
        Some(vpls),
        "inspect and bake disagree on the VPL count\n{r}"
    );

    let r = gibake!("inspect", &asset);
    assert_ok(&r);
    assert!(
        r.stdout.contains(&vpls.to_string()),
        "inspect does not print the VPL count\n{r}"
    );
}

#[test]
fn bake_with_threshold() {
    let work = tempfile::tempdir().unwrap();
    let asset = work.path().join("t.gibake");
    let mut c = common::gibake();
    c.arg("bake")
        .arg(common::data("sun.glb"))
        .arg("-o")
        .arg(&asset)
        .args([
            "--threshold",
            "0.5",
            "--rsm-size",
            "64",
            "--vpl-map-size",
            "16",
            "--shadow-map-size",
            "256",
            "--json",
        ]);
    let r = run_command(c);
    assert_ok(&r);
    let baked: serde_json::Value =
        serde_json::from_str(&r.stdout).unwrap_or_else(|e| panic!("bake --json: {e}\n{r}"));
    assert!(baked["vpls"].as_u64().is_some_and(|n| n > 0), "{r}");
    let r = gibake!("inspect", &asset);
    assert_ok(&r);
}

/// Every mode renders through `--bake`; the asset is refused with exit 2
/// for another scene, and a missing `--bake` is a clear usage error.
#[test]
fn render_every_mode_with_a_bake_and_refuse_a_foreign_asset() {
    let dir = tempfile::tempdir().unwrap();
    let scene = common::data("corner_bunny.glb");
    let (asset, _) = bake(&scene, dir.path(), "cb.gibake", 64, &[]);
    for mode in ["full", "indirect", "rsm", "naive", "direct"] {
        let out = dir.path().join(format!("{mode}.exr"));
        let stats = dir.path().join(format!("{mode}.json"));
        let r = gibake!(
            "render", &scene, "--bake", &asset, "--mode", mode, "--width", "24", "--height", "24",
            "--ssaa", "1", "-o", &out, "--stats", &stats
        );
        assert_ok(&r);
        assert_sane(&read_exr(&out), mode);
        let json: serde_json::Value =
            serde_json::from_slice(&std::fs::read(&stats).unwrap()).unwrap();
        assert_eq!(json["mode"], mode);
    }
    let other = common::data("occluded.glb");
    let out = dir.path().join("foreign.exr");
    let r = gibake!(
        "render", &other, "--bake", &asset, "--mode", "full", "--width", "16", "--height", "16",
        "-o", &out
    );
    assert_eq!(r.code, Some(2), "{r}");
    assert!(
        r.stderr.contains("cb.gibake") && r.stderr.contains("occluded.glb"),
        "{r}"
    );
    assert!(!out.exists());
    let r = gibake!(
        "render", &scene, "--mode", "full", "--width", "16", "--height", "16", "-o", &out
    );
    assert_eq!(r.code, Some(2), "{r}");
    assert!(r.stderr.contains("gibake bake"), "{r}");
}
