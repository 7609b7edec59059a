//! Issue 12, the cpfg dialect's runtime, through the real binary, beyond
//! the expected strings of tests/cpfg.rs (which checks the models of
//! blocks, randomness and contexts against tests/tools/cpfg_ref.py):
//! `printf` on standard error, `--seed`, the strategy (located errors of
//! blocks: tests/bad_input.rs, `cpfg_runaway_while` ...). Expected text comes from cpfg_ref.py or by hand, never from
//! lsgen.

mod common;

use common::{lsgen, run, tempdir, write, ROOT};
use std::path::Path;

fn derive(args: &[&str], file: &Path) -> (String, String) {
    let r = run(lsgen().args(args).arg(file));
    assert!(
        r.status.success(),
        "{}: {} ({})",
        r.what,
        r.stderr,
        r.status
    );
    (String::from_utf8(r.stdout).unwrap(), r.stderr)
}

/// `printf` and `fprintf(stderr, ...)` write to standard error, in step
/// order; `End:` runs after the last step only when the run reaches the
/// file's derivation length (cpfg_ref.py's standard error).
#[test]
fn printf_writes_to_standard_error() {
    let blocks = Path::new(ROOT).join("tests/cpfg/blocks.l");
    let (_, err) = derive(&["-n", "4"], &blocks);
    assert_eq!(err, "end: n=5\n");
    let (_, err) = derive(&["-n", "3"], &blocks);
    assert_eq!(err, "");
    // Frames run the same blocks as one derivation.
    let (_, err) = derive(&["--frames", "1..4"], &blocks);
    assert_eq!(err, "end: n=5\n");
    let stochastic = Path::new(ROOT).join("tests/cpfg/vlab_stochastic.l");
    let (_, err) = derive(&["-n", "3", "--no-homomorphism"], &stochastic);
    assert_eq!(
        err,
        "step 1: 1 branchings\nstep 2: 2 branchings\nstep 3: 2 branchings\n"
    );
}

/// `--seed N` on a `.l` file acts as `seed: N`: on a copy of
/// tests/cpfg/stochastic.l that says `seed: 99`, `--seed 7` gives the
/// strings of `seed: 7`; on a file without `seed:`, it makes the weights
/// count.
#[test]
fn seed_option_acts_as_the_seed_setting() {
    let src = std::fs::read_to_string(Path::new(ROOT).join("tests/cpfg/stochastic.l")).unwrap();
    assert!(src.contains("seed: 7\n"));
    let dir = tempdir();
    let other = write(
        dir.path(),
        "other.l",
        src.replace("seed: 7\n", "seed: 99\n"),
    );
    let unseeded = write(dir.path(), "unseeded.l", src.replace("seed: 7\n", ""));
    for n in ["5", "8"] {
        let want = std::fs::read_to_string(
            Path::new(ROOT).join(format!("tests/expected/cpfg/stochastic.n{n}.txt")),
        )
        .unwrap();
        let (plain, _) = derive(&["-n", n], &other);
        assert_ne!(plain, want, "seed 99 gives another string");
        assert_eq!(derive(&["-n", n, "--seed", "7"], &other).0, want);
        assert_eq!(derive(&["-n", n, "--seed", "7"], &unseeded).0, want);
    }
}

/// cpfg's draws are sequential, in string order: depth first is refused.
#[test]
fn depth_first_is_refused_for_cpfg_files() {
    let file = Path::new(ROOT).join("tests/cpfg/stochastic.l");
    let r = run(lsgen().args(["-n", "2", "--strategy", "dfs"]).arg(&file));
    assert_eq!(r.code(), Some(2), "{}", r.stderr);
    assert!(r.stderr.contains("cpfg"), "{}", r.stderr);
}

/// What keeps a `.l` file step by step, one thing each (README, "Coming
/// from cpfg"); the same file without it derives depth first.
#[test]
fn depth_first_only_without_what_runs_in_string_order() {
    let dir = tempdir();
    let plain = "A(x) : x > 1 --> B(x/2)[+(30)A(x-1)]A(x*0.5)\nB(x) --> B(x+func(1,0.5))\n";
    let view = write(dir.path(), "case.v", "function: f.func\n");
    write(
        dir.path(),
        "f.func",
        "range: 0.0 1.0\npoints: 4\n0 0.25\n0.3 0.5\n0.6 0.6\n1 0.75\n",
    );
    let derive = |body: &str, head: &str, strategy: &str, threads: &str| {
        let src = format!("Lsystem: 1\n{head}Axiom: A(3)B(1)\n{body}endlsystem\n");
        let file = write(dir.path(), "case.l", src);
        run(lsgen()
            .args([
                "-n",
                "3",
                "--strategy",
                strategy,
                "-j",
                threads,
                "--functions",
            ])
            .arg(&view)
            .arg(&file))
    };
    let want = derive(plain, "", "step", "1");
    assert_eq!(want.code(), Some(0), "{}", want.stderr);
    for threads in ["1", "3"] {
        let r = derive(plain, "", "dfs", threads);
        assert_eq!(
            (r.code(), &r.stdout),
            (Some(0), &want.stdout),
            "{}",
            r.stderr
        );
    }
    let refused = [
        ("seed: 3\n", ""),
        ("Start: {g = 1;}\n", ""),
        ("StartEach: {g = 1;}\n", ""),
        ("", "A(x) : {t = x;} x > 5 --> A(t)\n"),
        ("", "A(x) : x > 5 --> A(ran(1))\n"),
        ("", "A(x) < B(y) --> A(y)\n"),
        ("", "A(x)B(y) : x > 5 --> A(y)\n"),
        ("", "B(x) : x > 5 --> B(1/x)\n"),
        ("", "B(x) : x > 5 --> B(1/0)\n"),
        ("", "B(x) : x > 5 --> B(x/(x-1))\n"),
        ("derivation length: 2\n", "B(x) : x > Q --> B(1)\n"),
        (
            "define: { array a[2] = {1, 2}; }\n",
            "B(x) : x > 5 --> B(a[x])\n",
        ),
        ("", "B(x) : x > 5 --> %B(1)\n"),
        // (Sections: after the productions.)
        ("", "decomposition\nC --> D\n"),
        // A homomorphism with warnings whose successors hold a module it
        // rewrites (its depth limit).
        ("", "homomorphism\nC --> DC\n"),
        (
            "",
            "homomorphism: no warnings\nmaximum depth: 2\nC --> DC\n",
        ),
        ("", "homomorphism: no warnings\nmaximum depth: 0\nC --> D\n"),
    ];
    for (head, extra) in refused {
        // (Extra productions come first: they are tried first.)
        let body = match extra.contains("\nC --> ") {
            true => format!("{plain}{extra}"),
            false => format!("{extra}{plain}"),
        };
        let r = derive(&body, head, "dfs", "1");
        assert_eq!(r.code(), Some(2), "{head}{extra}: {}", r.stderr);
        assert!(r.stderr.contains("cpfg"), "{head}{extra}: {}", r.stderr);
    }
    // Nor one whose condition can fail where cpfg tries it at its depth
    // limit (`1 % 0` for the successor's `A(5)`): the step strategy's
    // error.
    let body = "A(x) --> A(x)\nhomomorphism: no warnings\nA(x) : 1 % (x - 5) > -100 --> B(x)A(5)\n";
    let r = derive(body, "", "dfs", "1");
    assert_eq!(r.code(), Some(2), "{}", r.stderr);
    let r = derive(body, "", "auto", "1");
    assert_eq!(r.code(), Some(1), "{}", r.stderr);
    assert!(r.stderr.contains("remainder by zero"), "{}", r.stderr);
    // A homomorphism without warnings (depth 1) does not, nor one with
    // warnings or a depth above 1 whose successors hold no module it
    // rewrites (it applies once).
    for hom in [
        "homomorphism: no warnings\nB(x) --> F(x)B(x)\n",
        "homomorphism\nB(x) --> F(x)A(x)\n",
        "homomorphism\nmaximum depth: 3\nB(x) --> F(x)A(x)\n",
    ] {
        let body = format!("{plain}{hom}");
        let want = derive(&body, "", "step", "1");
        assert_eq!(want.code(), Some(0), "{}", want.stderr);
        let r = derive(&body, "", "dfs", "3");
        assert_eq!(
            (r.code(), &r.stdout),
            (Some(0), &want.stdout),
            "{}",
            r.stderr
        );
    }
}

