//! Batches (issue 13): several FILE arguments and seed ranges, `-o`
//! templates, `-j` workers, and `-v`'s digit grouping; through the binary.
//! Expected strings come from the in-memory reference (tests/reference) or
//! are derived by hand.

mod common;
mod reference;

use common::{dir_with, lsgen, run, Run};
use std::path::Path;

/// A small stochastic system: each seed gives its own string.
const STOCHASTIC: &str = "productions:\n\
                          F -> F[+F]F : 0.3\n\
                          F -> F[-F] : 0.3\n\
                          F -> FF : 0.4\n\
                          axiom: F\n";

/// Divides by zero in step 2 (line 3, column 20).
const DIV_AT_STEP_2: &str = "productions:\n\
                             A(x) : x > 0 -> A(x-1)\n\
                             A(x) : x <= 0 -> B(1/x)\n\
                             axiom:\n\
                             A(1)\n";

fn lsgen_in(dir: &Path, args: &[&str]) -> Run {
    let r = run(lsgen().current_dir(dir).env_remove("LSGEN_JOBS").args(args));
    r.assert_no_crash();
    r
}

fn read(p: impl AsRef<Path>) -> String {
    std::fs::read_to_string(p.as_ref())
        .unwrap_or_else(|e| panic!("read {}: {e}", p.as_ref().display()))
}

#[test]
fn seed_range_gives_each_seed_its_reference_string_at_every_j() {
    let d = dir_with(&[("row.ls", STOCHASTIC)]);
    let mut want = Vec::new();
    for seed in 1..=12u64 {
        let w = reference::derive_text(STOCHASTIC, Some(4), Some(seed), 100_000).unwrap();
        want.push(w);
    }
    // Not all the same, or the test would not tell seeds apart.
    assert!(want.iter().any(|w| *w != want[0]));
    for j in ["1", "2", "8"] {
        let out = format!("j{j}/{{stem}}-{{seed}}.txt");
        std::fs::create_dir(d.path().join(format!("j{j}"))).unwrap();
        let r = lsgen_in(
            d.path(),
            &["-n", "4", "--seed", "1..12", "-j", j, "-o", &out, "row.ls"],
        );
        r.ok();
        let names = common::listing(&d.path().join(format!("j{j}")));
        assert_eq!(names.len(), 12, "-j {j}: {names:?}");
        for (i, w) in want.iter().enumerate() {
            let got = read(d.path().join(format!("j{j}/row-{}.txt", i + 1)));
            assert_eq!(&got, w, "-j {j}, seed {}", i + 1);
        }
    }
}

#[test]
fn several_files_take_their_stems() {
    let d = dir_with(&[
        ("algae.ls", "productions:\nA -> AB\nB -> A\naxiom: A\n"),
        ("double.ls", "productions:\nF -> FF\naxiom: F\n"),
    ]);
    lsgen_in(
        d.path(),
        &["-n", "4", "-o", "{stem}.{{txt}}", "algae.ls", "double.ls"],
    )
    .ok();
    assert_eq!(read(d.path().join("algae.{txt}")), "ABAABABA\n");
    assert_eq!(read(d.path().join("double.{txt}")), "FFFFFFFFFFFFFFFF\n");
}

#[test]
fn one_job_with_a_template_expands_it() {
    let d = dir_with(&[("algae.ls", "productions:\nA -> AB\nB -> A\naxiom: A\n")]);
    lsgen_in(
        d.path(),
        &["-n", "3", "--seed", "9", "-o", "{stem}-{seed}", "algae.ls"],
    )
    .ok();
    assert_eq!(read(d.path().join("algae-9")), "ABAAB\n");
}

#[test]
fn a_failing_member_is_reported_and_the_others_finish() {
    let d = dir_with(&[
        ("a.ls", "productions:\nA -> AB\nB -> A\naxiom: A\n"),
        ("bad.ls", DIV_AT_STEP_2),
        ("z.ls", "productions:\nF -> FF\naxiom: F\n"),
    ]);
    std::fs::create_dir(d.path().join("out")).unwrap();
    let r = lsgen_in(
        d.path(),
        &[
            "-n",
            "3",
            "--seed",
            "5",
            "-j",
            "2",
            "-o",
            "out/{stem}.txt",
            "a.ls",
            "bad.ls",
            "z.ls",
        ],
    );
    let err = r.fails(1);
    assert_eq!(
        err,
        "lsgen: bad.ls:3:20: error: division by zero (in step 2) [job bad.ls (seed 5)]\n\
         A(x) : x <= 0 -> B(1/x)\n\
         \x20                  ^\n\
         lsgen: error: 1 of 3 jobs failed\n"
    );
    common::assert_listing(&d.path().join("out"), &["a.txt", "z.txt"]);
    assert_eq!(read(d.path().join("out/a.txt")), "ABAAB\n");
    assert_eq!(read(d.path().join("out/z.txt")), "FFFFFFFF\n");
}

