//! The frame plan: the one place that decides which passes a frame has.
//!
//! [`FramePlan::new`] looks at the mode, the asset, the scene's light and
//! its moving objects once, when a [`crate::Renderer`] is created (again on
//! [`crate::Renderer::set_asset`]), and fixes
//!
//! - which per-frame passes exist ([`Pass`], a typed id that also keys the
//!   GPU timers and the [`crate::FrameStats`]);
//! - the shading flags ([`ShadeFlag`]), whose WGSL constants are generated
//!   from the Rust definition here ([`ShadeFlag::wgsl`]), never copied by
//!   hand.
//!
//! Which of the planned passes a given frame records depends only on that
//! frame's state: the VPL-map merge is skipped when no map is affected, the
//! G-buffer pass when the caller provides its own, the interleave filter
//! when a view sums every VPL ([`FramePlan::recorded`]).

use crate::cascades::CascadeLayout;
use crate::{Mode, RenderSettings, RuntimeError};
use gibake_asset::Asset;
use gibake_scene::Scene;

/// A pass of a frame, in recording order.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum Pass {
    /// Moving objects into their own primary shadow map (z-min merge with
    /// the baked one at shading).
    PrimaryMerge,
    /// Moving objects into the shadow maps of the other lights' views
    /// their bounds touch this frame (one small pass per view touched).
    LightMerge,
    /// Cascaded shadow maps fitted to the main view (a large level's direct
    /// light): static draws when a cascade moved, moving objects every
    /// frame.
    Cascades,
    /// Moving objects into an RSM at the bake's RSM resolution.
    DynamicRsm,
    /// The static VPLs' lit fraction from the dynamic RSM.
    Occlusion,
    /// The dynamic RSM clustered into dynamic VPLs on the GPU.
    DynamicVpls,
    /// The bounce off moving objects in the other lights' views they touch
    /// this frame, each view with a static RSM in the asset (format 4.1):
    /// per view, its dynamic RSM, occlusion and dynamic VPLs.
    LightBounce,
    /// Moving objects rasterized into the tiles of the VPL maps they reach
    /// (`naive`: every map re-rendered from all geometry).
    VplMaps,
    /// The camera G-buffer (per view; skipped when the caller provides one).
    GBuffer,
    /// Deferred shading (per view).
    Shade,
    /// The interleaved-sampling filter (per view, interleave > 1).
    Interleave,
    /// The view's radiance written or added into the caller's render target
    /// (per view, only for such a target).
    Composite,
}

impl Pass {
    /// Every pass, in recording order.
    pub const ALL: [Pass; 12] = [
        Pass::PrimaryMerge,
        Pass::LightMerge,
        Pass::Cascades,
        Pass::DynamicRsm,
        Pass::Occlusion,
        Pass::DynamicVpls,
        Pass::LightBounce,
        Pass::VplMaps,
        Pass::GBuffer,
        Pass::Shade,
        Pass::Interleave,
        Pass::Composite,
    ];

    /// Its name in stats and reports (`"primary merge"`, `"vpl maps"`, ...).
    pub fn name(self) -> &'static str {
        match self {
            Pass::PrimaryMerge => "primary merge",
            Pass::LightMerge => "light merge",
            Pass::Cascades => "cascades",
            Pass::DynamicRsm => "dynamic rsm",
            Pass::Occlusion => "occlusion",
            Pass::DynamicVpls => "dynamic vpls",
            Pass::LightBounce => "light bounce",
            Pass::VplMaps => "vpl maps",
            Pass::GBuffer => "gbuffer",
            Pass::Shade => "shade",
            Pass::Interleave => "interleave",
            Pass::Composite => "composite",
        }
    }

    /// Whether it belongs to the per-frame update of the moving objects (the
    /// shared, once-per-frame part), not to a view's G-buffer and shading.
    pub fn is_update(self) -> bool {
        !matches!(
            self,
            Pass::GBuffer | Pass::Shade | Pass::Interleave | Pass::Composite
        )
    }

    /// Position in [`Pass::ALL`].
    pub(crate) fn index(self) -> usize {
        self as usize
    }
}

impl std::fmt::Display for Pass {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

impl serde::Serialize for Pass {
    fn serialize<S: serde::Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        s.serialize_str(self.name())
    }
}

/// A set of [`Pass`]es.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct PassSet(u32);

impl PassSet {
    /// With `pass` added.
    pub fn with(self, pass: Pass) -> PassSet {
        PassSet(self.0 | 1 << pass.index())
    }

