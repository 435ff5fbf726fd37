//! Faults, farms and first contact (issue 20), end to end through the
//! `gibake` binary: I/O errors and signals injected at every rename, write
//! and removal of a re-bake (strace's `-e inject=`), full disks, two bakes
//! from two PID namespaces (`unshare`), SIGINT/SIGTERM, stale temporaries
//! and symbolic links, closed and full stderr, non-UTF-8 names, the umask,
//! 254-byte names, outputs checked before work, unbounded settings, readers
//! during a replace, and the Slurm scripts against a stand-in `sbatch`.
//!
//! The rule every case checks: the asset at `-o` is the old one or the new
//! one, complete (it loads and verifies), at every instant; a failed or
//! interrupted run leaves no temporary behind once the next run of the same
//! output is done; nothing panics. docs/robustness.md ("Faults") lists each
//! case with its result. strace and unshare are Debian packages (strace,
//! util-linux); scripts/ensure-deps.sh --faults installs strace. A missing
//! tool fails the test with what to install; it never skips.

use crate::common;

use std::ffi::OsStr;
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

use common::{Run, TINY_BAKE};

// ------------------------------------------------------------ helpers

pub(crate) fn gibake_bin() -> &'static str {
    env!("CARGO_BIN_EXE_gibake")
}

/// The bundled corner_bunny scene with its light renamed to `light`
/// (a name with a space tests the Slurm scripts' quoting).
fn scene_with_light(dir: &Path, name: &str, light: &str) -> PathBuf {
    let glb = std::fs::read(common::data("corner_bunny.glb")).expect("bundled scene");
    let json_len = u32::from_le_bytes(glb[12..16].try_into().unwrap()) as usize;
    let mut json: serde_json::Value =
        serde_json::from_slice(&glb[20..20 + json_len]).expect("glb json");
    json["extensions"]["KHR_lights_punctual"]["lights"][0]["name"] = light.into();
    let mut j = serde_json::to_vec(&json).unwrap();
    while !j.len().is_multiple_of(4) {
        j.push(b' ');
    }
    let rest = &glb[20 + json_len..];
    let mut out = Vec::new();
    out.extend_from_slice(&glb[0..8]);
    out.extend_from_slice(&((12 + 8 + j.len() + rest.len()) as u32).to_le_bytes());
    out.extend_from_slice(&(j.len() as u32).to_le_bytes());
    out.extend_from_slice(b"JSON");
    out.extend_from_slice(&j);
    out.extend_from_slice(rest);
    let p = dir.join(name);
    std::fs::write(&p, out).unwrap();
    p
}

pub(crate) fn scene(dir: &Path) -> PathBuf {
    scene_with_light(dir, "s.glb", "spot")
}

pub(crate) fn run(mut c: Command) -> Run {
    c.stdin(Stdio::null());
    common::run_command(c)
}

pub(crate) fn gibake<I, S>(args: I) -> Command
where
    I: IntoIterator<Item = S>,
    S: AsRef<OsStr>,
{
    let mut c = Command::new(gibake_bin());
    c.args(args);
    c
}

/// `bake SCENE -o OUT --vpls N` with the tiny settings, `--force`.
pub(crate) fn bake_args(scene: &Path, out: &Path, vpls: u32) -> Vec<std::ffi::OsString> {
    let mut a: Vec<std::ffi::OsString> = vec![
        "bake".into(),
        scene.into(),
        "-o".into(),
        out.into(),
        "--force".into(),
    ];
    for s in TINY_BAKE {
        a.push(s.into());
    }
    // TINY_BAKE's --vpls 16, then ours (clap takes the last).
    let i = a.iter().position(|x| x == "--vpls").unwrap();
    a[i + 1] = vpls.to_string().into();
    a
}

/// `strace` with fault injection around `gibake ARGS`.
pub(crate) fn under_strace(trace: &str, inject: &str, args: &[std::ffi::OsString]) -> Command {
    need("strace", "strace");
    let mut c = Command::new("strace");
    c.args(["-f", "-qq", "-o", "/dev/null", "-e"])
        .arg(format!("trace={trace}"))
        .arg("-e")
        .arg(format!("inject={inject}"))
        .arg(gibake_bin())
        .args(args);
    c
}

