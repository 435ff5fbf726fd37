//! Levels as real tools export them: files written by gltfpack and
//! gltf-transform from the bundled scenes (`data/exports/`, made by
//! `tools/exports/run.sh`) must bake and render to the image of the file
//! they came from, within a relative MSE of [`MAX_REL_MSE`] — compression,
//! quantization and WebP change the data a little, never what the level is.
//!
//! The committed exports are judged here on every run; `sweep` (ignored:
//! run it after `tools/exports/run.sh DIR`) judges every export in a
//! directory, at a larger size, and prints the table of docs/results.md.
//!
//! The other tests check, in rendered images of `data/exports/foliage.glb`
//! (a top-down orthographic view of a 6 m floor: pixel column ↔ x, row ↔
//! z), that each extension does what the file asks: the texture transform
//! moves the floor's checker by one check, alpha-masked leaves cast
//! dappled shadows (static ones through the bake's shadow map, the moving
//! one through the runtime's merge, and in the CPU reference) and let the
//! camera see through them, a masked fence lets the wall's bounce light
//! through (VPL maps), the specular-glossiness wall bounces red; and that
//! `--json` carries the import's warnings and stderr has no ANSI codes.

use crate::common;

use std::path::{Path, PathBuf};

use gibake_eval::EvalSettings;
use gibake_image::{Image, rel_mse};
use gibake_runtime::{Mode, RenderSettings};
use gibake_scene::Scene;
use glam::Vec3;
use serde_json::{Value, json};

/// The bound of the issue: an export's image within this relative MSE of
/// the uncompressed file's.
const MAX_REL_MSE: f64 = 0.003;

fn load(path: &Path) -> Scene {
    gibake_scene::load(path, &Default::default())
        .unwrap_or_else(|e| panic!("{}: {e}", path.display()))
}

/// Bakes and renders `scene` (full mode) with `s`.
fn image(ctx: &gibake_gpu::GpuContext, scene: &Scene, s: &EvalSettings) -> Image {
    let asset = gibake_eval::bake(ctx, scene, s).expect("bake");
    gibake_eval::render(ctx, scene, &asset, Mode::Full, s).expect("render")
}

fn small() -> EvalSettings {
    EvalSettings {
        size: 64,
        vpls: 128,
        rsm_size: 256,
        vpl_map_size: 64,
        ssaa: 1,
        time: 0.5,
        ..Default::default()
    }
}

/// The source of an export named `SOURCE.TAG.glb`: `data/SOURCE.glb`, or
/// `SOURCE.glb` beside the export.
fn source_of(export: &Path) -> PathBuf {
    let name = export.file_name().and_then(|n| n.to_str()).expect("name");
    let stem = name.split('.').next().expect("stem");
    let beside = export.with_file_name(format!("{stem}.glb"));
    if beside.exists() {
        beside
    } else {
        common::data(&format!("{stem}.glb"))
    }
}

/// The largest distance from a static vertex of `export` to the nearest
/// static vertex of `source`, relative to the source's static diagonal:
/// the position quantization error, measured (brute force; the bundled
/// scenes have a few thousand vertices).
fn position_error(export: &Scene, source: &Scene) -> f64 {
    let src: Vec<glam::Vec3> = source
        .static_meshes
        .iter()
        .flat_map(|m| m.positions.iter().copied())
        .collect();
    let mut worst = 0.0f32;
    for p in export.static_meshes.iter().flat_map(|m| &m.positions) {
        let d = src
            .iter()
            .map(|q| (*p - *q).length_squared())
            .fold(f32::INFINITY, f32::min);
        worst = worst.max(d.sqrt());
    }
    f64::from(worst) / f64::from(source.static_bounds().diagonal())
}

/// One judged export: name, relative MSE of its image against its
/// source's, relative position error, import warnings.
struct Judged {
    name: String,
    rel_mse: f64,
    position_error: f64,
    warnings: Vec<String>,
}

