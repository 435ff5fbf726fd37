//! `gibake bench frame`: a small run against a baseline that is this
//! binary behind a wrapper whose `bake --help` hides `--sun` (so a level
//! that needs a sun falls back to today's `--bounces 1`, as against a
//! binary from before `--sun`), checking the table and the JSON (every
//! level row, the passes, finite ratios, the fallback named); and the
//! bad baselines and levels that must end with exit code 2 and one clear
//! message.

use std::path::Path;

use crate::common::{gibake, run_command};

/// A wrapper around this test run's gibake whose `bake --help` lacks
/// `--sun` (everything else is gibake itself).
fn wrapper_without_sun(dir: &Path) -> std::path::PathBuf {
    use std::os::unix::fs::PermissionsExt;
    let path = dir.join("old-gibake");
    let me = env!("CARGO_BIN_EXE_gibake");
    std::fs::write(
        &path,
        format!(
            "#!/bin/sh\nif [ \"$1\" = bake ] && [ \"$2\" = --help ]; then\n  '{me}' bake --help | grep -v -e '--sun'\n  exit 0\nfi\nexec '{me}' \"$@\"\n"
        ),
    )
    .unwrap();
    std::fs::set_permissions(&path, std::fs::Permissions::from_mode(0o755)).unwrap();
    path
}

#[test]
fn bench_frame_reports_every_level_and_pass_with_ratios() {
    let dir = tempfile::tempdir().unwrap();
    let base = wrapper_without_sun(dir.path());
    let json_path = dir.path().join("frame.json");
    let md_path = dir.path().join("frame.md");
    let mut c = gibake();
    c.args(["bench", "frame", "--baseline"])
        .arg(&base)
        .args([
            "--baseline-name",
            "old",
            "--levels",
            "corner_bunny,gallery",
            "--size",
            "64x36",
            "--reps",
            "1",
            "--frames",
            "2",
            "--vpls",
            "64",
            "--work",
        ])
        .arg(dir.path().join("work"))
        .arg("--json")
        .arg(&json_path)
        .arg("--markdown")
        .arg(&md_path);
    let r = run_command(c);
    assert_eq!(r.code, Some(0), "{r}");
    // The table: one row per level in the summary, the baseline named, the
    // fallback marked and explained.
    let md = std::fs::read_to_string(&md_path).unwrap();
    assert!(r.stdout.contains(md.trim()), "stdout is the table:\n{r}");
    let summary_row = |level: &str| {
        md.lines()
            .find(|l| l.starts_with(&format!("| {level} | 64×36 |")))
            .unwrap_or_else(|| panic!("no row for {level}:\n{md}"))
            .to_string()
    };
    assert!(summary_row("corner_bunny").contains("`old`"), "{md}");
    assert!(
        summary_row("gallery").contains("today `--bounces 1` ¹"),
        "{md}"
    );
    assert!(md.contains("`gallery`: its `bake` has no --sun"), "{md}");
    for pass in ["frame", "shade", "gbuffer", "vpl maps"] {
        assert!(
            md.contains(&format!("| corner_bunny | 64×36 | {pass} |")),
            "no {pass} row for corner_bunny:\n{md}"
        );
    }
    // The JSON: every level, the passes, finite ratios.
    let j: serde_json::Value = serde_json::from_slice(&std::fs::read(&json_path).unwrap()).unwrap();
    assert_eq!(j["baseline_name"], "old");
    assert_eq!(j["same_binary"], false);
    let levels = j["levels"].as_array().unwrap();
    assert_eq!(
        levels
            .iter()
            .map(|l| l["level"].as_str().unwrap())
            .collect::<Vec<_>>(),
        ["corner_bunny", "gallery"]
    );
    assert_eq!(levels[0]["reference"], "baseline");
    assert!(levels[0]["baseline_failed"].is_null());
    assert_eq!(levels[1]["reference"], "today --bounces 1");
    assert!(
        levels[1]["baseline_failed"]
            .as_str()
            .unwrap()
            .contains("--sun")
    );
    assert_eq!(levels[1]["renders"]["baseline"], 0);
    for l in levels {
        let passes = l["passes"].as_array().unwrap();
        let get = |name: &str| {
            passes
                .iter()
                .find(|p| p["pass"] == name)
                .unwrap_or_else(|| panic!("{}: no pass {name}: {passes:?}", l["level"]))
        };
        for name in ["frame", "shade", "gbuffer"] {
            let p = get(name);
            for k in ["reference_ms", "today_ms", "today_bounces1_ms"] {
                let ms = p[k].as_f64().unwrap();
                assert!(
                    ms.is_finite() && ms > 0.0,
                    "{}: {name} {k} = {ms}",
                    l["level"]
                );
            }
            for k in ["today_over_reference", "default_over_bounces1"] {
                let q = &p[k];
                let (lo, m, hi) = (
                    q["min"].as_f64().unwrap(),
                    q["median"].as_f64().unwrap(),
                    q["max"].as_f64().unwrap(),
                );
                assert!(
                    lo > 0.0 && lo <= m && m <= hi && hi.is_finite(),
                    "{}: {name} {k}: {q}",
                    l["level"]
                );
            }
        }
        // The frame is the sum of the passes.
        let sum: f64 = passes
            .iter()
            .filter(|p| p["pass"] != "frame")
            .filter_map(|p| p["today_ms"].as_f64())
            .sum();
        let frame = get("frame")["today_ms"].as_f64().unwrap();
        assert!(
            frame > 0.0 && sum > 0.0,
            "{}: frame {frame}, passes {sum}",
            l["level"]
        );
    }
    // The moving balls corner_bunny animates reach the VPL maps.
    let merge = levels[0]["passes"]
        .as_array()
        .unwrap()
        .iter()
        .find(|p| p["pass"] == "vpl maps")
        .expect("corner_bunny has a VPL-map merge");
    assert!(merge["today_ms"].as_f64().unwrap() > 0.0);
}

