//! Real levels made by other people with real tools (`data/levels/`): what
//! the method promises on content users bring, judged against the
//! independent CPU reference.
//!
//! `data/levels/levels.json` lists each level: its file, where it comes
//! from (repository, commit, path, licence), and what a user adds on the
//! command line because the export lacks it — a sun (`--sun`), a camera
//! (`--look-at`) and the props that move (`--dynamic`). The file itself is
//! never edited: [`LevelSpec::load_options`] is exactly what `gibake bake
//! LEVEL --sun … --dynamic …` passes to the importer, and
//! [`LevelSpec::command_line`] prints those flags.
//!
//! [`judge_level`] renders the reference (direct + one bounce, direct only;
//! every bounce too with [`EvalSettings::every_bounce`]) and every mode,
//! and reports per level ([`LevelEval`]): image rel MSE, direct rel MSE,
//! the indirect part's mean bias per channel, `full`'s and `rsm`'s blurred
//! indirect error, mean FLIP, `naive` against `full`, the bake time and
//! VPL counts; against the every-bounce reference, the every-bounce ÷
//! one-bounce indirect ratio and `full`'s bias and error
//! ([`crate::EveryBounceEval`], [`LevelEval::every_markdown_row`]). [`write_panel`] writes the picture reference |
//! full | rsm | error that docs/results.md shows per level.

use std::path::{Path, PathBuf};
use std::time::Instant;

use gibake_gpu::GpuContext;
use gibake_image::Image;
use gibake_runtime::Mode;
use gibake_scene::{CameraChoice, LoadOptions, Scene, Sun};
use glam::Vec3;
use serde::{Deserialize, Serialize};

use crate::{EvalError, EvalSettings, IndirectEval, ReferenceImages};

/// Where a level comes from.
#[derive(Clone, Debug, Deserialize, Serialize)]
pub struct LevelSource {
    /// Public repository (`owner/name` on GitHub).
    pub repo: String,
    /// The commit the files were taken from.
    pub commit: String,
    /// Path of the file in that repository.
    pub path: String,
    /// Licence (SPDX name) and its file next to the level.
    pub licence: String,
}

/// The `--sun` of a level exported without a light.
#[derive(Clone, Copy, Debug, Deserialize, Serialize)]
pub struct LevelSun {
    /// Degrees, clockwise from −Z seen from above.
    pub azimuth: f32,
    /// Degrees above the horizon.
    pub elevation: f32,
    /// W/m².
    pub irradiance: f32,
}

/// The `--look-at` camera of a level.
#[derive(Clone, Copy, Debug, Deserialize, Serialize)]
pub struct LevelCamera {
    /// Eye position (world).
    pub eye: [f32; 3],
    /// Target point (world).
    pub target: [f32; 3],
    /// Vertical field of view, degrees.
    pub fov: f32,
}

/// A moving ball a level is given (a level exported as one mesh has no prop
/// that could move).
#[derive(Clone, Copy, Debug, Deserialize, Serialize)]
pub struct LevelBall {
    /// Centre (world).
    pub center: [f32; 3],
    /// Radius (world units).
    pub radius: f32,
    /// Lambertian albedo (linear RGB).
    pub albedo: [f32; 3],
}

/// Adds `b` to `scene` as a moving object named `name` (a UV sphere of 24 ×
/// 16 segments, as an engine would spawn a prop).
pub fn add_ball(scene: &mut Scene, name: &str, b: &LevelBall) {
    let g = gibake_scenegen::geom::uv_sphere(glam::DVec3::ZERO, f64::from(b.radius), 24, 16);
    let mesh = gibake_scene::Mesh {
        name: name.to_string(),
        positions: g.pos.iter().map(|p| p.as_vec3()).collect(),
        normals: g.nrm.iter().map(|n| n.as_vec3()).collect(),
        uvs: None,
        indices: g.idx.clone(),
        material: 0,
    };
    let material = gibake_scene::Material::opaque(name.to_string(), Vec3::from(b.albedo), None);
    scene.add_dynamic_object(
        name,
        vec![(mesh, material)],
        glam::Mat4::from_translation(Vec3::from(b.center)),
    );
}

