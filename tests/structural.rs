//! Issue 11 (docs/structural.md): decomposition, homomorphism depth, the
//! cut `%`, production groups and `step`, run through the real binary.
//! Expected strings come from the independent Python reference
//! (tests/tools/ref.py writes tests/expected/structural/), never from
//! lsgen; every strategy that accepts a system must give them.

mod common;

use common::{lsgen, run, tempdir, ROOT};
use std::path::Path;

/// Run `lsgen -n N --strategy S FILE` and return stdout, asserting success.
fn derive(file: &Path, n: &str, strategy: &str) -> String {
    let r = run(lsgen().args(["-n", n, "--strategy", strategy]).arg(file));
    assert!(
        r.status.success(),
        "{}: {} ({})",
        r.what,
        r.stderr,
        r.status
    );
    String::from_utf8(r.stdout).unwrap()
}

/// The models of tests/structural/ against every `NAME.nN.txt` in
/// tests/expected/structural/ (shedding_plant, compound_leaf and
/// alternating_tables moved to examples/ and tests/expected/, where
/// tests/examples.rs checks them; checked here too, with both strategies).
#[test]
fn every_structural_model_matches_the_reference() {
    let dir = Path::new(ROOT).join("tests/expected/structural");
    let mut checked = 0;
    for entry in std::fs::read_dir(&dir).unwrap() {
        let path = entry.unwrap().path();
        let name = path.file_name().unwrap().to_str().unwrap().to_string();
        let Some(stem) = name.strip_suffix(".txt") else {
            continue;
        };
        let Some((model, n)) = stem.rsplit_once(".n") else {
            continue;
        };
        let mut file = Path::new(ROOT).join(format!("tests/structural/{model}.ls"));
        if !file.exists() {
            file = Path::new(ROOT).join(format!("examples/{model}.ls"));
        }
        let want = std::fs::read_to_string(&path).unwrap();
        for strategy in ["auto", "step"] {
            assert_eq!(
                derive(&file, n, strategy),
                want,
                "{model} -n {n} --strategy {strategy}"
            );
        }
        checked += 1;
    }
    for (model, n) in [
        ("shedding_plant", 3),
        ("shedding_plant", 5),
        ("compound_leaf", 3),
        ("alternating_tables", 6),
    ] {
        let want = std::fs::read_to_string(
            Path::new(ROOT).join(format!("tests/expected/{model}.n{n}.txt")),
        )
        .unwrap();
        let file = Path::new(ROOT).join(format!("examples/{model}.ls"));
        for strategy in ["auto", "step"] {
            assert_eq!(
                derive(&file, &n.to_string(), strategy),
                want,
                "{model} -n {n}"
            );
        }
    }
    assert!(checked >= 16, "only {checked} expected files found");
}

/// The 300 random systems of random_cases.txt (every feature, written by
/// tests/tools/gen_cross_cases.py with ref.py).
#[test]
fn random_cases_match_the_reference() {
    let text =
        std::fs::read_to_string(Path::new(ROOT).join("tests/expected/structural/random_cases.txt"))
            .unwrap();
    let dir = tempdir();
    let file = dir.path().join("case.ls");
    let mut cases = 0;
    for case in text.split("=== ").skip(1) {
        let (n, rest) = case.split_once('\n').unwrap();
        let (src, want) = rest.split_once("--- expected\n").unwrap();
        std::fs::write(&file, src).unwrap();
        for strategy in ["auto", "step"] {
            assert_eq!(
                derive(&file, n.trim(), strategy).trim_end_matches('\n'),
                want.trim_end_matches('\n'),
                "case {cases} (-n {n}, --strategy {strategy}):\n{src}"
            );
        }
        cases += 1;
    }
    assert_eq!(cases, 300);
}

