//! Faults around the derivation: atomic `-o` output, temporary files,
//! signals, full disks, unwritable and unreadable paths, closed pipes,
//! runaway derivations and size limits. Every test runs the real binary.

mod common;

use common::{
    assert_listing, finish, listing, lsgen, lsgen_under_sh, run, spawn_with, tempdir, write, Run,
    Started,
};
use std::fs;
use std::os::unix::fs::MetadataExt;
use std::os::unix::process::ExitStatusExt;
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::thread;
use std::time::{Duration, Instant};

/// `F -> FF`: generation n has 2^n modules. Tests run it with
/// [`stepwise`], the step-by-step engine with its temporary generations
/// (deterministic context-free systems are otherwise expanded depth first,
/// without them, and far faster than these tests stop them).
const DOUBLING: &str = "productions:\nF -> FF\naxiom: F\n";
const OLD: &str = "old contents\n";

fn doubled(n: u32) -> Vec<u8> {
    let mut v = vec![b'F'; 1 << n];
    v.push(b'\n');
    v
}

/// lsgen forced onto the step-by-step engine (`--strategy step`).
fn stepwise() -> Command {
    let mut c = lsgen();
    c.args(["--strategy", "step"]);
    c
}

/// Start lsgen with stdout discarded and stderr captured.
fn spawn(cmd: &mut Command) -> Started {
    spawn_with(cmd, Stdio::null(), Stdio::null(), Stdio::piped())
}

/// An error without a source location: one `lsgen: SUBJECT: error: ...`
/// line; returns it.
fn plain_error<'a>(r: &'a Run, subject: &str) -> &'a str {
    let line = r.assert_one_error();
    let want = format!("lsgen: {subject}: error: ");
    assert!(
        line.starts_with(&want),
        "expected {want:?}...; stderr:\n{}",
        r.stderr
    );
    line
}

// --- (a) atomic replacement ------------------------------------------------

#[test]
fn success_replaces_an_existing_file_atomically() {
    let dir = tempdir();
    let d = dir.path();
    let input = write(d, "in.ls", DOUBLING);
    let out = write(d, "out.txt", OLD);
    let old_ino = fs::metadata(&out).unwrap().ino();
    let n = 22;
    let want = doubled(n);
    let mut child = spawn(
        stepwise()
            .arg(&input)
            .arg("-n")
            .arg(n.to_string())
            .arg("-o")
            .arg(&out),
    );
    // While it runs, the name always holds either the old file or the
    // complete new one.
    let mut polls = 0;
    while child.try_wait().unwrap().is_none() {
        let meta = fs::metadata(&out).expect("out.txt vanished during the run");
        let len = meta.len();
        assert!(
            len == OLD.len() as u64 || len == want.len() as u64,
            "out.txt seen with {len} bytes: a partial file"
        );
        polls += 1;
        thread::sleep(Duration::from_millis(2));
    }
    let r = finish(child, Duration::from_secs(60));
    assert!(polls > 0);
    r.assert_no_crash();
    assert_eq!(r.code(), Some(0), "stderr:\n{}", r.stderr);
    assert!(r.stderr.is_empty(), "stderr:\n{}", r.stderr);
    assert!(fs::read(&out).unwrap() == want, "wrong output");
    assert_ne!(
        fs::metadata(&out).unwrap().ino(),
        old_ino,
        "the file was rewritten in place, not replaced"
    );
    assert_listing(d, &["in.ls", "out.txt"]);
}

#[test]
fn success_creates_a_new_file_and_nothing_else() {
    let dir = tempdir();
    let d = dir.path();
    let input = write(d, "in.ls", DOUBLING);
    let out = d.join("new.txt");
    let r = run(stepwise().arg(&input).args(["-n", "5", "-o"]).arg(&out));
    assert_eq!(r.code(), Some(0), "stderr:\n{}", r.stderr);
    assert!(r.stdout.is_empty());
    assert_eq!(fs::read(&out).unwrap(), doubled(5));
    assert_listing(d, &["in.ls", "new.txt"]);
}

#[test]
fn output_may_replace_the_input_itself() {
    let dir = tempdir();
    let d = dir.path();
    let input = write(d, "in.ls", DOUBLING);
    let r = run(stepwise().arg(&input).args(["-n", "3", "-o"]).arg(&input));
    assert_eq!(r.code(), Some(0), "stderr:\n{}", r.stderr);
    assert_eq!(fs::read(&input).unwrap(), doubled(3));
    assert_listing(d, &["in.ls"]);
}

#[test]
fn replacing_keeps_the_permissions_of_the_existing_file() {
    use std::os::unix::fs::PermissionsExt;
    let dir = tempdir();
    let d = dir.path();
    let input = write(d, "in.ls", DOUBLING);
    let out = write(d, "out.txt", OLD);
    fs::set_permissions(&out, fs::Permissions::from_mode(0o600)).unwrap();
    let r = run(stepwise().arg(&input).args(["-n", "3", "-o"]).arg(&out));
    assert_eq!(r.code(), Some(0), "stderr:\n{}", r.stderr);
    assert_eq!(fs::read(&out).unwrap(), doubled(3));
    let mode = fs::metadata(&out).unwrap().permissions().mode() & 0o7777;
    assert_eq!(mode, 0o600, "mode {mode:o}");
}

