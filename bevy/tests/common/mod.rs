//! The headless harness: the example's level in a temporary asset root,
//! baked and rendered with the `gibake` binary of the main workspace, and
//! a Bevy app on lavapipe with no window, rendering into an `Rgba16Float`
//! image read back every frame.
//!
//! The tests fail (never skip) when something they need is missing: the
//! `gibake` binary (`GIBAKE`, else the main workspace's
//! `target/release/gibake`: build it with `cargo build --release -p
//! gibake`), or a GPU adapter (`mesa-vulkan-drivers` gives lavapipe).

#![allow(dead_code)]

use std::path::{Path, PathBuf};
use std::process::Command;
use std::sync::{Arc, Mutex, MutexGuard};
use std::time::{Duration, Instant};

use bevy::camera::{Exposure, RenderTarget};
use bevy::core_pipeline::tonemapping::{DebandDither, Tonemapping};
use bevy::light::GlobalAmbientLight;
use bevy::prelude::*;
use bevy::render::gpu_readback::{Readback, ReadbackComplete};
use bevy::render::render_resource::{TextureFormat, TextureUsages};
use bevy::window::ExitCondition;
use gibake_bevy::{GibakeCamera, GibakeLevel, GibakePlugin, GibakeSettings, GibakeShared};

/// The level of the example (`data/levels/living_room`) and its bake's
/// scene flags (levels.json: the sun, the lamp that moves).
pub const LEVEL: &str = "living_room.glb";
pub const BAKE_FLAGS: &[&str] = &["--sun", "173.1,60", "--dynamic", "Cylinder"];
/// The sun's irradiance (W/m²) of the first bake.
pub const SUN_IRRADIANCE: &str = "3";
/// levels.json's camera for it.
pub const EYE: [f32; 3] = [-2.93, 2.21, -1.89];
pub const TARGET: [f32; 3] = [-0.1, 1.98, 2.23];
pub const FOV_DEG: f32 = 75.0;
/// Small frames: lavapipe shades on the CPU. Rows of 8-byte texels are
/// 256-byte aligned at widths that are multiples of 32.
pub const W: u32 = 160;
pub const H: u32 = 96;

/// One GPU test at a time: each Bevy app and gibake render is already
/// using every core.
pub fn serial() -> MutexGuard<'static, ()> {
    static LOCK: Mutex<()> = Mutex::new(());
    LOCK.lock().unwrap_or_else(|e| e.into_inner())
}

/// The `gibake` binary.
pub fn gibake() -> PathBuf {
    if let Some(p) = std::env::var_os("GIBAKE") {
        return PathBuf::from(p);
    }
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("..");
    let mut candidates = vec![root.join("target/release/gibake")];
    if let Some(t) = std::env::var_os("CARGO_TARGET_DIR") {
        candidates.push(PathBuf::from(t).join("release/gibake"));
    }
    candidates
        .into_iter()
        .find(|p| p.is_file())
        .unwrap_or_else(|| {
            panic!(
                "these tests compare with the gibake binary: build it in the main workspace \
                 (`cargo build --release -p gibake`) or set GIBAKE to it"
            )
        })
}

/// Runs `gibake ARGS` in `dir`; panics with its output on failure.
pub fn run_gibake(dir: &Path, args: &[&str]) {
    let out = Command::new(gibake())
        .current_dir(dir)
        .args(args)
        .output()
        .expect("run gibake");
    assert!(
        out.status.success(),
        "gibake {args:?} failed ({}):\n{}{}",
        out.status,
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr)
    );
}

/// A temporary asset root holding the level (a copy) and its bake.
pub struct Root {
    pub dir: PathBuf,
}