/// Systems that use a feature of issue 11 are not derived depth first.
#[test]
fn depth_first_refuses_structural_systems() {
    let dir = tempdir();
    for (i, src) in [
        "groups: 1\nproductions:\nA -> AB\nproductions 1:\nB -> C\naxiom: A\n",
        "productions:\nA -> AL\ndecomposition:\nL -> F\naxiom: A\n",
        "productions:\nA -> A%\naxiom: A\n",
        "productions:\nA -> AF\naxiom: A[%A]A\n",
        "productions:\nA -> F(step)A\naxiom: A\n",
        "productions:\nA -> AB\nhomomorphism:\nmaximum depth: 2\nB -> C\nC -> D\naxiom: A\n",
    ]
    .iter()
    .enumerate()
    {
        let file = dir.path().join(format!("s{i}.ls"));
        std::fs::write(&file, src).unwrap();
        let r = run(lsgen().args(["-n", "2", "--strategy", "dfs"]).arg(&file));
        assert_eq!(r.status.code(), Some(2), "{src}: {}", r.stderr);
        assert!(
            r.stderr.contains("cannot be derived depth first"),
            "{}",
            r.stderr
        );
    }
}

/// A seeded stochastic system with groups, decomposition and a cut is
/// byte-identical across runs (and `--seed` changes it).
#[test]
fn seeded_stochastic_groups_are_reproducible() {
    let dir = tempdir();
    let file = dir.path().join("s.ls");
    std::fs::write(
        &file,
        "seed: 7\ngroups: 1 2\nproductions:\nA -> A[+B]\nB -> BF : 1\nB -> % : 1\n\
         productions 1:\nA -> AA : 1\nA -> A[-B] : 2\nproductions 2:\nB -> B[+A] : 1\n\
         decomposition:\nF -> G(ran(1)) : 1\nF -> F : 1\naxiom: A\n",
    )
    .unwrap();
    let a = derive(&file, "7", "auto");
    let b = derive(&file, "7", "step");
    assert_eq!(a, b);
    assert_eq!(a, derive(&file, "7", "auto"));
    assert!(a.len() > 50, "{a}");
    let r = run(lsgen().args(["-n", "7", "--seed", "8"]).arg(&file));
    assert_ne!(r.stdout, a.as_bytes());
}

/// The cut keeps the `]` and drops the branch; a `%` with a production
/// that applies is not a cut; the homomorphism never cuts (hand-derived,
/// docs/structural.md section 5).
#[test]
fn cut_by_hand() {
    let dir = tempdir();
    let cases = [
        (
            "productions:\nA -> B\naxiom: A[+%F[G]H]I%J\n",
            "1",
            "B[+]I\n",
        ),
        ("productions:\n% -> %\naxiom: A[%B]C\n", "1", "A[%B]C\n"),
        ("homomorphism:\nA -> %\naxiom: A[%B]C\n", "0", "%[%B]C\n"),
        (
            "productions:\nD(a) : a < 20 -> D(a+1)\nD(a) : a >= 20 -> %\naxiom: A[+D(19)F]B\n",
            "3",
            "A[+]B\n",
        ),
    ];
    for (i, (src, n, want)) in cases.iter().enumerate() {
        let file = dir.path().join(format!("c{i}.ls"));
        std::fs::write(&file, src).unwrap();
        assert_eq!(derive(&file, n, "auto"), *want, "{src}");
    }
}