/// Fails (never skips) when `tool` is missing.
pub(crate) fn need(tool: &str, package: &str) {
    let ok = Command::new("sh")
        .args(["-c", &format!("command -v {tool}")])
        .stdout(Stdio::null())
        .status()
        .is_ok_and(|s| s.success());
    assert!(
        ok,
        "{tool} is needed by this test: install the Debian package `{package}` \
         (scripts/ensure-deps.sh --faults)"
    );
}

/// The VPL budget of the asset at `out` if it loads and verifies (the
/// bakes below differ only in `--vpls`), else `None`.
pub(crate) fn asset_vpls(out: &Path) -> Option<u32> {
    gibake_asset::load(out)
        .ok()
        .and_then(|a| a.manifest.settings.vpl_budget)
}

/// Hidden entries of `dir` (temporaries, lock files).
pub(crate) fn hidden(dir: &Path) -> Vec<String> {
    let mut v: Vec<String> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .filter(|n| n.starts_with('.'))
        .collect();
    v.sort();
    v
}

pub(crate) fn no_panic(r: &Run) {
    assert!(
        !r.stderr.contains("panicked") && r.code != Some(101) && r.code != Some(134),
        "panic\n{r}"
    );
}

/// A clean re-bake after a fault: succeeds, leaves the new asset, and no
/// temporary or lock file (the stale ones of a killed run are removed).
fn clean_rebake_after(dir: &Path, scene: &Path, out: &Path, what: &str) {
    let r = run(gibake(bake_args(scene, out, 12)));
    assert_eq!(r.code, Some(0), "{what}: the next bake failed\n{r}");
    assert_eq!(asset_vpls(out), Some(12), "{what}");
    assert_eq!(hidden(dir), Vec::<String>::new(), "{what}: leftovers");
}

// ------------------------------------------------------------ I/O errors

#[test]
fn an_io_error_at_any_step_of_a_rebake_leaves_the_old_asset_or_the_new_one() {
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path();
    let scene = scene(dir);
    let out = dir.join("x.gibake");
    let mut cases = vec![
        ("renameat2", "renameat2:error=EIO:when=1".to_string()),
        ("rename", "rename:error=EIO:when=1".into()),
        ("mkdir", "mkdir:error=EIO:when=1".into()),
        ("mkdir", "mkdir:error=ENOSPC:when=1+".into()),
        ("fsync", "fsync:error=EIO:when=1".into()),
        ("fsync", "fsync:error=EIO:when=3".into()),
        ("unlink", "unlink:error=EIO:when=1+".into()),
        ("unlinkat", "unlinkat:error=EIO:when=1+".into()),
        ("rmdir", "rmdir:error=EIO:when=1+".into()),
        ("linkat,link", "linkat:error=EPERM:when=1+".into()),
        ("flock", "flock:error=ENOLCK:when=1".into()),
    ];
    // A disk that fills up from the N-th write on (stderr's writes count too).
    for n in [1, 2, 3, 5, 8, 13, 21] {
        cases.push(("write", format!("write:error=ENOSPC:when={n}+")));
    }
    for (trace, inject) in cases {
        let r = run(gibake(bake_args(&scene, &out, 16)));
        assert_eq!(r.code, Some(0), "{r}");
        std::fs::write(out.join("notes.txt"), b"mine").unwrap();
        let r = run(under_strace(trace, &inject, &bake_args(&scene, &out, 12)));
        no_panic(&r);
        let now = asset_vpls(&out);
        assert!(
            matches!(now, Some(16) | Some(12)),
            "{inject}: the asset is neither old nor new ({now:?})\n{r}"
        );
        if r.code == Some(0) {
            assert_eq!(
                now,
                Some(12),
                "{inject}: success but not the new asset\n{r}"
            );
        } else {
            assert_eq!(r.code, Some(2), "{inject}\n{r}");
            // (A full disk fails stderr's writes too.)
            if trace != "write" {
                assert!(r.stderr.contains("error: "), "{inject}: one message\n{r}");
            }
        }
        assert_eq!(
            std::fs::read(out.join("notes.txt")).unwrap(),
            b"mine",
            "{inject}: the user's file"
        );
        clean_rebake_after(dir, &scene, &out, &inject);
    }
}

