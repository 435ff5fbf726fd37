//! The window and its event loop (winit's `ApplicationHandler`): creates
//! the window, surface, device and renderer when the loop starts, renders
//! one frame per redraw (runtime → present pass → surface), handles keys
//! and the mouse, polls the asset for hot reload and the figures for the
//! title, and in headless runs stops after the asked frames.

use std::sync::Arc;
use std::time::{Duration, Instant};

use gibake_runtime::{
    CameraMatrices, FrameInput, Image, Mode, Projection, RenderSettings, Renderer,
};
use winit::application::ApplicationHandler;
use winit::dpi::PhysicalSize;
use winit::event::{DeviceEvent, DeviceId, ElementState, KeyEvent, MouseButton, WindowEvent};
use winit::event_loop::{ActiveEventLoop, ControlFlow, EventLoop};
use winit::keyboard::{KeyCode, PhysicalKey};
use winit::window::{CursorGrabMode, Window, WindowId};

use crate::fly::{FlyCamera, Held};
use crate::present::PresentPass;
use crate::watch::AssetWatch;
use crate::{Screenshot, ViewOptions, ViewerError};

/// How often the title's figures change.
const TITLE_INTERVAL: Duration = Duration::from_millis(500);
/// Headless: frames the surface may refuse in a row before giving up.
const MAX_SKIPPED: u32 = 200;

/// Everything that lives on the GPU.
struct Gpu {
    window: Arc<Window>,
    surface: wgpu::Surface<'static>,
    config: wgpu::SurfaceConfiguration,
    device: wgpu::Device,
    queue: wgpu::Queue,
    record: gibake_gpu::AdapterRecord,
    present: PresentPass,
    renderer: Renderer,
}

struct App {
    opts: ViewOptions,
    gpu: Option<Gpu>,
    error: Option<ViewerError>,
    shot: Option<Screenshot>,
    /// Animation time, seconds.
    time: f32,
    playing: bool,
    last: Instant,
    /// Frames presented.
    frames: u32,
    skipped: u32,
    fly: FlyCamera,
    /// Keep the scene's own camera (until the user moves).
    follow_scene: bool,
    held: Held,
    looking: bool,
    captured: bool,
    exposure: Option<f32>,
    watch: Option<AssetWatch>,
    title_at: Instant,
    stats: String,
    /// Hot reloads done.
    reloads: u32,
    /// The scene options the scene on screen was loaded with, when known
    /// (what a reloaded asset is compared with: [`crate::level`]).
    loaded_with: Option<gibake_runtime::SceneOptions>,
}

/// The display named in the environment, for messages; `None`: none.
fn display() -> Option<String> {
    let get = |v: &str| std::env::var(v).ok().filter(|s| !s.is_empty());
    get("WAYLAND_DISPLAY")
        .map(|d| format!("WAYLAND_DISPLAY={d}"))
        .or_else(|| get("WAYLAND_SOCKET").map(|d| format!("WAYLAND_SOCKET={d}")))
        .or_else(|| get("DISPLAY").map(|d| format!("DISPLAY={d}")))
}

pub(crate) fn run(opts: ViewOptions) -> Result<Option<Screenshot>, ViewerError> {
    let Some(display) = display() else {
        return Err(ViewerError::NoDisplay);
    };
    let event_loop = EventLoop::new().map_err(|source| ViewerError::EventLoop {
        display: display.clone(),
        source,
    })?;
    event_loop.set_control_flow(ControlFlow::Poll);
    let fly = initial_camera(&opts.scene, opts.time)?;
    let now = Instant::now();
    // As the caller loaded it (`gibake view`: the user's options, the
    // asset's recorded ones applied).
    let loaded_with = match (&opts.reimport, &opts.asset, &opts.asset_dir) {
        (Some(r), Some(a), Some(dir)) => r.options_for(a.scene_options(), dir).ok(),
        _ => None,
    };
    let mut app = App {
        follow_scene: opts.scene.camera.is_some(),
        time: opts.time,
        playing: true,
        exposure: opts.exposure,
        watch: opts.asset_dir.as_deref().map(AssetWatch::new),
        opts,
        gpu: None,
        error: None,
        shot: None,
        last: now,
        frames: 0,
        skipped: 0,
        fly,
        held: Held::default(),
        looking: false,
        captured: false,
        title_at: now,
        stats: String::new(),
        reloads: 0,
        loaded_with,
    };
    event_loop
        .run_app(&mut app)
        .map_err(|source| ViewerError::EventLoop { display, source })?;
    if let Some(e) = app.error {
        return Err(e);
    }
    Ok(app.shot)
}

