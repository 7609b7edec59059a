//! The differential test of the cpfg dialect: 1120 random `.l` systems
//! (every feature of the dialect mixed, see tests/tools/gen_cpfg_cases.py;
//! cases 301-400 also assign `Q` and `Z` in blocks and try productions at
//! the decomposition's and the homomorphism's depth limit, and 401-500
//! add contexts to decomposition productions, and 501-560 have axioms whose
//! parameters read globals, `ran` and a `Q` or `Z` that `Start:` assigns,
//! and 561-600 are seeded, with keys without parameters that have several
//! productions, mostly without weights: each weighs 1 and competes, and
//! 601-640 call `func(id, x)` with function files of their own, given by a
//! view file `case.v` or directly with `--functions`, and 641-720 assign
//! to formal parameters in pre-condition blocks, which the next production
//! tried does not see, and 721-780 define arrays in a `define:` block and
//! read and assign their elements, with subscripts out of range (clamped)
//! and fractional ones, and 781-810 have string literals among their
//! parameters, which are their numbers among the file's strings, and
//! 811-870 have predecessors of several modules in the decomposition and
//! the homomorphism, with contexts, conditions and blocks, seeded or not, and
//! 871-930 call `curveX`, `curveY`, `curveZ` and `curveGAL` with contour
//! files of their own (and often functions), given by a view file's
//! `curve:` lines or directly with `--functions` or `--curves`, and 931-990
//! have turtle queries `?P`, `?H`, `?L`, `?U` that conditions read through
//! contexts and predecessors, filled by the turtle with the settings of the
//! view file `case.v`, given with `--cpfg-view`, and 991-1020 are those
//! with a homomorphism that cannot change the turtle (still modules outside
//! its successors' brackets, no blocks, probabilities or `ran`; cpfg's
//! turtle, and the reference's, read the string through it, sometimes at
//! `maximum depth: 2`, with contexts and conditions) and `@Gs`, `@Gc(2)`,
//! `@Ge(2)`, `@Gt`, `@Gr` in successors), and 1021-1050 with a
//! homomorphism that moves the turtle (moves outside its successors'
//! brackets, sometimes a production for a move of the string), which the
//! turtle follows, and 1051-1080 with cpfg's movements (`tropism:` and
//! `torque:` lines in the view, `@Ts`, `@Ti`, `@Td`, `@Tp`, `@Tf`), and
//! 1081-1120 have nothing cpfg runs in string order (no `seed:`, `ran`,
//! blocks, contexts, queries, ...), which lsgen derives depth first
//! (`--strategy dfs`, on three threads every other case),
//! derived by the independent reference tests/tools/cpfg_ref.py; lsgen must
//! print the same string for each. Every other case runs with
//! `LSGEN_TEST_SPLIT=1`: splits in tasks of one module or byte where a
//! pass splits, and the last two passes give back their input byte by byte
//! (`derive::reclaim`), so that a reader that went back into it fails.
//! Cases 2 and 3 of every 4 run with `LSGEN_TEST_WALK=0`: the
//! decomposition's and the homomorphism's recursion walk every successor
//! as they reach it (draws, warnings, block variables and failures kept
//! in cpfg's order), not only those of more than 64 modules.
//!
//! A case: `=== STEPS`, the `.l` text, then zero or more `--- file NAME`
//! sections (the file's text, written beside case.l), an optional
//! `--- args --functions A ...` line (options and their files, relative to
//! the case's directory: `--functions`, `--curves` or `--cpfg-view`;
//! without it `--functions case.v` if the case has that file), then
//! `--- expected` and the output line.

mod common;

use common::{lsgen, run, tempdir, ROOT};
use std::path::Path;

/// A case's `.l` text, its files (name, text) and its `--- args` words.
fn split_case(body: &str) -> (String, Vec<(String, String)>, Option<Vec<String>>) {
    let mut src = String::new();
    let mut files: Vec<(String, String)> = Vec::new();
    let mut args = None;
    for line in body.split_inclusive('\n') {
        if let Some(name) = line.strip_prefix("--- file ") {
            files.push((name.trim_end_matches('\n').to_string(), String::new()));
        } else if let Some(rest) = line.strip_prefix("--- args") {
            args = Some(rest.split_whitespace().map(str::to_string).collect());
        } else if let Some((_, text)) = files.last_mut() {
            text.push_str(line);
        } else {
            src.push_str(line);
        }
    }
    (src, files, args)
}

#[test]
fn random_cases_match_cpfg_ref() {
    let text =
        std::fs::read_to_string(Path::new(ROOT).join("tests/expected/cpfg/random/cases.txt"))
            .unwrap();
    let dir = tempdir();
    let mut cases = 0;
    let mut failures = Vec::new();
    for case in text.split("=== ").skip(1) {
        let (n, rest) = case.split_once('\n').unwrap();
        let (body, want) = rest.split_once("--- expected\n").unwrap();
        let (src, files, args) = split_case(body);
        // each case in a directory of its own: no file of another case
        let case_dir = dir.path().join(format!("case{cases}"));
        std::fs::create_dir(&case_dir).unwrap();
        let file = case_dir.join("case.l");
        std::fs::write(&file, &src).unwrap();
        for (name, text) in &files {
            std::fs::write(case_dir.join(name), text).unwrap();
        }
        let args = args.unwrap_or_else(|| {
            if files.iter().any(|(name, _)| name == "case.v") {
                vec!["--functions".to_string(), "case.v".to_string()]
            } else {
                Vec::new()
            }
        });
        let mut cmd = lsgen();
        if cases % 2 == 1 {
            cmd.env("LSGEN_TEST_SPLIT", "1");
        }
        if cases % 4 >= 2 {
            // Every successor of the decomposition and the homomorphism's
            // depth walked as it is reached (`step.rs`'s `descend`).
            cmd.env("LSGEN_TEST_WALK", "0");
        }
        cmd.args(["-n", n.trim()]);
        if cases >= 1080 {
            // (Refused if the file needs the step strategy.)
            cmd.args([
                "--strategy",
                "dfs",
                "-j",
                if cases % 2 == 1 { "3" } else { "1" },
            ]);
        }
        let mut words = args.iter();
        while let Some(w) = words.next() {
            // (`--curves` is another name of `--functions`; `--cpfg-view`
            // gives the view file of the queries' turtle)
            assert!(
                w == "--functions" || w == "--curves" || w == "--cpfg-view",
                "case {cases}: bad `--- args` line"
            );
            let f = words.next().expect("an option of `--- args` needs a file");
            cmd.arg(w).arg(case_dir.join(f));
        }
        let r = run(cmd.arg(&file));
        let got = String::from_utf8_lossy(&r.stdout);
        if !r.status.success() || got.trim_end_matches('\n') != want.trim_end_matches('\n') {
            failures.push(format!(
                "case {cases} (-n {n}{}):\n{body}--- want\n{want}--- got ({})\n{got}\n{}",
                args.iter().map(|a| format!(" {a}")).collect::<String>(),
                r.status,
                r.stderr
            ));
        }
        cases += 1;
    }
    assert_eq!(cases, 1120);
    assert!(
        failures.is_empty(),
        "{} of {cases} cases differ from cpfg_ref.py:\n{}",
        failures.len(),
        failures.join("\n")
    );
}
