//! `cargo run --release -p gibake-eval --example eval_levels -- [NAME]... [--size N] [--spp N] [--vpls N] [--shadow-map N] [--blur N] [--ssaa N] [--near-field-descent N] [--later-near-field-descent N] [--later-descent-sweep N,N,…] [--later-vpls N] [--cascades auto|on|off] [--out DIR] [--markdown] [--no-naive] [--static-only] [--one-bounce-only] [--no-second-maps] [--list LEVELS.json]`
//! Judges the real levels of data/levels/levels.json, or of `--list`'s file
//! (its levels' files relative to it; all, or those named), against the
//! CPU reference, one bounce and every bounce (`vs one bounce: …`, `vs
//! every bounce ×R/G/B of one: …`: what the later bounces add and
//! `full`'s bias against each; then `every-bounce bake`: the default bake,
//! the later bounces' VPLs included, against the every-bounce reference;
//! `--one-bounce-only` leaves the every-bounce reference and bake out,
//! 1.5–20× the one-bounce reference's time); prints one
//! line per level and, with --out,
//! writes reference | full | rsm | error pictures (NAME.png), the same
//! for the indirect light alone (NAME_indirect.png) and every-bounce
//! reference | every-bounce bake | one-bounce bake | error
//! (NAME_every.png); --markdown ends with
//! the table of docs/results.md, "Real levels", and the every-bounce table
//! of docs/reference.md, "Every bounce on the real levels". `DUMP_EXR=1` with
//! `--out DIR` also writes the reference's, `full`'s and `rsm`'s indirect
//! images, the direct light and the reference's direct light as EXR
//! (`NAME_ref_ind.exr`, …, `NAME_ref_direct.exr`), as `eval_lights` does.
//! `--shadow-map N` bakes the primary shadow map at N² (default 2048, as
//! `gibake bake`). `--no-second-maps` renders the bakes without their
//! VPLs' second origins and maps, as a format 4.6 asset did (what they
//! change; docs/method.md, "Below the horizon"). `--no-naive` leaves out
//! the `naive` render (every VPL map re-rendered: 90% of the time on
//! lavapipe) and its naive~full figure. `--static-only` judges each level
//! without its moving objects (bake, frames and reference alike), to tell
//! the static VPLs' error from what the moving objects add. `--ssaa`
//! (default 4) renders each frame at N× the size and averages N² samples
//! per pixel, as the reference's 512 paths per pixel integrate its area:
//! at 2 (4 samples) the pixels of a level's small bright features are
//! sampled so coarsely that they, not the light, dominate a 40² image's
//! rel MSE (arena 0.0112 at 2, 0.0053 at 4) and move its means by up to
//! 2 points (docs/results.md, "Real levels").
fn main() {
    let mut s = gibake_eval::EvalSettings {
        size: 128,
        spp: 512,
        blur: 4,
        ssaa: 4,
        every_bounce: true,
        every_bounce_bake: true,
        ..Default::default()
    };
    let args: Vec<String> = std::env::args().skip(1).collect();
    let mut it = args.iter();
    let mut names = Vec::new();
    let mut out = None;
    let mut markdown = false;
    let mut static_only = false;
    let mut list = gibake_eval::levels::bundled_list();
    let mut rows = Vec::new();
    let mut every_rows = Vec::new();
    while let Some(a) = it.next() {
        let mut num = || {
            it.next()
                .expect("a value")
                .parse::<u32>()
                .expect("a number")
        };
        match a.as_str() {
            "--size" => s.size = num(),
            "--spp" => s.spp = num(),
            "--vpls" => s.vpls = num(),
            "--blur" => s.blur = num(),
            "--rsm" => s.rsm_size = num(),
            "--map" => s.vpl_map_size = num(),
            "--shadow-map" => s.shadow_map_size = num(),
            "--ssaa" => s.ssaa = num(),
            "--near-field-descent" => s.near_field_descent = num(),
            "--later-near-field-descent" => s.later_near_field_descent = num(),
            "--later-vpls" => s.later_vpls = Some(num()),
            "--later-descent-sweep" => {
                s.later_descent_sweep = it
                    .next()
                    .expect("a list")
                    .split(',')
                    .map(|v| v.parse().expect("a number"))
                    .collect()
            }
            "--cascades" => {
                s.cascades = match it.next().map(String::as_str) {
                    Some("on") => gibake_runtime::Cascades::On,
                    Some("off") => gibake_runtime::Cascades::Off,
                    Some("auto") => gibake_runtime::Cascades::Auto,
                    other => panic!("--cascades auto|on|off, not {other:?}"),
                }
            }
            "--markdown" => markdown = true,
            "--no-naive" => s.naive = false,
            "--no-second-maps" => s.second_maps = false,
            "--one-bounce-only" => {
                s.every_bounce = false;
                s.every_bounce_bake = false;
            }
            "--static-only" => static_only = true,
            "--out" => out = Some(std::path::PathBuf::from(it.next().expect("a directory"))),
            "--list" => list = std::path::PathBuf::from(it.next().expect("a levels.json")),
            _ => names.push(a.clone()),
        }
    }
    let dir = list.parent().unwrap().to_path_buf();
    let specs = gibake_eval::levels::read_specs(&list).unwrap();
    // A name that is no level (a second `--vpls` value, a typo) is an
    // error, not a level silently left out.
    let unknown: Vec<&String> = names
        .iter()
        .filter(|n| !specs.iter().any(|l| &l.name == *n))
        .collect();
    if !unknown.is_empty() {
        let known: Vec<&str> = specs.iter().map(|l| l.name.as_str()).collect();
        eprintln!(
            "error: not a level of {}: {unknown:?} (levels: {}; each option takes one value)",
            list.display(),
            known.join(", ")
        );
        std::process::exit(2);
    }
    let ctx = gibake_gpu::GpuContext::new(&Default::default()).unwrap();
    for spec in specs
        .iter()
        .filter(|l| names.is_empty() || names.contains(&l.name))
    {
        let mut scene = spec.load(&dir).unwrap();
        if static_only {
            scene = gibake_bake::static_only(&scene);
        }
        let t = std::time::Instant::now();
        let (e, images) = gibake_eval::levels::judge_level(&ctx, &scene, &spec.name, &s).unwrap();
        println!("{} ({:.0} s)", e.line(), t.elapsed().as_secs_f64());
        rows.push(e.markdown_row());
        every_rows.extend(e.every_markdown_row());
        if let Some(d) = &out {
            std::fs::create_dir_all(d).unwrap();
            gibake_eval::levels::write_panel(&images, &d.join(format!("{}.png", spec.name)))
                .unwrap();
            gibake_eval::levels::write_indirect_panel(
                &images,
                &d.join(format!("{}_indirect.png", spec.name)),
            )
            .unwrap();
            gibake_eval::levels::write_every_panel(
                &images,
                &d.join(format!("{}_every.png", spec.name)),
            )
            .unwrap();
            if std::env::var("DUMP_EXR").is_ok() {
                gibake_eval::levels::write_exrs(&images, d, &spec.name).unwrap();
            }
        }
    }
    if markdown {
        println!("{}", gibake_eval::levels::LevelEval::MARKDOWN_HEADER);
        for r in rows {
            println!("{r}");
        }
        if !every_rows.is_empty() {
            println!();
            println!("{}", gibake_eval::levels::LevelEval::EVERY_MARKDOWN_HEADER);
            for r in every_rows {
                println!("{r}");
            }
        }
    }
}