/// A runtime error found depth first in a `.l` file is the one the step
/// strategy reports (the earliest step's first in string order).
#[test]
fn a_depth_first_error_is_the_step_strategys() {
    let dir = tempdir();
    // Step 2's first module overflows a 32-bit float; depth first meets
    // step 3's overflow of the first module's expansion before it.
    let src =
        "Lsystem: 1\nAxiom: A(1)B(1)\nA(x) --> A(x*1.0e15)\nB(x) --> B(x*1.0e25)\nendlsystem\n";
    let file = write(dir.path(), "over.l", src);
    let step = run(lsgen().args(["-n", "3", "--strategy", "step"]).arg(&file));
    assert_eq!(step.code(), Some(1), "{}", step.stderr);
    assert!(
        step.stderr.contains("out of the range of a 32-bit float")
            && step.stderr.contains("(in step 2)"),
        "{}",
        step.stderr
    );
    for threads in ["1", "2"] {
        let r = run(lsgen()
            .args(["-n", "3", "--strategy", "dfs", "-j", threads])
            .arg(&file));
        assert_eq!((r.code(), &r.stderr), (Some(1), &step.stderr));
    }
}

/// A multi-module predecessor draws once for the whole run, in cpfg's
/// string order (strings from tests/tools/cpfg_ref.py on this model; one
/// draw per module of the run gives others from step 2 on).
#[test]
fn a_multi_module_predecessor_draws_once() {
    let dir = tempdir();
    let file = write(
        dir.path(),
        "multi_stochastic.l",
        "Lsystem: 1\nseed: 3\nderivation length: 6\nAxiom: A B C A B\n\
         A B --> X : 1\nA B --> Y : 2\nA --> A B : 1\nC --> C A B\nX --> A B\nY --> A\nendlsystem\n",
    );
    let want = [
        "YCABY",
        "ACABYA",
        "ABCABABBAAB",
        "XCABYXBABY",
        "ABCABXAABBABBA",
        "XCABYABABXBYBAB",
    ];
    for (i, want) in want.iter().enumerate() {
        let n = (i + 1).to_string();
        assert_eq!(
            derive(&["-n", &n], &file).0,
            format!("{want}\n"),
            "{n} steps"
        );
    }
}

/// A production's local variables keep their values between applications
/// (cpfg's per-production symbol tables): `c` and `d` count across the
/// string and the steps (string from tests/tools/cpfg_ref.py; by hand:
/// step 1 gives B(1)A B(2)A B(3)A, step 2 adds to d in string order).
#[test]
fn locals_keep_their_values_between_applications() {
    let dir = tempdir();
    let file = write(
        dir.path(),
        "locals.l",
        "Lsystem: 1\nderivation length: 2\nAxiom: A A A\n\
         A : {c = c + 1;} * --> B(c) A\nB(x) : {d = d + x;} * --> B(d)\nendlsystem\n",
    );
    assert_eq!(
        derive(&["-n", "2"], &file).0,
        "B(1)B(4)AB(3)B(5)AB(6)B(6)A\n"
    );
}

/// The homomorphism's `seed:` seeds the generator of the successors of the
/// productions it applies; the conditions at its top level draw from the
/// first one (interpret.c; string from tests/tools/cpfg_ref.py, which one
/// generator for both would not give).
#[test]
fn homomorphism_seed_is_for_successors() {
    let dir = tempdir();
    let file = write(
        dir.path(),
        "homseed.l",
        "Lsystem: 1\nderivation length: 1\nAxiom: A A A A\nA --> A\nhomomorphism\nseed: 9\n\
         A : ran(1) < 0.5 --> R(ran(1))\nA --> S(ran(1))\nendlsystem\n",
    );
    assert_eq!(
        derive(&["-n", "1"], &file).0,
        "R(0.00804881)S(0.0912162)R(0.742382)S(0.0601525)\n"
    );
}

/// `maximum depth:` and `derivation length:` are cpfg's `(int) Eval(...)`
/// (lsys_input.y): truncated, not rounded, and 0 or below is accepted. A
/// decomposition of depth 0 or below decomposes nothing, silently
/// (generate.c, ApplyRecursiveProductions returns 0 at once); a
/// homomorphism of depth 0 applies nothing but warns where a production
/// applies (interpret.c, InterpretHomomorphism); a negative derivation
/// length derives no step (control.c, GenerateNSteps) and `Z` keeps it.
/// Strings from tests/tools/cpfg_ref.py (by hand: `2.7` as 3 would give
/// `E`, a depth of 1 `C`).
#[test]
fn depths_and_lengths_truncate_as_cpfg() {
    let dir = tempdir();
    let decomposition = |depth: &str| {
        format!(
            "Lsystem: 1\nderivation length: 1\nAxiom: A\nA --> B\ndecomposition\n\
             maximum depth: {depth}\nB --> C\nC --> D\nD --> E\nendlsystem\n"
        )
    };
    for (depth, want, warns) in [("0", "B", false), ("-3", "B", false), ("2.7", "D", true)] {
        let file = write(dir.path(), "d.l", decomposition(depth));
        let (out, err) = derive(&[], &file);
        assert_eq!(out, format!("{want}\n"), "maximum depth: {depth}");
        assert_eq!(
            err.contains("stopped at maximum depth"),
            warns,
            "{depth}: {err}"
        );
    }
    for (section, depth, warns) in [
        ("homomorphism", "0", true),
        ("homomorphism no warnings", "-1", false),
    ] {
        let file = write(
            dir.path(),
            "h.l",
            format!(
                "Lsystem: 1\nderivation length: 1\nAxiom: A\nA --> BAB\n{section}\n\
                 maximum depth: {depth}\nB --> C\nendlsystem\n"
            ),
        );
        let (out, err) = derive(&[], &file);
        assert_eq!(out, "BAB\n", "{section}, {depth}");
        assert_eq!(
            err.contains("homomorphism stopped at maximum depth 0"),
            warns,
            "{section}: {err}"
        );
    }
    for (length, want) in [("-2", "A(-2)"), ("2.7", "A(4)")] {
        let file = write(
            dir.path(),
            "n.l",
            format!("Lsystem: 1\nderivation length: {length}\nAxiom: A(Z)\nA(x) --> A(x+1)\nendlsystem\n"),
        );
        assert_eq!(derive(&[], &file).0, format!("{want}\n"), "{length}");
    }
}

/// A negative `seed:` is cpfg's: `(int)`, then control.c's
/// `seed48({seed, 0, 155})` stores it in an `unsigned short`, modulo 2^16:
/// -65529 seeds as 7, -1 as 65535, and -65536 (non-zero, so seed48 is
/// called) as 0, which is X = 155 << 32, not the unseeded state of
/// `seed: 0`. Strings of tests/cpfg/stochastic.l from
/// tests/tools/cpfg_ref.py (-1 and 65535 agree, so do -65536 and 65536).
#[test]
fn negative_seeds_wrap_as_an_unsigned_short() {
    let src = std::fs::read_to_string(Path::new(ROOT).join("tests/cpfg/stochastic.l")).unwrap();
    assert!(src.contains("seed: 7\n"));
    let dir = tempdir();
    let seven =
        std::fs::read_to_string(Path::new(ROOT).join("tests/expected/cpfg/stochastic.n5.txt"))
            .unwrap();
    let cases = [
        ("-65529", seven.trim_end()),
        (
            "-1",
            "H[+F(2)[-F(0)][-F(1)[+F(0)]F(1)]]H[-F(3)[-F(0)][-F(1)[-F(0)]][-F(2)[+F(0)]F(2)[-F(1)]]]\
             [-H[+F(2)[+F(0)]F(2)[-F(1)]]H[-G[-F(1)][+F(2)[+F(1)]F(2)[-F(0)]]F(3)[-F(0)][-F(1)[-F(0)]]]]",
        ),
        ("-65536", "F(5)[+F(0)]F(5)[-F(1)[-F(0)]][-F(3)[-F(0)]][-H]"),
    ];
    for (seed, want) in cases {
        let file = write(
            dir.path(),
            "s.l",
            src.replace("seed: 7\n", &format!("seed: {seed}\n")),
        );
        assert_eq!(
            derive(&["-n", "5"], &file).0,
            format!("{want}\n"),
            "seed: {seed}"
        );
    }
}

/// Negative weights take part in cpfg's stochastic choice as they are
/// (generate.c: FindApplProductions adds each to the total, SelectProd
/// draws r = total * drand48() as a float and subtracts the weights in
/// file order, the first production where r <= 0 wins, none if r stays
/// above 0). By hand: `A`'s weights 1, -1, 3 (total 3) give `B` for a
/// draw up to 1/3 and `D` above, never `C`; `E`'s -1, 1 (total 0) always
/// `Y`; `F`'s lone -2 (r = -2u, then r + 2 > 0) nothing, `F` is copied.
/// The string (which `A` gets which) from tests/tools/cpfg_ref.py.
#[test]
fn negative_weights_compete_as_in_cpfg() {
    let dir = tempdir();
    let file = write(
        dir.path(),
        "neg.l",
        "Lsystem: 1\nseed: 5\nderivation length: 2\nAxiom: A A A A A A A A E E F\n\
         A --> B : 1\nA --> C : -1\nA --> D : 3\nE --> X : -1\nE --> Y : 1\nF --> Z : -2\nendlsystem\n",
    );
    let (out, err) = derive(&[], &file);
    assert_eq!(out, "DDBDDBDBYYF\n");
    assert_eq!(err, "");
}

