//! The example L-systems, run through the real `lsgen` binary and compared
//! with the expected outputs in `tests/expected/` (made by the independent
//! Python reference `tests/tools/ref.py`), plus the headline facts of the
//! classic examples.

mod common;

use common::{lsgen_in_root, run, ROOT};
use std::path::{Path, PathBuf};

/// Run `lsgen` from the repository root with no standard input; insist on
/// a clean exit, no panic and nothing on stderr, and return standard output.
fn lsgen_ok(args: &[&str]) -> String {
    run(lsgen_in_root().args(args)).ok()
}

/// The output line without its newline (and checking there is exactly one).
fn line(out: &str) -> &str {
    let s = out
        .strip_suffix('\n')
        .unwrap_or_else(|| panic!("output does not end with a newline: {out:?}"));
    assert!(!s.contains('\n'), "output has more than one line");
    s
}

fn expected_dir() -> PathBuf {
    Path::new(ROOT).join("tests").join("expected")
}

/// `NAME.nN.txt` -> (NAME, N).
fn parse_expected_name(file: &str) -> Option<(String, u64)> {
    let stem = file.strip_suffix(".txt")?;
    let (name, n) = stem.rsplit_once(".n")?;
    Some((name.to_string(), n.parse().ok()?))
}

fn expected(name: &str, n: u64) -> String {
    let p = expected_dir().join(format!("{name}.n{n}.txt"));
    std::fs::read_to_string(&p).unwrap_or_else(|e| panic!("cannot read {}: {e}", p.display()))
}

/// First byte where two strings differ, for readable failure messages.
fn first_difference(a: &str, b: &str) -> usize {
    a.bytes()
        .zip(b.bytes())
        .position(|(x, y)| x != y)
        .unwrap_or(a.len().min(b.len()))
}

fn excerpt(s: &str, at: usize) -> String {
    let from = at.saturating_sub(30);
    let to = (at + 30).min(s.len());
    String::from_utf8_lossy(&s.as_bytes()[from..to]).into_owned()
}

#[test]
fn every_expected_file_matches() {
    let mut entries: Vec<_> = std::fs::read_dir(expected_dir())
        .expect("tests/expected")
        .map(|e| e.unwrap().file_name().into_string().unwrap())
        .filter(|f| f.ends_with(".txt"))
        .collect();
    entries.sort();
    assert!(
        entries.len() >= 50,
        "only {} expected files found",
        entries.len()
    );
    let mut failures = Vec::new();
    for file in &entries {
        let (name, n) = parse_expected_name(file)
            .unwrap_or_else(|| panic!("tests/expected/{file} is not named NAME.nN.txt"));
        let example = format!("examples/{name}.ls");
        assert!(
            Path::new(ROOT).join(&example).is_file(),
            "tests/expected/{file}: there is no {example}"
        );
        let want = expected(&name, n);
        let out = run(lsgen_in_root().args(["-n", &n.to_string(), &example]));
        out.assert_no_crash();
        let got = String::from_utf8_lossy(&out.stdout);
        let stderr = &out.stderr;
        if out.code() != Some(0) || !stderr.is_empty() {
            failures.push(format!(
                "tests/expected/{file}: `lsgen -n {n} {example}` exited with {:?}:\n{stderr}",
                out.code()
            ));
        } else if got != want {
            let at = first_difference(&got, &want);
            failures.push(format!(
                "tests/expected/{file}: `lsgen -n {n} {example}` differs at byte {at} \
                 (got {} bytes, want {}):\n  got:  {:?}\n  want: {:?}",
                got.len(),
                want.len(),
                excerpt(&got, at),
                excerpt(&want, at)
            ));
        }
    }
    assert!(
        failures.is_empty(),
        "{} of {} expected outputs differ:\n{}",
        failures.len(),
        entries.len(),
        failures.join("\n")
    );
}

#[test]
fn algae_lengths_are_fibonacci_numbers() {
    // a -> ab, b -> a from the axiom a: lengths 1, 2, 3, 5, 8, ...
    let (mut a, mut b) = (1usize, 2usize);
    for n in 0..=20u64 {
        let out = lsgen_ok(&["-n", &n.to_string(), "examples/algae.ls"]);
        let s = line(&out);
        assert!(s.bytes().all(|c| c == b'a' || c == b'b'), "n={n}: {s:?}");
        assert_eq!(s.len(), a, "algae after {n} steps");
        (a, b) = (b, a + b);
    }
}

#[test]
fn algae_first_generations() {
    let want = ["a", "ab", "aba", "abaab", "abaababa", "abaababaabaab"];
    for (n, w) in want.iter().enumerate() {
        let out = lsgen_ok(&["-n", &n.to_string(), "examples/algae.ls"]);
        assert_eq!(line(&out), *w, "algae after {n} steps");
    }
}

