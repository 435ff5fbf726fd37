//! `cargo run --release -p gibake-eval --example strip_second_maps -- IN.gibake OUT.gibake`
//! Writes `IN` again without its VPLs' second origins and maps
//! (`gibake_eval::without_second_maps`): the asset shades as a format 4.6
//! asset did (a receiver below a VPL's horizon answered by its first map's
//! rim). For measuring what the second maps cost and change with `gibake
//! render --stats` on the same bake (docs/method.md, "Below the horizon").
fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let [input, output] = args.as_slice() else {
        eprintln!("usage: strip_second_maps IN.gibake OUT.gibake");
        std::process::exit(2);
    };
    let asset = gibake_asset::load(std::path::Path::new(input)).unwrap_or_else(|e| {
        eprintln!("error: {e}");
        std::process::exit(2)
    });
    let stripped = gibake_eval::without_second_maps(asset);
    if let Err(e) = gibake_asset::write(&stripped, std::path::Path::new(output)) {
        eprintln!("error: {e}");
        std::process::exit(2);
    }
}
