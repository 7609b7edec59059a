//! The one way integration tests run the real binaries (`lsgen`,
//! `lsgen-turtle`): build a [`Command`] with [`lsgen`] or [`turtle`] (args,
//! env and working directory as usual), then [`run`] it (stdin closed) or
//! [`run_with_stdin`]; both capture stdout, stderr, the exit status or
//! signal, and kill a run that takes longer than [`TIME_LIMIT`]. Tests
//! that stop a run themselves [`spawn`] it and [`finish`] it. Plus the
//! directory helpers the tests share.
#![allow(dead_code)]

use std::collections::BTreeSet;
use std::ffi::OsStr;
use std::io::Read;
use std::os::unix::process::{CommandExt, ExitStatusExt};
use std::path::{Path, PathBuf};
use std::process::{Child, Command, ExitStatus, Stdio};
use std::thread;
use std::time::{Duration, Instant};

/// The repository root (examples/, tests/expected/ are below it).
pub const ROOT: &str = env!("CARGO_MANIFEST_DIR");

/// No single run of these tests should take longer than this.
pub const TIME_LIMIT: Duration = Duration::from_secs(60);

/// The binary under test, as a path.
pub const LSGEN: &str = env!("CARGO_BIN_EXE_lsgen");

/// lsgen-turtle, as a path.
pub const TURTLE: &str = env!("CARGO_BIN_EXE_lsgen-turtle");

/// A command for `program` as every test starts it: no backtrace settings
/// from the caller's environment, and the termination signals (SIGINT,
/// SIGTERM, SIGHUP, SIGQUIT) at their default disposition and unblocked,
/// whatever the test process inherited. A test run started with `&` from a
/// script inherits SIGINT ignored, and an exec'd child keeps an ignored
/// signal: `kill -INT` would then not stop it.
pub fn command(program: impl AsRef<OsStr>) -> Command {
    let mut c = Command::new(program);
    c.env_remove("RUST_BACKTRACE")
        .env_remove("RUST_LIB_BACKTRACE");
    // SAFETY: between fork and exec only async-signal-safe calls:
    // signal(2), sigemptyset/sigaddset on a local set, sigprocmask(2).
    unsafe {
        c.pre_exec(|| {
            let mut set: libc::sigset_t = std::mem::zeroed();
            libc::sigemptyset(&mut set);
            for s in [libc::SIGINT, libc::SIGTERM, libc::SIGHUP, libc::SIGQUIT] {
                libc::signal(s, libc::SIG_DFL);
                libc::sigaddset(&mut set, s);
            }
            libc::sigprocmask(libc::SIG_UNBLOCK, &set, std::ptr::null_mut());
            Ok(())
        });
    }
    c
}

/// A command for the binary under test.
pub fn lsgen() -> Command {
    command(LSGEN)
}

/// A command for lsgen-turtle.
pub fn turtle() -> Command {
    command(TURTLE)
}

/// lsgen started from the repository root (so `examples/...` works).
pub fn lsgen_in_root() -> Command {
    let mut c = lsgen();
    c.current_dir(ROOT);
    c
}

/// lsgen under `sh -c 'SETUP; exec lsgen ARGS...'` (for `ulimit` and
/// redirections of lsgen's own descriptors); add lsgen's arguments with
/// `.arg`/`.args`.
pub fn lsgen_under_sh(setup: &str) -> Command {
    let mut c = command("sh");
    c.arg("-c")
        .arg(format!("{setup}; exec \"$0\" \"$@\""))
        .arg(LSGEN);
    c
}

/// The path of `examples/NAME.ls`.
pub fn example(name: &str) -> String {
    Path::new(ROOT)
        .join("examples")
        .join(format!("{name}.ls"))
        .display()
        .to_string()
}

/// What a finished run left.
#[derive(Debug)]
pub struct Run {
    /// The command line, for messages.
    pub what: String,
    pub status: ExitStatus,
    pub stdout: Vec<u8>,
    pub stderr: String,
    pub elapsed: Duration,
}

impl Run {
    pub fn code(&self) -> Option<i32> {
        self.status.code()
    }

    /// The signal that killed the run, if one did.
    pub fn signal(&self) -> Option<i32> {
        self.status.signal()
    }

    /// Standard output as text (it must be UTF-8).
    pub fn out(&self) -> String {
        String::from_utf8(self.stdout.clone())
            .unwrap_or_else(|_| panic!("{}: output is not UTF-8", self.what))
    }

    /// Lines of standard error that start with `lsgen: `.
    pub fn lsgen_lines(&self) -> Vec<&str> {
        self.stderr
            .lines()
            .filter(|l| l.starts_with("lsgen: "))
            .collect()
    }

