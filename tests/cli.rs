//! The command line of the real `lsgen` binary: every flag, standard input
//! and output, exit statuses, the error format, broken pipes.

mod common;

use common::{dir_with, example, lsgen, lsgen_in_root, Run, ROOT};
use std::io::Read;
use std::path::Path;
use std::process::Stdio;

/// Run lsgen in `dir` with `args`, feeding `stdin` (none: /dev/null);
/// never a crash.
fn run_in(dir: &Path, args: &[&str], stdin: Option<&[u8]>) -> Run {
    let mut cmd = lsgen();
    cmd.args(args).current_dir(dir);
    let r = match stdin {
        Some(data) => common::run_with_stdin(&mut cmd, data),
        None => common::run(&mut cmd),
    };
    r.assert_no_crash();
    r
}

/// Run lsgen from the repository root (so `examples/...` paths work).
fn run(args: &[&str]) -> Run {
    run_in(Path::new(ROOT), args, None)
}

fn run_stdin(args: &[&str], stdin: &[u8]) -> Run {
    run_in(Path::new(ROOT), args, Some(stdin))
}

fn read_example(name: &str) -> Vec<u8> {
    std::fs::read(example(name)).unwrap()
}

fn expected(name: &str, n: u64) -> String {
    let p = Path::new(ROOT)
        .join("tests/expected")
        .join(format!("{name}.n{n}.txt"));
    std::fs::read_to_string(&p).unwrap_or_else(|e| panic!("cannot read {}: {e}", p.display()))
}

/// Sorted names of the entries of `dir` (hidden ones included).
fn listing(dir: &Path) -> Vec<String> {
    common::listing(dir).into_iter().collect()
}

/// A parametric system that divides by zero in step 2 (line 3, column 20).
const DIV_AT_STEP_2: &str = "productions:\n\
                             A(x) : x > 0 -> A(x-1)\n\
                             A(x) : x <= 0 -> B(1/x)\n\
                             axiom:\n\
                             A(1)\n";

const DOUBLING: &str = "productions:\nF -> FF\naxiom: F\n";

// ---------------------------------------------------------------- stdin

#[test]
fn reads_the_system_from_stdin_without_file_argument() {
    let out = run_stdin(&["-n", "5"], &read_example("algae")).ok();
    assert_eq!(out, expected("algae", 5));
}

#[test]
fn reads_the_system_from_stdin_with_dash() {
    let out = run_stdin(&["-n", "5", "-"], &read_example("algae")).ok();
    assert_eq!(out, expected("algae", 5));
    let out = run_stdin(&["-"], &read_example("parametric")).ok();
    assert_eq!(out, "F(1.456)B(1)A(8,7)\n");
}

#[test]
fn errors_in_stdin_are_reported_as_stdin() {
    let r = run_stdin(&[], b"productions:\nA(x) -> B(y)\naxiom:\nA(1)\n");
    assert_eq!(
        r.fails(1),
        "lsgen: <stdin>:2:11: error: unknown identifier `y`\nA(x) -> B(y)\n          ^\n"
    );
}

#[test]
fn empty_stdin_is_an_error() {
    let r = run_stdin(&[], b"");
    let e = r.one_error();
    assert!(e.contains("<stdin>") && e.contains("axiom"), "{e}");
}

// ---------------------------------------------------------------- -o

#[test]
fn output_file_holds_exactly_the_output_and_stdout_is_empty() {
    let d = tempfile::tempdir().unwrap();
    let out = d.path().join("out.txt");
    let out_s = out.display().to_string();
    for flag in ["-o", "--output"] {
        let r = run(&[flag, &out_s, "examples/plant_a.ls"]);
        assert_eq!(r.ok(), "", "-o must not write to stdout");
        assert_eq!(
            std::fs::read_to_string(&out).unwrap(),
            expected("plant_a", 5)
        );
        assert_eq!(
            listing(d.path()),
            ["out.txt"],
            "stray files beside the output"
        );
    }
}

#[test]
fn output_file_relative_to_the_working_directory() {
    let d = dir_with(&[("p.ls", DOUBLING)]);
    let r = run_in(d.path(), &["-n", "3", "-o", "result", "p.ls"], None);
    assert_eq!(r.ok(), "");
    assert_eq!(
        std::fs::read_to_string(d.path().join("result")).unwrap(),
        "FFFFFFFF\n"
    );
    assert_eq!(listing(d.path()), ["p.ls", "result"]);
}

#[test]
fn output_file_replaces_an_existing_file_on_success() {
    let d = dir_with(&[
        ("p.ls", DOUBLING),
        ("out.txt", "old contents, longer than the new\n"),
    ]);
    let r = run_in(d.path(), &["-n", "2", "-o", "out.txt", "p.ls"], None);
    assert_eq!(r.ok(), "");
    assert_eq!(
        std::fs::read_to_string(d.path().join("out.txt")).unwrap(),
        "FFFF\n"
    );
    assert_eq!(listing(d.path()), ["out.txt", "p.ls"]);
}

#[test]
fn output_file_is_untouched_when_the_run_fails() {
    let old = "precious old contents\n";
    let d = dir_with(&[("p.ls", DIV_AT_STEP_2), ("out.txt", old)]);
    // Step 1 succeeds (and the failure only happens while writing step 2).
    let r = run_in(d.path(), &["-n", "1"], Some(DIV_AT_STEP_2.as_bytes()));
    assert_eq!(r.ok(), "A(0)\n");
    let r = run_in(d.path(), &["-n", "2", "-o", "out.txt", "p.ls"], None);
    assert_eq!(
        r.fails(1),
        "lsgen: p.ls:3:20: error: division by zero (in step 2)\n\
         A(x) : x <= 0 -> B(1/x)\n                   ^\n"
    );
    assert_eq!(
        std::fs::read_to_string(d.path().join("out.txt")).unwrap(),
        old
    );
    assert_eq!(
        listing(d.path()),
        ["out.txt", "p.ls"],
        "stray files left behind"
    );
}

#[test]
fn output_file_is_not_created_when_the_run_fails() {
    let d = dir_with(&[("p.ls", DIV_AT_STEP_2)]);
    let r = run_in(d.path(), &["-n", "2", "-o", "new.txt", "p.ls"], None);
    r.one_error();
    assert_eq!(listing(d.path()), ["p.ls"], "stray files left behind");
    // A parse error, too.
    let d = dir_with(&[("p.ls", "productions:\nF -> G(x)\naxiom: F\n")]);
    let r = run_in(d.path(), &["-o", "new.txt", "p.ls"], None);
    r.one_error();
    assert_eq!(listing(d.path()), ["p.ls"], "stray files left behind");
}

#[test]
fn output_file_is_untouched_when_max_length_stops_the_run() {
    let d = dir_with(&[("p.ls", DOUBLING), ("out.txt", "old\n")]);
    let r = run_in(
        d.path(),
        &["-n", "10", "--max-length", "100", "-o", "out.txt", "p.ls"],
        None,
    );
    assert!(r.one_error().contains("--max-length"));
    assert_eq!(
        std::fs::read_to_string(d.path().join("out.txt")).unwrap(),
        "old\n"
    );
    assert_eq!(listing(d.path()), ["out.txt", "p.ls"]);
}

#[test]
fn output_into_a_missing_directory_fails() {
    let d = tempfile::tempdir().unwrap();
    let target = d.path().join("no/such/dir/out.txt");
    let t = target.display().to_string();
    let r = run(&["-o", &t, "examples/algae.ls"]);
    let e = r.one_error();
    assert!(e.starts_with(&format!("lsgen: {t}: error: ")), "{e}");
    assert_eq!(e.lines().count(), 1, "{e}");
    assert!(listing(d.path()).is_empty());
}

#[test]
fn output_to_a_device_is_written_in_place() {
    if !Path::new("/dev/null").exists() {
        return;
    }
    let r = run(&["-o", "/dev/null", "examples/plant_a.ls"]);
    assert_eq!(r.ok(), "");
}

/// `-o -` is standard output (lsgen before this wrote a file named `-`).
#[test]
fn output_dash_is_standard_output() {
    let d = tempfile::tempdir().unwrap();
    let algae = example("algae");
    let r = run_in(d.path(), &["-n", "5", "-o", "-", &algae], None);
    assert_eq!(r.ok(), expected("algae", 5));
    assert!(listing(d.path()).is_empty(), "{:?}", listing(d.path()));
    // `./-` is still a file of that name.
    let r = run_in(d.path(), &["-n", "5", "-o", "./-", &algae], None);
    assert_eq!(r.ok(), "");
    assert_eq!(
        std::fs::read_to_string(d.path().join("-")).unwrap(),
        expected("algae", 5)
    );
}

/// Run lsgen with its standard output on /dev/full (every write fails).
fn run_to_dev_full(args: &[&str]) -> Option<(i32, String)> {
    let full = std::fs::OpenOptions::new()
        .write(true)
        .open("/dev/full")
        .ok()?;
    let r = common::finish(
        common::spawn_with(
            lsgen_in_root().args(args),
            Stdio::null(),
            Stdio::from(full),
            Stdio::piped(),
        ),
        common::TIME_LIMIT,
    );
    r.assert_no_crash();
    Some((r.code().unwrap(), r.stderr))
}