    /// With `pass` added if `on`.
    pub fn with_if(self, pass: Pass, on: bool) -> PassSet {
        if on { self.with(pass) } else { self }
    }

    /// Whether `pass` is in the set.
    pub fn has(self, pass: Pass) -> bool {
        self.0 & (1 << pass.index()) != 0
    }

    /// The passes, in recording order.
    pub fn iter(self) -> impl Iterator<Item = Pass> {
        Pass::ALL.into_iter().filter(move |p| self.has(*p))
    }
}

/// A bit of the shading pass's `flags`: what shading reads and adds.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[repr(u32)]
pub enum ShadeFlag {
    /// Direct light.
    Direct = 1,
    /// Static VPLs.
    StaticVpl = 2,
    /// Dynamic VPLs.
    DynamicVpl = 4,
    /// VPL visibility from hemisphere maps (off in `rsm` mode).
    Visibility = 8,
    /// Every VPL map is a merge-atlas tile (`naive`).
    AtlasOnly = 16,
    /// Moving objects drawn into the primary map.
    DynPrimary = 32,
    /// Partial occlusion of static VPLs.
    Occlusion = 64,
    /// Moving objects are merged into VPL map tiles (`vpl_tile` is bound).
    Tiles = 128,
    /// Direct light shadowed by cascades where they hold the point.
    Cascades = 256,
    /// The lights after the first are culled per 8×8 tile by their range
    /// and a spot's cone (`other_lights.wgsl`).
    CullLights = 512,
}

impl ShadeFlag {
    /// Every flag.
    pub const ALL: [ShadeFlag; 10] = [
        ShadeFlag::Direct,
        ShadeFlag::StaticVpl,
        ShadeFlag::DynamicVpl,
        ShadeFlag::Visibility,
        ShadeFlag::AtlasOnly,
        ShadeFlag::DynPrimary,
        ShadeFlag::Occlusion,
        ShadeFlag::Tiles,
        ShadeFlag::Cascades,
        ShadeFlag::CullLights,
    ];

    /// The WGSL constant's name.
    fn wgsl_name(self) -> &'static str {
        match self {
            ShadeFlag::Direct => "FLAG_DIRECT",
            ShadeFlag::StaticVpl => "FLAG_STATIC_VPL",
            ShadeFlag::DynamicVpl => "FLAG_DYNAMIC_VPL",
            ShadeFlag::Visibility => "FLAG_VISIBILITY",
            ShadeFlag::AtlasOnly => "FLAG_ATLAS_ONLY",
            ShadeFlag::DynPrimary => "FLAG_DYN_PRIMARY",
            ShadeFlag::Occlusion => "FLAG_OCCLUSION",
            ShadeFlag::Tiles => "FLAG_TILES",
            ShadeFlag::Cascades => "FLAG_CASCADES",
            ShadeFlag::CullLights => "FLAG_CULL_LIGHTS",
        }
    }

    /// `const FLAG_…: u32 = …u;` for every flag: the shading WGSL's
    /// definition of the bits, generated from this enum.
    pub(crate) fn wgsl() -> String {
        ShadeFlag::ALL
            .iter()
            .map(|f| format!("const {}: u32 = {}u;\n", f.wgsl_name(), *f as u32))
            .collect()
    }
}

/// What a frame of one renderer consists of, decided once from the mode,
/// the asset, the light and the moving objects.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct FramePlan {
    mode: Mode,
    passes: PassSet,
    flags: u32,
    cascades: Option<CascadeLayout>,
    descent: u32,
    /// [`RenderSettings::later_near_field_descent`].
    later_descent: u32,
    /// The later bounces' VPLs shaded (0: none in the asset, or a mode
    /// that shades no static VPL).
    later_vpls: u32,
}