#[test]
fn batch_usage_errors() {
    let d = dir_with(&[
        ("a.ls", "productions:\nA -> AB\naxiom: A\n"),
        ("b.ls", "productions:\nA -> AB\naxiom: A\n"),
    ]);
    std::fs::create_dir(d.path().join("sub")).unwrap();
    std::fs::write(d.path().join("sub/a.ls"), "axiom: A\n").unwrap();
    let cases: &[(&[&str], &str)] = &[
        (&["a.ls", "b.ls"], "need -o with a template"),
        (&["--seed", "1..3", "a.ls"], "need -o with a template"),
        (
            &["--seed", "1..3", "-o", "-", "a.ls"],
            "need -o with a template",
        ),
        (
            &["--seed", "1..3", "-o", "{stem}", "a.ls"],
            "needs `{seed}`",
        ),
        (&["-o", "{seed}", "a.ls", "b.ls"], "need `{stem}`"),
        (&["-o", "{stem}", "a.ls", "sub/a.ls"], "same {stem} `a`"),
        (&["--seed", "1..2", "-o", "{seed}", "-"], "standard input"),
        (&["-o", "{stem}.{x}", "a.ls"], "unknown placeholder `{x}`"),
        (&["-o", "{stem", "a.ls"], "unclosed"),
        (&["-o", "f{n}", "a.ls"], "`{n}`"),
        (&["--seed", "5..1", "a.ls"], "empty range"),
        (&["-j", "0", "a.ls"], "0"),
    ];
    for (args, needle) in cases {
        let r = lsgen_in(d.path(), args);
        let err = r.fails(2);
        assert!(err.contains(needle), "{args:?}: {err}");
    }
    common::assert_listing(d.path(), &["a.ls", "b.ls", "sub"]);
}

/// Make a FIFO at `path`; false (the test says it is skipped) where
/// `mkfifo` cannot.
fn mkfifo(path: &Path) -> bool {
    let made = std::process::Command::new("mkfifo")
        .arg(path)
        .status()
        .is_ok_and(|s| s.success());
    if !made {
        eprintln!("skipped: no mkfifo");
    }
    made
}

/// Every job reads the `--axiom` file, and each seed the L-system file,
/// again: a FIFO (a pipe, `<(...)`, `/dev/stdin`) would give the first job
/// all of it and the others an empty axiom, silently (exit 0; found by the
/// review helper). A usage error before any job, as `--axiom -` is; one
/// file from a FIFO per job is fine.
#[test]
fn a_pipe_read_by_several_jobs_is_refused_before_any_job() {
    let d = dir_with(&[
        ("a.ls", "productions:\nA -> AB\naxiom: A\n"),
        ("b.ls", "productions:\nA -> AB\naxiom: A\n"),
    ]);
    if !mkfifo(&d.path().join("fifo")) {
        return;
    }
    let cases: &[(&[&str], &str)] = &[
        (
            &["--axiom", "fifo", "-o", "{stem}", "a.ls", "b.ls"],
            "`--axiom fifo` is not a regular file",
        ),
        (
            &["--axiom", "fifo", "--seed", "1..2", "-o", "{seed}", "a.ls"],
            "`--axiom fifo` is not a regular file",
        ),
        (
            &["--seed", "1..2", "-o", "{seed}", "fifo"],
            "fifo is not a regular file",
        ),
        (
            &["--axiom", "-", "-o", "{stem}", "a.ls", "b.ls"],
            "`--axiom -` can feed one job only",
        ),
    ];
    for (args, needle) in cases {
        let r = lsgen_in(d.path(), args);
        let err = r.fails(2);
        assert!(err.contains(needle), "{args:?}: {err}");
    }
    common::assert_listing(d.path(), &["a.ls", "b.ls", "fifo"]);
}

/// A job's output that is one of the batch's inputs (another job's file,
/// the file of a seed range, the `--axiom` file) is not written: the later
/// jobs read it again, and what they read depended on `-j` (found by the
/// review helper). That job fails; the input and the other outputs stay.
#[test]
fn a_jobs_output_never_replaces_an_input_of_the_batch() {
    let sys = "productions:\nA -> AB\naxiom: A\n";
    for j in ["1", "2"] {
        let d = dir_with(&[
            ("2.ls", sys),
            ("b.ls", sys),
            ("b.txt.ls", sys),
            ("x.ls", sys),
            ("ax", "AA"),
        ]);
        let args = ["-j", j, "--seed", "1..3", "-o", "{seed}.ls", "2.ls"];
        input_not_replaced(d.path(), &args, "2.ls", "1 of 3");
        assert_eq!(read(d.path().join("2.ls")), sys);
        assert_eq!(read(d.path().join("1.ls")), "AB\n");
        assert_eq!(read(d.path().join("3.ls")), "AB\n");
        let r = lsgen_in(
            d.path(),
            &["-j", j, "-o", "{stem}.txt.ls", "b.ls", "b.txt.ls"],
        );
        assert!(r.fails(1).contains("1 of 2 jobs failed"));
        assert_eq!(read(d.path().join("b.txt.ls")), sys);
        assert_eq!(read(d.path().join("b.txt.txt.ls")), "AB\n");
        let r = lsgen_in(
            d.path(),
            &["-j", j, "--axiom", "ax", "-o", "{stem}", "b.ls", "2.ls"],
        );
        assert_eq!(r.ok(), "");
        assert_eq!(read(d.path().join("ax")), "AA");
        let r = lsgen_in(
            d.path(),
            &["-j", j, "--axiom", "ax", "-o", "a{stem}", "x.ls", "2.ls"],
        );
        let err = r.fails(1);
        assert!(
            err.contains("ax: error: cannot write: it is an input"),
            "{err}"
        );
        assert_eq!(read(d.path().join("ax")), "AA");
    }
}