#[test]
fn write_errors_on_stdout_are_reported() {
    for n in ["0", "3", "25"] {
        let Some((code, e)) = run_to_dev_full(&["-n", n, "examples/algae.ls"]) else {
            return; // no /dev/full here
        };
        assert_eq!(code, 1, "-n {n}: {e}");
        assert!(
            e.starts_with("lsgen: standard output: error: cannot write"),
            "-n {n}: {e}"
        );
        assert_eq!(e.lines().count(), 1, "{e}");
    }
}

#[test]
fn write_errors_on_an_output_device_name_it() {
    if !Path::new("/dev/full").exists() {
        return;
    }
    let r = run(&["-o", "/dev/full", "examples/algae.ls"]);
    let e = r.one_error();
    assert!(
        e.starts_with("lsgen: /dev/full: error: cannot write"),
        "{e}"
    );
}

// ---------------------------------------------------------------- -n

#[test]
fn n_overrides_the_derivation_length_of_the_file() {
    // parametric.ls says `derivation length: 4`.
    assert_eq!(
        run(&["examples/parametric.ls"]).ok(),
        expected("parametric", 4)
    );
    for n in [0u64, 2, 6] {
        let ns = n.to_string();
        assert_eq!(
            run(&["-n", &ns, "examples/parametric.ls"]).ok(),
            expected("parametric", n)
        );
        assert_eq!(
            run(&["--derivation-length", &ns, "examples/parametric.ls"]).ok(),
            expected("parametric", n)
        );
    }
}

#[test]
fn n_zero_prints_the_axiom() {
    assert_eq!(
        run(&["-n", "0", "examples/koch_snowflake.ls"]).ok(),
        "F--F--F\n"
    );
    // The homomorphism still applies after zero steps.
    assert_eq!(
        run(&["-n", "0", "examples/sierpinski_gasket.ls"]).ok(),
        "F\n"
    );
    assert_eq!(
        run(&[
            "-n",
            "0",
            "--no-homomorphism",
            "examples/sierpinski_gasket.ls"
        ])
        .ok(),
        "R\n"
    );
}

#[test]
fn huge_n_does_not_crash() {
    // Accepting the number and running (for ever) or rejecting it with a
    // clean error are both fine; a crash is not.
    let d = dir_with(&[("p.ls", "homomorphism:\nF -> G\naxiom: F\n")]);
    let mut child = common::spawn(
        lsgen()
            .args(["-n", "18446744073709551615", "p.ls"])
            .current_dir(d.path()),
    );
    let deadline = std::time::Instant::now() + std::time::Duration::from_secs(3);
    loop {
        if child.try_wait().unwrap().is_some() {
            break;
        }
        if std::time::Instant::now() > deadline {
            // Still deriving: not a crash.
            child.kill().unwrap();
            child.wait().unwrap();
            return;
        }
        std::thread::sleep(std::time::Duration::from_millis(20));
    }
    let r = common::finish(child, common::TIME_LIMIT);
    r.assert_no_crash();
    let (code, stderr) = (r.code().unwrap(), &r.stderr);
    assert!(code == 1 || code == 2, "exit {code}: {stderr}");
    assert!(stderr.starts_with("lsgen: "), "{stderr}");
}

// ---------------------------------------------------------------- --seed

#[test]
fn seed_flag_overrides_the_seed_setting() {
    // stochastic_plant.ls says `seed: 42`.
    let file_seed = run(&["examples/stochastic_plant.ls"]).ok();
    assert_eq!(
        run(&["--seed", "42", "examples/stochastic_plant.ls"]).ok(),
        file_seed
    );
    let s7 = run(&["--seed", "7", "examples/stochastic_plant.ls"]).ok();
    assert_ne!(
        s7, file_seed,
        "--seed 7 gave the output of the file's seed 42"
    );
}

#[test]
fn same_seed_same_output() {
    for seed in ["0", "1", "18446744073709551615"] {
        let a = run(&["--seed", seed, "examples/stochastic_plant.ls"]).ok();
        let b = run(&["--seed", seed, "examples/stochastic_plant.ls"]).ok();
        assert_eq!(a, b, "two runs with --seed {seed} differ");
        assert!(a.starts_with('F') && a.ends_with('\n'));
    }
}

#[test]
fn different_seeds_different_outputs() {
    let outs: Vec<String> = (1..=5)
        .map(|s| run(&["--seed", &s.to_string(), "examples/stochastic_plant.ls"]).ok())
        .collect();
    for i in 0..outs.len() {
        for j in i + 1..outs.len() {
            assert_ne!(
                outs[i],
                outs[j],
                "--seed {} and --seed {} agree",
                i + 1,
                j + 1
            );
        }
    }
}

#[test]
fn seed_reported_by_verbose_reproduces_an_unseeded_run() {
    let src = "productions:\nF -> F[+F]F : 1\nF -> F[-F]F : 1\nF -> FF : 1\naxiom: F\n";
    let d = dir_with(&[("s.ls", src)]);
    let r = run_in(d.path(), &["-v", "-n", "4", "s.ls"], None);
    assert_eq!(r.code(), Some(0), "{}", r.stderr);
    let seed = r
        .stderr
        .lines()
        .find_map(|l| l.strip_prefix("lsgen: seed "))
        .unwrap_or_else(|| panic!("no seed reported:\n{}", r.stderr))
        .trim()
        .to_string();
    let again = run_in(d.path(), &["--seed", &seed, "-n", "4", "s.ls"], None).ok();
    assert_eq!(again, r.out());
}

// ---------------------------------------------------------------- --no-homomorphism

#[test]
fn no_homomorphism_keeps_the_symbols() {
    assert_eq!(
        run(&["-n", "1", "examples/sierpinski_gasket.ls"]).ok(),
        "F-F-F\n"
    );
    assert_eq!(
        run(&[
            "-n",
            "1",
            "--no-homomorphism",
            "examples/sierpinski_gasket.ls"
        ])
        .ok(),
        "L-R-L\n"
    );
    assert_eq!(
        run(&["--no-homomorphism", "examples/parametric.ls"]).ok(),
        "CB(1)A(8,7)\n"
    );
    // Without a homomorphism section the flag changes nothing.
    assert_eq!(
        run(&["--no-homomorphism", "examples/plant_a.ls"]).ok(),
        expected("plant_a", 5)
    );
}

// ---------------------------------------------------------------- --check

#[test]
fn check_is_silent_on_every_example() {
    let mut names: Vec<_> = std::fs::read_dir(Path::new(ROOT).join("examples"))
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|e| e == "ls"))
        .collect();
    names.sort();
    assert!(!names.is_empty());
    for p in names {
        let r = run(&["--check", &p.display().to_string()]);
        assert_eq!(r.ok(), "", "--check printed something for {}", p.display());
    }
}

#[test]
fn check_derives_nothing() {
    // Dividing by zero in step 2 is a runtime error, not a check error.
    let d = dir_with(&[("p.ls", DIV_AT_STEP_2)]);
    assert_eq!(run_in(d.path(), &["--check", "p.ls"], None).ok(), "");
    // Nor does it need a temp dir or write an output file.
    let r = run_in(
        d.path(),
        &[
            "--check",
            "-o",
            "out.txt",
            "--tmpdir",
            "/no/such/dir",
            "p.ls",
        ],
        None,
    );
    assert_eq!(r.ok(), "");
    assert_eq!(listing(d.path()), ["p.ls"]);
}

#[test]
fn check_reports_errors_in_the_productions() {
    let d = dir_with(&[("p.ls", "productions:\nA(x) -> B(y)\naxiom:\nA(1)\n")]);
    let r = run_in(d.path(), &["--check", "p.ls"], None);
    assert_eq!(
        r.fails(1),
        "lsgen: p.ls:2:11: error: unknown identifier `y`\nA(x) -> B(y)\n          ^\n"
    );
}

#[test]
fn check_reports_errors_in_the_axiom() {
    let d = dir_with(&[("p.ls", "productions:\nF -> FF\naxiom:\nF+F)F\n")]);
    let r = run_in(d.path(), &["--check", "p.ls"], None);
    assert_eq!(
        r.fails(1),
        "lsgen: p.ls:4:4: error: `)` is reserved and cannot be a symbol\nF+F)F\n   ^\n"
    );
    // Errors far into the axiom, too.
    let d = dir_with(&[("p.ls", "productions:\nF -> FF\naxiom: F\nF\nF[F\n")]);
    let r = run_in(d.path(), &["--check", "p.ls"], None);
    let e = r.one_error();
    assert!(e.contains("unbalanced brackets"), "{e}");
}

#[test]
fn check_reads_the_axiom_file() {
    let d = dir_with(&[
        ("p.ls", DOUBLING),
        ("good.txt", "F+F\n"),
        ("bad.txt", "F)\n"),
    ]);
    let r = run_in(d.path(), &["--check", "--axiom", "good.txt", "p.ls"], None);
    assert_eq!(r.ok(), "");
    let r = run_in(d.path(), &["--check", "--axiom", "bad.txt", "p.ls"], None);
    assert_eq!(
        r.fails(1),
        "lsgen: bad.txt:1:2: error: `)` is reserved and cannot be a symbol\nF)\n ^\n"
    );
    let r = run_in(d.path(), &["--check", "--axiom", "-", "p.ls"], Some(b"F(1"));
    let e = r.one_error();
    assert!(e.starts_with("lsgen: <stdin>:1:2: error: "), "{e}");
}