/// Every `*.*.glb` export in `dir` with its relative MSE against its source.
fn judge_dir(dir: &Path, s: &EvalSettings) -> Vec<Judged> {
    let ctx = common::gpu();
    let mut files: Vec<PathBuf> = std::fs::read_dir(dir)
        .unwrap_or_else(|e| panic!("{}: {e}", dir.display()))
        .map(|e| e.expect("entry").path())
        .filter(|p| {
            p.extension().is_some_and(|x| x == "glb")
                && p.file_name()
                    .and_then(|n| n.to_str())
                    .is_some_and(|n| n.matches('.').count() >= 2)
        })
        .collect();
    files.sort();
    let mut sources: std::collections::BTreeMap<PathBuf, (Scene, Image)> = Default::default();
    let mut out = Vec::new();
    for f in files {
        let src = source_of(&f);
        let (source, reference) = sources.entry(src.clone()).or_insert_with(|| {
            let scene = load(&src);
            let img = image(&ctx, &scene, s);
            (scene, img)
        });
        let scene = load(&f);
        let img = image(&ctx, &scene, s);
        let j = Judged {
            name: f.file_name().unwrap().to_string_lossy().into_owned(),
            rel_mse: rel_mse(&img, reference),
            position_error: position_error(&scene, source),
            warnings: scene.warnings.clone(),
        };
        eprintln!(
            "{}: rel MSE {:.2e}, position error {:.2e} of the diagonal, against {}",
            j.name,
            j.rel_mse,
            j.position_error,
            src.display()
        );
        out.push(j);
    }
    out
}

/// The message of every file in `dir` that gibake refuses.
fn refusals(dir: &Path) -> Vec<(String, String)> {
    let mut out = Vec::new();
    let Ok(rd) = std::fs::read_dir(dir) else {
        return out;
    };
    let mut files: Vec<PathBuf> = rd.map(|e| e.expect("entry").path()).collect();
    files.sort();
    for f in files {
        let name = f.file_name().unwrap().to_string_lossy().into_owned();
        match gibake_scene::load(&f, &Default::default()) {
            Ok(_) => panic!("{name}: expected a refusal, the file loaded"),
            Err(e) => out.push((name, e.to_string())),
        }
    }
    out
}

#[test]
#[ignore = "a sweep over a directory of exports: GIBAKE_EXPORTS=DIR (tools/exports/run.sh DIR)"]
fn sweep() {
    let dir = std::env::var("GIBAKE_EXPORTS").expect("set GIBAKE_EXPORTS=DIR");
    let s = EvalSettings {
        size: 128,
        vpls: 256,
        rsm_size: 512,
        vpl_map_size: 64,
        ssaa: 1,
        time: 0.5,
        ..Default::default()
    };
    let results = judge_dir(Path::new(&dir), &s);
    println!(
        "| export | rel MSE vs source | position error / diagonal | warnings |\n|---|---:|---:|---:|"
    );
    for j in &results {
        println!(
            "| `{}` | {:.2e} | {:.1e} | {} |",
            j.name,
            j.rel_mse,
            j.position_error,
            j.warnings.len()
        );
    }
    println!();
    for (name, message) in refusals(&Path::new(&dir).join("refused")) {
        println!("- `{name}`: {message}");
        assert!(
            message.contains("gltf-transform"),
            "{name}: the refusal gives no command: {message}"
        );
    }
    let bad: Vec<&str> = results
        .iter()
        .filter(|j| j.rel_mse > MAX_REL_MSE)
        .map(|j| j.name.as_str())
        .collect();
    assert!(bad.is_empty(), "over {MAX_REL_MSE}: {bad:?}");
}

// ------------------------------------------------------------------ committed exports

fn exports_dir() -> PathBuf {
    common::data("exports")
}

