//! [`inspect`]: a summary of an asset (counts, sizes, settings, provenance,
//! VPL statistics), printable (`Display`) or serialisable (`Serialize`).

use std::fmt;

use serde::Serialize;

use crate::format::{FILE_MANIFEST, FILE_VIEW_RSMS, testing::manifest_bytes};
use crate::{Asset, BakeSettings, FORMAT_MAJOR, FORMAT_MINOR, NO_MAP, Provenance};

/// Size of one file of the asset.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct FileSize {
    /// File name inside the asset directory.
    pub name: String,
    /// Size in bytes.
    pub bytes: u64,
}

/// Order statistics of a set of values (all 0 when empty).
#[derive(Clone, Debug, Default, PartialEq, Serialize)]
pub struct Stats {
    /// Number of values.
    pub count: usize,
    /// Sum.
    pub total: f64,
    /// Smallest.
    pub min: f64,
    /// Median (mean of the two middle values for an even count).
    pub median: f64,
    /// Largest.
    pub max: f64,
    /// Mean.
    pub mean: f64,
}

impl Stats {
    /// Statistics of `values` (NaN sorts last; none are expected).
    pub fn of(values: impl IntoIterator<Item = f64>) -> Stats {
        let mut v: Vec<f64> = values.into_iter().collect();
        if v.is_empty() {
            return Stats::default();
        }
        v.sort_by(f64::total_cmp);
        let n = v.len();
        let total: f64 = v.iter().sum();
        let median = if n % 2 == 1 {
            v[n / 2]
        } else {
            0.5 * (v[n / 2 - 1] + v[n / 2])
        };
        Stats {
            count: n,
            total,
            min: v[0],
            median,
            max: v[n - 1],
            mean: total / n as f64,
        }
    }
}

/// Coverage of a distance/metric map.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct MapStats {
    /// Resolution (square) of one map.
    pub size: u32,
    /// Number of maps (layers).
    pub layers: u32,
    /// Fraction of texels that see a surface (finite value).
    pub covered_fraction: f64,
    /// Smallest finite value (0 when none).
    pub min: f64,
    /// Largest finite value (0 when none).
    pub max: f64,
}

impl MapStats {
    fn of(size: u32, layers: u32, data: &[f32]) -> MapStats {
        MapStats::of_texels(size, layers, data, data.len())
    }

    /// Over `data`, of which `texels` are map texels (the rest: an atlas's
    /// unused, all-infinite tiles).
    fn of_texels(size: u32, layers: u32, data: &[f32], texels: usize) -> MapStats {
        let (mut n, mut lo, mut hi) = (0usize, f64::INFINITY, f64::NEG_INFINITY);
        for &x in data.iter().filter(|x| x.is_finite()) {
            n += 1;
            lo = lo.min(x as f64);
            hi = hi.max(x as f64);
        }
        let covered_fraction = if texels == 0 {
            0.0
        } else {
            n as f64 / texels as f64
        };
        let (min, max) = if n == 0 { (0.0, 0.0) } else { (lo, hi) };
        MapStats {
            size,
            layers,
            covered_fraction,
            min,
            max,
        }
    }
}