// ---------------------------------------------------------------- --axiom

#[test]
fn axiom_file_replaces_the_axiom() {
    let d = dir_with(&[("a.txt", "B(2)A(4,4)\n"), ("b.txt", "A(1,4)\n")]);
    let p = example("parametric");
    let r = run_in(d.path(), &["--axiom", "a.txt", &p], None);
    assert_eq!(r.ok(), "F(1.456)B(1)A(8,7)\n");
    // A(1,4) -> B(1)A(0.25,0) -> B(0)A(0.5,0.25) -> CA(1,0.75) -> CA(2,1.75)
    let r = run_in(d.path(), &["--axiom", "b.txt", &p], None);
    assert_eq!(r.ok(), "F(1.456)A(2,1.75)\n");
}

#[test]
fn axiom_from_stdin() {
    let r = run_stdin(&["--axiom", "-", "-n", "2", "examples/plant_a.ls"], b"F+F");
    assert_eq!(
        r.ok(),
        "F[+F]F[-F]F[+F[+F]F[-F]F]F[+F]F[-F]F[-F[+F]F[-F]F]F[+F]F[-F]F+\
         F[+F]F[-F]F[+F[+F]F[-F]F]F[+F]F[-F]F[-F[+F]F[-F]F]F[+F]F[-F]F\n"
    );
    // An empty axiom is an empty string.
    let r = run_stdin(&["--axiom", "-", "examples/plant_a.ls"], b"");
    assert_eq!(r.ok(), "\n");
}

#[test]
fn axiom_flag_allows_a_file_without_axiom() {
    let d = dir_with(&[("p.ls", "productions:\nF -> FF\n")]);
    let r = run_in(
        d.path(),
        &["--axiom", "-", "-n", "2", "p.ls"],
        Some(b"F+F\n"),
    );
    assert_eq!(r.ok(), "FFFF+FFFF\n");
    let r = run_in(d.path(), &["--check", "--axiom", "-", "p.ls"], Some(b"F\n"));
    assert_eq!(r.ok(), "");
    // Without --axiom the axiom is missing.
    let r = run_in(d.path(), &["p.ls"], None);
    assert_eq!(
        r.fails(1),
        "lsgen: p.ls:2:8: error: missing `axiom:`: the axiom comes last, after the productions\n\
         F -> FF\n       ^\n"
    );
}

/// Also by the stream's names: `--axiom /dev/stdin` with the L-system on
/// standard input printed an empty string, exit 0 (the L-system's reader
/// had taken the bytes; found by the hostile review of frames).
#[test]
fn axiom_and_system_cannot_both_be_stdin() {
    for args in [
        &["--axiom", "-"][..],
        &["--axiom", "-", "-"],
        &["--axiom", "/dev/stdin"],
        &["--axiom", "/dev/fd/0", "/dev/stdin"],
        &["--axiom", "-", "/dev/stdin"],
        &["--axiom", "/dev/stdin", "--frames", "0..2"],
    ] {
        let r = run_stdin(args, &read_example("algae"));
        let e = r.fails(2);
        assert_eq!(
            e, "lsgen: error: the L-system and `--axiom` cannot both come from standard input\n",
            "{args:?}"
        );
    }
}

/// A `.l` file's `#include "/dev/stdin"` where lsgen reads standard input
/// itself took what `--axiom -` needed (the axiom was silently empty,
/// exit 0), or read nothing after an L-system from standard input (found
/// by the review helper). A located error at the `#include`; with the
/// axiom from a file, the include reads standard input as before.
#[test]
fn an_include_of_standard_input_that_lsgen_reads_is_an_error() {
    let sys = "Lsystem: 1\n#include \"/dev/stdin\"\nAxiom: F(X)\nendlsystem\n";
    let d = dir_with(&[("inc.l", sys), ("ax", "G(2)")]);
    let message = "error: cannot include `/dev/stdin`: it is standard input, which this run reads itself (the L-system, `--axiom` or the module string)";
    let r = run_in(
        d.path(),
        &["-n", "0", "--axiom", "-", "inc.l"],
        Some(b"#define X 7\n"),
    );
    let e = r.one_error();
    assert!(
        e.starts_with(&format!("lsgen: inc.l:2:10: {message}")),
        "{e}"
    );
    let r = run_in(d.path(), &["-n", "0"], Some(sys.as_bytes()));
    let e = r.one_error();
    assert!(
        e.starts_with(&format!("lsgen: <stdin>:2:10: {message}")),
        "{e}"
    );
    let r = run_in(d.path(), &["-n", "0", "inc.l"], Some(b"#define X 7\n"));
    assert_eq!(r.ok(), "F(7)\n");
    let r = run_in(
        d.path(),
        &["-n", "0", "--axiom", "ax", "inc.l"],
        Some(b"#define X 7\n"),
    );
    assert_eq!(r.ok(), "G(2)\n");
}

#[test]
fn missing_axiom_file_fails() {
    let d = dir_with(&[("p.ls", DOUBLING)]);
    let r = run_in(d.path(), &["--axiom", "nope.txt", "p.ls"], None);
    let e = r.one_error();
    assert!(e.starts_with("lsgen: nope.txt: error: "), "{e}");
}

/// `lsgen -n A --no-homomorphism p.ls | lsgen -n B --axiom - p.ls`
fn chained(file: &str, a: u64, b: u64) -> String {
    let first = run(&["-n", &a.to_string(), "--no-homomorphism", file]).ok();
    run_stdin(
        &["-n", &b.to_string(), "--axiom", "-", file],
        first.as_bytes(),
    )
    .ok()
}

#[test]
fn chaining_through_axiom_equals_one_long_run() {
    for name in [
        "parametric",
        "plant_a",
        "dragon_curve",
        "context_plant_a",
        "context_plant_d",
        "signal",
        "parametric_context",
        "sierpinski_gasket",
        "row_of_trees",
        "monopodial_tree",
    ] {
        let file = example(name);
        let whole = run(&["-n", "5", &file]).ok();
        assert_eq!(
            chained(&file, 3, 2),
            whole,
            "{name}: 3 + 2 steps != 5 steps"
        );
    }
    // The expected files agree, and bigger splits work.
    let file = example("context_plant_b");
    assert_eq!(chained(&file, 17, 13), expected("context_plant_b", 30));
    let file = example("dragon_curve");
    assert_eq!(chained(&file, 9, 1), expected("dragon_curve", 10));
}

// ---------------------------------------------------------------- --max-length

#[test]
fn max_length_in_modules() {
    // algae after 10 steps: 144 modules.
    assert_eq!(
        run(&["-n", "10", "--max-length", "144", "examples/algae.ls"]).ok(),
        expected("algae", 10)
    );
    let r = run(&["-n", "10", "--max-length", "143", "examples/algae.ls"]);
    let e = r.one_error();
    assert!(e.contains("--max-length"), "{e}");
    let r = run(&["-n", "10", "--max-length", "100", "examples/algae.ls"]);
    assert!(r.one_error().contains("--max-length"));
    // Suffixes for modules.
    for ok in ["1k", "1K", "5M", "2G", "1_000"] {
        assert_eq!(
            run(&["-n", "10", "--max-length", ok, "examples/algae.ls"]).ok(),
            expected("algae", 10),
            "--max-length {ok}"
        );
    }
}

#[test]
fn max_length_in_bytes() {
    for ok in ["1kB", "1KB", "1KiB", "2MB", "1GiB", "1000B"] {
        assert_eq!(
            run(&["-n", "10", "--max-length", ok, "examples/algae.ls"]).ok(),
            expected("algae", 10),
            "--max-length {ok}"
        );
    }
    for bad in ["100B", "50B"] {
        let r = run(&["-n", "10", "--max-length", bad, "examples/algae.ls"]);
        let e = r.one_error();
        assert!(e.contains("--max-length"), "--max-length {bad}: {e}");
    }
}

#[test]
fn max_length_stops_a_runaway_system_early() {
    // Without the limit this would be 2^60 modules.
    let d = dir_with(&[("p.ls", DOUBLING)]);
    let started = std::time::Instant::now();
    let r = run_in(d.path(), &["-n", "60", "--max-length", "1M", "p.ls"], None);
    assert!(r.one_error().contains("--max-length"));
    assert!(started.elapsed().as_secs() < 60);
}

#[test]
fn max_length_rejects_bad_values() {
    for bad in ["12parsecs", "", "abc", "-5", "5X"] {
        let r = run(&["--max-length", bad, "examples/algae.ls"]);
        r.fails(2);
    }
    // The message lists every unit it takes, `K` and `KB` too.
    let r = run(&["--max-length", "5X", "examples/algae.ls"]);
    assert!(
        r.fails(2).contains(
            "unknown unit `X`: modules take k (or K), M, G; bytes take B, kB (or KB), \
             MB, GB, TB, KiB, MiB, GiB, TiB"
        ),
        "{}",
        r.stderr
    );
}

// ---------------------------------------------------------------- --tmpdir

#[test]
fn tmpdir_is_used_and_left_clean() {
    let t = tempfile::tempdir().unwrap();
    let ts = t.path().display().to_string();
    assert_eq!(
        run(&["--tmpdir", &ts, "examples/plant_d.ls"]).ok(),
        expected("plant_d", 7)
    );
    assert!(listing(t.path()).is_empty(), "temp files left in --tmpdir");
}