/// In a seeded system a production without a weight weighs 1 (cpfg's
/// lsys_input.y), so `A`'s two plain productions compete, also where
/// everything else is constant: lsgen's fast paths (the byte table, the
/// depth-first plans) took `A`'s first production every time and printed
/// XXXXXXXX. The strings from tests/tools/cpfg_ref.py (seed 3: drand48
/// seeded {3, 0, 155}, one draw per module); `--seed` stands for `seed:`.
#[test]
fn unweighted_alternatives_compete_when_seeded() {
    let dir = tempdir();
    let body = "derivation length: 1\nAxiom: AAAAAAAA\nA --> X\nA --> Y\nendlsystem\n";
    let seeded = write(dir.path(), "s.l", format!("Lsystem: 1\nseed: 3\n{body}"));
    let plain = write(dir.path(), "p.l", format!("Lsystem: 1\n{body}"));
    for args in [&[][..], &["--strategy", "step"], &["-j", "2"]] {
        assert_eq!(derive(args, &seeded), ("YXYXXYXX\n".into(), String::new()));
    }
    assert_eq!(
        derive(&["--seed", "3"], &plain),
        ("YXYXXYXX\n".into(), String::new())
    );
    // Without a seed, the first applicable production: no draw.
    assert_eq!(derive(&[], &plain), ("XXXXXXXX\n".into(), String::new()));
}

/// NaN and infinities in cpfg expressions are C's doubles (generate.c's
/// Eval: `stack > temp`, `!stack`, `stack ? a : b`, `&&`; CondDiff's
/// `return !temp`), not errors: a comparison with NaN is false except
/// `!=`, NaN is true as a condition and in `?:` / `&&`, `!NaN` is 0,
/// inf - inf is NaN, `sign` of NaN is -1 (`x == 0 ? 0 : x > 0 ? 1 : -1`).
/// By hand, and tests/tools/cpfg_ref.py gives the same string: Y(3), Y(4),
/// Y(7) and Y(8) apply, the rest are copied.
#[test]
fn nan_and_infinities_are_values_as_in_c() {
    let dir = tempdir();
    let file = write(
        dir.path(),
        "nan.l",
        "Lsystem: 1\nderivation length: 1\nAxiom: A(1) B(1) C(1) D(1) E(1) G(1) H(1) I(1)\n\
         A(x) : sqrt(-x) > 0 --> Y(1)\n\
         B(x) : sqrt(-x) <= 0 --> Y(2)\n\
         C(x) : sqrt(-x) != 0 --> Y(3)\n\
         D(x) : sqrt(-x) --> Y(4)\n\
         E(x) : !sqrt(-x) --> Y(5)\n\
         G(x) : exp(1000*x) - exp(1000*x) == 0 --> Y(6)\n\
         H(x) : (log(-x) ? 1 : 0) && exp(1000) > 1 --> Y(7)\n\
         I(x) : sign(asin(2*x)) < 0 --> Y(8)\n\
         endlsystem\n",
    );
    let (out, err) = derive(&[], &file);
    assert_eq!(out, "A(1)B(1)Y(3)Y(4)E(1)G(1)Y(7)Y(8)\n");
    assert_eq!(err, "");
}

/// The homomorphism's `seed:` and `maximum depth:` may come several times,
/// the last of each winning (lsys_input.y: HomoItems is a list, each
/// HomoSeed / ProdDepth assigns); a negative seed is as none (interpret.c
/// seeds the homomorphism's generator only for `seed >= 0`, -1 being the
/// default). The strings of `seed: 9` and of no seed are those of
/// tests/tools/cpfg_ref.py (and `homomorphism_seed_is_for_successors`);
/// depths by hand: 1 stops at `B`, 2 reaches `C`.
#[test]
fn homomorphism_settings_repeat_and_the_last_wins() {
    let dir = tempdir();
    let seeded = "R(0.00804881)S(0.0912162)R(0.742382)S(0.0601525)\n";
    let unseeded = "R(0.749902)R(0.870465)S(0.785799)S(0.368766)\n";
    for (settings, want) in [
        ("seed: 1\nseed: 9\n", seeded),
        ("seed: 9\nmaximum depth: 1\nseed: 9\n", seeded),
        ("seed: 9\nseed: -5\n", unseeded),
        ("", unseeded),
    ] {
        let file = write(
            dir.path(),
            "hs.l",
            format!(
                "Lsystem: 1\nderivation length: 1\nAxiom: A A A A\nA --> A\nhomomorphism\n{settings}\
                 A : ran(1) < 0.5 --> R(ran(1))\nA --> S(ran(1))\nendlsystem\n"
            ),
        );
        assert_eq!(derive(&[], &file).0, want, "{settings}");
    }
    for (settings, want) in [
        ("maximum depth: 1\nmaximum depth: 2\n", "C\n"),
        ("maximum depth: 2\nseed: 3\nmaximum depth: 1\n", "B\n"),
    ] {
        let file = write(
            dir.path(),
            "hd.l",
            format!(
                "Lsystem: 1\nderivation length: 1\nAxiom: X\nX --> A\nhomomorphism no warnings\n{settings}\
                 A --> B\nB --> C\nendlsystem\n"
            ),
        );
        assert_eq!(derive(&[], &file).0, want, "{settings}");
    }
}

/// `Q` and `Z` exist in cpfg from the `derivation length:` line on
/// (lsys_input.y's Dlength adds them to the global symbol table; Derive
/// then replaces `Q` there each step). Without that line they are
/// undefined names: 0, with the warning, however many steps `-n` asks
/// for. A name cpfg's parser does not find becomes a variable of the
/// table in use, the L-system's in the header (settings, blocks, the
/// axiom): a header item up to the line that names `Q` or `Z` makes it
/// such a variable, which hides the built-in one from then on; in a
/// production without the line, one assigned in its block is its own.
/// Strings from tests/tools/cpfg_ref.py, which keeps cpfg's tables.
#[test]
fn q_and_z_come_with_the_derivation_length_line() {
    let dir = tempdir();
    let cases: [(&str, &str, &str); 5] = [
        // Without the line: 0 in every step.
        (
            "2",
            "Lsystem: 1\nAxiom: A(Q,Z)\nA(x,y) --> A(Q+x, Z+y+1)\nendlsystem\n",
            "A(0,2)",
        ),
        // The line, and nothing before it: the step and the length.
        (
            "2",
            "Lsystem: 1\nderivation length: 2\nStart: {g = Q + Z;}\nAxiom: A(Q,Z)\n\
             A(x,y) --> A(Q+x, Z+y+1, g)\nendlsystem\n",
            "A(1,5,2)",
        ),
        // `Z` read before the line: a variable of the L-system, 0 from
        // then on (`Q` is still the step).
        (
            "2",
            "Lsystem: 1\nseed: Z + 3\nderivation length: 2\nStart: {g = Q + Z;}\nAxiom: A(Q,Z)\n\
             A(x,y) --> A(Q+x, Z+y+1, g)\nendlsystem\n",
            "A(1,1,0)",
        ),
        // Without the line, `Q` assigned in a production's block is that
        // production's variable...
        (
            "3",
            "Lsystem: 1\nAxiom: A(0)\nA(x) : {Q = Q + 2;} * --> A(x+Q)\nB --> B(Q)\nendlsystem\n",
            "A(12)",
        ),
        // ... and the L-system's once the axiom names it: `B` sees it.
        (
            "3",
            "Lsystem: 1\nAxiom: A(Q) B\nA(x) : {Q = Q + 2;} * --> A(x+Q)\nB --> B(Q)\nendlsystem\n",
            "A(12)B(2)",
        ),
    ];
    for (n, src, want) in cases {
        let file = write(dir.path(), "qz.l", src);
        let (out, err) = derive(&["-n", n], &file);
        assert_eq!(out, format!("{want}\n"), "{src}");
        if !src.contains("derivation length") {
            assert!(err.contains("`Q` is not defined"), "{src}: {err}");
        }
    }
}

/// The warning that weights are ignored without `seed:` is not given
/// where `--seed` makes them count.
#[test]
fn seed_option_has_no_ignored_weights_warning() {
    let dir = tempdir();
    let file = write(
        dir.path(),
        "w.l",
        "Lsystem: 1\nderivation length: 1\nAxiom: A\nA --> B : 1\nendlsystem\n",
    );
    let (_, err) = derive(&[], &file);
    assert!(
        err.contains("a probability without `seed:` is ignored"),
        "{err}"
    );
    let (out, err) = derive(&["--seed", "3"], &file);
    assert_eq!(out, "B\n");
    assert_eq!(err, "");
}