/// `args` run in `dir`: the job whose output would be `name`, an input of
/// the batch, fails without writing it (`failed`: "1 of 3"); the others
/// finish.
fn input_not_replaced(dir: &Path, args: &[&str], name: &str, failed: &str) {
    let r = lsgen_in(dir, args);
    let err = r.fails(1);
    let refused = format!("{name}: error: cannot write: it is an input of this batch");
    assert!(err.contains(&refused), "{err}");
    assert!(err.contains(&format!("{failed} jobs failed")), "{err}");
}

/// A `.l` file's `#include`s, and `--cpfg-view`, are read again by every
/// job too: a job's output over one of them changed what the later jobs
/// read, and the exit status and the outputs depended on `-j` (found by
/// the review helper: exit 1 at `-j 1`, where job 2's output replaced
/// `2.h`, and 0 at `-j 4`). That job fails at every `-j`; the included
/// files and the other outputs stay.
#[test]
fn a_jobs_output_never_replaces_what_a_cpfg_file_includes() {
    for j in ["1", "2", "4"] {
        let d = dir_with(&[
            (
                "m.l",
                "Lsystem: 1\n#include \"2.h\"\nAxiom: F(X,Y)\nendlsystem\n",
            ),
            ("2.h", "#include \"inc/3.h\"\n#define X 7\n"),
            ("1.v", "angle factor: 8\n"),
        ]);
        std::fs::create_dir(d.path().join("inc")).unwrap();
        common::write(d.path(), "inc/3.h", "#define Y 5\n");
        let args = ["-j", j, "--seed", "1..4", "-o", "{seed}.h", "m.l"];
        input_not_replaced(d.path(), &args, "2.h", "1 of 4");
        assert_eq!(
            read(d.path().join("2.h")),
            "#include \"inc/3.h\"\n#define X 7\n"
        );
        for k in ["1", "3", "4"] {
            assert_eq!(read(d.path().join(format!("{k}.h"))), "F(7,5)\n", "-j {j}");
        }
        // A nested include, and the view file.
        let r = lsgen_in(
            d.path(),
            &["-j", j, "--seed", "2..3", "-o", "inc/{seed}.h", "m.l"],
        );
        assert!(r.fails(1).contains("inc/3.h: error: cannot write"));
        assert_eq!(read(d.path().join("inc/3.h")), "#define Y 5\n");
        assert_eq!(read(d.path().join("inc/2.h")), "F(7,5)\n");
        let r = lsgen_in(
            d.path(),
            &[
                "-j",
                j,
                "--cpfg-view",
                "1.v",
                "--seed",
                "1..2",
                "-o",
                "{seed}.v",
                "m.l",
            ],
        );
        assert!(r.fails(1).contains("1.v: error: cannot write"));
        assert_eq!(read(d.path().join("1.v")), "angle factor: 8\n");
        assert_eq!(read(d.path().join("2.v")), "F(7,5)\n");
    }
}

/// A `.l` file whose `#include` reads a pipe or a device gave the first
/// job what it read and the others nothing: their strings differed from
/// the single runs' with exit 0 (`#include "/dev/stdin"`), or the batch
/// waited forever (a FIFO nobody writes again; found by the review
/// helper). A usage error before any job, naming the file and what it
/// includes; nothing is read from it.
#[test]
fn an_include_of_a_pipe_in_a_batch_is_refused_before_any_job() {
    let d = dir_with(&[
        (
            "stdin.l",
            "Lsystem: 1\n#include \"/dev/stdin\"\nAxiom: F(X)\nendlsystem\n",
        ),
        (
            "fifo.l",
            "Lsystem: 1\n#include \"h/f\"\nAxiom: F(X)\nendlsystem\n",
        ),
        ("b.ls", "productions:\nA -> AB\naxiom: A\n"),
    ]);
    std::fs::create_dir(d.path().join("h")).unwrap();
    if !mkfifo(&d.path().join("h/f")) {
        return;
    }
    let cases: &[(&[&str], &str)] = &[
        (
            &["--seed", "1..2", "-o", "{seed}", "fifo.l"],
            "fifo.l includes h/f, which is not a regular file",
        ),
        (
            &["-o", "{stem}", "fifo.l", "b.ls"],
            "fifo.l includes h/f, which is not a regular file",
        ),
    ];
    // (Without a timeout a FIFO read would hang the test.)
    for (args, needle) in cases {
        let r = run(lsgen()
            .current_dir(d.path())
            .env_remove("LSGEN_JOBS")
            .args(["--max-length", "1k"])
            .args(*args));
        let err = r.fails(2);
        assert!(err.contains(needle), "{args:?}: {err}");
    }
    let mut child = lsgen()
        .current_dir(d.path())
        .args(["--seed", "1..4", "-o", "o{seed}", "stdin.l"])
        .stdin(std::process::Stdio::piped())
        .stdout(std::process::Stdio::null())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .unwrap();
    {
        use std::io::Write;
        let mut stdin = child.stdin.take().unwrap();
        stdin.write_all(b"#define X 7\n").unwrap();
    }
    let out = child.wait_with_output().unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{err}");
    assert!(
        err.contains("stdin.l includes /dev/stdin, which is not a regular file"),
        "{err}"
    );
    common::assert_listing(d.path(), &["b.ls", "fifo.l", "h", "stdin.l"]);
}