// ------------------------------------------------------------ signals

#[test]
fn killed_at_any_step_the_asset_is_old_or_new_and_the_next_run_cleans_up() {
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path();
    let scene = scene(dir);
    let out = dir.join("x.gibake");
    let cases = [
        ("renameat2", "renameat2:signal=SIGKILL:when=1"),
        ("unlink", "unlink:signal=SIGKILL:when=1"),
        ("unlink", "unlink:signal=SIGKILL:when=3"),
        ("rmdir", "rmdir:signal=SIGKILL:when=1"),
        ("mkdir", "mkdir:signal=SIGKILL:when=1"),
        ("fsync", "fsync:signal=SIGKILL:when=2"),
        ("write", "write:signal=SIGKILL:when=10"),
    ];
    for (trace, inject) in cases {
        let r = run(gibake(bake_args(&scene, &out, 16)));
        assert_eq!(r.code, Some(0), "{r}");
        let r = run(under_strace(trace, inject, &bake_args(&scene, &out, 12)));
        no_panic(&r);
        let now = asset_vpls(&out);
        assert!(
            matches!(now, Some(16) | Some(12)),
            "{inject}: neither old nor new ({now:?})\n{r}"
        );
        clean_rebake_after(dir, &scene, &out, inject);
    }
}

#[test]
fn killed_between_the_two_renames_of_the_fallback_the_next_writer_restores() {
    // Where the file system cannot exchange, two renames: old aside, new in.
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path();
    let scene = scene(dir);
    let out = dir.join("x.gibake");
    for (cmd, outputs) in [("bake", &out), ("merge", &out)] {
        let r = run(gibake(bake_args(&scene, outputs, 16)));
        assert_eq!(r.code, Some(0), "{r}");
        let args = if cmd == "bake" {
            bake_args(&scene, &out, 12)
        } else {
            // Two parts merged over the asset.
            let mut parts = Vec::new();
            for k in 0..2 {
                let p = dir.join(format!("part.{k}"));
                let mut a = bake_args(&scene, &p, 12);
                a.retain(|x| x != "--force");
                a.push("--shard".into());
                a.push(format!("{k}/2").into());
                let r = run(gibake(a));
                assert_eq!(r.code, Some(0), "{r}");
                parts.push(p);
            }
            let mut a: Vec<std::ffi::OsString> = vec!["merge".into()];
            a.extend(parts.iter().map(|p| p.clone().into_os_string()));
            a.extend(["-o".into(), out.clone().into_os_string()]);
            a
        };
        let mut c = under_strace("rename", "rename:signal=SIGKILL:when=2", &args);
        c.env(gibake_output_no_exchange(), "1");
        let r = run(c);
        no_panic(&r);
        assert_eq!(r.code, None, "{cmd}: killed\n{r}");
        // The moment without a directory: the old one is aside, complete.
        let aside: Vec<String> = hidden(dir)
            .into_iter()
            .filter(|n| n.ends_with(".old"))
            .collect();
        assert_eq!(aside.len(), 1, "{cmd}: {:?}", hidden(dir));
        assert_eq!(asset_vpls(&dir.join(&aside[0])), Some(16), "{cmd}");
        // The next writer puts it back first, then replaces it.
        clean_rebake_after(dir, &scene, &out, cmd);
        for k in 0..2 {
            let _ = std::fs::remove_file(dir.join(format!("part.{k}")));
        }
    }
}

fn gibake_output_no_exchange() -> &'static str {
    gibake_output::NO_EXCHANGE_ENV
}

