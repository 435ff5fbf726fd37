//! Diffing bakes in CI (issue 52), end to end through the `gibake` binary:
//! the five pipeline contracts the issue's fault corpus broke — an
//! up-to-date check on a read-only file system, an up-to-date check that
//! covers the moving objects' sweep, diff images written through a
//! temporary and a rename (a full disk leaves no short file), messages
//! that say a path is a symbolic link (and a link to an asset is written
//! where it points), and stale temporaries removed by a run that writes
//! nothing — then the image-space diff (`gibake diff --scene`) and the CI
//! step of docs/pipeline.md, run as written on two bakes of the bundled
//! corner that differ visibly and on two that differ within tolerance.
//!
//! The read-only and full-disk cases mount in a user and mount namespace
//! (util-linux's `unshare --user --map-root-user --mount`); the killed run
//! uses strace's `-e inject=`. A missing tool fails the test with what to
//! install; it never skips.

use crate::common;
use crate::faults::{
    asset_vpls, bake_args, gibake, gibake_bin, hidden, need, no_panic, run, scene, under_strace,
};

use std::ffi::OsString;
use std::path::Path;
use std::process::Command;

/// Rewrites the glTF JSON of the `.glb` at `src` with `edit` into `dst`
/// (the binary chunk is kept as it is).
pub(crate) fn edit_glb(src: &Path, dst: &Path, edit: impl FnOnce(&mut serde_json::Value)) {
    let glb = std::fs::read(src).expect("read glb");
    let json_len = u32::from_le_bytes(glb[12..16].try_into().unwrap()) as usize;
    let mut json: serde_json::Value =
        serde_json::from_slice(&glb[20..20 + json_len]).expect("glb json");
    edit(&mut json);
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
    std::fs::write(dst, out).expect("write glb");
}

/// `bake_args` without `--force`: a pipeline's plain bake.
fn plain_bake(scene: &Path, out: &Path, vpls: u32) -> Vec<OsString> {
    let mut a = bake_args(scene, out, vpls);
    a.retain(|x| x != "--force");
    a
}

/// One shell command line of `args` (each quoted for `sh`).
fn shell_line(args: &[OsString]) -> String {
    std::iter::once(gibake_bin().into())
        .chain(args.iter().cloned())
        .map(|a| format!("'{}'", a.to_string_lossy().replace('\'', r"'\''")))
        .collect::<Vec<_>>()
        .join(" ")
}

/// Runs the shell `script` in a new user and mount namespace (as its root),
/// where it may mount; the mounts vanish with it.
fn in_mount_namespace(script: &str) -> common::Run {
    need("unshare", "util-linux");
    let mut c = Command::new("unshare");
    c.args(["--user", "--map-root-user", "--mount", "sh", "-c", script]);
    run(c)
}

// ------------------------------------------------- the five contracts

#[test]
fn an_up_to_date_check_works_on_a_read_only_file_system() {
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path();
    let scene = scene(dir);
    let out = dir.join("x.gibake");
    assert_eq!(run(gibake(plain_bake(&scene, &out, 16))).code, Some(0));
    let before = std::fs::read(out.join("manifest.bin")).unwrap();
    let d = dir.display();
    // The checkout mounted read-only over itself: up to date is an answer
    // (exit 0); a bake that is needed is refused, saying why and what.
    let script = format!(
        "mount --bind '{d}' '{d}' && mount -o remount,bind,ro '{d}' && cd '{d}' || exit 99\n\
         touch probe 2>/dev/null && exit 98\n\
         {fresh}; echo \"fresh=$?\" >&2\n\
         {stale}; echo \"stale=$?\" >&2\n",
        fresh = shell_line(&plain_bake(&scene, &out, 16)),
        stale = shell_line(&plain_bake(&scene, &out, 12)),
    );
    let r = in_mount_namespace(&script);
    no_panic(&r);
    assert_eq!(r.code, Some(0), "{r}");
    assert!(
        r.stderr.contains("fresh=0"),
        "up to date on a read-only fs\n{r}"
    );
    assert!(r.stderr.contains("up to date"), "{r}");
    assert!(r.stderr.contains("stale=2"), "{r}");
    assert!(
        r.stderr
            .contains("needs a bake (setting --vpls changed (16 → 12))")
            && r.stderr.contains("Read-only file system"),
        "{r}"
    );
    assert_eq!(std::fs::read(out.join("manifest.bin")).unwrap(), before);
}

