//! `gibake bench quality --quick` runs, and its JSON has a finite error and
//! a finite time for every mode, so the benchmark cannot rot unnoticed.

use std::process::Command;

#[test]
fn quick_quality_bench_reports_every_mode() {
    let dir = tempfile::tempdir().unwrap();
    let out = Command::new(env!("CARGO_BIN_EXE_gibake"))
        .args([
            "bench",
            "quality",
            "--quick",
            "--scenes",
            "occluded",
            "--random-scenes",
            "0",
            "--out",
        ])
        .arg(dir.path())
        .output()
        .unwrap();
    let stdout = String::from_utf8_lossy(&out.stdout);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(
        out.status.success(),
        "gibake bench failed ({:?})\nstdout:\n{stdout}\nstderr:\n{stderr}",
        out.status
    );
    assert!(stdout.contains("| mode |"), "no table printed:\n{stdout}");
    let json: serde_json::Value =
        serde_json::from_slice(&std::fs::read(dir.path().join("quality.json")).unwrap()).unwrap();
    assert!(
        json["adapter"].as_str().is_some_and(|a| !a.is_empty()),
        "no adapter named"
    );
    let scenes = json["scenes"].as_array().unwrap();
    assert_eq!(scenes.len(), 1);
    assert_eq!(scenes[0]["scene"], "occluded");
    let rows = scenes[0]["rows"].as_array().unwrap();
    let finite = |v: &serde_json::Value| v.as_f64().is_some_and(|x| x.is_finite() && x >= 0.0);
    for mode in [
        "full",
        "full+later",
        "naive",
        "rsm",
        "direct",
        "indirect",
        "reference",
    ] {
        let of_mode: Vec<_> = rows.iter().filter(|r| r["mode"] == mode).collect();
        assert!(!of_mode.is_empty(), "no row for mode {mode}: {rows:?}");
        for r in of_mode {
            assert!(finite(&r["rel_mse"]), "{mode}: error not finite: {r}");
            assert!(
                finite(&r["every_rel_mse"]),
                "{mode}: error against every bounce not finite: {r}"
            );
            assert!(finite(&r["frame_ms"]), "{mode}: time not finite: {r}");
        }
    }
    // Against the every-bounce reference, the default bake (every bounce)
    // has less indirect error than the first bounce alone at the same
    // budget (occluded.glb is a room lit from outside).
    for budget in [64, 250] {
        let err = |mode: &str| {
            rows.iter()
                .find(|r| r["mode"] == mode && r["vpl_budget"] == budget && r["interleave"] == 1)
                .and_then(|r| r["every_indirect_rel_mse"].as_f64())
                .unwrap_or_else(|| panic!("no {mode} row at {budget}: {rows:?}"))
        };
        assert!(
            err("full+later") < err("full"),
            "{budget} VPLs: every bounce {} against the first alone {}",
            err("full+later"),
            err("full")
        );
    }
    for r in rows.iter().filter(|r| r["vpl_budget"].is_u64()) {
        assert!(finite(&r["bake_seconds"]), "bake time not finite: {r}");
    }
    assert!(dir.path().join("report.md").is_file());
    let png = std::fs::read(dir.path().join("quality_occluded.png")).unwrap();
    assert_eq!(&png[..8], b"\x89PNG\r\n\x1a\n");
}