#[test]
fn committed_exports_bake_like_their_sources() {
    let results = judge_dir(&exports_dir(), &small());
    assert!(results.len() >= 10, "{} exports judged", results.len());
    for j in &results {
        assert!(
            j.rel_mse <= MAX_REL_MSE,
            "{}: rel MSE {:.2e} over {MAX_REL_MSE}",
            j.name,
            j.rel_mse
        );
        assert!(j.warnings.is_empty(), "{}: {:?}", j.name, j.warnings);
    }
    let refused = refusals(&exports_dir().join("refused"));
    assert_eq!(refused.len(), 2, "{refused:?}");
    for (name, message) in refused {
        let ext = if name.contains("draco") {
            "KHR_draco_mesh_compression"
        } else {
            "EXT_texture_avif"
        };
        assert!(
            message.contains(ext) && message.contains("gltf-transform"),
            "{name}: {message}"
        );
    }
}

// ------------------------------------------------------------------ foliage.glb, measured

/// A GLB's JSON and BIN chunk.
fn split_glb(bytes: &[u8]) -> (Value, Vec<u8>) {
    let word = |i: usize| u32::from_le_bytes(bytes[i..i + 4].try_into().unwrap()) as usize;
    let jlen = word(12);
    let json = serde_json::from_slice(&bytes[20..20 + jlen]).expect("JSON chunk");
    let blen = word(20 + jlen);
    (json, bytes[28 + jlen..28 + jlen + blen].to_vec())
}

fn join_glb(json: &Value, bin: &[u8]) -> Vec<u8> {
    let mut js = serde_json::to_vec(json).unwrap();
    while !js.len().is_multiple_of(4) {
        js.push(b' ');
    }
    let total = 28 + js.len() + bin.len();
    let mut out = Vec::with_capacity(total);
    out.extend_from_slice(b"glTF");
    out.extend_from_slice(&2u32.to_le_bytes());
    out.extend_from_slice(&(total as u32).to_le_bytes());
    out.extend_from_slice(&(js.len() as u32).to_le_bytes());
    out.extend_from_slice(b"JSON");
    out.extend_from_slice(&js);
    out.extend_from_slice(&(bin.len() as u32).to_le_bytes());
    out.extend_from_slice(b"BIN\0");
    out.extend_from_slice(bin);
    out
}

/// foliage.glb's bytes after `edit` changed its JSON.
fn foliage_bytes(edit: impl FnOnce(&mut Value)) -> Vec<u8> {
    let bytes = std::fs::read(exports_dir().join("foliage.glb")).expect("foliage.glb");
    let (mut j, bin) = split_glb(&bytes);
    edit(&mut j);
    join_glb(&j, &bin)
}

/// foliage.glb after `edit` changed its JSON.
fn foliage(edit: impl FnOnce(&mut Value)) -> Scene {
    gibake_scene::load_from_slice(
        &foliage_bytes(edit),
        &exports_dir().join("foliage.glb"),
        &Default::default(),
    )
    .expect("foliage.glb loads")
}

/// Sets the alpha mode of the materials named in `names`.
fn alpha_mode(j: &mut Value, names: &[&str], mode: &str) {
    for m in j["materials"].as_array_mut().unwrap() {
        if names.contains(&m["name"].as_str().unwrap_or("")) {
            m["alphaMode"] = json!(mode);
        }
    }
}

/// Drops the scene's root nodes named in `names`.
fn drop_nodes(j: &mut Value, names: &[&str]) {
    let nodes = j["nodes"].clone();
    let roots = j["scenes"][0]["nodes"].as_array_mut().unwrap();
    roots.retain(|n| {
        !names.contains(
            &nodes[n.as_u64().unwrap() as usize]["name"]
                .as_str()
                .unwrap_or(""),
        )
    });
}

const SIZE: u32 = 96;

/// Renders `scene` from its top-down camera at SIZE² (no supersampling).
fn render(
    ctx: &gibake_gpu::GpuContext,
    scene: &Scene,
    asset: Option<&gibake_asset::Asset>,
    mode: Mode,
) -> Image {
    let rs = RenderSettings {
        width: SIZE,
        height: SIZE,
        mode,
        interleave: 1,
        ..Default::default()
    };
    gibake_eval::frame::render_image(&ctx.device, &ctx.queue, scene, asset, &rs, 0.0, 1)
        .expect("render")
}

