//! `--frames A..B[:K]` (issue 13): every asked-for generation from one
//! derivation, each exactly what `lsgen -n k` prints; to standard output one
//! per line, or with `-o` to files named by a template.

mod common;

use common::{example, lsgen, run};
use std::path::Path;

/// `lsgen ARGS FILE` must succeed; its standard output.
fn ok(args: &[&str], file: &str) -> String {
    let r = run(lsgen().args(args).arg(file));
    r.assert_no_crash();
    assert_eq!(r.code(), Some(0), "lsgen {args:?} {file}: {}", r.stderr);
    r.out()
}

/// The expected string of `tests/expected/NAME.nK.txt` (from the
/// independent Python reference), with its newline.
fn expected(name: &str, k: u64) -> String {
    let p = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("tests/expected")
        .join(format!("{name}.n{k}.txt"));
    let mut s = std::fs::read_to_string(&p).unwrap_or_else(|e| panic!("{}: {e}", p.display()));
    if !s.ends_with('\n') {
        s.push('\n');
    }
    s
}

/// Frames of `name` to standard output equal `-n k` for each frame, with
/// `extra` options on both sides.
fn frames_equal_runs(name: &str, range: &str, ks: &[u64], extra: &[&str]) {
    let file = example(name);
    let mut args = vec!["--frames", range];
    args.extend_from_slice(extra);
    let got = ok(&args, &file);
    let mut want = String::new();
    for k in ks {
        let n = k.to_string();
        let mut args = vec!["-n", &n];
        args.extend_from_slice(extra);
        want.push_str(&ok(&args, &file));
    }
    assert_eq!(got.lines().count(), ks.len(), "{name} {range}");
    assert_eq!(got, want, "{name} --frames {range} {extra:?}");
}

#[test]
fn frames_match_the_independent_reference() {
    // algae: D0L (depth first for -n); parametric: conditions and a
    // homomorphism applied to each frame; signal: context-sensitive.
    let cases: &[(&str, &str, &[u64])] = &[
        (
            "algae",
            "0..15",
            &[0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12, 13, 14, 15],
        ),
        ("algae", "2..13:4", &[2, 6, 10]),
        ("parametric", "0..6", &[0, 1, 2, 3, 4, 5, 6]),
        ("signal", "1..7:2", &[1, 3, 5, 7]),
        ("context_plant_a", "1..3", &[1, 2, 3]),
    ];
    for (name, range, ks) in cases {
        let got = ok(&["--frames", range], &example(name));
        let lines: Vec<&str> = got.split_inclusive('\n').collect();
        assert_eq!(lines.len(), ks.len(), "{name} {range}");
        for (line, &k) in lines.iter().zip(ks.iter()) {
            let path = Path::new(env!("CARGO_MANIFEST_DIR"))
                .join("tests/expected")
                .join(format!("{name}.n{k}.txt"));
            if path.exists() {
                assert_eq!(*line, expected(name, k), "{name} frame {k}");
            }
        }
    }
}

#[test]
fn frame_k_is_what_n_k_prints() {
    // Deterministic, bracketed, parametric with a homomorphism,
    // context-sensitive, and seeded stochastic systems; with and without
    // the homomorphism.
    frames_equal_runs("plant_a", "0..5", &[0, 1, 2, 3, 4, 5], &[]);
    frames_equal_runs("koch_snowflake", "1..5:2", &[1, 3, 5], &[]);
    frames_equal_runs("parametric", "0..6:3", &[0, 3, 6], &[]);
    frames_equal_runs(
        "parametric",
        "0..6",
        &[0, 1, 2, 3, 4, 5, 6],
        &["--no-homomorphism"],
    );
    frames_equal_runs("context_plant_b", "2..12:5", &[2, 7, 12], &[]);
    frames_equal_runs("signal", "0..7", &[0, 1, 2, 3, 4, 5, 6, 7], &[]);
    for seed in ["1", "7", "1234567"] {
        frames_equal_runs(
            "stochastic_plant",
            "0..5",
            &[0, 1, 2, 3, 4, 5],
            &["--seed", seed],
        );
    }
    frames_equal_runs("stochastic_row", "1..4:3", &[1, 4], &["--seed", "3"]);
    // A single frame is `-n`.
    frames_equal_runs("stochastic_plant", "4..4", &[4], &["--seed", "9"]);
}