/// The summary [`inspect`] returns.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Inspection {
    /// Format version this summary was made with (`major.minor`).
    pub format_version: String,
    /// Provenance (baker, scene, adapter).
    pub provenance: Provenance,
    /// Bake settings.
    pub settings: BakeSettings,
    /// Static scene hash (64 hex digits).
    pub static_scene_hash: String,
    /// The primary lights baked.
    pub lights: Vec<crate::LightRecord>,
    /// Per light, its VPLs on its outer rings (format 4.3; empty when none
    /// has any: [`crate::Manifest::ring_vpls`]).
    pub ring_vpls: Vec<u32>,
    /// The scene options the bake applied (format 4.4,
    /// [`crate::Manifest::scene_options`]; `None`: not recorded).
    pub scene_options: Option<crate::SceneOptions>,
    /// The same as the bake's command-line flags (`--sun 173,60 --dynamic
    /// 'Cylinder*'`; empty for none; `None`: not recorded): what to give
    /// `gibake reference`, which takes no asset.
    pub scene_flags: Option<String>,
    /// The bounces after the first (format 4.6, [`crate::Manifest::later`];
    /// `None`: the first bounce alone).
    pub later: Option<crate::LaterRecord>,
    /// Where the later VPLs' light came from (format 4.8): the source
    /// groups the first bounce's VPLs fall in, and the mean share of a
    /// later VPL's light its named groups carry (`None`: not recorded).
    pub later_sources: Option<(usize, f32)>,
    /// Shadow-map views of the lights after the first (a point light's six
    /// faces, a spot's or sun's one).
    pub views: usize,
    /// How many of them store a map in `light_maps.exr` (the others hold
    /// no surface).
    pub light_maps_stored: usize,
    /// Their maps' resolution (0 without views).
    pub light_map_size: u32,
    /// The primary maps' view: `"spot"` (a perspective view) or
    /// `"directional"`.
    pub light: String,
    /// Light origin.
    pub light_origin: [f32; 3],
    /// Light direction.
    pub light_direction: [f32; 3],
    /// Number of VPLs.
    pub vpl_count: usize,
    /// Number of stored hemisphere maps.
    pub map_count: usize,
    /// VPLs whose map is not stored (it sees no surface).
    pub vpls_without_map: usize,
    /// VPLs with a second origin for the light below their horizon
    /// (format 4.7, [`crate::LowerVpl`]).
    pub vpls_with_lower: usize,
    /// Second hemisphere maps stored (the others of those VPLs see no
    /// surface).
    pub lower_map_count: usize,
    /// Whether the scene has moving objects (RSM stored).
    pub has_dynamic: bool,
    /// Size of every file, `manifest.bin` first (empty list of data files if
    /// the asset was never written or loaded).
    pub files: Vec<FileSize>,
    /// Sum of `files`.
    pub total_bytes: u64,
    /// Total VPL flux (W, RGB).
    pub total_flux: [f64; 3],
    /// Luminance of VPL flux.
    pub flux_luminance: Stats,
    /// VPL areas (world units²).
    pub area: Stats,
    /// RSM texels per VPL.
    pub texels: Stats,
    /// The primary shadow map.
    pub primary_depth: MapStats,
    /// The hemisphere maps.
    pub vpl_maps: MapStats,
    /// The RSM metric (`None` without moving objects).
    pub rsm: Option<MapStats>,
    /// How many views store a static RSM in `view_rsms.exr` (format 4.1:
    /// the views of other lights moving objects can enter; 0 without).
    pub view_rsms: usize,
    /// Their resolution (`rsm_size`; 0 when none is stored).
    pub view_rsm_size: u32,
    /// The size of `view_rsms.exr` (0 when not stored).
    pub view_rsms_bytes: u64,
    /// The view RSMs' metric, over every tile (`None` when none is stored).
    pub view_rsm_metric: Option<MapStats>,
}