/// An `LD_PRELOAD` shim that makes every `O_TMPFILE` open fail with
/// EOPNOTSUPP, as on file systems without it (NFS, CIFS, FUSE, vfat...).
const NO_TMPFILE_SHIM: &str = r#"
#define _GNU_SOURCE
#include <dlfcn.h>
#include <errno.h>
#include <fcntl.h>
#include <stdarg.h>
#define WRAP(name, CALL, ...)                                              \
    int name(__VA_ARGS__, int flags, ...) {                                \
        va_list ap; va_start(ap, flags); int mode = va_arg(ap, int);       \
        va_end(ap);                                                        \
        if ((flags & __O_TMPFILE) == __O_TMPFILE) {                        \
            errno = EOPNOTSUPP; return -1;                                 \
        }                                                                  \
        static int (*real)(); if (!real) real = dlsym(RTLD_NEXT, #name);   \
        return CALL;                                                       \
    }
WRAP(open, real(path, flags, mode), const char *path)
WRAP(open64, real(path, flags, mode), const char *path)
WRAP(openat, real(dirfd, path, flags, mode), int dirfd, const char *path)
WRAP(openat64, real(dirfd, path, flags, mode), int dirfd, const char *path)
"#;

/// Build the shim with the system C compiler; None if there is none.
fn build_no_tmpfile_shim(dir: &Path) -> Option<PathBuf> {
    let src = write(dir, "notmp.c", NO_TMPFILE_SHIM);
    let so = dir.join("notmp.so");
    let ok = Command::new("cc")
        .args(["-shared", "-fPIC", "-o"])
        .arg(&so)
        .arg(&src)
        .arg("-ldl")
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .status()
        .is_ok_and(|s| s.success());
    ok.then_some(so)
}

/// (lsgen before e2ca773 always failed here, after the whole derivation,
/// with `cannot write: No such file or directory`: linkat through
/// /proc/self/fd cannot link the deleted file tempfile falls back to.)
#[test]
fn output_on_a_file_system_without_o_tmpfile() {
    let shim_dir = tempdir();
    let Some(shim) = build_no_tmpfile_shim(shim_dir.path()) else {
        eprintln!("skipped: no C compiler for the LD_PRELOAD shim");
        return;
    };
    let dir = tempdir();
    let tmp = tempdir();
    let d = dir.path();
    let input = write(d, "in.ls", DOUBLING);
    let out = write(d, "out.txt", OLD);
    let r = run(stepwise()
        .env("LD_PRELOAD", &shim)
        .arg(&input)
        .args(["-n", "3", "--tmpdir"])
        .arg(tmp.path())
        .arg("-o")
        .arg(&out));
    r.assert_no_crash();
    assert_eq!(r.code(), Some(0), "stderr:\n{}", r.stderr);
    assert_eq!(fs::read(&out).unwrap(), doubled(3));
    assert_listing(d, &["in.ls", "out.txt"]);
    assert_listing(tmp.path(), &[]);
}

/// Without O_TMPFILE the complete output is copied into a named temp file
/// at the end; SIGINT during that copy must not leave it behind.
#[test]
fn sigint_during_the_final_copy_without_o_tmpfile() {
    let shim_dir = tempdir();
    let Some(shim) = build_no_tmpfile_shim(shim_dir.path()) else {
        eprintln!("skipped: no C compiler for the LD_PRELOAD shim");
        return;
    };
    let dir = tempdir();
    let d = dir.path();
    let input = write(d, "in.ls", DOUBLING);
    let out = d.join("out.txt");
    // 2^26 bytes of output: the copy takes long enough to be caught.
    let child = spawn(
        stepwise()
            .env("LD_PRELOAD", &shim)
            .arg(&input)
            .args(["-n", "26", "-o"])
            .arg(&out),
    );
    let pid = child.id().to_string();
    let deadline = Instant::now() + Duration::from_secs(120);
    let mut caught = false;
    let mut child = child;
    while Instant::now() < deadline && child.try_wait().unwrap().is_none() {
        if listing(d).iter().any(|n| n.starts_with(".lsgen-")) {
            let _ = Command::new("kill").args(["-INT", &pid]).status();
            caught = true;
            break;
        }
        thread::sleep(Duration::from_millis(1));
    }
    let r = finish(child, Duration::from_secs(60));
    if !caught {
        eprintln!("skipped: the final copy was not seen ({:?})", r.status);
        return;
    }
    let names = listing(d);
    assert!(
        !names.iter().any(|n| n.starts_with(".lsgen-")),
        "temp file left behind: {names:?}"
    );
}

#[test]
fn failure_without_o_tmpfile_leaves_nothing_behind() {
    let shim_dir = tempdir();
    let Some(shim) = build_no_tmpfile_shim(shim_dir.path()) else {
        eprintln!("skipped: no C compiler for the LD_PRELOAD shim");
        return;
    };
    let dir = tempdir();
    let tmp = tempdir();
    let d = dir.path();
    let input = write(
        d,
        "in.ls",
        "derivation length: 6\nproductions:\nF -> FF\nA(x) -> A(x-1) B(1/x)\naxiom: F A(3)\n",
    );
    let out = write(d, "out.txt", OLD);
    let r = run(lsgen()
        .env("LD_PRELOAD", &shim)
        .arg(&input)
        .arg("--tmpdir")
        .arg(tmp.path())
        .arg("-o")
        .arg(&out));
    assert!(
        r.assert_one_error().contains("division by zero"),
        "stderr:\n{}",
        r.stderr
    );
    assert_eq!(fs::read_to_string(&out).unwrap(), OLD);
    assert_listing(d, &["in.ls", "out.txt"]);
    assert_listing(tmp.path(), &[]);
}

// --- (b) failure leaves an existing file alone ------------------------------

#[test]
fn runtime_error_at_a_late_step_leaves_the_existing_file_untouched() {
    let dir = tempdir();
    let d = dir.path();
    // F doubles each step; A(x) divides by x, which reaches 0 in step 19.
    let input = write(
        d,
        "in.ls",
        "derivation length: 20\nproductions:\nF -> FF\nA(x) -> A(x-1) B(10/x)\naxiom: F A(18)\n",
    );
    let out = write(d, "out.txt", OLD);
    let before = fs::metadata(&out).unwrap();
    let r = run(lsgen().arg(&input).arg("-o").arg(&out));
    let line = r.assert_one_error();
    assert!(
        line.contains(":4:18: error: division by zero (in step 19)"),
        "stderr:\n{}",
        r.stderr
    );
    assert_eq!(fs::read_to_string(&out).unwrap(), OLD);
    let after = fs::metadata(&out).unwrap();
    assert_eq!(after.ino(), before.ino());
    assert_eq!(after.mtime_nsec(), before.mtime_nsec());
    assert_listing(d, &["in.ls", "out.txt"]);
}

#[test]
fn input_error_leaves_the_existing_file_untouched() {
    let dir = tempdir();
    let d = dir.path();
    let input = write(d, "in.ls", "productions:\nF -> FF\naxiom: F F)\n");
    let out = write(d, "out.txt", OLD);
    let r = run(lsgen().arg(&input).arg("-o").arg(&out));
    r.assert_one_error();
    assert_eq!(fs::read_to_string(&out).unwrap(), OLD);
    assert_listing(d, &["in.ls", "out.txt"]);
}

// --- (c), (d) signals and temporary files ------------------------------------

#[derive(Clone, Copy, Debug)]
enum Stop {
    Kill,
    Int,
    Term,
}

/// Start a derivation that takes far longer than the test (2^30 modules),
/// stop it after ~300 ms, and check that nothing is left behind: no output
/// file, no temporary file, and the existing output untouched.
fn stopped_run_leaves_nothing(stop: Stop) {
    let dir = tempdir();
    let tmp = tempdir();
    let d = dir.path();
    let input = write(d, "in.ls", DOUBLING);
    let out = write(d, "out.txt", OLD);
    let fresh = d.join("fresh.txt");
    for target in [&out, &fresh] {
        let mut child = spawn(
            stepwise()
                .arg(&input)
                .args(["-n", "30", "--max-length", "1TB", "--tmpdir"])
                .arg(tmp.path())
                .arg("-o")
                .arg(target),
        );
        thread::sleep(Duration::from_millis(300));
        assert!(
            child.try_wait().unwrap().is_none(),
            "the derivation ended before it could be stopped"
        );
        let signal = match stop {
            Stop::Kill => {
                child.kill().unwrap();
                9
            }
            Stop::Int | Stop::Term => {
                let (flag, sig) = match stop {
                    Stop::Int => ("-INT", 2),
                    _ => ("-TERM", 15),
                };
                let st = Command::new("kill")
                    .arg(flag)
                    .arg(child.id().to_string())
                    .status()
                    .expect("run kill(1)");
                assert!(st.success());
                sig
            }
        };
        let r = finish(child, Duration::from_secs(30));
        assert!(!r.status.success(), "{stop:?}: a stopped run succeeded");
        assert!(!r.stderr.contains("panicked"), "stderr:\n{}", r.stderr);
        if let Some(s) = r.status.signal() {
            assert_eq!(s, signal, "{stop:?}: killed by another signal");
        }
        assert_eq!(fs::read_to_string(&out).unwrap(), OLD, "{stop:?}");
        assert_listing(d, &["in.ls", "out.txt"]);
        assert_listing(tmp.path(), &[]);
    }
}

#[test]
fn sigkill_mid_run_leaves_no_output_and_no_temp_files() {
    stopped_run_leaves_nothing(Stop::Kill);
}

#[test]
fn sigint_mid_run_leaves_no_output_and_no_temp_files() {
    stopped_run_leaves_nothing(Stop::Int);
}

#[test]
fn sigterm_mid_run_leaves_no_output_and_no_temp_files() {
    stopped_run_leaves_nothing(Stop::Term);
}

#[test]
fn tmpdir_is_empty_after_success_and_after_errors() {
    let dir = tempdir();
    let tmp = tempdir();
    let d = dir.path();
    let t = tmp.path();
    // Success, to a file and to stdout.
    let input = write(d, "in.ls", DOUBLING);
    let out = d.join("out.txt");
    let r = run(stepwise()
        .arg(&input)
        .args(["-n", "12", "--tmpdir"])
        .arg(t)
        .arg("-o")
        .arg(&out));
    assert_eq!(r.code(), Some(0), "stderr:\n{}", r.stderr);
    assert_listing(t, &[]);
    let r = run(stepwise().arg(&input).args(["-n", "12", "--tmpdir"]).arg(t));
    assert_eq!(r.code(), Some(0), "stderr:\n{}", r.stderr);
    assert_eq!(r.stdout, doubled(12));
    assert_listing(t, &[]);
    // A runtime error in a late step.
    let bad = write(
        d,
        "bad.ls",
        "derivation length: 8\nproductions:\nF -> FF\nA(x) -> A(x-1) B(sqrt(x))\naxiom: F A(5)\n",
    );
    let r = run(stepwise()
        .arg(&bad)
        .arg("--tmpdir")
        .arg(t)
        .arg("-o")
        .arg(&out));
    assert!(
        r.assert_one_error().contains("(in step 7)"),
        "stderr:\n{}",
        r.stderr
    );
    assert_listing(t, &[]);
    // An error in the axiom, after the first temporary file exists.
    let bad = write(d, "bad2.ls", "productions:\nF -> FF\naxiom: F F F F(1,\n");
    let r = run(stepwise()
        .arg(&bad)
        .arg("--tmpdir")
        .arg(t)
        .arg("-o")
        .arg(&out));
    r.assert_one_error();
    assert_listing(t, &[]);
    // The last runs failed: out.txt is still the first run's.
    assert_eq!(fs::read(&out).unwrap(), doubled(12));
    assert_listing(d, &["bad.ls", "bad2.ls", "in.ls", "out.txt"]);
}

// --- (e) full disks ------------------------------------------------------------

fn have_dev_full() -> bool {
    Path::new("/dev/full").exists()
}

#[test]
fn dev_full_as_output_file_fails_with_a_message() {
    if !have_dev_full() {
        eprintln!("skipped: no /dev/full");
        return;
    }
    for n in ["3", "22"] {
        let dir = tempdir();
        let input = write(dir.path(), "in.ls", DOUBLING);
        let r = run(stepwise().arg(&input).args(["-n", n, "-o", "/dev/full"]));
        let line = r.assert_one_error();
        assert!(line.contains(": error: "), "stderr:\n{}", r.stderr);
        assert!(line.contains("No space left"), "stderr:\n{}", r.stderr);
        assert_listing(dir.path(), &["in.ls"]);
    }
}

#[test]
fn dev_full_as_output_file_is_named_in_the_message() {
    if !have_dev_full() {
        eprintln!("skipped: no /dev/full");
        return;
    }
    let dir = tempdir();
    let input = write(dir.path(), "in.ls", DOUBLING);
    let r = run(stepwise().arg(&input).args(["-n", "3", "-o", "/dev/full"]));
    plain_error(&r, "/dev/full");
}

#[test]
fn dev_full_as_stdout_fails_with_a_message() {
    if !have_dev_full() {
        eprintln!("skipped: no /dev/full");
        return;
    }
    for n in ["3", "22"] {
        let dir = tempdir();
        let input = write(dir.path(), "in.ls", DOUBLING);
        let full = fs::OpenOptions::new()
            .write(true)
            .open("/dev/full")
            .unwrap();
        let child = spawn_with(
            stepwise().arg(&input).args(["-n", n]),
            Stdio::null(),
            Stdio::from(full),
            Stdio::piped(),
        );
        let r = finish(child, Duration::from_secs(60));
        let line = plain_error(&r, "standard output");
        assert!(line.contains("No space left"), "stderr:\n{}", r.stderr);
    }
}

/// A mounted file system, unmounted on drop.
struct Mount(PathBuf);

impl Drop for Mount {
    fn drop(&mut self) {
        let _ = Command::new("umount").arg(&self.0).status();
    }
}

fn mount_tmpfs(at: &Path, size: &str) -> Option<Mount> {
    let ok = Command::new("mount")
        .args(["-t", "tmpfs", "-o", &format!("size={size}"), "tmpfs"])
        .arg(at)
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .status()
        .is_ok_and(|s| s.success());
    ok.then(|| Mount(at.to_path_buf()))
}

#[test]
#[ignore = "needs root: mount"]
fn small_tmpfs_fills_up_cleanly() {
    let dir = tempdir();
    let small = tempdir();
    let d = dir.path();
    let s = small.path();
    let Some(_mount) = mount_tmpfs(s, "1m") else {
        eprintln!("skipped: cannot mount a tmpfs here");
        return;
    };
    let input = write(d, "in.ls", DOUBLING);
    // Temporary generations do not fit.
    let out = d.join("out.txt");
    let r = run(stepwise()
        .arg(&input)
        .args(["-n", "22", "--tmpdir"])
        .arg(s)
        .arg("-o")
        .arg(&out));
    let line = r.assert_one_error();
    assert!(line.contains("No space left"), "stderr:\n{}", r.stderr);
    assert_listing(s, &[]);
    assert_listing(d, &["in.ls"]);
    // The output does not fit: an existing file there stays as it was.
    let old = write(s, "out.txt", OLD);
    let r = run(stepwise()
        .arg(&input)
        .args(["-n", "22", "--tmpdir"])
        .arg(d)
        .arg("-o")
        .arg(&old));
    let line = plain_error(&r, &old.display().to_string());
    assert!(line.contains("No space left"), "stderr:\n{}", r.stderr);
    assert_eq!(fs::read_to_string(&old).unwrap(), OLD);
    assert_listing(s, &["out.txt"]);
    assert_listing(d, &["in.ls"]);
}

// --- (f) unwritable output, unreadable input -----------------------------------

#[test]
fn output_in_a_missing_directory() {
    let dir = tempdir();
    let input = write(dir.path(), "in.ls", DOUBLING);
    let r = run(stepwise().arg(&input).args(["-o", "/nonexistent-dir/x"]));
    let line = plain_error(&r, "/nonexistent-dir/x");
    assert!(line.contains("No such file or directory"), "{line}");
    assert!(!Path::new("/nonexistent-dir").exists());
}

#[test]
fn output_that_is_a_directory_or_below_a_file() {
    let dir = tempdir();
    let d = dir.path();
    let input = write(d, "in.ls", DOUBLING);
    let sub = d.join("sub");
    fs::create_dir(&sub).unwrap();
    let r = run(stepwise().arg(&input).arg("-o").arg(&sub));
    let line = plain_error(&r, &sub.display().to_string());
    assert!(line.contains("directory"), "{line}");
    let below = input.join("x");
    let r = run(stepwise().arg(&input).arg("-o").arg(&below));
    plain_error(&r, &below.display().to_string());
    assert_listing(d, &["in.ls", "sub"]);
    assert_listing(&sub, &[]);
}

#[test]
fn input_that_is_a_directory() {
    let dir = tempdir();
    let d = dir.path();
    let out = d.join("out.txt");
    let r = run(lsgen().arg(d).arg("-o").arg(&out));
    let line = plain_error(&r, &d.display().to_string());
    assert!(line.contains("directory"), "{line}");
    assert_listing(d, &[]);
}

#[test]
fn input_that_does_not_exist() {
    let dir = tempdir();
    let d = dir.path();
    let missing = d.join("missing.ls");
    let out = d.join("out.txt");
    let r = run(lsgen().arg(&missing).arg("-o").arg(&out));
    let line = plain_error(&r, &missing.display().to_string());
    assert!(line.contains("No such file or directory"), "{line}");
    assert_listing(d, &[]);
}

#[test]
fn axiom_file_that_does_not_exist() {
    let dir = tempdir();
    let d = dir.path();
    let input = write(d, "in.ls", DOUBLING);
    let missing = d.join("missing.txt");
    let out = d.join("out.txt");
    let r = run(stepwise()
        .arg(&input)
        .arg("--axiom")
        .arg(&missing)
        .arg("-o")
        .arg(&out));
    plain_error(&r, &missing.display().to_string());
    assert_listing(d, &["in.ls"]);
}

#[test]
fn tmpdir_that_does_not_exist() {
    let dir = tempdir();
    let d = dir.path();
    let input = write(d, "in.ls", DOUBLING);
    let out = d.join("out.txt");
    let missing = d.join("no-such-tmp");
    let r = run(stepwise()
        .arg(&input)
        .args(["-n", "3", "--tmpdir"])
        .arg(&missing)
        .arg("-o")
        .arg(&out));
    plain_error(&r, &missing.display().to_string());
    assert_listing(d, &["in.ls"]);
}

// --- (g) closed pipe -------------------------------------------------------------

fn closed_pipe(read_first: usize) {
    use std::io::Read;
    let dir = tempdir();
    let input = write(dir.path(), "in.ls", DOUBLING);
    // 4 MiB of output: far more than a pipe holds.
    let mut child = spawn_with(
        stepwise().arg(&input).args(["-n", "22"]),
        Stdio::null(),
        Stdio::piped(),
        Stdio::piped(),
    );
    let mut stdout = child.stdout.take().unwrap();
    let mut buf = vec![0; read_first];
    stdout.read_exact(&mut buf).unwrap();
    drop(stdout);
    let r = finish(child, Duration::from_secs(60));
    assert!(
        r.status.signal().is_none(),
        "killed by signal {:?}",
        r.status.signal()
    );
    assert_eq!(r.code(), Some(0), "stderr:\n{}", r.stderr);
    assert_eq!(r.stderr, "", "a closed pipe should end quietly");
}

#[test]
fn closed_pipe_after_some_output_ends_quietly() {
    closed_pipe(16);
}

#[test]
fn closed_pipe_before_any_output_ends_quietly() {
    closed_pipe(0);
}

// --- (h) runaway derivations -------------------------------------------------------

#[test]
fn max_length_stops_a_runaway_derivation() {
    for limit in ["1M", "2MB", "300000"] {
        let dir = tempdir();
        let tmp = tempdir();
        let d = dir.path();
        let input = write(d, "in.ls", DOUBLING);
        let out = write(d, "out.txt", OLD);
        let start = Instant::now();
        let r = run(stepwise()
            .arg(&input)
            .args(["-n", "60", "--max-length", limit, "--tmpdir"])
            .arg(tmp.path())
            .arg("-o")
            .arg(&out));
        let took = start.elapsed();
        let line = r.assert_one_error();
        assert!(line.contains("--max-length"), "stderr:\n{}", r.stderr);
        assert!(took < Duration::from_secs(10), "{limit}: took {took:?}");
        assert_eq!(fs::read_to_string(&out).unwrap(), OLD);
        assert_listing(d, &["in.ls", "out.txt"]);
        assert_listing(tmp.path(), &[]);
    }
}

#[test]
fn max_length_allows_what_fits() {
    let dir = tempdir();
    let input = write(dir.path(), "in.ls", DOUBLING);
    let r = run(stepwise()
        .arg(&input)
        .args(["-n", "10", "--max-length", "1024"]));
    assert_eq!(r.code(), Some(0), "stderr:\n{}", r.stderr);
    assert_eq!(r.stdout, doubled(10));
}

// --- (i) limits ------------------------------------------------------------------

const MILLION: usize = 1_000_000;

/// Run `src` to a file; the result must be `want`, or a clear error.
fn result_or_clear_error(src: &str, args: &[&str], want: impl Fn(&[u8]) -> bool) {
    let dir = tempdir();
    let d = dir.path();
    let input = write(d, "in.ls", src);
    let out = d.join("out.txt");
    let r = run(lsgen().arg(&input).args(args).arg("-o").arg(&out));
    r.assert_no_crash();
    if r.code() == Some(0) {
        assert!(want(&fs::read(&out).unwrap()), "wrong result");
        assert_listing(d, &["in.ls", "out.txt"]);
    } else {
        r.assert_one_error();
        assert_listing(d, &["in.ls"]);
    }
}

#[test]
fn million_nested_brackets_with_a_left_context() {
    let src = format!(
        "productions:\nA < B -> C\naxiom: A{}B{}\n",
        "[".repeat(MILLION),
        "]".repeat(MILLION)
    );
    let want = format!("A{}C{}\n", "[".repeat(MILLION), "]".repeat(MILLION));
    result_or_clear_error(&src, &[], |got| got == want.as_bytes());
}

#[test]
fn million_nested_brackets_with_a_right_context() {
    let src = format!(
        "productions:\nA > B -> C\naxiom: A{}{}B\n",
        "[F".repeat(MILLION),
        "]".repeat(MILLION)
    );
    let want = format!("C{}{}B\n", "[F".repeat(MILLION), "]".repeat(MILLION));
    result_or_clear_error(&src, &[], |got| got == want.as_bytes());
}

#[test]
fn million_nested_brackets_with_context_free_rules() {
    let src = format!(
        "productions:\nB -> C\nF -> FF\naxiom: A{}B{}\n",
        "[F".repeat(MILLION),
        "]".repeat(MILLION)
    );
    let want = format!("A{}C{}\n", "[FF".repeat(MILLION), "]".repeat(MILLION));
    result_or_clear_error(&src, &[], |got| got == want.as_bytes());
}

#[test]
fn hundred_thousand_productions() {
    // Symbol i rewrites to symbol i+1 (supplementary-plane characters).
    let n = 100_000;
    let sym = |i: usize| char::from_u32(0x20000 + i as u32).unwrap();
    let mut src = String::from("productions:\n");
    for i in 0..n {
        src.push(sym(i));
        src.push_str(" -> ");
        src.push(sym(i + 1));
        src.push('\n');
    }
    // The axiom on its own line after ASCII padding (see
    // bad_input::axiom_line_with_multibyte_symbols_is_accepted).
    src.push_str("axiom:          \n");
    src.extend((0..n).map(sym));
    src.push('\n');
    let mut want: String = (1..=n).map(sym).collect();
    want.push('\n');
    result_or_clear_error(&src, &[], |got| got == want.as_bytes());
}

#[test]
fn hundred_thousand_conditional_productions_of_one_module() {
    let n = 100_000;
    let mut src = String::from("productions:\n");
    for i in 0..n {
        src.push_str(&format!("A(x) : x == {i} -> B({})\n", 2 * i));
    }
    src.push_str("axiom: A(99999) A(5) A(100000)\n");
    result_or_clear_error(&src, &[], |got| got == b"B(199998)B(10)A(100000)\n");
}

#[test]
fn successor_of_a_million_modules() {
    // 200000 × `G[+H]` = 10^6 modules.
    let succ = "G[+H]".repeat(MILLION / 5);
    let src = format!("productions:\nF -> {succ}\naxiom: F F\n");
    let want = format!("{succ}{succ}\n");
    result_or_clear_error(&src, &[], |got| got == want.as_bytes());
}

#[test]
fn parameters_near_the_limits_of_f64_read_back_exactly() {
    let src = "define: M = 1.7976931348623157e308\n\
               productions:\n\
               F(a,b,c,d) -> G(a, b, c, d, M, -M, a/2, b*2, -0, 0.1+0.2, 1/3, 2.2250738585072014e-308/2)\n\
               axiom: F(1e308, 5e-324, 2.2250738585072014e-308, -1.7976931348623157e308)\n";
    let want: [f64; 12] = [
        1e308,
        5e-324,
        2.2250738585072014e-308,
        -1.7976931348623157e308,
        f64::MAX,
        -f64::MAX,
        5e307,
        1e-323,
        -0.0,
        0.1 + 0.2,
        1.0 / 3.0,
        2.2250738585072014e-308 / 2.0,
    ];
    let dir = tempdir();
    let input = write(dir.path(), "in.ls", src);
    let r = run(lsgen().arg(&input));
    assert_eq!(r.code(), Some(0), "stderr:\n{}", r.stderr);
    let text = String::from_utf8(r.stdout).unwrap();
    let inner = text
        .strip_prefix("G(")
        .and_then(|t| t.strip_suffix(")\n"))
        .unwrap_or_else(|| panic!("unexpected output {text:?}"));
    let got: Vec<f64> = inner
        .split(',')
        .map(|s| s.parse().unwrap_or_else(|_| panic!("not a number: {s:?}")))
        .collect();
    assert_eq!(got.len(), want.len(), "{text}");
    for (g, w) in got.iter().zip(&want) {
        assert_eq!(g.to_bits(), w.to_bits(), "{g:e} != {w:e} in {text}");
    }
    // And the printed text reads back into the same values through lsgen.
    let again = write(
        dir.path(),
        "again.ls",
        format!("productions:\nG -> G\naxiom: {text}"),
    );
    let r2 = run(lsgen().arg(&again).args(["-n", "0"]));
    assert_eq!(r2.code(), Some(0), "stderr:\n{}", r2.stderr);
    assert_eq!(String::from_utf8(r2.stdout).unwrap(), text);
    assert_eq!(listing(dir.path()).len(), 2);
}

// --- (j) where `-o` leads: streams, symbolic links, directories ------------------

/// lsgen with standard output on `stdout_file` (opened for appending).
fn run_with_stdout_file(cmd: &mut Command, stdout_file: &Path) -> Run {
    let f = fs::OpenOptions::new()
        .append(true)
        .open(stdout_file)
        .unwrap();
    let child = spawn_with(cmd, Stdio::null(), Stdio::from(f), Stdio::piped());
    finish(child, Duration::from_secs(60))
}

/// `-o /dev/stdout` and its kin name lsgen's own standard output: write to
/// it as a stream (lsgen before this renamed a temp file over the name: as
/// root, /dev/stdout itself became a regular file and the redirected
/// stdout stayed empty). /dev/stdout itself is reached only through a link
/// of our own, so that a regression cannot replace the machine's.
#[test]
fn output_naming_our_own_stdout_writes_the_stream() {
    let dir = tempdir();
    let d = dir.path();
    let input = write(d, "in.ls", DOUBLING);
    std::os::unix::fs::symlink("/proc/self/fd/1", d.join("to-proc")).unwrap();
    std::os::unix::fs::symlink("/dev/stdout", d.join("to-dev-stdout")).unwrap();
    std::os::unix::fs::symlink("to-dev-stdout", d.join("chain")).unwrap();
    let targets = [
        "/dev/fd/1".to_string(),
        "/proc/self/fd/1".to_string(),
        d.join("to-proc").display().to_string(),
        d.join("to-dev-stdout").display().to_string(),
        d.join("chain").display().to_string(),
    ];
    for (i, target) in targets.iter().enumerate() {
        // Standard output is a regular file opened for appending (`>>`):
        // the output goes after what is there, as the shell would put it.
        let captured = write(d, &format!("stdout{i}.txt"), OLD);
        let r = run_with_stdout_file(
            stepwise().arg(&input).args(["-n", "4", "-o"]).arg(target),
            &captured,
        );
        r.assert_no_crash();
        assert_eq!(r.code(), Some(0), "-o {target}: stderr:\n{}", r.stderr);
        let mut want = OLD.as_bytes().to_vec();
        want.extend(doubled(4));
        assert_eq!(fs::read(&captured).unwrap(), want, "-o {target}");
    }
    for link in ["to-proc", "to-dev-stdout", "chain"] {
        assert!(
            fs::symlink_metadata(d.join(link))
                .unwrap()
                .file_type()
                .is_symlink(),
            "{link} was replaced"
        );
    }
    let mut names = vec!["in.ls", "to-proc", "to-dev-stdout", "chain"];
    let captured: Vec<String> = (0..targets.len())
        .map(|i| format!("stdout{i}.txt"))
        .collect();
    names.extend(captured.iter().map(String::as_str));
    assert_listing(d, &names);
}

/// A descriptor lsgen does not have is an error, not a file.
#[test]
fn output_naming_a_closed_descriptor_fails() {
    let dir = tempdir();
    let d = dir.path();
    let input = write(d, "in.ls", DOUBLING);
    let r = run(stepwise().arg(&input).args(["-o", "/dev/fd/9"]));
    let line = plain_error(&r, "/dev/fd/9");
    assert!(line.contains("Bad file descriptor"), "{line}");
    assert_listing(d, &["in.ls"]);
}

/// `-o` onto a FIFO streams into it (no temp file, nothing renamed).
#[test]
fn output_to_a_fifo_is_streamed() {
    use std::io::Read;
    let dir = tempdir();
    let d = dir.path();
    let input = write(d, "in.ls", DOUBLING);
    let fifo = d.join("fifo");
    let ok = Command::new("mkfifo")
        .arg(&fifo)
        .status()
        .is_ok_and(|s| s.success());
    if !ok {
        eprintln!("skipped: mkfifo failed");
        return;
    }
    let child = spawn(stepwise().arg(&input).args(["-n", "16", "-o"]).arg(&fifo));
    let mut got = Vec::new();
    fs::File::open(&fifo)
        .unwrap()
        .read_to_end(&mut got)
        .unwrap();
    let r = finish(child, Duration::from_secs(60));
    assert_eq!(r.code(), Some(0), "stderr:\n{}", r.stderr);
    assert!(got == doubled(16), "wrong output through the FIFO");
    assert!(std::os::unix::fs::FileTypeExt::is_fifo(
        &fs::symlink_metadata(&fifo).unwrap().file_type()
    ));
    assert_listing(d, &["fifo", "in.ls"]);
}

/// `-o link` writes through the link, as `>` does: the target is replaced
/// atomically (new inode, written beside it in its own directory) and the
/// link stays (lsgen before this replaced the link with a regular file and
/// left the target as it was).
#[test]
fn output_through_a_symlink_replaces_its_target_and_keeps_the_link() {
    use std::os::unix::fs::{symlink, PermissionsExt};
    let dir = tempdir();
    let d = dir.path();
    let input = write(d, "in.ls", DOUBLING);
    let sub = d.join("sub");
    fs::create_dir(&sub).unwrap();
    let target = write(&sub, "target.txt", OLD);
    fs::set_permissions(&target, fs::Permissions::from_mode(0o640)).unwrap();
    // A relative link (relative to its own directory), an absolute one, and
    // a link to a link.
    symlink("sub/target.txt", d.join("rel")).unwrap();
    symlink(&target, d.join("abs")).unwrap();
    symlink("rel", d.join("chain")).unwrap();
    for (n, link) in [(3, "rel"), (4, "abs"), (5, "chain")] {
        // Held open, the replaced file keeps its inode and contents.
        let before = fs::read(&target).unwrap();
        let old = fs::File::open(&target).unwrap();
        let old_ino = old.metadata().unwrap().ino();
        let r = run(stepwise()
            .arg(&input)
            .args(["-n", &n.to_string(), "-o"])
            .arg(d.join(link)));
        assert_eq!(r.code(), Some(0), "-o {link}: stderr:\n{}", r.stderr);
        assert!(fs::read(&target).unwrap() == doubled(n), "-o {link}");
        let meta = fs::symlink_metadata(d.join(link)).unwrap();
        assert!(meta.file_type().is_symlink(), "-o {link}: link replaced");
        let t = fs::metadata(&target).unwrap();
        assert_ne!(t.ino(), old_ino, "-o {link}: target rewritten in place");
        let mut kept = Vec::new();
        std::io::Read::read_to_end(&mut &old, &mut kept).unwrap();
        assert_eq!(kept, before, "-o {link}: target rewritten in place");
        assert_eq!(t.permissions().mode() & 0o7777, 0o640, "-o {link}");
    }
    assert_eq!(
        fs::read_link(d.join("rel")).unwrap(),
        Path::new("sub/target.txt")
    );
    assert_listing(d, &["abs", "chain", "in.ls", "rel", "sub"]);
    assert_listing(&sub, &["target.txt"]);
    // A failed run leaves the target alone.
    let bad = write(d, "bad.ls", "productions:\nF -> FF\naxiom: F F)\n");
    let r = run(stepwise().arg(&bad).arg("-o").arg(d.join("rel")));
    r.assert_one_error();
    assert!(fs::read(&target).unwrap() == doubled(5));
    assert_listing(&sub, &["target.txt"]);
}

/// A dangling link: its target is created, the link kept.
#[test]
fn output_through_a_dangling_symlink_creates_its_target() {
    let dir = tempdir();
    let d = dir.path();
    let input = write(d, "in.ls", DOUBLING);
    fs::create_dir(d.join("sub")).unwrap();
    std::os::unix::fs::symlink("sub/new.txt", d.join("link")).unwrap();
    let r = run(stepwise()
        .arg(&input)
        .args(["-n", "3", "-o"])
        .arg(d.join("link")));
    assert_eq!(r.code(), Some(0), "stderr:\n{}", r.stderr);
    assert!(fs::symlink_metadata(d.join("link"))
        .unwrap()
        .file_type()
        .is_symlink());
    assert_eq!(fs::read(d.join("sub/new.txt")).unwrap(), doubled(3));
    assert_listing(d, &["in.ls", "link", "sub"]);
    assert_listing(&d.join("sub"), &["new.txt"]);
}

/// A link that leads to itself: a clear error, nothing written.
#[test]
fn output_through_a_symlink_loop_fails() {
    let dir = tempdir();
    let d = dir.path();
    let input = write(d, "in.ls", DOUBLING);
    std::os::unix::fs::symlink("b", d.join("a")).unwrap();
    std::os::unix::fs::symlink("a", d.join("b")).unwrap();
    let a = d.join("a");
    let r = run(stepwise().arg(&input).arg("-o").arg(&a));
    let line = plain_error(&r, &a.display().to_string());
    assert!(line.contains("symbolic links"), "{line}");
    assert_listing(d, &["a", "b", "in.ls"]);
}

/// `-o newdir/` names a directory: say so before deriving anything (lsgen
/// before this derived in full and then said "Not a directory").
#[test]
fn output_named_like_a_directory_is_refused_up_front() {
    let dir = tempdir();
    let d = dir.path();
    let input = write(d, "in.ls", DOUBLING);
    fs::create_dir(d.join("sub")).unwrap();
    let cases = [
        ("newdir/", "no such directory"),
        ("sub/", "is a directory"),
        // (Not "no such directory, and -o takes a file name, not a
        // directory", which it said, and which also held these words.)
        ("in.ls/", "not a directory, but the name ends with `/`"),
    ];
    for (arg, want) in cases {
        let target = format!("{}/{arg}", d.display());
        let start = Instant::now();
        // 2^30 modules: far longer than the test if it were derived.
        let r =
            run(stepwise()
                .arg(&input)
                .args(["-n", "30", "--max-length", "1TB", "-o", &target]));
        let line = plain_error(&r, &target);
        assert!(line.contains(want), "-o {arg}: {line}");
        assert!(line.contains("-o") || arg == "in.ls/", "{line}");
        assert!(
            start.elapsed() < Duration::from_secs(10),
            "-o {arg} derived first"
        );
    }
    assert_listing(d, &["in.ls", "sub"]);
    assert_listing(&d.join("sub"), &[]);
}

// --- (k) leftovers of killed runs --------------------------------------------------

/// Start time (clock ticks since boot) of process `pid`, /proc/PID/stat
/// field 22.
fn process_start(pid: u32) -> u64 {
    let stat = fs::read_to_string(format!("/proc/{pid}/stat")).unwrap();
    let after = &stat[stat.rfind(')').unwrap() + 1..];
    after.split_whitespace().nth(19).unwrap().parse().unwrap()
}

/// The PID of a process that has ended.
fn dead_pid() -> u32 {
    let mut c = Command::new("true").spawn().unwrap();
    let pid = c.id();
    c.wait().unwrap();
    pid
}

/// The temp file names `-o` uses beside its target carry the PID and start
/// time of their run: `.lsgen-PID-START-NANOS-K.tmp`. A run writing into a
/// directory removes those of runs that no longer run (killed with -9 with
/// the name in place, see README), and only those.
#[test]
fn leftovers_of_dead_runs_are_removed_by_the_next_run() {
    let dir = tempdir();
    let d = dir.path();
    let input = write(d, "in.ls", DOUBLING);
    let me = std::process::id();
    let my_start = process_start(me);
    let dead = dead_pid();
    let dead_run = format!(".lsgen-{dead}-12345-678-0.tmp");
    // Our PID, another start time: the PID was reused since.
    let reused = format!(".lsgen-{me}-{}-1-0.tmp", my_start + 1);
    // A live process (this test): its run is still going.
    let live = format!(".lsgen-{me}-{my_start}-2-0.tmp");
    // Not lsgen's names.
    let others = [".lsgen-notes.tmp", ".lsgen-1-2-3.tmp", "lsgen-1-2-3-4.tmp"];
    for name in [&dead_run, &reused, &live] {
        write(d, name, "FFFF\n");
    }
    for name in others {
        write(d, name, "keep\n");
    }
    let out = d.join("out.txt");
    let r = run(stepwise().arg(&input).args(["-n", "3", "-o"]).arg(&out));
    assert_eq!(r.code(), Some(0), "stderr:\n{}", r.stderr);
    assert_eq!(fs::read(&out).unwrap(), doubled(3));
    let mut want = vec!["in.ls", "out.txt", live.as_str()];
    want.extend(others);
    assert_listing(d, &want);
}

/// Where O_TMPFILE is unsupported the complete output is copied into a
/// named temp file at the end; `kill -9` during that copy leaves it (this
/// cannot be prevented). The next run into that directory removes it.
#[test]
fn sigkill_during_the_final_copy_leaves_a_temp_file_the_next_run_removes() {
    let shim_dir = tempdir();
    let Some(shim) = build_no_tmpfile_shim(shim_dir.path()) else {
        eprintln!("skipped: no C compiler for the LD_PRELOAD shim");
        return;
    };
    let dir = tempdir();
    let d = dir.path();
    let input = write(d, "in.ls", DOUBLING);
    let out = write(d, "out.txt", OLD);
    let mut child = spawn(
        stepwise()
            .env("LD_PRELOAD", &shim)
            .arg(&input)
            .args(["-n", "26", "-o"])
            .arg(&out),
    );
    let deadline = Instant::now() + Duration::from_secs(120);
    let mut caught = false;
    while Instant::now() < deadline && child.try_wait().unwrap().is_none() {
        if listing(d).iter().any(|n| n.starts_with(".lsgen-")) {
            child.kill().unwrap();
            caught = true;
            break;
        }
        thread::sleep(Duration::from_millis(1));
    }
    let r = finish(child, Duration::from_secs(60));
    let left = temp_names(d);
    if !caught || left.is_empty() {
        eprintln!("skipped: the final copy was not caught ({:?})", r.status);
        return;
    }
    assert_eq!(r.status.signal(), Some(9));
    assert_eq!(fs::read_to_string(&out).unwrap(), OLD, "a partial output");
    // The next run (with or without O_TMPFILE) into the same directory.
    let r = run(stepwise().arg(&input).args(["-n", "3", "-o"]).arg(&out));
    assert_eq!(r.code(), Some(0), "stderr:\n{}", r.stderr);
    assert_eq!(fs::read(&out).unwrap(), doubled(3));
    assert_listing(d, &["in.ls", "out.txt"]);
}

/// strace running lsgen with every rename(2) delayed by `delay_us`, to
/// hit the window between naming a finished file and renaming it.
fn lsgen_with_slow_rename(delay_us: u32) -> Command {
    let mut c = common::command("strace");
    c.args([
        "-f",
        "-o",
        "/dev/null",
        "-e",
        &format!("inject=/^rename:delay_enter={delay_us}"),
    ])
    .arg(common::LSGEN);
    c
}

/// The `.lsgen-...` temp names in `d`.
fn temp_names(d: &Path) -> Vec<String> {
    listing(d)
        .into_iter()
        .filter(|n| n.starts_with(".lsgen-"))
        .collect()
}

/// The PID in the first `.lsgen-PID-...` temp name to appear in `d`
/// (within 30 s).
fn temp_name_pid(d: &Path) -> String {
    let deadline = Instant::now() + Duration::from_secs(30);
    while Instant::now() < deadline {
        let pid = listing(d).iter().find_map(|n| {
            n.strip_prefix(".lsgen-")
                .and_then(|rest| rest.split('-').next())
                .map(str::to_string)
        });
        if let Some(pid) = pid {
            return pid;
        }
        thread::sleep(Duration::from_millis(5));
    }
    panic!("no temp name seen: is strace working?");
}

/// kill -9 between naming the finished file and renaming it over an
/// existing target leaves the temp name (issue 9, item 9): delay rename(2)
/// with strace to hit that window, then check the next run removes it.
/// Needs strace and ptrace permission; run by hand:
/// `cargo test --test faults -- --ignored sigkill_between_link_and_rename`.
#[test]
#[ignore = "needs strace (ptrace) and takes a few seconds"]
fn sigkill_between_link_and_rename_leaves_a_name_the_next_run_removes() {
    let dir = tempdir();
    let d = dir.path();
    let input = write(d, "in.ls", DOUBLING);
    let out = write(d, "out.txt", OLD);
    let child = spawn_with(
        lsgen_with_slow_rename(5_000_000)
            .args(["--strategy", "step"])
            .arg(&input)
            .args(["-n", "12", "-o"])
            .arg(&out),
        Stdio::null(),
        Stdio::null(),
        Stdio::piped(),
    );
    let pid = temp_name_pid(d);
    let st = Command::new("kill").args(["-9", &pid]).status().unwrap();
    assert!(st.success());
    let _ = finish(child, Duration::from_secs(30));
    let left = temp_names(d);
    assert_eq!(left.len(), 1, "the window was not hit: {left:?}");
    assert_eq!(fs::read_to_string(&out).unwrap(), OLD);
    let r = run(stepwise().arg(&input).args(["-n", "3", "-o"]).arg(&out));
    assert_eq!(r.code(), Some(0), "stderr:\n{}", r.stderr);
    assert_eq!(fs::read(&out).unwrap(), doubled(3));
    assert_listing(d, &["in.ls", "out.txt"]);
    // A new file is linked straight to its name: no rename, no window (the
    // delayed rename would take 5 s).
    let fresh = d.join("fresh.txt");
    let start = Instant::now();
    let r = run(lsgen_with_slow_rename(5_000_000)
        .args(["--strategy", "step"])
        .arg(&input)
        .args(["-n", "3", "-o"])
        .arg(&fresh));
    assert_eq!(r.code(), Some(0), "stderr:\n{}", r.stderr);
    assert!(
        start.elapsed() < Duration::from_secs(4),
        "a rename was made"
    );
    assert_eq!(fs::read(&fresh).unwrap(), doubled(3));
    assert_listing(d, &["fresh.txt", "in.ls", "out.txt"]);
}

/// SIGTERM while a batch's job is between naming its finished file and
/// renaming it over an existing output: the job's thread holds the signal
/// until the name is gone, and so must the thread that waits for the jobs
/// (it took the signal and ended the run with the temp name left, found by
/// the review helper). Needs strace, as the test above; run by hand:
/// `cargo test --test faults -- --ignored sigterm_in_a_batch`.
#[test]
#[ignore = "needs strace (ptrace) and takes a few seconds"]
fn sigterm_in_a_batch_between_link_and_rename_leaves_no_name() {
    let dir = tempdir();
    let d = dir.path();
    let input = write(d, "in.ls", DOUBLING);
    let out = |s: u32| d.join(format!("out-{s}.txt"));
    for s in 1..=2 {
        fs::write(out(s), OLD).unwrap();
    }
    let child = spawn_with(
        lsgen_with_slow_rename(3_000_000)
            .args(["-j", "1", "--seed", "1..2", "--strategy", "step"])
            .arg(&input)
            .args(["-n", "12", "-o"])
            .arg(d.join("out-{seed}.txt")),
        Stdio::null(),
        Stdio::null(),
        Stdio::piped(),
    );
    let pid = temp_name_pid(d);
    let st = Command::new("kill").args(["-TERM", &pid]).status().unwrap();
    assert!(st.success());
    let _ = finish(child, Duration::from_secs(30));
    let left = temp_names(d);
    assert!(left.is_empty(), "left behind: {left:?}");
    // The first job's output is in place, whole; the second never started.
    assert_eq!(fs::read(out(1)).unwrap(), doubled(12));
    assert_eq!(fs::read_to_string(out(2)).unwrap(), OLD);
}

/// A directory with the doubling system and an empty `out` directory.
fn tiny_batch_files() -> (tempfile::TempDir, PathBuf, PathBuf) {
    let dir = tempdir();
    let input = write(dir.path(), "in.ls", DOUBLING);
    let out = dir.path().join("out");
    fs::create_dir(&out).unwrap();
    (dir, input, out)
}

/// `cmd` as 3000 tiny jobs on `j` threads, from `input` into `out`.
fn tiny_batch<'c>(cmd: &'c mut Command, j: &str, input: &Path, out: &Path) -> &'c mut Command {
    cmd.args(["-j", j, "--seed", "1..3000", "-n", "3"])
        .arg(input)
        .arg("-o")
        .arg(out.join("{seed}.txt"))
}

