//! The command line people expect (issue 13): shell completions and a man
//! page generated from the clap definition, `--help` with examples, exit
//! codes and a pointer to README; through the binary.

mod common;

use common::{lsgen, run, Run};

fn lsgen_run(args: &[&str]) -> Run {
    let r = run(lsgen().args(args));
    r.assert_no_crash();
    r
}

#[test]
fn completions_for_each_shell_name_the_options() {
    for (shell, marker) in [
        ("bash", "complete -F _lsgen"),
        ("zsh", "#compdef lsgen"),
        ("fish", "complete -c lsgen"),
    ] {
        let out = lsgen_run(&["--completions", shell]).ok();
        assert!(out.contains(marker), "{shell}: no `{marker}`:\n{out}");
        for opt in ["seed", "jobs", "output", "max-length", "completions"] {
            assert!(out.contains(opt), "{shell}: no `{opt}`");
        }
    }
}

#[test]
fn bash_completion_is_valid_bash() {
    let out = lsgen_run(&["--completions", "bash"]).ok();
    let dir = common::tempdir();
    let p = common::write(dir.path(), "lsgen.bash", &out);
    let r = run(common::command("bash").arg("-n").arg(&p));
    if r.code() == Some(127) || r.stderr.contains("No such file") {
        return; // no bash here
    }
    assert_eq!(r.code(), Some(0), "bash -n: {}", r.stderr);
}

#[test]
fn unknown_shell_is_a_usage_error() {
    let r = lsgen_run(&["--completions", "tcsh"]);
    assert!(r.fails(2).contains("tcsh"), "{}", r.stderr);
    let r = lsgen_run(&["--man", "x.ls"]);
    r.fails(2);
}

#[test]
fn man_page_is_roff_with_the_options() {
    let out = lsgen_run(&["--man"]).ok();
    assert!(out.contains(".TH lsgen 1"), "{out}");
    for opt in [r"\-\-seed", r"\-\-jobs", r"\-\-output", r"\-\-completions"] {
        assert!(out.contains(opt), "no {opt}");
    }
    assert!(out.contains("LSGEN_JOBS"), "the environment variable");
    assert!(!out.contains("strategy"), "lists --strategy");
}

#[test]
fn completions_and_man_report_write_errors() {
    for args in [&["--man"][..], &["--completions", "fish"]] {
        let r = run(common::lsgen_under_sh("exec >/dev/full").args(args));
        assert_eq!(
            r.stderr, "lsgen: standard output: error: cannot write: No space left on device\n",
            "{args:?}"
        );
        assert_eq!(r.code(), Some(1), "{args:?}");
    }
}

#[test]
fn help_has_examples_exit_codes_and_readme() {
    for flag in ["--help", "-h"] {
        let out = lsgen_run(&[flag]).ok();
        assert!(
            out.contains("Examples:\n  lsgen -n 5 examples/algae.ls"),
            "{out}"
        );
        assert!(out.contains("--seed 1..100 -o 'forest/{stem}-{seed}.txt'"));
        assert!(out.contains("Exit status: 0 success; 1 "), "{out}");
        assert!(out.contains("2 a usage error"), "{out}");
        assert!(out.contains("README.md"), "{out}");
    }
}

#[test]
fn help_examples_run() {
    // The first example of --help does what it says (algae, by hand:
    // a -> ab, b -> a; a, ab, aba, abaab, abaababa, abaababaabaab).
    let r = run(lsgen()
        .current_dir(common::ROOT)
        .args(["-n", "5", "examples/algae.ls"]));
    assert_eq!(r.ok(), "abaababaabaab\n");
}

/// `--precision 3` gives what C's `printf("%.3g")` gives (checked with
/// Python's `%` operator: 1.05 3.88e+06 1.23e-05 100 -2.5 1e+03), the
/// exponent written as lsgen writes it; for every strategy.
#[test]
fn precision_prints_significant_digits_and_reads_back() {
    let dir = common::tempdir();
    let p = common::write(
        dir.path(),
        "p.ls",
        "productions:\nA(x) -> A(x/3)B(x*1234567)\n\
         axiom: A(3.14159265)C(0.000012345,100,-2.5,999.9)\n",
    );
    let p = p.to_str().unwrap();
    let want = "A(1.05)B(3.88e6)C(1.23e-5,100,-2.5,1e3)\n";
    for strategy in ["auto", "step", "dfs"] {
        let r = lsgen_run(&["-n", "1", "--precision", "3", "--strategy", strategy, p]);
        assert_eq!(r.ok(), want, "--strategy {strategy}");
    }
    // The default stays the shortest round-trip form.
    let r = lsgen_run(&["-n", "1", p]);
    assert_eq!(
        r.ok(),
        "A(1.0471975500000001)B(3878506.6131325504)C(0.000012345,100,-2.5,999.9)\n"
    );
    // The output reads back as an axiom: the same numbers.
    let r = common::run_with_stdin(lsgen().args(["-n", "0", "--axiom", "-", p]), want);
    assert_eq!(r.ok(), "A(1.05)B(3880000)C(0.0000123,100,-2.5,1000)\n");
    // Out of range is a usage error.
    for bad in ["0", "18", "x"] {
        lsgen_run(&["--precision", bad, p]).fails(2);
    }
}
