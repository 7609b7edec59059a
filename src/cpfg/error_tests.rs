//! The cpfg front end's errors are typed: each stage's error is a variant
//! of that stage's enum (the `.ls` one where it is the same error), and an
//! `#include` that cannot be read keeps the operating system's error as
//! its `source()`. The expected messages are the texts the front end wrote
//! as strings before the errors were typed (e89df03), copied by hand.

use crate::diag::PreprocessError::{BadExpression, InvalidDirective, Macro, NotSupported};
use crate::diag::{
    Block, CompileError, DirectiveError, Error, ErrorKind, ExprError, IfError, LexicalError,
    MacroError, OptionNames, ParseError, PpConstruct, PreprocessError, RandomError, Refused,
    RuntimeError, Stage, UsageError, WarningKind,
};
use crate::Pass;

/// The error of loading the `.l` text `src` (named `dir/t.l`).
fn load_error(src: &str) -> Error {
    match super::load(
        "/nonexistent-lsgen-dir/t.l",
        src,
        false,
        OptionNames::Library,
        (&Default::default(), true),
    ) {
        Ok(_) => panic!("expected an error for {src:?}"),
        Err(e) => e,
    }
}

/// The error of deriving the `.l` text `src`.
fn run_error(src: &str) -> Error {
    let reader = std::io::Cursor::new(src.as_bytes().to_vec());
    let mut ls = crate::LSystem::from_reader(reader, "t.l").expect("a valid file");
    let mut out = Vec::new();
    match ls.derive(&crate::Options::new(), &mut out) {
        Ok(_) => panic!("expected a run-time error for {src:?}"),
        Err(e) => e,
    }
}

#[test]
fn a_lexical_error_is_lexical() {
    let e = load_error("Lsystem: 1\nAxiom: A(1e6)\nendlsystem\n");
    assert_eq!(e.stage(), Stage::Lexical);
    assert!(
        matches!(e.kind(), ErrorKind::Lexical(LexicalError::ExponentWithoutDot(t)) if t == "1e6"),
        "{e:?}"
    );
    assert_eq!(
        e.message(),
        "cpfg needs a dot in an exponent literal (`1.0e6`, not `1e6`): `1e6`"
    );
    // The same error as in `.ls` files is the same variant.
    let e = load_error("Lsystem: 1\nAxiom: A(1.0e999)\nendlsystem\n");
    assert!(
        matches!(e.kind(), ErrorKind::Lexical(LexicalError::NumberOutOfRange(t)) if t == "1.0e999"),
        "{e:?}"
    );
    assert_eq!(e.message(), "number `1.0e999` is out of range");
}

#[test]
fn a_parse_error_is_the_ls_grammars_variant() {
    let e = load_error("Lsystem: 1\nAxiom: A\nA --> B\n");
    assert_eq!(e.stage(), Stage::Parse);
    assert!(
        matches!(e.kind(), ErrorKind::Parse(ParseError::MissingEndlsystem)),
        "{e:?}"
    );
    let e = load_error("Lsystem: 1\nAxiom: A\nA --> B\n)\nendlsystem\n");
    assert_eq!(e.stage(), Stage::Parse);
    let ErrorKind::Parse(ParseError::Unexpected { found, .. }) = e.kind() else {
        panic!("{e:?}");
    };
    assert_eq!(found, "`)`");
    assert_eq!(
        e.message(),
        "unexpected `)`, expected a production or `endlsystem`"
    );
}