/// SIGTERM or SIGINT at any moment of a batch on several threads leaves no
/// temporary name beside the outputs, and ends the run by that signal:
/// one thread of lsgen's own takes the signals and lets a file that is
/// getting its name finish. Before, a signal sent to the process reached
/// whichever thread did not hold it and ended the run while another job
/// was between naming its file and renaming it over the old one (12 of 30
/// such runs left a name; found by the review helper).
#[test]
fn a_signal_in_a_batch_on_threads_leaves_no_temp_name() {
    let (_dir, input, out) = tiny_batch_files();
    let batch = || {
        let mut c = lsgen();
        tiny_batch(&mut c, "8", &input, &out);
        c
    };
    // Every output exists: each job renames over one.
    let r = run(&mut batch());
    assert_eq!(r.code(), Some(0), "stderr:\n{}", r.stderr);
    let mut signalled = 0;
    for round in 0..12u64 {
        // (Every other round with the progress display, a thread of its
        // own started before the jobs'.)
        let mut c = batch();
        if round % 2 == 1 {
            c.arg("--progress");
        }
        let child = spawn(&mut c);
        thread::sleep(Duration::from_millis(80 + 40 * round));
        let sig = if round % 4 < 2 { "-TERM" } else { "-INT" };
        let pid = child.id().to_string();
        let _ = Command::new("kill").args([sig, &pid]).status();
        let r = finish(child, Duration::from_secs(60));
        let left = temp_names(&out);
        assert!(left.is_empty(), "round {round}: left behind: {left:?}");
        if let Some(s) = r.status.signal() {
            assert!([libc::SIGTERM, libc::SIGINT].contains(&s), "{:?}", r.status);
            signalled += 1;
        } else {
            assert_eq!(r.code(), Some(0), "stderr:\n{}", r.stderr);
        }
    }
    assert!(signalled > 0, "no run was caught by its signal");
    for s in [1, 1500, 3000] {
        assert_eq!(fs::read(out.join(format!("{s}.txt"))).unwrap(), doubled(3));
    }
}