#[test]
fn bench_frame_refuses_bad_baselines_and_levels_with_exit_2() {
    use std::os::unix::fs::PermissionsExt;
    let dir = tempfile::tempdir().unwrap();
    let not_exec = dir.path().join("notes.txt");
    std::fs::write(&not_exec, "not a binary").unwrap();
    let other = dir.path().join("other-tool");
    std::fs::write(&other, "#!/bin/sh\necho 'some other tool'\n").unwrap();
    std::fs::set_permissions(&other, std::fs::Permissions::from_mode(0o755)).unwrap();
    let failing = dir.path().join("failing");
    std::fs::write(&failing, "#!/bin/sh\necho 'boom' >&2\nexit 3\n").unwrap();
    std::fs::set_permissions(&failing, std::fs::Permissions::from_mode(0o755)).unwrap();
    let me = Path::new(env!("CARGO_BIN_EXE_gibake"));
    let cases: [(&Path, &str, &str); 5] = [
        (&dir.path().join("missing"), "corner_bunny", "no such file"),
        (&not_exec, "corner_bunny", "not a working gibake binary"),
        (&other, "corner_bunny", "not a gibake binary"),
        (&failing, "corner_bunny", "exit code 3: boom"),
        (me, "no_such_level", "--levels: no level \"no_such_level\""),
    ];
    for (base, level, want) in cases {
        let mut c = gibake();
        c.args(["bench", "frame", "--baseline"])
            .arg(base)
            .args(["--levels", level, "--size", "32x18", "--work"])
            .arg(dir.path().join("work"));
        let r = run_command(c);
        assert_eq!(r.code, Some(2), "{r}");
        let line = r
            .stderr
            .lines()
            .find(|l| l.starts_with("error:"))
            .unwrap_or_default();
        assert!(line.contains(want), "want {want:?} in the error:\n{r}");
        if level == "corner_bunny" {
            assert!(
                line.contains(&base.display().to_string()),
                "the error names the baseline:\n{r}"
            );
        }
        assert!(r.stdout.is_empty(), "no table on a refusal:\n{r}");
    }
    // No --baseline at all.
    let mut c = gibake();
    c.args(["bench", "frame", "--size", "32x18"]);
    let r = run_command(c);
    assert_eq!(r.code, Some(2), "{r}");
    assert!(r.stderr.contains("needs --baseline BIN"), "{r}");
}