#[test]
fn a_refused_construct_is_a_parse_error() {
    let e = load_error("Lsystem: 1\nAxiom: A\nA -o> B\nendlsystem\n");
    assert_eq!(e.stage(), Stage::Parse);
    assert!(
        matches!(
            e.kind(),
            ErrorKind::Parse(ParseError::Refused(Refused::ObjectProduction))
        ),
        "{e:?}"
    );
    assert_eq!(
        e.message(),
        "`-o>` (an object production, for cpfg's surfaces and objects) is not supported: lsgen rewrites strings only"
    );
    // A query of the turtle without the view file its turtle reads.
    let e = load_error("Lsystem: 1\nAxiom: A\nA --> B ?P(1,2)\nendlsystem\n");
    assert!(
        matches!(
            e.kind(),
            ErrorKind::Parse(ParseError::Refused(Refused::QueryWithoutView))
        ),
        "{e:?}"
    );
    assert_eq!(
        e.message(),
        "a query of the turtle (`?P`, `?H`, `?L`, `?U`) needs cpfg's view file: give it with --cpfg-view FILE.v (the turtle's angle, tropism and scale are there)"
    );
}

#[test]
fn a_lowering_error_is_a_compile_error() {
    // A setting is read as the file is parsed, before any block: one that
    // reads a global is no constant (lsgen's error; cpfg reads 0).
    let e =
        load_error("Lsystem: 1\nStart: {x = 2;}\nderivation length: 1 + x\nAxiom: A\nendlsystem\n");
    assert_eq!(e.stage(), Stage::Compile);
    assert!(
        matches!(e.kind(), ErrorKind::Compile(CompileError::NotConstant)),
        "{e:?}"
    );
    let at = e.location().expect("located");
    assert_eq!((at.line, at.col), (3, 20));
    // `Q` and `Z` are cpfg's global variables (lsys_input.y's Dlength adds
    // them to the global table, LHS finds them there): a block may assign
    // them. cpfg reads the axiom after `Start:` (control.c), so an axiom
    // may read what `Start:` assigned, as any global (tests/cpfg_runtime.rs).
    for src in [
        "Start: {if (1) {Z = 2;}}\nAxiom: A(1, Z)",
        "Start: {Q = 1;}\nAxiom: A\nA : {Q = 7;} * --> A",
        "Axiom: A(Q, Z)\nA(x, y) : * {if (1) {Z = 2;}} --> A",
        "StartEach: {Q = 1;}\nAxiom: A(Q)",
    ] {
        let src = format!("Lsystem: 1\nderivation length: 2\n{src}\nendlsystem\n");
        let r = super::load(
            "t.l",
            &src,
            false,
            OptionNames::Library,
            (&Default::default(), true),
        );
        assert!(r.is_ok(), "{src}: {:?}", r.err());
    }
    assert!(super::load(
        "t.l",
        "Lsystem: 1\nAxiom: A(1)\nA(Q) : {Q = 7;} * --> B(Q)\nendlsystem\n",
        false,
        OptionNames::Library,
        (&Default::default(), true),
    )
    .is_ok());
    // cpfg's `(int)` of a value no `int` holds is undefined behaviour.
    let e = load_error("Lsystem: 1\nderivation length: 3000000000\nAxiom: A\nendlsystem\n");
    assert!(
        matches!(
            e.kind(),
            ErrorKind::Compile(CompileError::OutOfRange {
                what: "the derivation length",
                ..
            })
        ),
        "{e:?}"
    );
    assert_eq!(
        e.message(),
        "the derivation length must be from -2147483648 to 2147483647, not 3000000000"
    );
}

#[test]
fn a_block_error_while_deriving_is_a_runtime_error() {
    let e = run_error(
        "Lsystem: 1\nderivation length: 2\nEndEach: {x = 1 % (Q - 1);}\nAxiom: A\nendlsystem\n",
    );
    assert_eq!(e.stage(), Stage::Runtime);
    assert!(
        matches!(
            e.kind(),
            ErrorKind::Runtime(RuntimeError::Block {
                error: ExprError::RemainderByZero,
                block: Block::EndEach(Pass::Step(1)),
            })
        ),
        "{e:?}"
    );
    assert_eq!(
        e.message(),
        "remainder by zero (`x % 0` crashes cpfg) (in `EndEach:` after step 1)"
    );
}