/// A signal the run was started with ignored (`nohup` ignores SIGHUP)
/// stays ignored in a batch: the signal thread leaves it alone (held, it
/// would have reached that thread and ended the run), while one not
/// ignored ends it.
#[test]
fn an_ignored_hangup_does_not_end_a_batch() {
    let (_dir, input, out) = tiny_batch_files();
    for (setup, ends) in [("trap '' HUP", false), ("true", true)] {
        let child = spawn(tiny_batch(&mut lsgen_under_sh(setup), "4", &input, &out));
        thread::sleep(Duration::from_millis(150));
        let pid = child.id().to_string();
        let _ = Command::new("kill").args(["-HUP", &pid]).status();
        let r = finish(child, Duration::from_secs(60));
        if ends {
            // (Unless the batch was done before the signal.)
            if r.code() != Some(0) {
                assert_eq!(r.status.signal(), Some(libc::SIGHUP), "{:?}", r.status);
            }
        } else {
            assert_eq!(r.code(), Some(0), "stderr:\n{}", r.stderr);
            assert_eq!(fs::read_dir(&out).unwrap().count(), 3000);
        }
        assert!(temp_names(&out).is_empty());
    }
}

// --- (l) resource limits and unwritable streams ------------------------------------

/// `ulimit -f` exceeded: a clear error and exit 1, not death by SIGXFSZ;
/// the old file stays, no temp file is left.
#[test]
fn file_size_limit_is_an_error_not_a_signal() {
    let dir = tempdir();
    let tmp = tempdir();
    let d = dir.path();
    let input = write(d, "in.ls", DOUBLING);
    let out = write(d, "out.txt", OLD);
    // 64 blocks (32 or 64 KiB by the shell's unit) for 1 MiB of output; the
    // temporary generations go to a tmpfs-free --tmpdir, limited too.
    let r = run(lsgen_under_sh("ulimit -f 64")
        .args(["--strategy", "step"])
        .arg(&input)
        .args(["-n", "20", "--tmpdir"])
        .arg(tmp.path())
        .arg("-o")
        .arg(&out));
    let line = r.assert_one_error();
    assert!(line.contains("File too large"), "stderr:\n{}", r.stderr);
    assert_eq!(fs::read_to_string(&out).unwrap(), OLD);
    assert_listing(d, &["in.ls", "out.txt"]);
    assert_listing(tmp.path(), &[]);
    // Depth first (no temporary generations): the output file itself.
    let plain = write(d, "plain.ls", "productions:\nF -> FF\naxiom: F\n");
    let r = run(lsgen_under_sh("ulimit -f 64")
        .arg(&plain)
        .args(["-n", "20", "-o"])
        .arg(&out));
    let line = plain_error(&r, &out.display().to_string());
    assert!(line.contains("File too large"), "{line}");
    assert_eq!(fs::read_to_string(&out).unwrap(), OLD);
    assert_listing(d, &["in.ls", "out.txt", "plain.ls"]);
}

