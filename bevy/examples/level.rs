//! A small game on a real level: the living room of Godot's
//! physical-light demo (`data/levels/living_room`, MIT), lit by a sun
//! through its window, with gibake's baked bounce light added to Bevy's
//! frame and a floor lamp (the level's `Cylinder`) that moves.
//!
//! ```text
//! cd bevy && cargo run -p gibake-bevy --example level --ignore-rust-version
//! ```
//!
//! The first run bakes `assets/living_room.gibake` with the `gibake`
//! binary of the main workspace (`GIBAKE` names it; else
//! `../target/release/gibake` or `gibake` on the `PATH`). Re-baking it
//! while the game runs (another `--vpls`, say) reloads it in the game.
//!
//! Keys: W A S D, Q E, Shift fly; mouse (right button held, M grabs the
//! cursor) looks around;
//! G toggles gibake's light; L switches what gibake adds (the indirect
//! light onto Bevy's own sun, or everything, with Bevy's sun off); H hides
//! the lamp; Space pauses it; Esc quits. The top line shows the per-pass
//! GPU times of a frame a few frames old (`poll_stats`).
//!
//! `--frames N --screenshot out.png` renders N frames, writes what the
//! window shows, and exits (run it under Xvfb for pictures); `--size WxH`
//! sizes the window.

use std::path::{Path, PathBuf};
use std::process::Command;
use std::sync::{Arc, Mutex};

use bevy::camera::Exposure;
use bevy::camera_controller::free_camera::{FreeCamera, FreeCameraPlugin};
use bevy::core_pipeline::tonemapping::Tonemapping;
use bevy::light::GlobalAmbientLight;
use bevy::prelude::*;
use bevy::render::view::screenshot::{Screenshot, ScreenshotCaptured};
use bevy::window::{PrimaryWindow, WindowResolution};
use gibake_bevy::{
    GibakeCamera, GibakeLevel, GibakeLight, GibakeMode, GibakeObject, GibakePlugin, GibakeSettings,
    GibakeShared, Pass,
};

/// The level's bake, as `gibake bake` is told (levels.json: its sun, the
/// lamp that moves).
const BAKE_ARGS: &[&str] = &[
    "--sun",
    "173.1,60",
    "--sun-irradiance",
    "3",
    "--dynamic",
    "Cylinder",
];

fn main() -> AppExit {
    let options = match Options::parse(std::env::args().skip(1)) {
        Ok(o) => o,
        Err(e) => {
            eprintln!("level: {e}\n\n{USAGE}");
            std::process::exit(2);
        }
    };
    let Options {
        frames,
        screenshot,
        size,
        off,
    } = options;
    if let Err(e) = ensure_bake() {
        eprintln!("level: {e}");
        std::process::exit(2);
    }
    // Bevy asks for every feature the adapter has (its default
    // `WgpuSettingsPriority::Functionality`): timestamp queries for the top
    // line's per-pass times where the GPU has them.
    App::new()
        .add_plugins(
            DefaultPlugins
                .set(WindowPlugin {
                    primary_window: Some(Window {
                        title: "gibake in Bevy: living room".into(),
                        resolution: WindowResolution::new(size.0, size.1),
                        ..default()
                    }),
                    ..default()
                })
                // The example's assets wherever the binary runs from.
                .set(AssetPlugin {
                    file_path: assets().to_string_lossy().into_owned(),
                    ..default()
                }),
        )
        .add_plugins((GibakePlugin::default(), FreeCameraPlugin))
        // gibake's bounce replaces Bevy's flat ambient term.
        .insert_resource(GlobalAmbientLight::NONE)
        .insert_resource(GibakeSettings {
            enabled: !off,
            ..default()
        })
        .insert_resource(ClearColor(Color::srgb(0.55, 0.7, 0.9)))
        .insert_resource(Run {
            frames,
            screenshot,
            done: 0,
            paused: false,
            t: 0.0,
            shot: Arc::default(),
        })
        .add_systems(Startup, setup)
        .add_systems(Update, (keys, move_lamp, status_line, finish))
        .run()
}

const USAGE: &str = "usage: level [--size WIDTHxHEIGHT] [--off] [--frames N [--screenshot OUT.png]]
  --size WxH         the window's size (default 1024x576)
  --off              start with gibake's light off (G turns it on)
  --frames N         render N frames once gibake draws, then exit
  --screenshot PATH  with --frames: write the window's last frame as a PNG";

/// The command line.
struct Options {
    frames: Option<u32>,
    screenshot: Option<PathBuf>,
    size: (u32, u32),
    off: bool,
}

