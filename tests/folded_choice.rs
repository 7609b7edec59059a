//! The step pass's short way for keys whose choice needs nothing but the
//! draw (`derive::choose::Folded`: one context-free stochastic group, no
//! conditions, constant non-negative weights, constant successors, no
//! parameters): the same string as the reference rewriter
//! (`tests/reference/`) and as lsgen's general path, which each system
//! is forced onto by giving its stochastic productions the always-true
//! condition `step >= 0` (no draw, the same candidates and weights).

mod common;
mod reference;

use lsgen::engine::Limits;

fn lsgen(src: &str, steps: u64, seed: u64) -> Result<String, String> {
    lsgen::derive_bytes(src.as_bytes(), Some(steps), Some(seed), Limits::default())
        .map(|v| String::from_utf8(v).expect("lsgen writes UTF-8"))
        .map_err(|e| e.to_string())
}

/// `src` with the condition `step >= 0` on each production of `keys`
/// (lines `K -> ...` of the productions).
fn general(src: &str, keys: &[char]) -> String {
    src.lines()
        .map(|l| match l.split_once(" -> ") {
            Some((k, rest)) if k.len() == 1 && keys.contains(&k.chars().next().unwrap()) => {
                format!("{k} : step >= 0 -> {rest}\n")
            }
            _ => format!("{l}\n"),
        })
        .collect()
}

/// The folded system, its general twin and the reference agree at every
/// step count up to `n`, for a few seeds; and so does `-j 2` in small
/// chunks.
fn check(src: &str, keys: &[char], n: u64) {
    let slow = general(src, keys);
    assert_ne!(slow, src, "the twin must differ");
    let mut drew = false;
    for seed in [1, 2, 7, 42] {
        for steps in 1..=n {
            let fast = lsgen(src, steps, seed);
            let want = reference::derive_text(src, Some(steps), Some(seed), 200_000);
            assert_eq!(
                fast.as_ref().map(|s| s.trim_end()),
                want.as_ref().map(|s| s.trim_end()),
                "reference, seed {seed}, {steps} steps:\n{src}"
            );
            assert_eq!(
                fast,
                lsgen(&slow, steps, seed),
                "general path, seed {seed}, {steps} steps:\n{slow}"
            );
            let chunks = lsgen::derive_bytes_on(
                src.as_bytes(),
                Some(steps),
                Some(seed),
                Limits::default(),
                (2, Some(3)),
            )
            .map(|v| String::from_utf8(v).unwrap())
            .map_err(|e| e.to_string());
            assert_eq!(fast, chunks, "-j 2, seed {seed}, {steps} steps");
            drew |= seed == 1 && fast != lsgen(src, steps, 2);
        }
    }
    // (The seed must matter somewhere, or no draw was tested.)
    assert!(drew, "no step count depends on the seed:\n{src}");
}

#[test]
fn abop_1_27() {
    // Three weighted productions, brackets between the drawing modules.
    let src =
        "productions:\nF -> F[+F]F[-F]F : 0.33\nF -> F[+F]F : 0.33\nF -> F[-F]F : 0.34\naxiom: F\n";
    check(src, &['F'], 4);
}

#[test]
fn zero_and_default_weights_single_candidates() {
    // F: a weight 0 that never wins, a default weight 1 and 2.5; G: one
    // candidate (wins without a draw); H: every weight 0 (chooses nothing,
    // copied: not folded); X: deterministic (the byte table).
    let src = "productions:\nF -> F[+F]F : 0\nF -> FF\nF -> F[-F] : 2.5\nG -> GF : 0.5\nH -> X : 0\nH -> G : 0\nX -> +X\naxiom: F[G]HFXG\n";
    check(src, &['F', 'G', 'H'], 5);
}

#[test]
fn beside_left_contexts_and_a_homomorphism() {
    // Left contexts are kept for another key (the folded key's modules
    // must enter them); the homomorphism draws too (region 1).
    let src = "ignore: +-\nproductions:\nF -> F[+F]A : 1\nF -> FB-F : 3\nF < A -> B\nB < B -> A\n\nhomomorphism:\nA -> CD : 1\nA -> DC : 1\n\naxiom: FAB\n";
    check(src, &['F', 'A'], 4);
}

#[test]
fn negative_constant_weight_is_still_a_load_error() {
    // Never folded: the header check rejects it before any step, also
    // when no module of the key is ever rewritten (hand derived: line 3,
    // column 10 is the weight).
    let src = "productions:\nS -> A\nA -> B : -1\nA -> C : 1\naxiom: S\n";
    for n in ["1", "2"] {
        let mut cmd = common::lsgen();
        cmd.args(["-n", n, "--seed", "1"]);
        let r = common::run_with_stdin(&mut cmd, src);
        r.assert_no_crash();
        assert_eq!(r.code(), Some(1), "{}", r.stderr);
        assert_eq!(
            r.stderr.lines().next(),
            Some("lsgen: <stdin>:3:10: error: a probability cannot be negative (-1)"),
            "{}",
            r.stderr
        );
    }
}

#[test]
fn successors_with_parameters_and_the_key_seen_with_parameters() {
    // F's successors carry constant parameters (1/3 folded at load, -0,
    // 1e21, 1e-7) and a cut; G makes F(1), a module of F's symbol with a
    // parameter that F's productions do not rewrite: it must stay as it is
    // on the folded path too.
    let src = "productions:\nF -> A(1/3)[+F]B(2)F : 1/3\nF -> F-G : 2/3\nF -> X(1e21,-0,1e-7)[%F] : 0.5\nA(x) -> A(x+1)\nB(x) : x > 1 -> B(x-1)F\nG -> F(1)G : 1\nG -> : 1\naxiom: F[F]GF\n";
    check(src, &['F', 'G'], 4);
}

#[test]
fn in_the_table_beside_right_contexts_and_brackets() {
    // A right context elsewhere makes every generation indexed (each `[`
    // carries its branch's end): the table copies the brackets between
    // F's, and F's draw positions must count each `[` as one module. F's
    // and G's successors have no brackets, so the byte table draws for
    // them; H's have brackets and go the folded path.
    let src = "productions:\nA > B -> C\nB -> BA\nC -> A\nF -> F : 0.3\nF -> FF : 0.4\nF -> G : 0.3\nG -> F : 1\nG -> : 1\nH -> H[F] : 1\nH -> [G]H : 1\naxiom: F[AB]F[F[A]B]FAF[[F]G]HF\n";
    check(src, &['F', 'G', 'H'], 6);
}
