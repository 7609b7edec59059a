//! The differential test of the cpfg dialect: 600 random `.l` systems
//! (every feature of the dialect mixed, see tests/tools/gen_cpfg_cases.py;
//! cases 301-400 also assign `Q` and `Z` in blocks and try productions at
//! the decomposition's and the homomorphism's depth limit, and 401-500
//! add contexts to decomposition productions, and 501-560 have axioms whose
//! parameters read globals, `ran` and a `Q` or `Z` that `Start:` assigns,
//! and 561-600 are seeded, with keys without parameters that have several
//! productions, mostly without weights: each weighs 1 and competes),
//! derived by the independent reference tests/tools/cpfg_ref.py; lsgen must
//! print the same string for each. Every other case runs with
//! `LSGEN_TEST_SPLIT=1`: splits in tasks of one module or byte where a
//! pass splits, and the last two passes give back their input byte by byte
//! (`derive::reclaim`), so that a reader that went back into it fails.

mod common;

use common::{lsgen, run, tempdir, ROOT};
use std::path::Path;

#[test]
fn random_cases_match_cpfg_ref() {
    let text =
        std::fs::read_to_string(Path::new(ROOT).join("tests/expected/cpfg/random/cases.txt"))
            .unwrap();
    let dir = tempdir();
    let file = dir.path().join("case.l");
    let mut cases = 0;
    let mut failures = Vec::new();
    for case in text.split("=== ").skip(1) {
        let (n, rest) = case.split_once('\n').unwrap();
        let (src, want) = rest.split_once("--- expected\n").unwrap();
        std::fs::write(&file, src).unwrap();
        let mut cmd = lsgen();
        if cases % 2 == 1 {
            cmd.env("LSGEN_TEST_SPLIT", "1");
        }
        let r = run(cmd.args(["-n", n.trim()]).arg(&file));
        let got = String::from_utf8_lossy(&r.stdout);
        if !r.status.success() || got.trim_end_matches('\n') != want.trim_end_matches('\n') {
            failures.push(format!(
                "case {cases} (-n {n}):\n{src}--- want\n{want}--- got ({})\n{got}\n{}",
                r.status, r.stderr
            ));
        }
        cases += 1;
    }
    assert_eq!(cases, 600);
    assert!(
        failures.is_empty(),
        "{} of {cases} cases differ from cpfg_ref.py:\n{}",
        failures.len(),
        failures.join("\n")
    );
}