#[test]
fn sigint_and_sigterm_remove_what_the_process_created() {
    use std::os::unix::process::ExitStatusExt;
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path();
    let scene = scene(dir);
    let out = dir.join("x.gibake");
    let r = run(gibake(bake_args(&scene, &out, 16)));
    assert_eq!(r.code, Some(0), "{r}");
    // At the swap (new asset complete in its temporary), in the middle of
    // writing the maps, and while a render writes a frame.
    for (trace, inject) in [
        ("renameat2", "renameat2:signal=SIGTERM:when=1"),
        ("renameat2", "renameat2:signal=SIGINT:when=1"),
        ("mkdir", "mkdir:signal=SIGTERM:when=1"),
        ("fsync", "fsync:signal=SIGINT:when=2"),
    ] {
        let mut c = under_strace(trace, inject, &bake_args(&scene, &out, 12));
        c.stdout(Stdio::null()).stderr(Stdio::null());
        let status = c.status().unwrap();
        let sig = status.signal();
        assert!(
            matches!(sig, Some(2) | Some(15)),
            "{inject}: ended by the signal, as its default would ({status:?})"
        );
        assert!(matches!(asset_vpls(&out), Some(16) | Some(12)), "{inject}");
        assert_eq!(hidden(dir), Vec::<String>::new(), "{inject}: leftovers");
    }
    let frame = dir.join("f.exr");
    let mut args: Vec<std::ffi::OsString> = vec!["render".into(), scene.clone().into()];
    for a in common::TINY_RENDER {
        args.push(a.into());
    }
    args.extend(["-o".into(), frame.clone().into()]);
    let mut c = under_strace("fsync", "fsync:signal=SIGTERM:when=1", &args);
    c.stdout(Stdio::null()).stderr(Stdio::null());
    let status = c.status().unwrap();
    assert_eq!(status.signal(), Some(15), "{status:?}");
    // The signal races the rename: no frame, or the whole frame.
    assert!(
        !frame.exists() || gibake_image::Image::read_exr(&frame).is_ok(),
        "a partial frame"
    );
    assert_eq!(hidden(dir), Vec::<String>::new(), "render: leftovers");
}

// ------------------------------------------------------------ farms

#[test]
fn two_bakes_of_one_output_from_two_pid_namespaces_leave_a_complete_asset() {
    need("unshare", "util-linux");
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path();
    let scene = scene(dir);
    let out = dir.join("x.gibake");
    // Both processes are PID 1 in their own namespace.
    let probe = Command::new("unshare")
        .args([
            "--user",
            "--map-root-user",
            "--pid",
            "--fork",
            "sh",
            "-c",
            "echo $$",
        ])
        .output()
        .expect("unshare");
    assert_eq!(
        String::from_utf8_lossy(&probe.stdout).trim(),
        "1",
        "unshare --user --pid --fork must give PID 1 (user namespaces enabled?)\n{}",
        String::from_utf8_lossy(&probe.stderr)
    );
    for round in 0..3 {
        let spawn = |vpls: u32| {
            let mut c = Command::new("unshare");
            c.args(["--user", "--map-root-user", "--pid", "--fork", gibake_bin()])
                .args(bake_args(&scene, &out, vpls))
                .stdin(Stdio::null())
                .stdout(Stdio::piped())
                .stderr(Stdio::piped());
            c.spawn().expect("spawn")
        };
        let (a, b) = (spawn(16), spawn(12));
        let (a, b) = (a.wait_with_output().unwrap(), b.wait_with_output().unwrap());
        for o in [&a, &b] {
            assert!(
                o.status.success(),
                "round {round}: {}",
                String::from_utf8_lossy(&o.stderr)
            );
        }
        let v = asset_vpls(&out);
        assert!(matches!(v, Some(16) | Some(12)), "round {round}: damaged");
        assert_eq!(hidden(dir), Vec::<String>::new(), "round {round}");
    }
}

#[test]
fn a_second_bake_of_the_same_output_waits_then_finds_it_up_to_date() {
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path();
    let scene = scene(dir);
    let out = dir.join("x.gibake");
    // The first holds the lock for a moment (stopped at its swap by strace's
    // delay injection); the second waits for it, then is up to date.
    let mut args = bake_args(&scene, &out, 16);
    args.retain(|a| a != "--force");
    let mut first = under_strace("renameat2", "renameat2:delay_enter=1500000", &args);
    first.stdout(Stdio::null()).stderr(Stdio::null());
    let mut first = first.spawn().unwrap();
    let lock = dir.join(".x.gibake.lock");
    let t = Instant::now();
    while !lock.exists() && t.elapsed() < Duration::from_secs(20) {
        std::thread::sleep(Duration::from_millis(10));
    }
    let r = run(gibake(args.clone()));
    assert!(first.wait().unwrap().success());
    assert_eq!(r.code, Some(0), "{r}");
    assert!(
        r.stderr.contains("another gibake process is writing it"),
        "{r}"
    );
    assert!(r.stderr.contains("up to date"), "{r}");
    assert_eq!(hidden(dir), Vec::<String>::new());
}

