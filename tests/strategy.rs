//! The hidden `--strategy auto|step|dfs` flag that lets tests force how a
//! derivation is carried out (issue 10): expected strings are derived by
//! hand.

use std::process::Command;

const BIN: &str = env!("CARGO_BIN_EXE_lsgen");

fn run(src: &str, args: &[&str]) -> (String, String, i32) {
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("p.ls");
    std::fs::write(&p, src).unwrap();
    let out = Command::new(BIN).args(args).arg(&p).output().unwrap();
    (
        String::from_utf8(out.stdout).unwrap(),
        String::from_utf8(out.stderr).unwrap(),
        out.status.code().unwrap_or(-1),
    )
}

const ALGAE: &str = "productions:\nA -> AB\nB -> A\naxiom: A\n";
const PARAMETRIC: &str =
    "productions:\nA(x) : x < 2 -> A(x+1)B\nA(x) : x >= 2 -> C(x)\naxiom: A(0)\n";

#[test]
fn every_strategy_gives_the_same_string() {
    // A, AB, ABA, ABAAB, ABAABABA
    for s in ["auto", "step", "dfs"] {
        assert_eq!(
            run(ALGAE, &["-n", "4", "--strategy", s]),
            ("ABAABABA\n".into(), String::new(), 0),
            "{s}"
        );
        // A(0), A(1)B, A(2)BB, C(2)BB
        assert_eq!(
            run(PARAMETRIC, &["-n", "3", "--strategy", s]),
            ("C(2)BB\n".into(), String::new(), 0),
            "{s}"
        );
    }
}

#[test]
fn step_really_steps() {
    // Only the step-by-step engine sees the fixed point after step 1.
    let (out, err, code) = run(
        "productions:\nA -> A\naxiom: A\n",
        &["-n", "5", "-v", "--seed", "1", "--strategy", "step"],
    );
    assert_eq!((out.as_str(), code), ("A\n", 0));
    assert!(err.contains("steps 2..5: unchanged (fixed point)"), "{err}");
    let (out, err, code) = run(
        "productions:\nA -> A\naxiom: A\n",
        &["-n", "5", "-v", "--seed", "1", "--strategy", "dfs"],
    );
    assert_eq!((out.as_str(), code), ("A\n", 0));
    assert!(!err.contains("fixed point"), "{err}");
}

#[test]
fn dfs_is_a_usage_error_when_the_system_does_not_allow_it() {
    let refused = [
        // a context
        ("productions:\nA < B -> A\naxiom: AB\n", vec!["-n", "2"]),
        // a probability
        ("productions:\nA -> AB : 0.5\naxiom: A\n", vec!["-n", "2"]),
        // parametric, and generation lengths asked for
        (PARAMETRIC, vec!["-n", "3", "-v"]),
        (PARAMETRIC, vec!["-n", "3", "--max-length", "100"]),
        // deeper than the depth-first stack
        (ALGAE, vec!["-n", "70000", "--max-length", "10"]),
        // nothing to derive
        (ALGAE, vec!["-n", "0", "--no-homomorphism"]),
    ];
    for (src, mut args) in refused {
        args.extend(["--strategy", "dfs"]);
        let (out, err, code) = run(src, &args);
        assert_eq!((out.as_str(), code), ("", 2), "{src} {args:?}: {err}");
        assert!(
            err.ends_with(
                "lsgen: error: `--strategy dfs`: this system cannot be derived depth first \
             with these options\n"
            ),
            "{err}"
        );
    }
    let (out, err, code) = run(ALGAE, &["--strategy", "sideways"]);
    assert_eq!((out.as_str(), code), ("", 2), "{err}");
}

/// `--max-length` errors name the step as `--first-step` numbers it,
/// whatever the strategy: depth first, D0L lengths are worked out before
/// anything is derived, and that check said "step 3" for the run's third
/// step where the step engine says "step 7".
#[test]
fn a_length_error_names_the_step_by_first_step() {
    // From A: AB (2 modules, step 5), ABA (3, step 6), ABAAB (5, step 7).
    // Bytes: the binary generations before the last one count (AB is 2
    // bytes, ABA 3): over 2 bytes at step 6.
    for (limit, want) in [
        ("3", "(3 modules) in step 7"),
        ("2B", "(2 bytes) in step 6"),
    ] {
        let want = format!("lsgen: error: the string grew past --max-length {want}\n");
        for s in ["auto", "step", "dfs"] {
            let args = ["--first-step", "5", "-n", "3", "--max-length", limit];
            let args = [&args[..], &["--strategy", s]].concat();
            assert_eq!(run(ALGAE, &args), (String::new(), want.clone(), 1), "{s}");
        }
    }
}