/// Each of `cases` (arguments, part of the message), run in `dir` at
/// `-j 1` and `-j 2`, is a usage error that writes nothing there.
fn refused_at_j_1_and_2(dir: &Path, cases: &[(&[&str], &str)]) {
    let before = common::listing(dir);
    for (args, needle) in cases {
        for j in ["1", "2"] {
            let mut a = args.to_vec();
            a.extend(["-j", j]);
            let r = lsgen_in(dir, &a);
            let err = r.fails(2);
            assert!(err.contains(needle), "{args:?}: {err}");
            assert_eq!(common::listing(dir), before, "{args:?}");
        }
    }
}

/// Two outputs the template names alike are a usage error before any job
/// runs (they used to replace each other, the last thread's winning, so
/// the files depended on -j): `{stem}{seed}` makes `a11` of a.ls seed 11
/// and a1.ls seed 1, `{n}{seed}` `111` of generation 1 seed 11 and
/// generation 11 seed 1. With a separator they are apart and all written.
#[test]
fn outputs_named_alike_are_refused_before_any_job() {
    let sys = "productions:\nA -> AB\naxiom: A\n";
    let d = dir_with(&[("a.ls", sys), ("a1.ls", sys)]);
    let cases: &[(&[&str], &str)] = &[
        (
            &[
                "-n",
                "2",
                "--seed",
                "1..11",
                "-o",
                "{stem}{seed}",
                "a.ls",
                "a1.ls",
            ],
            "a.ls (seed 11) and a1.ls (seed 1) would both write `a11`",
        ),
        (
            &[
                "--frames",
                "1..11",
                "--seed",
                "1..11",
                "-o",
                "{n}{seed}",
                "a.ls",
            ],
            "a.ls (seed 1, generation 11) and a.ls (seed 11, generation 1) would both write `111`",
        ),
    ];
    refused_at_j_1_and_2(d.path(), cases);
    common::assert_listing(d.path(), &["a.ls", "a1.ls"]);
    let r = lsgen_in(
        d.path(),
        &[
            "-n",
            "2",
            "--seed",
            "1..11",
            "-o",
            "{stem}-{seed}",
            "a.ls",
            "a1.ls",
        ],
    );
    r.ok();
    assert_eq!(std::fs::read_dir(d.path()).unwrap().count(), 2 + 22);
    assert_eq!(read(d.path().join("a1-1")), "ABB\n");
}

/// Names apart that lead to one file are refused before any job too: a
/// `..` after a varying directory, a linked directory, an output name
/// that is a link to another (`-o` follows it). They used to be written
/// one over the other, the last thread's winning. Outputs in directories
/// of their own are all written.
#[test]
fn outputs_that_are_one_file_are_refused_before_any_job() {
    use std::os::unix::fs::symlink;
    let sys = "productions:\nA -> AB\naxiom: A\n";
    let d = dir_with(&[("a.ls", sys), ("b.ls", sys)]);
    for sub in ["a", "b", "d1"] {
        std::fs::create_dir(d.path().join(sub)).unwrap();
    }
    symlink("d1", d.path().join("d2")).unwrap();
    symlink("o-1", d.path().join("o-2")).unwrap();
    symlink("o7-1", d.path().join("o7-2")).unwrap();
    let cases: &[(&[&str], &str)] = &[
        (
            &[
                "-o",
                "{stem}/../out-{seed}",
                "--seed",
                "1..2",
                "a.ls",
                "b.ls",
            ],
            "a.ls (seed 1) would write `a/../out-1` and b.ls (seed 1) `b/../out-1`, \
             which are one file",
        ),
        (
            &["-o", "d{seed}/x", "--seed", "1..3", "a.ls"],
            "a.ls (seed 1) would write `d1/x` and a.ls (seed 2) `d2/x`, which are one file",
        ),
        (
            &["-o", "o-{seed}", "--seed", "1..2", "a.ls"],
            "a.ls (seed 1) would write `o-1` and a.ls (seed 2) `o-2`, which are one file",
        ),
        (
            &[
                "-o",
                "o{seed}-{n}",
                "--frames",
                "1..2",
                "--seed",
                "7..8",
                "a.ls",
            ],
            "a.ls (seed 7, generation 1) would write `o7-1` and a.ls (seed 7, generation 2) \
             `o7-2`, which are one file",
        ),
    ];
    refused_at_j_1_and_2(d.path(), cases);
    for sub in ["a", "b", "d1"] {
        assert_eq!(std::fs::read_dir(d.path().join(sub)).unwrap().count(), 0);
    }
    lsgen_in(
        d.path(),
        &["-o", "{stem}/out-{seed}", "--seed", "1..2", "a.ls", "b.ls"],
    )
    .ok();
    for f in ["a/out-1", "a/out-2", "b/out-1", "b/out-2"] {
        assert_eq!(read(d.path().join(f)), "AB\n", "{f}");
    }
}