impl FramePlan {
    /// The plan for `settings.mode` over `scene` with `asset` (every mode
    /// but `Direct` needs one: [`RuntimeError::NeedsAsset`]).
    ///
    /// - primary merge: the scene has moving objects (every mode) and its
    ///   first light the primary maps (not a point light);
    /// - light merge: moving objects, direct light shaded, and a view of a
    ///   light after the first that their swept bounds can enter
    ///   ([`gibake_gpu::LightView::may_see`]);
    /// - dynamic RSM and occlusion: moving objects, an asset that stores its
    ///   RSM, an indirect mode;
    /// - dynamic VPLs: as the dynamic RSM, with `max_dynamic_vpls > 0`;
    /// - VPL maps: `naive` always (the re-render), `full` and `indirect`
    ///   with moving objects;
    /// - cascades: a directional light, direct light shaded, and
    ///   [`RenderSettings::cascades`] on, or automatic and the single
    ///   primary map coarse against what the camera sees
    ///   ([`crate::cascades::choose`]);
    /// - G-buffer, shading, interleave: per view.
    pub fn new(
        settings: &RenderSettings,
        scene: &Scene,
        asset: Option<&Asset>,
    ) -> Result<FramePlan, RuntimeError> {
        let mode = settings.mode;
        if asset.is_none() && mode != Mode::Direct {
            return Err(RuntimeError::NeedsAsset(mode.name()));
        }
        let moving = !scene.dynamic_objects.is_empty();
        let indirect = asset.is_some() && mode != Mode::Direct;
        let rsm = moving && indirect && asset.is_some_and(|a| a.rsm.is_some());
        // The other lights' bounce off moving objects (format 4.1 assets).
        let light_bounce = moving && indirect && asset.is_some_and(|a| !a.view_rsms.is_empty());
        let vpl_maps = asset.is_some()
            && match mode {
                Mode::Naive => true,
                Mode::Full | Mode::Indirect => moving,
                Mode::Direct | Mode::Rsm => false,
            };
        let primary = match asset {
            Some(a) => crate::baked::light_view(a, a.primary_depth.size),
            None => gibake_gpu::LightView::for_scene(scene, settings.shadow_map_size),
        };
        let cascades = if matches!(mode, Mode::Indirect) {
            None
        } else {
            crate::cascades::choose(
                settings.cascades,
                scene,
                &primary,
                settings.height,
                settings.cascade_map_size,
            )
        };
        let passes = PassSet::default()
            .with_if(
                Pass::PrimaryMerge,
                moving && crate::light::has_primary(scene),
            )
            .with_if(
                Pass::LightMerge,
                moving
                    && mode != Mode::Indirect
                    && !crate::other_lights::movable(
                        &crate::other_lights::views_of(scene, asset, settings.shadow_map_size).0,
                        &scene.dynamic_swept_bounds(),
                    )
                    .is_empty(),
            )
            .with_if(Pass::Cascades, cascades.is_some())
            .with_if(Pass::DynamicRsm, rsm)
            .with_if(Pass::Occlusion, rsm)
            .with_if(Pass::DynamicVpls, rsm && settings.max_dynamic_vpls > 0)
            .with_if(Pass::LightBounce, light_bounce)
            .with_if(Pass::VplMaps, vpl_maps)
            .with(Pass::GBuffer)
            .with(Pass::Shade)
            .with(Pass::Interleave)
            .with(Pass::Composite);
        use ShadeFlag as F;
        let mut flags = match mode {
            Mode::Direct => F::Direct as u32,
            Mode::Full | Mode::Naive => {
                F::Direct as u32 | F::StaticVpl as u32 | F::Visibility as u32
            }
            Mode::Indirect => F::StaticVpl as u32 | F::Visibility as u32,
            Mode::Rsm => F::Direct as u32 | F::StaticVpl as u32,
        };
        for (on, flag) in [
            (mode == Mode::Naive, F::AtlasOnly),
            (passes.has(Pass::PrimaryMerge), F::DynPrimary),
            (
                passes.has(Pass::Occlusion) || passes.has(Pass::LightBounce),
                F::Occlusion,
            ),
            // Without a merge atlas there is no tile buffer: every VPL uses
            // its baked map alone (a static scene, or rsm mode).
            (passes.has(Pass::VplMaps), F::Tiles),
            (
                passes.has(Pass::DynamicVpls)
                    || (passes.has(Pass::LightBounce) && settings.max_dynamic_vpls > 0),
                F::DynamicVpl,
            ),
            (passes.has(Pass::Cascades), F::Cascades),
            (
                flags & F::Direct as u32 != 0
                    && settings.light_culling
                    && crate::light::other_lights_can_cull(scene),
                F::CullLights,
            ),
        ] {
            if on {
                flags |= flag as u32;
            }
        }
        Ok(FramePlan {
            mode,
            passes,
            flags,
            cascades,
            descent: settings.near_field_descent,
            later_descent: settings.later_near_field_descent,
            later_vpls: if flags & F::StaticVpl as u32 != 0 {
                asset.map_or(0, |a| a.manifest.later_vpls())
            } else {
                0
            },
        })
    }