#[test]
fn missing_tmpdir_is_a_clear_error() {
    let t = tempfile::tempdir().unwrap();
    let missing = t.path().join("does-not-exist");
    let ms = missing.display().to_string();
    let r = run(&["--tmpdir", &ms, "-n", "3", "examples/algae.ls"]);
    let e = r.one_error();
    assert!(e.starts_with(&format!("lsgen: {ms}: error: ")), "{e}");
    assert_eq!(e.lines().count(), 1, "{e}");
}

// ---------------------------------------------------------------- -v

#[test]
fn verbose_reports_seed_and_lengths_on_stderr() {
    let quiet = run(&["-n", "4", "--seed", "5", "examples/algae.ls"]).ok();
    for flag in ["-v", "--verbose"] {
        let r = run(&[flag, "-n", "4", "--seed", "5", "examples/algae.ls"]);
        assert_eq!(r.code(), Some(0), "{}", r.stderr);
        assert_eq!(r.out(), quiet, "{flag} changed stdout");
        let lines: Vec<&str> = r.stderr.lines().collect();
        assert!(lines.iter().all(|l| l.starts_with("lsgen: ")), "{lines:?}");
        assert!(
            lines.iter().any(|l| l.contains("seed 5")),
            "no seed: {lines:?}"
        );
        // a, ab, aba, abaab, abaababa
        for (step, modules) in [(1, 2), (2, 3), (3, 5), (4, 8)] {
            let want = format!("step {step}: {modules} modules");
            assert!(
                lines.iter().any(|l| l.contains(&want)),
                "no `{want}` in {lines:?}"
            );
        }
    }
}

#[test]
fn verbose_reports_the_file_seed() {
    let r = run(&["-v", "examples/stochastic_plant.ls"]);
    assert_eq!(r.code(), Some(0));
    assert_eq!(r.out(), run(&["examples/stochastic_plant.ls"]).ok());
    assert!(
        r.stderr.lines().any(|l| l == "lsgen: seed 42"),
        "{}",
        r.stderr
    );
}

#[test]
fn verbose_with_output_file_keeps_stdout_empty() {
    let d = dir_with(&[("p.ls", DOUBLING)]);
    let r = run_in(d.path(), &["-v", "-n", "3", "-o", "o.txt", "p.ls"], None);
    assert_eq!(r.code(), Some(0), "{}", r.stderr);
    assert!(r.stdout.is_empty());
    assert!(r.stderr.contains("step 3: 8 modules"), "{}", r.stderr);
    assert_eq!(
        std::fs::read_to_string(d.path().join("o.txt")).unwrap(),
        "FFFFFFFF\n"
    );
}

// ---------------------------------------------------------------- help, version, usage errors

#[test]
fn help_and_version_exit_zero() {
    for flag in ["--help", "-h"] {
        let r = run(&[flag]);
        let out = r.ok();
        assert!(out.contains("Usage:"), "{out}");
        for opt in [
            "--output",
            "--derivation-length",
            "--seed",
            "--no-homomorphism",
            "--check",
            "--axiom",
            "--max-length",
            "--tmpdir",
            "--verbose",
        ] {
            assert!(out.contains(opt), "{flag} does not mention {opt}");
        }
        // No line broken where clap's help would turn a `{n}` into one
        // (`{seed}, ` then `; {{ and }}` on the next line).
        assert!(
            !out.lines().any(|l| l.trim_end().ends_with(", ")
                || l.trim() == "`"
                || l.trim_start().starts_with("; ")
                || l.trim_start().starts_with("` ")),
            "{out}"
        );
        assert!(out.contains("{seed}, and n in braces"), "{out}");
    }
    for flag in ["--version", "-V"] {
        let out = run(&[flag]).ok();
        assert_eq!(out, format!("lsgen {}\n", env!("CARGO_PKG_VERSION")));
    }
}

/// `--version`/`--help` whose text cannot be written fail with a message
/// (lsgen before this exited 0); a closed pipe is still a quiet success.
#[test]
fn help_and_version_report_write_errors() {
    for flag in ["--version", "--help"] {
        let Some((code, e)) = run_to_dev_full(&[flag]) else {
            return; // no /dev/full here
        };
        assert_eq!(code, 1, "{flag} > /dev/full: {e}");
        assert_eq!(
            e, "lsgen: standard output: error: cannot write: No space left on device\n",
            "{flag}"
        );
        // A pipe nobody reads any more.
        let mut child = common::spawn(lsgen().arg(flag));
        drop(child.stdout.take());
        let r = common::finish(child, common::TIME_LIMIT);
        assert_eq!(r.code(), Some(0), "{flag} | closed: {}", r.stderr);
        assert_eq!(r.stderr, "", "{flag} | closed");
    }
}

#[test]
fn usage_errors_exit_2() {
    let algae = "examples/algae.ls";
    let cases: &[&[&str]] = &[
        &["--bogus", algae],
        &["-x", algae],
        &["-n", "abc", algae],
        &["-n", "-1", algae],
        &["-n", "1.5", algae],
        &["-n", "18446744073709551616", algae],
        &["-n"],
        &["--seed", "x", algae],
        &["--seed", "-3", algae],
        &["--max-length", "lots", algae],
        &[algae, algae],
        &["-o"],
    ];
    for args in cases {
        let r = run(args);
        let e = r.fails(2);
        assert!(e.contains("error"), "{args:?}: {e}");
    }
}

#[test]
fn missing_input_file_exits_1() {
    let d = tempfile::tempdir().unwrap();
    let r = run_in(d.path(), &["missing.ls"], None);
    let e = r.one_error();
    assert!(e.starts_with("lsgen: missing.ls: error: "), "{e}");
    assert_eq!(e.lines().count(), 1, "{e}");
    assert!(e.contains("No such file or directory"), "{e}");
}

#[test]
fn directory_as_input_exits_1() {
    let d = tempfile::tempdir().unwrap();
    let ds = d.path().display().to_string();
    let r = run(&[&ds]);
    let e = r.one_error();
    assert!(e.starts_with(&format!("lsgen: {ds}: error: ")), "{e}");
}

// ---------------------------------------------------------------- broken pipe

#[test]
fn broken_pipe_is_a_quiet_success() {
    // algae after 30 steps: 1.3 million modules, far beyond a pipe buffer.
    let mut child = common::spawn(lsgen_in_root().args(["-n", "30", "examples/algae.ls"]));
    let mut stdout = child.stdout.take().unwrap();
    let mut head = [0u8; 16];
    stdout.read_exact(&mut head).unwrap();
    assert_eq!(&head, b"abaababaabaababa");
    drop(stdout);
    let r = common::finish(child, common::TIME_LIMIT);
    let stderr = &r.stderr;
    assert_eq!(r.code(), Some(0), "stderr: {stderr}");
    assert_eq!(stderr, "", "a broken pipe must be silent");
}

#[test]
fn broken_pipe_when_printing_the_axiom() {
    // n = 0: the axiom is streamed straight to the output.
    let mut big = b"productions:\nF -> G\naxiom:\n".to_vec();
    big.extend(std::iter::repeat_n(b'F', 4 << 20));
    let d = tempfile::tempdir().unwrap();
    std::fs::write(d.path().join("big.ls"), &big).unwrap();
    let mut child = common::spawn(lsgen().args(["-n", "0", "big.ls"]).current_dir(d.path()));
    let mut stdout = child.stdout.take().unwrap();
    let mut head = [0u8; 4];
    stdout.read_exact(&mut head).unwrap();
    assert_eq!(&head, b"FFFF");
    drop(stdout);
    let r = common::finish(child, common::TIME_LIMIT);
    let stderr = &r.stderr;
    assert_eq!(r.code(), Some(0), "stderr: {stderr}");
    assert_eq!(stderr, "");
}

// ---------------------------------------------------------------- file syntax

#[test]
fn shebang_line_is_skipped() {
    let src = "#!/usr/bin/env lsgen\nproductions:\nF -> F+F\naxiom: F\n";
    let d = dir_with(&[("p.ls", src)]);
    assert_eq!(
        run_in(d.path(), &["-n", "2", "p.ls"], None).ok(),
        "F+F+F+F\n"
    );
    // Line numbers still count the #! line.
    let src = "#!/usr/bin/env lsgen\nproductions:\nF -> G(x)\naxiom: F\n";
    let d = dir_with(&[("p.ls", src)]);
    let r = run_in(d.path(), &["p.ls"], None);
    assert_eq!(
        r.fails(1),
        "lsgen: p.ls:3:8: error: unknown identifier `x`\nF -> G(x)\n       ^\n"
    );
}

#[test]
fn long_arrow_works() {
    let src = "productions:\nF --> F-F\nA(x) : x > 0 --> A(x-1)F\naxiom: F A(2)\n";
    let d = dir_with(&[("p.ls", src)]);
    assert_eq!(
        run_in(d.path(), &["-n", "2", "p.ls"], None).ok(),
        "F-F-F-FA(0)FF-F\n"
    );
}

