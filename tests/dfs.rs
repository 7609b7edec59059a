//! The depth-first expansion of D0L systems (src/dfs.rs) must print exactly
//! what the step-by-step engine prints, and report the same lengths.

mod common;

use common::{lsgen_under_sh, run, run_ls, tempdir, write, Run};

/// Run `src` with `--strategy STRATEGY` and `args`; `dfs` must not be
/// refused (exit 2), or the comparison would not be one.
fn with(strategy: &str, src: &str, args: &[&str]) -> Run {
    let mut all = vec!["--strategy", strategy];
    all.extend_from_slice(args);
    let r = run_ls(src, &all);
    r.assert_no_crash();
    assert_ne!(r.code(), Some(2), "{}: refused:\n{}", r.what, r.stderr);
    r
}

/// Depth first and step by step on the same system and arguments:
/// (stdout, stderr, exit status) of each.
fn both(src: &str, args: &[&str]) -> (Run, Run) {
    (with("dfs", src, args), with("step", src, args))
}

fn without_seed_line(s: &str) -> String {
    s.lines()
        .filter(|l| !l.starts_with("lsgen: seed"))
        .collect::<Vec<_>>()
        .join("\n")
}

/// Same output, same exit status, same standard error (but the seed line).
fn assert_same(a: &Run, b: &Run, what: &str) {
    assert_eq!(
        (a.code(), b.code()),
        (Some(0), Some(0)),
        "{what}: {}{}",
        a.stderr,
        b.stderr
    );
    assert!(a.stdout == b.stdout, "{what}: outputs differ");
    assert_eq!(
        without_seed_line(&a.stderr),
        without_seed_line(&b.stderr),
        "{what}: standard error"
    );
}

/// The flag really selects the engine: under `ulimit -f` (a few KiB) the
/// step engine's temporary generations of `F -> FF` grow past the limit,
/// while depth first only generation 0 goes to a file and the 1 MiB of
/// output streams to a pipe. A system depth first cannot expand is refused
/// with exit status 2.
#[test]
fn strategy_flag_selects_the_engine() {
    let dir = tempdir();
    let p = write(dir.path(), "p.ls", "productions:\nF -> FF\naxiom: F\n");
    let r = run(lsgen_under_sh("ulimit -f 8")
        .args(["--strategy", "dfs", "-n", "20"])
        .arg(&p));
    assert_eq!(r.code(), Some(0), "{}", r.stderr);
    assert_eq!(r.stdout.len(), (1 << 20) + 1);
    let r = run(lsgen_under_sh("ulimit -f 8")
        .args(["--strategy", "step", "-n", "20"])
        .arg(&p));
    assert!(
        r.assert_one_error().contains("File too large"),
        "{}",
        r.stderr
    );
    for (src, args) in [
        ("productions:\nA < B -> A\naxiom: AB\n", &["-n", "1"][..]),
        ("productions:\nF -> FF : 0.5\naxiom: F\n", &["-n", "1"]),
        ("productions:\nF -> FF\naxiom: F\n", &["-n", "65537"]),
        (
            "productions:\nA(x) -> A(x+1)\naxiom: A(0)\n",
            &["-n", "2", "-v"],
        ),
    ] {
        let mut all = vec!["--strategy", "dfs"];
        all.extend_from_slice(args);
        let r = run_ls(src, &all);
        assert!(
            r.fails(2).contains("depth first"),
            "{src:?} {args:?}: {}",
            r.stderr
        );
    }
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
        let src = std::fs::read_to_string(common::example(name)).unwrap();
        let (a, b) = both(&src, &["-n", n, "-v"]);
        assert_same(&a, &b, name);
        let (a, b) = both(&src, &["-n", n]);
        assert_same(&a, &b, name);
    }
}

#[test]
fn homomorphism_deletion_unicode_and_parameters_in_the_axiom() {
    let src =
        "productions:\nF -> F+G\nG -> \nhomomorphism:\n+ -> Ω(1)\nF -> FF\naxiom: F A(2) ΩF[F]\n";
    for n in ["1", "2", "5"] {
        let (a, b) = both(src, &["-n", n]);
        assert_same(&a, &b, &format!("n={n}"));
    }
    // By hand: F -> F+G, then the homomorphism F -> FF, + -> Ω(1).
    let (a, _) = both(src, &["-n", "1"]);
    assert_eq!(a.out(), "FFΩ(1)GA(2)ΩFFΩ(1)G[FFΩ(1)G]\n");
}

