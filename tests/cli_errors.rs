//! End-to-end tests of the `gibake` CLI on bad input and bad usage: every
//! case must exit with code 2, print one clear message on stderr that names
//! the offending file (or flag) and what is wrong, never panic, and leave no
//! output (nor temporary files) behind.

use crate::common;

use common::{Run, TINY_BAKE, TINY_RENDER, run_command};

use std::path::{Path, PathBuf};

/// Runs `gibake` with the given arguments (anything `AsRef<OsStr>`).
macro_rules! gibake {
    ($($a:expr),* $(,)?) => {{
        let mut c = common::gibake();
        $( c.arg($a); )*
        let cmd = format!("gibake {}", c.get_args().map(|a| a.to_string_lossy().into_owned()).collect::<Vec<_>>().join(" "));
        let o = c.output().expect("cannot start the gibake binary");
        Run {
            code: o.status.code(),
            stdout: String::from_utf8_lossy(&o.stdout).into_owned(),
            stderr: String::from_utf8_lossy(&o.stderr).into_owned(),
            cmd,
        }
    }};
}

/// Asserts exit code 2, no panic, and that stderr contains every one of
/// `needles` (case-insensitive). Returns the failure instead of panicking.
fn check_bad(r: &Run, needles: &[&str]) -> Result<(), String> {
    let err = r.stderr.to_lowercase();
    let mut problems = Vec::new();
    if r.code != Some(2) {
        problems.push(format!("exit code {:?}, expected 2", r.code));
    }
    if err.contains("panicked") || err.contains("rust_backtrace") {
        problems.push("it panicked".to_string());
    }
    for n in needles {
        if !err.contains(&n.to_lowercase()) {
            problems.push(format!("stderr does not mention {n:?}"));
        }
    }
    if problems.is_empty() {
        Ok(())
    } else {
        Err(format!("{}\n{r}", problems.join("; ")))
    }
}

fn assert_bad(r: &Run, needles: &[&str]) {
    if let Err(e) = check_bad(r, needles) {
        panic!("{e}");
    }
}

/// Asserts `dir` holds nothing (no output, no temporary leftovers).
fn assert_empty(dir: &Path, r: &Run) {
    let left: Vec<_> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    assert!(
        left.is_empty(),
        "files left behind in {}: {left:?}\n{r}",
        dir.display()
    );
}

fn file_name(p: &Path) -> String {
    p.file_name().unwrap().to_string_lossy().into_owned()
}

// ---------------------------------------------------------------------------
// Tiny glTF scenes (JSON with a base64 data-URI buffer).

fn base64(data: &[u8]) -> String {
    const T: &[u8; 64] = b"ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
    let mut s = String::with_capacity(data.len().div_ceil(3) * 4);
    for c in data.chunks(3) {
        let b = [
            c[0],
            c.get(1).copied().unwrap_or(0),
            c.get(2).copied().unwrap_or(0),
        ];
        let n = (u32::from(b[0]) << 16) | (u32::from(b[1]) << 8) | u32::from(b[2]);
        for i in 0..4 {
            if i <= c.len() {
                s.push(T[((n >> (18 - 6 * i)) & 63) as usize] as char);
            } else {
                s.push('=');
            }
        }
    }
    s
}

/// A floor quad seen by a camera and lit by lights pointing down.
struct Tiny {
    positions: Vec<[f32; 3]>,
    indices: Vec<u32>,
    /// (name, type) of each light: "spot", "directional" or "point".
    lights: Vec<(&'static str, &'static str)>,
    camera: bool,
    /// Mark the floor `extras: {"dynamic": true}` (then nothing is static).
    dynamic_floor: bool,
}

impl Default for Tiny {
    fn default() -> Self {
        Tiny {
            positions: vec![
                [-1.0, 0.0, -1.0],
                [1.0, 0.0, -1.0],
                [1.0, 0.0, 1.0],
                [-1.0, 0.0, 1.0],
            ],
            indices: vec![0, 3, 2, 0, 2, 1],
            lights: vec![("key", "spot")],
            camera: true,
            dynamic_floor: false,
        }
    }
}