#[test]
fn capitalised_keywords_work() {
    let src = "Derivation length: 3\nDefine: k = 2\nSeed: 1\nProductions:\n\
               A(x) -> A(x*k)\nHomomorphism:\nA(x) -> B(x)\nAxiom: A(1)\n";
    let d = dir_with(&[("p.ls", src)]);
    assert_eq!(run_in(d.path(), &["p.ls"], None).ok(), "B(8)\n");
    let src = "DERIVATION LENGTH: 2\nPRODUCTIONS:\nF -> FF\nAXIOM:\nF\n";
    let d = dir_with(&[("p.ls", src)]);
    assert_eq!(run_in(d.path(), &["p.ls"], None).ok(), "FFFF\n");
}

#[test]
fn default_derivation_length_is_one_step() {
    assert_eq!(lsgen::cli::DEFAULT_DERIVATION_LENGTH, 1);
    let d = dir_with(&[("p.ls", "productions:\nF -> F+F\naxiom: F\n")]);
    assert_eq!(run_in(d.path(), &["p.ls"], None).ok(), "F+F\n");
    assert_eq!(
        run_stdin(&[], b"productions:\na -> ab\nb -> a\naxiom: a\n").ok(),
        "ab\n"
    );
}

#[test]
fn crlf_line_endings_work() {
    let d = dir_with(&[(
        "p.ls",
        "derivation length: 2\r\nproductions:\r\nF -> FF\r\naxiom: F\r\n",
    )]);
    assert_eq!(run_in(d.path(), &["p.ls"], None).ok(), "FFFF\n");
}

// ---------------------------------------------------------------- numbers and round trips

#[test]
fn numbers_are_printed_in_shortest_form() {
    let src = "productions:\nA -> B(0.5)B(1e-7)B(2.0)B(-0)\naxiom: A\n";
    let d = dir_with(&[("p.ls", src)]);
    assert_eq!(
        run_in(d.path(), &["p.ls"], None).ok(),
        "B(0.5)B(1e-7)B(2)B(-0)\n"
    );
    let src = "productions:\nA -> B(1/2, 4/2, 0.1+0.2, 1/3, -3, 1e16, 123456)\naxiom: A\n";
    let d = dir_with(&[("p.ls", src)]);
    assert_eq!(
        run_in(d.path(), &["p.ls"], None).ok(),
        "B(0.5,2,0.30000000000000004,0.3333333333333333,-3,1e16,123456)\n"
    );
}

/// `lsgen --axiom OUT -n 0` reproduces OUT byte for byte.
fn assert_round_trip(out: &str, file: &str, what: &str) {
    let d = dir_with(&[("out.txt", out)]);
    let again = run_in(d.path(), &["-n", "0", "--axiom", "out.txt", file], None).ok();
    assert!(
        again == out,
        "{what}: reading the output back changes it:\n{out}\n{again}"
    );
    let again = run_stdin(&["-n", "0", "--axiom", "-", file], out.as_bytes()).ok();
    assert!(
        again == out,
        "{what}: reading the output back from stdin changes it"
    );
}

#[test]
fn output_read_back_as_axiom_reproduces_itself() {
    let src = "productions:\n\
               A(x) -> Ω(x/3)[+ß(x*1e20)]é(-x)B(x*0, -(x*0), 1e-7, 0.1+0.2)\n\
               B(a,b,c,d) -> 中(a,b,c,d)\n\
               axiom: A(1) Ω(2.5) A(5e-324)\n";
    let d = dir_with(&[("u.ls", src)]);
    let u = d.path().join("u.ls").display().to_string();
    let out1 = run_in(d.path(), &["-n", "1", "u.ls"], None).ok();
    assert!(
        out1.contains("Ω(0.3333333333333333)[+ß(1e20)]é(-1)"),
        "{out1}"
    );
    assert!(out1.contains("B(0,-0,1e-7,0.30000000000000004)"), "{out1}");
    assert_round_trip(&out1, &u, "unicode, n=1");
    let out2 = run_in(d.path(), &["-n", "2", "u.ls"], None).ok();
    assert!(out2.contains("中(0,-0,1e-7,0.30000000000000004)"), "{out2}");
    assert_round_trip(&out2, &u, "unicode, n=2");
    for (name, n) in [
        ("monopodial_tree", "4"),
        ("ternary_tree", "3"),
        ("row_of_trees", "6"),
        ("parametric", "5"),
        ("stochastic_plant", "5"),
        ("context_plant_c", "26"),
    ] {
        let file = example(name);
        let out = run(&["-n", n, &file]).ok();
        assert_round_trip(&out, &file, name);
    }
}

// ---------------------------------------------------------------- the error format

/// Run `src` as `p.ls` in a fresh directory (with `args` before the file).
fn run_source(src: &str, args: &[&str]) -> Run {
    let d = dir_with(&[("p.ls", src)]);
    let mut all = args.to_vec();
    all.push("p.ls");
    run_in(d.path(), &all, None)
}

/// The full stderr of a failing run, checked to be exactly `want`.
fn assert_error(src: &str, args: &[&str], want: &str) {
    let r = run_source(src, args);
    let got = r.fails(1);
    assert!(
        got == want,
        "for\n{src}\nwant stderr:\n{want}\ngot:\n{got}\n(debug: {got:?})"
    );
    // --check finds the same error, unless it is a runtime one.
    let r = run_source(src, &["--check"]);
    if want.contains("(in step") || want.contains("(in the homomorphism)") {
        assert_eq!(r.ok(), "", "--check derives nothing");
    } else {
        assert_eq!(r.fails(1), want, "--check reports a different error");
    }
}

#[test]
fn error_unknown_identifier_in_a_successor() {
    assert_error(
        "productions:\nA(x) -> B(y)\naxiom:\nA(1)\n",
        &[],
        "lsgen: p.ls:2:11: error: unknown identifier `y`\nA(x) -> B(y)\n          ^\n",
    );
}

#[test]
fn error_division_by_zero_at_step_2() {
    assert_error(
        DIV_AT_STEP_2,
        &["-n", "2"],
        "lsgen: p.ls:3:20: error: division by zero (in step 2)\n\
         A(x) : x <= 0 -> B(1/x)\n                   ^\n",
    );
}

#[test]
fn error_division_by_zero_after_a_tab_and_unicode() {
    // The caret line keeps the tab so it lines up under the source.
    assert_error(
        "productions:\n\tΩ(x) -> Ω(x/0)\naxiom: Ω(2)\n",
        &[],
        "lsgen: p.ls:2:12: error: division by zero (in step 1)\n\
         \tΩ(x) -> Ω(x/0)\n\t          ^\n",
    );
}

#[test]
fn error_in_the_homomorphism() {
    assert_error(
        "derivation length: 2\nproductions:\nA(x) -> A(x-1)\nhomomorphism:\nA(x) -> B(1/x)\naxiom: A(2)\n",
        &[],
        "lsgen: p.ls:5:11: error: division by zero (in the homomorphism)\n\
         A(x) -> B(1/x)\n          ^\n",
    );
}

#[test]
fn error_unterminated_comment() {
    assert_error(
        "productions:\nF -> FF /* oops\naxiom:\nF\n",
        &[],
        "lsgen: p.ls:2:9: error: unterminated comment: `/*` without `*/`\n\
         F -> FF /* oops\n        ^\n",
    );
}

#[test]
fn error_unterminated_comment_in_the_axiom() {
    assert_error(
        "productions:\nF -> FF\naxiom:\nF F /* never closed\nF\n",
        &[],
        "lsgen: p.ls:4:5: error: unterminated comment: `/*` without `*/`\n\
         F F /* never closed\n    ^\n",
    );
}

#[test]
fn error_bad_axiom_character() {
    assert_error(
        "productions:\nF -> FF\naxiom:\nF+F)F\n",
        &[],
        "lsgen: p.ls:4:4: error: `)` is reserved and cannot be a symbol\nF+F)F\n   ^\n",
    );
    // Columns count characters, not bytes.
    assert_error(
        "productions:\nF -> FF\naxiom: Ωé)\n",
        &[],
        "lsgen: p.ls:3:10: error: `)` is reserved and cannot be a symbol\naxiom: Ωé)\n         ^\n",
    );
}

#[test]
fn error_empty_parameter_in_the_axiom() {
    assert_error(
        "productions:\nF -> FF\n\tAXIOM:\tF\n  G(1,)\n",
        &[],
        "lsgen: p.ls:4:7: error: empty parameter\n  G(1,)\n      ^\n",
    );
}

#[test]
fn error_header_syntax() {
    assert_error(
        "productions:\nF < -> G\naxiom: F\n",
        &[],
        "lsgen: p.ls:2:5: error: unexpected `->`, expected a symbol\nF < -> G\n    ^\n",
    );
    assert_error(
        "derivation length: 2.5\naxiom: F\n",
        &[],
        "lsgen: p.ls:1:20: error: the derivation length must be a whole number from 0 to 2^53, not 2.5\n\
         derivation length: 2.5\n                   ^\n",
    );
}

/// The snippet and caret lines of a located error, checked to point at
/// the character `at`.
fn caret_points_at(e: &str, at: char) {
    let lines: Vec<&str> = e.lines().collect();
    assert_eq!(lines.len(), 3, "{e:?}");
    let caret = lines[2].chars().count() - 1;
    assert!(lines[2].ends_with('^'), "{e:?}");
    assert_eq!(
        lines[1].chars().nth(caret),
        Some(at),
        "caret misplaced: {e:?}"
    );
}