#[test]
fn many_steps_of_a_non_growing_system() {
    let src = "productions:\nA -> B\nB -> CA\nC -> \naxiom: A[B]\n";
    // 65536 steps: the most depth first takes.
    for n in ["1000", "1001", "65536"] {
        let (a, b) = both(src, &["-n", n]);
        assert_same(&a, &b, &format!("n={n}"));
    }
    // By hand: A[B] -> B[CA] -> CA[B] -> B[CA] -> ...: odd steps give
    // B[CA], even ones CA[B].
    let (a, _) = both(src, &["-n", "1001"]);
    assert_eq!(a.out(), "B[CA]\n");
    // Past the limit, auto derives step by step.
    let r = run_ls(src, &["-n", "66000"]);
    assert_eq!(r.ok(), "CA[B]\n");
}

#[test]
fn max_length_is_checked_before_writing() {
    let src = "productions:\nF -> FF\naxiom: F\n";
    let r = with("dfs", src, &["-n", "40", "--max-length", "1M"]);
    assert!(
        r.one_error().contains("--max-length (1000000 modules)"),
        "{}",
        r.stderr
    );
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
        let (a, b) = both(src, args);
        assert_eq!(
            (&a.stdout, a.code()),
            (&b.stdout, b.code()),
            "{args:?}: {}{}",
            a.stderr,
            b.stderr
        );
        assert_eq!(
            without_seed_line(&a.stderr),
            without_seed_line(&b.stderr),
            "{args:?}"
        );
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
        let src = std::fs::read_to_string(common::example(name)).unwrap();
        let (a, b) = both(&src, &["-n", n]);
        assert_same(&a, &b, name);
        // -v takes the step engine: the same output.
        let c = run_ls(&src, &["-n", n, "-v"]);
        assert!(a.stdout == c.stdout, "{name}: -v output differs");
    }
    // Conditions, a module no production matches, deletion, brackets,
    // a parametric homomorphism.
    let src = "define: R = 1.5\nproductions:\nA(x) : x < 3 -> A(x+1)[B(x*R)]\nA(x) : x >= 3 -> C(x)\nB(y) : y > 2 ->\nhomomorphism:\nC(z) -> F(z/2)\nB(y) -> G(y,y^2)\naxiom: A(0) D(7) A(2.5)\n";
    for n in ["1", "2", "3", "4", "7"] {
        let (a, b) = both(src, &["-n", n]);
        assert_same(&a, &b, &format!("n={n}"));
    }
}

#[test]
fn runtime_errors_in_depth_first_parametric_expansion() {
    // A(2) -> A(1)B(0.5) -> A(0)B(1)B(0.5) -> step 3 divides by A(0)'s 0.
    let src = "productions:\nA(x) -> A(x-1)B(1/x)\naxiom: A(2)\n";
    let (a, b) = both(src, &["-n", "4"]);
    for r in [&a, &b] {
        assert!(
            r.one_error()
                .contains(":2:17: error: division by zero (in step 3)"),
            "{}",
            r.stderr
        );
    }
    let after_path = |r: &Run| r.stderr.split_once("p.ls:").unwrap().1.to_string();
    assert_eq!(after_path(&a), after_path(&b));
}

/// Depth first keeps a constant run of a successor whole when nothing
/// rewrites its modules (issue 15), and decodes it when a production or
/// only the homomorphism does; the last step's successors go straight out
/// through the homomorphism (computed modules, fixed points). All of it,
/// nested, at every depth, must print what the step engine prints.
#[test]
fn constant_runs_depth_first_equal_stepwise() {
    let src = "define: a = 30\nproductions:\nA(x) : x < 3 -> [+(a)G(2.5)[ω]]A(x+1)[-(a)ω(0.1)]X A(x*2)F(1)B(x/3)K(x)\nA(x) : x >= 3 -> [G]\nF(l) -> F(l*1.5)\nK(x) -> K(x)\nhomomorphism:\nX -> Y(3)Z\nB(y) : y > 0.2 -> Q(y*2)\nK(x) : x > 0 -> [K]\naxiom: A(0) [G(1)] F(2) K(2)\n";
    for n in ["1", "2", "3", "5"] {
        let (a, b) = both(src, &["-n", n]);
        assert_same(&a, &b, &format!("n={n}"));
        let (a, b) = both(src, &["-n", n, "--no-homomorphism"]);
        assert_same(&a, &b, &format!("n={n}, no homomorphism"));
    }
}
