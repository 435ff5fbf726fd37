//! What a [`crate::Renderer`] renders: the [`Mode`] and the
//! [`RenderSettings`], checked against the caller's device before anything
//! is created.

use crate::{RuntimeError, interleave};

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

/// Whether the primary directional light's direct term is shadowed by
/// cascades fitted to the main view ([`RenderSettings::cascades`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum Cascades {
    /// On when the single primary map's texel is coarse against what the
    /// camera sees (see `runtime/src/cascades.rs`): a large level gets
    /// them, a small scene keeps exactly the single map.
    #[default]
    Auto,
    /// Always (directional light only: a spot light keeps its map).
    On,
    /// Never: the single primary map, as baked.
    Off,
}

/// Settings of a [`crate::Renderer`].
#[derive(Clone, Debug)]
pub struct RenderSettings {
    /// Output width in pixels ([`crate::Renderer::resize`] changes it).
    pub width: u32,
    /// Output height in pixels.
    pub height: u32,
    /// Primary shadow map resolution when no asset is given (direct mode);
    /// with an asset, the baked map's resolution is used.
    pub shadow_map_size: u32,
    /// What to render.
    pub mode: Mode,
    /// Most dynamic VPLs per frame of the first light (rounded up to a
    /// power of 4; 0: none, in every light).
    pub max_dynamic_vpls: u32,
    /// Most dynamic VPLs per view of the lights after the first that the
    /// moving objects touch in a frame (format 4.1's bounce off moving
    /// objects in every light; rounded up to a power of 4): shading reads
    /// `(4^(d+1) − 1)/3` slots per touched view, `d = ceil(log4 N)` (21 at
    /// the default 16), so a frame whose moving objects touch many lamp
    /// views stays affordable (measured in docs/results.md, "Every light").
    pub max_dynamic_vpls_per_view: u32,
    /// Interleaved VPL sampling: 1 (every pixel sums every VPL), 2, 4 or 8
    /// (each pixel of an N×N block sums a disjoint 1/N² of the VPLs, and a
    /// geometry-aware filter over its neighbours reconstructs the sum), or
    /// 0 (the default: 4 from 256² output pixels on, else 1 — measured, see
    /// docs/results.md; re-chosen on [`crate::Renderer::resize`]). Other values are
    /// [`RuntimeError::InvalidSetting`]. [`crate::Renderer::interleave`] says which
    /// factor is in use.
    pub interleave: u32,
    /// Most moving objects [`crate::Renderer::spawn`] adds over the renderer's
    /// life (copies of the scene's declared ones; room for their draws is
    /// made at creation).
    pub max_spawned: u32,
    /// Cascaded shadow maps for the direct light of a directional primary
    /// light ([`Cascades::Auto`] by default; [`crate::FramePlan::cascades`]
    /// says what was chosen).
    pub cascades: Cascades,
    /// Resolution of each cascade (0, the default: chosen from the level's
    /// extent against the camera's pixel, see `cascades.rs`).
    pub cascade_map_size: u32,
    /// Light culling in shading (on by default): each 8×8 tile of pixels
    /// skips the lights after the first whose glTF `range` ends before
    /// every surface of the tile, or whose spot cone misses them all.
    /// Exact — a culled light adds exactly 0 there — and planned only
    /// where some light after the first has a range or is a spot
    /// ([`crate::FramePlan::shade_flags`]); off is for measuring it.
    pub light_culling: bool,
    /// Moving objects far apart in one light view bounce in a window each
    /// (on by default): up to four groups of objects, each clustered with a
    /// quarter of the view's dynamic-VPL slots at one level less, so each
    /// object gets finer cells than one window around all of them would
    /// give (docs/method.md, "Objects far apart"). Off: one window around
    /// every object the view sees; for measuring what the split buys
    /// (`gibake bench scaling`, "moving objects far apart").
    pub split_windows: bool,
    /// The static VPLs' near-field descent, in disk radii `√(A/π)`: a
    /// level-1 or level-2 node of a VPL's tree is drawn as its four
    /// children where the receiver is nearer than this many of its radii,
    /// and the VPL as its level-1 nodes nearer than twice as many of its
    /// own (docs/method.md, "Descent ratio"). 8 by default; 4, the rule
    /// before session 19, costs about 0.6× the shade pass and is darker on
    /// clusters whose parts face different ways (the garden level −7.6%
    /// against −6.8% red; docs/results.md, "Real levels"). A finest
    /// node's light skips the map test within half of it, at most 4 of
    /// its radii (shade.wgsl `open_ratio`). From 4 to 32, else
    /// [`RuntimeError::InvalidSetting`].
    pub near_field_descent: u32,
    /// The later bounces' VPLs' near-field descent (an asset baked with
    /// every bounce, format 4.6), as [`RenderSettings::near_field_descent`]
    /// for the first bounce's; 0 draws each as one disk with its far-field
    /// lobe at every receiver. A later VPL gathers the light of a wide
    /// stretch of the static surfaces (radii of a metre in a living room),
    /// so at the first bounce's descent its tree descends at nearly every
    /// pixel of the room: each cost about 3.5× a first-bounce VPL's shading.
    /// Its light is smooth; what its tree buys is measured in
    /// docs/method.md, "Every bounce" → "Frame cost"; its finest nodes'
    /// light skips the map test within half of it (at the default 4: 2 of
    /// their radii; docs/method.md, "The surfels' share, the later VPLs'
    /// open share and their finest nodes"). From 0 to 32, else
    /// [`RuntimeError::InvalidSetting`].
    pub later_near_field_descent: u32,
    /// Shade the later bounces' VPLs at every pixel, as the first bounce's
    /// (off by default: an interleaved view shades them on a
    /// half-resolution grid and its interleave filter brings them up to
    /// full resolution; a view with interleave 1 always shades them at
    /// every pixel). Their light is smooth and each later VPL's tree
    /// descends nearly everywhere, so the half-resolution grid costs about
    /// a quarter of their shading; what it changes in the image is
    /// measured in docs/method.md, "Every bounce" → "Frame cost: the later bounces at half resolution". On:
    /// for measuring that.
    pub later_full_resolution: bool,
    /// The largest share of each moving object's shadow in the static
    /// VPLs' light that the VPL-map merge may leave out, its faintest
    /// first: per moving draw, the maps whose VPL loses least light to it
    /// (a VPL across the level from a small object) are not drawn into
    /// while their light in all stays within this share of the light the
    /// draw takes from every map it reaches
    /// ([`crate::FrameStats::merge_faint_pairs`] counts them). Measured in
    /// docs/method.md, "The VPL-map merge" → "Faint shadows left out". 0:
    /// every map a moving object reaches. From 0 to 0.5, else
    /// [`RuntimeError::InvalidSetting`].
    pub merge_cull_share: f32,
}