#[test]
fn error_excerpt_of_a_long_axiom_line() {
    // `)` at column 7 + 1000 + 1.
    let src = format!("productions:\nF -> G\naxiom: {})FF\n", "F".repeat(1000));
    let r = run_source(&src, &[]);
    let e = r.one_error();
    assert!(
        e.starts_with("lsgen: p.ls:3:1008: error: `)` is reserved"),
        "{e}"
    );
    caret_points_at(e, ')');
    let snippet = e.lines().nth(1).unwrap();
    assert!(
        snippet.starts_with("...F") && snippet.len() < 200,
        "{snippet}"
    );
}

#[test]
fn error_excerpt_of_a_very_long_axiom_line() {
    let src = format!("productions:\nF -> G\naxiom: {})FF\n", "F".repeat(200_000));
    let r = run_source(&src, &[]);
    let e = r.one_error();
    assert!(
        e.starts_with("lsgen: p.ls:3:200008: error: `)` is reserved"),
        "{e}"
    );
    caret_points_at(e, ')');
    let snippet = e.lines().nth(1).unwrap();
    assert!(snippet.starts_with("...F"), "{snippet}");
}

#[test]
fn error_excerpt_deep_into_a_long_axiom() {
    let src = format!(
        "productions:\nF -> G\naxiom:\n{}ΩF)\n",
        "F\n".repeat(100_000)
    );
    let r = run_source(&src, &[]);
    assert_eq!(
        r.fails(1),
        "lsgen: p.ls:100004:3: error: `)` is reserved and cannot be a symbol\nΩF)\n  ^\n"
    );
}

#[test]
fn error_excerpt_of_a_very_long_axiom_parameter() {
    // The bad parameter `y` is followed by 200000 blanks before its `)`.
    let src = format!("productions:\nF -> G\naxiom: F(y{})\n", " ".repeat(200_000));
    let r = run_source(&src, &[]);
    let e = r.one_error();
    assert!(
        e.starts_with("lsgen: p.ls:3:10: error: unknown identifier `y`\n"),
        "{e}"
    );
    caret_points_at(e, 'y');
}

#[test]
fn bad_inputs_give_one_error_and_never_panic() {
    let cases: &[&[u8]] = &[
        b"",
        b"\n\n",
        b"productions:\nF -> FF\n",
        b"axiom",
        b"derivation length: -1\naxiom: F\n",
        b"derivation length: 1e30\naxiom: F\n",
        b"seed: -5\naxiom: F\n",
        b"define: x = 1/0\naxiom: F\n",
        b"define: x = y\naxiom: F\n",
        b"define: x\naxiom: F\n",
        b"productions:\nF -> G : -1\naxiom: F\n",
        b"productions:\nF(x,x) -> G(x)\naxiom: F(1,2)\n",
        b"productions:\nF -> G(foo(1))\naxiom: F\n",
        b"productions:\nF -> G(sqrt(-1))\naxiom: F\n",
        b"productions:\nF -> G(1e308*10)\naxiom: F\n",
        b"productions:\nF(x) -> F(x*1e300)\naxiom: F(1e300)\n",
        b"productions:\nF -> G\naxiom: F(1e999)\n",
        b"productions:\nF -> G\naxiom: F(\n",
        b"productions:\nF -> G\naxiom: F(1,,2)\n",
        b"productions:\nF -> G\naxiom: F(y)\n",
        b"ignore: (\naxiom: F\n",
        b"productions:\nF -> \xff\naxiom: F\n",
        b"productions:\nF -> G\naxiom: F\xff\n",
        b"productions:\nF -> G\x00\naxiom: F\n",
        b"productions:\nF -> G\naxiom: F\x01\n",
        b"productions:\nF -> G\naxiom: ]\n",
        b"productions:\nF -> ]\naxiom: F\n",
        b"productions:\nF -> F[F\naxiom: F\n",
        b"productions:\nF -> G\naxiom: [[[[F\n",
        b"productions:\nF -> G(\naxiom: F\n",
        b"productions:\n-> G\naxiom: F\n",
        b"productions:\nA B -> C\naxiom: F\n",
        b"productions:\nF -> G\nproductions:\nF -> G\naxiom: F\n",
        b"productions:\nF -> G\naxiom: F\naxiom: F\n",
        b"productions:\nF -> G(1%2)\naxiom: F\n",
        b"/* never closed\nproductions:\nF -> G\naxiom: F\n",
        b"productions:\nF -> FF\naxiom: F /* never closed\n",
    ];
    for src in cases {
        let d = tempfile::tempdir().unwrap();
        std::fs::write(d.path().join("p.ls"), src).unwrap();
        for args in [&["-n", "3", "p.ls"][..], &["--check", "p.ls"][..]] {
            let r = run_in(d.path(), args, None);
            let shown = String::from_utf8_lossy(src);
            if args[0] == "--check" && r.code() == Some(0) {
                continue; // a runtime error: --check derives nothing
            }
            assert_eq!(
                r.code(),
                Some(1),
                "{args:?} on {shown:?}: stderr {:?}",
                r.stderr
            );
            let e = r.one_error();
            assert!(
                e.starts_with("lsgen: p.ls:") || e.starts_with("lsgen: p.ls: "),
                "{shown:?}: {e:?}"
            );
            let first = e.lines().next().unwrap();
            if first.starts_with("lsgen: p.ls:") && !first.starts_with("lsgen: p.ls: ") {
                // Located: three lines, the last a caret.
                assert_eq!(e.lines().count(), 3, "{shown:?}: {e:?}");
                assert!(e.ends_with("^\n"), "{shown:?}: {e:?}");
            }
        }
    }
}

#[test]
fn an_error_run_never_writes_stdout() {
    // Even when the failure comes after the first steps have run.
    let r = run_source(DIV_AT_STEP_2, &["-n", "5"]);
    r.one_error();
}

// ------------------------------------------------ the reader (issue 9)

/// (4) Inputs that never reach `axiom:` fail fast and in bounded memory:
/// the header is checked as it is read (NUL, invalid UTF-8) and refused
/// past 64 MiB. Run under `ulimit -v` (lsgen's own worker stack reserves
/// 256 MiB of address space); lsgen 9bc7f68 ran out of memory on each.
#[test]
fn endless_headers_fail_fast_in_bounded_memory() {
    let cases: &[(&str, &[&str])] = &[
        ("\"$0\" /dev/zero", &["/dev/zero:1:1: error: NUL"]),
        (
            "yes 'F -> FF' | \"$0\" -",
            &["<stdin>:8388609:1: error: ", "too long"],
        ),
        // An unclosed comment: "/*x\n" (4 bytes), then 2^25 - 2 lines of
        // "x\n" fill 2^26 bytes: the limit is at the start of line 2^25.
        (
            "{ printf '/*x\\n'; yes x; } | \"$0\" -",
            &["<stdin>:33554432:1: error: ", "too long"],
        ),
        // NUL or invalid UTF-8 within a few bytes (usually on line 1).
        ("\"$0\" /dev/urandom", &["/dev/urandom:", "error: "]),
    ];
    for (script, want) in cases {
        let started = std::time::Instant::now();
        let out = common::run(
            common::command("sh")
                .arg("-c")
                .arg(format!("ulimit -v 700000; {script}"))
                .arg(common::LSGEN),
        );
        out.assert_no_crash();
        let stderr = &out.stderr;
        assert_eq!(out.code(), Some(1), "{script}: {stderr}");
        assert!(out.stdout.is_empty(), "{script}");
        let first = stderr.lines().next().unwrap_or("");
        for w in *want {
            assert!(first.contains(w), "{script}: want {w:?} in {stderr}");
        }
        assert!(
            ["NUL", "invalid UTF-8", "too long"]
                .iter()
                .any(|m| first.contains(m)),
            "{script}: {stderr}"
        );
        assert!(
            started.elapsed() < std::time::Duration::from_secs(30),
            "{script} took {:?}",
            started.elapsed()
        );
    }
}

/// (11, 12) Keywords, `axiom:` included, may follow comments on their
/// line, or a comment that ends on it.
#[test]
fn keywords_after_comments_on_their_line() {
    let src = "/* c */ derivation length: 3\n/* c */ productions:\nF -> FG\n/* h */ homomorphism:\nG -> H\n/* a */ axiom: F\n";
    // F -> FG -> FGG -> FGGG, then G -> H.
    assert_eq!(run_stdin(&["-"], src.as_bytes()).ok(), "FHHH\n");
    let src = "productions:\nF -> FG /* a\n*/ axiom: F\n";
    assert_eq!(run_stdin(&["-"], src.as_bytes()).ok(), "FG\n");
    let src = "productions:\nF -> FG\n/* a\nb */ axiom: F\n";
    assert_eq!(run_stdin(&["-"], src.as_bytes()).ok(), "FG\n");
}

