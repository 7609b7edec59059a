//! lsgen as a library (issue 10): a few lines using `lsgen::...` with `?`
//! stream a derivation into a Vec and into a file. Expected strings are
//! derived by hand.

use std::error::Error;

/// The five-line program of the issue.
fn algae(steps: u64, out: impl std::io::Write) -> Result<lsgen::Stats, Box<dyn Error>> {
    let mut ls = lsgen::LSystem::parse("productions:\nA -> AB\nB -> A\naxiom: A\n")?;
    Ok(ls.derive(&lsgen::Options::new().steps(steps), out)?)
}

#[test]
fn streams_into_a_vec() -> Result<(), Box<dyn Error>> {
    let mut v = Vec::new();
    // A, AB, ABA, ABAAB, ABAABABA
    let stats = algae(4, &mut v)?;
    assert_eq!(String::from_utf8(v)?, "ABAABABA\n");
    assert_eq!((stats.modules, stats.bytes, stats.steps), (8, 8, 4));
    Ok(())
}

#[test]
fn streams_into_a_file() -> Result<(), Box<dyn Error>> {
    let dir = tempfile::tempdir()?;
    let path = dir.path().join("out.txt");
    algae(5, std::fs::File::create(&path)?)?;
    assert_eq!(std::fs::read_to_string(&path)?, "ABAABABAABAAB\n");
    Ok(())
}

#[test]
fn reader_options_and_events() -> Result<(), Box<dyn Error>> {
    // Parametric with a homomorphism and a file seed: A(1) -> A(2)B ...
    let src = "derivation length: 2\nseed: 9\nproductions:\nA(x) -> A(x+1)B\n\
               homomorphism:\nB -> F\naxiom: A(1)\n";
    let mut ls = lsgen::LSystem::from_reader(std::io::Cursor::new(src.to_string()), "p.ls")?;
    let mut out = Vec::new();
    let mut passes = Vec::new();
    let stats = ls.derive_with(&lsgen::Options::new(), &mut out, |e| {
        if let lsgen::Event::Generation { pass, modules, .. } = *e {
            passes.push((pass.to_string(), modules));
        }
    })?;
    assert_eq!(String::from_utf8(out)?, "A(3)FF\n");
    assert_eq!(stats.seed, Some(9));
    assert_eq!(
        passes,
        [
            ("the axiom".to_string(), 1),
            ("step 1".to_string(), 2),
            ("step 2".to_string(), 3),
            ("the homomorphism".to_string(), 3)
        ]
    );
    // The axiom of a reader is streamed once.
    assert!(ls.derive(&lsgen::Options::new(), Vec::new()).is_err());
    Ok(())
}

#[test]
fn a_string_derives_again_with_other_options() -> Result<(), Box<dyn Error>> {
    let src = "productions:\nB -> [C]B\nhomomorphism:\nC -> D\naxiom: AB\n";
    let mut ls = lsgen::LSystem::parse(src)?;
    let mut a = Vec::new();
    ls.derive(&lsgen::Options::new().steps(2), &mut a)?;
    assert_eq!(a, b"A[D][D]B\n");
    let mut b = Vec::new();
    ls.derive(&lsgen::Options::new().steps(2).homomorphism(false), &mut b)?;
    assert_eq!(b, b"A[C][C]B\n");
    Ok(())
}

#[test]
fn errors_are_located_and_limits_apply() {
    let e = lsgen::LSystem::parse("productions:\nA -> B(\naxiom: A\n").expect_err("a syntax error");
    assert_eq!(
        e.location().map(|l| (l.line, l.path.as_str())),
        Some((2, "<input>"))
    );
    let mut ls = lsgen::LSystem::parse("productions:\nA -> AA\naxiom: A\n").unwrap();
    let limits = lsgen::Limits {
        modules: 100,
        bytes: u64::MAX,
    };
    let e = ls
        .derive(&lsgen::Options::new().steps(10).limits(limits), Vec::new())
        .expect_err("past the limit");
    assert_eq!(
        e.message(),
        "the string grew past `Limits::modules` (100 modules) in step 7"
    );
}

#[test]
fn errors_say_which_stage_found_them() {
    use lsgen::Stage::*;
    let stage = |src: &str| match lsgen::LSystem::parse(src) {
        Err(e) => e.stage(),
        Ok(mut ls) => {
            let e = ls
                .derive(&lsgen::Options::new().steps(3), Vec::new())
                .expect_err("an error");
            e.stage()
        }
    };
    assert_eq!(stage("productions:\nA -> B\0\naxiom: A\n"), Lexical);
    assert_eq!(stage("productions:\nA -> B /* open\n"), Lexical);
    assert_eq!(stage("productions:\nA -> B(\naxiom: A\n"), Parse);
    assert_eq!(stage("productions:\nA -> B\naxiom: A(\n"), Parse);
    assert_eq!(stage("productions:\nA(x) -> B(y)\naxiom: A(1)\n"), Compile);
    assert_eq!(
        stage("productions:\nA(x) -> A(1/x)\naxiom: A(0)\n"),
        Runtime
    );
    let io = lsgen::LSystem::parse("axiom: A\n")
        .unwrap()
        .derive(
            &lsgen::Options::new().tmpdir("/nonexistent/dir"),
            Vec::new(),
        )
        .expect_err("no temporary directory");
    assert_eq!(io.stage(), Io);
    assert!(std::error::Error::source(&io).is_some());
}