/// Standard output closed (`>&-`): the output has nowhere to go, which is
/// an error (lsgen before this exited 0 with the output lost). With `-o`
/// nothing goes to standard output and the run succeeds.
#[test]
fn closed_stdout_is_an_error_when_the_output_goes_there() {
    let dir = tempdir();
    let d = dir.path();
    let input = write(d, "in.ls", DOUBLING);
    for args in [
        &["-n", "3"][..],
        &["-n", "3", "-o", "-"],
        &["-n", "3", "-o", "/dev/stdout"],
    ] {
        let r = run(lsgen_under_sh("exec >&-")
            .args(["--strategy", "step"])
            .arg(&input)
            .args(args));
        let line = plain_error(&r, "standard output");
        assert!(line.contains("closed"), "{args:?}: {line}");
    }
    for flag in ["--version", "--help"] {
        let r = run(lsgen_under_sh("exec >&-").arg(flag));
        let line = plain_error(&r, "standard output");
        assert!(line.contains("closed"), "{flag}: {line}");
    }
    let out = d.join("out.txt");
    let r = run(lsgen_under_sh("exec >&-")
        .args(["--strategy", "step"])
        .arg(&input)
        .args(["-n", "3", "-o"])
        .arg(&out));
    assert_eq!(r.code(), Some(0), "stderr:\n{}", r.stderr);
    assert_eq!(fs::read(&out).unwrap(), doubled(3));
    // Standard error closed too, with -v: the file holds only the output.
    let r = run(lsgen_under_sh("exec >&- 2>&-")
        .args(["--strategy", "step"])
        .arg(&input)
        .args(["-v", "-n", "4", "-o"])
        .arg(&out));
    assert_eq!(r.code(), Some(0));
    assert_eq!(fs::read(&out).unwrap(), doubled(4));
}