fn bake(ctx: &gibake_gpu::GpuContext, scene: &Scene) -> gibake_asset::Asset {
    gibake_eval::bake(
        ctx,
        scene,
        &EvalSettings {
            vpls: 256,
            rsm_size: 256,
            vpl_map_size: 64,
            ..Default::default()
        },
    )
    .expect("bake")
}

/// The pixels whose centres lie in the floor rectangle x ∈ [x0, x1],
/// z ∈ [z0, z1] (image column ↔ x, row ↔ z over [−3, 3]).
fn pixels(img: &Image, x0: f32, x1: f32, z0: f32, z1: f32) -> Vec<Vec3> {
    let w = img.width as f32;
    let h = img.height as f32;
    let mut out = Vec::new();
    for py in 0..img.height {
        for px in 0..img.width {
            let x = -3.0 + 6.0 * (px as f32 + 0.5) / w;
            let z = -3.0 + 6.0 * (py as f32 + 0.5) / h;
            if (x0..=x1).contains(&x) && (z0..=z1).contains(&z) {
                out.push(img.get(px, py));
            }
        }
    }
    out
}

fn sum(p: &[Vec3]) -> f32 {
    p.iter().map(|c| c.x + c.y + c.z).sum()
}

/// Where the masked image lies between the opaque one (0) and the one
/// without the cut-out object (1), over a region: the fraction of light
/// the cut-outs let through.
fn through(masked: &[Vec3], opaque: &[Vec3], none: &[Vec3]) -> f32 {
    (sum(masked) - sum(opaque)) / (sum(none) - sum(opaque))
}

#[test]
fn texture_transform_moves_the_checker() {
    let ctx = common::gpu();
    // The transform shifts the texture one check along u (x): the checks
    // swap colours. Column px of the image samples texel u·96 = px + 8.5.
    let score = |scene: &Scene, shifted: bool| -> f32 {
        let img = render(&ctx, scene, None, Mode::Direct);
        let mut lum = Vec::new();
        for py in 0..SIZE {
            for px in 76..SIZE - 2 {
                let (tx, ty) = (
                    px as f32 + 0.5 + if shifted { 8.0 } else { 0.0 },
                    py as f32 + 0.5,
                );
                let (fx, fy) = (tx.rem_euclid(8.0), ty.rem_euclid(8.0));
                if (2.0..6.0).contains(&fx) && (2.0..6.0).contains(&fy) {
                    let bright = ((tx / 8.0) as i32 + (ty / 8.0) as i32) % 2 == 0;
                    let c = img.get(px, py);
                    lum.push((c.x + c.y + c.z, bright));
                }
            }
        }
        let lo = lum.iter().map(|l| l.0).fold(f32::INFINITY, f32::min);
        let hi = lum.iter().map(|l| l.0).fold(0.0, f32::max);
        let mid = 0.5 * (lo + hi);
        lum.iter().filter(|(l, b)| (*l > mid) == *b).count() as f32 / lum.len() as f32
    };
    let with = foliage(|_| {});
    let without = foliage(|j| {
        j["materials"][0]["pbrMetallicRoughness"]["baseColorTexture"]
            .as_object_mut()
            .unwrap()
            .remove("extensions");
    });
    let (a, b) = (score(&with, true), score(&without, true));
    eprintln!("checks matching the shifted checker: with the transform {a:.3}, without {b:.3}");
    assert!(a > 0.95, "with KHR_texture_transform: {a}");
    assert!(
        b < 0.05,
        "without it the checks are the other way round: {b}"
    );
    assert_ne!(
        gibake_scene::static_scene_hash(&with),
        gibake_scene::static_scene_hash(&without)
    );
}

