//! One string on several threads (`-j N`, `LSGEN_JOBS`; issue 15): the
//! output, or the error, is byte-identical for every thread count. The
//! one-thread strings are checked against the reference elsewhere
//! (`tests/differential.rs`, `tests/examples.rs`); expected strings here
//! are derived by hand.

mod common;

use common::{lsgen, run, run_ls, tempdir, ROOT};
use std::path::{Path, PathBuf};

/// Every `.ls` file of `examples/` and `benches/workloads/`.
fn systems() -> Vec<PathBuf> {
    let mut v = Vec::new();
    for dir in ["examples", "benches/workloads"] {
        for e in std::fs::read_dir(Path::new(ROOT).join(dir)).unwrap() {
            let p = e.unwrap().path();
            if p.extension().is_some_and(|x| x == "ls") {
                v.push(p);
            }
        }
    }
    v.sort();
    assert!(v.len() > 40, "{v:?}");
    v
}

/// stdout, stderr and exit status of lsgen with `args` on `-j` threads,
/// split into tiny tasks (`LSGEN_TEST_SPLIT`: 5 modules per thread depth
/// first, chunks of 5 bytes step by step) so that small strings split.
fn on(threads: &str, args: &[&str], file: &Path) -> (Vec<u8>, String, Option<i32>) {
    let r = run(lsgen()
        .env("LSGEN_TEST_SPLIT", "5")
        .args(["-j", threads])
        .args(args)
        .arg(file));
    r.assert_no_crash();
    let code = r.code();
    (r.stdout, r.stderr, code)
}

#[test]
fn every_example_is_the_same_on_1_2_and_8_threads() {
    for file in systems() {
        // The file's own length and seed, two other seeds, and for the
        // deterministic parametric ones 8 steps (split at a deeper
        // generation).
        let mut lengths = vec![vec![], vec!["--seed", "1"], vec!["--seed", "99"]];
        let text = std::fs::read_to_string(&file).unwrap();
        if text.contains('(') && !text.contains('<') && !text.contains('>') {
            lengths.push(vec!["-n", "8"]);
        }
        for args in lengths {
            let one = on("1", &args, &file);
            assert_eq!(one.2, Some(0), "{}: {}", file.display(), one.1);
            for j in ["2", "8"] {
                let many = on(j, &args, &file);
                assert!(
                    one == many,
                    "{} {args:?}: -j {j} differs from -j 1 ({} and {} bytes; {})",
                    file.display(),
                    one.0.len(),
                    many.0.len(),
                    many.1
                );
            }
        }
    }
}

#[test]
fn a_large_parametric_tree_is_the_same_on_1_2_and_8_threads() {
    // About 10 MB of text: split at a deep generation, into many tasks,
    // each block of text passing through the writer in order.
    let dir = tempdir();
    let file = Path::new(ROOT).join("benches/workloads/parametric_tree.ls");
    let mut outs = Vec::new();
    for j in ["1", "2", "8"] {
        let o = dir.path().join(format!("j{j}.txt"));
        let r = run(lsgen().args(["-n", "11", "-j", j, "-o"]).arg(&o).arg(&file));
        assert_eq!(r.ok(), "");
        outs.push(std::fs::read(&o).unwrap());
    }
    assert!(outs[0].len() > 5_000_000, "{}", outs[0].len());
    assert!(outs[0] == outs[1] && outs[0] == outs[2]);
    // LSGEN_JOBS sets the thread count too; --precision filters the same
    // text whatever the threads.
    let r = run(lsgen().env("LSGEN_JOBS", "2").args(["-n", "11"]).arg(&file));
    assert!(r.ok().as_bytes() == outs[0]);
    let p = |j: &str| {
        let r = run(lsgen()
            .args(["-n", "9", "--precision", "3", "-j", j])
            .arg(&file));
        r.ok()
    };
    assert_eq!(p("1"), p("8"));
}

#[test]
fn a_hand_derived_string_on_many_threads() {
    // A(0) -> A(1)[B] -> A(2)[B][BB] -> A(2)[BB][BBBB]... with A(x) : x >= 2
    // staying: after 4 steps A(2)[BBBB][BBBBBBBB].
    let src = "productions:\nA(x) : x < 2 -> A(x+1)[B]\nB -> BB\naxiom: A(0)\n";
    for j in ["1", "2", "8"] {
        let r = run_ls(src, &["-n", "4", "-j", j]);
        assert_eq!(r.ok(), "A(2)[BBBB][BBBBBBBB]\n", "-j {j}");
    }
}