impl Tiny {
    fn json(&self) -> String {
        let mut bin = Vec::new();
        for p in &self.positions {
            for c in p {
                bin.extend_from_slice(&c.to_le_bytes());
            }
        }
        let pos_len = bin.len();
        for i in &self.indices {
            bin.extend_from_slice(&i.to_le_bytes());
        }
        let idx_len = bin.len() - pos_len;
        // min/max over the finite components (JSON cannot hold NaN or inf).
        let mut lo = [f32::MAX; 3];
        let mut hi = [f32::MIN; 3];
        for p in &self.positions {
            for k in 0..3 {
                if p[k].is_finite() {
                    lo[k] = lo[k].min(p[k]);
                    hi[k] = hi[k].max(p[k]);
                }
            }
        }
        let mut nodes = vec![format!(
            r#"{{"name":"floor","mesh":0{}}}"#,
            if self.dynamic_floor {
                r#","extras":{"dynamic":true}"#
            } else {
                ""
            }
        )];
        if self.camera {
            nodes.push(r#"{"name":"cam","camera":0,"translation":[0,1,3]}"#.to_string());
        }
        let mut lights = Vec::new();
        for (i, (name, ty)) in self.lights.iter().enumerate() {
            let spot = if *ty == "spot" {
                r#","spot":{"innerConeAngle":0.4,"outerConeAngle":0.7}"#
            } else {
                ""
            };
            lights.push(format!(
                r#"{{"name":"{name}","type":"{ty}","color":[1,1,1],"intensity":20{spot}}}"#
            ));
            nodes.push(format!(
                r#"{{"name":"{name}_node","translation":[{x},3,0],"rotation":[-0.70710678,0,0,0.70710678],"extensions":{{"KHR_lights_punctual":{{"light":{i}}}}}}}"#,
                x = i as f32 * 0.5
            ));
        }
        let roots: Vec<String> = (0..nodes.len()).map(|i| i.to_string()).collect();
        format!(
            r#"{{
  "asset": {{"version": "2.0"}},
  "extensionsUsed": ["KHR_lights_punctual"],
  "extensions": {{"KHR_lights_punctual": {{"lights": [{lights}]}}}},
  "scene": 0,
  "scenes": [{{"nodes": [{roots}]}}],
  "nodes": [{nodes}],
  "cameras": [{{"type": "perspective", "perspective": {{"yfov": 0.9, "znear": 0.05, "zfar": 100}}}}],
  "materials": [{{"pbrMetallicRoughness": {{"baseColorFactor": [0.8, 0.8, 0.8, 1]}}}}],
  "meshes": [{{"name": "floor", "primitives": [{{"attributes": {{"POSITION": 0}}, "indices": 1, "material": 0}}]}}],
  "accessors": [
    {{"bufferView": 0, "componentType": 5126, "count": {vcount}, "type": "VEC3", "min": [{lo0:?}, {lo1:?}, {lo2:?}], "max": [{hi0:?}, {hi1:?}, {hi2:?}]}},
    {{"bufferView": 1, "componentType": 5125, "count": {icount}, "type": "SCALAR"}}
  ],
  "bufferViews": [
    {{"buffer": 0, "byteOffset": 0, "byteLength": {pos_len}}},
    {{"buffer": 0, "byteOffset": {pos_len}, "byteLength": {idx_len}}}
  ],
  "buffers": [{{"byteLength": {blen}, "uri": "data:application/octet-stream;base64,{b64}"}}]
}}"#,
            lights = lights.join(","),
            roots = roots.join(","),
            nodes = nodes.join(",\n    "),
            vcount = self.positions.len(),
            icount = self.indices.len(),
            lo0 = lo[0],
            lo1 = lo[1],
            lo2 = lo[2],
            hi0 = hi[0],
            hi1 = hi[1],
            hi2 = hi[2],
            blen = bin.len(),
            b64 = base64(&bin),
        )
    }

    /// Writes the scene as `dir/name` (a .gltf) and returns its path.
    fn write(&self, dir: &Path, name: &str) -> PathBuf {
        let p = dir.join(name);
        std::fs::write(&p, self.json()).unwrap();
        p
    }
}