/// Summarises `asset`: counts, file sizes (from its manifest, as written or
/// loaded), settings, provenance, VPL flux/area statistics and map coverage.
pub fn inspect(asset: &Asset) -> Inspection {
    let m = &asset.manifest;
    let manifest_size = manifest_bytes(m).map(|b| b.len() as u64).unwrap_or(0);
    let mut files = vec![FileSize {
        name: FILE_MANIFEST.into(),
        bytes: manifest_size,
    }];
    files.extend(m.files.iter().map(|f| FileSize {
        name: f.name.clone(),
        bytes: f.size,
    }));
    let total_bytes = files.iter().map(|f| f.bytes).sum();
    let mut total_flux = [0f64; 3];
    for v in &asset.vpls {
        for (t, f) in total_flux.iter_mut().zip(v.flux) {
            *t += f as f64;
        }
    }
    let s = &m.settings;
    let map_count = asset.stored_map_count();
    Inspection {
        format_version: format!("{FORMAT_MAJOR}.{FORMAT_MINOR}"),
        provenance: m.provenance.clone(),
        settings: s.clone(),
        static_scene_hash: m
            .static_scene_hash
            .iter()
            .map(|b| format!("{b:02x}"))
            .collect(),
        lights: m.lights.clone(),
        ring_vpls: m.ring_vpls.clone(),
        scene_options: m.scene_options.clone(),
        scene_flags: m.scene_options.as_ref().map(|o| o.flags()),
        later: m.later.clone(),
        later_sources: m.later_sources.as_ref().map(|s| {
            let mut groups: Vec<u32> = s
                .first
                .iter()
                .filter(|(_, w)| *w > 0.0)
                .map(|(g, _)| *g)
                .collect();
            groups.sort_unstable();
            groups.dedup();
            let n = s.weights.len() / crate::SOURCES_PER_LATER_VPL;
            let named: f32 = s.weights.iter().map(|(_, w)| w).sum();
            (groups.len(), if n > 0 { named / n as f32 } else { 0.0 })
        }),
        views: m.views.len(),
        light_maps_stored: m.views.iter().filter(|v| v.tile != NO_MAP).count(),
        light_map_size: m.light_map_size,
        light: if m.light_view.directional {
            "directional"
        } else {
            "spot"
        }
        .into(),
        light_origin: m.light_view.origin,
        light_direction: m.light_view.direction,
        vpl_count: asset.vpls.len(),
        map_count,
        vpls_without_map: asset.vpls.iter().filter(|v| v.map == NO_MAP).count(),
        vpls_with_lower: asset.vpl_lower.iter().filter(|l| l.is_some()).count(),
        lower_map_count: asset.vpl_lower_maps.count() as usize,
        has_dynamic: asset.rsm.is_some(),
        files,
        total_bytes,
        total_flux,
        flux_luminance: Stats::of(asset.vpls.iter().map(|v| v.flux_luminance() as f64)),
        area: Stats::of(asset.vpls.iter().map(|v| v.area as f64)),
        texels: Stats::of(asset.vpls.iter().map(|v| v.texels as f64)),
        primary_depth: MapStats::of(asset.primary_depth.size, 1, &asset.primary_depth.data),
        vpl_maps: MapStats::of_texels(
            s.vpl_map_size,
            map_count as u32,
            asset.vpl_maps.texels(),
            map_count * (s.vpl_map_size as usize).pow(2),
        ),
        rsm: asset
            .rsm
            .as_ref()
            .map(|r| MapStats::of(r.size, 1, &r.metric)),
        view_rsms: m.view_rsms.len(),
        view_rsm_size: if m.view_rsms.is_empty() {
            0
        } else {
            s.rsm_size
        },
        view_rsms_bytes: m
            .files
            .iter()
            .find(|f| f.name == FILE_VIEW_RSMS)
            .map_or(0, |f| f.size),
        view_rsm_metric: (!asset.view_rsms.is_empty()).then(|| {
            let all: Vec<f32> = asset
                .view_rsms
                .iter()
                .flat_map(|r| r.metric.iter().copied())
                .collect();
            MapStats::of(s.rsm_size, asset.view_rsms.len() as u32, &all)
        }),
    }
}

/// Human-readable byte count.
pub(crate) fn human_bytes(b: u64) -> String {
    const UNITS: [&str; 4] = ["KiB", "MiB", "GiB", "TiB"];
    if b < 1024 {
        return format!("{b} B");
    }
    let mut v = b as f64 / 1024.0;
    let mut u = 0;
    while v >= 1024.0 && u + 1 < UNITS.len() {
        v /= 1024.0;
        u += 1;
    }
    format!("{v:.1} {}", UNITS[u])
}

fn g(x: f64) -> String {
    if x == 0.0 || (1e-3..1e5).contains(&x.abs()) {
        format!("{x:.4}")
    } else {
        format!("{x:.4e}")
    }
}