/// The fly camera's start: the scene's camera at `time`, else a view of
/// the static geometry from the front.
fn initial_camera(scene: &gibake_runtime::Scene, time: f32) -> Result<FlyCamera, ViewerError> {
    let b = scene.static_bounds();
    let diag = (b.max - b.min).length();
    let diag = if diag.is_finite() && diag > 0.0 {
        diag
    } else {
        1.0
    };
    let speed = 0.25 * diag;
    if let (Some(cam), Some(world)) = (&scene.camera, scene.camera_transform(time)) {
        let (yfov, znear) = match cam.projection {
            Projection::Perspective { yfov, znear, .. } => (yfov, znear),
            Projection::Orthographic { znear, .. } => (60f32.to_radians(), znear.max(1e-3 * diag)),
        };
        return Ok(FlyCamera::from_transform(world, yfov, znear, speed));
    }
    if !(b.min.is_finite() && b.max.is_finite()) {
        return Err(ViewerError::NoCamera(scene.source.clone()));
    }
    let c = 0.5 * (b.min + b.max);
    let eye = c + glam::Vec3::new(0.0, 0.25, 1.0) * diag;
    Ok(FlyCamera::look_at(
        eye,
        c,
        60f32.to_radians(),
        1e-3 * diag,
        speed,
    ))
}

/// The surface format: plain 8-bit (the shader encodes sRGB), else sRGB.
fn surface_format(caps: &wgpu::SurfaceCapabilities) -> Option<wgpu::TextureFormat> {
    use wgpu::TextureFormat as F;
    [
        F::Bgra8Unorm,
        F::Rgba8Unorm,
        F::Bgra8UnormSrgb,
        F::Rgba8UnormSrgb,
    ]
    .into_iter()
    .find(|f| caps.formats.contains(f))
}

impl App {
    fn headless(&self) -> bool {
        self.opts.frames.is_some()
    }

    fn init(&mut self, event_loop: &ActiveEventLoop) -> Result<Gpu, ViewerError> {
        let s = &self.opts.settings;
        let attrs = Window::default_attributes()
            .with_title("gibake view")
            .with_inner_size(PhysicalSize::new(s.width, s.height))
            .with_resizable(!self.headless());
        let window = Arc::new(
            event_loop
                .create_window(attrs)
                .map_err(ViewerError::Window)?,
        );
        let instance =
            wgpu::Instance::new(wgpu::InstanceDescriptor::new_without_display_handle().with_env());
        let surface = instance
            .create_surface(window.clone())
            .map_err(ViewerError::Surface)?;
        let adapter = crate::gpu::pick(&instance, self.opts.adapter.as_deref(), |a| {
            a.is_surface_supported(&surface)
        })?;
        let record = crate::gpu::record(&adapter);
        let needs =
            gibake_runtime::Requirements::of(&self.opts.scene, self.opts.asset.as_ref(), s)?;
        needs
            .check(&adapter.limits())
            .map_err(|source| ViewerError::Unsupported {
                adapter: record.name.clone(),
                source: Box::new(source),
            })?;
        let (device, queue) = crate::gpu::device(&adapter)?;
        let caps = surface.get_capabilities(&adapter);
        let format =
            surface_format(&caps).ok_or_else(|| ViewerError::SurfaceFormat(record.name.clone()))?;
        let size = window.inner_size();
        // Headless runs read the last presented frame back when they may.
        let copy = if self.headless() {
            caps.usages & wgpu::TextureUsages::COPY_SRC
        } else {
            wgpu::TextureUsages::empty()
        };
        let config = wgpu::SurfaceConfiguration {
            usage: wgpu::TextureUsages::RENDER_ATTACHMENT | copy,
            format,
            width: size.width.max(1),
            height: size.height.max(1),
            present_mode: if self.headless() {
                wgpu::PresentMode::AutoNoVsync
            } else {
                wgpu::PresentMode::AutoVsync
            },
            desired_maximum_frame_latency: 2,
            alpha_mode: caps
                .alpha_modes
                .first()
                .copied()
                .unwrap_or(wgpu::CompositeAlphaMode::Auto),
            view_formats: vec![],
            color_space: wgpu::SurfaceColorSpace::Auto,
        };
        surface.configure(&device, &config);
        let present = PresentPass::new(&device, format);
        let renderer = Renderer::new(
            &device,
            &queue,
            &self.opts.scene,
            self.opts.asset.as_ref(),
            &self.opts.settings,
        )?;
        eprintln_info(&format!("GPU: {record}"));
        Ok(Gpu {
            window,
            surface,
            config,
            device,
            queue,
            record,
            present,
            renderer,
        })
    }

