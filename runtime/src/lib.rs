//! gibake's game-facing runtime, in the style of wgpu middleware.
//!
//! ```no_run
//! # fn frame(device: &wgpu::Device, queue: &wgpu::Queue) -> Result<(), Box<dyn std::error::Error>> {
//! use gibake_runtime::{CameraMatrices, FrameInput, RenderSettings, Renderer, glam::Mat4};
//!
//! let scene = gibake_runtime::load_scene(std::path::Path::new("level.glb"), &Default::default())?;
//! let asset = gibake_runtime::load_asset(std::path::Path::new("level.gibake"))?;
//! let mut renderer = Renderer::new(device, queue, &scene, Some(&asset), &RenderSettings::default())?;
//! let door = renderer.object("door").ok_or("no door")?;
//!
//! // Every frame: the game's camera and moved objects, then one encoder.
//! let camera = CameraMatrices::perspective(Mat4::IDENTITY, 1.0, 640.0 / 480.0, 0.1);
//! let moved = [(door, Mat4::from_translation([0.0, 1.0, 0.0].into()))];
//! renderer.prepare(device, queue, &FrameInput::new(camera).moving(&moved))?;
//! let mut encoder = device.create_command_encoder(&Default::default());
//! renderer.record(&mut encoder);
//! // ... sample `renderer.output()` (linear radiance) in the game's own pass ...
//! queue.submit([encoder.finish()]);
//! # Ok(()) }
//! ```
//!
//! A [`Renderer`] owns the GPU resources for one [`Scene`] and (except in
//! `direct` mode) one baked [`Asset`], on the caller's `wgpu::Device`. The
//! scene is plain data an engine can fill from its own meshes; with the
//! default `gltf` feature [`load_scene`] reads one from a glTF file (its
//! camera, if any, is not needed: the camera comes with each frame). Moving
//! objects are addressed by [`ObjectHandle`] ([`Renderer::object`] looks one
//! up by name). Per frame, [`Renderer::prepare`] does every upload and
//! growth and returns typed errors ([`RuntimeError`]); [`Renderer::record`]
//! only records. The frame lands in [`Renderer::output`] (linear radiance,
//! [`OUTPUT_FORMAT`], sampleable) or in a texture the caller provides
//! ([`Renderer::set_output_target`]); [`Renderer::resize`] changes its size.
//!
//! Per frame, only what moving objects cause is done (design brief, steps
//! 4–8), all on the GPU, with no read-back:
//! 1. moving objects → their own primary shadow map; shading takes the
//!    minimum with the baked static map (the z-min merge, without copying);
//! 2. moving objects → a small RSM at the bake's RSM resolution; texels where
//!    they are nearer the light than the static surface
//!    - scale the static VPLs' flux by their lit fraction (partial occlusion),
//!    - become dynamic VPLs (quadtree on the GPU);
//! 3. static VPL maps: only the VPLs whose hemisphere a moving object's
//!    bounds enter get a tile in which the moving objects are rasterized
//!    exactly; shading takes the minimum with the baked map. A VPL no longer
//!    affected simply has no tile: its baked map is used as it is.
//! 4. G-buffer, then shading.
//!
//! With no moving objects none of 1–3 exists: no pass, no texture.

mod atlas;
#[doc(hidden)]
pub mod baked;
mod camera;
#[doc(hidden)]
pub mod dynamic_rsm;
#[doc(hidden)]
pub mod dynamic_vpl;
mod gbuffer;
mod interleave;
mod merge;
mod shade;
#[doc(hidden)]
pub mod timer;
#[doc(hidden)]
pub mod transport;

use std::sync::atomic::{AtomicU32, Ordering};
use std::time::Instant;

use gibake_gpu::mesh::SceneGpu;
use gibake_gpu::passes::shadow::ShadowPass;
use gibake_gpu::{GpuPrimaryLight, LightView};
use glam::Mat4;
use wgpu::util::DeviceExt;

pub use camera::{CameraMatrices, NoCamera};
pub use gbuffer::GBUFFER_FORMATS;
pub use gibake_asset::{Asset, AssetError, load as load_asset};
pub use gibake_gpu::GpuError;
pub use gibake_image::Image;
pub use gibake_scene::{
    Aabb, Animator, DynamicObject, Light, LightKind, Material, Mesh, Projection, Scene, SceneError,
    Texture,
};
#[cfg(feature = "gltf")]
pub use gibake_scene::{LoadOptions, load as load_scene};
pub use {glam, wgpu};

/// Format of the renderer's output: linear radiance.
pub const OUTPUT_FORMAT: wgpu::TextureFormat = shade::RADIANCE_FORMAT;

/// What a frame contains.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum Mode {
    /// The method: direct + static VPLs with merged maps + dynamic VPLs.
    #[default]
    Full,
    /// Direct light only (needs no asset).
    Direct,
    /// The indirect part of `Full`.
    Indirect,
    /// Dachsbacher's RSM: direct + every VPL, no VPL visibility.
    Rsm,
    /// Like `Full`, but every VPL map is re-rendered from all geometry every
    /// frame (the cost baseline; same image).
    Naive,
}