#[test]
fn a_changed_sweep_of_the_moving_objects_is_rebaked_to_a_clean_bakes_bytes() {
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path();
    let s = dir.join("s.glb");
    std::fs::copy(common::data("corner_bunny.glb"), &s).unwrap();
    let (a, b) = (dir.join("a.gibake"), dir.join("b.gibake"));
    assert_eq!(run(gibake(plain_bake(&s, &a, 16))).code, Some(0));
    // The lowest ball at half its size: the static scene and the light's
    // view are the same, the moving objects' swept box is not (and with it
    // the reach probe's aim and the --vpls threshold).
    edit_glb(&common::data("corner_bunny.glb"), &s, |j| {
        assert_eq!(j["nodes"][4]["name"], "ball_00");
        j["nodes"][4]["scale"] = serde_json::json!([0.5, 0.5, 0.5]);
    });
    let r = run(gibake(plain_bake(&s, &a, 16)));
    assert_eq!(r.code, Some(0), "{r}");
    assert!(
        r.stderr
            .contains("the moving objects' swept bounds changed"),
        "not re-baked\n{r}"
    );
    // Now up to date, and byte for byte what a clean bake writes.
    let r = run(gibake(plain_bake(&s, &a, 16)));
    assert!(r.stderr.contains("up to date"), "{r}");
    assert_eq!(run(gibake(bake_args(&s, &b, 16))).code, Some(0));
    let names = |d: &Path| {
        let mut v: Vec<_> = std::fs::read_dir(d)
            .unwrap()
            .map(|e| e.unwrap().file_name())
            .collect();
        v.sort();
        v
    };
    assert_eq!(names(&a), names(&b));
    for f in names(&a) {
        assert_eq!(
            std::fs::read(a.join(&f)).unwrap(),
            std::fs::read(b.join(&f)).unwrap(),
            "{f:?}"
        );
    }
}

#[test]
fn diff_images_onto_a_full_disk_leave_no_short_file() {
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path();
    let scene = scene(dir);
    let (a, b, c) = (
        dir.join("a.gibake"),
        dir.join("b.gibake"),
        dir.join("c.gibake"),
    );
    for (out, vpls) in [(&a, 16), (&b, 12), (&c, 8)] {
        assert_eq!(run(gibake(bake_args(&scene, out, vpls))).code, Some(0));
    }
    let diff = |x: &Path, images: &Path| -> Vec<OsString> {
        vec![
            "diff".into(),
            a.clone().into(),
            x.into(),
            "--images".into(),
            images.into(),
        ]
    };
    // What a disk with room writes: A against B.
    let roomy = dir.join("roomy");
    let r = run(gibake(diff(&b, &roomy)));
    assert_eq!(r.code, Some(1), "{r}");
    // And A against C, the images a run with room would leave.
    let roomy_c = dir.join("roomy_c");
    assert_eq!(run(gibake(diff(&c, &roomy_c))).code, Some(1));
    let sizes_of = |name: &str| -> Vec<u64> {
        [&roomy, &roomy_c]
            .iter()
            .filter_map(|d| std::fs::metadata(d.join(name)).map(|m| m.len()).ok())
            .collect()
    };
    assert_eq!(sizes_of("vpl_maps.diff.exr").len(), 2, "{r}");
    // A small tmpfs holding those images, then filled to the last page;
    // A against C onto it fails. Each file left is listed with its size.
    let full = dir.join("full");
    std::fs::create_dir_all(&full).unwrap();
    let script = format!(
        "mount -t tmpfs -o size=64k gibake-full '{f}' || exit 99\n\
         cp '{roomy}'/*.exr '{f}'/ || exit 98\n\
         head -c 1000000 /dev/zero > '{f}/filler' 2>/dev/null\n\
         {cmd}; echo \"diff=$?\" >&2\n\
         rm '{f}/filler'\n\
         for p in '{f}'/* '{f}'/.[!.]*; do [ -e \"$p\" ] && echo \"left $(stat -c %s \"$p\") $(basename \"$p\")\" >&2; done\n",
        f = full.display(),
        roomy = roomy.display(),
        cmd = shell_line(&diff(&c, &full)),
    );
    let r = in_mount_namespace(&script);
    no_panic(&r);
    assert!(r.stderr.contains("diff=2"), "{r}");
    assert!(r.stderr.contains("No space left on device"), "{r}");
    let left: Vec<&str> = r
        .stderr
        .lines()
        .filter_map(|l| l.strip_prefix("left "))
        .collect();
    assert!(!left.is_empty(), "{r}");
    // Old images or new ones, whole: nothing short, no temporary, no lock.
    for line in left {
        let (size, name) = line.split_once(' ').unwrap();
        assert!(
            !name.starts_with('.'),
            "a temporary or lock left: {line}\n{r}"
        );
        assert!(
            sizes_of(name).contains(&size.parse::<u64>().unwrap()),
            "{name}: a short image under its final name ({size} bytes; whole: {:?})\n{r}",
            sizes_of(name)
        );
    }
}

