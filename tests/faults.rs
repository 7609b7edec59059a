//! Faults around the derivation: atomic `-o` output, temporary files,
//! signals, full disks, unwritable and unreadable paths, closed pipes,
//! runaway derivations and size limits. Every test runs the real binary.

mod faults_support;

use faults_support::{assert_listing, finish, listing, lsgen, run, tempdir, Run};
use std::fs;
use std::os::unix::fs::MetadataExt;
use std::os::unix::process::ExitStatusExt;
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::thread;
use std::time::{Duration, Instant};

/// `F -> FF`: generation n has 2^n modules.
/// `F -> FF`, plus a context production for a symbol that never occurs: the
/// same strings, but it keeps the step-by-step engine with its temporary
/// generations (deterministic context-free systems are expanded depth first,
/// without them, and far faster than these tests stop them).
const DOUBLING: &str = "productions:\nF -> FF\n\u{2603} < \u{2603} -> \u{2603}\naxiom: F\n";
const OLD: &str = "old contents\n";

fn write(dir: &Path, name: &str, text: impl AsRef<[u8]>) -> PathBuf {
    let p = dir.join(name);
    fs::write(&p, text).unwrap();
    p
}

fn doubled(n: u32) -> Vec<u8> {
    let mut v = vec![b'F'; 1 << n];
    v.push(b'\n');
    v
}

/// Start lsgen with stdout discarded and stderr captured.
fn spawn(cmd: &mut Command) -> Child {
    cmd.stdin(Stdio::null())
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .expect("spawn lsgen")
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
        lsgen()
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
    let r = run(lsgen().arg(&input).args(["-n", "5", "-o"]).arg(&out));
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
    let r = run(lsgen().arg(&input).args(["-n", "3", "-o"]).arg(&input));
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
    let r = run(lsgen().arg(&input).args(["-n", "3", "-o"]).arg(&out));
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
    let r = run(lsgen()
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
        lsgen()
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
            lsgen()
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
    let r = run(lsgen()
        .arg(&input)
        .args(["-n", "12", "--tmpdir"])
        .arg(t)
        .arg("-o")
        .arg(&out));
    assert_eq!(r.code(), Some(0), "stderr:\n{}", r.stderr);
    assert_listing(t, &[]);
    let r = run(lsgen().arg(&input).args(["-n", "12", "--tmpdir"]).arg(t));
    assert_eq!(r.code(), Some(0), "stderr:\n{}", r.stderr);
    assert_eq!(r.stdout, doubled(12));
    assert_listing(t, &[]);
    // A runtime error in a late step.
    let bad = write(
        d,
        "bad.ls",
        "derivation length: 8\nproductions:\nF -> FF\nA(x) -> A(x-1) B(sqrt(x))\naxiom: F A(5)\n",
    );
    let r = run(lsgen().arg(&bad).arg("--tmpdir").arg(t).arg("-o").arg(&out));
    assert!(
        r.assert_one_error().contains("(in step 7)"),
        "stderr:\n{}",
        r.stderr
    );
    assert_listing(t, &[]);
    // An error in the axiom, after the first temporary file exists.
    let bad = write(d, "bad2.ls", "productions:\nF -> FF\naxiom: F F F F(1,\n");
    let r = run(lsgen().arg(&bad).arg("--tmpdir").arg(t).arg("-o").arg(&out));
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
        let r = run(lsgen().arg(&input).args(["-n", n, "-o", "/dev/full"]));
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
    let r = run(lsgen().arg(&input).args(["-n", "3", "-o", "/dev/full"]));
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
        let child = lsgen()
            .arg(&input)
            .args(["-n", n])
            .stdin(Stdio::null())
            .stdout(Stdio::from(full))
            .stderr(Stdio::piped())
            .spawn()
            .unwrap();
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
    let r = run(lsgen()
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
    let r = run(lsgen()
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
    let r = run(lsgen().arg(&input).args(["-o", "/nonexistent-dir/x"]));
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
    let r = run(lsgen().arg(&input).arg("-o").arg(&sub));
    let line = plain_error(&r, &sub.display().to_string());
    assert!(line.contains("directory"), "{line}");
    let below = input.join("x");
    let r = run(lsgen().arg(&input).arg("-o").arg(&below));
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
    let r = run(lsgen()
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
    let r = run(lsgen()
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
    let mut child = lsgen()
        .arg(&input)
        .args(["-n", "22"])
        .stdin(Stdio::null())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
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
        let r = run(lsgen()
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
    let r = run(lsgen()
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