#[test]
fn the_first_error_in_step_order_whatever_the_threads() {
    // Depth first, A's subtree reaches its error (step 3: A(2) divides by
    // 2-2) before D(0) is looked at; but D(0) divides by zero in step 1,
    // the earliest step: that is the error (at the division, column 11), on
    // any number of threads, and no output file is left.
    let src = "productions:\nA(x) -> A(x+1)B(1/(2-x))\nD(x) -> D(1/x)\naxiom: A(0)D(0)\n";
    let dir = tempdir();
    let p = common::write(dir.path(), "p.ls", src);
    let o = dir.path().join("out.txt");
    let mut errors = Vec::new();
    for j in ["1", "2", "8"] {
        let r = run(lsgen().args(["-n", "5", "-j", j, "-o"]).arg(&o).arg(&p));
        let err = r.one_error().to_string();
        assert!(
            err.contains("p.ls:3:11: error: division by zero (in step 1)\nD(x) -> D(1/x)\n"),
            "-j {j}: {err}"
        );
        assert!(!o.exists());
        errors.push(err);
    }
    assert_eq!(errors[0], errors[1]);
    assert_eq!(errors[0], errors[2]);
}

#[test]
fn jobs_must_be_a_positive_count() {
    let dir = tempdir();
    let p = common::write(dir.path(), "p.ls", "axiom: A\n");
    for bad in ["0", "x"] {
        let r = run(lsgen().args(["-j", bad]).arg(&p));
        r.fails(2);
    }
}

#[test]
fn a_stochastic_plant_is_the_same_on_1_2_and_8_threads() {
    // Step by step in chunks of 256 KiB: about 4 MB of text, each
    // generation cut into several chunks whose draws are placed by module
    // index.
    let file = Path::new(ROOT).join("examples/stochastic_plant.ls");
    let text = |j: &str| {
        run(lsgen()
            .args(["-n", "11", "--seed", "7", "-j", j])
            .arg(&file))
        .ok()
    };
    let one = text("1");
    assert!(one.len() > 2_000_000, "{}", one.len());
    assert!(one == text("2"));
    assert!(one == text("8"));
}

#[test]
fn the_first_error_of_a_split_step_whatever_the_threads() {
    // Step by step (a probability), in chunks: in step 2, B(0) divides by
    // 0 - 0; the first such B in string order is the one reported, with
    // its step, on any number of threads.
    let src = "productions:\nA -> A[B(0)]A : 1\nA -> A : 1\nB(x) -> B(1/(x-x))\naxiom: AAAAAAAAAAAAAAAA\n";
    let mut errors = Vec::new();
    for j in ["1", "2", "8"] {
        let dir = tempdir();
        let p = common::write(dir.path(), "p.ls", src);
        let r = run(lsgen()
            .env("LSGEN_TEST_SPLIT", "3")
            .args(["-n", "4", "--seed", "1", "-j", j])
            .arg(&p));
        let err = r.one_error().to_string();
        assert!(
            err.contains("p.ls:4:11: error: division by zero (in step 2)\nB(x) -> B(1/(x-x))\n"),
            "-j {j}: {err}"
        );
        errors.push(err.replace(&p.display().to_string(), "p.ls"));
    }
    assert_eq!(errors[0], errors[1]);
    assert_eq!(errors[0], errors[2]);
}

#[test]
fn memory_stays_flat_while_the_reader_of_the_output_waits() {
    // The output goes to a pipe that is not read for 2 seconds: the
    // workers ahead of the writer must wait (bounded channels), not buffer
    // the tens of MB they could derive meanwhile. Peak RSS by GNU time.
    let time = Path::new("/usr/bin/time");
    assert!(time.exists(), "these tests need GNU time at /usr/bin/time");
    let dir = tempdir();
    for (file, n) in [
        ("parametric_tree.ls", "13"),  // depth first, about 78 MB
        ("stochastic_plant.ls", "13"), // step by step, about 40 MB
    ] {
        let rss = dir.path().join("rss.txt");
        let model = Path::new(ROOT).join("benches/workloads").join(file);
        let script = format!(
            "/usr/bin/time -f %M -o '{}' '{}' -j 2 -n {n} --seed 1 '{}' | (sleep 2; cat >/dev/null)",
            rss.display(),
            common::LSGEN,
            model.display()
        );
        let r = run(common::command("sh").args(["-c", &script]));
        assert_eq!(r.ok(), "", "{file}");
        let text = std::fs::read_to_string(&rss).unwrap();
        let kib: u64 = text.trim().lines().last().unwrap().parse().unwrap();
        assert!(kib < 40 * 1024, "{file}: peak RSS {kib} KiB");
    }
}