#[test]
fn a_symbolic_link_to_an_asset_is_named_and_written_where_it_points() {
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path();
    let scene = scene(dir);
    let real = dir.join("builds");
    std::fs::create_dir(&real).unwrap();
    let asset = real.join("x.gibake");
    assert_eq!(run(gibake(plain_bake(&scene, &asset, 16))).code, Some(0));
    let link = dir.join("current.gibake");
    std::os::unix::fs::symlink(&asset, &link).unwrap();
    // Up to date through the link.
    let r = run(gibake(plain_bake(&scene, &link, 16)));
    assert_eq!(r.code, Some(0), "{r}");
    assert!(r.stderr.contains("is a symbolic link to"), "{r}");
    assert!(r.stderr.contains("up to date"), "{r}");
    // Stale through the link: baked where it points; the link is kept.
    let r = run(gibake(plain_bake(&scene, &link, 12)));
    assert_eq!(r.code, Some(0), "{r}");
    assert!(
        std::fs::symlink_metadata(&link)
            .unwrap()
            .file_type()
            .is_symlink()
    );
    assert_eq!(asset_vpls(&asset), Some(12));
    assert_eq!(hidden(dir), Vec::<String>::new());
    assert_eq!(hidden(&real), Vec::<String>::new());
    // A link to a file, a dangling link: refused, saying what they are.
    let notes = dir.join("notes.txt");
    std::fs::write(&notes, b"mine").unwrap();
    let to_file = dir.join("f.gibake");
    std::os::unix::fs::symlink(&notes, &to_file).unwrap();
    let dangling = dir.join("d.gibake");
    std::os::unix::fs::symlink(dir.join("gone.gibake"), &dangling).unwrap();
    for (out, says) in [
        (&to_file, "(a regular file), and an asset is a directory"),
        (&dangling, "which does not exist"),
    ] {
        let r = run(gibake(plain_bake(&scene, out, 16)));
        assert_eq!(r.code, Some(2), "{r}");
        assert!(r.stderr.contains("is a symbolic link to"), "{r}");
        assert!(r.stderr.contains(says), "{says}\n{r}");
        assert!(!r.stderr.contains("is not a directory"), "{r}");
    }
    assert_eq!(std::fs::read(&notes).unwrap(), b"mine");
    // The library's own refusal says it too.
    let a = gibake_asset::load(&asset).unwrap();
    let e = gibake_asset::write(&a, &to_file).unwrap_err().to_string();
    assert!(e.contains("is a symbolic link to"), "{e}");
    let e = gibake_asset::write(&a, &notes).unwrap_err().to_string();
    assert!(e.contains("is a regular file, not a directory"), "{e}");
}