#[test]
fn readers_during_a_replace_see_the_old_asset_or_the_new_one() {
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path();
    let scene = scene(dir);
    let out = dir.join("x.gibake");
    let r = run(gibake(bake_args(&scene, &out, 16)));
    assert_eq!(r.code, Some(0), "{r}");
    let done = std::sync::Arc::new(std::sync::atomic::AtomicBool::new(false));
    let writer = {
        let (done, scene, out) = (done.clone(), scene.clone(), out.clone());
        std::thread::spawn(move || {
            for i in 0..6 {
                let r = run(gibake(bake_args(
                    &scene,
                    &out,
                    if i % 2 == 0 { 12 } else { 16 },
                )));
                assert_eq!(r.code, Some(0), "{r}");
            }
            done.store(true, std::sync::atomic::Ordering::SeqCst);
        })
    };
    let mut reads = 0;
    while !done.load(std::sync::atomic::Ordering::SeqCst) {
        let v = gibake_asset::load(&out);
        assert!(
            v.is_ok(),
            "a reader saw a damaged asset: {}",
            v.unwrap_err()
        );
        reads += 1;
    }
    writer.join().unwrap();
    assert!(reads > 3, "only {reads} reads overlapped the re-bakes");
}

#[test]
fn the_slurm_scripts_keep_arguments_whole_and_fail_when_a_task_fails() {
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path();
    let scene = scene_with_light(dir, "lit.glb", "Key Light");
    let out = dir.join("lit.gibake");
    let standin = common::root().join("tests/slurm_standin");
    let path = format!(
        "{}:{}",
        standin.display(),
        std::env::var("PATH").unwrap_or_default()
    );
    let submit = |light: &str, state: &str| {
        let mut c = Command::new("bash");
        c.arg(common::root().join("scripts/slurm/submit.sh"))
            .args(["--wait"])
            .arg(&scene)
            .arg(&out)
            .arg("3")
            .args(["--light", light])
            .args(TINY_BAKE)
            .env("PATH", &path)
            .env("GIBAKE", gibake_bin())
            .env("SBATCH_STANDIN_DIR", dir.join(state));
        run(c)
    };
    let r = submit("Key Light", "ok");
    assert_eq!(r.code, Some(0), "{r}");
    assert!(gibake_asset::load(&out).is_ok(), "{r}");
    // The parts are removed after the merge.
    assert_eq!(
        std::fs::read_dir(dir.join("lit.gibake.parts"))
            .unwrap()
            .filter(|e| e
                .as_ref()
                .unwrap()
                .file_name()
                .to_string_lossy()
                .starts_with("part-"))
            .count(),
        0
    );
    std::fs::remove_dir_all(&out).unwrap();
    // Every shard fails (no such light): submit.sh fails, no asset.
    let r = submit("No Such Light", "bad");
    assert_ne!(r.code, Some(0), "{r}");
    assert!(r.stderr.contains("sharded bake failed"), "{r}");
    assert!(!out.exists());
}

// ------------------------------------------------------------ names, pipes, modes

