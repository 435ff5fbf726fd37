//! The Slurm recipe of docs/pipeline.md, for real: starts a one-node Slurm
//! cluster on this machine (`scripts/slurm/ci-cluster.sh`: Debian
//! `slurm-wlm` and `munge`, installed when missing; no systemd), submits a
//! 4-shard bake of a bundled scene as a job array plus a merge job that
//! depends on it (`scripts/slurm/submit.sh`), waits for the merge, and
//! compares the merged asset's bytes with a single-machine bake
//! (`scripts/slurm/ci-test.sh`). It fails, never skips, when Slurm cannot
//! be installed or started.

use crate::common;

#[test]
fn four_shard_bake_on_a_local_slurm_cluster_equals_the_single_bake() {
    let script = common::root().join("scripts/slurm/ci-test.sh");
    let out = std::process::Command::new("bash")
        .arg(&script)
        .arg(env!("CARGO_BIN_EXE_gibake"))
        .output()
        .unwrap_or_else(|e| panic!("cannot run {}: {e}", script.display()));
    let text = format!(
        "--- stdout ---\n{}\n--- stderr ---\n{}",
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr)
    );
    assert!(
        out.status.success(),
        "{} failed ({}): the Slurm cluster did not start or the sharded bake differs; \
         this test needs root (or sudo) to install and run slurm-wlm and munge\n{text}",
        script.display(),
        out.status
    );
    assert!(
        text.contains("slurm: merged asset is byte-identical"),
        "the script did not confirm the comparison\n{text}"
    );
    eprintln!("{text}");
}