/// Between the words of a keyword (`derivation length:`) and in a `view:`
/// setting stand any blanks (the no-break space here) and comments, as
/// between tokens (lsgen 9b99c7d took spaces and tabs only there, and
/// ended a view setting at its first comment).
#[test]
fn keyword_lines_take_unicode_blanks_and_comments() {
    for kw in [
        "derivation /* c */ length:",
        "derivation\u{a0}length:",
        "derivation\u{a0}/* c */\u{a0}length:",
        "derivation/**/length:",
    ] {
        let src = format!("{kw} 2\nproductions:\nA -> AB\naxiom: A\n");
        assert_eq!(run_stdin(&["-"], src.as_bytes()).ok(), "ABB\n", "{src:?}");
    }
    for view in [
        "view: angle = /* c */ 30",
        "view:\u{a0}angle\u{a0}=\u{a0}30\u{a0}/* c */",
        "view: width /* c */ increment = 1",
        "view: direction = 30 /* c */ 20",
    ] {
        let src = format!("{view}\naxiom: A\n");
        assert_eq!(run_stdin(&["-"], src.as_bytes()).ok(), "A\n", "{src:?}");
    }
    // The setting is every word of the line: a comment no longer ends it.
    let r = run_stdin(&["-"], b"view: angle = 30 /* c */ 40\naxiom: A\n");
    assert!(
        r.fails(1).contains("1:14: error: expected one number"),
        "{}",
        r.stderr
    );
}

/// `--max-length` errors name the flag, byte for byte (the library names
/// its `Limits` fields instead: tests/library.rs).
#[test]
fn max_length_errors_name_the_flag() {
    let r = run_stdin(&["-", "-n", "4", "--max-length", "5"], DOUBLING.as_bytes());
    assert_eq!(
        r.fails(1),
        "lsgen: error: the string grew past --max-length (5 modules) in step 3\n"
    );
    let r = run_stdin(
        &["-", "-n", "4", "--max-length", "15B"],
        DOUBLING.as_bytes(),
    );
    assert_eq!(
        r.fails(1),
        "lsgen: error: the string grew past --max-length (15 bytes) in step 4\n"
    );
}

/// Step numbers past 2^64 - 1 are a usage error that names lsgen's flags
/// (the library names its methods instead: tests/library.rs).
#[test]
fn steps_past_the_last_step_number_name_the_flags() {
    let r = run_stdin(
        &["-", "-n", "2", "--first-step", "18446744073709551614"],
        DOUBLING.as_bytes(),
    );
    assert_eq!(
        r.fails(2),
        "lsgen: error: `--first-step 18446744073709551614` with 2 steps: \
         step numbers must stay below 2^64 - 1\n"
    );
    // The file's `derivation length:` (1 here) counts too.
    let r = run_stdin(
        &["-", "--first-step", "18446744073709551615"],
        DOUBLING.as_bytes(),
    );
    assert!(
        r.fails(2)
            .contains("`--first-step 18446744073709551615` with 1 steps"),
        "{}",
        r.stderr
    );
}

/// (13) A `,` or `)` in a comment in a parameter list: the same in the
/// axiom as in a successor.
#[test]
fn comments_in_parameter_lists_of_the_axiom_as_in_successors() {
    let list = "F(1 /* a, b */)G F(1, /* a, b) */ 2) H(/* ( */ 3 /*)*/)";
    let want = "F(1)GF(1,2)H(3)\n";
    let axiom = format!("axiom: {list}\n");
    assert_eq!(run_stdin(&["-", "-n", "0"], axiom.as_bytes()).ok(), want);
    let succ = format!("productions:\nA -> {list}\naxiom: A\n");
    assert_eq!(run_stdin(&["-"], succ.as_bytes()).ok(), want);
}

/// (14) One rule for the axiom, a successor and `--axiom`: blanks (any
/// Unicode white space) and, where comments exist, comments may stand
/// between a symbol and its `(`, wherever the module is.
#[test]
fn parameters_attach_after_blanks_and_comments_everywhere() {
    for sep in [
        "", " ", "\t", "\u{a0}", "\u{b}", "\u{c}", "\u{2003}", "/* c */",
    ] {
        let modules = format!("GF{sep}(1)F{sep}(2)");
        let want = "GF(1)F(2)\n";
        let axiom = format!("axiom: {modules}\n");
        let r = run_stdin(&["-", "-n", "0"], axiom.as_bytes());
        assert_eq!(r.ok(), want, "axiom, {sep:?}");
        let succ = format!("productions:\nA -> {modules}\naxiom: A\n");
        let r = run_stdin(&["-"], succ.as_bytes());
        assert_eq!(r.ok(), want, "successor, {sep:?}");
        if !sep.contains("/*") {
            // `--axiom` text has no comments.
            let d = dir_with(&[("p.ls", "axiom: X\n"), ("ax.txt", &modules)]);
            let r = run_in(d.path(), &["p.ls", "-n", "0", "--axiom", "ax.txt"], None);
            assert_eq!(r.ok(), want, "--axiom, {sep:?}");
        }
    }
    // A newline too, in the axiom (a successor ends at the line's end).
    let r = run_stdin(&["-", "-n", "0"], b"axiom: GF\n  (1)\n");
    assert_eq!(r.ok(), "GF(1)\n");
}

/// (15) Property: in random multi-line axioms (blanks, CRLF, comments and
/// line breaks inside parameter lists), an unknown name is reported at its
/// own line and column, with the caret under it. The expected place is
/// counted while the text is built.
#[test]
fn errors_in_random_multi_line_axioms_are_located() {
    let mut state = 0x9E37_79B9_7F4A_7C15u64;
    let mut next = move |n: u64| {
        state ^= state << 13;
        state ^= state >> 7;
        state ^= state << 17;
        state % n
    };
    for case in 0..150 {
        let mut text = String::from("productions:\nF -> FF\naxiom:");
        let mut bad_at = None;
        let n_modules = 1 + next(6);
        let bad_module = next(n_modules);
        let blank = |k: u64| ["", " ", "\n", "\r\n", "\t", " /* a, b)\n */ ", "\n\n  "][k as usize];
        for m in 0..n_modules {
            text.push_str(blank(next(7)));
            text.push("FGAB+-&^".as_bytes()[next(8) as usize] as char);
            let n_params = if m == bad_module {
                1 + next(4)
            } else {
                next(3)
            };
            if n_params == 0 {
                continue;
            }
            text.push_str(blank(next(7)));
            text.push('(');
            let bad_param = next(n_params);
            for p in 0..n_params {
                if p > 0 {
                    text.push_str(blank(next(7)));
                    text.push(',');
                }
                let terms = 1 + next(3);
                let bad_term = next(terms);
                for t in 0..terms {
                    text.push_str(blank(next(7)));
                    if t > 0 {
                        text.push_str(["+", "*", "-"][next(3) as usize]);
                        text.push_str(blank(next(7)));
                    }
                    if m == bad_module && p == bad_param && t == bad_term {
                        let line = text.matches('\n').count() + 1;
                        let start = text.rfind('\n').map_or(0, |i| i + 1);
                        let col = text[start..].chars().count() + 1;
                        bad_at = Some((line, col));
                        text.push('q');
                    } else {
                        text.push_str(["1", "2.5", "(3)", "4e1"][next(4) as usize]);
                    }
                }
            }
            text.push_str(blank(next(7)));
            text.push(')');
        }
        text.push('\n');
        let (line, col) = bad_at.unwrap();
        let r = run_stdin(&["-"], text.as_bytes());
        let e = r.one_error();
        let head = format!("lsgen: <stdin>:{line}:{col}: error: unknown identifier `q`");
        assert!(
            e.starts_with(&head),
            "case {case}: {text:?}\nwant {head}\ngot {e}"
        );
        let lines: Vec<&str> = e.lines().collect();
        assert_eq!(lines.len(), 3, "case {case}: {e}");
        let src_line = text.split('\n').nth(line - 1).unwrap();
        let src_line = src_line.strip_suffix('\r').unwrap_or(src_line);
        assert_eq!(lines[1], src_line, "case {case}: {text:?}");
        let pad: String = src_line
            .chars()
            .take(col - 1)
            .map(|c| if c == '\t' { '\t' } else { ' ' })
            .collect();
        assert_eq!(lines[2], format!("{pad}^"), "case {case}: {text:?}");
    }
}

/// (23) A byte-order mark at the start of an `--axiom` file is skipped, as
/// at the start of an .ls file (lsgen 9bc7f68 read it as a U+FEFF module).
#[test]
fn byte_order_mark_in_an_axiom_file_is_skipped() {
    let d = dir_with(&[
        ("p.ls", "\u{feff}productions:\nF -> G\naxiom: X\n"),
        ("ax.txt", "\u{feff}F(1)F"),
    ]);
    let r = run_in(d.path(), &["p.ls", "--axiom", "ax.txt"], None);
    assert_eq!(r.ok(), "F(1)G\n");
}

/// lsgen run as user 65534 (by root, through `setpriv`).
fn as_user_65534() -> std::process::Command {
    let mut c = std::process::Command::new("setpriv");
    c.args([
        "--reuid=65534",
        "--regid=65534",
        "--clear-groups",
        common::LSGEN,
    ]);
    c
}

