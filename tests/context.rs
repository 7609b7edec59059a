//! Context-sensitive matching, one rule of the README per test, through the
//! real streaming engine (`derive_bytes`).

use lsgen::engine::Limits;

fn derive(src: &str, steps: u64) -> String {
    match lsgen::derive_bytes(src.as_bytes(), Some(steps), Some(1), Limits::default()) {
        Ok(v) => String::from_utf8(v).unwrap().trim_end().to_string(),
        Err(e) => panic!("{e}"),
    }
}

fn one(src: &str) -> String {
    derive(src, 1)
}

#[test]
fn signal_propagates_one_cell_per_step() {
    let src = "productions:\nb < a -> b\nb -> a\naxiom: baaaaaa\n";
    assert_eq!(derive(src, 1), "abaaaaa");
    assert_eq!(derive(src, 2), "aabaaaa");
    assert_eq!(derive(src, 3), "aaabaaa");
}

#[test]
fn left_context_steps_over_the_opening_bracket() {
    // The first module of a branch has the branch's parent as left neighbour.
    assert_eq!(one("productions:\nA < B -> X\naxiom: A[B]CB\n"), "A[X]CB");
}

#[test]
fn left_context_skips_whole_branches() {
    // In ABC[DE][SG[HI[JK]L]MNO], S has left context BC.
    let s = "ABC[DE][SG[HI[JK]L]MNO]";
    assert_eq!(
        one(&format!("productions:\nB C < S -> s\naxiom: {s}\n")),
        "ABC[DE][sG[HI[JK]L]MNO]"
    );
    assert_eq!(
        one(&format!("productions:\nE < S -> s\naxiom: {s}\n")),
        s,
        "E is inside a closed branch, not a left neighbour of S"
    );
    assert_eq!(
        one("productions:\nA < B -> X\naxiom: A[C[D]E][F]B\n"),
        "A[C[D]E][F]X"
    );
}

#[test]
fn right_context_skips_branches_it_does_not_ask_for() {
    assert_eq!(
        one("productions:\nA > B -> X\naxiom: A[C][D[E]]B\n"),
        "X[C][D[E]]B"
    );
}

#[test]
fn right_context_with_pattern_brackets() {
    // In ABC[DE][SG[HI[JK]L]MNO], S has right context G[H]M.
    let s = "ABC[DE][SG[HI[JK]L]MNO]";
    assert_eq!(
        one(&format!("productions:\nS > G[H]M -> s\naxiom: {s}\n")),
        "ABC[DE][sG[HI[JK]L]MNO]"
    );
    assert_eq!(
        one(&format!("productions:\nS > G[H]N -> s\naxiom: {s}\n")),
        s
    );
}

#[test]
fn pattern_bracket_tries_each_consecutive_branch() {
    assert_eq!(
        one("productions:\nA > [C] -> X\naxiom: A[B][C]\n"),
        "X[B][C]"
    );
    assert_eq!(
        one("productions:\nA > [C] -> X\naxiom: A[B]D[C]\n"),
        "A[B]D[C]"
    );
}

#[test]
fn pattern_close_skips_rest_of_branch() {
    assert_eq!(
        one("productions:\nA > [B]C -> X\naxiom: A[BDE[F]G]C\n"),
        "X[BDE[F]G]C"
    );
}

#[test]
fn every_module_of_a_branch_sees_what_follows_it() {
    // `]` in a right context: the rest of the module's own branch is
    // skipped, then B must follow. Each A of a branch (A of a nested
    // branch: its `]` is followed by `A]`, not B); a later sibling branch.
    // Remembered per level since the skip was quadratic in the branch.
    assert_eq!(
        one("productions:\nA > ]B -> C\naxiom: [AAAA]B[A[A]A[A]A]B[A]D\n"),
        "[CCCC]B[C[A]C[A]C]B[A]D"
    );
}

#[test]
fn string_close_ends_the_search() {
    // A context never runs past the end of its own branch.
    assert_eq!(one("productions:\nA > B -> X\naxiom: [A]B\n"), "[A]B");
    assert_eq!(one("productions:\nA > B -> X\naxiom: [AB]\n"), "[XB]");
}

#[test]
fn incomplete_context_at_string_ends_does_not_match() {
    assert_eq!(one("productions:\nA B < C -> X\naxiom: BC\n"), "BC");
    assert_eq!(one("productions:\nC > A B -> X\naxiom: CA\n"), "CA");
}

#[test]
fn ignore_and_consider() {
    assert_eq!(
        one("ignore: +-F\nproductions:\nA < B -> X\naxiom: A+F-B\n"),
        "A+F-X"
    );
    assert_eq!(one("productions:\nA < B -> X\naxiom: A+F-B\n"), "A+F-B");
    assert_eq!(
        one("consider: AB\nproductions:\nA < B > A -> X\naxiom: A+F-BGGA\n"),
        "A+F-XGGA"
    );
    // Brackets are never ignored: the branch is still skipped.
    assert_eq!(
        one("ignore: [\nproductions:\nA > B -> X\naxiom: A[C]B\n"),
        "X[C]B"
    );
}