#[test]
fn stderr_full_or_closed_is_no_panic() {
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path();
    let scene = scene(dir);
    let out = dir.join("x.gibake");
    let mut c = gibake(bake_args(&scene, &out, 16));
    c.stderr(
        std::fs::File::options()
            .write(true)
            .open("/dev/full")
            .unwrap(),
    );
    let status = c.status().unwrap();
    assert_eq!(status.code(), Some(0), "stderr on a full device");
    // A batch whose stderr pipe closes after one line: every scene baked.
    let s2 = scene_with_light(dir, "t.glb", "spot");
    let cmd = format!(
        "'{}' bake '{}' '{}' --out-dir '{}' {} 2>&1 | head -1 >/dev/null; echo ${{PIPESTATUS[0]}}",
        gibake_bin(),
        scene.display(),
        s2.display(),
        dir.join("batch").display(),
        TINY_BAKE.join(" ")
    );
    let o = Command::new("bash").args(["-c", &cmd]).output().unwrap();
    assert_eq!(String::from_utf8_lossy(&o.stdout).trim(), "0");
    assert!(gibake_asset::load(&dir.join("batch/s.gibake")).is_ok());
    assert!(gibake_asset::load(&dir.join("batch/t.gibake")).is_ok());
}

#[cfg(unix)]
#[test]
fn non_utf8_file_names_are_shown_lossily_everywhere() {
    use std::os::unix::ffi::OsStrExt;
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path();
    let plain = scene(dir);
    let scene = dir.join(OsStr::from_bytes(b"sc\xffene.glb"));
    std::fs::rename(&plain, &scene).unwrap();
    let frame = dir.join(OsStr::from_bytes(b"f\xfe.exr"));
    let stats = dir.join(OsStr::from_bytes(b"st\xfe.json"));
    let mut c = gibake([OsStr::new("render"), scene.as_os_str()]);
    c.args(common::TINY_RENDER)
        .arg("-o")
        .arg(&frame)
        .arg("--stats")
        .arg(&stats);
    let r = run(c);
    assert_eq!(r.code, Some(0), "{r}");
    let j: serde_json::Value = serde_json::from_slice(&std::fs::read(&stats).unwrap()).unwrap();
    assert!(j["scene"].as_str().unwrap().contains('\u{fffd}'), "{j}");
    let asset = dir.join(OsStr::from_bytes(b"a\xff.gibake"));
    let mut a = bake_args(&scene, &asset, 16);
    a.push("--json".into());
    let r = run(gibake(a));
    assert_eq!(r.code, Some(0), "{r}");
    let j: serde_json::Value = serde_json::from_str(&r.stdout).unwrap();
    assert!(j["asset"].as_str().unwrap().contains('\u{fffd}'), "{j}");
    let mut c = gibake([OsStr::new("bake"), scene.as_os_str()]);
    c.arg("--out-dir")
        .arg(dir.join("b"))
        .arg("--json")
        .args(TINY_BAKE);
    let r = run(c);
    assert_eq!(r.code, Some(0), "{r}");
    let j: serde_json::Value = serde_json::from_str(&r.stdout).unwrap();
    assert!(
        j["scenes"][0]["scene"]
            .as_str()
            .unwrap()
            .contains('\u{fffd}'),
        "{j}"
    );
}

#[cfg(unix)]
#[test]
fn output_modes_follow_the_umask() {
    use std::os::unix::fs::PermissionsExt;
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path();
    let scene = scene(dir);
    let frame = dir.join("f.png");
    let stats = dir.join("s.json");
    for (umask, want) in [("022", 0o644), ("077", 0o600), ("002", 0o664)] {
        let cmd = format!(
            "umask {umask}; exec '{}' render '{}' {} -o '{}' --stats '{}'",
            gibake_bin(),
            scene.display(),
            common::TINY_RENDER.join(" "),
            frame.display(),
            stats.display()
        );
        let o = Command::new("sh").args(["-c", &cmd]).output().unwrap();
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        for f in [&frame, &stats] {
            let mode = std::fs::metadata(f).unwrap().permissions().mode() & 0o777;
            assert_eq!(mode, want, "umask {umask}: {} is {mode:o}", f.display());
        }
    }
}