impl Mode {
    /// Lower-case name (`full`, `direct`, ...).
    pub fn name(self) -> &'static str {
        match self {
            Mode::Full => "full",
            Mode::Direct => "direct",
            Mode::Indirect => "indirect",
            Mode::Rsm => "rsm",
            Mode::Naive => "naive",
        }
    }
}

/// Settings of a [`Renderer`].
#[derive(Clone, Debug)]
pub struct RenderSettings {
    /// Output width in pixels ([`Renderer::resize`] changes it).
    pub width: u32,
    /// Output height in pixels.
    pub height: u32,
    /// Primary shadow map resolution when no asset is given (direct mode);
    /// with an asset, the baked map's resolution is used.
    pub shadow_map_size: u32,
    /// What to render.
    pub mode: Mode,
    /// Most dynamic VPLs per frame (rounded up to a power of 4; 0: none).
    pub max_dynamic_vpls: u32,
    /// Interleaved VPL sampling: 1 (every pixel sums every VPL), 2, 4 or 8
    /// (each pixel of an N×N block sums a disjoint 1/N² of the VPLs, and a
    /// geometry-aware filter over its neighbours reconstructs the sum), or
    /// 0 (the default: 4 from 256² output pixels on, else 1 — measured, see
    /// docs/results.md; re-chosen on [`Renderer::resize`]). Other values are
    /// [`RuntimeError::InvalidSetting`]. [`Renderer::interleave`] says which
    /// factor is in use.
    pub interleave: u32,
}

impl Default for RenderSettings {
    fn default() -> Self {
        RenderSettings {
            max_dynamic_vpls: 256,
            width: 640,
            height: 480,
            shadow_map_size: 2048,
            mode: Mode::Full,
            interleave: interleave::AUTO,
        }
    }
}