    /// No panic message, no backtrace, no internal error, no signal, no
    /// exit status of a panic (101) or of lsgen's bug handler (70).
    pub fn assert_no_crash(&self) -> &Self {
        for bad in [
            "panicked",
            "RUST_BACKTRACE",
            "stack backtrace",
            "internal error",
            "overflowed its stack",
        ] {
            assert!(
                !self.stderr.contains(bad),
                "{}: stderr mentions {bad:?}:\n{}",
                self.what,
                self.stderr
            );
        }
        assert_eq!(
            self.signal(),
            None,
            "{}: killed by a signal; stderr:\n{}",
            self.what,
            self.stderr
        );
        assert!(
            !matches!(self.code(), Some(70 | 101)),
            "{}: exit status {:?} (a panic); stderr:\n{}",
            self.what,
            self.code(),
            self.stderr
        );
        self
    }

    /// Exit 0 and nothing on stderr; returns stdout as text.
    pub fn ok(&self) -> String {
        self.assert_no_crash();
        assert_eq!(
            self.code(),
            Some(0),
            "{} exited with {:?}:\n{}",
            self.what,
            self.code(),
            self.stderr
        );
        assert!(
            self.stderr.is_empty(),
            "{} wrote to stderr:\n{}",
            self.what,
            self.stderr
        );
        self.out()
    }

    /// Exit `code` and nothing on stdout; returns stderr.
    pub fn fails(&self, code: i32) -> &str {
        self.assert_no_crash();
        assert_eq!(
            self.code(),
            Some(code),
            "{} exited with {:?} (want {code}); stdout {:?}, stderr:\n{}",
            self.what,
            self.code(),
            String::from_utf8_lossy(&self.stdout),
            self.stderr
        );
        assert!(
            self.stdout.is_empty(),
            "{} failed but wrote to stdout: {:?}",
            self.what,
            String::from_utf8_lossy(&self.stdout)
        );
        &self.stderr
    }

    /// Exit status 1 and exactly one `lsgen: ` line on stderr, which holds
    /// `: error: ` once; returns that line.
    pub fn assert_one_error(&self) -> &str {
        self.assert_no_crash();
        assert_eq!(
            self.code(),
            Some(1),
            "{}: expected exit status 1; stderr:\n{}",
            self.what,
            self.stderr
        );
        let lines = self.lsgen_lines();
        assert_eq!(
            lines.len(),
            1,
            "{}: expected exactly one `lsgen: ` line; stderr:\n{}",
            self.what,
            self.stderr
        );
        assert_eq!(
            self.stderr.matches(": error: ").count(),
            1,
            "{}: expected exactly one error; stderr:\n{}",
            self.what,
            self.stderr
        );
        lines[0]
    }

    /// Exit 1, nothing on stdout, exactly one error, first on stderr;
    /// returns stderr whole.
    pub fn one_error(&self) -> &str {
        self.fails(1);
        self.assert_one_error();
        assert!(
            self.stderr.starts_with("lsgen: "),
            "{}: stderr {:?}",
            self.what,
            self.stderr
        );
        &self.stderr
    }
}

fn describe(cmd: &Command) -> String {
    let program = cmd.get_program();
    let program = if program == LSGEN {
        "lsgen".into()
    } else if program == TURTLE {
        "lsgen-turtle".into()
    } else {
        program.to_string_lossy()
    };
    let mut s = format!("`{program}");
    for a in cmd.get_args() {
        s.push(' ');
        s.push_str(&a.to_string_lossy());
    }
    s.push('`');
    s
}

fn drain(mut r: impl Read + Send + 'static) -> thread::JoinHandle<Vec<u8>> {
    thread::spawn(move || {
        let mut v = Vec::new();
        let _ = r.read_to_end(&mut v);
        v
    })
}

/// A started run, with its command line for messages.
pub struct Started {
    pub child: Child,
    pub what: String,
}

impl std::ops::Deref for Started {
    type Target = Child;
    fn deref(&self) -> &Child {
        &self.child
    }
}

impl std::ops::DerefMut for Started {
    fn deref_mut(&mut self) -> &mut Child {
        &mut self.child
    }
}

/// Start `cmd` with stdin closed, stdout and stderr piped ([`spawn_with`]
/// for other descriptors).
pub fn spawn(cmd: &mut Command) -> Started {
    spawn_with(cmd, Stdio::null(), Stdio::piped(), Stdio::piped())
}

/// Start `cmd` with the given standard descriptors.
pub fn spawn_with(cmd: &mut Command, stdin: Stdio, stdout: Stdio, stderr: Stdio) -> Started {
    let what = describe(cmd);
    let child = cmd
        .stdin(stdin)
        .stdout(stdout)
        .stderr(stderr)
        .spawn()
        .unwrap_or_else(|e| panic!("cannot start {what}: {e}"));
    Started { child, what }
}