#[test]
fn frames_go_to_files_named_by_the_template() {
    let dir = common::tempdir();
    let sub = dir.path().join("frames");
    std::fs::create_dir(&sub).unwrap();
    // An existing frame file is replaced.
    std::fs::write(sub.join("plant-3.txt"), "old\n").unwrap();
    let template = sub.join("plant-{n}.txt");
    let file = example("stochastic_plant");
    let r = run(lsgen()
        .args(["--frames", "1..5:2", "--seed", "7", "-o"])
        .arg(&template)
        .arg(&file));
    r.assert_no_crash();
    assert_eq!(r.code(), Some(0), "{}", r.stderr);
    assert_eq!(r.stdout, b"");
    let mut names: Vec<String> = std::fs::read_dir(&sub)
        .unwrap()
        .map(|e| e.unwrap().file_name().into_string().unwrap())
        .collect();
    names.sort();
    assert_eq!(names, ["plant-1.txt", "plant-3.txt", "plant-5.txt"]);
    for k in [1, 3, 5] {
        let got = std::fs::read_to_string(sub.join(format!("plant-{k}.txt"))).unwrap();
        assert_eq!(
            got,
            ok(&["-n", &k.to_string(), "--seed", "7"], &file),
            "frame {k}"
        );
    }
    // `-o -` is standard output.
    let out = ok(&["--frames", "0..1", "-o", "-"], &example("algae"));
    assert_eq!(out, "a\nab\n");
}

/// Two frame names that lead to one file (a name linked to another, as
/// `-o` follows links) are a usage error before any frame: the later frame
/// used to replace the earlier one's file.
#[test]
fn frames_that_are_one_file_are_refused() {
    let dir = common::tempdir();
    std::os::unix::fs::symlink("f1.txt", dir.path().join("f3.txt")).unwrap();
    let r = run(lsgen()
        .args(["--frames", "1..4", "-o"])
        .arg(dir.path().join("f{n}.txt"))
        .arg(example("algae")));
    r.assert_no_crash();
    assert_eq!(r.code(), Some(2), "{}", r.stderr);
    assert!(
        r.stderr.contains("generation 1 would write `")
            && r.stderr.contains("f1.txt` and generation 3 `")
            && r.stderr.contains("f3.txt`, which are one file"),
        "{}",
        r.stderr
    );
    assert!(!dir.path().join("f1.txt").exists());
    assert!(!dir.path().join("f2.txt").exists());
}

#[test]
fn a_failing_frame_leaves_no_partial_file() {
    // Step 3 fails (division by zero): frames 1 and 2 are complete, no
    // frame 3, no temporary file.
    let dir = common::tempdir();
    let ls = dir.path().join("p.ls");
    std::fs::write(&ls, "productions:\nA(x) -> A(x-1)B(1/x)\naxiom: A(2)\n").unwrap();
    let r = run(lsgen()
        .args(["--frames", "1..4", "-o"])
        .arg(dir.path().join("f{n}.txt"))
        .arg(&ls));
    r.assert_no_crash();
    assert_eq!(r.code(), Some(1), "{}", r.stderr);
    assert!(
        r.stderr.contains("division by zero (in step 3)"),
        "{}",
        r.stderr
    );
    let mut names: Vec<String> = std::fs::read_dir(dir.path())
        .unwrap()
        .map(|e| e.unwrap().file_name().into_string().unwrap())
        .collect();
    names.sort();
    assert_eq!(names, ["f1.txt", "f2.txt", "p.ls"]);
    assert_eq!(
        std::fs::read_to_string(dir.path().join("f2.txt")).unwrap(),
        "A(0)B(1)B(0.5)\n"
    );
}

#[test]
fn bad_frame_ranges_are_usage_errors() {
    let file = example("algae");
    for (args, needle) in [
        (&["--frames", "5..2"][..], "comes after"),
        (&["--frames", "1..3:0"], "1 or more"),
        (&["--frames", "1.."], "not a range"),
        (&["--frames", "..3"], "not a range"),
        (&["--frames", "a..b"], "not a range"),
        (&["--frames", "1-3"], "not a range"),
        (&["--frames", "1..3:x"], "not a range"),
        (&["--frames", "0..9007199254740993"], "go up to"),
        (&["--frames", "1..3", "-n", "2"], "cannot be used with"),
        (&["--frames", "1..3", "-o", "plain.txt"], "{n}"),
        (&["--first-step", "0"], "first-step"),
    ] {
        let r = run(lsgen().args(args).arg(&file));
        r.assert_no_crash();
        assert_eq!(r.code(), Some(2), "{args:?}: {}", r.stderr);
        assert!(r.stderr.contains(needle), "{args:?}: {}", r.stderr);
        assert_eq!(r.stdout, b"", "{args:?}");
    }
}