/// `-o` does not replace a file its user could not write with `>` (the
/// rename would, as the directory allows it): a read-only file stays, the
/// run fails with the system's message. As root, through `setpriv` to
/// user 65534; root itself may write it, as with `>`.
#[test]
fn output_refuses_a_file_its_user_cannot_write() {
    use std::os::unix::fs::PermissionsExt;
    let d = common::tempdir();
    let dir = d.path();
    std::fs::set_permissions(dir, std::fs::Permissions::from_mode(0o777)).unwrap();
    let src = common::write(dir, "a.ls", "axiom:\nF\n");
    std::fs::set_permissions(&src, std::fs::Permissions::from_mode(0o644)).unwrap();
    let ro = common::write(dir, "ro.txt", "old\n");
    std::fs::set_permissions(&ro, std::fs::Permissions::from_mode(0o444)).unwrap();
    // SAFETY: geteuid has no preconditions.
    let root = unsafe { libc::geteuid() } == 0;
    let mut cmd = if root {
        as_user_65534()
    } else {
        std::process::Command::new(common::LSGEN)
    };
    cmd.arg(&src).arg("-o").arg(&ro);
    let r = common::run(&mut cmd);
    assert_eq!(r.code(), Some(1), "{}", r.stderr);
    assert_eq!(
        r.stderr,
        format!(
            "lsgen: {}: error: cannot write: Permission denied\n",
            ro.display()
        )
    );
    assert_eq!(std::fs::read_to_string(&ro).unwrap(), "old\n");
    let left: Vec<_> = std::fs::read_dir(dir).unwrap().collect();
    assert_eq!(left.len(), 2, "a temporary file was left");
    if root {
        let r = common::run(lsgen().arg(&src).arg("-o").arg(&ro));
        assert_eq!(r.code(), Some(0), "{}", r.stderr);
        assert_eq!(std::fs::read_to_string(&ro).unwrap(), "F\n");
    }
}

/// In a sticky directory, another user's file that `>` could write is
/// refused before the derivation, saying why (the rename that replaces it
/// is not permitted there: lsgen 5cc20ce derived, then failed with
/// "Operation not permitted"). Needs two users: as root, the file is
/// root's and lsgen runs as user 65534; otherwise skipped.
#[test]
fn output_refuses_another_users_file_in_a_sticky_directory() {
    use std::os::unix::fs::PermissionsExt;
    // SAFETY: geteuid has no preconditions.
    if unsafe { libc::geteuid() } != 0 {
        return;
    }
    let d = common::tempdir();
    let dir = d.path();
    std::fs::set_permissions(dir, std::fs::Permissions::from_mode(0o1777)).unwrap();
    let src = common::write(dir, "a.ls", "axiom:\nF\n");
    std::fs::set_permissions(&src, std::fs::Permissions::from_mode(0o644)).unwrap();
    let theirs = common::write(dir, "theirs.txt", "old\n");
    std::fs::set_permissions(&theirs, std::fs::Permissions::from_mode(0o666)).unwrap();
    let as_nobody = |out: &std::path::Path| {
        let mut c = as_user_65534();
        c.arg(&src).arg("-o").arg(out);
        common::run(&mut c)
    };
    let r = as_nobody(&theirs);
    assert_eq!(r.code(), Some(1), "{}", r.stderr);
    assert_eq!(
        r.stderr,
        format!(
            "lsgen: {}: error: cannot write: another user's file in a sticky directory, \
             which lsgen cannot replace (it writes a new file and renames it over the old \
             one); write to standard output and redirect it with `>`\n",
            theirs.display()
        )
    );
    assert_eq!(std::fs::read_to_string(&theirs).unwrap(), "old\n");
    let left: Vec<_> = std::fs::read_dir(dir).unwrap().collect();
    assert_eq!(left.len(), 2, "a temporary file was left");
    // A new file there is the user's own.
    let mine = dir.join("mine.txt");
    let r = as_nobody(&mine);
    assert_eq!(r.code(), Some(0), "{}", r.stderr);
    assert_eq!(std::fs::read_to_string(&mine).unwrap(), "F\n");
}

/// Blanks and comments may stand before a keyword's `:` as between its
/// words (README, "Keywords"); a line break may not. Algae from A, three
/// steps: AB, ABA, ABAAB; the comment `/* : */` holds a colon itself.
#[test]
fn keywords_take_blanks_and_comments_before_their_colon() {
    let src = "derivation length /* : */ : 3\nseed\t: 1\nproductions :\nA -> AB\nB -> A\n\
               homomorphism  :\nmaximum depth : 1\nB -> B\naxiom\u{a0}/* x */ : A\n";
    assert_eq!(run_stdin(&["-"], src.as_bytes()).ok(), "ABAAB\n");
    let r = run_stdin(&["-"], b"productions:\nA -> AB\naxiom\n: A\n");
    assert_eq!(r.code(), Some(1));
}

/// A file name with a line break or a terminal escape is shown escaped
/// (`\n`, `\u{1b}`) in the one error line, never raw (found by the review
/// helper: `$'no\ndir/x'` split the line, `$'b\e[31mad.ls'` coloured the
/// terminal), in located errors too.
#[test]
fn control_characters_of_file_names_are_escaped_in_errors() {
    let d = dir_with(&[("e\u{1b}[1mrr.ls", "productions:\nF -> (\naxiom: F\n")]);
    for (name, shown) in [
        ("no\ndir/x.ls", "lsgen: no\\ndir/x.ls: error: cannot open"),
        (
            "b\u{1b}[31mad.ls",
            "lsgen: b\\u{1b}[31mad.ls: error: cannot open",
        ),
        (
            "e\u{1b}[1mrr.ls",
            "lsgen: e\\u{1b}[1mrr.ls:2:6: error: unexpected `(`",
        ),
    ] {
        let r = run_in(d.path(), &[name], None);
        let line = r.assert_one_error();
        assert!(line.starts_with(shown), "{name:?}: {line}");
        assert!(!r.stderr.contains('\u{1b}'), "{name:?}: {:?}", r.stderr);
    }
}

/// A file whose lines end with `\r` alone (classic Mac OS) is one line to
/// lsgen, as `\r` is a blank: its error says why the line is so long. A
/// `\r\n` file gets no such note, and no `\r` reaches the terminal.
#[test]
fn lines_ending_with_a_lone_carriage_return_get_a_note() {
    let d = dir_with(&[
        ("mac.ls", "productions:\rA -> AB\raxiom: A\r"),
        ("dos.ls", "productions:\r\nA -> A(\r\naxiom: A\r\n"),
    ]);
    let r = common::run(lsgen().current_dir(d.path()).arg("mac.ls"));
    r.assert_no_crash();
    assert_eq!(r.code(), Some(1));
    assert_eq!(
        r.stderr,
        "lsgen: mac.ls:1:14: error: unexpected symbol `A`, expected end of line\n\
         productions:\u{FFFD}A -> AB\u{FFFD}axiom: A\n             ^\n\
         note: a `\\r` (shown as \u{FFFD}) without a `\\n` after it ends no line: lines end \
         with `\\n` or `\\r\\n`, so a file whose lines end with `\\r` alone is one line\n"
    );
    let r = common::run(lsgen().current_dir(d.path()).arg("dos.ls"));
    assert_eq!(r.code(), Some(1));
    assert!(
        !r.stderr.contains("note:") && !r.stderr.contains('\r'),
        "{}",
        r.stderr
    );
    assert_eq!(r.stderr.lines().count(), 3, "{}", r.stderr);
}

/// U+FEFF is no module anywhere: `--axiom` text and a `.l` file refuse it
/// past their first character (where it is a byte-order mark, skipped).
/// It used to be a module, which `--axiom` then dropped at the start of a
/// string, so a chained `--first-step` run differed from one run.
#[test]
fn a_byte_order_mark_is_no_symbol() {
    let d = dir_with(&[
        ("p.ls", "productions:\nA -> AB\naxiom: A\n"),
        (
            "p.l",
            "Lsystem: 1\nderivation length: 1\nAxiom: A\nA --> \u{FEFF}B\nendlsystem\n",
        ),
    ]);
    let axiom = |text: &str| {
        common::run_with_stdin(
            lsgen().current_dir(d.path()).args(["--axiom", "-", "p.ls"]),
            text,
        )
    };
    assert_eq!(axiom("\u{FEFF}A").ok(), "AB\n");
    let r = axiom("A\u{FEFF}");
    assert_eq!(r.code(), Some(1));
    assert!(
        r.stderr.starts_with(
            "lsgen: <stdin>:1:2: error: U+FEFF (a byte-order mark, invisible) cannot be a symbol"
        ),
        "{}",
        r.stderr
    );
    let r = common::run(lsgen().current_dir(d.path()).arg("p.l"));
    assert_eq!(r.code(), Some(1));
    assert!(
        r.stderr.starts_with("lsgen: p.l:4:7: error: U+FEFF"),
        "{}",
        r.stderr
    );
}

/// `-v` counts in words that agree with their numbers: `1 production`,
/// `1 module, 1 byte` (it said `1 productions`, `1 modules, 1 bytes`).
#[test]
fn verbose_counts_agree_in_number() {
    let d = dir_with(&[(
        "p.ls",
        "productions:\nA -> A\nhomomorphism:\nA -> B\naxiom: A\n",
    )]);
    let r = common::run(
        lsgen()
            .current_dir(d.path())
            .args(["--check", "-v", "p.ls"]),
    );
    assert_eq!(
        r.stderr,
        "lsgen: p.ls: ok: 1 production, 1 homomorphism production\n"
    );
    let r = common::run(
        lsgen()
            .current_dir(d.path())
            .args(["-n", "1", "-v", "p.ls"]),
    );
    assert!(
        r.stderr.contains("lsgen: step 1: 1 module, 1 byte\n"),
        "{}",
        r.stderr
    );
}