/// A left context with `[` or `]` never matches in cpfg: generate.c's
/// LconDiff passes over the string's brackets (`]` skips a branch, `[` is
/// stepped over) and compares the pattern only with other modules, so the
/// production never applies, and its pre-condition block never runs
/// (LconDiff fails before CondDiff). lsgen warns. By hand (and
/// tests/tools/cpfg_ref.py): B's left context is A (`A < B`: V), C's is A
/// past the branch (the last production: T, its block printing once).
#[test]
fn a_bracket_in_a_left_context_never_matches() {
    let dir = tempdir();
    let file = write(
        dir.path(),
        "lcb.l",
        "Lsystem: 1\nderivation length: 1\nAxiom: A[B]C[D]E\n\
         [ < B --> X\nA[ < B : {printf(\"never\\n\");} * --> Y\n] < C --> Z\nA] < C --> W\n\
         A < B --> V\nB --> U\nC : {printf(\"tried\\n\");} * --> T\nendlsystem\n",
    );
    let (out, err) = derive(&[], &file);
    assert_eq!(out, "A[V]T[D]E\n");
    assert_eq!(
        err.matches("a left context with `[` or `]` never matches")
            .count(),
        4,
        "{err}"
    );
    assert!(!err.contains("never\n"), "{err}");
    assert_eq!(err.matches("tried\n").count(), 1, "{err}");
}

/// A `[` or `]` is rewritten like any module in cpfg: generate.c's Derive
/// tries the productions of every module of the string, brackets included
/// (FindProd by `firstProd['[']`), and so do the decomposition and the
/// homomorphism; the right context of a `[` starts inside its branch, the
/// left context of a `]` is the branch's last module (LconDiff, RconDiff
/// from the bracket's neighbours). Strings from tests/tools/cpfg_ref.py
/// (the first by hand too: each `[` gains a G and each `]` an H per step).
#[test]
fn brackets_are_rewritten_as_in_cpfg() {
    let dir = tempdir();
    let cases = [
        (
            "derivation length: 2\nAxiom: A[B]C[D[E]]F\n[ --> [G\n] --> H]\n",
            "A[GGBHH]C[GGD[GGEHH]HH]F",
        ),
        // Contexts around a bracket, with `=` inside the branch.
        (
            "derivation length: 1\nAxiom: A[B]C\nA < [ > B --> [X\n] > C --> Y]\nB > ] --> Z\n",
            "A[XZY]C",
        ),
        (
            "derivation length: 1\nAxiom: A[B[C]D]E\n[ > C=]E --> [X\n[ > B=]E --> [Y\n",
            "A[YB[C]D]E",
        ),
        (
            "derivation length: 1\nAxiom: A[B[C]]D\nC < ] > ] --> Q]\nB < ] --> R]\n] > D --> S]\n",
            "A[B[CQ]R]D",
        ),
        // `=` after a `[`'s first module skips to the end of the branch
        // the `[` opens (B's `=` before it found the outer branch's end;
        // the inner `[`'s C=]E must not reuse it).
        (
            "derivation length: 1\nAxiom: A[B[C]D]E[F]G\nB > =]E --> X\n[ > C=]E --> [P\n\
             [ > B=]E --> [Q\n[ > F=]G --> [R\n",
            "A[QX[C]D]E[RF]G",
        ),
        // Stochastic: a bracket draws and chooses like any module.
        (
            "derivation length: 3\nseed: 4\nAxiom: A[B][C]D\n[ --> [F : 1\n[ --> [G : 2\n\
             ] --> ] : 1\n] --> H] : 1\nA --> A[B]\n",
            "A[B][GB][GFBH][GFFBHH][GFGCH]D",
        ),
        // Decomposition (depth 1: `D` stays) and homomorphism (depth 2).
        (
            "derivation length: 1\nAxiom: A[B]C\nA --> A\ndecomposition no warnings\n[ --> [D\nD --> E\n",
            "A[DB]C",
        ),
        (
            "derivation length: 1\nAxiom: A[B]C\nA --> A\nhomomorphism no warnings\nmaximum depth: 2\n\
             [ --> [;\n; --> ,\n",
            "A[;,B]C",
        ),
    ];
    for (body, want) in cases {
        let file = write(dir.path(), "b.l", format!("Lsystem: 1\n{body}endlsystem\n"));
        let (out, err) = derive(&[], &file);
        assert_eq!(out, format!("{want}\n"), "{body}");
        assert_eq!(err, "", "{body}");
    }
}

/// What lsgen cannot follow: cpfg carries on with a string whose brackets
/// no longer balance (`[ --> X` gives `AXB]C`), lsgen's strings must
/// balance: a located error at the production; and a bracket inside a
/// predecessor of several modules (`A[ --> X`, which cpfg's PredDiff
/// matches) is refused where it is written.
#[test]
fn unbalancing_bracket_productions_are_located_errors() {
    let dir = tempdir();
    for (prods, at, words) in [
        (
            "A --> A\n[ --> X\n",
            ":5:1: error: ",
            "produces a `]` without `[`",
        ),
        ("A --> A\n] --> X\n", ":5:1: error: ", "leaves a `[` open"),
        (
            "A[ --> X\n",
            ":4:2: error: ",
            "a predecessor of several modules cannot hold `[` or `]`",
        ),
    ] {
        let file = write(
            dir.path(),
            "u.l",
            format!("Lsystem: 1\nderivation length: 1\nAxiom: A[B]C\n{prods}endlsystem\n"),
        );
        let r = run(lsgen().arg(&file));
        let e = r.one_error().to_string();
        assert!(
            e.starts_with(&format!("lsgen: {}{at}", file.display())) && e.contains(words),
            "{prods}: {e}"
        );
    }
}

/// lsgen prints each warning as it is found, in its place among the
/// lines of cpfg's `printf` and of `-v` (the library hands them over as
/// events instead, tests/library.rs): the division by zero of the first
/// `A`'s production comes between the two `A`s' `printf`s, and once per
/// run; the file's warnings come first, with `--seed` named.
#[test]
fn warnings_keep_their_place_among_printf_lines() {
    let dir = tempdir();
    let file = write(
        dir.path(),
        "order.l",
        "Lsystem: 1\nderivation length: 2\nEndEach: {printf(\"end %g\\n\", Q);}\n\
         Axiom: A(1) A(2)\nA(x) : {printf(\"A(%g)\\n\", x);} * --> A(x/0)B(y)\n\
         B(x) --> C : 1\nendlsystem\n",
    );
    let (out, err) = derive(&["-v"], &file);
    assert_eq!(out, "A(1)B(0)CA(2)B(0)C\n");
    let f = file.display();
    assert_eq!(
        err,
        format!(
            "lsgen: {f}:5:46: warning: `y` is not defined: it is 0 here, as in cpfg\n\
             A(x) : {{printf(\"A(%g)\\n\", x);}} * --> A(x/0)B(y)\n{}^\n\
             lsgen: {f}:6:14: warning: a probability without `seed:` is ignored, as in \
             cpfg (the first applicable production applies; `--seed` makes it count)\n\
             B(x) --> C : 1\n{}^\n\
             lsgen: seed 0\n\
             lsgen: axiom: 2 modules, 20 bytes\n\
             A(1)\n\
             lsgen: warning: division by zero in a cpfg expression: divided by 1 instead, \
             as cpfg does\n\
             A(2)\n\
             lsgen: step 1: 4 modules, 40 bytes\n\
             end 1\n\
             A(1)\n\
             A(2)\n\
             lsgen: step 2: 6 modules, 18 bytes\n\
             end 2\n",
            " ".repeat(45),
            " ".repeat(13)
        )
    );
}

/// A production's block runs wherever the production is tried, so a step
/// that leaves the string as it was is no fixed point when the block
/// changed a variable: `g` counts the steps in `A`'s block (its own
/// variable, kept between applications), and `A` becomes `B` in step 4
/// (cpfg: generate.c's Derive runs the pre-condition block before the
/// condition each step). By hand, and tests/tools/cpfg_ref.py agrees: B.
/// lsgen used to stop stepping after step 1 (the string unchanged, no
/// draw) and print A, unless a header block existed.
#[test]
fn a_production_block_keeps_an_unchanged_string_stepping() {
    let dir = tempdir();
    let src =
        "Lsystem: 1\nderivation length: 5\nAxiom: A\nA : {g = g + 1;} g > 3 --> B\nendlsystem\n";
    let file = write(dir.path(), "pb.l", src);
    assert_eq!(derive(&[], &file).0, "B\n");
    // Three steps are not enough.
    assert_eq!(derive(&["-n", "3"], &file).0, "A\n");
}