/// Runs `render`, `reference` and `bake` on `scene` with outputs in a fresh
/// empty directory and checks each fails cleanly (exit 2, naming the scene
/// file and `what`, no panic, nothing written).
fn every_command_rejects(scene: &Path, what: &[&str]) {
    let name = file_name(scene);
    let mut failures = Vec::new();
    for cmd in ["render", "reference", "bake"] {
        let out = tempfile::tempdir().unwrap();
        let r = match cmd {
            "render" => render(scene, &out.path().join("frame.exr"), &[]),
            "reference" => gibake!(
                "reference",
                scene,
                "--spp",
                "1",
                "--width",
                "8",
                "--height",
                "8",
                "-o",
                out.path().join("ref.exr")
            ),
            _ => {
                let mut c = common::gibake();
                c.arg("bake")
                    .arg(scene)
                    .arg("-o")
                    .arg(out.path().join("out.gibake"))
                    .args(TINY_BAKE);
                run_command(c)
            }
        };
        let mut needles = vec![name.as_str()];
        needles.extend_from_slice(what);
        if let Err(e) = check_bad(&r, &needles) {
            failures.push(format!("[{cmd}] {e}"));
        }
        let left: Vec<_> = std::fs::read_dir(out.path())
            .unwrap()
            .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
            .collect();
        if !left.is_empty() {
            failures.push(format!("[{cmd}] files left behind: {left:?}\n{r}"));
        }
    }
    assert!(failures.is_empty(), "{}", failures.join("\n\n"));
}

/// `gibake render SCENE [tiny settings] -o OUT` with extra arguments.
fn render(scene: &Path, out: &Path, extra: &[&str]) -> Run {
    let mut c = common::gibake();
    c.arg("render")
        .arg(scene)
        .args(TINY_RENDER)
        .args(extra)
        .arg("-o")
        .arg(out);
    run_command(c)
}

// ---------------------------------------------------------------------------
// Bad scenes.

#[test]
fn scene_file_missing() {
    let dir = tempfile::tempdir().unwrap();
    let scene = dir.path().join("no_such_scene.glb");
    let out = tempfile::tempdir().unwrap();
    let r = render(&scene, &out.path().join("frame.exr"), &[]);
    assert_bad(&r, &["no_such_scene.glb", "cannot read"]);
    assert_empty(out.path(), &r);
    every_command_rejects(&scene, &["cannot read"]);
}

#[test]
fn scene_not_gltf_random_bytes() {
    let dir = tempfile::tempdir().unwrap();
    let mut x: u64 = 0x9e37_79b9_7f4a_7c15;
    let bytes: Vec<u8> = (0..4096)
        .map(|_| {
            x ^= x << 13;
            x ^= x >> 7;
            x ^= x << 17;
            (x >> 24) as u8
        })
        .collect();
    assert_ne!(&bytes[..4], b"glTF");
    let scene = dir.path().join("noise.glb");
    std::fs::write(&scene, &bytes).unwrap();
    every_command_rejects(&scene, &["glTF"]);
}

#[test]
fn scene_truncated_glb() {
    let dir = tempfile::tempdir().unwrap();
    let full = std::fs::read(common::data("corner_bunny.glb")).unwrap();
    let scene = dir.path().join("half_bunny.glb");
    std::fs::write(&scene, &full[..full.len() / 2]).unwrap();
    every_command_rejects(&scene, &["truncated"]);
}

#[test]
fn scene_nan_vertex() {
    let dir = tempfile::tempdir().unwrap();
    let mut t = Tiny::default();
    t.positions[2] = [1.0, f32::NAN, 1.0];
    let scene = t.write(dir.path(), "nan_vertex.gltf");
    every_command_rejects(&scene, &["not finite", "POSITION"]);
}

#[test]
fn scene_huge_vertex_is_infinite_in_f32() {
    let dir = tempfile::tempdir().unwrap();
    let mut t = Tiny::default();
    // 1e39 does not fit in an f32: stored as +inf in the binary buffer.
    t.positions[1] = [1e39f64 as f32, 0.0, -1.0];
    assert!(t.positions[1][0].is_infinite());
    let scene = t.write(dir.path(), "inf_vertex.gltf");
    every_command_rejects(&scene, &["not finite"]);
}

#[test]
fn scene_index_out_of_range() {
    let dir = tempfile::tempdir().unwrap();
    let t = Tiny {
        indices: vec![0, 3, 2, 0, 2, 7],
        ..Tiny::default()
    };
    let scene = t.write(dir.path(), "bad_index.gltf");
    every_command_rejects(&scene, &["index 7", "out of range"]);
}

/// Every command takes a scene whose only light is a point light: it is
/// the primary light (cube-face maps), not an error.
#[test]
fn scene_with_only_a_point_light_is_taken_by_every_command() {
    let dir = tempfile::tempdir().unwrap();
    let t = Tiny {
        lights: vec![("bulb", "point")],
        ..Tiny::default()
    };
    let scene = t.write(dir.path(), "point_only.gltf");
    let out = tempfile::tempdir().unwrap();
    let frame = out.path().join("frame.exr");
    let r = render(&scene, &frame, &[]);
    assert_eq!(r.code, Some(0), "{r}");
    assert!(frame.is_file(), "{r}");
    let mut c = common::gibake();
    c.arg("bake")
        .arg(&scene)
        .arg("-o")
        .arg(out.path().join("out.gibake"))
        .args(TINY_BAKE);
    let r = run_command(c);
    assert_eq!(r.code, Some(0), "{r}");
}