/// Two outputs that lead to one stream would mix their text: a FIFO
/// (two links to it), lsgen's own standard output under two names. Both
/// are refused before any job, as two names of one file are (they were
/// written at once, their lines cut into each other; found by the review
/// helper); a character device such as /dev/null takes any number.
#[test]
fn outputs_that_are_one_stream_are_refused_but_dev_null_is_shared() {
    use std::os::unix::fs::symlink;
    let sys = "productions:\nA -> AB\naxiom: A\n";
    let d = dir_with(&[("a.ls", sys)]);
    let st = std::process::Command::new("mkfifo")
        .arg(d.path().join("pipe"))
        .status()
        .unwrap();
    assert!(st.success());
    for (link, to) in [
        ("p-1", "pipe"),
        ("p-2", "pipe"),
        ("s-1", "/dev/stdout"),
        ("s-2", "/dev/fd/1"),
        ("n-1", "/dev/null"),
        ("n-2", "/dev/null"),
    ] {
        symlink(to, d.path().join(link)).unwrap();
    }
    let cases: &[(&[&str], &str)] = &[
        (
            &["-o", "p-{seed}", "--seed", "1..2", "a.ls"],
            "a.ls (seed 1) would write `p-1` and a.ls (seed 2) `p-2`, which are one file",
        ),
        // (Standard output is a pipe here, as `run` reads it.)
        (
            &["-o", "s-{seed}", "--seed", "1..2", "a.ls"],
            "a.ls (seed 1) would write `s-1` and a.ls (seed 2) `s-2`, which are one file",
        ),
    ];
    refused_at_j_1_and_2(d.path(), cases);
    let r = lsgen_in(d.path(), &["-o", "n-{seed}", "--seed", "1..2", "a.ls"]);
    r.ok();
}

/// Names that are not UTF-8 are names like any other: an `-o` template
/// with such bytes expands its placeholders (it used to be taken as a plain
/// name, and the batch refused), and stems keep their bytes (two stems
/// that differ only there used to be refused as one, and `{stem}` wrote
/// U+FFFD).
#[test]
fn names_that_are_not_utf8_are_templates_and_stems() {
    use std::ffi::OsStr;
    use std::os::unix::ffi::OsStrExt;
    let d = common::tempdir();
    let sys = "productions:\nA -> AB\naxiom: A\n";
    let name = |b: &[u8]| d.path().join(OsStr::from_bytes(b));
    std::fs::write(name(b"a\xff.ls"), sys).unwrap();
    std::fs::write(name(b"a\xfe.ls"), sys).unwrap();
    std::fs::create_dir(name(b"o\xe9")).unwrap();
    let r = run(lsgen()
        .current_dir(d.path())
        .env_remove("LSGEN_JOBS")
        .arg("-o")
        .arg(OsStr::from_bytes(b"o\xe9/{stem}-{seed}"))
        .args(["--seed", "1..2"])
        .arg(OsStr::from_bytes(b"a\xff.ls"))
        .arg(OsStr::from_bytes(b"a\xfe.ls")));
    r.assert_no_crash();
    assert_eq!(r.code(), Some(0), "{}", r.stderr);
    for out in [
        &b"o\xe9/a\xff-1"[..],
        b"o\xe9/a\xff-2",
        b"o\xe9/a\xfe-1",
        b"o\xe9/a\xfe-2",
    ] {
        assert_eq!(read(name(out)), "AB\n", "{}", String::from_utf8_lossy(out));
    }
    assert_eq!(std::fs::read_dir(name(b"o\xe9")).unwrap().count(), 4);
    // A typo is refused there too.
    let r = run(lsgen()
        .current_dir(d.path())
        .arg("-o")
        .arg(OsStr::from_bytes(b"o\xe9/{sed}"))
        .args(["--seed", "1..2"])
        .arg(OsStr::from_bytes(b"a\xff.ls")));
    r.assert_no_crash();
    assert!(r.fails(2).contains("{sed}"), "{}", r.stderr);
}

