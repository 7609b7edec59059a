//! The depth-first expansion of D0L systems (src/dfs.rs) must print exactly
//! what the step-by-step engine prints, and report the same lengths.

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

/// The same system, forced onto the step-by-step engine by a context
/// production for a symbol that never occurs.
fn stepwise(src: &str) -> String {
    src.replacen(
        "productions:\n",
        "productions:\n\u{2603} < \u{2603} -> \u{2603}\n",
        1,
    )
}

fn without_seed_line(s: &str) -> String {
    s.lines()
        .filter(|l| !l.starts_with("lsgen: seed"))
        .collect::<Vec<_>>()
        .join("\n")
}

#[test]
fn depth_first_equals_stepwise_on_the_d0l_examples() {
    for (name, n) in [
        ("koch_snowflake", "6"),
        ("dragon_curve", "12"),
        ("plant_a", "4"),
        ("plant_d", "7"),
        ("plant_f", "5"),
        ("sierpinski_gasket", "7"),
        ("hilbert3d", "3"),
        ("algae", "20"),
    ] {
        let src = std::fs::read_to_string(format!("examples/{name}.ls")).unwrap();
        let (a, ea, ca) = run(&src, &["-n", n, "-v"]);
        let (b, eb, cb) = run(&stepwise(&src), &["-n", n, "-v"]);
        assert_eq!((ca, cb), (0, 0), "{name}: {ea}{eb}");
        assert!(a == b, "{name}: outputs differ");
        assert_eq!(
            without_seed_line(&ea),
            without_seed_line(&eb),
            "{name}: lengths"
        );
    }
}

#[test]
fn homomorphism_deletion_unicode_and_parameters_in_the_axiom() {
    let src =
        "productions:\nF -> F+G\nG -> \nhomomorphism:\n+ -> Ω(1)\nF -> FF\naxiom: F A(2) ΩF[F]\n";
    for n in ["0", "1", "2", "5"] {
        let (a, ea, _) = run(src, &["-n", n]);
        let (b, eb, _) = run(&stepwise(src), &["-n", n]);
        assert_eq!(a, b, "n={n}: {ea}{eb}");
    }
    let (a, _, _) = run(src, &["-n", "1"]);
    assert_eq!(a, "FFΩ(1)GA(2)ΩFFΩ(1)G[FFΩ(1)G]\n");
}

#[test]
fn many_steps_of_a_non_growing_system() {
    let src = "productions:\nA -> B\nB -> CA\nC -> \naxiom: A[B]\n";
    for n in ["1000", "1001", "66000"] {
        let (a, _, _) = run(src, &["-n", n]);
        let (b, _, _) = run(&stepwise(src), &["-n", n]);
        assert_eq!(a, b, "n={n}");
    }
}

#[test]
fn max_length_is_checked_before_writing() {
    let (out, err, code) = run(
        "productions:\nF -> FF\naxiom: F\n",
        &["-n", "40", "--max-length", "1M"],
    );
    assert_eq!(code, 1);
    assert!(out.is_empty());
    assert!(err.contains("--max-length (1000000 modules)"), "{err}");
}

#[test]
fn lengths_and_byte_limits_count_wide_modules_as_the_step_engine_does() {
    // Modules with parameters or non-ASCII symbols pass through unchanged
    // but take several bytes each in the intermediate format.
    let src = "productions:\nF -> GGGGGGGGGG\nG ->\naxiom:\nA(1)A(1)éA(1)A(1)A(1)F\n";
    for args in [
        &["-n", "2", "-v"][..],
        &["-n", "2", "--max-length", "55B"],
        &["-n", "2", "--max-length", "60B"],
        &["-n", "2", "--max-length", "14"],
        &["-n", "1", "--max-length", "20B", "--no-homomorphism"],
    ] {
        let (a, ea, ca) = run(src, args);
        let (b, eb, cb) = run(&stepwise(src), args);
        assert_eq!((a, ca), (b, cb), "{args:?}: {ea}{eb}");
        assert_eq!(without_seed_line(&ea), without_seed_line(&eb), "{args:?}");
    }
}

#[test]
fn parametric_systems_depth_first_equal_stepwise() {
    for (name, n) in [
        ("parametric", "6"),
        ("monopodial_tree", "8"),
        ("sympodial_tree", "8"),
        ("ternary_tree", "5"),
        ("row_of_trees", "6"),
    ] {
        let src = std::fs::read_to_string(format!("examples/{name}.ls")).unwrap();
        let (a, ea, ca) = run(&src, &["-n", n]);
        let (b, eb, cb) = run(&stepwise(&src), &["-n", n]);
        assert_eq!((ca, cb), (0, 0), "{name}: {ea}{eb}");
        assert!(a == b, "{name}: outputs differ");
        // -v takes the step engine too.
        let (c, _, _) = run(&src, &["-n", n, "-v"]);
        assert!(a == c, "{name}: -v output differs");
    }
    // Conditions, a module no production matches, deletion, brackets,
    // a parametric homomorphism.
    let src = "define: R = 1.5\nproductions:\nA(x) : x < 3 -> A(x+1)[B(x*R)]\nA(x) : x >= 3 -> C(x)\nB(y) : y > 2 ->\nhomomorphism:\nC(z) -> F(z/2)\nB(y) -> G(y,y^2)\naxiom: A(0) D(7) A(2.5)\n";
    for n in ["1", "2", "3", "4", "7"] {
        let (a, ea, _) = run(src, &["-n", n]);
        let (b, eb, _) = run(&stepwise(src), &["-n", n]);
        assert_eq!(a, b, "n={n}: {ea}{eb}");
    }
}

#[test]
fn runtime_errors_in_depth_first_parametric_expansion() {
    let src = "productions:\nA(x) -> A(x-1)B(1/x)\naxiom: A(2)\n";
    let (out, err, code) = run(src, &["-n", "4"]);
    assert_eq!(code, 1, "{out}{err}");
    assert!(err.contains("division by zero (in step 3)"), "{err}");
    assert_eq!(err.lines().filter(|l| l.starts_with("lsgen: ")).count(), 1);
}