#[test]
fn preprocessor_errors_are_staged_and_keep_the_io_source() {
    let e = load_error("Lsystem: 1\n#include \"no-such-file.h\"\nAxiom: A\nendlsystem\n");
    assert_eq!(e.stage(), Stage::Io);
    assert!(
        matches!(
            e.kind(),
            ErrorKind::Preprocess(PreprocessError::IncludeFailed { .. })
        ),
        "{e:?}"
    );
    let source = std::error::Error::source(&e).expect("the OS error");
    let io = source
        .downcast_ref::<std::io::Error>()
        .expect("an io::Error");
    assert_eq!(io.kind(), std::io::ErrorKind::NotFound);
    assert_eq!(
        e.message(),
        "cannot include `/nonexistent-lsgen-dir/no-such-file.h`: No such file or directory"
    );

    let e = load_error("Lsystem: 1\n/* open\nAxiom: A\nendlsystem\n");
    assert_eq!(e.stage(), Stage::Lexical);
    assert_eq!(e.message(), "unterminated comment: `/*` without `*/`");
    assert!(std::error::Error::source(&e).is_none());

    let e = load_error("#frobnicate\nLsystem: 1\nAxiom: A\nendlsystem\n");
    assert_eq!(e.stage(), Stage::Parse);
    assert!(
        matches!(e.kind(), ErrorKind::Preprocess(PreprocessError::UnknownDirective(d)) if d == "frobnicate"),
        "{e:?}"
    );
    assert_eq!(e.message(), "unknown directive `#frobnicate`");
}

