//! `gibake-scenegen [OUT_DIR]`: writes the bundled scenes (`corner_bunny.glb`,
//! `occluded.glb`, `sun.glb`, and the multi-light `lamps.glb`) with default
//! parameters into `OUT_DIR` (default `data/`). The output is deterministic.

use std::path::PathBuf;
use std::process::ExitCode;

fn main() -> ExitCode {
    let mut args = std::env::args_os().skip(1);
    let out = args
        .next()
        .map(PathBuf::from)
        .unwrap_or_else(|| PathBuf::from("data"));
    if args.next().is_some() || out.to_str().is_some_and(|s| s.starts_with('-')) {
        eprintln!("usage: gibake-scenegen [OUT_DIR]   (default OUT_DIR: data/)");
        return ExitCode::from(2);
    }
    if let Err(e) = std::fs::create_dir_all(&out) {
        eprintln!("gibake-scenegen: cannot create {}: {e}", out.display());
        return ExitCode::from(2);
    }
    for (name, f) in gibake_scenegen::all()
        .into_iter()
        .chain(gibake_scenegen::multi_light())
    {
        let bytes = f(&gibake_scenegen::Params::default());
        let path = out.join(format!("{name}.glb"));
        // Write to a temporary file and rename, so no half-written scene is left.
        let tmp = out.join(format!(".{name}.glb.tmp"));
        if let Err(e) = std::fs::write(&tmp, &bytes).and_then(|()| std::fs::rename(&tmp, &path)) {
            let _ = std::fs::remove_file(&tmp);
            eprintln!("gibake-scenegen: cannot write {}: {e}", path.display());
            return ExitCode::from(1);
        }
        println!("{} ({} bytes)", path.display(), bytes.len());
    }
    ExitCode::SUCCESS
}
