//! The command line people expect (issue 13): shell completions and a man
//! page generated from the clap definition, `--help` with examples, exit
//! codes and a pointer to README; through the binary.

mod common;

use common::{lsgen, run, run_with_stdin, Run};

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
        for opt in [
            "seed",
            "jobs",
            "output",
            "max-length",
            "completions",
            "help",
            "version",
        ] {
            assert!(out.contains(opt), "{shell}: no `{opt}`");
        }
        // Hidden options (for tests) are not offered.
        assert!(!out.contains("strategy"), "{shell} offers --strategy");
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

/// `--tmpdir`'s help names the whole default, as README does: `$TMPDIR`,
/// and `/tmp` when it is unset or empty (std's temp_dir; lsgen runs with
/// an empty TMPDIR).
#[test]
fn help_names_the_tmpdir_default_as_readme_does() {
    let out = lsgen_run(&["--help"]).ok();
    let at = out.find("--tmpdir <DIR>").expect("--tmpdir in --help");
    let entry = &out[at..out[at..].find("\n\n").map_or(out.len(), |e| at + e)];
    assert!(
        entry.contains("$TMPDIR") && entry.contains("/tmp"),
        "{entry}"
    );
    let empty = run_with_stdin(
        lsgen().args(["-n", "1", "-"]).env("TMPDIR", ""),
        "axiom:\nA\n",
    );
    assert_eq!(empty.ok(), "A\n");
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
        "productions:\nA(x) -> A(x/3)B(x*1234567)D(0.123456789,2)\n\
         homomorphism:\nG -> E(3.14159265)\n\
         axiom: A(3.14159265)C(0.000012345,100,-2.5,999.9)G\n",
    );
    let p = p.to_str().unwrap();
    // (Constants of successors too, in the productions and the
    // homomorphism.)
    let want = "A(1.05)B(3.88e6)D(0.123,2)C(1.23e-5,100,-2.5,1e3)E(3.14)\n";
    for strategy in ["auto", "step", "dfs"] {
        for threads in ["1", "2"] {
            let r = lsgen_run(&[
                "-n",
                "1",
                "--precision",
                "3",
                "--strategy",
                strategy,
                "-j",
                threads,
                p,
            ]);
            assert_eq!(r.ok(), want, "--strategy {strategy} -j {threads}");
        }
    }
    // `-v` counts the bytes printed (the newline aside).
    let r = lsgen_run(&["-n", "1", "--precision", "3", "-v", p]);
    assert!(
        r.stderr.contains(&format!(", {} bytes\n", want.len() - 1)),
        "{}",
        r.stderr
    );
    // The default stays the shortest round-trip form.
    let r = lsgen_run(&["-n", "1", p]);
    assert_eq!(
        r.ok(),
        "A(1.0471975500000001)B(3878506.6131325504)D(0.123456789,2)\
         C(0.000012345,100,-2.5,999.9)E(3.14159265)\n"
    );
    // The output reads back as an axiom: the same numbers.
    let r = common::run_with_stdin(lsgen().args(["-n", "0", "--axiom", "-", p]), want);
    assert_eq!(
        r.ok(),
        "A(1.05)B(3880000)D(0.123,2)C(0.0000123,100,-2.5,1000)E(3.14)\n"
    );
    // Out of range is a usage error.
    for bad in ["0", "18", "x"] {
        lsgen_run(&["--precision", bad, p]).fails(2);
    }
}

// ---------------------------------------------------------------- progress

/// Run `lsgen ARGS` on a pseudo-terminal (util-linux `script`); what the
/// terminal showed. None when `script` is missing.
fn on_a_terminal(args: &str) -> Option<String> {
    let r = run(common::command("script").current_dir(common::ROOT).args([
        "-qfc",
        &format!("{} {args}", common::LSGEN),
        "/dev/null",
    ]));
    if r.code() == Some(127) || r.stderr.contains("No such file") {
        return None;
    }
    assert_eq!(r.code(), Some(0), "script: {}", r.stderr);
    Some(String::from_utf8_lossy(&r.stdout).into_owned())
}