/// Every variant added for the cpfg front end, the warnings and the usage
/// checks renders the text the string it replaced had.
#[test]
fn typed_messages_are_the_former_strings() {
    let cases: Vec<(String, &str)> = vec![
        (LexicalError::ExpressionChar('#').to_string(), "unexpected character `#` in an expression"),
        (LexicalError::UnterminatedString.to_string(), "unterminated string"),
        (LexicalError::BlocksNestedTooDeeply.to_string(), "blocks nested too deep (over 256)"),
        (
            LexicalError::FileTooLarge { mib: 64 }.to_string(),
            "file larger than 64 MiB",
        ),
        (Refused::SecondLsystem.to_string(), "a second `Lsystem:`: several L-systems in one file (cpfg's sub-L-systems) are not supported; lsgen derives one L-system per file"),
        (Refused::Ring.to_string(), "`ring lsystem` is not supported: lsgen derives open strings (no ring of modules)"),
        (Refused::RingSetting.to_string(), "ring L-systems (`ring lsystem`) are not supported"),
        (Refused::Environment.to_string(), "`?E` (communication with an environment program) needs cpfg's environment process: not supported by lsgen, which only rewrites strings"),
        (Refused::SubLsystemCall.to_string(), "`?(id,s)` (a sub-L-system call) needs cpfg's sub-L-systems: not supported by lsgen, which only rewrites strings"),
        (Refused::Query.to_string(), "a `?` not followed by `P`, `H`, `L` or `U` (the turtle queries lsgen fills, with `--cpfg-view`): its other query modules need cpfg's interpretation or environment: not supported by lsgen, which only rewrites strings"),
        (Refused::SubLsystemEnd.to_string(), "`$` (the end of a sub-L-system) is not supported: lsgen has no sub-L-systems"),
        (Refused::Surface.to_string(), "`@S` (a surface from cpfg's surface files) is not supported: lsgen has no surfaces"),
        (Refused::Atan2.to_string(), "`atan2` is reserved in cpfg but a syntax error there: use `atan(y / x)`"),
        (Refused::External.to_string(), "`external` (arrays shared with cpfg's sub-L-systems) is not supported: declare the array with `array`"),
        (Refused::Function("curveX".into()).to_string(), "`curveX` is not supported: it needs cpfg's function files, curves, view or animation"),
        (Refused::Address.to_string(), "`&` (an address) is not supported: write `&&`"),
        (Refused::FprintfNotStderr.to_string(), "lsgen supports `fprintf` only on `stderr`"),
        (ParseError::MissingLsystem.to_string(), "empty file: a cpfg L-system starts with `Lsystem:`"),
        (ParseError::BeforeLsystem("symbol `F`".into()).to_string(), "unexpected symbol `F`: a cpfg L-system starts with `Lsystem:`"),
        (ParseError::SettingAfterAxiom("`x`".into()).to_string(), "unexpected `x`: the settings (`seed:`, `derivation length:`, `ignore:`, `consider:`, blocks) come before `Axiom:`, one per line"),
        (ParseError::BlockTwice.to_string(), "this block is given twice"),
        (ParseError::SettingTwice.to_string(), "this setting is given twice"),
        (ParseError::NullPredecessor.to_string(), "the strict predecessor cannot be `*`"),
        (ParseError::NoFormat("printf".into()).to_string(), "`printf` needs a format string"),
        (CompileError::StatementAsValue("printf".into()).to_string(), "`printf` is a statement of a block, not a value"),
        (CompileError::NotConstant.to_string(), "this value must be known before the derivation (a constant expression)"),
        (
            CompileError::OutOfRange { what: "the seed", min: 0.0, max: 9.007_199_254_740_992e15, value: -1.0 }.to_string(),
            "the seed must be from 0 to 9007199254740992, not -1",
        ),
        (CompileError::FormalTwice("x".into()).to_string(), "formal parameter `x` is named twice in this production (cpfg: multiple definition)"),
        (CompileError::PrintfConversion('s').to_string(), "printf: `%s` is not a conversion lsgen prints"),
        (CompileError::PrintfUnfinished.to_string(), "printf: the format ends inside a `%` conversion"),
        (CompileError::PrintfArity { takes: 1, given: 2 }.to_string(), "printf: the format takes 1 value, 2 given"),
        (CompileError::PrintfArity { takes: 2, given: 0 }.to_string(), "printf: the format takes 2 values, 0 given"),
        (CompileError::OutOfF32.to_string(), "this value does not fit cpfg's 32-bit float"),
        (CompileError::EmptyAxiom.to_string(), "the axiom is empty"),
        (RuntimeError::WorkerStopped.to_string(), "internal error: a worker thread stopped"),
        (ExprError::Random(RandomError::CpfgOnly).to_string(), "bran, biran and srand are cpfg functions, only in `.l` files"),
        (ExprError::Random(RandomError::BranNoValue).to_string(), "bran() finds no value for these parameters"),
        (ExprError::Random(RandomError::BiranTooManyTrials).to_string(), "biran() takes at most 16777216 trials"),
        (ExprError::Random(RandomError::SrandNotFinite).to_string(), "srand() needs a finite number"),
        (Block::Start.to_string(), "`Start:`"),
        (Block::StartEach(Pass::Step(3)).to_string(), "`StartEach:` before step 3"),
        (Block::End.to_string(), "`End:`"),
        (WarningKind::HashModule.to_string(), "`#` followed by a symbol is taken as a module, not a directive"),
        (WarningKind::UserDirective("hi".into()).to_string(), "#warning hi"),
        (WarningKind::PragmaIgnored.to_string(), "#pragma ignored"),
        (WarningKind::ExtraTokens("#undef X".into()).to_string(), "extra tokens after `#undef X` ignored"),
        (WarningKind::MacroRedefined("N".into()).to_string(), "macro `N` redefined"),
        (
            WarningKind::UnterminatedCharConstant.to_string(),
            "unterminated character constant: the rest of the line is kept as it is, without macro expansion, as vlabcpp does",
        ),
        (WarningKind::NotDefined("v".into()).to_string(), "`v` is not defined: it is 0 here, as in cpfg"),
        (WarningKind::ProbabilityWithoutSeed { names: OptionNames::CommandLine }.to_string(), "a probability without `seed:` is ignored, as in cpfg (the first applicable production applies; `--seed` makes it count)"),
        (WarningKind::ProbabilityWithoutSeed { names: OptionNames::Library }.to_string(), "a probability without `seed:` is ignored, as in cpfg (the first applicable production applies; `seed(N)` makes it count)"),
        (WarningKind::ProbabilityInSection("decomposition ").to_string(), "a probability in the decomposition section is ignored, as in cpfg (the first applicable decomposition production applies)"),
        (WarningKind::StepHidden.to_string(), "`step` hides the built-in step number"),
        (
            WarningKind::LeftContextBracket.to_string(),
            "a left context with `[` or `]` never matches, as in cpfg (its matcher passes over the string's brackets): this production never applies",
        ),
        (
            WarningKind::DivisionByZero.to_string(),
            "division by zero in a cpfg expression: divided by 1 instead, as cpfg does",
        ),
        (
            WarningKind::MaximumDepth { max: 3, symbol: 'A', pass: Pass::Step(2) }.to_string(),
            "decomposition stopped at maximum depth 3, but this production still applies (to module A, in step 2)",
        ),
        (
            WarningKind::MaximumDepth { max: 4, symbol: 'B', pass: Pass::Homomorphism }.to_string(),
            "homomorphism stopped at maximum depth 4, but this production still applies (to module B)",
        ),
        (UsageError::FramesNeedN.to_string(), "`--frames` with `-o` needs `{n}` (the generation number) in the file name"),
        (UsageError::StdinInBatch.to_string(), "standard input can feed one job only: a batch (several files or seeds) needs file names"),
        (UsageError::StdinAxiomInBatch.to_string(), "`--axiom -` can feed one job only: a batch needs an axiom file"),
        (UsageError::StreamAxiomInBatch("/dev/stdin".into()).to_string(), "`--axiom /dev/stdin` is not a regular file (a pipe or a device is read once) and can feed one job only: a batch needs an axiom file"),
        (UsageError::StreamFileInBatch("/dev/fd/63".into()).to_string(), "/dev/fd/63 is not a regular file (a pipe or a device is read once) and can feed one job only: a seed range needs a file"),
        (UsageError::BatchNeedsTemplate.to_string(), "several jobs (files or seeds) need -o with a template, e.g. -o 'out/{stem}-{seed}.txt', so that each has its own file"),
        (UsageError::SeedRangeNeedsSeed.to_string(), "a seed range needs `{seed}` in the -o template, so that each seed has its own file"),
        (UsageError::FilesNeedStem.to_string(), "several files need `{stem}` in the -o template, so that each has its own file"),
        (
            UsageError::SameStem { first: "a/x.ls".into(), second: "b/x.ls".into(), stem: "x".into() }.to_string(),
            "a/x.ls and b/x.ls have the same {stem} `x`: their outputs would collide",
        ),
        (UsageError::BothFromStdin.to_string(), "the L-system and `--axiom` cannot both come from standard input"),
        (UsageError::CpfgNotDepthFirst.to_string(), "`--strategy dfs`: this cpfg (`.l`) file is derived step by step: it has what cpfg runs in string order (draws, blocks, queries, warnings) or what only that strategy derives (README, \"Coming from cpfg\")"),
        (UsageError::UnknownFormat("gif".into()).to_string(), "unknown format `gif` (svg, png, obj, segments)"),
        (UsageError::FormatFromName("p.gif".into()).to_string(), "cannot tell the format from `p.gif`: give -f svg|png|obj|segments"),
    ];
    for (got, want) in cases {
        assert_eq!(got, want);
    }
    let pp = |e: PreprocessError| e.to_string();
    let cases: Vec<(String, &str)> = vec![
        (
            pp(InvalidDirective(DirectiveError::NeedsMacroName(
                "#undef".into(),
            ))),
            "`#undef` needs a macro name",
        ),
        (
            pp(InvalidDirective(DirectiveError::DefinedAsName)),
            "`defined` cannot be a macro name",
        ),
        (
            pp(InvalidDirective(DirectiveError::ParamListNotClosed)),
            "missing `)` in macro parameter list",
        ),
        (
            pp(InvalidDirective(DirectiveError::ExpectedParamName)),
            "expected a parameter name",
        ),
        (
            pp(InvalidDirective(DirectiveError::DuplicateParam("a".into()))),
            "duplicate macro parameter `a`",
        ),
        (
            pp(InvalidDirective(DirectiveError::ExpectedCommaOrParen)),
            "expected `,` or `)` in parameter list",
        ),
        (
            pp(InvalidDirective(DirectiveError::PasteAtEnd)),
            "`##` cannot be at either end of a macro body",
        ),
        (
            pp(InvalidDirective(DirectiveError::StringifyNeedsParam)),
            "`#` in a function-like macro must be followed by a parameter name (C stringification)",
        ),
        (
            pp(InvalidDirective(DirectiveError::IncludeNeedsName)),
            "`#include` needs a file name in quotes",
        ),
        (
            pp(InvalidDirective(DirectiveError::IncludeNotQuoted)),
            "`#include` expects \"FILE\"",
        ),
        (
            pp(InvalidDirective(DirectiveError::IncludeEmptyName)),
            "empty file name in `#include`",
        ),
        (
            pp(Macro(MacroError::UnterminatedArgs("F".into()))),
            "unterminated argument list of macro `F`",
        ),
        (
            pp(Macro(MacroError::Arity {
                name: "F".into(),
                want: 1,
                given: 2,
            })),
            "macro `F` takes 1 argument, 2 given",
        ),
        (
            pp(Macro(MacroError::Paste {
                left: "x".into(),
                right: "(".into(),
            })),
            "`##` pasting `x` and `(` does not give one token",
        ),
        (
            pp(BadExpression(IfError::DefinedNeedsName)),
            "`defined` needs a macro name",
        ),
        (
            pp(BadExpression(IfError::DefinedNotClosed)),
            "missing `)` after `defined(NAME`",
        ),
        (
            pp(BadExpression(IfError::Unexpected("@".into()))),
            "unexpected `@` in `#if` expression",
        ),
        (
            pp(BadExpression(IfError::Empty)),
            "`#if` needs an expression",
        ),
        (
            pp(BadExpression(IfError::MissingOperator)),
            "missing operator in `#if` expression",
        ),
        (
            pp(BadExpression(IfError::NotInteger("1.5".into()))),
            "`1.5` is not an integer (only integers are allowed in `#if`)",
        ),
        (
            pp(BadExpression(IfError::IntegerTooLarge(
                "99999999999999999999".into(),
            ))),
            "integer `99999999999999999999` too large",
        ),
        (
            pp(BadExpression(IfError::UnsupportedEscape("'\\q'".into()))),
            "unsupported escape in `'\\q'`",
        ),
        (
            pp(BadExpression(IfError::NotSingleChar("'ab'".into()))),
            "`'ab'` is not a single-character constant",
        ),
        (
            pp(BadExpression(IfError::NestedTooDeeply(128))),
            "`#if` expression nested too deeply (limit 128)",
        ),
        (
            pp(BadExpression(IfError::MissingColon)),
            "missing `:` after `?` in `#if` expression",
        ),
        (
            pp(BadExpression(IfError::DivisionByZero)),
            "division by zero in `#if` expression",
        ),
        (
            pp(BadExpression(IfError::EndsEarly)),
            "`#if` expression ends too early",
        ),
        (
            pp(BadExpression(IfError::MissingParen)),
            "missing `)` in `#if` expression",
        ),
        (
            pp(NotSupported(PpConstruct::LineMarker)),
            "a `# LINE \"file\"` line marker is not supported",
        ),
        (
            pp(NotSupported(PpConstruct::Directive("ident".into()))),
            "`#ident` is not supported",
        ),
        (
            pp(NotSupported(PpConstruct::VaArgs)),
            "variadic macros (`__VA_ARGS__`) is not supported",
        ),
        (
            pp(NotSupported(PpConstruct::Ellipsis)),
            "variadic macros (`...`) is not supported",
        ),
        (
            pp(NotSupported(PpConstruct::SystemInclude)),
            "`#include <...>` (there is no system include path; use \"...\") is not supported",
        ),
    ];
    for (got, want) in cases {
        assert_eq!(got, want);
    }
    assert_eq!(Error::new(UsageError::FilesNeedStem).stage(), Stage::Usage);
}