/// A homomorphism, whose depth warnings are on by default in cpfg, does
/// not keep a string that stopped changing stepping: a billion steps end
/// at the fixed point (lsgen stepped through all of them). By hand:
/// A(0) -> A(1)B -> A(2)BB -> A(3)BBB, then unchanged; B -> C.
#[test]
fn a_homomorphism_keeps_the_fixed_point_stop() {
    let dir = tempdir();
    let file = write(
        dir.path(),
        "fp.l",
        "Lsystem: 1\nderivation length: 1000000000\nAxiom: A(0)\n\
         A(x) : x < 3 --> A(x+1)B\nhomomorphism\nB --> C\nendlsystem\n",
    );
    let (out, err) = derive(&["-v"], &file);
    assert_eq!(out, "A(3)CCC\n");
    assert!(
        err.contains("steps 5..1000000000: unchanged (fixed point)"),
        "{err}"
    );
}

/// A decomposition of maximum depth 0 only tries its productions, never
/// applies them: a post-condition block there never runs, and does not
/// keep a string that stopped changing stepping (it did: a billion steps).
/// A pre-condition block runs at each try, so it does. By hand: A stays A
/// (cpfg_ref.py agrees at -n 5).
#[test]
fn a_depth_0_decomposition_keeps_the_fixed_point_unless_its_tries_run_blocks() {
    let dir = tempdir();
    let src = |block: &str| {
        format!(
            "Lsystem: 1\nderivation length: 1000000000\nAxiom: A\nA --> A\n\
             decomposition\nmaximum depth: 0\nA : {block} --> B\nendlsystem\n"
        )
    };
    let file = write(dir.path(), "post.l", src("* {g = g + 1;}"));
    let (out, err) = derive(&["-v"], &file);
    assert_eq!(out, "A\n");
    assert!(
        err.contains("steps 2..1000000000: unchanged (fixed point)"),
        "{err}"
    );
    let file = write(dir.path(), "pre.l", src("{g = g + 1;} *"));
    let (out, err) = derive(&["-v", "-n", "5"], &file);
    assert_eq!(out, "A\n");
    assert!(!err.contains("fixed point"), "{err}");
}

/// At the decomposition's and the homomorphism's depth limit cpfg still
/// tries the productions of the module it keeps (generate.c,
/// interpret.c's InterpretHomomorphism), evaluating their conditions:
/// `1/x` with `x` 0 divides by 1 and warns there, and `x % x` crashes
/// cpfg (a located error here), with the sections' warnings off too.
/// lsgen skipped such tries unless they drew or ran a block (and missed
/// a condition that is one division, such as `1/x`, when it first
/// tested for divisions). By hand: B(0) becomes C(0) at depth 1, which
/// keeps it; C's condition is then evaluated. tests/tools/cpfg_ref.py
/// agrees on each case.
#[test]
fn tries_at_the_depth_limit_warn_and_fail_as_in_cpfg() {
    let dir = tempdir();
    let division = "lsgen: warning: division by zero in a cpfg expression: divided by 1 \
                    instead, as cpfg does\n";
    let hom = |cond: &str| {
        format!(
            "Lsystem: 1\nderivation length: 0\nAxiom: B(0)\nhomomorphism no warnings\n\
             B(x) --> C(x)\nC(x) : {cond} --> D\nendlsystem\n"
        )
    };
    let decomp = |cond: &str| {
        format!(
            "Lsystem: 1\nderivation length: 1\nAxiom: A(0)\nA(x) --> B(x)\n\
             decomposition no warnings\nB(x) --> C(x)\nC(x) : {cond} --> D\nendlsystem\n"
        )
    };
    for (i, src) in [
        hom("1/x > 0"),
        hom("1/x"),
        hom("x/x"),
        hom("(1/x)"),
        decomp("1/x"),
        decomp("2 < 1/x"),
    ]
    .iter()
    .enumerate()
    {
        let file = write(dir.path(), &format!("div{i}.l"), src);
        let (out, err) = derive(&[], &file);
        assert_eq!((out.as_str(), err.as_str()), ("C(0)\n", division), "{src}");
    }
    for (i, (src, line, pass)) in [
        (hom("x % x > 0"), 6, "the homomorphism"),
        (decomp("x % x"), 7, "step 1"),
    ]
    .iter()
    .enumerate()
    {
        let file = write(dir.path(), &format!("rem{i}.l"), src);
        let r = run(lsgen().arg(&file));
        let err = r.fails(1);
        let want = format!(
            "lsgen: {}:{line}:8: error: remainder by zero (`x % 0` crashes cpfg) (in {pass})\n",
            file.display()
        );
        assert!(err.starts_with(&want), "{src}\n{err}");
    }
    // A successor that never applies is never evaluated: no warning (its
    // constant division is not worked out when the file is read). The
    // axiom is evaluated: there it warns.
    let file = write(
        dir.path(),
        "never.l",
        "Lsystem: 1\nderivation length: 1\nAxiom: A\nC --> B(1/0)\nendlsystem\n",
    );
    assert_eq!(derive(&[], &file), ("A\n".to_string(), String::new()));
    let file = write(
        dir.path(),
        "axiom.l",
        "Lsystem: 1\nderivation length: 1\nAxiom: A(1/0)\nC --> B(1/0)\nendlsystem\n",
    );
    assert_eq!(
        derive(&[], &file),
        ("A(1)\n".to_string(), division.to_string())
    );
}

/// Several `derivation length:` lines: the last sets the number of steps
/// (lsys_input.y's Dlength assigns `LsysPtr->n` each time) but `Z` keeps
/// the first's value: each line also calls SymbolTableAdd("Z"), which
/// appends a second entry to the global table, and SymbolTableFind
/// returns the first (generate.c). (With `-v`, cpfg reports that second
/// entry as an error and refuses the file; by default it says nothing.)
/// By hand: 3 steps from A(2), each adding 1, and B reads Z: A(5)B(2).
#[test]
fn the_last_derivation_length_counts_the_first_is_z() {
    let dir = tempdir();
    let file = write(
        dir.path(),
        "dl.l",
        "Lsystem: 1\nderivation length: 2\nderivation length: Z + 1\nAxiom: A(Z) C\n\
         A(x) --> A(x+1)\nC --> B(Z)\nendlsystem\n",
    );
    assert_eq!(derive(&[], &file).0, "A(5)B(2)\n");
}

/// `=(x)` in a right context skips the branch as `=` does, whatever its
/// parameters: generate.c's RconDiff switches on the symbol `=` alone,
/// and GetRconVars binds nothing from it, so `x` stays the production's
/// variable: 0 until a block assigns it, kept between applications (the
/// production's symbol table). By hand, and tests/tools/cpfg_ref.py
/// gives both strings: `B`'s context skips `D(5)`, reaches `]` and
/// `C(7)`: X(0,1,7); counting in `x` over three steps gives B(3). lsgen
/// used to read `=(x)` as a module `=` with one parameter, which nothing
/// matched.
#[test]
fn a_skip_with_parameters_skips_and_binds_nothing() {
    let dir = tempdir();
    for (n, succ, want) in [
        ("1", "* --> X(x,y,z)", "A[X(0,1,7)D(5)]C(7)"),
        ("3", "{x = x + 1;} * --> B(x)", "A[B(3)D(5)]C(7)"),
    ] {
        let file = write(
            dir.path(),
            "skip.l",
            format!(
                "Lsystem: 1\nderivation length: {n}\nAxiom: A[B(1)D(5)]C(7)\n\
                 B(y) > =(x)]C(z) : {succ}\nendlsystem\n"
            ),
        );
        assert_eq!(derive(&[], &file).0, format!("{want}\n"), "{succ}");
    }
}

