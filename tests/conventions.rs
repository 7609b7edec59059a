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