#[test]
fn scene_without_light() {
    let dir = tempfile::tempdir().unwrap();
    let t = Tiny {
        lights: vec![],
        ..Tiny::default()
    };
    let scene = t.write(dir.path(), "dark.gltf");
    every_command_rejects(&scene, &["light"]);
}

/// Two spots: both are primary lights by default; `--light NAME` picks
/// one; an unknown name is an error naming the available lights.
#[test]
fn scene_with_two_spots_lights_both_and_light_picks_one() {
    let dir = tempfile::tempdir().unwrap();
    let t = Tiny {
        lights: vec![("left_spot", "spot"), ("right_spot", "spot")],
        ..Tiny::default()
    };
    let scene = t.write(dir.path(), "two_spots.gltf");
    let out = tempfile::tempdir().unwrap();
    let both = out.path().join("both.exr");
    let r = render(&scene, &both, &[]);
    assert_eq!(r.code, Some(0), "{r}");
    assert!(!r.stderr.contains("ignoring"), "{r}");
    assert!(both.is_file(), "{r}");
    let frame = out.path().join("frame.exr");
    let r = render(&scene, &frame, &["--light", "right_spot"]);
    assert_eq!(r.code, Some(0), "{r}");
    assert!(
        r.stderr.contains("left_spot"),
        "the other light is named: {r}"
    );
    assert!(frame.is_file(), "{r}");
    let frame2 = out.path().join("frame2.exr");
    let r = render(&scene, &frame2, &["--light", "nope"]);
    assert_bad(&r, &["two_spots.gltf", "nope", "left_spot", "right_spot"]);
    assert!(!frame2.exists(), "{r}");
}

/// More lights than `--max-lights` is one clear error,
/// exit 2, no output; a limit of 0 is a usage error.
#[test]
fn reference_over_max_lights() {
    let out = tempfile::tempdir().unwrap();
    let exr = out.path().join("ref.exr");
    let r = gibake!(
        "reference",
        common::data("lamps.glb"),
        "--max-lights",
        "2",
        "--spp",
        "1",
        "--width",
        "8",
        "--height",
        "8",
        "-o",
        &exr
    );
    assert_bad(&r, &["lamps.glb", "3 lights", "--max-lights"]);
    assert_empty(out.path(), &r);
    let r = gibake!(
        "reference",
        common::data("lamps.glb"),
        "--max-lights",
        "0",
        "-o",
        &exr
    );
    assert_bad(&r, &["--max-lights"]);
    assert_empty(out.path(), &r);
}

#[test]
fn scene_no_static_triangles() {
    let dir = tempfile::tempdir().unwrap();
    let t = Tiny {
        dynamic_floor: true,
        ..Tiny::default()
    };
    let scene = t.write(dir.path(), "all_dynamic.gltf");
    every_command_rejects(&scene, &["no static triangles"]);
}

#[test]
fn render_and_reference_without_camera() {
    let dir = tempfile::tempdir().unwrap();
    let t = Tiny {
        camera: false,
        ..Tiny::default()
    };
    let scene = t.write(dir.path(), "no_camera.gltf");
    let out = tempfile::tempdir().unwrap();
    let r = render(&scene, &out.path().join("frame.exr"), &[]);
    assert_bad(&r, &["no_camera.gltf", "camera"]);
    assert_empty(out.path(), &r);
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
        out.path().join("ref.exr")
    );
    assert_bad(&r, &["no_camera.gltf", "camera"]);
    assert_empty(out.path(), &r);
}

#[test]
fn tiny_scene_itself_is_valid() {
    // Guards the tests above: the unmodified tiny scene renders fine, so
    // each failure above is caused by the one thing changed.
    let dir = tempfile::tempdir().unwrap();
    let scene = Tiny::default().write(dir.path(), "ok.gltf");
    let frame = dir.path().join("ok.exr");
    let r = render(&scene, &frame, &[]);
    assert_eq!(r.code, Some(0), "{r}");
    let img = gibake_image::Image::read_exr(&frame).unwrap();
    assert!(img.all_finite());
    assert!(
        img.mean().max_element() > 0.0,
        "the tiny scene renders black\n{r}"
    );
}