/// One entry of `data/levels/levels.json`.
#[derive(Clone, Debug, Deserialize, Serialize)]
pub struct LevelSpec {
    /// Short name (tables, pictures).
    pub name: String,
    /// What kind of level it is.
    pub what: String,
    /// The glTF file, relative to the directory of `levels.json`.
    pub file: PathBuf,
    /// Provenance.
    pub source: LevelSource,
    /// The sun given on the command line (none: the file's own light).
    pub sun: Option<LevelSun>,
    /// The camera given on the command line.
    pub camera: LevelCamera,
    /// `--dynamic` patterns: the props that move.
    #[serde(default)]
    pub dynamic: Vec<String>,
    /// `--bake-volume MINX,MINY,MINZ,MAXX,MAXY,MAXZ`, if the level needs one.
    #[serde(default)]
    pub bake_volume: Option<[f32; 6]>,
    /// Moving balls added to the level (as an engine would spawn them).
    #[serde(default)]
    pub balls: Vec<LevelBall>,
    /// Scene time rendered.
    #[serde(default)]
    pub time: f32,
    /// A documented failure of the method on this level: the looser bound
    /// it is held to (so that it cannot get worse unnoticed) and why.
    #[serde(default)]
    pub known_failure: Option<KnownFailure>,
}

/// A level on which the method misses the promised accuracy, stated with
/// the bound it does meet and the cause (docs/method.md, "Real levels").
#[derive(Clone, Debug, Deserialize, Serialize)]
pub struct KnownFailure {
    /// Largest |mean indirect bias| per channel it is held to (fraction).
    pub indirect_bias: f32,
    /// What goes wrong, and where it is written up.
    pub why: String,
}

/// Why the level list could not be read.
#[derive(Debug, thiserror::Error)]
pub enum LevelError {
    /// The list could not be read.
    #[error("{path}: {source}")]
    Io {
        /// The file.
        path: PathBuf,
        /// The cause.
        #[source]
        source: std::io::Error,
    },
    /// The list is not valid JSON of the expected shape.
    #[error("{path}: {message}")]
    Invalid {
        /// The file.
        path: PathBuf,
        /// What is wrong.
        message: String,
    },
    /// A level failed to load.
    #[error(transparent)]
    Scene(#[from] gibake_scene::SceneError),
}

/// The bundled level list, `data/levels/levels.json` of this repository.
pub fn bundled_list() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../data/levels/levels.json")
}

/// Reads a level list.
pub fn read_specs(path: &Path) -> Result<Vec<LevelSpec>, LevelError> {
    let text = std::fs::read_to_string(path).map_err(|source| LevelError::Io {
        path: path.to_path_buf(),
        source,
    })?;
    serde_json::from_str(&text).map_err(|e| LevelError::Invalid {
        path: path.to_path_buf(),
        message: e.to_string(),
    })
}

impl LevelSpec {
    /// The importer options the command-line flags give.
    pub fn load_options(&self) -> LoadOptions {
        LoadOptions {
            sun: self.sun.map(|s| Sun {
                azimuth_deg: s.azimuth,
                elevation_deg: s.elevation,
                irradiance: s.irradiance,
                color: Vec3::ONE,
            }),
            camera: CameraChoice::LookAt {
                eye: Vec3::from(self.camera.eye),
                target: Vec3::from(self.camera.target),
                yfov_deg: self.camera.fov,
            },
            dynamic: self.dynamic.clone(),
            bake_volume: self.bake_volume.map(|v| gibake_scene::Aabb {
                min: Vec3::new(v[0], v[1], v[2]),
                max: Vec3::new(v[3], v[4], v[5]),
            }),
            ..Default::default()
        }
    }