impl Root {
    /// The level baked with [`BAKE_FLAGS`], a sun of [`SUN_IRRADIANCE`].
    pub fn new(name: &str) -> Root {
        let dir = std::env::temp_dir().join(format!("gibake-bevy-{name}-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(&dir).unwrap();
        let level = Path::new(env!("CARGO_MANIFEST_DIR")).join("../data/levels/living_room");
        std::fs::copy(level.join(LEVEL), dir.join(LEVEL)).unwrap();
        let root = Root { dir };
        root.bake(SUN_IRRADIANCE);
        root
    }

    /// (Re-)bakes the level into `living_room.gibake` with a sun of
    /// `sun_irradiance` W/m².
    pub fn bake(&self, sun_irradiance: &str) {
        let mut args = vec!["bake", LEVEL];
        args.extend_from_slice(BAKE_FLAGS);
        args.extend_from_slice(&["--sun-irradiance", sun_irradiance]);
        args.extend_from_slice(&["--force", "-o", "living_room.gibake"]);
        run_gibake(&self.dir, &args);
    }

    /// `gibake render` of the test camera at time 0, read back: one
    /// sample per pixel (`--ssaa 1`), every VPL in every pixel
    /// (`--interleave 1`), as the plugin shades this size.
    pub fn render(&self, mode: &str, out: &str) -> Vec<[f32; 3]> {
        let look = format!(
            "{},{},{},{},{},{},{}",
            EYE[0], EYE[1], EYE[2], TARGET[0], TARGET[1], TARGET[2], FOV_DEG
        );
        let (w, h) = (W.to_string(), H.to_string());
        run_gibake(
            &self.dir,
            &[
                "render",
                LEVEL,
                "--bake",
                "living_room.gibake",
                "--mode",
                mode,
                "--look-at",
                &look,
                "--width",
                &w,
                "--height",
                &h,
                "--interleave",
                "1",
                "--ssaa",
                "1",
                "--time",
                "0",
                "-o",
                out,
            ],
        );
        let img = gibake_image::Image::read_exr(&self.dir.join(out)).expect("read the EXR");
        assert_eq!((img.width, img.height), (W, H));
        img.pixels.iter().map(|p| [p.x, p.y, p.z]).collect()
    }

    /// `gibake render --stats` of the test camera, `frames` frames at time
    /// 0 (nothing is animated: each is the same work): the last frame's GPU
    /// time per pass and its wall time (`prepare`, record, submit, wait),
    /// in milliseconds.
    pub fn render_stats(&self, mode: &str, frames: u32) -> (Vec<(String, f64)>, f64) {
        let look = format!(
            "{},{},{},{},{},{},{}",
            EYE[0], EYE[1], EYE[2], TARGET[0], TARGET[1], TARGET[2], FOV_DEG
        );
        let (w, h, n) = (W.to_string(), H.to_string(), frames.to_string());
        run_gibake(
            &self.dir,
            &[
                "render",
                LEVEL,
                "--bake",
                "living_room.gibake",
                "--mode",
                mode,
                "--look-at",
                &look,
                "--width",
                &w,
                "--height",
                &h,
                "--interleave",
                "1",
                "--ssaa",
                "1",
                "--time",
                "0",
                "--frames",
                &n,
                "--stats",
                "stats.json",
                "-o",
                "timed.exr",
            ],
        );
        let text = std::fs::read_to_string(self.dir.join("stats.json")).expect("read stats.json");
        let json: serde_json::Value = serde_json::from_str(&text).expect("stats.json is JSON");
        let last = json["frames"]
            .as_array()
            .and_then(|f| f.last())
            .expect("stats.json has frames");
        let wall_ms = last["wall_seconds"].as_f64().expect("wall_seconds") * 1e3;
        let passes = last["passes_ms"]
            .as_array()
            .expect("passes_ms")
            .iter()
            .map(|p| {
                (
                    p["pass"].as_str().expect("a pass name").to_string(),
                    p["ms"].as_f64().expect("a time"),
                )
            })
            .collect();
        (passes, wall_ms)
    }
}

impl Drop for Root {
    fn drop(&mut self) {
        let _ = std::fs::remove_dir_all(&self.dir);
    }
}

/// The newest frame read back, and how many have come.
#[derive(Default)]
struct Latest {
    data: Option<Vec<u8>>,
    count: u64,
}

/// A Bevy app with the plugin, the level and one camera rendering into an
/// image read back every frame.
pub struct Game {
    pub app: App,
    latest: Arc<Mutex<Latest>>,
    pub camera: Entity,
}

impl Game {
    pub fn new(root: &Root) -> Game {
        let mut app = App::new();
        let plugins = DefaultPlugins
            .set(AssetPlugin {
                file_path: root.dir.to_string_lossy().into_owned(),
                watch_for_changes_override: Some(true),
                ..default()
            })
            .set(WindowPlugin {
                primary_window: None,
                exit_condition: ExitCondition::DontExit,
                close_when_requested: false,
                ..default()
            })
            // Each update renders its own frame (no pipelining): frames
            // and what the test changed between them match.
            .disable::<bevy::render::pipelined_rendering::PipelinedRenderingPlugin>();
        #[cfg(feature = "example")]
        let plugins = plugins.disable::<bevy::winit::WinitPlugin>();
        app.add_plugins(plugins)
            .add_plugins(GibakePlugin {
                reload_poll: Duration::from_millis(100),
                ..default()
            })
            .insert_resource(GlobalAmbientLight::NONE);
        let mut image = Image::new_target_texture(W, H, TextureFormat::Rgba16Float, None);
        image.texture_descriptor.usage |= TextureUsages::COPY_SRC;
        let image = app.world_mut().resource_mut::<Assets<Image>>().add(image);
        let server = app.world().resource::<AssetServer>().clone();
        app.world_mut().spawn((
            WorldAssetRoot(server.load(GltfAssetLabel::Scene(0).from_asset(LEVEL))),
            GibakeLevel::new(server.load("living_room.gibake")),
        ));
        let camera = app
            .world_mut()
            .spawn((
                Camera3d::default(),
                Camera {
                    clear_color: ClearColorConfig::Custom(Color::BLACK),
                    ..default()
                },
                RenderTarget::Image(image.clone().into()),
                GibakeCamera::default(),
                Projection::Perspective(PerspectiveProjection {
                    fov: FOV_DEG.to_radians(),
                    near: 0.05,
                    ..default()
                }),
                Transform::from_translation(EYE.into()).looking_at(TARGET.into(), Vec3::Y),
                // Linear radiance as it is: no tone mapping, no dither,
                // an exposure of 1.
                Tonemapping::None,
                DebandDither::Disabled,
                Exposure {
                    ev100: -(1.2f32).log2(),
                },
            ))
            .id();
        let latest = Arc::new(Mutex::new(Latest::default()));
        let slot = latest.clone();
        app.world_mut()
            .spawn(Readback::texture(image))
            .observe(move |e: On<ReadbackComplete>| {
                let mut l = slot.lock().unwrap();
                l.data = Some(e.data.clone());
                l.count += 1;
            });
        app.finish();
        app.cleanup();
        Game {
            app,
            latest,
            camera,
        }
    }

    pub fn report(&self) -> gibake_bevy::GibakeReport {
        self.app.world().resource::<GibakeShared>().report()
    }

    pub fn settings(&mut self) -> Mut<'_, GibakeSettings> {
        self.app.world_mut().resource_mut::<GibakeSettings>()
    }

    /// One frame, and the newest frame read back (RGB).
    pub fn frame(&mut self) -> Option<Vec<[f32; 3]>> {
        self.app.update();
        let l = self.latest.lock().unwrap();
        l.data.as_ref().map(|d| decode(d))
    }

    /// The mean wall time of `n` frames (the whole Bevy frame: on lavapipe
    /// the GPU work is done on the CPU within it, the readback waited for).
    pub fn frame_wall_ms(&mut self, n: usize) -> f64 {
        let start = Instant::now();
        self.skip(n);
        start.elapsed().as_secs_f64() * 1e3 / n as f64
    }

    /// `n` frames, their pixels not looked at (what the test changed
    /// reaches the frames read back).
    pub fn skip(&mut self, n: usize) {
        for _ in 0..n {
            self.app.update();
        }
    }

    /// Updates until `ready` holds for the report and two frames read back
    /// in a row are equal (the pipelines compiled, the level drawn), then
    /// returns that frame. Panics after `limit`.
    pub fn settle(
        &mut self,
        what: &str,
        ready: impl Fn(&gibake_bevy::GibakeReport) -> bool,
    ) -> Vec<[f32; 3]> {
        let start = Instant::now();
        let limit = Duration::from_secs(300);
        let mut last: Option<Vec<[f32; 3]>> = None;
        let mut same = 0;
        loop {
            let f = self.frame();
            let report = self.report();
            if let Some(e) = &report.error {
                panic!("{what}: the plugin reports: {e}");
            }
            if let Some(f) = f
                && ready(&report)
                && f.iter().any(|p| p.iter().any(|c| *c > 0.0))
            {
                if last.as_ref() == Some(&f) {
                    same += 1;
                    // Equal over three frames: nothing is still arriving.
                    if same >= 3 {
                        return f;
                    }
                } else {
                    same = 0;
                }
                last = Some(f);
            }
            assert!(
                start.elapsed() < limit,
                "{what}: no steady frame within {limit:?} (report: {report:?})"
            );
        }
    }
}

/// `Rgba16Float` texels (rows of a multiple of 256 bytes) → RGB.
fn decode(data: &[u8]) -> Vec<[f32; 3]> {
    assert_eq!(data.len(), (W * H * 8) as usize, "unexpected readback size");
    data.chunks_exact(8)
        .map(|p| {
            let h = |k: usize| f16(u16::from_le_bytes([p[2 * k], p[2 * k + 1]]));
            [h(0), h(1), h(2)]
        })
        .collect()
}

pub fn f16(h: u16) -> f32 {
    let sign = if h & 0x8000 != 0 { -1.0 } else { 1.0 };
    let exp = i32::from((h >> 10) & 0x1f);
    let man = f32::from(h & 0x3ff);
    match exp {
        0 => sign * man * 2f32.powi(-24),
        31 if man == 0.0 => sign * f32::INFINITY,
        31 => f32::NAN,
        _ => sign * (1.0 + man / 1024.0) * 2f32.powi(exp - 15),
    }
}

/// Writes an RGB frame as a PNG preview (a fixed exposure, then sRGB)
/// when `GIBAKE_BEVY_PICTURES` names a directory.
pub fn picture(name: &str, pixels: &[[f32; 3]], exposure: f32) {
    let Some(dir) = std::env::var_os("GIBAKE_BEVY_PICTURES") else {
        return;
    };
    let dir = PathBuf::from(dir);
    std::fs::create_dir_all(&dir).unwrap();
    let mut rgba = Vec::with_capacity(pixels.len() * 4);
    for p in pixels {
        rgba.extend_from_slice(&[p[0], p[1], p[2], 1.0]);
    }
    gibake_image::Image::from_rgba_f32(W, H, &rgba)
        .write_png(&dir.join(name), Some(exposure))
        .expect("write the picture");
}