// ---------------------------------------------------------------------------
// Bad flags.

#[test]
fn unknown_subcommand() {
    let r = gibake!("frobnicate");
    assert_bad(&r, &["frobnicate", "unrecognized subcommand"]);
}

#[test]
fn no_arguments_is_usage_error() {
    let r = gibake!();
    assert_bad(&r, &["usage"]);
}

#[test]
fn unknown_flag() {
    let out = tempfile::tempdir().unwrap();
    let r = gibake!(
        "render",
        common::data("corner_bunny.glb"),
        "--bogus-flag",
        "-o",
        out.path().join("f.exr")
    );
    assert_bad(&r, &["--bogus-flag", "unexpected argument"]);
    assert_empty(out.path(), &r);
}

/// A render of the bundled scene with `extra` flags must fail with exit 2,
/// mention every one of `needles`, and write nothing.
fn render_flag_rejected(extra: &[&str], needles: &[&str]) {
    let out = tempfile::tempdir().unwrap();
    let mut c = common::gibake();
    c.arg("render")
        .arg(common::data("corner_bunny.glb"))
        .args(extra)
        .arg("-o")
        .arg(out.path().join("f.exr"));
    let r = run_command(c);
    assert_bad(&r, needles);
    assert_empty(out.path(), &r);
}

#[test]
fn render_width_zero() {
    // The message names the flag and says it is out of range.
    render_flag_rejected(
        &["--mode", "direct", "--width", "0", "--height", "16"],
        &["--width 0", "out of range"],
    );
}

#[test]
fn render_height_zero() {
    render_flag_rejected(
        &["--mode", "direct", "--width", "16", "--height", "0"],
        &["--height 0", "out of range"],
    );
}

#[test]
fn render_width_not_a_number() {
    render_flag_rejected(
        &["--mode", "direct", "--width", "abc"],
        &["--width", "abc", "invalid value"],
    );
}

#[test]
fn render_time_nan() {
    render_flag_rejected(
        &[
            "--mode", "direct", "--width", "16", "--height", "16", "--time", "nan",
        ],
        &["--time", "finite"],
    );
}

#[test]
fn render_time_infinite() {
    render_flag_rejected(
        &[
            "--mode", "direct", "--width", "16", "--height", "16", "--time", "inf",
        ],
        &["--time", "finite"],
    );
}

#[test]
fn render_frames_zero() {
    render_flag_rejected(
        &[
            "--mode", "direct", "--width", "16", "--height", "16", "--frames", "0",
        ],
        &["--frames", "at least 1"],
    );
}

#[test]
fn render_fps_negative() {
    render_flag_rejected(
        &[
            "--mode", "direct", "--width", "16", "--height", "16", "--fps=-1",
        ],
        &["--fps", "positive"],
    );
    // Without `=`, clap takes `-1` for a flag: still a usage error.
    render_flag_rejected(
        &[
            "--mode", "direct", "--width", "16", "--height", "16", "--fps", "-1",
        ],
        &["-1"],
    );
}

#[test]
fn render_fps_zero() {
    render_flag_rejected(
        &[
            "--mode", "direct", "--width", "16", "--height", "16", "--fps", "0",
        ],
        &["--fps", "positive"],
    );
}

#[test]
fn render_ssaa_zero() {
    render_flag_rejected(
        &[
            "--mode", "direct", "--width", "16", "--height", "16", "--ssaa", "0",
        ],
        &["--ssaa", "1..=8"],
    );
}

#[test]
fn render_unknown_mode() {
    render_flag_rejected(
        &["--mode", "fancy", "--width", "16", "--height", "16"],
        &["--mode", "fancy"],
    );
}

#[test]
fn render_without_output_flag() {
    let r = gibake!(
        "render",
        common::data("corner_bunny.glb"),
        "--mode",
        "direct"
    );
    assert_bad(&r, &["--output"]);
}

#[test]
fn reference_spp_zero() {
    let out = tempfile::tempdir().unwrap();
    let r = gibake!(
        "reference",
        common::data("corner_bunny.glb"),
        "--spp",
        "0",
        "--width",
        "8",
        "--height",
        "8",
        "-o",
        out.path().join("ref.exr")
    );
    assert_bad(&r, &["--spp", "at least 1"]);
    assert_empty(out.path(), &r);
}