/// The debug lines of `LSGEN_DEBUG_PAR=1` in `stderr`: the bytes the
/// workers spilled and the tasks that failed after spilling; and the rest
/// of `stderr`.
fn spill_report(stderr: &str) -> (u64, u64, String) {
    let (mut bytes, mut failed, mut rest) = (0, 0, String::new());
    for line in stderr.split_inclusive('\n') {
        if !line.starts_with("lsgen: par: ") {
            rest.push_str(line);
            continue;
        }
        let words: Vec<&str> = line.split_whitespace().collect();
        for (i, w) in words.iter().enumerate() {
            if *w == "spilled" && words.get(i + 2) == Some(&"bytes,") {
                bytes += words[i + 1].parse::<u64>().unwrap();
            }
            if *w == "failed" && i > 0 && words.get(i + 1) == Some(&"after") {
                failed += words[i - 1].parse::<u64>().unwrap();
            }
        }
    }
    (bytes, failed, rest)
}

#[test]
fn text_spilled_ahead_of_the_writer_is_the_same_and_leaves_no_file() {
    // Blocks of 64 bytes, one kept in memory ahead of the writer
    // (LSGEN_TEST_SPILL): the tasks the writer has not reached spill
    // their text to unnamed files in --tmpdir, copied out in order; the
    // same bytes as one thread, and nothing left in the directory.
    let dir = tempdir();
    let tmp = dir.path().join("tmp");
    std::fs::create_dir(&tmp).unwrap();
    for (file, args) in [
        ("benches/workloads/parametric_tree.ls", &["-n", "11"][..]),
        (
            "examples/stochastic_plant.ls",
            &["-n", "7", "--seed", "3"][..],
        ),
    ] {
        let file = Path::new(ROOT).join(file);
        let one = run(lsgen().args(["-j", "1"]).args(args).arg(&file)).ok();
        assert!(one.len() > 10_000, "{}", one.len());
        let mut spilled = 0;
        for j in ["2", "8"] {
            let r = run(lsgen()
                .env("LSGEN_TEST_SPLIT", "5")
                .env("LSGEN_TEST_SPILL", "64")
                .env("LSGEN_DEBUG_PAR", "1")
                .args(["-j", j, "--tmpdir"])
                .arg(&tmp)
                .args(args)
                .arg(&file));
            assert_eq!(r.code(), Some(0), "{}", r.stderr);
            let (bytes, _, rest) = spill_report(&r.stderr);
            assert_eq!(rest, "", "{}", file.display());
            assert!(one.as_bytes() == r.stdout, "{} -j {j}", file.display());
            spilled += bytes;
            let left: Vec<_> = std::fs::read_dir(&tmp).unwrap().collect();
            assert!(left.is_empty(), "{left:?}");
        }
        assert!(spilled > 0, "{}: nothing spilled", file.display());
    }
}

#[test]
fn an_error_in_a_task_that_spilled_is_the_first_error() {
    // Step by step (probabilities): C(0) reaches C(9) in step 10 and
    // divides by 9 - 9 there, in the middle of a generation of about
    // 10^5 modules; the chunk holding it has spilled text before the
    // error when the writer has not reached it. The error is the one of
    // one thread; no output file, nothing in --tmpdir.
    let src = "productions:\nF -> FF : 1\nF -> F[+F] : 1\nC(x) : x < 9 -> C(x+1)\n\
               C(x) : x >= 9 -> C(1/(x-x))\naxiom: FFFFFFFFC(0)FFFFFFFF\n";
    let dir = tempdir();
    let p = common::write(dir.path(), "p.ls", src);
    let tmp = dir.path().join("tmp");
    std::fs::create_dir(&tmp).unwrap();
    let o = dir.path().join("out.txt");
    let one = run(lsgen()
        .args(["-n", "12", "--seed", "5", "-j", "1", "-o"])
        .arg(&o)
        .arg(&p));
    let one = one.one_error().to_string();
    assert!(
        one.contains("p.ls:5:20: error: division by zero (in step 10)\n"),
        "{one}"
    );
    let mut failed_after_spilling = 0;
    for attempt in 0..10 {
        for j in ["2", "8"] {
            let r = run(lsgen()
                .env("LSGEN_TEST_SPLIT", "1000")
                .env("LSGEN_TEST_SPILL", "64")
                .env("LSGEN_DEBUG_PAR", "1")
                .args(["-n", "12", "--seed", "5", "-j", j, "--tmpdir"])
                .arg(&tmp)
                .arg("-o")
                .arg(&o)
                .arg(&p));
            assert_eq!(r.code(), Some(1), "{}", r.stderr);
            let (_, failed, rest) = spill_report(&r.stderr);
            assert_eq!(rest, one, "-j {j}");
            assert!(!o.exists());
            let left: Vec<_> = std::fs::read_dir(&tmp).unwrap().collect();
            assert!(left.is_empty(), "{left:?}");
            failed_after_spilling += failed;
        }
        if failed_after_spilling > 0 && attempt > 0 {
            break;
        }
    }
    assert!(failed_after_spilling > 0, "no failing task had spilled");
}