#[test]
fn a_run_that_finds_the_asset_up_to_date_removes_a_killed_runs_temporaries() {
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path();
    let scene = scene(dir);
    // Named as the batch below names it (the scene's stem).
    let out = dir.join("s.gibake");
    assert_eq!(run(gibake(plain_bake(&scene, &out, 16))).code, Some(0));
    // A forced re-bake killed at its swap: its new directory stays behind.
    let r = run(under_strace(
        "renameat2",
        "renameat2:signal=SIGKILL:when=1",
        &bake_args(&scene, &out, 16),
    ));
    assert_eq!(r.code, None, "killed\n{r}");
    let left = hidden(dir);
    assert!(
        left.iter().any(|n| n.ends_with(".tmp")),
        "the killed run left its temporary: {left:?}"
    );
    // The next run finds the asset up to date, writes nothing, and tidies.
    let r = run(gibake(plain_bake(&scene, &out, 16)));
    assert_eq!(r.code, Some(0), "{r}");
    assert!(r.stderr.contains("up to date"), "{r}");
    assert!(r.stderr.contains("removed what an earlier run left"), "{r}");
    assert_eq!(hidden(dir), Vec::<String>::new());
    assert_eq!(asset_vpls(&out), Some(16));
    // The batch form does the same.
    let r = run(under_strace(
        "renameat2",
        "renameat2:signal=SIGKILL:when=1",
        &bake_args(&scene, &out, 16),
    ));
    assert_eq!(r.code, None, "killed\n{r}");
    let mut a: Vec<OsString> = vec!["bake".into(), scene.into(), "--out-dir".into()];
    a.push(dir.into());
    for s in common::TINY_BAKE {
        a.push(s.into());
    }
    let r = run(gibake(a));
    assert_eq!(r.code, Some(0), "{r}");
    assert!(r.stderr.contains("up to date"), "{r}");
    assert_eq!(hidden(dir), Vec::<String>::new());
}

// ------------------------------------------- the image diff and CI step

/// The fenced block of `lang` that follows the first line of `doc`
/// containing `after`.
fn block_after(doc: &str, after: &str, lang: &str) -> String {
    let start = doc
        .find(after)
        .unwrap_or_else(|| panic!("docs/pipeline.md has no `{after}`"));
    let fence = format!("```{lang}\n");
    let open = start + doc[start..].find(&fence).expect("a fenced block") + fence.len();
    let close = open + doc[open..].find("\n```").expect("its end") + 1;
    doc[open..close].to_string()
}

/// The `run:` script of the GitHub Actions step named `name`.
fn github_run(yaml: &str, name: &str) -> String {
    let at = yaml
        .find(&format!("- name: {name}\n"))
        .unwrap_or_else(|| panic!("no step `{name}`"));
    let rest = &yaml[at..];
    let line = rest
        .lines()
        .find_map(|l| l.trim_start().strip_prefix("run: "))
        .expect("a one-line run:");
    line.to_string()
}

/// The bundled corner with its spot moved by `dx` along X.
fn corner_with_light_moved(dst: &Path, dx: f64) {
    edit_glb(&common::data("corner_bunny.glb"), dst, |j| {
        assert_eq!(j["nodes"][17]["name"], "spot");
        let x = j["nodes"][17]["translation"][0].as_f64().unwrap();
        j["nodes"][17]["translation"][0] = serde_json::json!(x + dx);
    });
}

/// A git repository holding `levels/corner.glb` (the bundled corner) at
/// its one commit, with `baked/corner.gibake` baked from it with `flags`
/// (the last accepted asset, not committed).
fn repo_with_accepted_level(dir: &Path, flags: &str) {
    let git = |args: &[&str]| {
        let o = Command::new("git")
            .args(["-c", "user.name=ci", "-c", "user.email=ci@example.com"])
            .args(args)
            .current_dir(dir)
            .output()
            .expect("git is needed by this test (Debian package git)");
        assert!(o.status.success(), "git {args:?}: {o:?}");
    };
    std::fs::create_dir_all(dir.join("levels")).unwrap();
    std::fs::create_dir_all(dir.join("baked")).unwrap();
    std::fs::copy(
        common::data("corner_bunny.glb"),
        dir.join("levels/corner.glb"),
    )
    .unwrap();
    git(&["init", "-q"]);
    git(&["add", "levels"]);
    git(&["commit", "-q", "-m", "the accepted level"]);
    let mut c = common::gibake();
    c.current_dir(dir)
        .args(["bake", "levels/corner.glb", "-o", "baked/corner.gibake"])
        .args(flags.split_whitespace());
    let r = run(c);
    assert_eq!(r.code, Some(0), "{r}");
}