/// `reference --bounces`: more than the cap, not a number, or with
/// `--direct-only` (which is `--bounces 0`): exit 2, the flag named.
#[test]
fn reference_bad_bounces() {
    let out = tempfile::tempdir().unwrap();
    for (value, extra, needles) in [
        ("1025", None, &["--bounces", "at most 1024"][..]),
        (
            "two",
            None,
            &["--bounces", "not a number of bounces", "all"][..],
        ),
        ("-1", None, &["--bounces"][..]),
        (
            "3",
            Some("--direct-only"),
            &["--bounces", "--direct-only"][..],
        ),
    ] {
        let mut c = common::gibake();
        c.arg("reference")
            .arg(common::data("corner_bunny.glb"))
            .args(["--spp", "1", "--width", "8", "--height", "8"])
            .arg(format!("--bounces={value}"))
            .args(extra)
            .arg("-o")
            .arg(out.path().join("ref.exr"));
        let r = run_command(c);
        assert_bad(&r, needles);
        assert_empty(out.path(), &r);
    }
}

#[test]
fn reference_width_zero() {
    let out = tempfile::tempdir().unwrap();
    let r = gibake!(
        "reference",
        common::data("corner_bunny.glb"),
        "--spp",
        "1",
        "--width",
        "0",
        "--height",
        "8",
        "-o",
        out.path().join("ref.exr")
    );
    assert_bad(&r, &["out of range"]);
    assert_empty(out.path(), &r);
}

#[test]
fn bake_vpls_and_threshold_conflict() {
    let out = tempfile::tempdir().unwrap();
    let r = gibake!(
        "bake",
        common::data("corner_bunny.glb"),
        "--vpls",
        "5",
        "--threshold",
        "0.1",
        "-o",
        out.path().join("x.gibake")
    );
    assert_bad(&r, &["--vpls", "--threshold", "cannot be used with"]);
    assert_empty(out.path(), &r);
}

#[test]
fn diff_unknown_tolerance_preset() {
    let out = tempfile::tempdir().unwrap();
    let r = gibake!(
        "diff",
        out.path().join("a.gibake"),
        out.path().join("b.gibake"),
        "--tolerance",
        "roughly"
    );
    assert_bad(&r, &["--tolerance", "roughly"]);
}

// ---------------------------------------------------------------------------
// Output directory that does not exist.

#[test]
fn render_output_dir_missing() {
    let out = tempfile::tempdir().unwrap();
    let target = out.path().join("missing_dir").join("frame.exr");
    let r = render(&common::data("corner_bunny.glb"), &target, &[]);
    assert_bad(&r, &["missing_dir", "does not exist"]);
    assert_empty(out.path(), &r);
}

#[test]
fn reference_output_dir_missing() {
    let out = tempfile::tempdir().unwrap();
    let target = out.path().join("missing_dir").join("ref.exr");
    let r = gibake!(
        "reference",
        common::data("corner_bunny.glb"),
        "--spp",
        "1",
        "--width",
        "8",
        "--height",
        "8",
        "-o",
        &target
    );
    assert_bad(&r, &["missing_dir", "does not exist"]);
    assert_empty(out.path(), &r);
}

#[test]
fn bake_output_dir_missing() {
    let out = tempfile::tempdir().unwrap();
    let target = out.path().join("missing_dir").join("out.gibake");
    let mut c = common::gibake();
    c.arg("bake")
        .arg(common::data("corner_bunny.glb"))
        .arg("-o")
        .arg(&target)
        .args(TINY_BAKE);
    let r = run_command(c);
    assert_bad(&r, &["missing_dir", "does not exist"]);
    assert_empty(out.path(), &r);
}

#[test]
fn render_stats_dir_missing_writes_no_stats() {
    // The frame may be written, but the stats path is bad: exit 2 naming it.
    let out = tempfile::tempdir().unwrap();
    let stats = out.path().join("missing_dir").join("stats.json");
    let r = render(
        &common::data("corner_bunny.glb"),
        &out.path().join("frame.exr"),
        &["--stats", stats.to_str().unwrap()],
    );
    assert_bad(&r, &["stats.json"]);
    assert!(!stats.exists());
}

// ---------------------------------------------------------------------------
// Baked assets: inspect / diff of missing or damaged assets.