    /// The static VPLs' near-field descent in disk radii
    /// ([`RenderSettings::near_field_descent`]).
    pub fn near_field_descent(&self) -> u32 {
        self.descent
    }

    /// The later bounces' VPLs this plan shades after the first bounce's
    /// (`gibake_asset::Manifest::later_vpls`): 0 where the bake left them
    /// out (a level lit from outside, `--bounces 1`) or the mode shades no
    /// static VPL — then no later-bounce work is done: no extra VPL shaded,
    /// no map merged, no occlusion share computed.
    pub fn later_vpls(&self) -> u32 {
        self.later_vpls
    }

    /// The later bounces' VPLs' near-field descent in disk radii, 0: one
    /// disk each ([`RenderSettings::later_near_field_descent`]).
    pub fn later_near_field_descent(&self) -> u32 {
        self.later_descent
    }

    /// The mode planned for.
    pub fn mode(&self) -> Mode {
        self.mode
    }

    /// Whether the frame has `pass` (for the per-view passes: whether a
    /// view may record it).
    pub fn has(&self, pass: Pass) -> bool {
        self.passes.has(pass)
    }

    /// The planned passes, in recording order.
    pub fn passes(&self) -> PassSet {
        self.passes
    }

    /// Whether any pass for moving objects exists (the per-frame update;
    /// `naive` re-renders the VPL maps even without moving objects).
    pub fn has_update(&self) -> bool {
        self.passes.iter().any(Pass::is_update)
    }

    /// The cascades drawn for the direct light (`None`: the single primary
    /// map alone).
    pub fn cascades(&self) -> Option<CascadeLayout> {
        self.cascades
    }

    /// The shading flags ([`ShadeFlag`] bits).
    pub fn shade_flags(&self) -> u32 {
        self.flags
    }

    /// Whether shading reads `flag`.
    pub fn shades(&self, flag: ShadeFlag) -> bool {
        self.flags & flag as u32 != 0
    }

    /// The passes one frame records, each with its view: the planned
    /// update passes once (the VPL maps only when `vpl_maps_affected`), then
    /// per view its G-buffer (unless the caller provides one as it is),
    /// shading, the filter (interleave > 1) and the composite (into a
    /// caller's render target).
    pub fn recorded(
        &self,
        vpl_maps_affected: bool,
        views: &[ViewPasses],
    ) -> Vec<(Pass, Option<u32>)> {
        let mut list: Vec<(Pass, Option<u32>)> = self
            .passes
            .iter()
            .filter(|p| p.is_update() && (*p != Pass::VplMaps || vpl_maps_affected))
            .map(|p| (p, None))
            .collect();
        for (k, v) in views.iter().enumerate() {
            let k = Some(k as u32);
            for (on, p) in [
                (v.gbuffer, Pass::GBuffer),
                (true, Pass::Shade),
                (v.interleave > 1, Pass::Interleave),
                (v.composite, Pass::Composite),
            ] {
                if on {
                    list.push((p, k));
                }
            }
        }
        list
    }
}

/// What decides a view's own passes.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct ViewPasses {
    /// The view records a G-buffer pass (its own, or one rebuilt from the
    /// caller's depth and normals).
    pub gbuffer: bool,
    /// The interleave factor in use.
    pub interleave: u32,
    /// The view's radiance goes into the caller's render target.
    pub composite: bool,
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn pass_names_are_distinct_and_ordered() {
        let names: Vec<_> = Pass::ALL.iter().map(|p| p.name()).collect();
        for (i, n) in names.iter().enumerate() {
            assert!(!names[..i].contains(n), "{n} twice");
        }
        assert!(Pass::ALL.windows(2).all(|w| w[0] < w[1]));
        assert_eq!(
            Pass::ALL.iter().filter(|p| !p.is_update()).count(),
            4,
            "G-buffer, shade, interleave, composite are the view's"
        );
    }

    #[test]
    fn wgsl_flags_come_from_the_enum() {
        let w = ShadeFlag::wgsl();
        assert!(w.contains("const FLAG_DIRECT: u32 = 1u;"));
        assert!(w.contains("const FLAG_TILES: u32 = 128u;"));
        assert_eq!(w.lines().count(), ShadeFlag::ALL.len());
        let bits: u32 = ShadeFlag::ALL.iter().map(|f| *f as u32).sum();
        assert_eq!(
            bits,
            (1 << ShadeFlag::ALL.len()) - 1,
            "one distinct bit per flag"
        );
    }
}