/// Runs `script` with `sh` in `dir`, `gibake` first on the `PATH`.
fn sh_in(dir: &Path, script: &str, env: &[(&str, &str)]) -> common::Run {
    let bin = Path::new(gibake_bin()).parent().unwrap().to_owned();
    let path = format!(
        "{}:{}",
        bin.display(),
        std::env::var("PATH").unwrap_or_default()
    );
    let mut c = Command::new("sh");
    c.args(["-c", script]).current_dir(dir).env("PATH", path);
    for (k, v) in env {
        c.env(k, v);
    }
    run(c)
}

/// Small bakes and frames: each diff renders in about a second.
const CI_BAKE: &str = "--vpls 64 --rsm-size 128 --vpl-map-size 32 --shadow-map-size 512";
const CI_DIFF: &str = "--width 160 --height 90";

#[test]
fn the_ci_step_of_docs_pipeline_md_fails_on_a_visible_change_and_passes_a_tolerable_one() {
    let doc = std::fs::read_to_string(common::root().join("docs/pipeline.md")).unwrap();
    let script = block_after(&doc, "`scripts/ci-diff-bakes.sh`:", "sh");
    assert_eq!(
        script,
        std::fs::read_to_string(common::root().join("scripts/ci-diff-bakes.sh")).unwrap(),
        "docs/pipeline.md shows scripts/ci-diff-bakes.sh as it is"
    );
    let plain = block_after(&doc, "A plain shell CI job", "sh");
    let yaml = block_after(&doc, "A GitHub Actions job", "yaml");
    let tmp = tempfile::tempdir().unwrap();
    let env = [("BAKE_FLAGS", CI_BAKE), ("DIFF_FLAGS", CI_DIFF)];

    // A moved light: the plain job, as written (its `scripts/...` is the
    // repository's; `origin/main` is this repository's one commit).
    let visible = tmp.path().join("visible");
    repo_with_accepted_level(&visible, CI_BAKE);
    std::fs::create_dir_all(visible.join("scripts")).unwrap();
    std::fs::write(visible.join("scripts/ci-diff-bakes.sh"), &script).unwrap();
    let plain = plain.replace("origin/main", "HEAD");
    corner_with_light_moved(&visible.join("levels/corner.glb"), -0.5);
    let r = sh_in(&visible, &plain, &env);
    no_panic(&r);
    assert_eq!(r.code, Some(1), "a visible change fails the job\n{r}");
    let summary = std::fs::read_to_string(visible.join("ci-diff/summary.md")).unwrap();
    assert!(
        r.stdout.contains(&summary),
        "the job prints the summary\n{r}"
    );
    assert!(
        summary.contains("## corner: **FAIL**, visible change"),
        "{summary}"
    );
    assert!(
        summary.contains("| camera | 0 s |") && summary.contains("**FAIL** |"),
        "{summary}"
    );
    // Where: a pixel and a world position in the table.
    assert!(
        summary.contains("pixel (") && summary.contains("world ("),
        "{summary}"
    );
    // The picture, by a path relative to the summary, and its heat map.
    let link = summary
        .split("](")
        .nth(1)
        .and_then(|s| s.split(')').next())
        .expect("a picture link");
    assert_eq!(link, "pictures/corner/camera_t0.png", "{summary}");
    let ci = visible.join("ci-diff");
    for p in [
        link,
        "pictures/corner/camera_t0_heat.png",
        "pictures/corner/camera_t0_a.png",
    ] {
        let bytes = std::fs::read(ci.join(p)).unwrap_or_else(|e| panic!("{p}: {e}"));
        assert_eq!(&bytes[..8], b"\x89PNG\r\n\x1a\n", "{p}");
    }
    let heat = png_rgb(&ci.join("pictures/corner/camera_t0_heat.png"));
    assert!(heat.iter().any(|&v| v > 128), "the heat map shows a change");
    assert!(
        heat.chunks(3).any(|p| p == [0, 255, 255]),
        "the largest change is boxed"
    );

    // The same change through the GitHub job's own steps.
    let summary_file = tmp.path().join("step_summary.md");
    std::fs::remove_dir_all(&ci).unwrap();
    let bake_step = github_run(&yaml, "Bake the changed levels and diff them");
    let r = sh_in(
        &visible,
        &bake_step,
        &[env[0], env[1], ("BASE", "HEAD"), ("ACCEPTED", "baked")],
    );
    assert_eq!(r.code, Some(1), "{r}");
    let step = github_run(&yaml, "Summary");
    let r = sh_in(
        &visible,
        &step,
        &[("GITHUB_STEP_SUMMARY", summary_file.to_str().unwrap())],
    );
    assert_eq!(r.code, Some(0), "{r}");
    let posted = std::fs::read_to_string(&summary_file).unwrap();
    assert!(posted.contains("## corner: **FAIL**"), "{posted}");

    // A light nudged by a tenth of a millimetre: the data differ (another
    // static scene), nobody sees it; the script as written passes.
    let tolerable = tmp.path().join("tolerable");
    repo_with_accepted_level(&tolerable, CI_BAKE);
    corner_with_light_moved(&tolerable.join("levels/corner.glb"), -1e-4);
    let mut e = env.to_vec();
    e.push(("BASE", "HEAD"));
    let r = sh_in(&tolerable, &script, &e);
    no_panic(&r);
    assert_eq!(r.code, Some(0), "a change within tolerance passes\n{r}");
    let summary = std::fs::read_to_string(tolerable.join("ci-diff/summary.md")).unwrap();
    assert!(
        summary.contains("## corner: **PASS**, no visible change"),
        "{summary}"
    );
    assert!(
        summary.contains("DIFFERENT SCENES"),
        "the data diff is there\n{summary}"
    );
    assert!(summary.contains("No visible change."), "{summary}");
}