#[test]
fn inspect_missing_dir() {
    let out = tempfile::tempdir().unwrap();
    let asset = out.path().join("ghost.gibake");
    let r = gibake!("inspect", &asset);
    assert_bad(&r, &["ghost.gibake"]);
    let err = r.stderr.to_lowercase();
    assert!(
        ["no such file", "does not exist", "not found", "cannot"]
            .iter()
            .any(|k| err.contains(k)),
        "no reason given\n{r}"
    );
    assert!(!asset.exists());
}

#[test]
fn inspect_dir_without_manifest() {
    let out = tempfile::tempdir().unwrap();
    let asset = out.path().join("empty.gibake");
    std::fs::create_dir(&asset).unwrap();
    let r = gibake!("inspect", &asset);
    assert_bad(&r, &["empty.gibake", "manifest.bin"]);
    let r = gibake!("inspect", &asset, "--json");
    assert_bad(&r, &["empty.gibake", "manifest.bin"]);
}

#[test]
fn inspect_a_file_not_a_dir() {
    let out = tempfile::tempdir().unwrap();
    let asset = out.path().join("flat.gibake");
    std::fs::write(&asset, b"not a directory").unwrap();
    let r = gibake!("inspect", &asset);
    assert_bad(&r, &["flat.gibake"]);
}

#[test]
fn diff_missing_asset() {
    let out = tempfile::tempdir().unwrap();
    let r = gibake!(
        "diff",
        out.path().join("one.gibake"),
        out.path().join("two.gibake")
    );
    assert_bad(&r, &["one.gibake"]);
}

/// Bakes the bundled corner scene with tiny settings into `dir/name`.
fn bake_tiny(dir: &Path, name: &str) -> PathBuf {
    let asset = dir.join(name);
    let mut c = common::gibake();
    c.arg("bake")
        .arg(common::data("corner_bunny.glb"))
        .arg("-o")
        .arg(&asset)
        .args(TINY_BAKE);
    let r = run_command(c);
    assert_eq!(r.code, Some(0), "the bake needed by this test failed\n{r}");
    assert!(asset.join("manifest.bin").is_file(), "{r}");
    asset
}

fn copy_dir(from: &Path, to: &Path) {
    std::fs::create_dir(to).unwrap();
    for e in std::fs::read_dir(from).unwrap() {
        let e = e.unwrap();
        assert!(
            e.file_type().unwrap().is_file(),
            "unexpected non-file {:?} in the asset",
            e.path()
        );
        std::fs::copy(e.path(), to.join(e.file_name())).unwrap();
    }
}

fn asset_files(asset: &Path) -> Vec<String> {
    let mut v: Vec<String> = std::fs::read_dir(asset)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    v.sort();
    v
}

#[test]
fn damaged_asset_files_are_named() {
    let work = tempfile::tempdir().unwrap();
    let good = bake_tiny(work.path(), "good.gibake");
    let files = asset_files(&good);
    for must in ["manifest.bin", "vpls.bin", "primary_depth.exr"] {
        assert!(
            files.iter().any(|f| f == must),
            "the asset has no {must}: {files:?}"
        );
    }
    // The good asset inspects fine (guards the checks below).
    let r = gibake!("inspect", &good);
    assert_eq!(r.code, Some(0), "{r}");

    let mut failures = Vec::new();
    let mut n = 0;
    for file in &files {
        for damage in ["truncated", "bit-flipped", "emptied", "deleted"] {
            n += 1;
            let bad = work.path().join(format!("bad{n}.gibake"));
            copy_dir(&good, &bad);
            let p = bad.join(file);
            let mut bytes = std::fs::read(&p).unwrap();
            match damage {
                "truncated" => bytes.truncate(bytes.len() / 2),
                "bit-flipped" => {
                    let i = bytes.len() / 2;
                    bytes[i] ^= 0x10;
                }
                "emptied" => bytes.clear(),
                _ => {}
            }
            if damage == "deleted" {
                std::fs::remove_file(&p).unwrap();
            } else {
                std::fs::write(&p, &bytes).unwrap();
            }
            let before = asset_files(&bad);
            for json in [false, true] {
                let r = if json {
                    gibake!("inspect", &bad, "--json")
                } else {
                    gibake!("inspect", &bad)
                };
                if let Err(e) = check_bad(&r, &[file]) {
                    failures.push(format!("{file} {damage}: {e}"));
                }
                if json && !r.stdout.trim().is_empty() {
                    failures.push(format!(
                        "{file} {damage}: inspect --json printed to stdout on error\n{r}"
                    ));
                }
            }
            for (a, b) in [(&bad, &good), (&good, &bad)] {
                let r = gibake!("diff", a, b);
                if let Err(e) = check_bad(&r, &[file]) {
                    failures.push(format!("{file} {damage} (diff): {e}"));
                }
            }
            // Reading never changes the asset.
            assert_eq!(
                asset_files(&bad),
                before,
                "{file} {damage}: inspect/diff changed the asset's files"
            );
        }
    }
    assert!(
        failures.is_empty(),
        "{} failure(s):\n\n{}",
        failures.len(),
        failures.join("\n\n")
    );
}