    /// The camera of this frame.
    fn camera(&self, w: u32, h: u32) -> CameraMatrices {
        if self.follow_scene
            && let Ok(c) = CameraMatrices::from_scene(&self.opts.scene, self.time, w, h)
        {
            return c;
        }
        self.fly.matrices(w as f32 / h.max(1) as f32)
    }

    /// Renders and presents one frame.
    fn frame(&mut self, event_loop: &ActiveEventLoop) -> Result<(), ViewerError> {
        let now = Instant::now();
        let dt = now.duration_since(self.last).as_secs_f32().min(0.25);
        self.last = now;
        if let Some(n) = self.opts.frames {
            self.time =
                self.opts.time + self.frames.min(n.saturating_sub(1)) as f32 / self.opts.fps;
        } else {
            if self.playing {
                self.time += dt;
            }
            if self.held.any() {
                self.follow_scene = false;
                self.fly.fly(self.held, dt);
            }
            self.reload_if_changed(now);
        }
        let Some(gpu) = self.gpu.as_ref() else {
            return Ok(());
        };
        let (w, h) = gpu.renderer.size();
        let camera = self.camera(w, h);
        let transforms = gibake_runtime::scene_transforms(&self.opts.scene, self.time);
        let gpu = self.gpu.as_mut().expect("checked above");
        gpu.renderer.prepare(
            &gpu.device,
            &gpu.queue,
            &FrameInput::new(camera).transforms(&transforms),
        )?;
        let mut enc = gpu.device.create_command_encoder(&Default::default());
        gpu.renderer.record(&mut enc);
        gpu.queue.submit([enc.finish()]);
        let exposure = match self.exposure {
            Some(e) => e,
            None => {
                let e = read_output(gpu)?.auto_exposure();
                self.exposure = Some(e);
                e
            }
        };
        let texture = match gpu.surface.get_current_texture() {
            wgpu::CurrentSurfaceTexture::Success(t)
            | wgpu::CurrentSurfaceTexture::Suboptimal(t) => t,
            wgpu::CurrentSurfaceTexture::Outdated => {
                gpu.surface.configure(&gpu.device, &gpu.config);
                return self.skip();
            }
            wgpu::CurrentSurfaceTexture::Timeout | wgpu::CurrentSurfaceTexture::Occluded => {
                return self.skip();
            }
            other => {
                return Err(ViewerError::SurfaceLost(format!(
                    "acquiring the next frame: {other:?}"
                )));
            }
        };
        let view = texture.texture.create_view(&Default::default());
        let mut enc = gpu.device.create_command_encoder(&Default::default());
        gpu.present.record(
            &gpu.device,
            &mut enc,
            gpu.renderer.output_view(),
            exposure,
            &view,
            [gpu.config.width, gpu.config.height],
        );
        gpu.queue.submit([enc.finish()]);
        let last = self.opts.frames.is_some_and(|n| self.frames + 1 >= n);
        let presented = if last && gpu.config.usage.contains(wgpu::TextureUsages::COPY_SRC) {
            Some(read_presented(gpu, &texture.texture)?)
        } else {
            None
        };
        gpu.window.pre_present_notify();
        gpu.queue.present(texture);
        self.skipped = 0;
        self.frames += 1;
        if let Some(stats) = gpu.renderer.poll_stats(&gpu.device) {
            let passes: Vec<String> = stats
                .passes
                .iter()
                .map(|(p, ms)| format!("{p} {ms:.2}"))
                .collect();
            self.stats = format!(
                "{} ms: {} = {:.2}",
                stats.timing,
                passes.join(" · "),
                stats.frame_ms
            );
        }
        if let Some(n) = self.opts.frames {
            if self.frames >= n {
                let gpu = self.gpu.as_ref().expect("present");
                self.shot = Some(Screenshot {
                    image: read_output(gpu)?,
                    exposure,
                    adapter: gpu.record.clone(),
                    presented,
                });
                event_loop.exit();
            }
        } else if now >= self.title_at {
            self.title_at = now + TITLE_INTERVAL;
            self.set_title();
        }
        Ok(())
    }