#[test]
fn alpha_cutouts_cast_dappled_shadows_and_show_what_is_behind() {
    let ctx = common::gpu();
    let masked = foliage(|_| {});
    let opaque = foliage(|j| alpha_mode(j, &["Leaf"], "OPAQUE"));
    let none = foliage(|j| drop_nodes(j, &["LeafA", "LeafB", "LeafC"]));
    // Direct light, no asset: the runtime's own shadow map of the static
    // leaves, merged with the moving one's (shadow.wgsl both times).
    let [m, o, n] = [&masked, &opaque, &none].map(|s| render(&ctx, s, None, Mode::Direct));
    // Shadows fall 1 m towards −X: LeafA's, LeafC's, moving LeafB's.
    for (what, z0, z1) in [
        ("LeafA (static)", 0.5, 1.1),
        ("LeafC (static)", 1.7, 2.3),
        ("LeafB (moving)", -2.5, -1.9),
    ] {
        let r = |img: &Image| pixels(img, -0.1, 0.5, z0, z1);
        let f = through(&r(&m), &r(&o), &r(&n));
        // Dappled: some texels fully lit, some fully shadowed.
        let lit = r(&m)
            .iter()
            .zip(r(&n))
            .filter(|(a, b)| a.x > 0.8 * b.x)
            .count() as f32
            / r(&m).len() as f32;
        let dark = r(&m)
            .iter()
            .zip(r(&o))
            .filter(|(a, b)| a.x < 1.2 * b.x + 1e-4)
            .count() as f32
            / r(&m).len() as f32;
        eprintln!(
            "{what}: {f:.3} of the light passes, {lit:.2} of the pixels lit, {dark:.2} in shadow"
        );
        assert!(
            (0.35..0.65).contains(&f),
            "{what}: fraction through the leaf {f}"
        );
        assert!(
            lit > 0.25 && dark > 0.25,
            "{what}: not dappled ({lit}, {dark})"
        );
    }
    // The camera sees the floor through the holes of LeafA (G-buffer).
    let r = |img: &Image| pixels(img, 0.9, 1.5, 0.5, 1.1);
    let (rm, ro, rn) = (r(&m), r(&o), r(&n));
    let floor_seen = rm
        .iter()
        .zip(ro.iter().zip(&rn))
        .filter(|(a, (leaf, floor))| (**a - **floor).length() < (**a - **leaf).length())
        .count() as f32
        / rm.len() as f32;
    eprintln!("LeafA from above: floor seen at {floor_seen:.2} of the pixels");
    assert!((0.3..0.7).contains(&floor_seen), "{floor_seen}");

    // The CPU reference cuts the same holes (gibake-raycast's any-hit).
    let reference = |s: &Scene| {
        gibake_reference::render(
            s,
            &gibake_reference::Settings {
                width: 48,
                height: 48,
                spp: 4,
                time: 0.0,
                depth: gibake_reference::Depth::Direct,
                seed: 0,
            },
            &|_| {},
        )
        .expect("reference")
    };
    let [rm, ro, rn] = [&masked, &opaque, &none].map(reference);
    let r = |img: &Image| pixels(img, -0.1, 0.5, 0.5, 1.1);
    let f = through(&r(&rm), &r(&ro), &r(&rn));
    eprintln!("reference, LeafA: {f:.3} of the light passes");
    assert!((0.35..0.65).contains(&f), "reference: {f}");
}

