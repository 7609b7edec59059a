//! Helpers shared by `tests/bad_input.rs` and `tests/faults.rs`: running the
//! real `lsgen` binary with a time limit, and looking at directories.
#![allow(dead_code)]

use std::collections::BTreeSet;
use std::io::Read;
use std::path::Path;
use std::process::{Child, Command, ExitStatus, Stdio};
use std::thread;
use std::time::{Duration, Instant};

/// No single run of these tests should take longer than this.
pub const TIME_LIMIT: Duration = Duration::from_secs(60);

/// A command for the binary under test.
pub fn lsgen() -> Command {
    let mut c = Command::new(env!("CARGO_BIN_EXE_lsgen"));
    c.env_remove("RUST_BACKTRACE")
        .env_remove("RUST_LIB_BACKTRACE");
    c
}

/// What a finished run left.
#[derive(Debug)]
pub struct Run {
    pub status: ExitStatus,
    pub stdout: Vec<u8>,
    pub stderr: String,
    pub elapsed: Duration,
}

impl Run {
    pub fn code(&self) -> Option<i32> {
        self.status.code()
    }

    /// Lines of standard error that start with `lsgen: `.
    pub fn lsgen_lines(&self) -> Vec<&str> {
        self.stderr
            .lines()
            .filter(|l| l.starts_with("lsgen: "))
            .collect()
    }

    /// No panic message, no backtrace, no internal error.
    pub fn assert_no_crash(&self) {
        for bad in [
            "panicked",
            "RUST_BACKTRACE",
            "stack backtrace",
            "internal error",
            "overflowed its stack",
        ] {
            assert!(
                !self.stderr.contains(bad),
                "stderr mentions {bad:?}:\n{}",
                self.stderr
            );
        }
        #[cfg(unix)]
        {
            use std::os::unix::process::ExitStatusExt;
            assert_eq!(
                self.status.signal(),
                None,
                "killed by a signal; stderr:\n{}",
                self.stderr
            );
        }
    }

    /// Exit status 1 and exactly one `lsgen: ` line on stderr; returns it.
    pub fn assert_one_error(&self) -> &str {
        self.assert_no_crash();
        assert_eq!(
            self.code(),
            Some(1),
            "expected exit status 1; stderr:\n{}",
            self.stderr
        );
        let lines = self.lsgen_lines();
        assert_eq!(
            lines.len(),
            1,
            "expected exactly one `lsgen: ` line; stderr:\n{}",
            self.stderr
        );
        lines[0]
    }
}

fn drain(mut r: impl Read + Send + 'static) -> thread::JoinHandle<Vec<u8>> {
    thread::spawn(move || {
        let mut v = Vec::new();
        let _ = r.read_to_end(&mut v);
        v
    })
}

/// Wait for a child whose stdout/stderr may be piped, killing it after
/// `limit`. Panics (failing the test) on timeout.
pub fn finish(mut child: Child, limit: Duration) -> Run {
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
            panic!("lsgen did not finish within {limit:?}");
        }
        thread::sleep(Duration::from_millis(5));
    };
    let elapsed = start.elapsed();
    let stdout = out.map(|h| h.join().unwrap()).unwrap_or_default();
    let stderr = err.map(|h| h.join().unwrap()).unwrap_or_default();
    Run {
        status,
        stdout,
        stderr: String::from_utf8_lossy(&stderr).into_owned(),
        elapsed,
    }
}

/// Run `cmd` to completion with stdin closed and stdout/stderr captured.
pub fn run(cmd: &mut Command) -> Run {
    let child = cmd
        .stdin(Stdio::null())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("spawn lsgen");
    finish(child, TIME_LIMIT)
}

/// Run `cmd` to completion with `input` on its stdin and stdout/stderr
/// captured. The input is written from a thread; lsgen may stop reading
/// early (at an error), so a failed write is not a test failure.
pub fn run_with_stdin(cmd: &mut Command, input: Vec<u8>) -> Run {
    use std::io::Write;
    let mut child = cmd
        .stdin(Stdio::piped())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("spawn lsgen");
    let mut stdin = child.stdin.take().unwrap();
    let writer = thread::spawn(move || {
        let _ = stdin.write_all(&input);
    });
    let r = finish(child, TIME_LIMIT);
    writer.join().unwrap();
    r
}

/// The names in a directory.
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