/// A template that makes a job's name `-` (`{stem}` of `-.ls`) names a
/// file: only `-o -` is standard output (the job's string used to go
/// there, in a batch, which refuses standard input).
#[test]
fn a_job_named_dash_writes_a_file() {
    let d = dir_with(&[("-.ls", "axiom:\nF\n"), ("x.ls", "axiom:\nG\n")]);
    let r = lsgen_in(d.path(), &["-o", "{stem}", "./-.ls", "x.ls"]);
    assert_eq!(r.ok(), "");
    assert_eq!(read(d.path().join("-")), "F\n");
    assert_eq!(read(d.path().join("x")), "G\n");
}

#[test]
fn lsgen_jobs_is_read_from_the_environment() {
    let d = dir_with(&[("a.ls", "productions:\nA -> AB\naxiom: A\n")]);
    let r = run(lsgen()
        .current_dir(d.path())
        .env("LSGEN_JOBS", "zero")
        .arg("a.ls"));
    // The message names the variable, not `--jobs` (which was not given).
    assert_eq!(
        r.fails(2),
        "lsgen: error: LSGEN_JOBS=`zero`: the number of threads must be a whole number \
         from 1 to 4096 (or unset or empty: all CPUs)\n"
    );
    for bad in ["0", "4097", " 2", "-1"] {
        let r = run(lsgen()
            .current_dir(d.path())
            .env("LSGEN_JOBS", bad)
            .arg("a.ls"));
        assert!(
            r.fails(2)
                .starts_with(&format!("lsgen: error: LSGEN_JOBS=`{bad}`: ")),
            "{bad}: {}",
            r.stderr
        );
    }
    // Not UTF-8: the value shown lossily, still a usage error of the variable.
    #[cfg(unix)]
    {
        use std::os::unix::ffi::OsStrExt;
        let r = run(lsgen()
            .current_dir(d.path())
            .env("LSGEN_JOBS", std::ffi::OsStr::from_bytes(b"\xff"))
            .arg("a.ls"));
        assert!(
            r.fails(2)
                .starts_with("lsgen: error: LSGEN_JOBS=`\u{fffd}`: "),
            "{}",
            r.stderr
        );
    }
    // `-j` wins over the variable, which is then not looked at; an empty
    // variable is not set.
    for (var, args) in [("zero", &["-j", "2"][..]), ("", &[][..]), ("3", &[][..])] {
        let r = run(lsgen()
            .current_dir(d.path())
            .env("LSGEN_JOBS", var)
            .args(args)
            .args(["-n", "2", "a.ls"]));
        assert_eq!(r.ok(), "ABB\n", "LSGEN_JOBS={var:?} {args:?}");
    }
}

#[test]
fn verbose_groups_digits() {
    let d = dir_with(&[("d.ls", "productions:\nF -> FF\naxiom: F\n")]);
    let r = lsgen_in(d.path(), &["-v", "-n", "10", "-o", "out", "d.ls"]);
    assert_eq!(r.code(), Some(0), "{}", r.stderr);
    assert!(
        r.stderr.contains("step 10: 1,024 modules, 1,024 bytes\n"),
        "{}",
        r.stderr
    );
}

#[test]
fn verbose_prints_counts_past_u64_as_a_lower_bound() {
    // 2^63 fits, 2^64 does not: its count is a lower bound, never a
    // saturated value presented as exact. /dev/full stops the writing.
    let d = dir_with(&[("d.ls", "productions:\nF -> FF\naxiom: F\n")]);
    let r = lsgen_in(
        d.path(),
        &[
            "-v",
            "-n",
            "70",
            "--strategy",
            "dfs",
            "-o",
            "/dev/full",
            "d.ls",
        ],
    );
    assert_eq!(r.code(), Some(1), "{}", r.stderr);
    assert!(
        r.stderr
            .contains("step 63: 9,223,372,036,854,775,808 modules"),
        "{}",
        r.stderr
    );
    assert!(
        r.stderr
            .contains("step 64: >= 18,446,744,073,709,551,615 modules"),
        "{}",
        r.stderr
    );
    assert!(!r.stderr.contains(" 18446744073709551615"), "{}", r.stderr);
}

// ---------------------------------------------------------------- runaway guard

const DOUBLING: &str = "productions:\nF -> FF\naxiom: F\n";

#[test]
fn a_string_larger_than_the_free_space_is_refused_before_writing() {
    // F -> FF: 2^10 modules and a newline = 1025 bytes, by hand.
    let d = dir_with(&[("d.ls", DOUBLING), ("out.txt", "old\n")]);
    let guarded = |free: &str, n: &str| {
        let r = run(lsgen()
            .current_dir(d.path())
            .env("LSGEN_TEST_FREE_BYTES", free)
            .args(["-n", n, "-o", "out.txt", "d.ls"]));
        r.assert_no_crash();
        r
    };
    let r = guarded("1024", "10");
    assert_eq!(
        r.fails(1),
        "lsgen: out.txt: error: the final string would be 1,025 bytes, more than the \
         1,024 bytes free on its file system: nothing written (fewer steps; --max-length \
         stops any run early)\n"
    );
    assert_eq!(read(d.path().join("out.txt")), "old\n");
    common::assert_listing(d.path(), &["d.ls", "out.txt"]);
    // Past u64: a lower bound, not a saturated size.
    let r = guarded("1024", "80");
    assert!(
        r.fails(1)
            .contains("would be more than 18,446,744,073,709,551,615 bytes"),
        "{}",
        r.stderr
    );
    // Exactly enough room: written.
    guarded("1025", "10").ok();
    assert_eq!(read(d.path().join("out.txt")).len(), 1025);
    common::assert_listing(d.path(), &["d.ls", "out.txt"]);
}