/// `Q` and `Z` are cpfg's global variables from the `derivation length:`
/// line on (lsys_input.y's Dlength adds them to the global symbol table),
/// and a block assigns them like any global (lsys_input.y's LHS finds
/// them there): in a header block, a production's pre- or post-condition
/// block, the decomposition's and the homomorphism's. generate.c's Derive
/// sets `Q` to the step number at the start of each step, before
/// `StartEach:`, so an assignment lasts until the next step; the
/// homomorphism, interpreted after the steps, reads what the blocks left.
/// Nothing sets `Z` again, and it does not change the number of steps
/// (control.c's GenerateNSteps runs `LsysPtr->n` of them). lsgen used to
/// refuse every such assignment. Each string by hand (below), and
/// tests/tools/cpfg_ref.py gives the same.
#[test]
fn q_and_z_can_be_assigned_in_blocks() {
    let dir = tempdir();
    let cases: [(&[&str], &str, &str); 12] = [
        // StartEach: step 1 Q=1: A B(1); step 2 Q=2, then 10: A B(10)
        // B(1); step 3 Q=3: A B(3) B(10) B(1).
        (
            &[],
            "derivation length: 3\nStartEach: {if (Q == 2) {Q = 10;}}\nAxiom: A\n\
             A --> A B(Q)",
            "AB(3)B(10)B(1)",
        ),
        // A post-condition block, seen by the modules after it in the
        // step, and set again by the next step: step 1 Q=1: B(1), then
        // Q=10: B(10); step 2 Q=2: B(2), Q=20: B(20).
        (
            &[],
            "derivation length: 2\nAxiom: B(0) A B(0)\nA : * {Q = Q * 10;} --> A\n\
             B(x) --> B(Q)",
            "B(2)AB(20)",
        ),
        // A pre-condition block runs also where the condition fails: step
        // 1 Q=9 before B(0); step 2 likewise.
        (
            &[],
            "derivation length: 2\nAxiom: A B(0)\nA : {Q = 9;} 0 --> X\nB(x) --> B(Q)",
            "AB(9)",
        ),
        // A decomposition's post-condition block: A -> C -> D sets Q=50
        // before B(0) is rewritten.
        (
            &[],
            "derivation length: 1\nAxiom: A B(0)\nA --> C\nB(x) --> B(Q)\n\
             decomposition\nC : * {Q = 50;} --> D",
            "DB(50)",
        ),
        // A homomorphism's pre-condition block, after step 1 (Q=1): the
        // first A makes Q=2, the second Q=3.
        (
            &[],
            "derivation length: 1\nAxiom: A A\nA --> A\nhomomorphism\n\
             A : {Q = Q + 1;} * --> A(Q)",
            "A(2)A(3)",
        ),
        // End: runs after the last step, before the homomorphism reads Q:
        // B(100); with -n 1 End: does not run (cpfg's endFlag): B(1).
        (
            &[],
            "derivation length: 2\nEnd: {Q = 100;}\nAxiom: A\nA --> A\nhomomorphism\n\
             A --> B(Q)",
            "B(100)",
        ),
        (
            &["-n", "1"],
            "derivation length: 2\nEnd: {Q = 100;}\nAxiom: A\nA --> A\nhomomorphism\n\
             A --> B(Q)",
            "B(1)",
        ),
        // Start: Q=5 (the axiom's interpretation, 0 steps); EndEach adds
        // 100 after each step: 1 + 100, then 2 + 100.
        (
            &["-n", "0"],
            "derivation length: 2\nStart: {Q = 5;}\nEndEach: {Q = Q + 100;}\nAxiom: A\n\
             A --> A\nhomomorphism\nA --> B(Q)",
            "B(5)",
        ),
        (
            &[],
            "derivation length: 2\nStart: {Q = 5;}\nEndEach: {Q = Q + 100;}\nAxiom: A\n\
             A --> A\nhomomorphism\nA --> B(Q)",
            "B(102)",
        ),
        // Z: Start: 3 + 1 = 4; step 1 A(4), then Z=8; step 2 A(8), Z=16;
        // step 3 A(16), Z=32. Three steps still (not 4, 8 or 32).
        (
            &[],
            "derivation length: 3\nStart: {Z = Z + 1;}\nEndEach: {Z = Z * 2;}\n\
             Axiom: A(0)\nA(x) --> A(Z)",
            "A(16)",
        ),
        // Z in a production's pre-condition block, read by the successor
        // and the homomorphism: Z = 3 in step 1, A(3); 4 in step 2, A(4);
        // the homomorphism's B(Z, Q) is B(4, 2) (its A(x) tried at depth
        // 1 would warn, hence `no warnings`).
        (
            &[],
            "derivation length: 2\nAxiom: A(0)\nA(x) : {Z = Z + 1;} * --> A(Z)\n\
             homomorphism no warnings\nA(x) --> A(x) B(Z, Q)",
            "A(4)B(4,2)",
        ),
        // `=(Q)` in a right context makes `Q` the production's own
        // variable (cpfg adds a formal to the production's table; the
        // skip binds nothing): B counts 5, 10, 15 in it, while X reads
        // the global Q, the step.
        (
            &[],
            "derivation length: 3\nAxiom: A[B(1)D(5)]C(7) X(0)\n\
             B(y) > =(Q)]C(z) : {Q = Q + 5;} * --> B(Q)\nX(x) --> X(Q)",
            "A[B(15)D(5)]C(7)X(3)",
        ),
    ];
    for (args, body, want) in cases {
        let src = format!("Lsystem: 1\n{body}\nendlsystem\n");
        let file = write(dir.path(), "qz.l", &src);
        let (out, err) = derive(args, &file);
        assert_eq!(out, format!("{want}\n"), "{args:?} {src}");
        assert_eq!(err, "", "{src}");
    }
    // The same blocks in frames: each frame is interpreted after its
    // step's EndEach:, as cpfg's animation interprets it.
    let file = write(
        dir.path(),
        "frames.l",
        "Lsystem: 1\nderivation length: 2\nStart: {Q = 5;}\nEndEach: {Q = Q + 100;}\n\
         Axiom: A\nA --> A\nhomomorphism\nA --> B(Q)\nendlsystem\n",
    );
    assert_eq!(
        derive(&["--frames", "0..2"], &file).0,
        "B(5)\nB(101)\nB(102)\n"
    );
}

/// cpfg tries the productions at the depth limit: generate.c's
/// ApplyRecursiveProductions and interpret.c's InterpretHomomorphism look
/// for the module's first applicable production (contexts, then CondDiff:
/// the pre-condition block, then the condition) before they compare the
/// depth with `maximum depth:`, then keep the module there. So the blocks
/// and conditions of the productions tried run, up to the first that
/// applies (which is not applied: no post-condition block). lsgen used to
/// only check whether one would apply, for the warning, without running
/// them. By hand (below); tests/tools/cpfg_ref.py gives the same strings.
#[test]
fn productions_are_tried_at_the_depth_limit() {
    let dir = tempdir();
    let cases: [(&str, &str, &str); 5] = [
        // Step 1: A -> B; B -> C at depth 0; C at depth 1 (the limit) is
        // tried: n = 1, and kept. Step 2: X(0) -> X(1); C -> D at depth 0
        // (n = 2), D kept. (Without the try: X(0)D.)
        (
            "derivation length: 2\nStart: {n = 0;}\nAxiom: X(0) A\nX(x) --> X(n)\nA --> B\n\
             decomposition\nmaximum depth: 1\nB --> C\nC : {n = n + 1;} * --> D",
            "X(1)D",
            "maximum depth 1",
        ),
        // The homomorphism (depth 1, no warnings): A -> B C; C at depth 1
        // is tried (n = 1) before Y reads n. (Without the try: Y(0).)
        (
            "derivation length: 1\nStart: {n = 0;}\nAxiom: A Y\nA --> A\n\
             homomorphism no warnings\nA --> B C\nC : {n = n + 1;} * --> E\nY --> Y(n)",
            "BCY(1)",
            "",
        ),
        // A decomposition of maximum depth 0 decomposes nothing, but
        // ApplyRecursiveProductions tries A at depth 0 in each step:
        // n = 1 after step 1, read by X in step 2. (Without: X(0)A.)
        (
            "derivation length: 2\nStart: {n = 0;}\nAxiom: X(0) A\nX(x) --> X(n)\n\
             decomposition\nmaximum depth: 0\nA : {n = n + 1;} * --> B",
            "X(1)A",
            "",
        ),
        // Only up to the first that applies: C's second production is
        // not tried (m stays 0) and the third's post block does not run.
        (
            "derivation length: 2\nStart: {n = 0; m = 0;}\nAxiom: X(0,0) A\n\
             X(x,y) --> X(n,m)\nA --> B\ndecomposition no warnings\nB --> C\n\
             C : {n = n + 1;} * --> D\nC : {m = m + 1;} * --> E\nC : * {m = 5;} --> F",
            "X(1,0)D",
            "",
        ),
        // A condition that draws (`ran`) draws at the limit too: C's
        // condition takes the first number of cpfg's ran generator
        // (0.170828), Y's successor the second (0.749902).
        (
            "derivation length: 1\nAxiom: A\nA --> B Y\ndecomposition no warnings\n\
             B --> C\nC : ran(1) > 2 --> D\nY --> Y(ran(1))",
            "CY(0.749902)",
            "",
        ),
    ];
    for (body, want, warning) in cases {
        let src = format!("Lsystem: 1\n{body}\nendlsystem\n");
        let file = write(dir.path(), "limit.l", &src);
        let (out, err) = derive(&[], &file);
        assert_eq!(out, format!("{want}\n"), "{src}");
        if warning.is_empty() {
            assert_eq!(err, "", "{src}");
        } else {
            assert!(err.contains(warning), "{src}: {err}");
        }
    }
}