/// `warnings` (docs/structural.md, section 4): once per section per run, at
/// the first production in file order that would still apply; the output
/// and the exit status are unchanged; without `warnings`, silence.
#[test]
fn depth_warnings() {
    let dir = tempdir();
    let file = dir.path().join("p.ls");
    let src = "derivation length: 3\nproductions:\nA -> AL\ndecomposition: warnings\n\
               maximum depth: 2\nL -> [+P][-P]\nP : 2 < 1 -> S\nP -> Q\nQ -> R\naxiom:\nA\n";
    std::fs::write(&file, src).unwrap();
    let r = run(lsgen().arg(&file));
    assert!(r.status.success(), "{}", r.stderr);
    // Step 1: L -> [+P][-P] (depth 1), P -> Q (depth 2), Q kept at the
    // limit although `Q -> R` applies; steps 2 and 3 rewrite the kept Q.
    assert_eq!(
        String::from_utf8(r.stdout).unwrap(),
        "A[+Q][-Q][+R][-R][+R][-R]\n"
    );
    assert_eq!(
        r.stderr,
        format!(
            "lsgen: {}:9:1: warning: decomposition stopped at maximum depth 2, but this \
             production still applies (to module Q, in step 1)\nQ -> R\n^\n",
            file.display()
        )
    );
    // Without `warnings`: the same string, nothing on stderr.
    std::fs::write(
        &file,
        src.replace("decomposition: warnings", "decomposition:"),
    )
    .unwrap();
    let r = run(lsgen().arg(&file));
    assert_eq!(
        String::from_utf8(r.stdout).unwrap(),
        "A[+Q][-Q][+R][-R][+R][-R]\n"
    );
    assert_eq!(r.stderr, "");

    // The homomorphism, default depth 1: G -> K would apply to the G made
    // by F -> G; the false condition before it does not count.
    std::fs::write(
        &file,
        "homomorphism: warnings\nF -> G\nG : 1 > 2 -> H\nG -> K\naxiom:\nFF\n",
    )
    .unwrap();
    let r = run(lsgen().arg(&file));
    assert_eq!(String::from_utf8(r.stdout).unwrap(), "GG\n");
    assert_eq!(
        r.stderr,
        format!(
            "lsgen: {}:4:1: warning: homomorphism stopped at maximum depth 1, but this \
             production still applies (to module G)\nG -> K\n^\n",
            file.display()
        )
    );
}

/// A constant or a formal parameter named `step` hides the built-in, with
/// a warning at its place (docs/structural.md, section 7).
#[test]
fn step_hidden_by_a_constant_or_parameter() {
    let dir = tempdir();
    let file = dir.path().join("p.ls");
    std::fs::write(
        &file,
        "define: step = 7\nproductions:\nA(step) -> A(step+1)B(step)\nB(x) -> C(step)\naxiom:\nA(1)\n",
    )
    .unwrap();
    let r = run(lsgen().args(["-n", "2"]).arg(&file));
    assert!(r.status.success(), "{}", r.stderr);
    // A's parameter hides the constant in A's production; B's sees 7.
    assert_eq!(String::from_utf8(r.stdout).unwrap(), "A(3)B(2)C(7)\n");
    let p = file.display();
    assert_eq!(
        r.stderr,
        format!(
            "lsgen: {p}:1:1: warning: `step` hides the built-in step number\ndefine: step = 7\n^\n\
             lsgen: {p}:3:3: warning: `step` hides the built-in step number\n\
             A(step) -> A(step+1)B(step)\n  ^\n"
        )
    );
    // Without them, `step` is the step number: 1, then 2.
    std::fs::write(&file, "productions:\nA(x) -> A(x+step)\naxiom:\nA(0)\n").unwrap();
    assert_eq!(derive(&file, "3", "auto"), "A(6)\n");
}

/// One module's decomposition can be huge (2^40 modules here): the output
/// is flushed, and so checked against --max-length, as it is written.
#[test]
fn a_huge_decomposition_meets_max_length() {
    let dir = tempdir();
    let file = dir.path().join("p.ls");
    std::fs::write(
        &file,
        "productions:\nX -> X\ndecomposition:\nmaximum depth: 40\nA -> AA\naxiom:\nA\n",
    )
    .unwrap();
    let out = dir.path().join("out.txt");
    let r = run(lsgen()
        .args(["-n", "1", "--max-length", "1000000"])
        .arg(&file)
        .arg("-o")
        .arg(&out));
    assert_eq!(r.status.code(), Some(1), "{}", r.stderr);
    assert!(
        r.stderr
            .contains("--max-length (1000000 modules) in step 1"),
        "{}",
        r.stderr
    );
    assert!(!out.exists());
}