#[test]
fn cutouts_let_bounce_light_through_and_spec_gloss_bounces_red() {
    let ctx = common::gpu();
    let masked = foliage(|_| {});
    let opaque = foliage(|j| alpha_mode(j, &["Fence"], "OPAQUE"));
    let none = foliage(|j| drop_nodes(j, &["Fence"]));
    let white = foliage(|j| {
        j["materials"][1]
            .as_object_mut()
            .unwrap()
            .remove("extensions");
    });
    let baked: Vec<(gibake_asset::Asset, &Scene)> = [&masked, &opaque, &none, &white]
        .into_iter()
        .map(|s| (bake(&ctx, s), s))
        .collect();
    let ind: Vec<Image> = baked
        .iter()
        .map(|(a, s)| render(&ctx, s, Some(a), Mode::Indirect))
        .collect();
    // Between the wall and the fence, out of the sun (the fence's shadow),
    // the floor's light is bounce light from the sunlit floor beyond the
    // fence and from the wall, which reaches it through the gaps (the
    // bake's RSM and VPL maps cut the same holes).
    let r = |img: &Image| pixels(img, -2.9, -2.4, -2.8, -0.4);
    let f = through(&r(&ind[0]), &r(&ind[1]), &r(&ind[2]));
    eprintln!(
        "between wall and fence: indirect {:.4} (masked) {:.4} (opaque) {:.4} (no fence): {f:.3} passes",
        sum(&r(&ind[0])),
        sum(&r(&ind[1])),
        sum(&r(&ind[2]))
    );
    assert!((0.15..0.6).contains(&f), "bounce through the fence: {f}");
    assert!(
        sum(&r(&ind[0])) > 1.5 * sum(&r(&ind[1])),
        "the gaps let at least half as much light again through as the opaque fence"
    );
    // Naive mode re-renders every VPL map on the GPU (hemi_raster.wgsl):
    // the same holes, so the same image as full mode. In front of the
    // fence, the wall's light crosses it twice; without the alpha test in
    // hemi_raster.wgsl naive mode was 1.8 % darker there (measured), with
    // it the two agree to 0.01 %.
    let full = render(&ctx, &masked, Some(&baked[0].0), Mode::Full);
    let naive = render(&ctx, &masked, Some(&baked[0].0), Mode::Naive);
    let e = rel_mse(&naive, &full);
    let front = |img: &Image| sum(&pixels(img, -2.0, -1.4, -2.8, -0.4));
    let (rn, rf) = (front(&naive), front(&full));
    let d = (rn - rf).abs() / rf;
    eprintln!("naive vs full: rel MSE {e:.2e}; in front of the fence {rn:.3} vs {rf:.3} ({d:.1e})");
    assert!(e < 1e-4, "naive vs full {e}");
    assert!(
        d < 3e-3,
        "naive mode's VPL maps see another fence: {rn} vs {rf}"
    );
    // The specular-glossiness wall bounces red onto the floor near it; its
    // white metallic-roughness fallback would not.
    let near_wall = |img: &Image| {
        let p = pixels(img, -2.9, -2.4, 0.3, 2.9);
        p.iter().copied().sum::<Vec3>() / p.len() as f32
    };
    let (red, grey) = (near_wall(&ind[0]), near_wall(&ind[3]));
    eprintln!("indirect near the wall: {red} (spec-gloss) vs {grey} (fallback)");
    assert!(red.x > 3.0 * red.y, "{red}");
    assert!(grey.x < 1.5 * grey.y, "{grey}");
}

#[test]
fn json_carries_warnings_and_stderr_has_no_colour() {
    let dir = tempfile::tempdir().expect("tempdir");
    let scene = dir.path().join("coated.glb");
    let bytes = foliage_bytes(|j| {
        j["materials"][1]["extensions"]["KHR_materials_clearcoat"] =
            json!({ "clearcoatFactor": 1.0 });
        j["extensionsUsed"]
            .as_array_mut()
            .unwrap()
            .push(json!("KHR_materials_clearcoat"));
    });
    std::fs::write(&scene, bytes).unwrap();
    let mut c = common::gibake();
    c.arg("bake")
        .arg(&scene)
        .arg("-o")
        .arg(dir.path().join("coated.gibake"))
        .args([
            "--vpls",
            "32",
            "--rsm-size",
            "64",
            "--vpl-map-size",
            "16",
            "--json",
        ]);
    let r = common::run_command(c);
    assert_eq!(r.code, Some(0), "{r}");
    let j: Value = serde_json::from_str(&r.stdout).expect("JSON on stdout");
    let warnings: Vec<&str> = j["warnings"]
        .as_array()
        .expect("warnings array")
        .iter()
        .map(|w| w.as_str().unwrap())
        .collect();
    assert!(
        warnings
            .iter()
            .any(|w| w.contains("KHR_materials_clearcoat") && w.contains("'RedWall'")),
        "{warnings:?}"
    );
    assert!(r.stderr.contains("KHR_materials_clearcoat"), "{r}");
    assert!(
        !r.stderr.contains('\u{1b}'),
        "ANSI escape codes on a non-terminal stderr: {r}"
    );
}