/// A decomposition's contexts are those of the whole predecessor in the
/// string before the step: cpfg's `ApplyProd` (generate.c) moves past the
/// predecessor's `predLen` modules before `ApplyRecursiveProductions`, so
/// the right context of a module made from `A B` is what follows `B`. By
/// hand, for `X A B Y` and `A B --> A B C`: C's left context is X, its
/// right context Y, so `C > Y` applies and `C > B` does not (lsgen read
/// the right context after `A`: `B`, the other way round). Tries at the
/// depth limit see the same contexts: with `maximum depth: 0` and a
/// pre-condition block counting the tries that match (`C(x) > Y`), step 1
/// makes C(0), tried with Y to its right (n = 1); step 2 makes C(1), tried
/// with C(0) to its right (no match), and C(0), copied, is tried with Y
/// (n = 2); step 3 makes C(2): `XABC(2)C(1)C(0)Y` (cpfg_ref.py agrees;
/// lsgen gave `XABC(1)C(0)C(0)Y`).
#[test]
fn decomposition_contexts_follow_the_whole_predecessor() {
    let dir = tempdir();
    let cases = [
        (
            "derivation length: 1\nAxiom: X A B Y\nA B --> A B C\ndecomposition\nC > Y --> D",
            "XABDY\n",
        ),
        (
            "derivation length: 1\nAxiom: X A B Y\nA B --> A B C\ndecomposition\nC > B --> D",
            "XABCY\n",
        ),
        (
            "derivation length: 3\nStart: {n = 0;}\nAxiom: X A B Y\nA B --> A B C(n)\n\
             decomposition\nmaximum depth: 0\nC(x) > Y : {n = n + 1;} * --> D",
            "XABC(2)C(1)C(0)Y\n",
        ),
    ];
    for (body, want) in cases {
        let src = format!("Lsystem: 1\n{body}\nendlsystem\n");
        let file = write(dir.path(), "pred.l", &src);
        let (out, _) = derive(&[], &file);
        assert_eq!(out, want, "{src}");
    }
}

/// Blocks that assign `Q` run in string order on one thread, also with
/// `-j` and chunks of one byte (`LSGEN_TEST_SPLIT=1`): a `.l` file is
/// derived by the one-thread step engine (`par::step_threads`), since
/// every block sees what the ones before it assigned. By hand: step 1,
/// Q = 1, 10, 100 before each B; step 2, Q = 2, 20, 200 (cpfg_ref.py
/// agrees).
#[test]
fn assigned_q_runs_in_string_order_with_threads() {
    let dir = tempdir();
    let file = write(
        dir.path(),
        "j.l",
        "Lsystem: 1\nderivation length: 2\nAxiom: B(0) A B(0) A B(0)\n\
         A : * {Q = Q * 10;} --> A\nB(x) --> B(Q)\nendlsystem\n",
    );
    let r = run(lsgen()
        .env("LSGEN_TEST_SPLIT", "1")
        .args(["-j", "2"])
        .arg(&file));
    assert!(r.status.success(), "{}", r.stderr);
    assert_eq!(String::from_utf8(r.stdout).unwrap(), "B(2)AB(20)AB(200)\n");
}

/// cpfg reads the axiom after `Start:` (control.c's Rewind): a parameter
/// of the axiom may read a global, draw with `ran`/`nran` (after the
/// block's `srand`) and read the `Q` and `Z` it assigned; a global that
/// only later blocks assign is still 0. Expected strings from
/// tests/tools/cpfg_ref.py; the frames start from the same axiom.
#[test]
fn the_axiom_reads_what_start_assigned() {
    let dir = tempdir();
    let draws = write(
        dir.path(),
        "draws.l",
        "Lsystem: 1\nStart: {srand(5); k = ran(10);}\nderivation length: 2\n\
         Axiom: A(ran(1)) B(k) C(k/0) D(nran(1,2))\nA(x) --> A(x+1)\nendlsystem\n",
    );
    let (out, err) = derive(&[], &draws);
    assert_eq!(out, "A(2.27285)B(5.2484)C(5.2484)D(-0.226458)\n");
    assert!(err.contains("division by zero"), "{err}");
    let frames = run(lsgen().args(["--frames", "0..2"]).arg(&draws));
    assert_eq!(
        String::from_utf8(frames.stdout).unwrap(),
        "A(0.272854)B(5.2484)C(5.2484)D(-0.226458)\n\
         A(1.27285)B(5.2484)C(5.2484)D(-0.226458)\n\
         A(2.27285)B(5.2484)C(5.2484)D(-0.226458)\n"
    );
    let qz = write(
        dir.path(),
        "qz.l",
        "Lsystem: 1\nStart: {Z = 9; Q = 4;}\nEndEach: {w = 3;}\nderivation length: 3\n\
         Axiom: A(Z, Q, w) B(Q+Z*2)\nA(x,y,z) --> A(x+Q, y+Z, z)\nendlsystem\n",
    );
    for (n, want) in [("0", "A(9,4,0)B(22)\n"), ("3", "A(21,31,0)B(22)\n")] {
        assert_eq!(derive(&["-n", n], &qz).0, want, "-n {n}");
    }
    // Also where `Q` and `Z` are the L-system's own variables: `Z` named
    // in a block before `derivation length:`, `Q` without that line (these
    // three were located errors once).
    for (src, want) in [
        (
            "derivation length: 1\nStart: {Q = 1;}\nAxiom: A(Q)",
            "A(1)\n",
        ),
        (
            "Start: {Z = 7;}\nderivation length: 2\nAxiom: A(Z)",
            "A(7)\n",
        ),
        ("Start: {Q = 7;}\nAxiom: A(Q)", "A(7)\n"),
    ] {
        let file = write(
            dir.path(),
            "v.l",
            format!("Lsystem: 1\n{src}\nendlsystem\n"),
        );
        assert_eq!(derive(&[], &file).0, want, "{src}");
    }
    // Its errors are located in the axiom, as those of a constant one.
    for (src, col, what) in [
        ("Start: {z = 0;}\nAxiom: A(1, 1%z)", 13, "remainder by zero"),
        (
            "Start: {b = 1.0e30;}\nAxiom: A(b * 1.0e20)",
            10,
            "32-bit float",
        ),
        // A NaN is said to be one (it was "out of the range of a 32-bit
        // float").
        (
            "Start: {b = -1;}\nAxiom: A(sqrt(b))",
            10,
            "value is NaN (not a number)",
        ),
    ] {
        let file = write(
            dir.path(),
            "e.l",
            format!("Lsystem: 1\nderivation length: 1\n{src}\nendlsystem\n"),
        );
        let r = run(lsgen().arg(&file));
        let e = r.fails(1);
        assert!(
            e.starts_with(&format!("lsgen: {}:4:{col}: error: ", file.display()))
                && e.contains(what)
                && e.contains("(in the axiom)"),
            "{e}"
        );
        assert!(r.stdout.is_empty());
    }
}