/// Structural keyword lines take any blank README calls a blank (the
/// no-break space here) and comments between their words, as other lines
/// do between tokens: `groups:`, `productions N:`, `warnings` / `no
/// warnings` and `maximum depth:` (lsgen 9b99c7d split them at spaces and
/// tabs only, and stopped reading them at a comment).
#[test]
fn keyword_lines_take_unicode_blanks_and_comments() {
    const NBSP: &str = "\u{a0}";
    let dir = tempdir();
    let file = dir.path().join("p.ls");
    let lsgen = |src: &str, n: &str| {
        std::fs::write(&file, src).unwrap();
        let r = run(lsgen().args(["-n", n]).arg(&file));
        assert!(r.status.success(), "{src:?}: {}", r.stderr);
        (String::from_utf8(r.stdout).unwrap(), r.stderr)
    };
    // Step 1 in group 1 (A -> AB), step 2 in group 2 (B -> C): both
    // groups read.
    let two_groups = "productions 1:\nA -> AB\nproductions 2:\nB -> C\naxiom: A\n";
    for groups in [
        "groups: 1 /* c */ 2".to_string(),
        "groups: /* c */ 1 2".to_string(),
        format!("groups: 1{NBSP}2"),
        format!("groups:{NBSP}1{NBSP}/* c */{NBSP}2{NBSP}/* c */"),
        "groups:/* c */1/**/2".to_string(),
    ] {
        let src = format!("{groups}\n{two_groups}");
        assert_eq!(
            lsgen(&src, "2"),
            ("AC\n".to_string(), String::new()),
            "{src:?}"
        );
    }
    for section in [
        "productions /* c */ 1:".to_string(),
        format!("productions{NBSP}1:"),
        format!("productions 1{NBSP}:"),
        format!("productions{NBSP}/* c */ 1 /* c */{NBSP}:"),
    ] {
        let src = format!("groups: 1\n{section}\nA -> AB\naxiom: A\n");
        assert_eq!(
            lsgen(&src, "1"),
            ("AB\n".to_string(), String::new()),
            "{src:?}"
        );
    }
    // `warnings` heard: the warning of `depth_warnings` above.
    let decomposition = |kw: &str| {
        format!("productions:\nA -> AL\n{kw}\nmaximum depth: 1\nL -> M\nM -> N\naxiom: A\n")
    };
    for (kw, warns) in [
        ("decomposition: /* c */ warnings".to_string(), true),
        (format!("decomposition:{NBSP}warnings{NBSP}/* c */"), true),
        ("decomposition: no /* c */ warnings".to_string(), false),
        (format!("decomposition: no{NBSP}warnings"), false),
    ] {
        let (out, err) = lsgen(&decomposition(&kw), "1");
        assert_eq!(out, "AM\n", "{kw:?}");
        assert_eq!(
            err.contains("warning: decomposition stopped at maximum depth 1"),
            warns,
            "{kw:?}: {err}"
        );
    }
    let homomorphism = |kw: &str| format!("{kw}\nA -> B\nB -> C\naxiom: A\n");
    for (kw, warns) in [
        ("homomorphism: no /* c */ warnings".to_string(), false),
        (format!("homomorphism:{NBSP}warnings"), true),
        (format!("homomorphism: no{NBSP}warnings"), false),
        (
            format!("Homomorphism:{NBSP}/* c */No/**/Warnings /* c */"),
            false,
        ),
    ] {
        let (out, err) = lsgen(&homomorphism(&kw), "0");
        assert_eq!(out, "B\n", "{kw:?}");
        assert_eq!(
            err.contains("warning: homomorphism stopped at maximum depth 1"),
            warns,
            "{kw:?}: {err}"
        );
    }
    // Depth 2 rewrites the B that A -> B made (depth 1 would leave it).
    for depth in [
        "maximum /* c */ depth: 2".to_string(),
        format!("maximum{NBSP}depth: 2"),
        format!("maximum{NBSP}/* c */{NBSP}depth:{NBSP}2"),
    ] {
        let src = format!("homomorphism:\n{depth}\nA -> B\nB -> C\naxiom: A\n");
        assert_eq!(
            lsgen(&src, "0"),
            ("C\n".to_string(), String::new()),
            "{src:?}"
        );
    }
}
