//! `fuzz/run.sh`'s libFuzzer flags, through its dry run (nothing is built
//! or fuzzed).

mod common;

use common::ROOT;

/// The libFuzzer flags `fuzz/run.sh ARGS` would run with.
fn flags(args: &[&str]) -> Vec<String> {
    let out = common::run(
        common::command("bash")
            .arg(format!("{ROOT}/fuzz/run.sh"))
            .args(args)
            .env("FUZZ_DRY_RUN", "1"),
    );
    assert!(out.status.success(), "{}: {}", out.what, out.stderr);
    out.out().lines().map(str::to_string).collect()
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