/// cpfg's arrays (`define: { array ... }`, generate.c's AllocateArray,
/// ProcessArrayDef and tARRAYREF). By hand, one step of
/// `A(0) A(1) A(5) A(-1)` with a = {{1,2,3},{4,5,6}}, b = {10,20,0,0}
/// (too few initial values: the rest 0, a warning), `Start:` setting
/// c[1] = 7 and b[3] = a[1][2] * 100 = 600:
/// - A(0): the post-condition block makes b[0] 11: B(a[0][0], b[0], b[0],
///   c[1], a[0.5][1]), and a[0.5][1] is element (int)(0.5 * 3 + 1) = 2,
///   a[0][2] = 3: B(1,11,11,7,3).
/// - A(1): b[0] = 12: B(a[1][1], b[1], 12, 7, 3) = B(5,20,12,7,3).
/// - A(5): no block; b[5] is b[3] (clamped, with a warning), a[5][9] is
///   a[1][2]: C(600,600,6).
/// - A(-1): b[0] = 13; a[-1][-1] is a[0][0], b[-1] is b[0]: B(1,13,13,7,3).
#[test]
fn arrays_are_cpfgs() {
    let dir = tempdir();
    let src = "#define M 2\n#define N 3\nLsystem: 1\ndefine: {\n\
               \tarray a[M][N] = {1, 2, 3,\n\t                 4, 5, 6};\n\
               \tarray b[4] = {10, 20}, c[2];\n\t}\nderivation length: 2\n\
               Start: {c[1] = 7; b[3] = a[1][2] * 100;}\n\
               Axiom: A(0) A(1) A(5) A(-1)\n\
               A(i) : i < 2 {b[0] = b[0] + 1;} --> B(a[i][i], b[i], b[0], c[1], a[0.5][1])\n\
               A(i) --> C(b[i], b[3], a[i][9])\nendlsystem\n";
    let file = write(dir.path(), "a.l", src);
    for j in ["1", "4"] {
        let (out, err) = derive(&["-j", j], &file);
        assert_eq!(
            out,
            "B(1,11,11,7,3)B(5,20,12,7,3)C(600,600,6)B(1,13,13,7,3)\n"
        );
        assert!(
            err.contains("a.l:7:8: warning: too few initial values for `b`: 2 for 4 elements"),
            "{err}"
        );
        assert_eq!(
            err.matches("warning: an array subscript out of range")
                .count(),
            1,
            "{err}"
        );
    }
    // The arrays start again in each run, before `Start:`; they keep
    // their values from step to step.
    let counting = write(
        dir.path(),
        "c.l",
        "Lsystem: 1\ndefine: { array n[1] = {5}; }\nderivation length: 3\n\
         EndEach: {n[0] = n[0] * 2;}\nAxiom: A\nA --> A B(n[0])\nendlsystem\n",
    );
    assert_eq!(derive(&[], &counting).0, "AB(20)B(10)B(5)\n");
    assert_eq!(
        derive(&["--frames", "1..2"], &counting).0,
        "AB(5)\nAB(10)B(5)\n"
    );
    // cpfg evaluates the initial values twice: as the file is read (every
    // array) and before `Start:` (the last `define:`'s arrays): `ran`
    // draws each time. Expected strings from tests/tools/cpfg_ref.py.
    for (src, want) in [
        (
            "define: { array R[2] = {trunc(ran(1)*1000), 5}; }\n\
             derivation length: 0\nAxiom: X(R[0], trunc(ran(1)*1000))",
            "X(750,96)\n",
        ),
        (
            "define: { array A[1] = {trunc(ran(1)*1000)}; }\n\
             define: { array B[2] = {trunc(ran(1)*1000)}; }\n\
             derivation length: 0\nAxiom: X(A[0], B[0], B[1], trunc(ran(1)*1000))",
            "X(171,96,0,870)\n",
        ),
        // A dimension may read `Z` once `derivation length:` has set it.
        (
            "derivation length: 3\ndefine: { array a[Z]; }\nAxiom: A(Z)\n\
             A(x) --> A(x+1) B(a[2])",
            "A(6)B(0)B(0)B(0)\n",
        ),
    ] {
        let f = write(
            dir.path(),
            "r.l",
            format!("Lsystem: 1\n{src}\nendlsystem\n"),
        );
        assert_eq!(derive(&[], &f).0, want, "{src}");
    }
}

/// An array used wrongly is a located error: at load (a name that is no
/// array, one without its subscripts, the wrong number of subscripts, a
/// dimension below 1, too many elements, a name defined twice) or while
/// deriving (a NaN subscript; fractional subscripts that make an element
/// past the end, where cpfg reads outside the array).
#[test]
fn arrays_used_wrongly_are_located_errors() {
    let dir = tempdir();
    let cases: &[(&str, &str, &str)] = &[
        ("define: { array a[2]; }", "A --> B(x[1])", "5:9: error: `x` is not an array of `define:`"),
        ("define: { array a[2]; }", "A --> B(a)", "5:9: error: `a` is an array: an element needs its subscripts"),
        ("define: { array a[2]; }", "A --> B(a[1][1])", "5:9: error: `a` has 1 dimension, not 2"),
        ("define: { array a[2][2]; }", "A : {a = 1;} * --> B", "5:6: error: `a` is an array"),
        ("define: { array a[0]; }", "A --> B", "2:19: error: an array dimension must be at least 1, not 0"),
        ("define: { array a[1024][1025]; }", "A --> B", "2:25: error: the arrays of `define:` hold more than 1048576 elements"),
        ("define: { array a[2], a[3]; }", "A --> B", "2:23: error: the array `a` is defined twice"),
        ("define: { array g[2]; }\nStart: {g = 1;}", "A --> B", "2:17: error: `g` is a variable of the blocks"),
        ("define: { array a[2]; }", "A --> B(a[sqrt(0-1)])", "5:9: error: an array subscript is not a number (in step 1)"),
        ("define: { array a[2][3]; }", "A --> B(a[1.9][2])", "5:9: error: the subscripts make element 7 of an array of 6 (cpfg goes past its end) (in step 1)"),
    ];
    for (define, prod, want) in cases {
        let file = write(
            dir.path(),
            "e.l",
            format!("Lsystem: 1\n{define}\nderivation length: 1\nAxiom: A\n{prod}\nendlsystem\n"),
        );
        let r = run(lsgen().arg(&file));
        let e = r.fails(1);
        assert!(
            e.starts_with(&format!("lsgen: {}:{want}", file.display())),
            "{want}\n{e}"
        );
        assert!(r.stdout.is_empty());
    }
}

/// A string is a value: its number in cpfg's global string table, which
/// takes every string literal of the file in order as the parser meets it
/// (control.c's `GlobalStringIndex`), `printf` formats included. By hand:
/// the `printf` format is string 0, `" %.f"` 1, `"x"` 2, `"y"` 3, `"z"` 4.
#[test]
fn strings_are_their_numbers() {
    let dir = tempdir();
    let file = write(
        dir.path(),
        "s.l",
        "Lsystem: 1\nderivation length: 1\nStart: {printf(\"start\\n\");}\nAxiom: A(3)\n\
         A(c) --> @L(\" %.f\", c) B(\"x\") C(\"y\", \"z\")\nendlsystem\n",
    );
    let (out, err) = derive(&[], &file);
    assert_eq!(out, "@L(1,3)B(2)C(3,4)\n");
    assert_eq!(err, "start\n");
}

/// The blocks of a predecessor of several modules may assign the
/// parameters of its later modules: the successor sees what they left, as
/// cpfg's does (its formals are one table). Strings from
/// tests/tools/cpfg_ref.py; by hand: v = 0 * 2 = 0, u = 0 + 7, C(7, 7);
/// the seeded choice keeps the chosen production's values, C(5, 0).
#[test]
fn blocks_assign_the_later_modules_of_a_predecessor() {
    let dir = tempdir();
    let file = write(
        dir.path(),
        "run.l",
        "Lsystem: 1\nderivation length: 1\nAxiom: A(2) A(0) C(1)\n\
         A(u) < A(z) : {u = 2;} 0 --> D\n\
         A(u) C(v) : {v = u * 2;} 1 {u = v + 7;} --> C(v + 7, u)\nendlsystem\n",
    );
    assert_eq!(derive(&[], &file).0, "A(2)C(7,7)\n");
    let seeded = write(
        dir.path(),
        "seeded.l",
        "Lsystem: 1\nderivation length: 1\nseed: 3\nAxiom: A(0) C(1)\n\
         A(u) C(v) : {v = 5;} 1 --> C(v, u)\nendlsystem\n",
    );
    assert_eq!(derive(&[], &seeded).0, "C(5,0)\n");
}

/// A NaN stored into a parameter while deriving is said to be one, at the
/// production's place and step (it was "out of the range of a 32-bit
/// float", which NaN is not).
#[test]
fn a_nan_parameter_is_named_nan() {
    let dir = tempdir();
    let src = "Lsystem: 1\nAxiom: A(1)\nA(x) --> B(sqrt(-x))\nendlsystem\n";
    let file = write(dir.path(), "nan.l", src);
    for strategy in ["step", "auto"] {
        let r = run(lsgen().args(["-n", "1", "--strategy", strategy]).arg(&file));
        let e = r.fails(1);
        assert!(
            e.contains(":3:12: error: the value is NaN (not a number)")
                && e.contains("(in step 1)"),
            "{e}"
        );
    }
}

/// A `.l` file whose every line warns (150 `#pragma`s): the first 100
/// warnings are shown, then one at line 101 counting the other 50; a file
/// of a million such lines held a million located warnings (378 MiB for
/// 1.5 million) and printed them all.
#[test]
fn a_file_shows_its_first_100_warnings_and_counts_the_rest() {
    let dir = tempdir();
    let src = format!(
        "{}Lsystem: 1\nAxiom: A\nA --> B\nendlsystem\n",
        "#pragma x\n".repeat(150)
    );
    let file = write(dir.path(), "w.l", src);
    let (out, err) = derive(&["-n", "1"], &file);
    assert_eq!(out, "B\n");
    let name = file.display();
    let pragma =
        |line: usize| format!("lsgen: {name}:{line}:1: warning: #pragma ignored\n#pragma x\n^\n");
    let mut want: String = (1..=100).map(pragma).collect();
    want.push_str(&format!(
        "lsgen: {name}:101:1: warning: 50 more warnings from here on not shown (a file's first 100 are)\n#pragma x\n^\n"
    ));
    assert_eq!(err, want);
}
