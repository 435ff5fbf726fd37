//! The README's command examples run as written (issue 20): every line of
//! the code blocks of "Everyday use" is run with bash, in order, in a
//! directory holding the files the examples assume (`scene.glb`, `a.gibake`
//! and `b.gibake`, `levels/*.glb`, `level.glb`, `lamps.glb`), with the `gibake` under test
//! first on `PATH`. Each must succeed (`diff` may also say "different",
//! exit 1). The benchmarks and `submit.sh` are the only lines not run, each
//! for a reason below, and the test fails if any other line is left out.

use crate::common;

use std::path::Path;
use std::process::Command;

/// Lines not run, and why (each is covered elsewhere).
const NOT_RUN: [(&str, &str); 5] = [
    (
        "gibake view scene.glb --bake scene.gibake",
        "opens a window and runs until it is closed; tests/view.rs runs it headless under Xvfb",
    ),
    (
        "gibake bench quality --quick",
        "minutes on lavapipe; tests/bench_quick.rs runs it on one scene",
    ),
    (
        "gibake bench accuracy --seeds 30",
        "many minutes; tests/bench_small.rs runs the bench small",
    ),
    (
        "scripts/slurm/submit.sh --wait level.glb level.gibake 16",
        "needs Slurm: tests/pipeline_slurm.rs (a real cluster) and tests/faults.rs (a stand-in sbatch)",
    ),
    (
        "BASE=origin/main sh scripts/ci-diff-bakes.sh",
        "needs a git repository with accepted assets: tests/ci_diff.rs runs it in one",
    ),
];

/// The command lines of the ```sh blocks of the README section `title`.
fn commands(readme: &str, title: &str) -> Vec<String> {
    let start = readme.find(title).expect("README section");
    let rest = &readme[start + title.len()..];
    let end = rest.find("\n## ").unwrap_or(rest.len());
    let mut out = Vec::new();
    let mut inside = false;
    for line in rest[..end].lines() {
        if line.trim_start().starts_with("```") {
            inside = line.trim() == "```sh";
            continue;
        }
        if inside {
            // A comment after two spaces ends the command.
            let cmd = match line.find("  #") {
                Some(i) => &line[..i],
                None => line,
            };
            let cmd = cmd.trim();
            if !cmd.is_empty() {
                out.push(cmd.to_string());
            }
        }
    }
    out
}

fn gibake(dir: &Path, args: &[&str]) {
    let out = Command::new(env!("CARGO_BIN_EXE_gibake"))
        .args(args)
        .current_dir(dir)
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{args:?}: {}",
        String::from_utf8_lossy(&out.stderr)
    );
}

#[test]
fn every_readme_example_runs_as_written() {
    let readme = std::fs::read_to_string(common::root().join("README.md")).unwrap();
    let lines = commands(&readme, "## Everyday use");
    assert!(lines.len() >= 12, "{lines:?}");
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path();
    // The files the examples assume: a small bundled scene everywhere.
    let scene = common::data("occluded.glb");
    std::fs::copy(&scene, dir.join("scene.glb")).unwrap();
    std::fs::copy(&scene, dir.join("level.glb")).unwrap();
    std::fs::copy(common::data("lamps.glb"), dir.join("lamps.glb")).unwrap();
    std::fs::create_dir(dir.join("levels")).unwrap();
    std::fs::copy(&scene, dir.join("levels/hall.glb")).unwrap();
    std::fs::copy(common::data("sun.glb"), dir.join("levels/yard.glb")).unwrap();
    // A real level exported without a light or camera (data/levels/).
    std::fs::copy(
        common::root().join("data/levels/living_room/living_room.glb"),
        dir.join("room.glb"),
    )
    .unwrap();
    for a in ["a.gibake", "b.gibake"] {
        let mut args = vec!["bake", "scene.glb", "-o", a];
        args.extend(common::TINY_BAKE);
        gibake(dir, &args);
    }
    let bin_dir = Path::new(env!("CARGO_BIN_EXE_gibake")).parent().unwrap();
    let path = format!(
        "{}:{}",
        bin_dir.display(),
        std::env::var("PATH").unwrap_or_default()
    );
    let mut skipped = Vec::new();
    for line in &lines {
        if let Some((_, why)) = NOT_RUN.iter().find(|(l, _)| l == line) {
            skipped.push(line.clone());
            eprintln!("not run: {line} ({why})");
            continue;
        }
        let t = std::time::Instant::now();
        let out = Command::new("bash")
            .args(["-euo", "pipefail", "-c", line])
            .current_dir(dir)
            .env("PATH", &path)
            .output()
            .unwrap();
        let code = out.status.code();
        let ok = code == Some(0) || (line.starts_with("gibake diff") && code == Some(1));
        assert!(
            ok,
            "README line failed ({code:?}): {line}\n{}",
            String::from_utf8_lossy(&out.stderr)
        );
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert!(
            !stderr.lines().any(|l| l.starts_with("error")),
            "an error line from a successful README line: {line}\n{stderr}"
        );
        eprintln!("ran ({:.1} s): {line}", t.elapsed().as_secs_f64());
    }
    let expected: Vec<String> = NOT_RUN.iter().map(|(l, _)| l.to_string()).collect();
    assert_eq!(skipped, expected, "README lines not run changed");
    // What the examples say they make.
    for f in [
        "scene.gibake/manifest.bin",
        "frame.exr",
        "stats.json",
        "frames/f_003.png",
        "ref.exr",
        "baked/hall.gibake/manifest.bin",
        "baked/yard.gibake/manifest.bin",
        "level.gibake/manifest.bin",
        "diff.md",
    ] {
        assert!(dir.join(f).exists(), "{f} was not made");
    }
}