#[test]
fn the_homomorphism_counts_in_the_final_size() {
    // F -> FG, G -> G; homomorphism G -> XYZ. After 3 steps: F G G G, so
    // F XYZ XYZ XYZ = 10 bytes and a newline, by hand.
    let src = "productions:\nF -> FG\nhomomorphism:\nG -> XYZ\naxiom: F\n";
    let d = dir_with(&[("h.ls", src)]);
    let r = run(lsgen()
        .current_dir(d.path())
        .env("LSGEN_TEST_FREE_BYTES", "10")
        .args(["-n", "3", "-o", "o", "h.ls"]));
    assert!(
        r.fails(1)
            .contains("would be 11 bytes, more than the 10 bytes"),
        "{}",
        r.stderr
    );
    let r = run(lsgen()
        .current_dir(d.path())
        .env("LSGEN_TEST_FREE_BYTES", "11")
        .args(["-n", "3", "-o", "o", "h.ls"]));
    r.ok();
    assert_eq!(read(d.path().join("o")), "FXYZXYZXYZ\n");
}

/// The real statvfs, on a 64 KiB tmpfs; needs root (to mount), else it
/// says so and checks nothing.
#[test]
fn free_space_guard_on_a_small_tmpfs() {
    let d = dir_with(&[("d.ls", DOUBLING)]);
    let mnt = d.path().join("mnt");
    std::fs::create_dir(&mnt).unwrap();
    let mounted = std::process::Command::new("mount")
        .args(["-t", "tmpfs", "-o", "size=64k", "tmpfs"])
        .arg(&mnt)
        .stderr(std::process::Stdio::null())
        .status()
        .is_ok_and(|s| s.success());
    if !mounted {
        eprintln!("free_space_guard_on_a_small_tmpfs: cannot mount a tmpfs (not root?): skipped");
        return;
    }
    struct Unmount<'a>(&'a Path);
    impl Drop for Unmount<'_> {
        fn drop(&mut self) {
            let _ = std::process::Command::new("umount").arg(self.0).status();
        }
    }
    let _guard = Unmount(&mnt);
    // 2^16 + 1 bytes do not fit in 64 KiB; 2^15 + 1 do.
    let r = lsgen_in(d.path(), &["-n", "16", "-o", "mnt/big", "d.ls"]);
    let err = r.fails(1);
    assert!(
        err.starts_with(
            "lsgen: mnt/big: error: the final string would be 65,537 bytes, more than the "
        ),
        "{err}"
    );
    common::assert_listing(&mnt, &[]);
    lsgen_in(d.path(), &["-n", "15", "-o", "mnt/small", "d.ls"]).ok();
    assert_eq!(std::fs::metadata(mnt.join("small")).unwrap().len(), 32769);
}

#[test]
fn check_takes_several_files_without_a_template() {
    let d = dir_with(&[
        ("a.ls", "productions:\nA -> AB\naxiom: A\n"),
        ("b.ls", "productions:\nA -> B(\naxiom: A\n"),
    ]);
    let r = lsgen_in(d.path(), &["--check", "a.ls", "a.ls"]);
    assert_eq!(r.ok(), "");
    let r = lsgen_in(d.path(), &["--check", "a.ls", "b.ls"]);
    let err = r.fails(1);
    assert!(err.contains("b.ls:2:"), "{err}");
    assert!(err.ends_with("lsgen: error: 1 of 2 jobs failed\n"), "{err}");
}

#[test]
fn an_output_name_that_is_not_utf8_still_works() {
    use std::os::unix::ffi::OsStrExt;
    let d = dir_with(&[("a.ls", "productions:\nA -> AB\naxiom: A\n")]);
    // A template like any other: `{{x}}` is `{x}`.
    let name = std::ffi::OsStr::from_bytes(b"out\xff{{x}}");
    let r = run(lsgen()
        .current_dir(d.path())
        .args(["-n", "2", "-o"])
        .arg(name)
        .arg("a.ls"));
    assert_eq!(r.ok(), "");
    let file = std::ffi::OsStr::from_bytes(b"out\xff{x}");
    assert_eq!(read(d.path().join(file)), "ABB\n");
}