/// Runtime errors. None of them is a panic; the messages name no command
/// line (a tool adds its own wording).
#[derive(Debug, thiserror::Error)]
pub enum RuntimeError {
    /// The scene has no camera (only [`CameraMatrices::from_scene`] and
    /// [`render_image`] need one).
    #[error(transparent)]
    NoCamera(#[from] NoCamera),
    /// A GPU operation failed.
    #[error(transparent)]
    Gpu(#[from] GpuError),
    /// The asset does not fit the scene.
    #[error(transparent)]
    Asset(#[from] AssetError),
    /// A bad setting (zero size, unknown interleave factor, ...).
    #[error("invalid render setting: {0}")]
    InvalidSetting(String),
    /// Something would exceed a limit of the caller's device.
    #[error("{what} needs {needed}; this device allows {limit}")]
    DeviceLimit {
        /// What was to be created.
        what: String,
        /// The size it needs (texels, bytes).
        needed: u64,
        /// The device's limit.
        limit: u64,
    },
    /// The mode needs a baked asset.
    #[error("mode `{0}` needs a baked asset")]
    NeedsAsset(&'static str),
    /// A frame's transform list does not have one matrix per moving object.
    #[error("{got} transforms given for {expected} moving objects")]
    TransformCount {
        /// Moving objects of the scene.
        expected: usize,
        /// Transforms given.
        got: usize,
    },
    /// A handle that is not one of this renderer's moving objects.
    #[error("{0:?} is not a moving object of this renderer")]
    UnknownObject(ObjectHandle),
    /// A caller-provided output texture does not fit.
    #[error("output target: {0}")]
    OutputTarget(String),
}

/// A moving object of one [`Renderer`] (from [`Renderer::object`] or
/// [`Renderer::objects`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct ObjectHandle {
    renderer: u32,
    index: u32,
}

impl ObjectHandle {
    /// Position of the object in the scene's `dynamic_objects`.
    pub fn index(self) -> usize {
        self.index as usize
    }
}

/// What the game supplies each frame.
#[derive(Clone, Copy, Debug)]
pub struct FrameInput<'a> {
    /// The camera (the output's aspect ratio is the caller's to match).
    pub camera: CameraMatrices,
    /// Either empty (objects stay where they are) or one world matrix per
    /// moving object, in handle order ([`ObjectHandle::index`]).
    pub transforms: &'a [Mat4],
    /// World matrices of single objects, applied after `transforms`.
    pub moved: &'a [(ObjectHandle, Mat4)],
}

impl<'a> FrameInput<'a> {
    /// A frame with `camera` and no object moved.
    pub fn new(camera: CameraMatrices) -> FrameInput<'a> {
        FrameInput {
            camera,
            transforms: &[],
            moved: &[],
        }
    }

    /// With one world matrix per moving object.
    pub fn transforms(self, transforms: &'a [Mat4]) -> FrameInput<'a> {
        FrameInput { transforms, ..self }
    }

    /// With single objects moved.
    pub fn moving(self, moved: &'a [(ObjectHandle, Mat4)]) -> FrameInput<'a> {
        FrameInput { moved, ..self }
    }
}

/// The world matrices of `scene`'s moving objects at `time` of its
/// animation, in handle order.
pub fn scene_transforms(scene: &Scene, time: f32) -> Vec<Mat4> {
    scene.dynamic_transforms(time)
}

/// Per-frame counts and times.
#[derive(Clone, Debug, Default, serde::Serialize)]
pub struct FrameStats {
    /// "gpu timestamps" or "wall (no timestamp queries on this adapter)".
    pub timing: String,
    /// Per pass `(name, milliseconds)`, in order.
    pub passes: Vec<(String, f64)>,
    /// Static VPLs shaded.
    pub static_vpls: u32,
    /// Dynamic VPL slots shaded.
    pub dynamic_vpl_slots: u32,
    /// VPL maps into which moving objects were rasterized this frame.
    pub affected_maps: u32,
    /// Draw calls recorded by the per-frame update (merge passes).
    pub update_draw_calls: u32,
    /// Draw calls in total.
    pub draw_calls: u32,
}

impl FrameStats {
    /// Sum of the update passes (everything but G-buffer, shading and its
    /// interleave filter).
    pub fn update_ms(&self) -> f64 {
        self.passes
            .iter()
            .filter(|(n, _)| n != "gbuffer" && n != "shade" && n != "interleave")
            .map(|(_, t)| t)
            .sum()
    }
}

/// Where shading writes, and what depends on the output size.
struct Target {
    gbuffer: gbuffer::GBuffer,
    /// The interleave filter (interleave > 1 only).
    interleave: Option<interleave::InterleavePass>,
    /// The renderer's output (its own, or the caller's).
    output: wgpu::Texture,
    output_view: wgpu::TextureView,
    /// Shading's G-buffer and output (group 0).
    frame_group: wgpu::BindGroup,
    /// The caller's G-buffer views, when it provides them.
    external_gbuffer: Option<[wgpu::TextureView; 3]>,
}

/// What the frame bind group needs besides the G-buffer and output.
struct FrameViews {
    primary_static: wgpu::TextureView,
    primary_dynamic: wgpu::TextureView,
    light_view_buf: wgpu::Buffer,
    light_buf: wgpu::Buffer,
}

impl FrameViews {
    /// Group 0 of shading for this G-buffer and output; interleaved, shading
    /// writes the filter's input, which the filter (bound here) resolves
    /// into `output`.
    fn bind(
        &self,
        device: &wgpu::Device,
        shade: &shade::ShadePass,
        gbuffer: [&wgpu::TextureView; 3],
        interleave: Option<&mut interleave::InterleavePass>,
        output: &wgpu::TextureView,
    ) -> wgpu::BindGroup {
        let shade_out = match interleave {
            Some(il) => {
                il.bind(device, gbuffer, output);
                il.shaded.clone()
            }
            None => output.clone(),
        };
        shade.frame_group(
            device,
            &shade::FrameInputs {
                gbuffer,
                primary_static: &self.primary_static,
                primary_dynamic: &self.primary_dynamic,
                light: &self.light_buf,
                light_view: &self.light_view_buf,
                output: &shade_out,
            },
        )
    }
}

/// Renders frames of one scene.
pub struct Renderer {
    id: u32,
    settings: RenderSettings,
    object_names: Vec<String>,
    scene_gpu: SceneGpu,
    baked: Option<baked::BakedGpu>,
    _own_static: Option<ShadowPass>,
    dyn_primary: Option<ShadowPass>,
    dyn_rsm: Option<dynamic_rsm::DynamicRsmPass>,
    occlusion: Option<dynamic_rsm::OcclusionPass>,
    merge: Option<merge::VplMerge>,
    gbuffer_pass: gbuffer::GBufferPass,
    shade: shade::ShadePass,
    target: Target,
    gi_group: wgpu::BindGroup,
    frame_views: FrameViews,
    params: shade::GpuShadeParams,
    dyn_vpls: Option<dynamic_vpl::DynamicVplPass>,
    transforms: Vec<Mat4>,
    timer: Option<timer::Timer>,
    stats: FrameStats,
    wall_start: Option<Instant>,
}

static NEXT_RENDERER: AtomicU32 = AtomicU32::new(0);

/// Checks an output size against the device.
fn check_size(device: &wgpu::Device, width: u32, height: u32) -> Result<(), RuntimeError> {
    let limit = device.limits().max_texture_dimension_2d;
    for (what, v) in [("width", width), ("height", height)] {
        if v == 0 {
            return Err(RuntimeError::InvalidSetting(format!(
                "{what} must be at least 1"
            )));
        }
        if v > limit {
            return Err(RuntimeError::DeviceLimit {
                what: format!("an output {what} of {v} pixels"),
                needed: u64::from(v),
                limit: u64::from(limit),
            });
        }
    }
    Ok(())
}

/// The renderer's own output texture.
fn own_output(device: &wgpu::Device, width: u32, height: u32) -> wgpu::Texture {
    gibake_gpu::util::texture_2d(
        device,
        "radiance",
        width,
        height,
        OUTPUT_FORMAT,
        wgpu::TextureUsages::STORAGE_BINDING
            | wgpu::TextureUsages::TEXTURE_BINDING
            | wgpu::TextureUsages::COPY_SRC,
    )
}

impl Renderer {
    /// Creates every GPU resource for `scene` (and `asset`, needed by every
    /// mode but `Direct`) on the caller's device. The asset must have been
    /// baked from this scene's static part. Moving objects start at their
    /// animation's time 0; the camera comes with the first
    /// [`Renderer::prepare`].
    pub fn new(
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        scene: &Scene,
        asset: Option<&Asset>,
        settings: &RenderSettings,
    ) -> Result<Renderer, RuntimeError> {
        check_size(device, settings.width, settings.height)?;
        let limit = device.limits().max_texture_dimension_2d;
        if settings.shadow_map_size == 0 {
            return Err(RuntimeError::InvalidSetting(
                "shadow map size must be at least 1".into(),
            ));
        }
        if asset.is_none() && settings.shadow_map_size > limit {
            return Err(RuntimeError::DeviceLimit {
                what: format!("a shadow map of {}²", settings.shadow_map_size),
                needed: u64::from(settings.shadow_map_size),
                limit: u64::from(limit),
            });
        }
        if !interleave::VALID.contains(&settings.interleave) {
            return Err(RuntimeError::InvalidSetting(format!(
                "interleave {} must be 0 (automatic), 1, 2, 4 or 8",
                settings.interleave
            )));
        }
        let mode = settings.mode;
        if asset.is_none() && mode != Mode::Direct {
            return Err(RuntimeError::NeedsAsset(mode.name()));
        }
        if let Some(a) = asset {
            gibake_asset::check_scene_hash(
                &a.manifest,
                &gibake_scene::static_scene_hash(scene),
                &scene.source,
            )?;
        }
        for t in &scene.textures {
            if t.width.max(t.height) > limit {
                return Err(RuntimeError::DeviceLimit {
                    what: format!("a {}×{} material texture", t.width, t.height),
                    needed: u64::from(t.width.max(t.height)),
                    limit: u64::from(limit),
                });
            }
        }
        // The asset first: its limits are checked before any upload.
        let baked = match asset {
            Some(a) => Some(baked::BakedGpu::new(device, queue, a)?),
            None => None,
        };
        let scene_gpu = SceneGpu::new(device, queue, scene, 0.0);
        let has_dynamic = !scene.dynamic_objects.is_empty();
        let indirect = mode != Mode::Direct;
        // Primary shadow map: baked static map, or rendered once here.
        let (view, primary_static, own_static) = match &baked {
            Some(b) => (b.view, b.primary.clone(), None),
            None => {
                let view = LightView::for_scene(scene, settings.shadow_map_size);
                let pass = ShadowPass::new(device, &scene_gpu, view);
                let mut enc = device.create_command_encoder(&Default::default());
                pass.encode(&mut enc, &scene_gpu, &[&scene_gpu.static_draws], None);
                queue.submit([enc.finish()]);
                (view, pass.metric_view.clone(), Some(pass))
            }
        };
        let dyn_primary = has_dynamic.then(|| ShadowPass::new(device, &scene_gpu, view));
        let light_view_buf = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some("primary light view"),
            contents: bytemuck::bytes_of(&view.to_gpu()),
            usage: wgpu::BufferUsages::UNIFORM,
        });

        // Moving objects' RSM and partial occlusion.
        let (dyn_rsm, occlusion) = match (&baked, has_dynamic && indirect) {
            (Some(b), true) => match &b.rsm {
                Some(r) => {
                    let pass = dynamic_rsm::DynamicRsmPass::new(device, &scene_gpu, &r.view);
                    let occ = dynamic_rsm::OcclusionPass::new(
                        device,
                        &r.static_metric,
                        &pass,
                        &r.texel_info,
                        b.vpls.len() as u32,
                    );
                    (Some(pass), Some(occ))
                }
                None => (None, None),
            },
            _ => (None, None),
        };

        // VPL-map merge (full/indirect with moving objects) or re-render
        // (naive).
        let needs_merge = match mode {
            Mode::Naive => true,
            Mode::Full | Mode::Indirect => has_dynamic,
            _ => false,
        };
        let merge = match (&baked, needs_merge) {
            (Some(b), true) => Some(merge::VplMerge::new(
                device,
                &scene_gpu,
                b,
                scene.full_bounds().diagonal(),
                mode == Mode::Naive,
            )?),
            _ => None,
        };

        let gbuffer_pass = gbuffer::GBufferPass::new(device, &scene_gpu);
        let light_buf = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some("primary light"),
            contents: bytemuck::bytes_of(&GpuPrimaryLight::new(&scene.light)),
            usage: wgpu::BufferUsages::UNIFORM,
        });
        let shade = shade::ShadePass::new(device);
        let primary_dynamic = dyn_primary
            .as_ref()
            .map(|p| p.metric_view.clone())
            .unwrap_or_else(|| primary_static.clone());
        let frame_views = FrameViews {
            primary_static,
            primary_dynamic,
            light_view_buf,
            light_buf,
        };
        // Dynamic VPLs: moving surfaces of the dynamic RSM, clustered on the
        // GPU with the bake's rule and threshold.
        let dyn_vpls = match (&dyn_rsm, &baked, asset) {
            (Some(r), Some(b), Some(a)) if settings.max_dynamic_vpls > 0 => {
                b.rsm.as_ref().map(|rg| {
                    dynamic_vpl::DynamicVplPass::new(
                        device,
                        r,
                        &rg.static_metric,
                        &frame_views.light_buf,
                        a.manifest.settings.threshold,
                        settings.max_dynamic_vpls,
                    )
                })
            }
            _ => None,
        };