    /// The path of the level's file, given the list's directory.
    pub fn path(&self, dir: &Path) -> PathBuf {
        dir.join(&self.file)
    }

    /// Loads the level as `gibake` would with [`LevelSpec::command_line`],
    /// plus its moving balls.
    pub fn load(&self, dir: &Path) -> Result<Scene, LevelError> {
        let mut scene = gibake_scene::load(&self.path(dir), &self.load_options())?;
        for (i, b) in self.balls.iter().enumerate() {
            add_ball(&mut scene, &format!("ball {i}"), b);
        }
        Ok(scene)
    }

    /// The flags a user gives `gibake bake`/`render`/`reference` for this
    /// level (the camera only matters to render and reference).
    pub fn command_line(&self) -> String {
        let mut out = Vec::new();
        if let Some(s) = self.sun {
            out.push(format!(
                "--sun {},{} --sun-irradiance {}",
                s.azimuth, s.elevation, s.irradiance
            ));
        }
        for d in &self.dynamic {
            out.push(format!("--dynamic '{d}'"));
        }
        if let Some(v) = self.bake_volume {
            out.push(format!(
                "--bake-volume {},{},{},{},{},{}",
                v[0], v[1], v[2], v[3], v[4], v[5]
            ));
        }
        let c = self.camera;
        out.push(format!(
            "--look-at {},{},{},{},{},{},{}",
            c.eye[0], c.eye[1], c.eye[2], c.target[0], c.target[1], c.target[2], c.fov
        ));
        out.join(" ")
    }
}

/// The figures of one level.
#[derive(Clone, Debug, Serialize)]
pub struct LevelEval {
    /// The indirect figures (bias, blurred errors, naive against full).
    pub indirect: IndirectEval,
    /// rel MSE of `full` against the reference (direct + one bounce).
    pub image_rel_mse: f64,
    /// rel MSE of `direct` against the reference's direct light.
    pub direct_rel_mse: f64,
    /// rel MSE of `rsm` against the reference.
    pub rsm_image_rel_mse: f64,
    /// Mean FLIP of `full` against the reference.
    pub flip: f64,
    /// Bake time, seconds (this machine).
    pub bake_s: f64,
    /// Wall seconds of the judgement's parts (this machine): the CPU
    /// reference, and each mode's render (`direct`, `full`, `rsm`,
    /// `naive`), for seeing where a test's time goes.
    pub reference_s: f64,
    /// Render seconds per mode, in the order direct, full, rsm, naive (0
    /// where not rendered).
    pub render_s: [f64; 4],
    /// Static and moving triangles.
    pub triangles: (usize, usize),
    /// VPL maps stored (a map that sees no surface is not).
    pub maps_stored: usize,
}

impl LevelEval {
    /// One line for logs.
    pub fn line(&self) -> String {
        format!(
            "{} | image {:.4} direct {:.4} rsm {:.4} | flip {:.3} | bake {:.1} s | reference {:.1} s, renders {:.1}/{:.1}/{:.1}/{:.1} s (direct/full/rsm/naive)",
            self.indirect.line(),
            self.image_rel_mse,
            self.direct_rel_mse,
            self.rsm_image_rel_mse,
            self.flip,
            self.bake_s,
            self.reference_s,
            self.render_s[0],
            self.render_s[1],
            self.render_s[2],
            self.render_s[3],
        )
    }

    /// The header of [`LevelEval::markdown_row`]'s table.
    pub const MARKDOWN_HEADER: &'static str = "| level | triangles | VPLs | full bias (R/G/B) | rsm bias | full err / rsm err | image rel MSE | direct rel MSE | FLIP | bake |\n|---|---|---|---|---|---|---|---|---|---|";