#[test]
fn frames_to_files_need_no_standard_output() {
    let dir = common::tempdir();
    let r = run(common::lsgen_under_sh("exec >&-")
        .args(["--frames", "1..2", "-o"])
        .arg(dir.path().join("a{n}.txt"))
        .arg(example("algae")));
    r.assert_no_crash();
    assert_eq!(r.code(), Some(0), "{}", r.stderr);
    assert_eq!(
        std::fs::read_to_string(dir.path().join("a2.txt")).unwrap(),
        "aba\n"
    );
}

/// `--precision` applies to frames as to a single run (stdout and files).
#[test]
fn frames_honour_precision() {
    let src = "productions:\nA(x) -> A(x/3)\naxiom:\nA(1)\n";
    let r = common::run_ls(src, &["--frames", "1..2", "--precision", "2"]);
    assert_eq!(r.ok(), "A(0.33)\nA(0.11)\n");
    let dir = common::tempdir();
    let t = dir.path().join("f-{n}.txt");
    let r = common::run_ls(
        src,
        &[
            "--frames",
            "2..2",
            "--precision",
            "2",
            "-o",
            t.to_str().unwrap(),
        ],
    );
    r.ok();
    let f = std::fs::read_to_string(dir.path().join("f-2.txt")).unwrap();
    assert_eq!(f, "A(0.11)\n");
}

/// A fixed point ends the stepping: the later frames are its generation
/// (a `--frames` range up to 2^53 used to step through every generation,
/// one temporary file each). Every frame is still what `-n k` prints, also
/// for a stochastic system whose string stays the same for some steps
/// while it draws (no fixed point: a later draw changes it).
#[test]
fn frames_after_a_fixed_point_are_not_derived() {
    let dir = common::tempdir();
    let d = dir.path();
    let fixed = common::write(
        d,
        "fixed.ls",
        "productions:\nA -> B\nB -> C\nhomomorphism:\nC -> X\naxiom:\nA\n",
    );
    let drawing = common::write(
        d,
        "drawing.ls",
        "seed: 5\nproductions:\nA -> A : 0.9\nA -> B : 0.1\nB -> C\naxiom:\nAA\n",
    );
    let each = |file: &Path, range: &str, ks: &[u64], extra: &[&str]| {
        let file = file.to_str().unwrap();
        let mut args = vec!["--frames", range];
        args.extend_from_slice(extra);
        let got = ok(&args, file);
        let mut want = String::new();
        for k in ks {
            let n = k.to_string();
            let mut args = vec!["-n", n.as_str()];
            args.extend_from_slice(extra);
            want.push_str(&ok(&args, file));
        }
        assert_eq!(got, want, "{file} --frames {range} {extra:?}");
        got
    };
    let got = each(&fixed, "0..9:3", &[0, 3, 6, 9], &[]);
    assert_eq!(got, "A\nX\nX\nX\n");
    each(
        &fixed,
        "1..8",
        &[1, 2, 3, 4, 5, 6, 7, 8],
        &["--no-homomorphism"],
    );
    each(&fixed, "5..7", &[5, 6, 7], &[]);
    let ks: Vec<u64> = (0..=40).collect();
    let got = each(&drawing, "0..40", &ks, &[]);
    let first_b = got.lines().position(|l| l != "AA").expect("a B by step 40");
    assert!(first_b > 1, "AA for a few steps first: {got}");
    let far = run(lsgen()
        .args(["--frames", "9007199254740990..9007199254740992"])
        .arg(&fixed));
    assert_eq!(far.code(), Some(0), "{}", far.stderr);
    assert_eq!(far.out(), "X\nX\nX\n");
    // A step K that takes the next frame past 2^64 - 1: no frame after
    // the last (the sum wrapped: frames 0 and 1, or files without end).
    let huge = |range: &str| {
        let r = common::run_within(
            lsgen().args(["--frames", range]).arg(&fixed),
            std::time::Duration::from_secs(10),
        );
        assert_eq!(r.code(), Some(0), "--frames {range}: {}", r.stderr);
        r.out()
    };
    assert_eq!(huge("2..2:18446744073709551615"), "X\n");
    assert_eq!(
        huge("9007199254740990..9007199254740992:18446744073709551615"),
        "X\n"
    );
    let dir = d.join("wrap");
    std::fs::create_dir(&dir).unwrap();
    let r = run(lsgen()
        .args(["--frames", "2..2:18446744073709551615", "-o"])
        .arg(dir.join("f{n}"))
        .arg(&fixed));
    assert_eq!(r.code(), Some(0), "{}", r.stderr);
    let names: Vec<_> = std::fs::read_dir(&dir)
        .unwrap()
        .map(|e| e.unwrap().file_name())
        .collect();
    assert_eq!(names, ["f2"]);
}