#[test]
fn bake_refuses_to_replace_a_non_asset_dir() {
    let work = tempfile::tempdir().unwrap();
    let target = work.path().join("precious.gibake");
    std::fs::create_dir(&target).unwrap();
    std::fs::write(target.join("keep.txt"), b"my data").unwrap();
    let mut c = common::gibake();
    c.arg("bake")
        .arg(common::data("corner_bunny.glb"))
        .arg("-o")
        .arg(&target)
        .args(TINY_BAKE);
    let r = run_command(c);
    assert_bad(&r, &["precious.gibake"]);
    assert_eq!(
        std::fs::read(target.join("keep.txt")).unwrap(),
        b"my data",
        "{r}"
    );
    assert_eq!(asset_files(&target), vec!["keep.txt".to_string()], "{r}");
    // No temporary directories left next to it.
    let left: Vec<_> = std::fs::read_dir(work.path())
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    assert_eq!(left, vec!["precious.gibake".to_string()], "{r}");
}

#[test]
fn diff_images_dir_with_damaged_asset_writes_nothing() {
    let work = tempfile::tempdir().unwrap();
    let good = bake_tiny(work.path(), "good.gibake");
    let bad = work.path().join("bad.gibake");
    copy_dir(&good, &bad);
    let p = bad.join("vpls.bin");
    let mut bytes = std::fs::read(&p).unwrap();
    bytes.truncate(bytes.len() / 2);
    std::fs::write(&p, bytes).unwrap();
    let images = work.path().join("diff_images");
    let r = gibake!("diff", &good, &bad, "--images", &images);
    assert_bad(&r, &["vpls.bin"]);
    assert!(
        !images.exists(),
        "--images directory created although the diff failed\n{r}"
    );
}

/// An asset baked with every light, rendered with `--light spot_lamp` (the
/// scene then has one light): one clear message naming the bake's flags
/// (none) and the ones given, exit 2, nothing written; an asset of format
/// 4.3 (no flags recorded) is refused by its light count, naming both
/// light sets and the flag.
#[test]
fn render_with_other_lights_than_the_bake_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    let asset = dir.path().join("lamps.gibake");
    let r = gibake!(
        "bake",
        common::data("lamps.glb"),
        "--rsm-size",
        "32",
        "--vpl-map-size",
        "8",
        "--shadow-map-size",
        "64",
        "--vpls",
        "8",
        // The first bounce alone: rewritten below as a 4.3 asset, which
        // had no later bounces.
        "--bounces",
        "1",
        "-o",
        &asset
    );
    assert_eq!(r.code, Some(0), "{}", r.stderr);
    let out = tempfile::tempdir().unwrap();
    let png = out.path().join("f.png");
    let r = gibake!(
        "render",
        common::data("lamps.glb"),
        "--light",
        "spot_lamp",
        "--bake",
        &asset,
        "--width",
        "8",
        "--height",
        "8",
        "-o",
        &png
    );
    assert_bad(
        &r,
        &[
            "lamps.gibake was baked with none of --sun, --dynamic, --light",
            "but `render` was given --light spot_lamp (--light differs)",
        ],
    );
    assert_empty(out.path(), &r);
    // The same asset as format 4.3 wrote it: nothing recorded to compare.
    let mut m = gibake_asset::load_manifest(&asset).unwrap();
    m.scene_options = None;
    m.swept_bounds = None;
    std::fs::write(
        asset.join(gibake_asset::FILE_MANIFEST),
        gibake_asset::testing::manifest_bytes_4_3(&m).unwrap(),
    )
    .unwrap();
    let r = gibake!(
        "render",
        common::data("lamps.glb"),
        "--light",
        "spot_lamp",
        "--bake",
        &asset,
        "--width",
        "8",
        "--height",
        "8",
        "-o",
        &png
    );
    assert_bad(
        &r,
        &["3 light(s)", "point_lamp", "loaded with 1", "--light"],
    );
    assert_empty(out.path(), &r);
}