    fn skip(&mut self) -> Result<(), ViewerError> {
        self.skipped += 1;
        if self.headless() && self.skipped > MAX_SKIPPED {
            return Err(ViewerError::SurfaceLost(format!(
                "the window gave no frame {MAX_SKIPPED} times in a row"
            )));
        }
        Ok(())
    }

    fn set_title(&self) {
        let Some(gpu) = &self.gpu else { return };
        let s = &self.opts.settings;
        let name = self
            .opts
            .scene
            .source
            .file_name()
            .map(|n| n.to_string_lossy().into_owned())
            .unwrap_or_default();
        let reloads = match self.reloads {
            0 => String::new(),
            n => format!(" — reloaded {n}×"),
        };
        gpu.window.set_title(&format!(
            "gibake view — {name} — {} — interleave {} — t {:.2} s {}{reloads} — {}",
            s.mode.name(),
            gpu.renderer.interleave(),
            self.time,
            if self.playing { "▶" } else { "⏸" },
            self.stats
        ));
    }

    /// Hot reload: a changed manifest → load, the level for it (loaded
    /// again when it was baked with other scene options), check,
    /// `set_asset`.
    fn reload_if_changed(&mut self, now: Instant) {
        let (Some(watch), Some(dir)) = (self.watch.as_mut(), self.opts.asset_dir.as_ref()) else {
            return;
        };
        if !watch.poll(now) {
            return;
        }
        let Some(gpu) = self.gpu.as_mut() else { return };
        let (reimport, loaded_with) = (self.opts.reimport.as_ref(), self.loaded_with.as_ref());
        let current = &self.opts.scene;
        let loaded = gibake_asset::load_with_limit(dir, self.opts.max_decoded_bytes)
            .map_err(|e| e.to_string())
            .and_then(|asset| {
                let (scene, with) =
                    crate::level::level_for(reimport, asset.scene_options(), loaded_with, dir)?;
                let level = scene.as_ref().unwrap_or(current);
                let hash = gibake_scene::static_scene_hash(level);
                gibake_asset::check_scene_hash_for(
                    dir,
                    &asset.manifest,
                    &hash,
                    &level.source,
                    with.as_ref(),
                )
                .map_err(|e| e.to_string())?;
                gpu.renderer
                    .set_asset(&gpu.device, &gpu.queue, level, Some(&asset))
                    .map_err(|e| e.to_string())?;
                Ok((asset, scene, with))
            });
        match loaded {
            Ok((asset, scene, with)) => {
                let again = match (&scene, &with) {
                    (Some(_), Some(w)) => format!(
                        " (the level loaded again with the bake's {})",
                        w.flags_or_none()
                    ),
                    _ => String::new(),
                };
                eprintln_info(&format!("reloaded {}{again}", dir.display()));
                self.opts.asset = Some(asset);
                if let Some(scene) = scene {
                    self.opts.scene = scene;
                }
                self.loaded_with = with;
                self.reloads += 1;
            }
            Err(e) => tracing::warn!(
                "{}: not reloaded, keeping the previous asset: {e}",
                dir.display()
            ),
        }
    }