    /// One row of a markdown table (docs/results.md, "Real levels").
    pub fn markdown_row(&self) -> String {
        let pct = |b: [f32; 3]| b.map(|x| format!("{:+.1}", 100.0 * x)).join("/") + "%";
        let rsm_mean = self.indirect.rsm_bias.iter().sum::<f32>() / 3.0;
        format!(
            "| {} | {} + {} | {} | {} | {:+.1}% | {:.2} / {:.2} | {:.4} | {:.4} | {:.3} | {:.1} s |",
            self.indirect.name,
            self.triangles.0,
            self.triangles.1,
            self.indirect.vpls,
            pct(self.indirect.full_bias),
            100.0 * rsm_mean,
            self.indirect.full_err,
            self.indirect.rsm_err,
            self.image_rel_mse,
            self.direct_rel_mse,
            self.flip,
            self.bake_s
        )
    }
}

impl LevelEval {
    /// The header of [`LevelEval::every_markdown_row`]'s table.
    pub const EVERY_MARKDOWN_HEADER: &'static str = "| level | every ÷ one bounce indirect (R/G/B) | bounces a path | one-bounce bake: full vs one bounce | full vs every bounce | rsm vs every bounce | full err vs every bounce | every-bounce bake (later VPLs): full vs every bounce | its err | its bake s |\n|---|---|---|---|---|---|---|---|---|---|";

    /// One row of the table of what the later bounces add and `full`'s
    /// bias against both references (docs/reference.md, "Every bounce on
    /// the real levels"); `None` without the every-bounce reference.
    pub fn every_markdown_row(&self) -> Option<String> {
        let e = self.indirect.every.as_ref()?;
        let pct = |b: [f32; 3]| b.map(|x| format!("{:+.1}", 100.0 * x)).join("/") + "%";
        let (baked, baked_err, baked_s) = match &e.baked {
            Some(b) => (
                format!("{} ({})", pct(b.full_bias), b.later_vpls),
                format!("{:.2}", b.full_err),
                format!("{:.1}", b.bake_s),
            ),
            None => ("—".into(), "—".into(), "—".into()),
        };
        Some(format!(
            "| {} | {} | {:.1} | {} | {} | {} | {:.2} | {baked} | {baked_err} | {baked_s} |",
            self.indirect.name,
            e.ratio.map(|r| format!("{r:.2}")).join("/"),
            e.mean_bounces,
            pct(self.indirect.full_bias),
            pct(e.full_bias),
            pct(e.rsm_bias),
            e.full_err,
        ))
    }
}

/// The images of one level's judgement.
pub struct LevelImages {
    /// The reference.
    pub reference: ReferenceImages,
    /// `full`.
    pub full: Image,
    /// `direct`.
    pub direct: Image,
    /// `rsm`.
    pub rsm: Image,
    /// `full` of the default bake (every bounce), where
    /// [`EvalSettings::every_bounce_bake`] rendered it.
    pub every_full: Option<Image>,
}

/// rel MSE of `naive` against `full` for `scene` baked with `s` (the
/// merged maps against every map re-rendered from all geometry): the check
/// [`judge_level`] makes when [`EvalSettings::naive`] is on, alone, so that
/// a test can make it with fewer VPLs than it judges the image with (the
/// merge is the same per VPL; `naive` costs a map render per VPL a frame).
pub fn naive_against_full(
    ctx: &GpuContext,
    scene: &Scene,
    s: &EvalSettings,
) -> Result<f64, EvalError> {
    let asset = crate::bake(ctx, scene, s)?;
    let full = crate::render(ctx, scene, &asset, Mode::Full, s)?;
    let naive = crate::render(ctx, scene, &asset, Mode::Naive, s)?;
    Ok(gibake_image::rel_mse(&naive, &full))
}