fn fmt_map(f: &mut fmt::Formatter<'_>, name: &str, m: &MapStats) -> fmt::Result {
    writeln!(
        f,
        "  {name:<14} {} x {}²  {:.1}% covered  finite range {} .. {}",
        m.layers,
        m.size,
        100.0 * m.covered_fraction,
        g(m.min),
        g(m.max)
    )
}

impl fmt::Display for Inspection {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let p = &self.provenance;
        let s = &self.settings;
        writeln!(f, "gibake asset, format {}", self.format_version)?;
        writeln!(
            f,
            "  baked by gibake {} from `{}`",
            p.baker_version, p.scene_name
        )?;
        writeln!(
            f,
            "  adapter {} ({}, driver {})",
            p.adapter, p.backend, p.driver
        )?;
        writeln!(f, "  static scene hash {}", self.static_scene_hash)?;
        match &self.scene_options {
            None => writeln!(
                f,
                "  scene flags: not recorded (an asset before format 4.4, or a library bake): give render and view the bake's own"
            )?,
            Some(o) if o.is_empty() => writeln!(
                f,
                "  scene flags: none (the level as exported: no {})",
                crate::all_flags()
            )?,
            Some(o) => writeln!(
                f,
                "  scene flags: {} (render and view apply them when given none)",
                o.flags()
            )?,
        }
        match &self.later {
            None => writeln!(
                f,
                "  bounces: the first alone (`--bounces 1`, or an asset before format 4.6)"
            )?,
            Some(l) => {
                let sum = |v: &[f32; 3]| f64::from(v[0]) + f64::from(v[1]) + f64::from(v[2]);
                let asked = match l.bounces {
                    0 => "every bounce that matters".to_string(),
                    n => format!("{n} in all"),
                };
                let what = if l.left_out {
                    format!(
                        "left out: they carry {:.2}% of the light the surfaces reflect",
                        100.0 * l.later_share()
                    )
                } else {
                    format!(
                        "{} VPLs after the first bounce's, {:.1}% of the light the surfaces reflect",
                        l.vpls,
                        100.0 * l.later_share()
                    )
                };
                writeln!(f, "  bounces: {asked}; the later ones {what}")?;
                // Light per bounce against the light reflected straight
                // from the lights.
                let direct = sum(&l.direct).max(f64::MIN_POSITIVE);
                let mut line =
                    String::from("    light reflected after each bounce (× the direct light's):");
                for (k, b) in l.per_bounce.iter().enumerate().take(8) {
                    line.push_str(&format!(" {}: {:.3}", k + 1, sum(b) / direct));
                }
                if l.per_bounce.len() > 8 {
                    let rest: f64 = l.per_bounce[8..].iter().map(sum).sum();
                    line.push_str(&format!(
                        " {}–{}: {:.3}",
                        9,
                        l.per_bounce.len(),
                        rest / direct
                    ));
                }
                if sum(&l.tail) > 0.0 {
                    line.push_str(&format!(" rest: {:.3}", sum(&l.tail) / direct));
                }
                writeln!(f, "{line}")?;
                if let Some((groups, named)) = self.later_sources {
                    writeln!(
                        f,
                        "    their sources: the first bounce's VPLs in {groups} groups; a later VPL's {} largest carry {:.0}% of its light on average (a moving object covering a light darkens the later light where it went)",
                        crate::SOURCES_PER_LATER_VPL,
                        100.0 * named
                    )?;
                }
                if !l.converged {
                    writeln!(
                        f,
                        "    the light did not die down (a closed level of albedo near 1): cut at {} bounces",
                        l.per_bounce.len()
                    )?;
                }
            }
        }
        let (o, d) = (self.light_origin, self.light_direction);
        writeln!(
            f,
            "  light view: {} at ({}, {}, {}) toward ({}, {}, {})",
            self.light, o[0], o[1], o[2], d[0], d[1], d[2]
        )?;
        for (k, l) in self.lights.iter().enumerate() {
            let (p, d, c) = (l.position, l.direction, l.color);
            let ring = match self.ring_vpls.get(k) {
                Some(&r) if r > 0 => format!(" ({r} on its outer rings)"),
                _ => String::new(),
            };
            let cone = if l.kind == crate::LIGHT_SPOT {
                format!(", cone {}–{} rad", l.inner_cone, l.outer_cone)
            } else {
                String::new()
            };
            let range = if l.range > 0.0 {
                format!(", range {}", l.range)
            } else {
                String::new()
            };
            writeln!(
                f,
                "  light '{}': {} at ({}, {}, {}) toward ({}, {}, {}), colour × intensity ({}, {}, {}){cone}{range}; {} VPLs{ring}",
                l.name,
                l.kind_name(),
                p[0],
                p[1],
                p[2],
                d[0],
                d[1],
                d[2],
                c[0],
                c[1],
                c[2],
                l.vpls
            )?;
        }
        if self.views > 0 {
            writeln!(
                f,
                "  shadow maps of the lights after the first: {} views, {} maps of {}² stored (the others see no surface)",
                self.views, self.light_maps_stored, self.light_map_size
            )?;
        }
        let budget = s
            .vpl_budget
            .map(|b| format!(", VPL budget {b}"))
            .unwrap_or_default();
        writeln!(
            f,
            "settings: RSM {}², VPL maps {}², shadow map {}², threshold {}{budget}",
            s.rsm_size, s.vpl_map_size, s.shadow_map_size, s.threshold
        )?;
        writeln!(
            f,
            "VPLs: {} ({} hemisphere maps stored, {} VPLs see no surface and store none)",
            self.vpl_count, self.map_count, self.vpls_without_map
        )?;
        writeln!(
            f,
            "  second origins    {} VPLs (light below their horizon), {} second maps stored",
            self.vpls_with_lower, self.lower_map_count
        )?;
        let t = self.total_flux;
        writeln!(
            f,
            "  total flux (W)    R {}  G {}  B {}",
            g(t[0]),
            g(t[1]),
            g(t[2])
        )?;
        let l = &self.flux_luminance;
        writeln!(
            f,
            "  flux luminance    min {}  median {}  max {}",
            g(l.min),
            g(l.median),
            g(l.max)
        )?;
        let a = &self.area;
        writeln!(
            f,
            "  area              total {}  min {}  median {}  max {}",
            g(a.total),
            g(a.min),
            g(a.median),
            g(a.max)
        )?;
        let x = &self.texels;
        writeln!(
            f,
            "  RSM texels/VPL    total {}  min {}  median {}  max {}",
            x.total, x.min, x.median, x.max
        )?;
        writeln!(f, "maps:")?;
        fmt_map(f, "primary depth", &self.primary_depth)?;
        fmt_map(f, "VPL maps", &self.vpl_maps)?;
        match &self.rsm {
            Some(r) => fmt_map(f, "RSM", r)?,
            None => writeln!(f, "  RSM            not stored (no moving objects)")?,
        }
        match &self.view_rsm_metric {
            Some(r) => fmt_map(f, "view RSMs", r)?,
            None if self.view_rsms > 0 => writeln!(
                f,
                "  view RSMs      {} x {}² (not loaded)",
                self.view_rsms, self.view_rsm_size
            )?,
            None => writeln!(f, "  view RSMs      none stored")?,
        }
        if self.view_rsms > 0 {
            writeln!(
                f,
                "  {} views store a static RSM for the bounce off moving objects in their light: view_rsms.exr, {}",
                self.view_rsms,
                human_bytes(self.view_rsms_bytes)
            )?;
        }
        writeln!(f, "files:")?;
        for file in &self.files {
            writeln!(f, "  {:<18} {:>12}", file.name, human_bytes(file.bytes))?;
        }
        writeln!(f, "  {:<18} {:>12}", "total", human_bytes(self.total_bytes))
    }
}