    /// A new renderer for changed settings (mode, interleave); on an
    /// error the old one stays.
    fn rebuild(&mut self, settings: RenderSettings) {
        let Some(gpu) = self.gpu.as_mut() else { return };
        let (w, h) = gpu.renderer.size();
        let settings = RenderSettings {
            width: w,
            height: h,
            ..settings
        };
        match Renderer::new(
            &gpu.device,
            &gpu.queue,
            &self.opts.scene,
            self.opts.asset.as_ref(),
            &settings,
        ) {
            Ok(r) => {
                gpu.renderer = r;
                self.opts.settings = settings;
            }
            Err(e) => tracing::warn!("cannot switch: {e}"),
        }
        self.set_title();
    }

    fn key(&mut self, code: KeyCode, pressed: bool, event_loop: &ActiveEventLoop) {
        let h = &mut self.held;
        match code {
            KeyCode::KeyW => h.forward = pressed,
            KeyCode::KeyS => h.back = pressed,
            KeyCode::KeyA => h.left = pressed,
            KeyCode::KeyD => h.right = pressed,
            KeyCode::KeyE => h.up = pressed,
            KeyCode::KeyQ => h.down = pressed,
            KeyCode::ShiftLeft | KeyCode::ShiftRight => h.fast = pressed,
            _ if !pressed => {}
            KeyCode::Space | KeyCode::KeyP => {
                self.playing = !self.playing;
                self.set_title();
            }
            KeyCode::KeyR => {
                if let Ok(f) = initial_camera(&self.opts.scene, self.time) {
                    self.fly = f;
                }
                self.follow_scene = self.opts.scene.camera.is_some();
            }
            KeyCode::KeyX => self.exposure = None,
            KeyCode::KeyC => self.capture(!self.captured),
            KeyCode::Escape if self.captured => self.capture(false),
            KeyCode::Escape => event_loop.exit(),
            KeyCode::KeyI => {
                let next = match self.gpu.as_ref().map_or(1, |g| g.renderer.interleave()) {
                    1 => 2,
                    2 => 4,
                    4 => 8,
                    _ => 1,
                };
                let s = RenderSettings {
                    interleave: next,
                    ..self.opts.settings.clone()
                };
                self.rebuild(s);
            }
            KeyCode::Digit1
            | KeyCode::Digit2
            | KeyCode::Digit3
            | KeyCode::Digit4
            | KeyCode::Digit5 => {
                let mode = match code {
                    KeyCode::Digit1 => Mode::Full,
                    KeyCode::Digit2 => Mode::Direct,
                    KeyCode::Digit3 => Mode::Indirect,
                    KeyCode::Digit4 => Mode::Rsm,
                    _ => Mode::Naive,
                };
                let s = RenderSettings {
                    mode,
                    ..self.opts.settings.clone()
                };
                self.rebuild(s);
            }
            _ => {}
        }
    }

    fn capture(&mut self, on: bool) {
        let Some(gpu) = &self.gpu else { return };
        let w = &gpu.window;
        let ok = if on {
            w.set_cursor_grab(CursorGrabMode::Locked)
                .or_else(|_| w.set_cursor_grab(CursorGrabMode::Confined))
                .is_ok()
        } else {
            w.set_cursor_grab(CursorGrabMode::None).is_ok()
        };
        if ok || !on {
            w.set_cursor_visible(!on);
            self.captured = on;
        }
    }

    fn fail(&mut self, event_loop: &ActiveEventLoop, e: ViewerError) {
        if self.error.is_none() {
            self.error = Some(e);
        }
        event_loop.exit();
    }
}