/// Standard input closed (`<&-`): reading the L-system or `--axiom -`
/// from it is a read error naming standard input (lsgen before this read
/// it as empty and said "empty L-system: no `axiom:` found").
#[test]
fn closed_stdin_is_a_read_error() {
    let dir = tempdir();
    let d = dir.path();
    let input = write(d, "in.ls", DOUBLING);
    let out = d.join("out.txt");
    for args in [&[][..], &["-"][..]] {
        let r = run(lsgen_under_sh("exec <&-").args(args).arg("-o").arg(&out));
        let line = plain_error(&r, "standard input");
        assert!(
            line.contains("cannot read") && line.contains("closed"),
            "{args:?}: {line}"
        );
        assert!(!out.exists());
    }
    let r = run(lsgen_under_sh("exec <&-")
        .arg(&input)
        .args(["--axiom", "-", "-o"])
        .arg(&out));
    let line = plain_error(&r, "standard input");
    assert!(line.contains("cannot read"), "{line}");
    assert!(!out.exists());
    // Standard input not read: a closed one does not matter.
    let r = run(lsgen_under_sh("exec <&-")
        .arg(&input)
        .args(["-n", "2", "-o"])
        .arg(&out));
    assert_eq!(r.code(), Some(0), "stderr:\n{}", r.stderr);
    assert_eq!(fs::read(&out).unwrap(), doubled(2));
}