#[test]
fn parameters_are_bound_from_contexts() {
    assert_eq!(
        one("productions:\nA(a) < B(b) > [C(c)]D(d) -> B(a+b+c+d)\naxiom: A(1)[E]B(2)[C(3)[E][E]D(4)]D(5)\n"),
        "A(1)[E]B(11)[C(3)[E][E]D(4)]D(5)"
    );
    assert_eq!(
        one("productions:\nA(x) B < C(y) > [D(z)]E : x < z -> C(y+1)\naxiom: A(1)BC(5)[D(2)]E\n"),
        "A(1)BC(6)[D(2)]E"
    );
    assert_eq!(
        one("productions:\nA(x) B < C(y) > [D(z)]E : x < z -> C(y+1)\naxiom: A(3)BC(5)[D(2)]E\n"),
        "A(3)BC(5)[D(2)]E"
    );
}

#[test]
fn context_beats_context_free_regardless_of_order() {
    assert_eq!(
        one("productions:\nB -> Y\nA < B -> X\naxiom: AB CB\n"),
        "AXCY"
    );
}

#[test]
fn homomorphism_sees_the_derived_string() {
    assert_eq!(
        one("productions:\nA -> AB\nhomomorphism:\nA < B -> X\naxiom: A\n"),
        "AX"
    );
}

#[test]
fn abop_fig_1_31a_first_steps() {
    let src = std::fs::read_to_string("examples/context_plant_a.ls").unwrap();
    let expect = [
        "F1F0F1",
        "F1F1F1F1",
        "F1F0F0F1",
        "F1F0F1[+F1F1]F1",
        "F1F1F1F1[-F0F1]F1",
    ];
    for (i, e) in expect.iter().enumerate() {
        assert_eq!(derive(&src, i as u64 + 1), *e, "step {}", i + 1);
    }
}

/// A right context must skip a branch far larger than any buffer (the main
/// reader's 1 MiB and the look-ahead's 64 KiB), and the result must be right.
#[test]
fn right_context_skips_a_branch_larger_than_the_buffers() {
    let huge = 3_000_000;
    let src = format!(
        "productions:\nX > Y -> Z\nY < X -> W\naxiom: X[{}[G]{}]Y[X]X\n",
        "F".repeat(huge / 2),
        "G".repeat(huge / 2)
    );
    let out = one(&src);
    assert!(out.starts_with("Z["), "{}", &out[..10]);
    assert!(out.ends_with("]Y[W]W"), "{}", &out[out.len() - 10..]);
    assert_eq!(out.len(), huge + 11);
    // Twice in a row: the first step writes a bracket index the second uses.
    let out2 = derive(
        &format!(
            "productions:\nA -> A\nX > Y -> Z\naxiom: X[{}]Y\n",
            "F".repeat(huge)
        ),
        2,
    );
    assert!(out2.starts_with("Z[") && out2.ends_with("]Y"));
}

#[test]
fn deep_nesting_with_left_context() {
    let depth = 200_000;
    let src = format!(
        "productions:\nA < B -> C\naxiom: A{}B{}\n",
        "[A".repeat(depth),
        "]".repeat(depth)
    );
    let out = one(&src);
    assert!(out.ends_with(&format!("AC{}", "]".repeat(depth))));
}

#[test]
fn two_module_right_context_over_interleaved_ignored_modules_and_branches() {
    // Only considered modules ask (no walk memo): A's context walks over
    // `+[B]` pairs to B, then over more of them to C; the A before a
    // single B does not match, nor the B's inside branches (they meet `]`).
    // Hand-derived.
    let run = "+[B]".repeat(3);
    let src = format!("ignore: +\nproductions:\nA > B C -> X\naxiom: A{run}B{run}CA+B+D\n");
    assert_eq!(one(&src), format!("X{run}B{run}CA+B+D"));
    // The same with the context's modules in a branch after the stretch.
    let src = format!("ignore: +\nproductions:\nA > B C -> X\naxiom: A{run}B[C]C\n");
    assert_eq!(one(&src), format!("X{run}B[C]C"));
}

#[test]
fn passed_over_modules_do_not_separate_consecutive_branches() {
    // `[A]X[B]` with X passed over is `[A][B]` to a context: the pattern's
    // `[B]` may match the second branch (hand-derived; ref.py agrees).
    assert_eq!(
        one("ignore: X\nproductions:\nB > [B] -> Z\naxiom: B[A]X[B]\n"),
        "Z[A]X[B]"
    );
    assert_eq!(
        one("consider: [ ] A B\nproductions:\nB > [B] -> Z\naxiom: B[XC[A]]X[BBB][C]XCX\n"),
        "Z[XC[A]]X[BBB][C]XCX"
    );
    // A considered module between them does separate them.
    assert_eq!(
        one("ignore: X\nproductions:\nB > [B] -> Z\naxiom: B[A]C[B]\n"),
        "B[A]C[B]"
    );
}