/// Judges `scene` (a level loaded with its spec's options): bakes it with
/// `s`, renders every mode and the reference, and computes the figures.
pub fn judge_level(
    ctx: &GpuContext,
    scene: &Scene,
    name: &str,
    s: &EvalSettings,
) -> Result<(LevelEval, LevelImages), EvalError> {
    let t = Instant::now();
    let reference = crate::reference_images(scene, s)?;
    let reference_s = t.elapsed().as_secs_f64();
    let t = Instant::now();
    let asset = crate::bake(ctx, scene, s)?;
    let bake_s = t.elapsed().as_secs_f64();
    let mut render_s = [0.0; 4];
    let mut render = |k: usize, m| {
        let t = Instant::now();
        let image = crate::render(ctx, scene, &asset, m, s);
        render_s[k] = t.elapsed().as_secs_f64();
        image
    };
    let direct = render(0, Mode::Direct)?;
    let full = render(1, Mode::Full)?;
    let rsm = render(2, Mode::Rsm)?;
    let naive = if s.naive {
        Some(render(3, Mode::Naive)?)
    } else {
        None
    };
    let ref_ind = reference.indirect();
    let (full_ind, rsm_ind) = (full.sub(&direct), rsm.sub(&direct));
    let rm = ref_ind.mean();
    let sum = |i: &Image| {
        let m = i.mean();
        m.x + m.y + m.z
    };
    let indirect = IndirectEval {
        name: name.to_string(),
        vpls: asset.vpls.len(),
        has_dynamic: !scene.dynamic_objects.is_empty(),
        ref_mean: rm.to_array(),
        ref_noise: (reference.noise / rm.max(Vec3::splat(f32::MIN_POSITIVE))).to_array(),
        full_bias: crate::bias(full_ind.mean(), rm),
        rsm_bias: crate::bias(rsm_ind.mean(), rm),
        full_err: crate::indirect_error(&full_ind, &ref_ind, s.blur),
        rsm_err: crate::indirect_error(&rsm_ind, &ref_ind, s.blur),
        naive_vs_full: naive
            .as_ref()
            .map_or(f64::NAN, |n| gibake_image::rel_mse(n, &full)),
        mode_indirect: [
            Some(("full".into(), sum(&full_ind))),
            Some(("rsm".into(), sum(&rsm_ind))),
            naive
                .as_ref()
                .map(|n| ("naive".into(), sum(&n.sub(&direct)))),
        ]
        .into_iter()
        .flatten()
        .collect(),
        every: reference.every.as_ref().map(|e| {
            crate::EveryBounceEval::new(&full_ind, &rsm_ind, e, &reference.direct, rm, s.blur)
        }),
    };
    // The default bake (every bounce) against the every-bounce reference.
    let mut indirect = indirect;
    let mut every_full = None;
    if let (Some(e), Some(judged), true) = (
        reference.every.as_ref(),
        indirect.every.take(),
        s.every_bounce_bake,
    ) {
        let (judged, full) =
            judged.with_default_bake(ctx, scene, s, e, &reference.direct, &direct)?;
        indirect.every = Some(judged);
        every_full = Some(full);
    }
    let exposure = reference.one_bounce.auto_exposure();
    let eval = LevelEval {
        indirect,
        image_rel_mse: gibake_image::rel_mse(&full, &reference.one_bounce),
        direct_rel_mse: gibake_image::rel_mse(&direct, &reference.direct),
        rsm_image_rel_mse: gibake_image::rel_mse(&rsm, &reference.one_bounce),
        flip: crate::flip::mean_flip_exposed(&full, &reference.one_bounce, exposure)
            .unwrap_or(f64::NAN),
        bake_s,
        reference_s,
        render_s,
        triangles: scene.triangle_counts(),
        maps_stored: asset.vpls.iter().filter(|v| v.map != u32::MAX).count(),
    };
    Ok((
        eval,
        LevelImages {
            reference,
            full,
            direct,
            rsm,
            every_full,
        },
    ))
}

/// Writes `every-bounce reference | the default bake's full | the
/// one-bounce bake's full | error` (the default bake's against the
/// every-bounce reference, 4×) side by side as a PNG, with the every-bounce
/// reference's exposure; nothing (`Ok(false)`) where the every-bounce
/// images were not rendered.
pub fn write_every_panel(
    images: &LevelImages,
    path: &Path,
) -> Result<bool, gibake_image::ImageError> {
    match (&images.reference.every, &images.every_full) {
        (Some(e), Some(full)) => write_row(&e.image, full, &images.full, path).map(|()| true),
        _ => Ok(false),
    }
}