#[test]
fn koch_snowflake_length_is_7_times_4_to_the_n() {
    let mut prev = String::new();
    for n in 0..=7u32 {
        let out = lsgen_ok(&["-n", &n.to_string(), "examples/koch_snowflake.ls"]);
        let s = line(&out);
        assert_eq!(s.len(), 7 * 4usize.pow(n), "snowflake after {n} steps");
        assert!(s.bytes().all(|c| b"F+-".contains(&c)), "n={n}");
        assert_eq!(s.bytes().filter(|&c| c == b'F').count(), 3 * 4usize.pow(n));
        if n == 0 {
            assert_eq!(s, "F--F--F");
        } else {
            // Each F of the previous generation became F+F--F+F.
            assert_eq!(s, prev.replace('F', "F+F--F+F"), "n={n}");
        }
        prev = s.to_string();
    }
}

#[test]
fn parametric_abop_1_10_at_default_length() {
    // ABOP p. 43: B(2)A(4,4) => ... => CB(1)A(8,7) after 4 steps, and the
    // homomorphism C -> F(R) with R = 1.456.
    let out = lsgen_ok(&["examples/parametric.ls"]);
    assert_eq!(out, "F(1.456)B(1)A(8,7)\n");
    assert_eq!(out, expected("parametric", 4));
}

#[test]
fn parametric_abop_1_10_derivation() {
    let steps = [
        "B(2)A(4,4)",
        "B(1)B(4)A(1,0)",
        "B(0)B(3)A(2,1)",
        "CB(2)A(4,3)",
        "CB(1)A(8,7)",
    ];
    for (n, want) in steps.iter().enumerate() {
        let out = lsgen_ok(&[
            "-n",
            &n.to_string(),
            "--no-homomorphism",
            "examples/parametric.ls",
        ]);
        assert_eq!(line(&out), *want, "after {n} steps");
    }
}

#[test]
fn signal_moves_one_cell_per_step() {
    let want = ["baaaaaa", "abaaaaa", "aabaaaa", "aaabaaa"];
    for (n, w) in want.iter().enumerate() {
        let out = lsgen_ok(&["-n", &n.to_string(), "examples/signal.ls"]);
        assert_eq!(line(&out), *w, "signal after {n} steps");
    }
    // The file's own derivation length is 3.
    assert_eq!(lsgen_ok(&["examples/signal.ls"]), "aaabaaa\n");
}

#[test]
fn parametric_context_abop_p42() {
    assert_eq!(
        lsgen_ok(&["examples/parametric_context.ls"]),
        "A(4)E(4.5)F(5.5)C(6)A(1)B(2)C(3)\n"
    );
}

#[test]
fn context_brackets_abop_p32() {
    assert_eq!(
        lsgen_ok(&["examples/context_brackets.ls"]),
        "aBc[de][sg[hi[jk]l]mno]\n"
    );
}

/// ABOP figure 1.31 a-e: the book's derivation lengths.
const CONTEXT_PLANTS: [(&str, u64); 5] = [
    ("context_plant_a", 30),
    ("context_plant_b", 30),
    ("context_plant_c", 26),
    ("context_plant_d", 24),
    ("context_plant_e", 26),
];

#[test]
fn context_plants_fig_1_31_at_book_length() {
    for (name, n) in CONTEXT_PLANTS {
        let file = format!("examples/{name}.ls");
        let want = expected(name, n);
        let got = lsgen_ok(&["-n", &n.to_string(), &file]);
        assert!(
            got == want,
            "`lsgen -n {n} {file}` differs from tests/expected/{name}.n{n}.txt at byte {}",
            first_difference(&got, &want)
        );
        // The file's `derivation length:` is the book's n.
        let got = lsgen_ok(&[&file]);
        assert!(
            got == want,
            "`lsgen {file}` (the file's own derivation length) differs from \
             tests/expected/{name}.n{n}.txt at byte {}",
            first_difference(&got, &want)
        );
    }
}

#[test]
fn sierpinski_homomorphism_draws_every_edge() {
    let out = lsgen_ok(&["-n", "1", "examples/sierpinski_gasket.ls"]);
    assert_eq!(out, "F-F-F\n");
    let out = lsgen_ok(&["-n", "2", "examples/sierpinski_gasket.ls"]);
    assert_eq!(out, "F+F+F-F-F-F-F+F+F\n");
}

#[test]
fn stochastic_plant_with_its_file_seed_is_repeatable() {
    let a = lsgen_ok(&["examples/stochastic_plant.ls"]);
    let b = lsgen_ok(&["examples/stochastic_plant.ls"]);
    assert_eq!(a, b);
    assert!(line(&a).starts_with('F'));
    assert_eq!(
        lsgen_ok(&["-n", "0", "examples/stochastic_plant.ls"]),
        "F\n"
    );
}