/// Standard input closed (`<&-`), named by a path (`/dev/stdin`,
/// `/dev/fd/0`, `/proc/self/fd/0`, as the file or `--axiom`): the same
/// read error, naming the path, exit 1 (it read the /dev/null that fd 0
/// holds then, and said "empty L-system"); so is a cpfg `#include` of
/// it. (Files lsgen opens never take fd 0: /dev/null holds it.)
#[test]
fn closed_stdin_named_by_a_path_is_a_read_error() {
    let dir = tempdir();
    let d = dir.path();
    let input = write(d, "in.ls", DOUBLING);
    let out = d.join("out.txt");
    for path in ["/dev/stdin", "/dev/fd/0", "/proc/self/fd/0"] {
        let r = run(lsgen_under_sh("exec <&-").arg(path).arg("-o").arg(&out));
        assert_eq!(r.code(), Some(1), "{path}: {}", r.stderr);
        let line = plain_error(&r, path);
        assert!(
            line.ends_with("cannot read: Bad file descriptor (closed at startup)"),
            "{path}: {line}"
        );
        assert!(!out.exists());
        let r = run(lsgen_under_sh("exec <&-")
            .arg(&input)
            .args(["--axiom", path, "-o"])
            .arg(&out));
        assert_eq!(r.code(), Some(1), "{path}: {}", r.stderr);
        let line = plain_error(&r, path);
        assert!(line.contains("cannot read"), "{path}: {line}");
        assert!(!out.exists());
    }
    // Standard error closed too: the same status, no panic.
    let r = run(lsgen_under_sh("exec <&- 2>&-")
        .arg("/dev/stdin")
        .arg("-o")
        .arg(&out));
    r.assert_no_crash();
    assert_eq!(r.code(), Some(1));
    assert!(!out.exists());
    // A cpfg file's `#include "/dev/stdin"`: the same, at the directive.
    let inc = write(
        d,
        "inc.l",
        "Lsystem: 1\n#include \"/dev/stdin\"\nAxiom: A\nendlsystem\n",
    );
    let r = run(lsgen_under_sh("exec <&-").arg(&inc).arg("-o").arg(&out));
    assert_eq!(r.code(), Some(1), "{}", r.stderr);
    assert!(
        r.assert_one_error().ends_with(
            "error: cannot include `/dev/stdin`: Bad file descriptor (closed at startup)"
        ),
        "{}",
        r.stderr
    );
    assert!(!out.exists());
    // An open standard input is read through its path as before.
    let r = run(lsgen_under_sh(&format!("exec <{}", input.display()))
        .args(["/dev/stdin", "-n", "2", "-o"])
        .arg(&out));
    assert_eq!(r.code(), Some(0), "stderr:\n{}", r.stderr);
    assert_eq!(fs::read(&out).unwrap(), doubled(2));
}