#[test]
fn progress_is_shown_on_a_terminal_and_absent_on_a_pipe() {
    let dir = common::tempdir();
    let out = dir.path().join("out.txt");
    let out = out.to_str().unwrap();
    // Step by step: the step and the generation's counts.
    let args = format!("-n 12 --strategy step -o {out} examples/plant_d.ls");
    let Some(screen) = on_a_terminal(&args) else {
        eprintln!("no `script`: skipped");
        return;
    };
    assert!(screen.contains("step "), "{screen:?}");
    assert!(screen.contains("/12: "), "{screen:?}");
    assert!(screen.contains(" modules, "), "{screen:?}");
    assert!(screen.contains("modules/s"), "{screen:?}");
    // Frames: steps up to the last frame (it showed the file's length).
    let frames = format!(
        "--frames 9..11 -o {}/f{{n}} examples/plant_d.ls",
        dir.path().display()
    );
    let screen = on_a_terminal(&frames).unwrap();
    assert!(screen.contains("/11: "), "{screen:?}");
    // Depth first, the final size known: a bar with an ETA.
    let screen = on_a_terminal(&format!("-n 24 -o {out} examples/dragon_curve.ls")).unwrap();
    assert!(screen.contains("steps 1..24 ["), "{screen:?}");
    assert!(screen.contains("ETA"), "{screen:?}");
    // Depth first with parameters: all steps in one pass, size unknown.
    let screen = on_a_terminal(&format!(
        "-n 8 -o {out} benches/workloads/parametric_tree.ls"
    ))
    .unwrap();
    assert!(screen.contains("steps 1..8 (depth first): "), "{screen:?}");
    // The string printed on the terminal itself: no bar drawn into it.
    let screen = on_a_terminal("-n 3 examples/algae.ls").unwrap();
    assert_eq!(screen, "abaab\r\n");
    // --quiet: nothing.
    let screen = on_a_terminal(&format!("-q {args}")).unwrap();
    assert_eq!(screen, "");
    // A batch: jobs done of all.
    let screen = on_a_terminal(&format!(
        "-n 3 --seed 1..4 -o {}/{{seed}} examples/algae.ls",
        dir.path().display()
    ))
    .unwrap();
    assert!(screen.contains("jobs: ["), "{screen:?}");
    assert!(screen.contains("/4"), "{screen:?}");
    // On a pipe: nothing on stderr.
    let r = run(lsgen().current_dir(common::ROOT).args([
        "-n",
        "12",
        "--strategy",
        "step",
        "-o",
        out,
        "examples/plant_d.ls",
    ]));
    assert_eq!(r.ok(), "");
}

#[test]
fn progress_forced_on_a_pipe_and_on_a_closed_stderr() {
    let dir = common::tempdir();
    let out = dir.path().join("out.txt");
    let out = out.to_str().unwrap();
    let r = run(lsgen().current_dir(common::ROOT).args([
        "--progress",
        "-n",
        "13",
        "--strategy",
        "step",
        "-o",
        out,
        "examples/plant_d.ls",
    ]));
    assert_eq!(r.code(), Some(0));
    assert!(r.stderr.contains("step "), "{:?}", r.stderr);
    // Closed standard error: no panic, the string written.
    let r = run(common::lsgen_under_sh("exec 2>&-")
        .current_dir(common::ROOT)
        .args(["--progress", "-n", "3", "examples/algae.ls"]));
    assert_eq!(r.ok(), "abaab\n");
    let r = run(common::lsgen_under_sh("exec 2>/dev/full")
        .current_dir(common::ROOT)
        .args(["--progress", "-n", "3", "examples/algae.ls"]));
    assert_eq!(r.ok(), "abaab\n");
}