/// Reads the renderer's output back (waits for the GPU).
fn read_output(gpu: &Gpu) -> Result<Image, ViewerError> {
    let out = gpu.renderer.output();
    let data = gibake_gpu::readback::read_texture_f32_on(&gpu.device, &gpu.queue, out, 0, 4)
        .map_err(gibake_runtime::RuntimeError::from)?;
    Ok(Image::from_rgba_f32(out.width(), out.height(), &data))
}

/// The surface texture's pixels as RGB8 rows (its format is one of
/// [`surface_format`]'s: BGRA or RGBA, 8 bits).
fn read_presented(gpu: &Gpu, t: &wgpu::Texture) -> Result<(u32, u32, Vec<u8>), ViewerError> {
    let bytes = gibake_gpu::readback::read_texture_on(&gpu.device, &gpu.queue, t, 0, 4)
        .map_err(gibake_runtime::RuntimeError::from)?;
    let bgra = matches!(
        t.format(),
        wgpu::TextureFormat::Bgra8Unorm | wgpu::TextureFormat::Bgra8UnormSrgb
    );
    let rgb = bytes
        .chunks_exact(4)
        .flat_map(|p| {
            if bgra {
                [p[2], p[1], p[0]]
            } else {
                [p[0], p[1], p[2]]
            }
        })
        .collect();
    Ok((t.width(), t.height(), rgb))
}

/// A line for the user on stderr (through the log at `info`, shown with
/// `-v`).
fn eprintln_info(msg: &str) {
    tracing::info!("{msg}");
}

impl ApplicationHandler for App {
    fn resumed(&mut self, event_loop: &ActiveEventLoop) {
        if self.gpu.is_some() {
            return;
        }
        match self.init(event_loop) {
            Ok(g) => {
                g.window.request_redraw();
                self.gpu = Some(g);
                self.last = Instant::now();
            }
            Err(e) => self.fail(event_loop, e),
        }
    }

    fn window_event(&mut self, event_loop: &ActiveEventLoop, _id: WindowId, event: WindowEvent) {
        match event {
            WindowEvent::CloseRequested => event_loop.exit(),
            WindowEvent::Resized(size) => {
                let headless = self.headless();
                let Some(gpu) = self.gpu.as_mut() else { return };
                if size.width == 0 || size.height == 0 {
                    return;
                }
                gpu.config.width = size.width;
                gpu.config.height = size.height;
                gpu.surface.configure(&gpu.device, &gpu.config);
                // Headless frames keep the asked size (the screenshot's).
                if !headless
                    && let Err(e) =
                        gpu.renderer
                            .resize(&gpu.device, &gpu.queue, size.width, size.height)
                {
                    tracing::warn!("cannot resize the frame: {e}");
                }
            }
            WindowEvent::RedrawRequested => {
                if let Err(e) = self.frame(event_loop) {
                    self.fail(event_loop, e);
                }
            }
            WindowEvent::KeyboardInput {
                event:
                    KeyEvent {
                        physical_key: PhysicalKey::Code(code),
                        state,
                        ..
                    },
                ..
            } => self.key(code, state == ElementState::Pressed, event_loop),
            WindowEvent::MouseInput {
                state,
                button: MouseButton::Right,
                ..
            } => self.looking = state == ElementState::Pressed,
            WindowEvent::Focused(false) => self.held = Held::default(),
            _ => {}
        }
    }

    fn device_event(&mut self, _el: &ActiveEventLoop, _id: DeviceId, event: DeviceEvent) {
        if let DeviceEvent::MouseMotion { delta } = event
            && (self.looking || self.captured)
            && !self.headless()
        {
            self.follow_scene = false;
            self.fly.turn(delta.0, delta.1);
        }
    }

    fn about_to_wait(&mut self, _event_loop: &ActiveEventLoop) {
        if let Some(g) = &self.gpu {
            g.window.request_redraw();
        }
    }
}
