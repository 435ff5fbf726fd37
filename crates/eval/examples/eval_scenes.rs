//! `cargo run --release -p gibake-eval --example eval_scenes -- [SEED|NAME]... [--size N] [--spp N] [--vpls N] [--ssaa N] [--blur N] [--every]`
//! (`--every`: against the every-bounce reference too, the default bake judged; `STATIC=1`: without the moving objects)
//! Prints the indirect-light figures of each scene (bundled names or seeds).
fn main() {
    let mut s = gibake_eval::EvalSettings::default();
    let args: Vec<String> = std::env::args().skip(1).collect();
    let mut it = args.iter();
    let mut scenes = Vec::new();
    while let Some(a) = it.next() {
        match a.as_str() {
            "--size" => s.size = it.next().unwrap().parse().unwrap(),
            "--spp" => s.spp = it.next().unwrap().parse().unwrap(),
            "--vpls" => s.vpls = it.next().unwrap().parse().unwrap(),
            "--dyn" => s.max_dynamic_vpls = it.next().unwrap().parse().unwrap(),
            "--rsm" => s.rsm_size = it.next().unwrap().parse().unwrap(),
            "--map" => s.vpl_map_size = it.next().unwrap().parse().unwrap(),
            "--ssaa" => s.ssaa = it.next().unwrap().parse().unwrap(),
            "--blur" => s.blur = it.next().unwrap().parse().unwrap(),
            "--every" => {
                s.every_bounce = true;
                s.every_bounce_bake = true;
                s.naive = false;
            }
            _ => scenes.push(a.clone()),
        }
    }
    let ctx = gibake_gpu::GpuContext::new(&Default::default()).unwrap();
    for sc in scenes {
        let (scene, name) = match sc.parse::<u64>() {
            Ok(seed) => gibake_eval::random_scene(seed),
            Err(_) => {
                let bytes = gibake_scenegen::by_name(&sc).unwrap()(&Default::default());
                (gibake_eval::load(&bytes, &format!("{sc}.glb")), sc.clone())
            }
        };
        let scene = if std::env::var("STATIC").is_ok() {
            gibake_bake::static_only(&scene)
        } else {
            scene
        };
        if std::env::var("DUMP").is_ok() {
            let asset = gibake_eval::bake(&ctx, &scene, &s).unwrap();
            let d = gibake_eval::render(&ctx, &scene, &asset, gibake_runtime::Mode::Direct, &s)
                .unwrap();
            let f =
                gibake_eval::render(&ctx, &scene, &asset, gibake_runtime::Mode::Full, &s).unwrap();
            let (r, _) = gibake_eval::reference_indirect(&scene, &s).unwrap();
            let fi = f.sub(&d);
            let e = r.auto_exposure();
            fi.write_png(
                std::path::Path::new(&format!("/tmp/{sc}_full_ind.png")),
                Some(e),
            )
            .unwrap();
            r.write_png(
                std::path::Path::new(&format!("/tmp/{sc}_ref_ind.png")),
                Some(e),
            )
            .unwrap();
            f.write_png(std::path::Path::new(&format!("/tmp/{sc}_full.png")), None)
                .unwrap();
            println!("means full {} ref {}", fi.mean(), r.mean());
        }
        let t = std::time::Instant::now();
        let e = gibake_eval::evaluate(&ctx, &scene, &name, &s, scene.dynamic_objects.is_empty())
            .unwrap();
        println!("{}  [{:.1}s]", e.line(), t.elapsed().as_secs_f64());
    }
}