/// The RGB8 pixels of a PNG the binary wrote.
fn png_rgb(path: &Path) -> Vec<u8> {
    let decoder = png::Decoder::new(std::io::BufReader::new(std::fs::File::open(path).unwrap()));
    let mut reader = decoder.read_info().unwrap();
    let mut buf = vec![0; reader.output_buffer_size().unwrap()];
    let info = reader.next_frame(&mut buf).unwrap();
    assert_eq!(info.color_type, png::ColorType::Rgb);
    buf.truncate(info.buffer_size());
    buf
}

#[test]
fn diff_scene_judges_by_the_images_and_refuses_what_it_cannot_compare() {
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path();
    let corner = dir.join("corner.glb");
    std::fs::copy(common::data("corner_bunny.glb"), &corner).unwrap();
    let bake = |scene: &Path, out: &Path, vpls: &str| {
        let mut c = common::gibake();
        c.args(["bake"]).arg(scene).arg("-o").arg(out);
        let flags = CI_BAKE.replace("--vpls 64", &format!("--vpls {vpls}"));
        c.args(flags.split_whitespace());
        let r = run(c);
        assert_eq!(r.code, Some(0), "{r}");
    };
    let (a, b) = (dir.join("a.gibake"), dir.join("b.gibake"));
    bake(&corner, &a, "64");
    bake(&corner, &b, "60");
    let diff = |extra: &[&dyn AsRef<std::ffi::OsStr>]| {
        let mut c = common::gibake();
        c.arg("diff").arg(&a).arg(&b);
        for e in extra {
            c.arg(e);
        }
        run(c)
    };
    // The data differ (another budget): exit 1 without --scene ...
    assert_eq!(diff(&[]).code, Some(1));
    // ... and within a stated tolerance nobody sees it: exit 0 with it;
    // the JSON has both diffs. (64 against 60 VPLs sits at the default
    // FLIP bar at this size: 0.0192 before the later bounces' VPLs got a
    // descent of their own, 0.0202 after, 0.023 after bake method revision
    // 10; the tolerance is given here.)
    let r = diff(&[
        &"--scene",
        &corner,
        &"--width",
        &"96",
        &"--height",
        &"54",
        &"--max-flip",
        &"0.03",
        &"--json",
    ]);
    assert_eq!(r.code, Some(0), "{r}");
    let j: serde_json::Value = serde_json::from_str(&r.stdout).expect("one JSON object");
    assert!(
        j["differences"].as_array().is_some_and(|d| !d.is_empty()),
        "{j}"
    );
    let views = j["image_diff"]["views"]
        .as_array()
        .expect("image_diff.views");
    assert_eq!(views.len(), 1, "{j}");
    assert_eq!(views[0]["view"], "camera");
    assert_eq!(j["image_diff"]["visible"], false);
    let flip = views[0]["flip"].as_f64().unwrap();
    assert!(flip > 0.0 && flip < 0.03, "{flip}");
    // Two views and two times: four rows; the look-at view is named. (The
    // camera's FLIP between the two budgets at 64×36 was 0.017 before bake
    // method revision 10 counted the bunny's small triangles in the later
    // bounces, 0.021 after: at the default bar; the tolerance is stated,
    // as above.)
    let r = diff(&[
        &"--scene",
        &corner,
        &"--width",
        &"64",
        &"--height",
        &"36",
        &"--view=2,1.5,2,-0.5,0.5,-0.5,50",
        &"--view-camera",
        &"camera",
        &"--time",
        &"0",
        &"--time",
        &"0.5",
        &"--max-flip",
        &"0.03",
    ]);
    assert_eq!(r.code, Some(0), "{r}");
    assert_eq!(r.stdout.matches(" at t = ").count(), 4, "{r}");
    assert!(r.stdout.contains("view at t = 0.5 s"), "{r}");

    // Refused, exit 2, before any render: one --scene for two levels ...
    let moved = dir.join("moved.glb");
    corner_with_light_moved(&moved, -0.5);
    let c = dir.join("c.gibake");
    bake(&moved, &c, "64");
    let mut cmd = common::gibake();
    cmd.arg("diff").arg(&a).arg(&c).arg("--scene").arg(&corner);
    let r = run(cmd);
    assert_eq!(r.code, Some(2), "{r}");
    assert!(r.stderr.contains("--scene A_SCENE --scene B_SCENE"), "{r}");
    // ... a level without a camera and no --view ...
    let room = dir.join("room.glb");
    edit_glb(&corner, &room, |j| {
        j["nodes"][18].as_object_mut().unwrap().remove("camera");
    });
    let mut cmd = common::gibake();
    cmd.arg("diff").arg(&a).arg(&b).arg("--scene").arg(&room);
    let r = run(cmd);
    assert_eq!(r.code, Some(2), "{r}");
    assert!(r.stderr.contains("the level has no camera"), "{r}");
    // ... a view without --scene, --images naming a file, --markdown not .md.
    let notes = dir.join("notes.txt");
    std::fs::write(&notes, b"mine").unwrap();
    for (args, says) in [
        (
            vec!["--view=1,1,1,0,0,0".to_string()],
            "give --scene LEVEL too",
        ),
        (
            vec!["--images".into(), notes.display().to_string()],
            "is a regular file",
        ),
        (
            vec!["--markdown".into(), dir.join("s.txt").display().to_string()],
            "--markdown must name a .md or .markdown file",
        ),
    ] {
        let mut cmd = common::gibake();
        cmd.arg("diff").arg(&a).arg(&b).args(&args);
        let r = run(cmd);
        assert_eq!(r.code, Some(2), "{args:?}\n{r}");
        assert!(r.stderr.contains(says), "{says}\n{r}");
    }
    assert_eq!(std::fs::read(&notes).unwrap(), b"mine");
}