/// A pipe whose reading end is already closed: every write fails with
/// EPIPE.
fn widowed_pipe() -> fs::File {
    use std::os::fd::FromRawFd;
    let mut fds = [0; 2];
    // SAFETY: pipe fills two new descriptors, which we then own.
    assert_eq!(unsafe { libc::pipe(fds.as_mut_ptr()) }, 0);
    // SAFETY: as above.
    unsafe {
        libc::close(fds[0]);
        fs::File::from_raw_fd(fds[1])
    }
}

/// Diagnostics never panic: `-v` (and error messages) with standard error
/// full or a closed pipe is not an error of the run (lsgen before this
/// aborted with SIGABRT: eprintln! panicked, then the panic hook did).
#[test]
fn unwritable_stderr_changes_nothing() {
    let dir = tempdir();
    let d = dir.path();
    let input = write(d, "in.ls", DOUBLING);
    let plain = write(d, "plain.ls", "productions:\nF -> FF\naxiom: F\n");
    let bad = write(d, "bad.ls", "productions:\nF -> FF\naxiom: F F)\n");
    type Open = fn() -> Option<fs::File>;
    let stderrs: [(&str, Open); 2] = [
        ("/dev/full", || {
            fs::OpenOptions::new().write(true).open("/dev/full").ok()
        }),
        ("a closed pipe", || Some(widowed_pipe())),
    ];
    for (what, open) in stderrs {
        for (file, args, code) in [
            (&input, &["--strategy", "step", "-v", "-n", "5"][..], 0),
            (&plain, &["-v", "-n", "5"], 0),
            (&input, &["-v", "--check"], 0),
            (&bad, &["-v", "-n", "5"], 1),
        ] {
            let Some(err) = open() else {
                continue;
            };
            let child = spawn_with(
                lsgen().arg(file).args(args),
                Stdio::null(),
                Stdio::piped(),
                Stdio::from(err),
            );
            let r = finish(child, Duration::from_secs(60));
            assert_eq!(r.status.signal(), None, "{what} {args:?}: killed");
            assert_eq!(r.code(), Some(code), "{what} {file:?} {args:?}");
            if code == 0 && !args.contains(&"--check") {
                assert_eq!(r.stdout, doubled(5), "{what} {args:?}");
            }
        }
    }
}