#[test]
fn names_of_254_bytes_work_for_every_output() {
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path();
    let scene = scene(dir);
    let frame = dir.join(format!("{}.exr", "f".repeat(250)));
    let stats = dir.join(format!("{}.json", "s".repeat(249)));
    let mut c = gibake([OsStr::new("render"), scene.as_os_str()]);
    c.args(common::TINY_RENDER)
        .arg("-o")
        .arg(&frame)
        .arg("--stats")
        .arg(&stats);
    let r = run(c);
    assert_eq!(r.code, Some(0), "{r}");
    assert!(frame.is_file() && stats.is_file());
    let asset = dir.join(format!("{}.gibake", "a".repeat(247)));
    let r = run(gibake(bake_args(&scene, &asset, 16)));
    assert_eq!(r.code, Some(0), "{r}");
    let part = dir.join(format!("{}.0", "p".repeat(252)));
    let mut a = bake_args(&scene, &part, 16);
    a.retain(|x| x != "--force");
    a.extend(["--shard".into(), "0/1".into()]);
    let r = run(gibake(a));
    assert_eq!(r.code, Some(0), "{r}");
    assert!(part.is_file());
    assert_eq!(hidden(dir), Vec::<String>::new());
}

#[test]
fn stale_links_named_like_temporaries_are_never_followed() {
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path();
    let scene = scene(dir);
    let victim = dir.join("thesis.tex");
    std::fs::write(&victim, b"precious").unwrap();
    // Links where an old gibake put its temporaries (`.p.0.tmp-PID`) and
    // where this one puts them (`.p.0.XXXXXX.tmp`).
    for name in [".p.0.tmp-1", ".p.0.tmp-2", ".p.0.AbCdEf.tmp"] {
        std::os::unix::fs::symlink(&victim, dir.join(name)).unwrap();
    }
    let part = dir.join("p.0");
    let mut a = bake_args(&scene, &part, 16);
    a.retain(|x| x != "--force");
    a.extend(["--shard".into(), "0/1".into()]);
    let r = run(gibake(a));
    assert_eq!(r.code, Some(0), "{r}");
    assert_eq!(std::fs::read(&victim).unwrap(), b"precious");
    assert!(gibake_asset::load_part(&part).is_ok());
}

// ------------------------------------------------------------ before work

#[test]
fn every_output_is_checked_before_any_work() {
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path();
    let scene = scene(dir);
    let asset = dir.join("x.gibake");
    let r = run(gibake(bake_args(&scene, &asset, 16)));
    assert_eq!(r.code, Some(0), "{r}");
    let quick = |args: Vec<std::ffi::OsString>, needle: &str| {
        let t = Instant::now();
        let r = run(gibake(args));
        assert_eq!(r.code, Some(2), "{r}");
        assert!(r.stderr.contains(needle), "{needle}\n{r}");
        assert!(t.elapsed() < Duration::from_secs(5), "{r}");
    };
    let render = |extra: &[&str]| {
        let mut a: Vec<std::ffi::OsString> = vec![
            "render".into(),
            scene.clone().into(),
            "--bake".into(),
            asset.clone().into(),
        ];
        for s in common::TINY_RENDER {
            a.push(s.into());
        }
        a.extend(extra.iter().map(|s| std::ffi::OsString::from(*s)));
        a
    };
    // --stats names a directory.
    std::fs::create_dir(dir.join("stats.json")).unwrap();
    let stats = dir.join("stats.json");
    let frame = dir.join("one.exr");
    quick(
        render(&[
            "-o",
            frame.to_str().unwrap(),
            "--stats",
            stats.to_str().unwrap(),
        ]),
        "--stats names a directory",
    );
    assert!(!frame.exists(), "nothing written");
    // The 4th frame of a sequence is a directory: refused before frame 0.
    std::fs::create_dir(dir.join("f_3.exr")).unwrap();
    let seq = dir.join("f_#.exr");
    quick(
        render(&["-o", seq.to_str().unwrap(), "--frames", "5"]),
        "f_3.exr: -o names a directory",
    );
    assert!(!dir.join("f_0.exr").exists(), "frame 0 not written");
    // An output directory that does not exist.
    let missing = dir.join("frames/f_###.png");
    quick(
        render(&["-o", missing.to_str().unwrap()]),
        "does not exist (create it first)",
    );
    // `bake -o new.png`: an asset is a directory named .gibake.
    let png = dir.join("new.png");
    quick(bake_args(&scene, &png, 16), "must end in .gibake");
    assert!(!png.exists());
    // `--rsm-size 1` and `--shard` with it: refused before any work.
    let mut a = bake_args(&scene, &dir.join("y.gibake"), 16);
    a.extend(["--rsm-size".into(), "1".into()]);
    quick(a.clone(), "--rsm-size");
    a.extend(["--shard".into(), "0/2".into()]);
    let i = a.iter().position(|x| x == "-o").unwrap();
    a[i + 1] = dir.join("part.0").into();
    quick(a, "--rsm-size");
}

