//! `gibake view`: its window path under a virtual X server (Xvfb, started
//! here) with lavapipe, compared with `gibake render` of the same view;
//! the missing-display error; `--gpu-report`. Xvfb missing is a failure
//! that says what to install, never a skip.

use crate::common;

use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::sync::OnceLock;
use std::time::{Duration, Instant};

/// A tiny bake of data/occluded.glb, shared by the tests of this file.
fn asset() -> &'static Path {
    static DIR: OnceLock<(tempfile::TempDir, PathBuf)> = OnceLock::new();
    &DIR.get_or_init(|| {
        let dir = tempfile::tempdir().unwrap();
        let out = dir.path().join("occluded.gibake");
        let mut c = common::gibake();
        c.arg("bake")
            .arg(common::data("occluded.glb"))
            .arg("-o")
            .arg(&out)
            .args(common::TINY_BAKE);
        let r = common::run_command(c);
        assert_eq!(r.code, Some(0), "{r}");
        (dir, out)
    })
    .1
}

/// A running Xvfb, killed on drop.
struct Xvfb {
    child: Child,
    display: String,
}

impl Drop for Xvfb {
    fn drop(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

/// Starts Xvfb on the first free display number from 90 on.
fn xvfb() -> Xvfb {
    for n in 90..140 {
        if Path::new(&format!("/tmp/.X{n}-lock")).exists()
            || Path::new(&format!("/tmp/.X11-unix/X{n}")).exists()
        {
            continue;
        }
        let child = Command::new("Xvfb")
            .arg(format!(":{n}"))
            .args(["-screen", "0", "320x240x24", "-nolisten", "tcp"])
            .stdout(Stdio::null())
            .stderr(Stdio::null())
            .spawn();
        let mut child = match child {
            Ok(c) => c,
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => panic!(
                "tests/view.rs needs Xvfb (a virtual X server) to open gibake view's window: \
                 `apt-get install xvfb` or `bash scripts/ensure-deps.sh --xvfb`"
            ),
            Err(e) => panic!("cannot start Xvfb: {e}"),
        };
        let socket = PathBuf::from(format!("/tmp/.X11-unix/X{n}"));
        let start = Instant::now();
        while start.elapsed() < Duration::from_secs(10) {
            if socket.exists() {
                return Xvfb {
                    child,
                    display: format!(":{n}"),
                };
            }
            if let Ok(Some(_)) = child.try_wait() {
                break; // taken meanwhile: the next number
            }
            std::thread::sleep(Duration::from_millis(20));
        }
        let _ = child.kill();
        let _ = child.wait();
    }
    panic!("Xvfb did not start on any display from :90 to :139");
}

/// `gibake` without any display in its environment.
fn no_display(mut c: Command) -> Command {
    c.env_remove("DISPLAY")
        .env_remove("WAYLAND_DISPLAY")
        .env_remove("WAYLAND_SOCKET");
    c
}

/// The view both commands render (small, fixed exposure, no
/// supersampling or interleaving, a time inside the animation).
const VIEW: [&str; 12] = [
    "--width",
    "96",
    "--height",
    "64",
    "--interleave",
    "1",
    "--shadow-map-size",
    "256",
    "--time",
    "0.5",
    "--exposure",
    "2",
];

fn png_rgb(path: &Path) -> (u32, u32, Vec<u8>) {
    let d = png::Decoder::new(std::io::BufReader::new(std::fs::File::open(path).unwrap()));
    let mut r = d.read_info().unwrap();
    let mut buf = vec![0; r.output_buffer_size().unwrap()];
    let info = r.next_frame(&mut buf).unwrap();
    assert_eq!(info.color_type, png::ColorType::Rgb, "{}", path.display());
    buf.truncate(info.buffer_size());
    (info.width, info.height, buf)
}

/// `gibake view --frames 3 --screenshot` in a real window equals `gibake
/// render` of frame 2 of the same sequence: radiance (EXR) within a
/// relative MSE of 1e-6, the PNG within 1/255 per channel, and the pixels
/// the window showed (`--presented`) within 2/255.
#[test]
fn headless_view_in_a_window_matches_render() {
    let asset = asset();
    let x = xvfb();
    let dir = tempfile::tempdir().unwrap();
    let scene = common::data("occluded.glb");
    for ext in ["png", "exr"] {
        let shot = dir.path().join(format!("view.{ext}"));
        let mut c = no_display(common::gibake());
        c.env("DISPLAY", &x.display)
            .arg("view")
            .arg(&scene)
            .arg("--bake")
            .arg(asset)
            .args(VIEW)
            .args(["--frames", "3", "--screenshot"])
            .arg(&shot);
        if ext == "png" {
            c.arg("--presented").arg(dir.path().join("shown.png"));
        }
        let r = common::run_command(c);
        assert_eq!(r.code, Some(0), "{r}");
        assert!(r.stderr.contains("wrote"), "{r}");
        let mut c = common::gibake();
        c.arg("render")
            .arg(&scene)
            .arg("--bake")
            .arg(asset)
            .args(VIEW)
            .args(["--ssaa", "1", "--frames", "3", "-o"])
            .arg(dir.path().join(format!("render#.{ext}")));
        let r = common::run_command(c);
        assert_eq!(r.code, Some(0), "{r}");
    }
    let render = dir.path().join("render2.png");
    let (vw, vh, v) = png_rgb(&dir.path().join("view.png"));
    let (rw, rh, r) = png_rgb(&render);
    assert_eq!((vw, vh), (96, 64));
    assert_eq!((rw, rh), (96, 64));
    let max = v.iter().zip(&r).map(|(a, b)| a.abs_diff(*b)).max().unwrap();
    let lit = v.iter().filter(|c| **c > 16).count();
    eprintln!(
        "PNG: max |view − render| = {max}/255; {lit} of {} channels lit",
        v.len()
    );
    assert!(
        lit > v.len() / 4,
        "the view is mostly black: nothing to compare"
    );
    assert!(max <= 1, "view and render differ by up to {max}/255");
    // What the window showed (the present pass's tone mapping on the GPU)
    // against render's PNG (the same curve on the CPU).
    let (sw, sh, shown) = png_rgb(&dir.path().join("shown.png"));
    assert_eq!((sw, sh), (96, 64), "the window's size");
    let max_shown = shown
        .iter()
        .zip(&r)
        .map(|(a, b)| a.abs_diff(*b))
        .max()
        .unwrap();
    eprintln!("window: max |shown − render| = {max_shown}/255");
    assert!(
        max_shown <= 2,
        "the window showed up to {max_shown}/255 off render's PNG"
    );
    let v = gibake_image::Image::read_exr(&dir.path().join("view.exr")).unwrap();
    let r = gibake_image::Image::read_exr(&dir.path().join("render2.exr")).unwrap();
    let e = gibake_image::rel_mse(&v, &r);
    eprintln!("EXR: relative MSE view vs render = {e:.3e}");
    assert!(e < 1e-6, "relative MSE {e}");
    // A different frame (time 0.5 + 0/30 s) is told apart: the bound can fail.
    let r0 = gibake_image::Image::read_exr(&dir.path().join("render0.exr")).unwrap();
    let e0 = gibake_image::rel_mse(&v, &r0);
    eprintln!("EXR: relative MSE view vs render's frame 0 = {e0:.3e}");
    assert!(
        e0 > 1e-4,
        "frames 0 and 2 look alike ({e0}): the check cannot fail"
    );
}

/// No display: exit 2 and one message naming DISPLAY and WAYLAND_DISPLAY.
#[test]
fn no_display_is_a_clear_error() {
    let mut c = no_display(common::gibake());
    c.arg("view")
        .arg(common::data("occluded.glb"))
        .args(["--mode", "direct", "--frames", "1"]);
    let r = common::run_command(c);
    assert_eq!(r.code, Some(2), "{r}");
    assert!(
        r.stderr.contains("DISPLAY") && r.stderr.contains("WAYLAND_DISPLAY"),
        "{r}"
    );
    assert!(!r.stderr.contains("panicked"), "{r}");
    assert_eq!(r.stderr.trim().lines().count(), 1, "{r}");
}

/// `--gpu-report` needs no display: adapter, the level's limits against
/// the adapter's, memory; exit 0 on an adapter that runs it.
#[test]
fn gpu_report_names_adapter_limits_and_memory() {
    let mut c = no_display(common::gibake());
    c.arg("view")
        .arg(common::data("occluded.glb"))
        .arg("--bake")
        .arg(asset())
        .arg("--gpu-report");
    let r = common::run_command(c);
    assert_eq!(r.code, Some(0), "{r}");
    for want in [
        "adapter: ",
        "backend: ",
        "max_storage_buffers_per_shader_stage: 5 / ",
        "GPU memory: ",
        "can run this level",
    ] {
        assert!(r.stdout.contains(want), "no {want:?} in\n{r}");
    }
}

/// Bad outputs are refused before any window opens: exit 2, one message.
#[test]
fn bad_screenshot_paths_are_refused_before_the_window() {
    let dir = tempfile::tempdir().unwrap();
    let shot = dir.path().join("a.png");
    let cases: [(&[&str], &str); 3] = [
        (&["--screenshot", "a.txt"], "--screenshot"),
        (&["--presented", "a.exr"], "--presented"),
        (
            &["--screenshot", "a.png", "--presented", "a.png"],
            "--presented",
        ),
    ];
    for (args, flag) in cases {
        let mut c = no_display(common::gibake());
        c.current_dir(dir.path())
            .arg("view")
            .arg(common::data("occluded.glb"))
            .args(["--mode", "direct", "--frames", "1"])
            .args(args);
        let r = common::run_command(c);
        assert_eq!(r.code, Some(2), "{r}");
        assert!(
            r.stderr.contains(flag) && !r.stderr.contains("DISPLAY"),
            "{r}"
        );
        assert!(!r.stderr.contains("panicked"), "{r}");
    }
    assert!(!shot.exists());
}