impl Options {
    fn parse(args: impl Iterator<Item = String>) -> Result<Options, String> {
        let mut o = Options {
            frames: None,
            screenshot: None,
            size: (1024, 576),
            off: false,
        };
        let mut args = args.peekable();
        while let Some(a) = args.next() {
            let mut value = || args.next().ok_or_else(|| format!("{a} needs a value"));
            match a.as_str() {
                "--frames" => {
                    let v = value()?;
                    o.frames = Some(
                        v.parse()
                            .ok()
                            .filter(|n| *n > 0)
                            .ok_or_else(|| format!("--frames {v}: not a positive number"))?,
                    );
                }
                "--screenshot" => o.screenshot = Some(PathBuf::from(value()?)),
                "--off" => o.off = true,
                "--size" => {
                    let v = value()?;
                    o.size = v
                        .split_once('x')
                        .and_then(|(w, h)| Some((w.parse().ok()?, h.parse().ok()?)))
                        .filter(|(w, h): &(u32, u32)| {
                            (1..=8192).contains(w) && (1..=8192).contains(h)
                        })
                        .ok_or_else(|| format!("--size {v}: not WIDTHxHEIGHT (1 to 8192 each)"))?;
                }
                "-h" | "--help" => {
                    println!("{USAGE}");
                    std::process::exit(0);
                }
                _ => return Err(format!("unknown argument {a}")),
            }
        }
        if o.screenshot.is_some() && o.frames.is_none() {
            return Err("--screenshot needs --frames".into());
        }
        Ok(o)
    }
}

#[derive(Resource)]
struct Run {
    frames: Option<u32>,
    screenshot: Option<PathBuf>,
    done: u32,
    paused: bool,
    t: f32,
    shot: Arc<Mutex<Option<Result<(), String>>>>,
}

#[derive(Component)]
struct StatusLine;

/// Where the example's assets live (Bevy's default root when run by cargo).
fn assets() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("assets")
}

/// Bakes the level with the `gibake` binary unless its bake is there.
fn ensure_bake() -> Result<(), String> {
    let out = assets().join("living_room.gibake");
    if out.join("manifest.bin").is_file() {
        return Ok(());
    }
    let gibake = gibake_binary().ok_or_else(|| {
        format!(
            "{} is not baked and no gibake binary was found: build it in the main workspace \
             (`cargo build --release -p gibake`), or set GIBAKE to it, or bake it yourself:\n  \
             gibake bake data/levels/living_room/living_room.glb {} -o {}",
            out.display(),
            BAKE_ARGS.join(" "),
            out.display()
        )
    })?;
    let level = assets().join("living_room.glb");
    eprintln!("level: baking {} with {}", out.display(), gibake.display());
    let status = Command::new(&gibake)
        .arg("bake")
        .arg(&level)
        .args(BAKE_ARGS)
        .arg("-o")
        .arg(&out)
        .status()
        .map_err(|e| format!("{}: {e}", gibake.display()))?;
    if !status.success() {
        return Err(format!("{} bake failed ({status})", gibake.display()));
    }
    Ok(())
}

fn gibake_binary() -> Option<PathBuf> {
    if let Some(p) = std::env::var_os("GIBAKE") {
        return Some(PathBuf::from(p));
    }
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("..");
    let mut candidates = vec![root.join("target/release/gibake")];
    if let Some(t) = std::env::var_os("CARGO_TARGET_DIR") {
        candidates.push(PathBuf::from(t).join("release/gibake"));
    }
    if let Some(path) = std::env::var_os("PATH") {
        candidates.extend(std::env::split_paths(&path).map(|d| d.join("gibake")));
    }
    candidates.into_iter().find(|p| p.is_file())
}

fn setup(mut commands: Commands, assets: Res<AssetServer>) {
    commands.spawn((
        WorldAssetRoot(assets.load(GltfAssetLabel::Scene(0).from_asset("living_room.glb"))),
        GibakeLevel::new(assets.load("living_room.gibake")),
    ));
    // levels.json's camera for this level: eye, target, 75° vertical.
    commands.spawn((
        Camera3d::default(),
        GibakeCamera::default(),
        Projection::Perspective(PerspectiveProjection {
            fov: 75f32.to_radians(),
            ..default()
        }),
        Transform::from_xyz(-2.93, 2.21, -1.89).looking_at(Vec3::new(-0.1, 1.98, 2.23), Vec3::Y),
        // An exposure of 3 (Bevy's `1 / (1.2 · 2^ev100)`): the sun's 3 W/m²
        // (lux to Bevy) and gibake's light, added times the same exposure,
        // brought up for the eye; ACES tone mapping after.
        Exposure {
            ev100: -(3.6f32).log2(),
        },
        Tonemapping::AcesFitted,
        FreeCamera::default(),
    ));
    commands.spawn((
        Text::new("gibake: loading"),
        TextFont {
            font_size: bevy::text::FontSize::Px(15.0),
            ..default()
        },
        TextColor(Color::WHITE),
        Node {
            position_type: PositionType::Absolute,
            top: Val::Px(6.0),
            left: Val::Px(8.0),
            ..default()
        },
        StatusLine,
    ));
}

