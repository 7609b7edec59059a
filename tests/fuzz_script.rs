//! `fuzz/run.sh`'s libFuzzer flags, through its dry run (nothing is built
//! or fuzzed).

use std::process::Command;

const ROOT: &str = env!("CARGO_MANIFEST_DIR");

/// The libFuzzer flags `fuzz/run.sh ARGS` would run with.
fn flags(args: &[&str]) -> Vec<String> {
    let out = Command::new("bash")
        .arg(format!("{ROOT}/fuzz/run.sh"))
        .args(args)
        .env("FUZZ_DRY_RUN", "1")
        .output()
        .expect("run bash");
    assert!(
        out.status.success(),
        "fuzz/run.sh {args:?}: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    String::from_utf8(out.stdout)
        .unwrap()
        .lines()
        .map(str::to_string)
        .collect()
}

fn runs(args: &[&str]) -> String {
    let f = flags(args);
    let runs: Vec<&String> = f.iter().filter(|s| s.starts_with("-runs=")).collect();
    assert_eq!(runs.len(), 1, "{args:?}: {f:?}");
    runs[0].clone()
}

/// RUNS 0 means until stopped: libFuzzer's -runs=-1 (its -runs=0 only
/// replays the seed corpus, which run.sh passed before).
#[test]
fn runs_zero_fuzzes_until_stopped() {
    assert_eq!(runs(&["derive", "0"]), "-runs=-1");
    assert_eq!(runs(&["parse", "0", "-max_total_time=60"]), "-runs=-1");
    assert_eq!(runs(&["derive", "10000000"]), "-runs=10000000");
    assert_eq!(runs(&["parse"]), "-runs=1000000");
    assert!(flags(&["derive", "0", "-max_total_time=60"]).contains(&"-max_total_time=60".into()));
}