#[test]
fn errors_carry_typed_payloads() {
    use lsgen::diag::{
        CompileError, ExprError, IoAction, LengthUnit, LexicalError, ParseError, RuntimeError,
    };
    use lsgen::ErrorKind;
    let parse = |src: &str| lsgen::LSystem::parse(src).expect_err("an error");
    // The unknown name comes with the error, not inside a message.
    match parse("productions:\nA(x) -> B(y)\naxiom: A(1)\n").kind() {
        ErrorKind::Compile(CompileError::Expr(ExprError::UnknownIdentifier(name))) => {
            assert_eq!(name, "y")
        }
        other => panic!("{other:?}"),
    }
    assert!(matches!(
        parse("define: a = 1\ndefine: a = 2\naxiom: A\n").kind(),
        ErrorKind::Compile(CompileError::DefinedTwice(n)) if n == "a"
    ));
    assert!(matches!(
        parse("productions:\nA -> B /* open\n").kind(),
        ErrorKind::Lexical(LexicalError::UnterminatedComment)
    ));
    assert!(matches!(
        parse("productions:\nA -> G > H\naxiom: A\n").kind(),
        ErrorKind::Parse(ParseError::ContextRightOfArrow('>'))
    ));
    assert!(matches!(
        parse("").kind(),
        ErrorKind::Parse(ParseError::EmptySystem)
    ));
    let derive = |src: &str, o: lsgen::Options| {
        lsgen::LSystem::parse(src)
            .unwrap()
            .derive(&o, Vec::new())
            .expect_err("an error")
    };
    let e = derive(
        "productions:\nA(x) -> A(1/x)\naxiom: A(0)\n",
        lsgen::Options::new().steps(1),
    );
    assert!(
        matches!(
            e.kind(),
            ErrorKind::Runtime(RuntimeError::Eval {
                error: ExprError::DivisionByZero,
                pass: lsgen::Pass::Step(1),
            })
        ),
        "{e:?}"
    );
    let limits = lsgen::Limits {
        modules: 3,
        bytes: u64::MAX,
    };
    let e = derive(
        "productions:\nA -> AA\naxiom: A\n",
        lsgen::Options::new().steps(4).limits(limits),
    );
    assert!(
        matches!(
            e.kind(),
            ErrorKind::Runtime(RuntimeError::TooLong {
                limit: 3,
                unit: LengthUnit::Modules,
                ..
            })
        ),
        "{e:?}"
    );
    let e = derive(
        "axiom: A\n",
        lsgen::Options::new().tmpdir("/nonexistent/dir"),
    );
    match e.kind() {
        ErrorKind::Io(io) => {
            assert_eq!(io.action, IoAction::CreateTemp);
            assert_eq!(
                io.os_error().map(|e| e.kind()),
                Some(std::io::ErrorKind::NotFound)
            );
        }
        other => panic!("{other:?}"),
    }
    // The library's rendering names no program: that is the binary's.
    assert_eq!(
        e.to_string(),
        "/nonexistent/dir: error: cannot create a temporary file: No such file or directory\n"
    );
}

/// A usage error of the options names them as the library does, by
/// [`lsgen::Options`]' methods, not by the binary's flags (lsgen 9b99c7d
/// said "`--first-step 1` with 18446744073709551615 steps" to a caller of
/// `steps(u64::MAX)`); the binary keeps its flags (tests/cli.rs).
#[test]
fn usage_errors_name_the_options_methods() {
    use lsgen::diag::{OptionNames, UsageError};
    let derive = |o: lsgen::Options| {
        lsgen::LSystem::parse("productions:\nA -> AB\naxiom: A\n")
            .unwrap()
            .derive(&o, Vec::new())
            .expect_err("step numbers past 2^64 - 1")
    };
    let e = derive(lsgen::Options::new().steps(u64::MAX));
    assert_eq!(e.stage(), lsgen::Stage::Usage);
    assert!(
        matches!(
            e.kind(),
            lsgen::ErrorKind::Usage(UsageError::StepsOverflow {
                first: 1,
                steps: u64::MAX,
                names: OptionNames::Library,
            })
        ),
        "{e:?}"
    );
    assert_eq!(
        e.to_string(),
        "error: `first_step(1)` with 18446744073709551615 steps: step numbers must stay below 2^64 - 1\n"
    );
    let e = derive(lsgen::Options::new().first_step(u64::MAX - 1).steps(2));
    assert_eq!(
        e.message(),
        "`first_step(18446744073709551614)` with 2 steps: step numbers must stay below 2^64 - 1"
    );
    assert!(!e.to_string().contains("--"), "{e}");
}

/// `derive_with` reports a cpfg block's `printf` text also when it runs
/// inside a `derive` on the same thread (here from that one's writer):
/// lsgen 2769e8d's `derive` dropped the text of every derivation nested in
/// it, and the inner events lacked it.
#[test]
fn derive_with_inside_derive_reports_printf() -> Result<(), Box<dyn Error>> {
    use lsgen::{LSystem, Options};
    let src = "Lsystem: 1\nderivation length: 1\nStart: {printf(\"start\\n\");}\n\
               Axiom: A(1)\nA(x) : {printf(\"A(%g)\\n\", x);} * --> A(x+1)\nendlsystem\n";
    let inner = || -> Vec<String> {
        let mut printed = Vec::new();
        LSystem::parse(src)
            .unwrap()
            .derive_with(&Options::new(), Vec::new(), |e| {
                if let lsgen::Event::Printf(t) = e {
                    printed.push(t.clone());
                }
            })
            .unwrap();
        printed
    };
    assert_eq!(inner(), ["start\n", "A(1)\n"]);
    struct Nesting<F: FnMut() -> Vec<String>>(F, Vec<Vec<String>>);
    impl<F: FnMut() -> Vec<String>> std::io::Write for Nesting<F> {
        fn write(&mut self, b: &[u8]) -> std::io::Result<usize> {
            let got = (self.0)();
            self.1.push(got);
            Ok(b.len())
        }
        fn flush(&mut self) -> std::io::Result<()> {
            Ok(())
        }
    }
    let mut w = Nesting(inner, Vec::new());
    LSystem::parse(src)?.derive(&Options::new(), &mut w)?;
    assert!(!w.1.is_empty());
    for got in &w.1 {
        assert_eq!(got, &["start\n", "A(1)\n"]);
    }
    Ok(())
}