#[test]
fn a_threshold_that_makes_millions_of_vpls_is_refused_once_they_are_counted() {
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path();
    let scene = scene(dir);
    let t = Instant::now();
    let out = dir.join("t.gibake");
    let r = run(gibake([
        OsStr::new("bake"),
        scene.as_os_str(),
        OsStr::new("-o"),
        out.as_os_str(),
        OsStr::new("--threshold"),
        OsStr::new("1e-30"),
    ]));
    assert_eq!(r.code, Some(2), "{r}");
    assert!(r.stderr.contains("--max-memory"), "{r}");
    assert!(t.elapsed() < Duration::from_secs(20), "{:?}", t.elapsed());
    assert!(!dir.join("t.gibake").exists());
}

// ------------------------------------------------------------ first contact

#[test]
fn a_successful_run_prints_no_error_line_and_no_debug_text() {
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path();
    let scene = scene(dir);
    let (a, b) = (dir.join("a.gibake"), dir.join("b.gibake"));
    let mut c = gibake(bake_args(&scene, &a, 16));
    // No session, as in CI, ssh and batch jobs.
    c.env_remove("XDG_RUNTIME_DIR")
        .env_remove("WAYLAND_DISPLAY");
    let r = run(c);
    assert_eq!(r.code, Some(0), "{r}");
    assert!(
        !r.stderr.lines().any(|l| l.starts_with("error")),
        "an error line on success\n{r}"
    );
    let r = run(gibake(bake_args(&scene, &b, 12)));
    assert_eq!(r.code, Some(0), "{r}");
    for json in [false, true] {
        let mut c = gibake([OsStr::new("diff"), a.as_os_str(), b.as_os_str()]);
        if json {
            c.arg("--json");
        }
        let r = run(c);
        assert_eq!(r.code, Some(1), "{r}");
        for debug in ["Some(", "None", "Backends(", "VplRecord"] {
            assert!(!r.stdout.contains(debug), "{debug}\n{r}");
        }
    }
    // What a path is, when it is not an asset.
    for (path, says) in [
        (scene.clone(), "a scene, not a baked asset"),
        (dir.join("none.gibake"), "does not exist"),
    ] {
        let r = run(gibake([OsStr::new("inspect"), path.as_os_str()]));
        assert_eq!(r.code, Some(2), "{r}");
        assert!(r.stderr.contains(says), "{says}\n{r}");
        assert!(!r.stderr.contains("os error"), "{r}");
    }
}

#[test]
fn the_same_scene_under_a_new_name_is_rebaked_to_the_same_bytes_as_a_forced_bake() {
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path();
    let s1 = scene(dir);
    let s2 = dir.join("renamed.glb");
    std::fs::copy(&s1, &s2).unwrap();
    let (a, b) = (dir.join("a.gibake"), dir.join("b.gibake"));
    let mut args = bake_args(&s1, &a, 16);
    args.retain(|x| x != "--force");
    assert_eq!(run(gibake(args)).code, Some(0));
    // Same content, new name: not up to date (the asset records the name).
    let mut args = bake_args(&s2, &a, 16);
    args.retain(|x| x != "--force");
    let r = run(gibake(args));
    assert_eq!(r.code, Some(0), "{r}");
    assert!(r.stderr.contains("file name changed"), "{r}");
    // ... and then equal to a forced bake of the new name, byte for byte.
    assert_eq!(run(gibake(bake_args(&s2, &b, 16))).code, Some(0));
    for f in ["manifest.bin", "vpls.bin", "vpl_maps.exr"] {
        assert_eq!(
            std::fs::read(a.join(f)).unwrap(),
            std::fs::read(b.join(f)).unwrap(),
            "{f}"
        );
    }
}