/// Wait for a started run, reading whatever of stdout/stderr is piped, and
/// kill it after `limit`. Panics (failing the test) on timeout.
pub fn finish(started: Started, limit: Duration) -> Run {
    let Started { mut child, what } = started;
    let start = Instant::now();
    let out = child.stdout.take().map(drain);
    let err = child.stderr.take().map(drain);
    let status = loop {
        if let Some(s) = child.try_wait().expect("try_wait") {
            break s;
        }
        if start.elapsed() > limit {
            let _ = child.kill();
            let _ = child.wait();
            panic!("{what} did not finish within {limit:?}");
        }
        thread::sleep(Duration::from_millis(5));
    };
    let elapsed = start.elapsed();
    let stdout = out.map(|h| h.join().unwrap()).unwrap_or_default();
    let stderr = err.map(|h| h.join().unwrap()).unwrap_or_default();
    Run {
        what,
        status,
        stdout,
        stderr: String::from_utf8_lossy(&stderr).into_owned(),
        elapsed,
    }
}

/// Run `cmd` to completion with stdin closed and stdout/stderr captured.
pub fn run(cmd: &mut Command) -> Run {
    finish(spawn(cmd), TIME_LIMIT)
}

/// As [`run`], with a time limit of `limit`.
pub fn run_within(cmd: &mut Command, limit: Duration) -> Run {
    finish(spawn(cmd), limit)
}

/// Run `cmd` to completion with `input` on its stdin and stdout/stderr
/// captured. The input is written from a thread; the program may stop
/// reading early (at an error), so a failed write is not a test failure.
pub fn run_with_stdin(cmd: &mut Command, input: impl Into<Vec<u8>>) -> Run {
    use std::io::Write;
    let input = input.into();
    let mut started = spawn_with(cmd, Stdio::piped(), Stdio::piped(), Stdio::piped());
    let mut stdin = started.child.stdin.take().unwrap();
    let writer = thread::spawn(move || {
        let _ = stdin.write_all(&input);
    });
    let r = finish(started, TIME_LIMIT);
    writer.join().unwrap();
    r
}

/// Run lsgen with `args` on `src` written to a file `p.ls` in a fresh
/// directory (the file comes last on the command line).
pub fn run_ls(src: impl AsRef<[u8]>, args: &[&str]) -> Run {
    let dir = tempdir();
    let p = write(dir.path(), "p.ls", src);
    run(lsgen().args(args).arg(&p))
}

/// Write `text` to `dir/name`; returns the path.
pub fn write(dir: &Path, name: &str, text: impl AsRef<[u8]>) -> PathBuf {
    let p = dir.join(name);
    std::fs::write(&p, text).unwrap_or_else(|e| panic!("write {}: {e}", p.display()));
    p
}

/// The names in a directory (hidden ones included).
pub fn listing(dir: &Path) -> BTreeSet<String> {
    std::fs::read_dir(dir)
        .unwrap_or_else(|e| panic!("read_dir {}: {e}", dir.display()))
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect()
}

/// Assert that `dir` holds exactly `names`.
pub fn assert_listing(dir: &Path, names: &[&str]) {
    let want: BTreeSet<String> = names.iter().map(|s| s.to_string()).collect();
    assert_eq!(
        listing(dir),
        want,
        "unexpected contents of {}",
        dir.display()
    );
}

/// A fresh temporary directory.
pub fn tempdir() -> tempfile::TempDir {
    tempfile::Builder::new()
        .prefix("lsgen-test-")
        .tempdir()
        .expect("create a temp dir")
}

/// A fresh directory holding `files`.
pub fn dir_with(files: &[(&str, &str)]) -> tempfile::TempDir {
    let d = tempdir();
    for (name, text) in files {
        write(d.path(), name, text);
    }
    d
}

/// The environment variable that rewrites golden files instead of
/// comparing with them: `LSGEN_BLESS=1 cargo test --test bad_input`.
pub const BLESS: &str = "LSGEN_BLESS";

/// Compare `got` with the golden file `tests/golden/REL` as a whole; with
/// `LSGEN_BLESS=1` in the environment, write `got` there instead (review
/// the change with `git diff` before committing it).
pub fn assert_golden(rel: &str, got: &str) {
    let path = Path::new(ROOT).join("tests/golden").join(rel);
    if std::env::var_os(BLESS).is_some_and(|v| v != "0") {
        if std::fs::read_to_string(&path).ok().as_deref() != Some(got) {
            std::fs::create_dir_all(path.parent().unwrap()).unwrap();
            std::fs::write(&path, got).unwrap_or_else(|e| panic!("write {}: {e}", path.display()));
        }
        return;
    }
    let want = std::fs::read_to_string(&path).unwrap_or_else(|e| {
        panic!("tests/golden/{rel}: {e}; got:\n{got}\n(write it with {BLESS}=1 and review it)")
    });
    if want != got {
        let show = |s: &str| {
            s.lines()
                .map(|l| {
                    let l: String = l.chars().take(300).collect();
                    format!("  |{l}\n")
                })
                .collect::<String>()
        };
        panic!(
            "stderr differs from tests/golden/{rel}\nwant:\n{}got:\n{}(debug: want {:?}, got {:?})\n\
             if the new text is right, rewrite the file with {BLESS}=1 and review the diff",
            show(&want),
            show(got),
            want.chars().take(2000).collect::<String>(),
            got.chars().take(2000).collect::<String>()
        );
    }
}