/// A reader that says it read more bytes than it was given room for (it
/// breaks `Read`'s contract) is an I/O error of the input, with an
/// `io::Error` source, where the claim is past the room given: lsgen
/// 2769e8d panicked on a slice past its buffer. (A smaller overstatement
/// cannot be told from a true count.)
#[test]
fn a_reader_that_overstates_is_an_error() {
    struct Overstating(std::io::Cursor<&'static [u8]>, usize);
    impl std::io::Read for Overstating {
        fn read(&mut self, buf: &mut [u8]) -> std::io::Result<usize> {
            let k = buf.len().min(3);
            let n = self.0.read(&mut buf[..k])?;
            Ok(if n == 0 { 0 } else { n + self.1 })
        }
    }
    for extra in [1 << 30, usize::MAX / 2] {
        let r = Overstating(
            std::io::Cursor::new(b"productions:\nA -> AB\naxiom: A\n"),
            extra,
        );
        let e = lsgen::LSystem::from_reader(r, "r.ls").expect_err("an error");
        assert_eq!(e.stage(), lsgen::Stage::Io, "{e}");
        let source = std::error::Error::source(&e).and_then(|s| s.downcast_ref::<std::io::Error>());
        assert_eq!(
            source.map(|s| s.kind()),
            Some(std::io::ErrorKind::InvalidData),
            "{e}"
        );
        assert!(
            e.to_string()
                .starts_with("r.ls: error: cannot read: the reader returned"),
            "{e}"
        );
    }
}

/// A fixed point skips to the last steps however many are asked for:
/// `steps(u64::MAX - 1)`, the most `first_step(1)` allows, derives (lsgen
/// 2769e8d overflowed `i + 2` on the pass after the skip: a panic in a
/// debug build; and counted past the homomorphism's pass 2^64 - 1: a
/// panic in any build).
#[test]
fn a_fixed_point_skips_to_the_largest_step() -> Result<(), Box<dyn Error>> {
    use lsgen::{LSystem, Options};
    for (src, want) in [
        ("productions:\nA -> A\naxiom: A B\n", &b"AB\n"[..]),
        (
            "productions:\nA(x) : x < 3 -> A(x+1)\naxiom: A(1) B\n",
            b"A(3)B\n",
        ),
        // The homomorphism is then pass 2^64 - 1, the last.
        (
            "productions:\nA -> A\nhomomorphism:\nA -> FF\naxiom: A B\n",
            b"FFB\n",
        ),
    ] {
        for threads in [1, 3] {
            let mut out = Vec::new();
            let o = Options::new().steps(u64::MAX - 1).threads(threads);
            let stats = LSystem::parse(src)?.derive(&o, &mut out)?;
            assert_eq!(stats.steps, u64::MAX - 1);
            assert_eq!(out, want);
        }
    }
    Ok(())
}

/// A usage error in the options is found before the axiom is read: a
/// system from a reader (whose axiom stream derives once) derives after
/// it with corrected options, as after `first_step(0)` (lsgen 2769e8d read
/// the stream first: `steps(u64::MAX)` left it `AlreadyDerived`).
#[test]
fn a_usage_error_leaves_the_stream_unread() -> Result<(), Box<dyn Error>> {
    use lsgen::{LSystem, Options};
    let src = "derivation length: 3\nproductions:\nA -> AB\nB -> A\naxiom: A\n";
    for bad in [
        Options::new().steps(u64::MAX),
        Options::new().first_step(u64::MAX),
        Options::new().first_step(0),
    ] {
        let mut ls = LSystem::from_reader(std::io::Cursor::new(src.to_string()), "r.ls")?;
        let e = ls.derive(&bad, Vec::new()).expect_err("a usage error");
        assert_eq!(e.stage(), lsgen::Stage::Usage, "{e}");
        let mut out = Vec::new();
        ls.derive(&Options::new(), &mut out)?;
        assert_eq!(out, b"ABAAB\n");
    }
    // A temporary directory that is not there, is a file, or takes no
    // files (/proc, whose mode lets root write, but where nothing can be
    // made): an I/O error naming it, the stream still unread.
    let dir = tempfile::tempdir()?;
    let file = dir.path().join("file");
    std::fs::write(&file, "")?;
    for (bad, why) in [
        (dir.path().join("absent"), "No such file or directory"),
        (file, "Not a directory"),
        (
            std::path::PathBuf::from("/proc"),
            "No such file or directory",
        ),
    ] {
        let mut ls = LSystem::from_reader(std::io::Cursor::new(src.to_string()), "r.ls")?;
        let e = ls
            .derive(&Options::new().tmpdir(&bad), Vec::new())
            .expect_err("no such directory");
        assert_eq!(e.stage(), lsgen::Stage::Io, "{e}");
        assert_eq!(
            e.to_string(),
            format!(
                "{}: error: cannot create a temporary file: {why}\n",
                bad.display()
            )
        );
        let mut out = Vec::new();
        ls.derive(&Options::new(), &mut out)?;
        assert_eq!(out, b"ABAAB\n");
    }
    Ok(())
}

/// `Stats::seed` is the seed the derivation used, as documented: an `.ls`
/// system without one reports the fresh seed it drew (which derives the
/// same string again); a cpfg `.l` system without `seed:` uses none, and
/// says so (lsgen 9b99c7d reported 0, which as `seed: 0` would make it
/// stochastic). `LSystem::seed` tells the same in advance.
#[test]
fn stats_report_the_seed_used() -> Result<(), Box<dyn Error>> {
    use lsgen::{LSystem, Options};
    let ls_src = "productions:\nA -> AB : 1\nA -> BA : 1\naxiom: A\n";
    let mut ls = LSystem::parse(ls_src)?;
    let planned = ls.seed(&Options::new());
    let mut first = Vec::new();
    let stats = ls.derive(&Options::new().steps(12), &mut first)?;
    assert!(stats.seed.is_some());
    assert_eq!(stats.seed, planned);
    let mut again = Vec::new();
    let o = Options::new().steps(12).seed(stats.seed.unwrap());
    assert_eq!(ls.derive(&o, &mut again)?.seed, stats.seed);
    assert_eq!(first, again);

    let cpfg = |seed: &str| {
        format!(
            "Lsystem: 1\n{seed}derivation length: 3\nAxiom: A\n\
             A --> AB : 1\nA --> BA : 1\nendlsystem\n"
        )
    };
    let mut l = LSystem::parse(&cpfg(""))?;
    assert_eq!(l.seed(&Options::new()), None);
    let mut out = Vec::new();
    let stats = l.derive(&Options::new(), &mut out)?;
    // No seed: the weights are ignored, the first production applies.
    assert_eq!((stats.seed, out), (None, b"ABBB\n".to_vec()));
    let stats = l.derive(&Options::new().seed(0), Vec::new())?;
    assert_eq!(stats.seed, Some(0));
    let l = &mut LSystem::parse(&cpfg("seed: 5\n"))?;
    assert_eq!(l.seed(&Options::new()), Some(5));
    assert_eq!(l.derive(&Options::new(), Vec::new())?.seed, Some(5));
    assert_eq!(l.derive(&Options::new().seed(3), Vec::new())?.seed, Some(3));
    Ok(())
}

/// The limits' errors name the library's settings, not the binary's
/// `--max-length` (which a library caller never saw): `Limits::modules`,
/// `Limits::bytes`, `free_space(N)`; the binary keeps its flag
/// (tests/cli.rs, tests/batch.rs).
#[test]
fn limit_errors_name_the_library_settings() {
    use lsgen::diag::{LengthUnit, OptionNames, RuntimeError};
    use lsgen::{ErrorKind, Limits, Options, Pass};
    let derive = |o: Options| {
        lsgen::LSystem::parse("productions:\nA -> AA\naxiom: A\n")
            .unwrap()
            .derive(&o, Vec::new())
            .expect_err("past a limit")
    };
    let modules = Limits {
        modules: 5,
        bytes: u64::MAX,
    };
    let e = derive(Options::new().steps(4).limits(modules));
    assert!(
        matches!(
            e.kind(),
            ErrorKind::Runtime(RuntimeError::TooLong {
                limit: 5,
                unit: LengthUnit::Modules,
                pass: Pass::Step(3),
                names: OptionNames::Library,
            })
        ),
        "{e:?}"
    );
    assert_eq!(
        e.to_string(),
        "error: the string grew past `Limits::modules` (5 modules) in step 3\n"
    );
    // The final text (16 bytes) against a byte limit.
    let bytes = Limits {
        modules: u64::MAX,
        bytes: 15,
    };
    let e = derive(Options::new().steps(4).limits(bytes));
    assert_eq!(
        e.message(),
        "the string grew past `Limits::bytes` (15 bytes) in step 4"
    );
    // A depth-first plan's final size against `free_space`.
    let e = derive(Options::new().steps(4).free_space(15));
    assert!(
        matches!(
            e.kind(),
            ErrorKind::Runtime(RuntimeError::NoSpace {
                free: 15,
                names: OptionNames::Library,
                ..
            })
        ),
        "{e:?}"
    );
    assert_eq!(
        e.to_string(),
        "output: error: the final string would be 17 bytes, more than `free_space(15)`: \
         nothing written (fewer steps; `limits()` stops any run early)\n"
    );
    for e in [
        derive(Options::new().steps(4).limits(modules)),
        derive(Options::new().steps(4).limits(bytes)),
        derive(Options::new().steps(4).free_space(15)),
    ] {
        assert!(!e.to_string().contains("--"), "{e}");
    }
}

/// `LSystem::seed` is the seed a derivation uses, before and after one:
/// `Options::seed`, else the file's `seed:`, else (`.ls`) the system's
/// fresh seed, else (`.l`) none; and it is what that derivation's
/// `Stats::seed` says. (After a derivation it used to forget the file's
/// `seed:`: the fresh seed for an `.ls` file, `None` for a `.l` one.)
#[test]
fn the_seed_is_the_one_a_derivation_uses_before_and_after() -> Result<(), Box<dyn Error>> {
    use lsgen::{LSystem, Options};
    let ls = |seed: &str| format!("{seed}productions:\nA -> AB : 1\nA -> BA : 1\naxiom: A\n");
    let l = |seed: &str| {
        format!(
            "Lsystem: 1\n{seed}derivation length: 3\nAxiom: A\n\
             A --> AB : 1\nA --> BA : 1\nendlsystem\n"
        )
    };
    // (source, the seed without and with `Options::seed(3)`); the fresh
    // seed of an `.ls` system is 77 here.
    let cases = [
        (ls(""), Some(77)),
        (ls("seed: 9\n"), Some(9)),
        (l(""), None),
        (l("seed: 5\n"), Some(5)),
    ];
    let three = Options::new().seed(3);
    for (src, file) in &cases {
        for stream in [false, true] {
            let mut sys = if stream {
                LSystem::from_reader(std::io::Cursor::new(src.clone()), "s")?
            } else {
                LSystem::parse(src)?
            }
            .with_fallback_seed(77)?;
            let what = format!("{src:?}, from a stream: {stream}");
            assert_eq!(sys.seed(&Options::new()), *file, "{what}");
            assert_eq!(sys.seed(&three), Some(3), "{what}");
            // Derived with the options' seed, then with its own.
            let stats = sys.derive(&three, Vec::new())?;
            assert_eq!(stats.seed, Some(3), "{what}");
            assert_eq!(sys.seed(&three), Some(3), "{what}");
            assert_eq!(sys.seed(&Options::new()), *file, "{what}");
            // A stream's `.ls` axiom is read once; a `.l` file's axiom is
            // in its text, and derives again.
            let cpfg = src.starts_with("Lsystem");
            if cpfg || !stream {
                let stats = sys.derive(&Options::new(), Vec::new())?;
                assert_eq!(stats.seed, *file, "{what}");
            }
            assert_eq!(sys.seed(&Options::new()), *file, "{what}");
            assert_eq!(sys.seed(&three), Some(3), "{what}");
        }
        // Derived with its own seed first, and after a failed derivation.
        let mut sys = LSystem::parse(src)?.with_fallback_seed(77)?;
        assert_eq!(sys.derive(&Options::new(), Vec::new())?.seed, *file);
        assert_eq!(sys.seed(&Options::new()), *file, "{src:?}");
        let limits = lsgen::Limits {
            modules: 1,
            bytes: u64::MAX,
        };
        let o = Options::new().steps(3).limits(limits);
        assert!(sys.derive(&o, Vec::new()).is_err(), "{src:?}");
        assert_eq!(sys.seed(&Options::new()), *file, "{src:?}");
        assert_eq!(sys.seed(&three), Some(3), "{src:?}");
    }
    // The fresh seed is drawn once per system, and reported the same.
    let mut sys = LSystem::parse(&ls(""))?;
    let fresh = sys.seed(&Options::new());
    assert!(fresh.is_some());
    assert_eq!(sys.derive(&Options::new(), Vec::new())?.seed, fresh);
    assert_eq!(sys.derive(&three, Vec::new())?.seed, Some(3));
    assert_eq!(sys.seed(&Options::new()), fresh);
    assert_eq!(sys.derive(&Options::new(), Vec::new())?.seed, fresh);
    Ok(())
}

/// Each event of `derive_with` as a line: a generation's pass and
/// modules, or a warning as it renders.
fn event_lines(
    ls: &mut lsgen::LSystem,
    options: &lsgen::Options,
) -> Result<(String, Vec<String>), lsgen::Error> {
    let mut out = Vec::new();
    let mut lines = Vec::new();
    ls.derive_with(options, &mut out, |e| {
        lines.push(match e {
            lsgen::Event::Generation { pass, modules, .. } => format!("{pass}: {modules}"),
            lsgen::Event::FixedPoint { from, to } => format!("fixed {from}..{to}"),
            lsgen::Event::Warning(w) => w.to_string(),
            lsgen::Event::Printf(text) => format!("printf: {text}"),
            other => format!("{other:?}"),
        })
    })?;
    Ok((String::from_utf8(out).unwrap(), lines))
}

/// A derivation hands its warnings to the caller as `Event::Warning`, in
/// their place among the generations (they went to standard error only,
/// where a library caller could neither see nor silence them): located
/// ones render as errors do, without a program name.
#[test]
fn warnings_are_events() -> Result<(), Box<dyn Error>> {
    use lsgen::diag::WarningKind;
    use lsgen::{LSystem, Options, Pass};
    // Decomposition at its maximum depth, in step 1.
    let src = "derivation length: 3\nproductions:\nA -> AL\ndecomposition: warnings\n\
               maximum depth: 2\nL -> [+P][-P]\nP : 2 < 1 -> S\nP -> Q\nQ -> R\naxiom:\nA\n";
    let mut ls = LSystem::parse(src)?;
    let (out, lines) = event_lines(&mut ls, &Options::new())?;
    assert_eq!(out, "A[+Q][-Q][+R][-R][+R][-R]\n");
    assert_eq!(
        lines,
        [
            "the axiom: 1",
            "<input>:9:1: warning: decomposition stopped at maximum depth 2, but this \
             production still applies (to module Q, in step 1)\nQ -> R\n^\n",
            "step 1: 9",
            "step 2: 17",
            "step 3: 25",
        ]
    );
    // Typed, with its place.
    let mut warnings = Vec::new();
    ls.derive_with(&Options::new().steps(1), Vec::new(), |e| {
        if let lsgen::Event::Warning(w) = e {
            warnings.push(w.clone());
        }
    })?;
    assert_eq!(warnings.len(), 1, "{warnings:?}");
    assert_eq!(
        warnings[0].kind(),
        &WarningKind::MaximumDepth {
            max: 2,
            symbol: 'Q',
            pass: Pass::Step(1)
        }
    );
    let at = warnings[0].location().expect("located");
    assert_eq!((at.path.as_str(), at.line, at.col), ("<input>", 9, 1));
    assert_eq!(
        warnings[0].message(),
        "decomposition stopped at maximum depth 2, but this production still \
         applies (to module Q, in step 1)"
    );

    // `step` hidden: found as the derivation starts, before the axiom.
    let mut ls = LSystem::parse("productions:\nA(step) -> A(step+1)\naxiom: A(0)\n")?;
    let (_, lines) = event_lines(&mut ls, &Options::new().steps(2))?;
    assert_eq!(
        lines,
        [
            "<input>:2:3: warning: `step` hides the built-in step number\n\
             A(step) -> A(step+1)\n  ^\n",
            "the axiom: 1",
            "step 1: 1",
            "step 2: 1",
        ]
    );
    Ok(())
}

/// A cpfg `.l` text's warnings: those found when it is read come first,
/// at every derivation; a division by zero (divided by 1, as cpfg does)
/// is said once per derivation, without a place (it was said once per
/// process: a second derivation said nothing); the ignored weights name
/// `Options::seed`, not `--seed`, and are not said where it makes them
/// count.
#[test]
fn cpfg_warnings_are_events() -> Result<(), Box<dyn Error>> {
    use lsgen::diag::WarningKind;
    use lsgen::{LSystem, Options};
    let src = "Lsystem: 1\nderivation length: 2\nAxiom: A(1)\n\
               A(x) --> A(x/0)B(y)\nB(x) --> C : 1\nendlsystem\n";
    let mut ls = LSystem::parse(src)?;
    let undefined = "<input>:4:18: warning: `y` is not defined: it is 0 here, as in cpfg\n\
                     A(x) --> A(x/0)B(y)\n                 ^\n";
    let weights = "<input>:5:14: warning: a probability without `seed:` is ignored, as in \
                   cpfg (the first applicable production applies; `seed(N)` makes it \
                   count)\nB(x) --> C : 1\n             ^\n";
    let division = "warning: division by zero in a cpfg expression: divided by 1 \
                    instead, as cpfg does\n";
    let want = [
        undefined,
        weights,
        "the axiom: 1",
        division,
        "step 1: 2",
        "step 2: 3",
    ];
    for _ in 0..2 {
        let (out, lines) = event_lines(&mut ls, &Options::new())?;
        assert_eq!(out, "A(1)B(0)C\n");
        assert_eq!(lines, want);
    }
    // With a seed the weights count: no warning about them.
    let (_, lines) = event_lines(&mut ls, &Options::new().seed(1))?;
    assert_eq!(
        lines,
        [
            undefined,
            "the axiom: 1",
            division,
            "step 1: 2",
            "step 2: 3"
        ]
    );
    // The division is typed, without a place.
    let mut division = Vec::new();
    ls.derive_with(&Options::new(), Vec::new(), |e| match e {
        lsgen::Event::Warning(w) if w.location().is_none() => division.push(w.kind().clone()),
        _ => {}
    })?;
    assert_eq!(division, [WarningKind::DivisionByZero]);
    Ok(())
}

/// A text that fails to load keeps the warnings found before its error:
/// `Error::warnings` gives them, in order (they were dropped with the
/// collection). Here a `.l` file's preprocessor warning, an undefined
/// name and ignored weights come before a call of an unknown function; from a
/// stream as from a string; an error without warnings has none.
#[test]
fn a_failed_load_keeps_its_warnings() {
    use lsgen::diag::WarningKind;
    use lsgen::LSystem;
    let src = "#warning careful\nLsystem: 1\nderivation length: 1\nAxiom: A(y)\n\
               A(x) --> B(x) : 1\nB : {z = foo(1);} * --> C\nendlsystem\n";
    let from_text = LSystem::parse(src).expect_err("no function foo");
    let from_stream = LSystem::from_reader(std::io::Cursor::new(src.to_string()), "m.l")
        .expect_err("no function foo");
    for (e, name) in [(&from_text, "<input>"), (&from_stream, "m.l")] {
        assert_eq!(e.location().map(|l| (l.line, l.col)), Some((6, 10)), "{e}");
        let kinds: Vec<_> = e.warnings().iter().map(|w| w.kind().clone()).collect();
        assert!(
            matches!(
                &kinds[..],
                [
                    WarningKind::UserDirective(m),
                    WarningKind::NotDefined(y),
                    WarningKind::ProbabilityWithoutSeed { .. },
                ] if m == "careful" && y == "y"
            ),
            "{kinds:?}"
        );
        assert_eq!(
            e.warnings()[1].to_string(),
            format!(
                "{name}:4:10: warning: `y` is not defined: it is 0 here, as in cpfg\n\
                 Axiom: A(y)\n         ^\n"
            )
        );
        // The error's own rendering is unchanged.
        assert!(
            e.to_string()
                .starts_with(&format!("{name}:6:10: error: unknown function `foo`")),
            "{e}"
        );
    }
    let e = LSystem::parse("productions:\nA -> B(\naxiom: A\n")
        .err()
        .unwrap();
    assert!(e.warnings().is_empty());
}

/// What a cpfg block's `printf` (and `fprintf(stderr, ...)`) prints is
/// handed to the caller as `Event::Printf`, in its place among the
/// warnings and generations (it went to standard error, which the binary
/// still writes): `Start:` before the axiom, the first `A`'s `printf`,
/// then the division by zero its production finds, then the second
/// `A`'s; each derivation prints again.
#[test]
fn cpfg_printf_is_an_event() -> Result<(), Box<dyn Error>> {
    use lsgen::{LSystem, Options};
    let src = "Lsystem: 1\nderivation length: 2\nStart: {printf(\"start\\n\");}\n\
               EndEach: {fprintf(stderr, \"end %g\\n\", Q);}\nAxiom: A(1) A(2)\n\
               A(x) : {printf(\"A(%g)\\n\", x);} * --> A(x/0)\nendlsystem\n";
    let division = "warning: division by zero in a cpfg expression: divided by 1 \
                    instead, as cpfg does\n";
    let want = [
        "printf: start\n",
        "the axiom: 2",
        "printf: A(1)\n",
        division,
        "printf: A(2)\n",
        "step 1: 2",
        "printf: end 1\n",
        "printf: A(1)\n",
        "printf: A(2)\n",
        "step 2: 2",
        "printf: end 2\n",
    ];
    let mut ls = LSystem::parse(src)?;
    for _ in 0..2 {
        let (out, lines) = event_lines(&mut ls, &Options::new())?;
        assert_eq!(out, "A(1)A(2)\n");
        assert_eq!(lines, want);
    }
    Ok(())
}

/// A step's `printf` text past 1 MiB waits in a temporary file until its
/// event, not in memory: every line still comes in its place, the
/// division by zero found among them too. By hand: step k rewrites
/// A(2^(k-1)) ... A(2^k - 1), in order, each printing its line; step 14
/// prints 8192 lines of 170 bytes (1.4 MB), and the division is at x =
/// 16000, past the first MiB.
#[test]
fn much_printf_text_comes_in_order() -> Result<(), Box<dyn Error>> {
    use lsgen::{LSystem, Options};
    let pad = "x".repeat(160);
    let src = format!(
        "Lsystem: 1\nderivation length: 14\nAxiom: A(1)\n\
         A(x) : {{printf(\"A(%g) {pad}\\n\", x); y = 1/(x-16000);}} * --> A(2*x)A(2*x+1)\n\
         endlsystem\n"
    );
    let mut want = vec!["the axiom: 1".to_string()];
    for k in 1..=14u32 {
        for x in 1u32 << (k - 1)..1 << k {
            want.push(format!("printf: A({x}) {pad}\n"));
            if x == 16000 {
                want.push(
                    "warning: division by zero in a cpfg expression: divided by 1 instead, \
                     as cpfg does\n"
                        .to_string(),
                );
            }
        }
        want.push(format!("step {k}: {}", 1u32 << k));
    }
    let dir = tempfile::tempdir()?;
    let mut ls = LSystem::parse(&src)?;
    let (out, lines) = event_lines(&mut ls, &Options::new().tmpdir(dir.path()))?;
    let string: String = (1u32 << 14..1 << 15).map(|x| format!("A({x})")).collect();
    assert_eq!(out, string + "\n");
    assert_eq!(lines.len(), want.len());
    assert!(lines == want);
    Ok(())
}

/// `from_reader` derives an `.ls` text once (its axiom is streamed), but a
/// cpfg `.l` text again and again: the whole file is read when it is
/// loaded (the preprocessor needs all of it), its axiom kept as text.
/// Each derivation is a whole run, the same as `parse`'s and as the
/// first: the `Start:` block runs once per derivation and not at load,
/// the draws start again from the seed (none consumed by the load or by
/// the derivation before), the file's warnings come again; `check` reads
/// the kept axiom without using it up.
#[test]
fn a_cpfg_text_from_a_reader_derives_again_the_same() -> Result<(), Box<dyn Error>> {
    use lsgen::{LSystem, Options};
    let src = "Lsystem: 1\nseed: 3\nderivation length: 4\n\
               Start: {printf(\"start\\n\"); n = 0;}\n\
               EndEach: {n = n + 1; printf(\"n=%g r=%g\\n\", n, ran(10));}\n\
               Axiom: A(y)\nA(x) --> A(x+1)B : 1\nA(x) --> A(x+2) : 1\nendlsystem\n";
    let mut parsed = LSystem::parse(src)?;
    let want = event_lines(&mut parsed, &Options::new())?;
    assert_eq!(want.1.iter().filter(|l| *l == "printf: start\n").count(), 1);
    assert!(want.1[0].contains("`y` is not defined"), "{:?}", want.1);
    let mut ls = LSystem::from_reader(std::io::Cursor::new(src.to_string()), "<input>")?;
    ls.check()?;
    for _ in 0..3 {
        assert_eq!(event_lines(&mut ls, &Options::new())?, want);
    }
    // Another seed, then the file's again.
    let mut other = LSystem::parse(src)?;
    let seeded = event_lines(&mut other, &Options::new().seed(11))?;
    assert_ne!(seeded.0, want.0);
    assert_eq!(event_lines(&mut ls, &Options::new().seed(11))?, seeded);
    assert_eq!(event_lines(&mut ls, &Options::new())?, want);
    // An `.ls` text from a reader derives once.
    let mut ls = LSystem::from_reader(
        std::io::Cursor::new("productions:\nA -> AB\naxiom: A\n".to_string()),
        "r",
    )?;
    ls.derive(&Options::new(), Vec::new())?;
    let again = ls
        .derive(&Options::new(), Vec::new())
        .expect_err("streamed once");
    assert!(matches!(
        again.kind(),
        lsgen::ErrorKind::Runtime(lsgen::diag::RuntimeError::AlreadyDerived)
    ));
    // A check reads the stream too, and the error says so.
    let mut ls = LSystem::from_reader(
        std::io::Cursor::new("productions:\nA -> AB\naxiom: A\n".to_string()),
        "r",
    )?;
    ls.check()?;
    let after_check = ls
        .derive(&Options::new(), Vec::new())
        .expect_err("checked, so read");
    assert_eq!(
        after_check.to_string(),
        "error: the axiom stream was already read (by a derivation or a check): it can be read once\n"
    );
    Ok(())
}

/// A library caller that does not ask for events hears no warning and no
/// cpfg `printf` on standard error: `parse`, `from_reader`, `derive` and
/// `check` say nothing there (they printed every warning, and `printf`'s
/// text). Run in a child process, whose standard error the parent reads.
#[test]
fn the_library_writes_no_warning_on_standard_error() -> Result<(), Box<dyn Error>> {
    use lsgen::{LSystem, Options};
    if !in_child("the_library_writes_no_warning_on_standard_error")? {
        return Ok(());
    }
    let cpfg = "Lsystem: 1\nderivation length: 2\nAxiom: A(1)\n\
                A(x) --> A(x/0)B(y)\nB(x) --> C : 1\nendlsystem\n";
    let structural = "derivation length: 3\nproductions:\nA -> AL\ndecomposition: warnings\n\
                      maximum depth: 2\nL -> [+P][-P]\nP -> Q\nQ -> R\naxiom:\nA\n";
    let step = "productions:\nA(step) -> A(step+1)\naxiom: A(0)\n";
    let printf = "Lsystem: 1\nderivation length: 1\nStart: {printf(\"start\\n\");}\n\
                  Axiom: A\nA : {fprintf(stderr, \"A\\n\");} * --> B\nendlsystem\n";
    for src in [cpfg, structural, step, printf] {
        let mut ls = LSystem::parse(src)?;
        ls.check()?;
        ls.derive(&Options::new(), Vec::new())?;
        let mut ls = LSystem::from_reader(std::io::Cursor::new(src.to_string()), "r")?;
        ls.derive(&Options::new(), Vec::new())?;
    }
    Ok(())
}

/// Run the test `name` again in a child process, and check that it passes
/// there without a byte on standard error: false in the parent (its work
/// is done), true in the child (do the test's work).
fn in_child(name: &str) -> Result<bool, Box<dyn Error>> {
    const CHILD: &str = "LSGEN_LIBRARY_TEST_CHILD";
    if std::env::var_os(CHILD).is_some() {
        return Ok(true);
    }
    let me = std::env::current_exe()?;
    let r = std::process::Command::new(me)
        .args(["--exact", name, "--test-threads", "1"])
        .env(CHILD, "1")
        .output()?;
    let stdout = String::from_utf8_lossy(&r.stdout);
    assert!(r.status.success(), "{stdout}");
    assert!(stdout.contains("1 passed"), "{stdout}");
    assert_eq!(String::from_utf8_lossy(&r.stderr), "");
    Ok(false)
}

/// The hidden helpers for tests and fuzzing (`derive_bytes`,
/// `derive_bytes_on`, `with_fallback_seed`; the binary calls none of
/// them) are the library's too: they write no warning on standard error
/// (`derive_bytes` printed a `.l` file's load warnings, the undefined
/// name and the division by zero of its axiom).
#[test]
fn the_hidden_helpers_write_nothing_on_standard_error() -> Result<(), Box<dyn Error>> {
    use lsgen::{LSystem, Limits, Options};
    if !in_child("the_hidden_helpers_write_nothing_on_standard_error")? {
        return Ok(());
    }
    let cpfg = "Lsystem: 1\nderivation length: 2\nStart: {printf(\"start\\n\");}\n\
                Axiom: A(1/0)\nA(x) --> A(x/0)B(y)\nB(x) --> C(2/0) : 1\nendlsystem\n";
    let step = "define: R = ran(1)\nproductions:\nA(step) -> A(step+R)\naxiom: A(0)\n";
    for src in [cpfg, step] {
        let out = lsgen::derive_bytes(src.as_bytes(), None, None, Limits::default())?;
        assert!(!out.is_empty());
        lsgen::derive_bytes_on(
            src.as_bytes(),
            Some(1),
            Some(3),
            Limits::default(),
            (2, None),
        )?;
        let mut ls = LSystem::parse(src)?.with_fallback_seed(7)?;
        ls.derive(&Options::new(), Vec::new())?;
    }
    Ok(())
}

/// cpfg's turtle queries from a library: the view file as `--cpfg-view`
/// reads it. F(2) then a right turn of 90 degrees and F(1): the turtle is
/// at (-1, 2) (README, "Coming from cpfg: turtle queries").
#[test]
fn cpfg_queries_with_a_view_file() -> Result<(), Box<dyn Error>> {
    let dir = tempfile::tempdir()?;
    let view = dir.path().join("plant.v");
    std::fs::write(&view, "angle increment: 90\n")?;
    let src = "Lsystem: 1\nderivation length: 0\nAxiom: F(2)+F(1)?P(0,0)\nendlsystem\n";
    let mut ls = lsgen::LSystem::from_reader_with_view(src.as_bytes(), "plant.l", &view, &[])?;
    let mut out = Vec::new();
    ls.derive(&lsgen::Options::new(), &mut out)?;
    assert_eq!(out, b"F(2)+F(1)?P(-1,2)\n");
    // Without the view file: refused, located.
    let e = lsgen::LSystem::from_reader_with_functions(src.as_bytes(), "plant.l", &[])
        .expect_err("refused");
    assert!(e.to_string().contains("needs cpfg's view file"), "{e}");
    Ok(())
}

/// `Load::includes(false)`: a `.l` text from someone else reads no file.
/// Its `#include` carried out is an error at its line, whatever file it
/// names (one that exists here), and no line of that file is quoted; one
/// in a skipped `#if` branch is not carried out; includes on (the default
/// and `from_reader`) read the file.
#[test]
fn includes_can_be_turned_off() -> Result<(), Box<dyn Error>> {
    let dir = tempfile::tempdir()?;
    let secret = dir.path().join("secret.h");
    std::fs::write(&secret, "#define N 2\n/* secret line */\n")?;
    let text = format!(
        "/* a model */\n#include \"{}\"\nLsystem: 1\nderivation length: N\nAxiom: A\nA --> AB\nendlsystem\n",
        secret.display()
    );
    let off = lsgen::Load::new().includes(false);
    let e = off.parse(&text).expect_err("refused");
    assert!(
        matches!(
            e.kind(),
            lsgen::ErrorKind::Preprocess(lsgen::diag::PreprocessError::IncludesOff)
        ),
        "{e}"
    );
    assert_eq!(e.stage(), lsgen::Stage::Parse);
    let shown = e.to_string();
    assert!(
        shown.starts_with("<input>:2:1: error: `#include` is turned off"),
        "{shown}"
    );
    assert!(!shown.contains("secret line"), "{shown}");
    let e = off
        .from_reader(std::io::Cursor::new(text.clone()), "model.l")
        .expect_err("refused");
    assert!(
        e.to_string()
            .starts_with("model.l:2:1: error: `#include` is turned off"),
        "{e}"
    );
    // On: the file is read (N is 2).
    for mut ls in [
        lsgen::Load::new().parse(&text)?,
        lsgen::LSystem::parse(&text)?,
        lsgen::LSystem::from_reader(std::io::Cursor::new(text.clone()), "model.l")?,
    ] {
        let mut out = Vec::new();
        ls.derive(&lsgen::Options::new(), &mut out)?;
        assert_eq!(out, b"ABB\n");
    }
    // Off, an `#include` in a skipped branch is fine.
    let skipped = text
        .replace("#include", "#define N 3\n#if 0\n#include")
        .replace("\nLsystem", "\n#endif\nLsystem");
    let mut ls = off.parse(&skipped)?;
    let mut out = Vec::new();
    ls.derive(&lsgen::Options::new(), &mut out)?;
    assert_eq!(out, b"ABBB\n");
    Ok(())
}

/// With includes off, no file beside the text's name is looked at: the
/// hint of a `func` without functions names the `.v` file beside only
/// with includes on.
#[test]
fn includes_off_looks_at_no_view_file_beside() -> Result<(), Box<dyn Error>> {
    let dir = tempfile::tempdir()?;
    std::fs::write(dir.path().join("plant.v"), "angle increment: 90\n")?;
    let name = dir.path().join("plant.l");
    let name = name.to_str().expect("a UTF-8 temporary directory");
    let src = "Lsystem: 1\nderivation length: 1\nAxiom: A(0)\nA(x) --> A(func(1, x))\nendlsystem\n";
    let read = |load: lsgen::Load| {
        load.from_reader(src.as_bytes(), name)
            .expect_err("refused")
            .to_string()
    };
    let on = read(lsgen::Load::new());
    assert!(on.contains("plant.v"), "{on}");
    let off = read(lsgen::Load::new().includes(false));
    assert!(off.contains("func"), "{off}");
    assert!(!off.contains("plant.v"), "{off}");
    Ok(())
}

/// `Load::dialect`: the language given, not told from the text; and
/// `Load::functions` and `view` read as the `from_reader_with_*`
/// constructors do.
#[test]
fn load_sets_the_dialect_and_the_functions() -> Result<(), Box<dyn Error>> {
    use lsgen::{Dialect, Load};
    let cpfg = "Lsystem: 1\nderivation length: 2\nAxiom: A\nA --> AB\nendlsystem\n";
    let ls = "derivation length: 2\nproductions:\nA -> AB\naxiom: A\n";
    let derive = |mut l: lsgen::LSystem| -> Result<Vec<u8>, lsgen::Error> {
        let mut out = Vec::new();
        l.derive(&lsgen::Options::new(), &mut out)?;
        Ok(out)
    };
    assert_eq!(derive(Load::new().parse(cpfg)?)?, b"ABB\n");
    assert_eq!(
        derive(Load::new().dialect(Dialect::Cpfg).parse(cpfg)?)?,
        b"ABB\n"
    );
    assert_eq!(
        derive(Load::new().dialect(Dialect::Ls).parse(ls)?)?,
        b"ABB\n"
    );
    let e = Load::new()
        .dialect(Dialect::Ls)
        .parse(cpfg)
        .expect_err("not .ls");
    assert_eq!(e.stage(), lsgen::Stage::Parse, "{e}");
    let e = Load::new()
        .dialect(Dialect::Cpfg)
        .parse(ls)
        .expect_err("not .l");
    assert_eq!(e.stage(), lsgen::Stage::Parse, "{e}");
    // A name ending in `.l` is cpfg's, unless the dialect says otherwise.
    assert!(Load::new().from_reader(ls.as_bytes(), "x.l").is_err());
    let l = Load::new()
        .dialect(Dialect::Ls)
        .from_reader(ls.as_bytes(), "x.l")?;
    assert_eq!(derive(l)?, b"ABB\n");

    let dir = tempfile::tempdir()?;
    let view = dir.path().join("plant.v");
    std::fs::write(&view, "angle increment: 90\n")?;
    let func = dir.path().join("f.func");
    // The line y = x.
    let line = "range: 0.0 1.0\npoints: 4\n0 0\n0.333333333 0.333333333\n\
                0.666666667 0.666666667\n1 1\n";
    std::fs::write(&func, line)?;
    let src = "Lsystem: 1\nderivation length: 1\nAxiom: F(2)+F(1)?P(0,0)A(0.5)\n\
               A(x) --> A(func(1,x))\nendlsystem\n";
    let by_load = Load::new()
        .view(&view)
        .functions([&func])
        .from_reader(src.as_bytes(), "plant.l")?;
    let by_ctor = lsgen::LSystem::from_reader_with_view(
        src.as_bytes(),
        "plant.l",
        &view,
        std::slice::from_ref(&func),
    )?;
    let (a, b) = (derive(by_load)?, derive(by_ctor)?);
    assert_eq!(a, b);
    assert_eq!(a, b"F(2)+F(1)?P(-1,2)A(0.5)\n");
    Ok(())
}

/// An `LSystem` can be read on one thread and derived on another (its
/// reader is `Send`), and shows what it is in `{:?}`.
#[test]
fn a_system_moves_between_threads_and_shows_itself() -> Result<(), Box<dyn Error>> {
    let ls = lsgen::LSystem::from_reader(
        std::io::Cursor::new(b"productions:\nA -> AB\nB -> A\naxiom: A\n".to_vec()),
        "algae.ls",
    )?;
    assert_eq!(
        format!("{ls:?}"),
        r#"LSystem { name: "algae.ls", dialect: Ls, derivable: true, .. }"#
    );
    let (ls, out) = std::thread::spawn(move || {
        let mut ls = ls;
        let mut out = Vec::new();
        ls.derive(&lsgen::Options::new().steps(4), &mut out)
            .map(|_| (ls, out))
    })
    .join()
    .expect("no panic")?;
    assert_eq!(out, b"ABAABABA\n");
    // Its stream read, it cannot be derived again.
    assert_eq!(
        format!("{ls:?}"),
        r#"LSystem { name: "algae.ls", dialect: Ls, derivable: false, .. }"#
    );
    let cpfg = lsgen::LSystem::parse("Lsystem: 1\nAxiom: A\nendlsystem\n")?;
    assert_eq!(
        format!("{cpfg:?}"),
        r#"LSystem { name: "<input>", dialect: Cpfg, derivable: true, .. }"#
    );
    Ok(())
}

/// A `.l` system derived again is compiled again from its preprocessed
/// text (the rules compiled at load went to the first derivation; nothing
/// else is kept): the same string each time, its view file's queries
/// still filled, and a seed that makes its weights count gives what
/// `lsgen --seed` gives, whose run compiles once. Without a seed the
/// first production always applies (cpfg ignores the weights) and the
/// query is worked out by hand: F(1) from (0, 0) facing up, `+` a right
/// turn of 90 degrees, each `?P` where the turtle stands.
#[test]
fn a_cpfg_system_derived_again_is_compiled_again() -> Result<(), Box<dyn Error>> {
    let dir = tempfile::tempdir()?;
    let view = dir.path().join("plant.v");
    std::fs::write(&view, "angle increment: 90\n")?;
    let src = "Lsystem: 1\nderivation length: 3\nAxiom: A\n\
               A --> F(1)+?P(0,0)A : 1\nA --> F(2)-A : 3\nendlsystem\n";
    let model = dir.path().join("plant.l");
    std::fs::write(&model, src)?;
    let mut ls = lsgen::LSystem::from_reader_with_view(src.as_bytes(), "plant.l", &view, &[])?;
    let mut derive = |options: lsgen::Options| -> Result<Vec<u8>, Box<dyn Error>> {
        let mut out = Vec::new();
        ls.derive(&options, &mut out)?;
        Ok(out)
    };
    let unseeded = b"F(1)+?P(0,1)F(1)+?P(-1,1)F(1)+?P(-1,0)A\n".to_vec();
    assert_eq!(derive(lsgen::Options::new())?, unseeded);
    assert_eq!(derive(lsgen::Options::new())?, unseeded);
    let seeded = derive(lsgen::Options::new().seed(7))?;
    assert_eq!(derive(lsgen::Options::new())?, unseeded);
    let cli = std::process::Command::new(env!("CARGO_BIN_EXE_lsgen"))
        .arg("--cpfg-view")
        .arg(&view)
        .args(["--seed", "7"])
        .arg(&model)
        .output()?;
    assert!(cli.status.success(), "{cli:?}");
    assert_eq!(seeded, cli.stdout);
    assert_ne!(seeded, unseeded);
    Ok(())
}