fn keys(
    input: Res<ButtonInput<KeyCode>>,
    mut settings: ResMut<GibakeSettings>,
    mut run: ResMut<Run>,
    mut lamps: Query<&mut Visibility, With<GibakeObject>>,
    mut suns: Query<&mut Visibility, (With<GibakeLight>, Without<GibakeObject>)>,
    mut exit: MessageWriter<AppExit>,
) {
    if input.just_pressed(KeyCode::KeyG) {
        settings.enabled = !settings.enabled;
    }
    // (M is the fly camera's cursor grab.)
    if input.just_pressed(KeyCode::KeyL) {
        settings.mode = match settings.mode {
            GibakeMode::Indirect => GibakeMode::Everything,
            GibakeMode::Everything => GibakeMode::Indirect,
        };
        // Everything: gibake's direct light replaces Bevy's sun.
        let shown = settings.mode == GibakeMode::Indirect;
        for mut v in &mut suns {
            *v = if shown {
                Visibility::Inherited
            } else {
                Visibility::Hidden
            };
        }
    }
    if input.just_pressed(KeyCode::KeyH) {
        for mut v in &mut lamps {
            v.toggle_inherited_hidden();
        }
    }
    if input.just_pressed(KeyCode::Space) {
        run.paused = !run.paused;
    }
    if input.just_pressed(KeyCode::Escape) {
        exit.write(AppExit::Success);
    }
}

/// The lamp walks along the room's back wall and turns.
fn move_lamp(
    time: Res<Time>,
    mut run: ResMut<Run>,
    mut lamps: Query<(&mut Transform, &GibakeObject)>,
    mut start: Local<Option<Transform>>,
) {
    if !run.paused {
        run.t += time.delta_secs();
    }
    for (mut t, o) in &mut lamps {
        if !o.is_declared() {
            continue;
        }
        let s = *start.get_or_insert(*t);
        let phase = run.t * 0.6;
        t.translation =
            s.translation + Vec3::new(0.9 * phase.sin(), 0.0, 0.5 * (phase * 0.7).sin());
        t.rotation = s.rotation * Quat::from_rotation_y(phase * 0.5);
    }
}

fn status_line(
    shared: Res<GibakeShared>,
    settings: Res<GibakeSettings>,
    mut text: Query<&mut Text, With<StatusLine>>,
) {
    let report = shared.report();
    let mut line = format!(
        "gibake {} ({:?}) [G toggle, L mode, H lamp, Space pause]",
        if settings.enabled { "on" } else { "off" },
        settings.mode
    );
    if let Some(e) = &report.error {
        line += &format!("  error: {e}");
    } else if let Some(s) = &report.stats {
        line += &format!("  frame {}: {:.2} ms GPU", s.frame, s.frame_ms);
        for p in Pass::ALL {
            let ms = s.pass_ms(p);
            if ms > 0.0 {
                line += &format!(", {} {:.2}", p.name(), ms);
            }
        }
        if report.reloads > 0 {
            line += &format!("  (re-bakes taken: {})", report.reloads);
        }
    }
    for mut t in &mut text {
        if t.0 != line {
            t.0.clone_from(&line);
        }
    }
}

/// With `--frames N`: a screenshot of frame N, then exit.
fn finish(
    mut commands: Commands,
    mut run: ResMut<Run>,
    shared: Res<GibakeShared>,
    mut exit: MessageWriter<AppExit>,
    window: Query<Entity, With<PrimaryWindow>>,
    settings: Res<GibakeSettings>,
    lights: Query<(), With<GibakeLight>>,
) {
    let Some(n) = run.frames else { return };
    // Count frames once gibake draws (the level and pipelines are ready),
    // or, with gibake off, once the level's lights are spawned.
    let ready = if settings.enabled {
        shared.report().frames > 0
    } else {
        !lights.is_empty()
    };
    if !ready {
        return;
    }
    run.done += 1;
    if run.done == n && window.single().is_ok() {
        match run.screenshot.clone() {
            Some(path) => {
                let slot = run.shot.clone();
                commands.spawn(Screenshot::primary_window()).observe(
                    move |shot: On<ScreenshotCaptured>| {
                        let r = write_png(&shot.image, &path);
                        *slot.lock().unwrap() = Some(r);
                    },
                );
            }
            None => {
                exit.write(AppExit::Success);
            }
        }
    }
    let result = run.shot.lock().unwrap().take();
    match result {
        Some(Ok(())) => {
            exit.write(AppExit::Success);
        }
        Some(Err(e)) => {
            eprintln!("level: {e}");
            exit.write(AppExit::from_code(2));
        }
        None => {}
    }
}

fn write_png(image: &Image, path: &Path) -> Result<(), String> {
    use bevy::render::render_resource::TextureFormat as F;
    let (w, h) = (image.width(), image.height());
    let mut data = image
        .data
        .clone()
        .ok_or("screenshot: no pixels came back")?;
    match image.texture_descriptor.format {
        F::Rgba8UnormSrgb | F::Rgba8Unorm => {}
        F::Bgra8UnormSrgb | F::Bgra8Unorm => data.chunks_exact_mut(4).for_each(|p| p.swap(0, 2)),
        f => return Err(format!("screenshot: a {f:?} surface")),
    }
    let file = std::fs::File::create(path).map_err(|e| format!("{}: {e}", path.display()))?;
    let mut enc = png::Encoder::new(std::io::BufWriter::new(file), w, h);
    enc.set_color(png::ColorType::Rgba);
    enc.set_depth(png::BitDepth::Eight);
    enc.write_header()
        .and_then(|mut wr| wr.write_image_data(&data))
        .map_err(|e| format!("{}: {e}", path.display()))
}