#[test]
fn a_failing_job_names_the_seed_it_used() {
    // No --seed: the job's seed is its file's `seed:`.
    let bad = format!("seed: 42\n{DIV_AT_STEP_2}");
    let d = dir_with(&[
        ("bad.ls", bad.as_str()),
        ("ok.ls", "productions:\nA -> AB\naxiom: A\n"),
    ]);
    let r = lsgen_in(
        d.path(),
        &["-n", "3", "-o", "{stem}.out", "bad.ls", "ok.ls"],
    );
    let err = r.fails(1);
    assert!(
        err.starts_with(
            "lsgen: bad.ls:4:20: error: division by zero (in step 2) [job bad.ls (seed 42)]\n"
        ),
        "{err}"
    );
    assert_eq!(read(d.path().join("ok.out")), "ABBB\n");
}

#[test]
fn a_files_warning_is_said_once_for_all_its_jobs() {
    // `x` is not defined (cpfg: 0, with a warning at 4:10). Every job of
    // the batch loads the file; the warning is said once per file.
    let src = "#define N 1\nLsystem: 1\nderivation length: 2\nAxiom: A(x)\n\
               A(y) --> A(y+1)\nendlsystem\n";
    let d = dir_with(&[("w.l", src), ("v.l", src)]);
    for j in ["1", "2"] {
        let out = format!("{{stem}}-{{seed}}-j{j}.txt");
        let r = lsgen_in(
            d.path(),
            &["--seed", "1..4", "-j", j, "-o", &out, "w.l", "v.l"],
        );
        assert_eq!(r.code(), Some(0), "{}", r.stderr);
        assert!(r.stdout.is_empty());
        for f in ["w.l", "v.l"] {
            let head = format!("lsgen: {f}:4:10: warning: `x` is not defined");
            assert_eq!(r.stderr.matches(&head).count(), 1, "-j {j}:\n{}", r.stderr);
        }
        assert_eq!(
            r.stderr.matches("warning").count(),
            2,
            "-j {j}:\n{}",
            r.stderr
        );
        assert_eq!(read(d.path().join(format!("w-3-j{j}.txt"))), "A(2)\n");
    }
}

/// A batch prints the first 1,000 failures in job order and counts the
/// rest (it used to hold every failed job's error until the end: 550
/// bytes each, 220 MB for 400,000 failing seeds).
#[test]
fn a_batch_keeps_the_first_thousand_failures() {
    let d = dir_with(&[("a.ls", "axiom: A\n")]);
    let r = lsgen_in(
        d.path(),
        &["-q", "--seed", "1..1500", "-o", "nodir/{seed}", "a.ls"],
    );
    assert_eq!(r.code(), Some(1), "{}", r.stderr);
    let lines: Vec<&str> = r.stderr.lines().collect();
    assert_eq!(lines.len(), 1002, "{}", r.stderr);
    for (k, l) in lines[..1000].iter().enumerate() {
        assert!(
            l.starts_with(&format!("lsgen: nodir/{}: error: ", k + 1))
                && l.ends_with(&format!("(seed {})]", k + 1)),
            "{l}"
        );
    }
    assert_eq!(
        lines[1000],
        "lsgen: ... and 500 more failed jobs, not shown (the first 1,000 are)"
    );
    assert_eq!(lines[1001], "lsgen: error: 1,500 of 1,500 jobs failed");
}

/// Jobs that fail with the same error (a mistake in the file, met by
/// every seed's job) print it once, at the first of them, with how many
/// others did and the last one; other errors print as before, in job
/// order. It used to print the same error and source line once per seed.
#[test]
fn the_same_error_in_many_jobs_is_printed_once() {
    let d = dir_with(&[
        ("bad.ls", "productions:\nAB -> C\naxiom: A\n"),
        ("div.ls", "productions:\nA(x) -> B(1/x)\naxiom: A(0)\n"),
        ("ok.ls", "axiom: A\n"),
    ]);
    std::fs::create_dir(d.path().join("out")).unwrap();
    for j in ["1", "2", "4"] {
        let r = lsgen_in(
            d.path(),
            &[
                "-j",
                j,
                "--seed",
                "1..40",
                "-o",
                "out/{stem}-{seed}",
                "bad.ls",
                "ok.ls",
                "div.ls",
            ],
        );
        let err = r.fails(1);
        assert_eq!(
            err,
            "lsgen: bad.ls:2:2: error: a predecessor is one module; use `<` and `>` for contexts [job bad.ls (seed 1)]\n\
             AB -> C\n\
             \x20^\n\
             lsgen: the same error in 39 more jobs, the last bad.ls (seed 40)\n\
             lsgen: div.ls:2:11: error: division by zero (in step 1) [job div.ls (seed 1)]\n\
             A(x) -> B(1/x)\n\
             \x20         ^\n\
             lsgen: the same error in 39 more jobs, the last div.ls (seed 40)\n\
             lsgen: error: 80 of 120 jobs failed\n",
            "-j {j}"
        );
        let r = lsgen_in(
            d.path(),
            &[
                "-j",
                j,
                "--seed",
                "7..8",
                "-o",
                "out/{stem}-{seed}",
                "bad.ls",
            ],
        );
        assert!(
            r.fails(1).contains(
                "\nlsgen: the same error in job bad.ls (seed 8)\nlsgen: error: 2 of 2 jobs failed\n"
            ),
            "-j {j}: {}",
            r.stderr
        );
    }
}