/// [`RenderSettings::near_field_descent`] by default (the CPU twin's
/// `gibake_eval::transport::DESCENT_RATIO`).
pub const DEFAULT_NEAR_FIELD_DESCENT: u32 = 8;

/// [`RenderSettings::merge_cull_share`] by default.
pub const DEFAULT_MERGE_CULL_SHARE: f32 = 0.05;

/// [`RenderSettings::later_near_field_descent`] by default.
pub const DEFAULT_LATER_NEAR_FIELD_DESCENT: u32 = 4;

impl Default for RenderSettings {
    fn default() -> Self {
        RenderSettings {
            max_dynamic_vpls: 256,
            max_dynamic_vpls_per_view: 16,
            width: 640,
            height: 480,
            shadow_map_size: 2048,
            mode: Mode::Full,
            interleave: interleave::AUTO,
            max_spawned: 16,
            cascades: Cascades::Auto,
            cascade_map_size: 0,
            light_culling: true,
            split_windows: true,
            near_field_descent: DEFAULT_NEAR_FIELD_DESCENT,
            later_near_field_descent: DEFAULT_LATER_NEAR_FIELD_DESCENT,
            later_full_resolution: false,
            merge_cull_share: DEFAULT_MERGE_CULL_SHARE,
        }
    }
}

impl RenderSettings {
    /// Checks the settings on their own and against `device` (sizes within
    /// its largest 2D texture; `with_asset`: the baked primary map's size
    /// is used, not [`RenderSettings::shadow_map_size`]).
    pub(crate) fn check(
        &self,
        device: &wgpu::Device,
        with_asset: bool,
    ) -> Result<(), RuntimeError> {
        check_interleave(self.interleave)?;
        if !(4..=32).contains(&self.near_field_descent) {
            return Err(RuntimeError::InvalidSetting(format!(
                "near-field descent {} must be from 4 to 32 disk radii",
                self.near_field_descent
            )));
        }
        if self.later_near_field_descent > 32 {
            return Err(RuntimeError::InvalidSetting(format!(
                "the later bounces' near-field descent {} must be from 0 to 32 disk radii",
                self.later_near_field_descent
            )));
        }
        if !(0.0..=0.5).contains(&self.merge_cull_share) {
            return Err(RuntimeError::InvalidSetting(format!(
                "the merge's cull share {} must be from 0 to 0.5",
                self.merge_cull_share
            )));
        }
        crate::view::check_size(device, self.width, self.height, self.interleave)?;
        let limit = device.limits().max_texture_dimension_2d;
        if self.shadow_map_size == 0 {
            return Err(RuntimeError::InvalidSetting(
                "shadow map size must be at least 1".into(),
            ));
        }
        if self.cascade_map_size > limit {
            return Err(RuntimeError::DeviceLimit {
                what: format!("cascades of {}²", self.cascade_map_size),
                needed: u64::from(self.cascade_map_size),
                limit: u64::from(limit),
            });
        }
        if !with_asset && self.shadow_map_size > limit {
            return Err(RuntimeError::DeviceLimit {
                what: format!("a shadow map of {}²", self.shadow_map_size),
                needed: u64::from(self.shadow_map_size),
                limit: u64::from(limit),
            });
        }
        Ok(())
    }
}

/// Refuses an interleave factor other than 0 (automatic), 1, 2, 4, 8.
pub(crate) fn check_interleave(n: u32) -> Result<(), RuntimeError> {
    if !interleave::VALID.contains(&n) {
        return Err(RuntimeError::InvalidSetting(format!(
            "interleave {n} must be 0 (automatic), 1, 2, 4 or 8"
        )));
    }
    Ok(())
}