/// Writes `reference | full | rsm | error` side by side as a PNG, all with
/// the reference's exposure; the error panel is `|full − reference|` at 4×
/// that exposure.
pub fn write_panel(images: &LevelImages, path: &Path) -> Result<(), gibake_image::ImageError> {
    let r = &images.reference.one_bounce;
    write_row(r, &images.full, &images.rsm, path)
}

/// Writes the same row for the indirect light alone (each image minus its
/// direct part), exposed for the reference's indirect light: where `full`
/// loses or gains bounce light shows here, not hidden under the direct.
pub fn write_indirect_panel(
    images: &LevelImages,
    path: &Path,
) -> Result<(), gibake_image::ImageError> {
    let r = images.reference.indirect();
    let full = images.full.sub(&images.direct);
    let rsm = images.rsm.sub(&images.direct);
    write_row(&r, &full, &rsm, path)
}

/// Writes the reference's, `full`'s and `rsm`'s indirect light and the
/// direct light as EXR, `DIR/NAME_ref_ind.exr`, `NAME_full_ind.exr`,
/// `NAME_rsm_ind.exr`, `NAME_direct.exr` and the reference's direct light
/// `NAME_ref_direct.exr`, and where rendered the every-bounce reference's
/// and bake's indirect light `NAME_every_ref_ind.exr`, `NAME_every_full_ind.exr`
/// (the examples' `DUMP_EXR=1`: for looking at where
/// the indirect light is lost, or where the direct light's shadows leak).
pub fn write_exrs(
    images: &LevelImages,
    dir: &Path,
    name: &str,
) -> Result<(), gibake_image::ImageError> {
    for (part, image) in [
        ("ref_ind", images.reference.indirect()),
        ("full_ind", images.full.sub(&images.direct)),
        ("rsm_ind", images.rsm.sub(&images.direct)),
        ("direct", images.direct.clone()),
        ("ref_direct", images.reference.direct.clone()),
    ] {
        image.write_exr(&dir.join(format!("{name}_{part}.exr")))?;
    }
    // The every-bounce reference's and the every-bounce bake's indirect
    // light, where rendered.
    if let (Some(e), Some(full)) = (&images.reference.every, &images.every_full) {
        let ref_direct = &images.reference.direct;
        e.image
            .sub(ref_direct)
            .write_exr(&dir.join(format!("{name}_every_ref_ind.exr")))?;
        full.sub(&images.direct)
            .write_exr(&dir.join(format!("{name}_every_full_ind.exr")))?;
    }
    Ok(())
}

/// `reference | full | rsm | 4·|full − reference|` at the reference's exposure,
/// at least 640 pixels wide.
pub fn write_row(
    r: &Image,
    full: &Image,
    rsm: &Image,
    path: &Path,
) -> Result<(), gibake_image::ImageError> {
    let (w, h) = (r.width, r.height);
    // Small judged images are blown up (nearest texel: every pixel still the
    // measured one) so that the panel is at least 640 pixels wide.
    let zoom = 640u32.div_ceil((4 * w).max(1)).max(1);
    let mut out = Image::new(4 * w * zoom, h * zoom);
    let err = {
        let mut e = Image::new(w, h);
        for (k, (a, b)) in full.pixels.iter().zip(&r.pixels).enumerate() {
            e.pixels[k] = (*a - *b).abs() * 4.0;
        }
        e
    };
    for (panel, img) in [r, full, rsm, &err].into_iter().enumerate() {
        for y in 0..h * zoom {
            for x in 0..w * zoom {
                out.set(
                    (panel as u32 * w) * zoom + x,
                    y,
                    img.get(x / zoom, y / zoom),
                );
            }
        }
    }
    out.write_png(path, Some(r.auto_exposure()))
}