        let mut flags = match mode {
            Mode::Direct => shade::FLAG_DIRECT,
            Mode::Full | Mode::Naive => {
                shade::FLAG_DIRECT | shade::FLAG_STATIC_VPL | shade::FLAG_VISIBILITY
            }
            Mode::Indirect => shade::FLAG_STATIC_VPL | shade::FLAG_VISIBILITY,
            Mode::Rsm => shade::FLAG_DIRECT | shade::FLAG_STATIC_VPL,
        };
        if mode == Mode::Naive {
            flags |= shade::FLAG_ATLAS_ONLY;
        }
        if dyn_primary.is_some() {
            flags |= shade::FLAG_DYN_PRIMARY;
        }
        if occlusion.is_some() {
            flags |= shade::FLAG_OCCLUSION;
        }
        // Without a merge atlas there is no tile buffer: every VPL uses its
        // baked map alone (a static scene, or rsm mode).
        if merge.is_some() {
            flags |= shade::FLAG_TILES;
        }
        if dyn_vpls.is_some() && mode != Mode::Direct {
            flags |= shade::FLAG_DYNAMIC_VPL;
        }
        let params = shade::GpuShadeParams {
            size: [settings.width, settings.height],
            flags,
            n_static: baked.as_ref().map(|b| b.vpls.len() as u32).unwrap_or(0),
            map_size: baked.as_ref().map(|b| b.map_size).unwrap_or(1),
            atlas_cols: merge.as_ref().map(|m| m.atlas_cols()).unwrap_or(1),
            n_dynamic: dyn_vpls.as_ref().map(|d| d.slots()).unwrap_or(0),
            static_cols: baked.as_ref().map(|b| b.static_cols).unwrap_or(1),
            interleave: interleave::effective(settings.interleave, settings.width, settings.height),
            _pad: [0; 3],
        };
        queue.write_buffer(&shade.uniform_buf, 0, bytemuck::bytes_of(&params));
        let target = Self::make_target(device, queue, &shade, &frame_views, settings, None);
        let gi_group = Self::make_gi_group(
            device,
            &shade,
            baked.as_ref(),
            occlusion.as_ref(),
            merge.as_ref(),
            dyn_vpls.as_ref(),
        );
        Ok(Renderer {
            id: NEXT_RENDERER.fetch_add(1, Ordering::Relaxed),
            settings: settings.clone(),
            object_names: scene
                .dynamic_objects
                .iter()
                .map(|o| o.name.clone())
                .collect(),
            transforms: scene_transforms(scene, 0.0),
            scene_gpu,
            baked,
            _own_static: own_static,
            dyn_primary,
            dyn_rsm,
            occlusion,
            merge,
            gbuffer_pass,
            shade,
            target,
            gi_group,
            frame_views,
            params,
            dyn_vpls,
            timer: timer::Timer::new(device, queue, 9),
            stats: FrameStats::default(),
            wall_start: None,
        })
    }

    /// G-buffer, interleave filter, output and frame group for the
    /// settings' size; `output`: the caller's texture, or `None` for an own.
    fn make_target(
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        shade: &shade::ShadePass,
        frame_views: &FrameViews,
        settings: &RenderSettings,
        output: Option<&wgpu::Texture>,
    ) -> Target {
        let (w, h) = (settings.width, settings.height);
        let gbuffer = gbuffer::GBuffer::new(device, w, h);
        let output = output.cloned().unwrap_or_else(|| own_output(device, w, h));
        let output_view = output.create_view(&Default::default());
        let n = interleave::effective(settings.interleave, w, h);
        let mut interleave =
            (n > 1).then(|| interleave::InterleavePass::new(device, queue, [w, h], n));
        let views = [&gbuffer.views[0], &gbuffer.views[1], &gbuffer.views[2]];
        let frame_group = frame_views.bind(device, shade, views, interleave.as_mut(), &output_view);
        Target {
            gbuffer,
            interleave,
            output,
            output_view,
            frame_group,
            external_gbuffer: None,
        }
    }

    fn make_gi_group(
        device: &wgpu::Device,
        shade: &shade::ShadePass,
        baked: Option<&baked::BakedGpu>,
        occlusion: Option<&dynamic_rsm::OcclusionPass>,
        merge: Option<&merge::VplMerge>,
        dyn_vpls: Option<&dynamic_vpl::DynamicVplPass>,
    ) -> wgpu::BindGroup {
        shade.gi_group(
            device,
            &shade::GiInputs {
                vpls: baked.map(|b| &b.vpl_buf),
                occlusion: occlusion.map(|o| &o.occluded),
                vpl_tile: merge.map(|m| m.tile_buf()),
                static_maps: baked.map(|b| &b.static_maps),
                atlas: merge.map(|m| m.atlas_view()),
                dyn_vpls: dyn_vpls.map(|d| &d.vpls),
                vpl_nodes: baked.map(|b| &b.node_buf),
            },
        )
    }

    /// The moving objects: handle and name, in the scene's order.
    pub fn objects(&self) -> impl Iterator<Item = (ObjectHandle, &str)> + '_ {
        self.object_names.iter().enumerate().map(|(i, n)| {
            (
                ObjectHandle {
                    renderer: self.id,
                    index: i as u32,
                },
                n.as_str(),
            )
        })
    }

    /// The first moving object named `name`.
    pub fn object(&self, name: &str) -> Option<ObjectHandle> {
        self.objects().find(|(_, n)| *n == name).map(|(h, _)| h)
    }

    /// The current world matrix of a moving object.
    pub fn transform(&self, object: ObjectHandle) -> Result<Mat4, RuntimeError> {
        Ok(self.transforms[self.check_handle(object)?])
    }

    fn check_handle(&self, h: ObjectHandle) -> Result<usize, RuntimeError> {
        if h.renderer != self.id || h.index() >= self.transforms.len() {
            return Err(RuntimeError::UnknownObject(h));
        }
        Ok(h.index())
    }

    /// The output size in pixels.
    pub fn size(&self) -> (u32, u32) {
        (self.settings.width, self.settings.height)
    }

    /// The interleave factor in use (1, 2, 4 or 8; resolves
    /// [`RenderSettings::interleave`] = 0 for the current size).
    pub fn interleave(&self) -> u32 {
        self.params.interleave
    }

    /// Changes the output size: a new G-buffer and output (the renderer's
    /// own again, and its own G-buffer: a caller that provided either
    /// provides it again at the new size). The camera's aspect ratio is the
    /// caller's to change.
    pub fn resize(
        &mut self,
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        width: u32,
        height: u32,
    ) -> Result<(), RuntimeError> {
        check_size(device, width, height)?;
        self.settings.width = width;
        self.settings.height = height;
        self.params.size = [width, height];
        self.params.interleave = interleave::effective(self.settings.interleave, width, height);
        queue.write_buffer(&self.shade.uniform_buf, 0, bytemuck::bytes_of(&self.params));
        self.target = Self::make_target(
            device,
            queue,
            &self.shade,
            &self.frame_views,
            &self.settings,
            None,
        );
        Ok(())
    }

    /// Renders into the caller's `texture` from now on (`None`: the
    /// renderer's own output again). It must be a 2D [`OUTPUT_FORMAT`]
    /// texture of the output size with `STORAGE_BINDING` usage.
    pub fn set_output_target(
        &mut self,
        device: &wgpu::Device,
        texture: Option<&wgpu::Texture>,
    ) -> Result<(), RuntimeError> {
        let (w, h) = self.size();
        if let Some(t) = texture {
            let problem = if t.format() != OUTPUT_FORMAT {
                Some(format!("format {:?}, needs {OUTPUT_FORMAT:?}", t.format()))
            } else if !t.usage().contains(wgpu::TextureUsages::STORAGE_BINDING) {
                Some("needs STORAGE_BINDING usage".to_string())
            } else if t.dimension() != wgpu::TextureDimension::D2 || t.sample_count() != 1 {
                Some("needs a single-sampled 2D texture".to_string())
            } else if (t.width(), t.height()) != (w, h) {
                Some(format!(
                    "{}×{}, the output is {w}×{h} (resize first)",
                    t.width(),
                    t.height()
                ))
            } else {
                None
            };
            if let Some(p) = problem {
                return Err(RuntimeError::OutputTarget(p));
            }
        }
        self.target.output = match texture {
            Some(t) => t.clone(),
            None => own_output(device, w, h),
        };
        self.target.output_view = self.target.output.create_view(&Default::default());
        self.rebind_frame(device);
        Ok(())
    }

    /// Rebinds group 0 (and the interleave filter) to the current output
    /// and G-buffer (the caller's, if it provides one).
    fn rebind_frame(&mut self, device: &wgpu::Device) {
        let t = &mut self.target;
        let g = t.external_gbuffer.as_ref().unwrap_or(&t.gbuffer.views);
        t.frame_group = self.frame_views.bind(
            device,
            &self.shade,
            [&g[0], &g[1], &g[2]],
            t.interleave.as_mut(),
            &t.output_view,
        );
    }

    /// Prepares one frame: applies the camera and the moving objects'
    /// matrices, and uploads every table and grows every buffer the frame
    /// needs (the merge atlas included). On an error nothing of the frame is
    /// recorded differently from the last successful prepare's, except the
    /// matrices.
    pub fn prepare(
        &mut self,
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        frame: &FrameInput<'_>,
    ) -> Result<(), RuntimeError> {
        // Validate everything before changing anything.
        let n = self.transforms.len();
        if !frame.transforms.is_empty() && frame.transforms.len() != n {
            return Err(RuntimeError::TransformCount {
                expected: n,
                got: frame.transforms.len(),
            });
        }
        for (h, _) in frame.moved {
            self.check_handle(*h)?;
        }
        if !frame.transforms.is_empty() {
            self.transforms.copy_from_slice(frame.transforms);
        }
        for (h, m) in frame.moved {
            self.transforms[h.index()] = *m;
        }
        if n > 0 {
            self.scene_gpu
                .set_dynamic_transforms(queue, &self.transforms);
        }
        queue.write_buffer(
            &self.gbuffer_pass.uniform_buf,
            0,
            bytemuck::bytes_of(&frame.camera.to_gpu()),
        );

        let mut stats = FrameStats {
            static_vpls: self.params.n_static,
            dynamic_vpl_slots: self.params.n_dynamic,
            ..Default::default()
        };
        let mut calls = 0u32;
        let mut planned: Vec<&'static str> = Vec::new();
        if self.dyn_primary.is_some() {
            planned.push("primary merge");
            calls += self.scene_gpu.dynamic_draws.len() as u32;
        }
        if self.dyn_rsm.is_some() && self.occlusion.is_some() {
            planned.push("dynamic rsm");
            calls += self.scene_gpu.dynamic_draws.len() as u32;
            planned.push("occlusion");
            if self.dyn_vpls.is_some() {
                planned.push("dynamic vpls");
            }
        }
        if let Some(m) = self.merge.as_mut() {
            let grown = m.prepare(device, queue, &self.scene_gpu, &self.transforms)?;
            if grown {
                self.params.atlas_cols = m.atlas_cols();
                queue.write_buffer(&self.shade.uniform_buf, 0, bytemuck::bytes_of(&self.params));
                self.gi_group = Self::make_gi_group(
                    device,
                    &self.shade,
                    self.baked.as_ref(),
                    self.occlusion.as_ref(),
                    self.merge.as_ref(),
                    self.dyn_vpls.as_ref(),
                );
            }
            let m = self.merge.as_ref().expect("matched above");
            stats.affected_maps = m.affected();
            if m.affected() > 0 {
                planned.push("vpl maps");
                calls += m.draw_calls();
            }
        }
        stats.update_draw_calls = calls;
        if self.target.external_gbuffer.is_none() {
            planned.push("gbuffer");
            calls +=
                (self.scene_gpu.static_draws.len() + self.scene_gpu.dynamic_draws.len()) as u32;
        }
        planned.push("shade");
        if self.target.interleave.is_some() {
            planned.push("interleave");
        }
        stats.draw_calls = calls;
        if let Some(t) = self.timer.as_mut() {
            t.reset();
            for p in planned {
                t.plan(p);
            }
        }
        self.stats = stats;
        self.wall_start = Some(Instant::now());
        Ok(())
    }

    /// [`Renderer::prepare`] for the frame of `scene`'s own animation at
    /// `time`, seen by its camera ([`RuntimeError::NoCamera`] without one):
    /// what tools and tests render.
    pub fn prepare_at_time(
        &mut self,
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        scene: &Scene,
        time: f32,
    ) -> Result<(), RuntimeError> {
        let (w, h) = self.size();
        let camera = CameraMatrices::from_scene(scene, time, w, h)?;
        let transforms = scene_transforms(scene, time);
        self.prepare(
            device,
            queue,
            &FrameInput::new(camera).transforms(&transforms),
        )
    }

    /// Records the frame last prepared into `encoder`; uploads nothing.
    pub fn record(&self, encoder: &mut wgpu::CommandEncoder) {
        let timer = self.timer.as_ref();
        // 1. Moving objects into their primary shadow map.
        if let Some(p) = &self.dyn_primary {
            let ts = timer.and_then(|t| t.render("primary merge"));
            p.encode(
                encoder,
                &self.scene_gpu,
                &[&self.scene_gpu.dynamic_draws],
                ts,
            );
        }
        // 2. Moving objects' RSM, partial occlusion, dynamic VPLs.
        if let (Some(r), Some(o)) = (&self.dyn_rsm, &self.occlusion) {
            r.encode(
                encoder,
                &self.scene_gpu,
                timer.and_then(|t| t.render("dynamic rsm")),
            );
            o.encode(encoder, timer.and_then(|t| t.compute("occlusion")));
            if let Some(d) = &self.dyn_vpls {
                d.encode(encoder, timer);
            }
        }
        // 3. VPL maps.
        if let Some(m) = &self.merge {
            m.record(encoder, timer.and_then(|t| t.render("vpl maps")));
        }
        // 4. G-buffer and shading.
        if self.target.external_gbuffer.is_none() {
            let all = [
                &self.scene_gpu.static_draws[..],
                &self.scene_gpu.dynamic_draws[..],
            ];
            self.gbuffer_pass.encode(
                encoder,
                &self.target.gbuffer,
                &self.scene_gpu,
                &all,
                timer.and_then(|t| t.render("gbuffer")),
            );
        }
        self.shade.encode(
            encoder,
            &self.target.frame_group,
            &self.gi_group,
            [self.settings.width, self.settings.height],
            timer.and_then(|t| t.compute("shade")),
        );
        if let Some(il) = &self.target.interleave {
            il.encode(encoder, timer.and_then(|t| t.compute("interleave")));
        }
        if let Some(t) = timer {
            t.resolve(encoder);
        }
    }

    /// Stats of the last frame: waits for the GPU, reads the timestamps.
    pub fn stats(&mut self, device: &wgpu::Device) -> FrameStats {
        let mut s = self.stats.clone();
        match &self.timer {
            Some(t) => {
                s.timing = "gpu timestamps".into();
                s.passes = t
                    .read(device)
                    .into_iter()
                    .map(|(n, ms)| (n.to_string(), ms))
                    .collect();
            }
            None => {
                let _ = device.poll(wgpu::PollType::wait_indefinitely());
                s.timing = "wall (no timestamp queries on this adapter)".into();
                let ms = self
                    .wall_start
                    .map(|w| w.elapsed().as_secs_f64() * 1e3)
                    .unwrap_or(0.0);
                s.passes = vec![("frame".into(), ms)];
            }
        }
        s
    }

    /// The renderer's own G-buffer textures, in [`GBUFFER_FORMATS`] order.
    pub fn gbuffer_textures(&self) -> &[wgpu::Texture] {
        &self.target.gbuffer.textures
    }

    /// The renderer's own G-buffer views, in [`GBUFFER_FORMATS`] order.
    pub fn gbuffer_views(&self) -> &[wgpu::TextureView; 3] {
        &self.target.gbuffer.views
    }

    /// The frame's linear radiance ([`OUTPUT_FORMAT`], row 0 at the top,
    /// `TEXTURE_BINDING` usage): the renderer's own texture, or the one given
    /// to [`Renderer::set_output_target`].
    pub fn output(&self) -> &wgpu::Texture {
        &self.target.output
    }

    /// A view of [`Renderer::output`].
    pub fn output_view(&self) -> &wgpu::TextureView {
        &self.target.output_view
    }

    /// Shades the game's own G-buffer instead of rendering one: three views
    /// of output-sized textures in [`GBUFFER_FORMATS`] with
    /// `TEXTURE_BINDING` usage — 0: world position (xyz) and coverage (w = 1
    /// where a surface is, 0 elsewhere), 1: octahedral-encoded shading
    /// normal (xy) and geometric normal (zw), both facing the viewer (see
    /// `oct_encode` in the shared `common.wgsl`), 2: linear albedo (rgb).
    /// After this call [`Renderer::record`] skips its G-buffer pass, until
    /// [`Renderer::resize`], after which the caller provides its G-buffer
    /// again.
    pub fn use_external_gbuffer(&mut self, device: &wgpu::Device, views: [&wgpu::TextureView; 3]) {
        self.target.external_gbuffer = Some(views.map(|v| v.clone()));
        self.rebind_frame(device);
    }

    /// Whether any resource for moving objects exists (merge maps, dynamic
    /// RSM, occlusion sums, merge atlas, dynamic VPLs). False for a scene
    /// without moving objects: nothing is allocated for them.
    pub fn has_dynamic_resources(&self) -> bool {
        self.dyn_primary.is_some()
            || self.dyn_rsm.is_some()
            || self.occlusion.is_some()
            || self.merge.is_some()
            || self.dyn_vpls.is_some()
    }

    /// GPU bytes uploaded from the asset.
    pub fn asset_bytes(&self) -> u64 {
        self.baked.as_ref().map(|b| b.bytes).unwrap_or(0)
    }

    /// Reads the output back (waits for the GPU), box-filtered by `ssaa`.
    pub fn read_output(
        &self,
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        ssaa: u32,
    ) -> Result<Image, RuntimeError> {
        let out = self.output();
        let data = gibake_gpu::readback::read_texture_f32_on(device, queue, out, 0, 4)?;
        let img = Image::from_rgba_f32(out.width(), out.height(), &data);
        Ok(gibake_image::box_downsample(&img, ssaa.max(1)))
    }
}

/// Renders one frame of `scene`'s animation at `time`, seen by its camera,
/// and reads it back. `ssaa` renders at `ssaa ×` the resolution and
/// box-filters down (an unbiased pixel integral, like the reference's
/// jittered samples).
pub fn render_image(
    device: &wgpu::Device,
    queue: &wgpu::Queue,
    scene: &Scene,
    asset: Option<&Asset>,
    settings: &RenderSettings,
    time: f32,
    ssaa: u32,
) -> Result<Image, RuntimeError> {
    let ssaa = ssaa.max(1);
    let mut hi = settings.clone();
    hi.width = settings.width * ssaa;
    hi.height = settings.height * ssaa;
    // The camera first: no GPU work for a scene without one.
    CameraMatrices::from_scene(scene, time, hi.width, hi.height)?;
    let mut renderer = Renderer::new(device, queue, scene, asset, &hi)?;
    renderer.prepare_at_time(device, queue, scene, time)?;
    let mut enc = device.create_command_encoder(&Default::default());
    renderer.record(&mut enc);
    queue.submit([enc.finish()]);
    renderer.read_output(device, queue, ssaa)
}
