//! Unit tests of the cpfg preprocessor. Expected texts are derived by hand
//! from C's rules and `vlabcpp`'s documented behaviour (see the module docs),
//! never copied from the preprocessor's output.

use super::preprocess::*;
use std::collections::HashMap;
use std::io;
use std::path::Path;

/// A loader serving `files` (path -> text) from memory.
fn mem(files: &[(&str, &str)]) -> impl Fn(&Path) -> io::Result<String> {
    let m: HashMap<String, String> = files
        .iter()
        .map(|(p, t)| (p.to_string(), t.to_string()))
        .collect();
    move |p: &Path| {
        m.get(p.to_str().unwrap())
            .cloned()
            .ok_or_else(|| io::Error::new(io::ErrorKind::NotFound, "No such file or directory"))
    }
}

fn run(src: &str) -> Result<Output, PpError> {
    preprocess(Path::new("m.l"), src, &mem(&[]))
}

fn text(src: &str) -> String {
    match run(src) {
        Ok(o) => o.text,
        Err(e) => panic!("unexpected error: {e}"),
    }
}

fn err(src: &str) -> PpError {
    match run(src) {
        Ok(o) => panic!("expected an error, got {:?}", o.text),
        Err(e) => e,
    }
}

/// (file, line, column) of an error.
fn place(e: &PpError) -> (&str, usize, usize) {
    (&e.at.path, e.at.line, e.at.col)
}

/// (file, line, column) of the `n`th occurrence (0-based) of `needle` in the output.
fn loc_of(o: &Output, needle: &str, n: usize) -> (String, usize, usize) {
    let off = o
        .text
        .match_indices(needle)
        .nth(n)
        .unwrap_or_else(|| panic!("{needle:?} not in {:?}", o.text))
        .0;
    let l = o.map.locate(off);
    (l.file.to_string(), l.line, l.col)
}

fn l(file: &str, line: usize, col: usize) -> (String, usize, usize) {
    (file.to_string(), line, col)
}

// ---------------------------------------------------------------- text

#[test]
fn plain_text_passes_through_byte_for_byte() {
    let src = "Lsystem: 1\nAxiom: F(1)[+F]\n\tG\nF --> F F\nendlsystem\n";
    assert_eq!(text(src), src);
    // A missing final newline is added, as cpp does.
    assert_eq!(text("A --> B"), "A --> B\n");
    assert_eq!(text(""), "");
}

#[test]
fn crlf_input_becomes_lf_and_maps_to_the_right_columns() {
    let o = run("#define X 1\r\nA X\r\n\tB\r\n").unwrap();
    assert_eq!(o.text, "\nA 1\n\tB\n");
    assert_eq!(loc_of(&o, "B", 0), l("m.l", 3, 2));
    assert_eq!(loc_of(&o, "A", 0), l("m.l", 2, 1));
    let e = err("A\r\n#bogus\r\n");
    assert_eq!(place(&e), ("m.l", 2, 2));
    assert_eq!(e.at.snippet, "#bogus");
}

#[test]
fn line_continuation_joins_lines() {
    // The newline lost to the splice follows the line (line sync).
    assert_eq!(text("#define LONG 1 +\\\n 2\nLONG\n"), "\n\n1 + 2\n");
    // In ordinary text too, even inside a name; CR LF after the backslash.
    let o = run("AB\\\r\nCD E\n").unwrap();
    assert_eq!(o.text, "ABCD E\n");
    assert_eq!(loc_of(&o, "C", 0), l("m.l", 2, 1));
    assert_eq!(loc_of(&o, "E", 0), l("m.l", 2, 4));
}

#[test]
fn comments_are_spaces_and_keep_their_newlines() {
    // A block comment becomes a space followed by its newlines, a line
    // comment a space.
    let o = run("A /* x\ny */ B // c\nC\n").unwrap();
    assert_eq!(o.text, "A  \n B  \nC\n");
    assert_eq!(loc_of(&o, "B", 0), l("m.l", 2, 6));
    assert_eq!(loc_of(&o, "C", 0), l("m.l", 3, 1));
    // The newline comes right after the comment, so a TAB after the comment
    // still starts a continuation line (`\n\t`) as with vlabcpp.
    assert_eq!(text("A /*\n*/\tB\n"), "A  \n\tB\n");
    // Comment markers inside literals are text; a comment in a directive
    // continues the directive.
    assert_eq!(
        text("#define X 1 /* two\nlines */ + 2\nprintf(\"X /* %d\", X) // c\n"),
        "\n\nprintf(\"X /* %d\", 1 + 2)  \n"
    );
}

#[test]
fn newline_tab_is_left_for_the_parser() {
    // Directive lines and skipped lines stay empty lines, so a TAB line
    // after them does not continue the statement before them.
    let src = "A --> B\n#ifdef X\nC\n#endif\n\tD\n";
    assert_eq!(text(src), "A --> B\n\n\n\n\tD\n");
}

// ---------------------------------------------------------------- macros

#[test]
fn object_like_macros() {
    let o = run("#define L 10\n#define ANGLE 22.5\nF(L)+(ANGLE)\n").unwrap();
    assert_eq!(o.text, "\n\nF(10)+(22.5)\n");
    // Names inside other names, numbers or strings are not macros; `$` is
    // a name character as in vlabcpp.
    assert_eq!(
        text("#define X 1\n#define e 5\nXX X1 1X 1e+5 $X X$ \"X\" X\n"),
        "\n\nXX X1 1X 1e+5 $X X$ \"X\" 1\n"
    );
}

#[test]
fn function_like_macros_and_nesting() {
    let src = "#define SQ(x) ((x)*(x))\n#define TWO 2\n#define ADD(a, b) a+b\n\
               A(SQ(TWO+1)) B(ADD(SQ(1), ADD(2,3)))\n";
    assert_eq!(text(src), "\n\n\nA(((2+1)*(2+1))) B(((1)*(1))+2+3)\n");
    // Empty and parenthesised arguments, zero parameters.
    assert_eq!(
        text("#define P(a,b) [a|b]\n#define Z() z\nP(,(1,2)) P(f(x), ) Z()\n"),
        "\n\n[|(1,2)] [f(x)|] z\n"
    );
    // A function-like macro name without `(` is left alone.
    assert_eq!(text("#define F(x) <x>\nF + F (1)\n"), "\nF + <1>\n");
}

#[test]
fn no_recursive_self_expansion() {
    assert_eq!(text("#define A A B\nA\n"), "\nA B\n");
    assert_eq!(text("#define X Y\n#define Y X\nX Y\n"), "\n\nX Y\n");
    // C's classic example: the inner `f` is painted blue.
    assert_eq!(text("#define f(x) x f\nf(1)(2)\n"), "\n1 f(2)\n");
    // A function-like name produced by a macro takes its `(` from the text.
    assert_eq!(
        text("#define G F\n#define F(x) <x>\nG(1) G\n"),
        "\n\n<1> F\n"
    );
    // But a macro may appear again in its own argument.
    assert_eq!(text("#define g(x) [x]\ng(g(1))\n"), "\n[[1]]\n");
}

#[test]
fn macro_call_spanning_lines() {
    let o = run("#define F(a,b) a b\nF(1,\n2) X\nY\n").unwrap();
    assert_eq!(o.text, "\n1 2 X\n\nY\n");
    assert_eq!(loc_of(&o, "X", 0), l("m.l", 3, 4));
    assert_eq!(loc_of(&o, "Y", 0), l("m.l", 4, 1));
    assert_eq!(loc_of(&o, "2", 0), l("m.l", 3, 1));
    // The `(` may be on the next line; if it is not, the newline stays.
    assert_eq!(text("#define F(a) <a>\nF\n(1)\n"), "\n<1>\n");
    assert_eq!(text("#define F(a) <a>\nF\nG\n"), "\nF\nG\n");
}

#[test]
fn stringify_and_paste() {
    let src = "#define S(x) #x\n#define P(a,b) a##b\n#define Q(a) a ## 1\n\
               S(F(1)  \"q\\n\") P(F,1) P(,X) P(Y,) Q(G) P(+,=)\n";
    assert_eq!(text(src), "\n\n\n\"F(1) \\\"q\\\\n\\\"\" F1 X Y G1 +=\n");
    // A pasted name is rescanned.
    assert_eq!(
        text("#define CAT(a,b) a##b\n#define AB done\nCAT(A,B)\n"),
        "\n\ndone\n"
    );
    // `#` is literal in an object-like macro (cpfg's line width module).
    assert_eq!(text("#define W #(3)F\nW\n"), "\n#(3)F\n");
}

#[test]
fn undef() {
    assert_eq!(text("#define X 1\nX\n#undef X\nX\n"), "\n1\n\nX\n");
}

#[test]
fn redefinition_warns() {
    let o = run("#define X 1\n#define X 1\n#define X 2\nX\n").unwrap();
    assert_eq!(o.text, "\n\n\n2\n");
    assert_eq!(o.warnings.len(), 1);
    assert_eq!((o.warnings[0].at.line, o.warnings[0].at.col), (3, 9));
    assert!(o.warnings[0].message.to_string().contains("redefined"));
}

#[test]
fn macro_errors() {
    let e = err("#define F(a,b) a\nF(1)\n");
    assert!(matches!(e.kind, PpErrorKind::Macro(_)), "{e}");
    assert_eq!(place(&e), ("m.l", 2, 1));
    assert_eq!(e.message(), "macro `F` takes 2 arguments, 1 given");

    let e = err("#define F(a) a\nX F(1,\n2\n");
    assert_eq!(place(&e), ("m.l", 2, 3));
    assert!(e.message().contains("unterminated argument list"), "{e}");

    let e = err("#define F(a) a\nF(1\n#define G\n)\n");
    assert!(e.message().contains("unterminated argument list"), "{e}");

    let e = err("#define Q(a) a##(\nQ(x)\n");
    assert_eq!(place(&e), ("m.l", 2, 1));
    assert!(e.message().contains("pasting `x` and `(`"), "{e}");

    let e = err("#define S(a) #(a)\n");
    assert!(matches!(e.kind, PpErrorKind::InvalidDirective(_)), "{e}");
    assert_eq!(place(&e), ("m.l", 1, 14));

    for (src, col) in [("#define J ## a\n", 11), ("#define J(a) a ##\n", 16)] {
        let e = err(src);
        assert!(e.message().contains("`##` cannot be at either end"), "{e}");
        assert_eq!(place(&e), ("m.l", 1, col));
    }

    let e = err("#define V(...) __VA_ARGS__\n");
    assert!(matches!(e.kind, PpErrorKind::NotSupported(_)), "{e}");
    assert_eq!(place(&e), ("m.l", 1, 11));

    for (src, col) in [
        ("#define\n", 2),
        ("#define 1 2\n", 9),
        ("#define F(a,a) a\n", 13),
        ("#define F(a\n", 10),
        ("#define defined 1\n", 9),
    ] {
        let e = err(src);
        assert!(
            matches!(e.kind, PpErrorKind::InvalidDirective(_)),
            "{src}: {e}"
        );
        assert_eq!(place(&e), ("m.l", 1, col), "{src}");
    }
}

// ---------------------------------------------------------------- map

#[test]
fn map_through_macros() {
    let o = run("#define SEG F(1)\n#define ID(x) [x]\nA SEG ID(  B  )\n").unwrap();
    assert_eq!(o.text, "\n\nA F(1) [B]\n");
    // A body token maps to the call, and knows its place in the body.
    let f = o.text.find('F').unwrap();
    let or = o.map.origin(f + 2); // the `1`
    assert_eq!((or.at.line, or.at.col), (3, 3));
    let def = or.macro_def.unwrap();
    assert_eq!((def.line, def.col), (1, 15));
    let u = or.macro_use.unwrap();
    assert_eq!((u.line, u.col), (3, 3));
    // An argument token maps to where it is written, in the call.
    let b = o.text.find('B').unwrap();
    let or = o.map.origin(b);
    assert_eq!((or.at.line, or.at.col), (3, 12));
    assert_eq!(or.macro_use.map(|u| (u.line, u.col)), Some((3, 7)));
    assert_eq!(or.macro_def, None);
    // Plain text has no macro.
    let or = o.map.origin(o.text.find('A').unwrap());
    assert_eq!((or.at.line, or.at.col, or.macro_use), (3, 1, None));
    // A located error position with the source line.
    let loc = o.map.location(f);
    assert_eq!((loc.line, loc.col), (3, 3));
    assert_eq!(loc.snippet, "A SEG ID(  B  )");
}

#[test]
fn map_through_nested_macros_reports_the_outermost_call() {
    let o = run("#define IN G\n#define OUT [IN]\n\n  OUT\n").unwrap();
    assert_eq!(o.text, "\n\n\n  [G]\n");
    let or = o.map.origin(o.text.find('G').unwrap());
    assert_eq!((or.at.line, or.at.col), (4, 3));
    let d = or.macro_def.unwrap();
    assert_eq!((d.line, d.col), (1, 12));
}

#[test]
fn map_columns_count_characters() {
    let o = run("/* é */ é X\n").unwrap();
    assert_eq!(loc_of(&o, "X", 0), l("m.l", 1, 11));
}

// ---------------------------------------------------------------- includes

#[test]
fn include_relative_to_the_including_file() {
    let files = [
        ("dir/a.h", "#define A B\n#include \"sub/b.h\"\n"),
        ("dir/sub/b.h", "C\n#include \"../c.h\""),
        ("dir/sub/../c.h", "D"),
    ];
    let o = preprocess(Path::new("m.l"), "#include \"dir/a.h\"\nA\n", &mem(&files)).unwrap();
    // The #include line's newline comes back after the included text.
    assert_eq!(o.text, "\nC\nD\n\nB\n");
    assert_eq!(loc_of(&o, "C", 0), l("dir/sub/b.h", 1, 1));
    assert_eq!(loc_of(&o, "D", 0), l("dir/sub/../c.h", 1, 1));
    assert_eq!(loc_of(&o, "B", 0), l("m.l", 2, 1));
    let d = o.map.origin(o.text.find('B').unwrap()).macro_def.unwrap();
    assert_eq!((d.file, d.line, d.col), ("dir/a.h", 1, 11));
}

#[test]
fn include_of_a_missing_file() {
    let e = preprocess(
        Path::new("models/m.l"),
        "A\n#include  \"nope.h\"\n",
        &mem(&[]),
    )
    .unwrap_err();
    assert_eq!(place(&e), ("models/m.l", 2, 11));
    match &e.kind {
        PpErrorKind::IncludeFailed { path, source } => {
            assert_eq!(path, Path::new("models/nope.h"));
            assert_eq!(source.kind(), io::ErrorKind::NotFound);
        }
        k => panic!("{k:?}"),
    }
    assert!(std::error::Error::source(&e).is_some());
    assert_eq!(
        e.message(),
        "cannot include `models/nope.h`: No such file or directory"
    );
}

#[test]
fn include_errors_point_into_the_included_file() {
    let files = [("a.h", "X\n#if 1\nY\n")];
    let e = preprocess(Path::new("m.l"), "#include \"a.h\"\n", &mem(&files)).unwrap_err();
    assert_eq!(place(&e), ("a.h", 2, 1));
    assert!(matches!(
        e.kind,
        PpErrorKind::UnterminatedConditional("#if")
    ));
    // An #endif in an included file cannot close the includer's #if.
    let files = [("a.h", "#endif\n")];
    let e = preprocess(
        Path::new("m.l"),
        "#if 1\n#include \"a.h\"\n#endif\n",
        &mem(&files),
    )
    .unwrap_err();
    assert_eq!(place(&e), ("a.h", 1, 1));
    assert!(matches!(
        e.kind,
        PpErrorKind::UnmatchedConditional("#endif")
    ));
    let files = [("a.h", "/* open\n")];
    let e = preprocess(Path::new("m.l"), "#include \"a.h\"\n", &mem(&files)).unwrap_err();
    assert_eq!(place(&e), ("a.h", 1, 1));
    assert!(matches!(e.kind, PpErrorKind::UnterminatedComment));
}

#[test]
fn include_cycles_and_depth() {
    // A cycle without a guard recurses to the depth limit: an error there,
    // naming the cycle.
    let files = [
        ("a.h", "#include \"b.h\"\n"),
        ("b.h", "\n#include \"a.h\"\n"),
    ];
    let e = preprocess(Path::new("m.l"), "#include \"a.h\"\n", &mem(&files)).unwrap_err();
    // (m.l and 199 files: the 200th include is a.h's.)
    assert_eq!(place(&e), ("a.h", 1, 1));
    assert_eq!(
        e.message(),
        "#include recursion without end (over 200 files deep; an include guard would stop it): b.h -> a.h -> b.h"
    );
    let e = preprocess(Path::new("m.l"), "#include \"./m.l\"\n", &mem(&[])).unwrap_err();
    assert!(
        matches!(e.kind, PpErrorKind::IncludeCycle { limit: 200, .. }),
        "{e}"
    );
    assert!(e.message().ends_with(": m.l -> m.l"), "{e}");

    let files = [
        ("1.h", "#include \"2.h\"\n"),
        ("2.h", "#include \"3.h\"\n"),
        ("3.h", "ok\n"),
    ];
    let limits = Limits {
        max_include_depth: 3,
        ..Limits::default()
    };
    let e = preprocess_with(
        Path::new("m.l"),
        "#include \"1.h\"\n",
        &mem(&files),
        &limits,
    )
    .unwrap_err();
    assert_eq!(place(&e), ("2.h", 1, 1));
    assert!(matches!(e.kind, PpErrorKind::Limit { limit: 3, .. }), "{e}");
    let limits = Limits {
        max_include_depth: 4,
        ..Limits::default()
    };
    let o = preprocess_with(
        Path::new("m.l"),
        "#include \"1.h\"\n",
        &mem(&files),
        &limits,
    )
    .unwrap();
    assert_eq!(o.text, "ok\n");
}

/// Guarded includes that come back to a file being included are cpp's:
/// the guard ends the recursion (the expected texts are gcc's `cpp -P`
/// output of the same files, its blank lines aside).
#[test]
fn guarded_include_cycles_are_followed() {
    // The whole file guarded: its text once.
    let m = "#ifndef M_L\n#define M_L\n#include \"m.l\"\nX\n#endif\n";
    let o = preprocess(Path::new("m.l"), m, &mem(&[])).unwrap();
    assert_eq!(o.text.split_whitespace().collect::<Vec<_>>(), ["X"]);
    // Only the include guarded: the text after it twice, the included
    // copy first.
    let m = "#ifndef G\n#define G\n#include \"m.l\"\n#endif\nX\n";
    let o = preprocess(Path::new("m.l"), m, &mem(&[])).unwrap();
    assert_eq!(o.text.split_whitespace().collect::<Vec<_>>(), ["X", "X"]);
    // Two headers that include each other, each guarded.
    let files = [
        (
            "a.h",
            "#ifndef A_H\n#define A_H\n#include \"b.h\"\nA\n#endif\n",
        ),
        (
            "b.h",
            "#ifndef B_H\n#define B_H\n#include \"a.h\"\nB\n#endif\n",
        ),
    ];
    let o = preprocess(
        Path::new("m.l"),
        "#include \"a.h\"\n#include \"b.h\"\nM\n",
        &mem(&files),
    )
    .unwrap();
    assert_eq!(
        o.text.split_whitespace().collect::<Vec<_>>(),
        ["B", "A", "M"]
    );
}

#[test]
fn include_forms() {
    let files = [("a.h", "A\n")];
    let o = preprocess(
        Path::new("m.l"),
        "#define H \"a.h\"\n#include H\n",
        &mem(&files),
    )
    .unwrap();
    assert_eq!(o.text, "\nA\n");
    let e = err("#include <stdio.h>\n");
    assert!(matches!(e.kind, PpErrorKind::NotSupported(_)), "{e}");
    assert_eq!(place(&e), ("m.l", 1, 10));
    let e = err("#include\n");
    assert!(matches!(e.kind, PpErrorKind::InvalidDirective(_)), "{e}");
    let e = err("#include foo\n");
    assert!(matches!(e.kind, PpErrorKind::InvalidDirective(_)), "{e}");
    assert_eq!(place(&e), ("m.l", 1, 10));
}

// ---------------------------------------------------------------- conditionals

#[test]
fn conditional_groups() {
    let src = "#define X 3\n\
               #ifdef X\na\n#else\nb\n#endif\n\
               #ifndef X\nc\n#elif X == 3\nd\n#elif 1\ne\n#else\nf\n#endif\n\
               #if 0\n#if 1\ng\n#else\nh\n#endif\n#elif defined Y\ni\n#else\nj\n#endif\n";
    let o = text(src);
    let kept: Vec<&str> = o.lines().filter(|l| !l.is_empty()).collect();
    assert_eq!(kept, ["a", "d", "j"]);
    // Every line of the source is one line of the output here.
    assert_eq!(o.lines().count(), src.lines().count());
}

#[test]
fn skipped_groups_are_not_checked() {
    let src =
        "#if 0\n#bogus\n#(2)F\n#include \"nope\"\n#if 1/0\n#endif\n#error no\n'\n#endif\nok\n";
    let o = run(src).unwrap();
    assert_eq!(o.text, "\n\n\n\n\n\n\n\n\nok\n");
    assert!(o.warnings.is_empty());
}

#[test]
fn if_expressions() {
    let cases: &[(&str, bool)] = &[
        ("1+2*3 == 7", true),
        ("(1+2)*3 == 9", true),
        ("-2 < 0", true),
        ("!0 && !!5", true),
        ("~0 == -1", true),
        ("7/2 == 3 && -7/2 == -3 && -7%2 == -1", true),
        ("1 << 4 == 16 && -16 >> 2 == -4", true),
        ("1 ? 2 : 0", true),
        ("0 ? 1 : 0", false),
        ("0 ? 1/0 : 1", true),
        ("0 && 1/0", false),
        ("1 || 1/0", true),
        ("defined X && defined(X) && X == 3", true),
        ("defined ( X ) + defined UNDEF == 1", true),
        ("UNKNOWN == 0 && !true", true),
        ("0x10 == 16 && 010 == 8 && 10L == 10u", true),
        ("'A' == 65 && '\\n' == 10", true),
        ("3 > 2 > 1", false),
        ("(5 & 3) == 1 && (5 | 3) == 7 && (5 ^ 3) == 6", true),
        ("2 >= 2 && 2 <= 1", false),
        ("SUM(1, 2) == 3", true),
        ("1 != 1, 1", true),
        // C's intmax_t / uintmax_t: an unsigned operand makes the
        // operation unsigned. Expected values: gcc -E 12.2 on each line.
        ("18446744073709551615 > 0", true),
        ("0xFFFFFFFFFFFFFFFF > 0", true),
        ("9223372036854775808 > 0", true),
        ("-1 > 0u", true),
        ("-1 < 0", true),
        ("0u - 1 == 0xFFFFFFFFFFFFFFFF", true),
        ("(0u - 1) / 2 == 0x7FFFFFFFFFFFFFFF", true),
        ("-1 / 2u > 0", true),
        ("(0u - 1) >> 63 == 1", true),
        ("(-1) >> 63 == -1", true),
        ("-8 % 3u == 2", true),
        ("(1 ? -1 : 0u) > 0", true),
        ("(0 ? 1u : -1) < 0", false),
        ("(!0u) - 2 < 0", true),
        ("(1 < 2u) - 2 < 0", true),
        ("~0u > 0", true),
        ("1u << 63 > 0", true),
        ("1 << 63 < 0", true),
        ("-0x8000000000000000 < 0", false),
        ("0x7FFFFFFFFFFFFFFF + 1 < 0", true),
    ];
    for (e, want) in cases {
        let src =
            format!("#define X 3\n#define SUM(a,b) ((a)+(b))\n#if {e}\nyes\n#else\nno\n#endif\n");
        let got = text(&src).contains("yes");
        assert_eq!(got, *want, "#if {e}");
    }
}

#[test]
fn bad_if_expressions() {
    let cases: &[(&str, usize, &str)] = &[
        ("#if 1 +\n", 8, "ends too early"),
        ("#if 1/0\n", 6, "division by zero"),
        ("#if 1 % (2-2)\n", 7, "division by zero"),
        ("#if 1.5\n", 5, "not an integer"),
        ("#if \"s\"\n", 5, "unexpected"),
        ("#if\n", 2, "needs an expression"),
        ("#if (1\n", 7, "missing `)`"),
        ("#if 1 2\n", 7, "missing operator"),
        ("#if 1 = 1\n", 7, "unexpected `=`"),
        ("#if defined\n", 5, "needs a macro name"),
        ("#if defined(X\n", 5, "missing `)`"),
        ("#if 1 ? 2\n", 10, "missing `:`"),
        ("#if 99999999999999999999\n", 5, "too large"),
    ];
    for (src, col, msg) in cases {
        let e = err(src);
        assert!(
            matches!(e.kind, PpErrorKind::BadExpression(_)),
            "{src}: {e}"
        );
        assert_eq!(place(&e), ("m.l", 1, *col), "{src}: {e}");
        assert!(e.message().contains(msg), "{src}: {e}");
    }
    // Deep nesting is an error, not a stack overflow.
    for deep in [
        format!("#if {}1{}\n", "(".repeat(100_000), ")".repeat(100_000)),
        format!("#if {}1\n", "-".repeat(100_000)),
        format!("#if {}1\n", "1?1:".repeat(100_000)),
    ] {
        let e = err(&deep);
        assert!(e.message().contains("nested too deeply"), "{e}");
        assert_eq!(place(&e).1, 1);
    }
    // 120 levels are fine.
    let ok = format!("#if {}1{}\nyes\n#endif\n", "(".repeat(120), ")".repeat(120));
    assert_eq!(text(&ok), "\nyes\n\n");
    // Through a macro: the error points at the macro's use.
    let e = err("#define BAD 1/0\n#if 1 + BAD\n#endif\n");
    assert_eq!(place(&e), ("m.l", 2, 9));
}

#[test]
fn conditional_structure_errors() {
    let e = err("A\n#if 1\nB\n");
    assert!(matches!(
        e.kind,
        PpErrorKind::UnterminatedConditional("#if")
    ));
    assert_eq!(place(&e), ("m.l", 2, 1));
    let e = err("#ifdef X\n#else\n");
    assert!(matches!(
        e.kind,
        PpErrorKind::UnterminatedConditional("#ifdef")
    ));
    for (src, d, line) in [
        ("#else\n", "#else", 1),
        ("A\n  #endif\n", "#endif", 2),
        ("#elif 1\n", "#elif", 1),
    ] {
        let e = err(src);
        assert!(
            matches!(e.kind, PpErrorKind::UnmatchedConditional(x) if x == d),
            "{src}: {e}"
        );
        assert_eq!(place(&e).1, line);
        assert_eq!(e.message(), format!("`{d}` without `#if`"));
    }
    let e = err("#if 1\n#else\n#elif 1\n#endif\n");
    assert!(matches!(e.kind, PpErrorKind::AfterElse("#elif")));
    assert_eq!(place(&e), ("m.l", 3, 1));
    let e = err("#if 0\n#else\n#else\n#endif\n");
    assert!(matches!(e.kind, PpErrorKind::AfterElse("#else")));
    let e = err("#ifdef\n#endif\n");
    assert!(matches!(e.kind, PpErrorKind::InvalidDirective(_)), "{e}");
    // Extra tokens after #endif: a warning, as in vlabcpp.
    let o = run("#ifdef X junk\n#endif X\n").unwrap();
    assert_eq!(o.warnings.len(), 2);
    assert_eq!(o.warnings[1].at.line, 2);
}

// ---------------------------------------------------------------- directives

#[test]
fn module_lines_starting_with_hash() {
    let o = run("Axiom: A\n#(2)F\n  #+F\n#\nB\n").unwrap();
    assert_eq!(o.text, "Axiom: A\n#(2)F\n  #+F\n\nB\n");
    let w: Vec<(usize, usize)> = o.warnings.iter().map(|w| (w.at.line, w.at.col)).collect();
    assert_eq!(w, [(2, 1), (3, 3)]);
    assert!(o.warnings[0]
        .to_string()
        .starts_with("lsgen: m.l:2:1: warning: "));
    // Macros still expand on such a line.
    assert_eq!(text("#define W 3\n#(W)F\n"), "\n#(3)F\n");
}

#[test]
fn unknown_and_unsupported_directives() {
    let e = err("A\n#foo bar\n");
    assert!(matches!(&e.kind, PpErrorKind::UnknownDirective(n) if n == "foo"));
    assert_eq!(place(&e), ("m.l", 2, 2));
    let d: crate::diag::Error = e.into();
    assert_eq!(
        d.to_string(),
        "m.l:2:2: error: unknown directive `#foo`\n#foo bar\n ^\n"
    );
    for src in [
        "#line 3\n",
        "# 12 \"x.l\"\n",
        "#ident \"x\"\n",
        "#import \"x\"\n",
    ] {
        let e = err(src);
        assert!(matches!(e.kind, PpErrorKind::NotSupported(_)), "{src}: {e}");
    }
    let e = err("\n#error stop here\n");
    assert_eq!(e.message(), "#error stop here");
    assert_eq!(place(&e), ("m.l", 2, 1));
    let o = run("#warning careful\n#pragma once\nA\n").unwrap();
    assert_eq!(o.text, "\n\nA\n");
    assert_eq!(o.warnings.len(), 2);
}

#[test]
fn lexical_errors() {
    let e = err("A\nB /* open\n\n");
    assert!(matches!(e.kind, PpErrorKind::UnterminatedComment));
    assert_eq!(place(&e), ("m.l", 2, 3));
    let e = err("A \\\n\"open\n");
    assert!(matches!(e.kind, PpErrorKind::UnterminatedLiteral('"')));
    assert_eq!(place(&e), ("m.l", 2, 1));
    // A `'` not closed on its line of text is vlabcpp's (cccp.c): a
    // message, and the rest of the line as it is, without macro expansion
    // (gcc's cpp does the same); a comment after it is still removed. In a
    // directive it is an error.
    let o = run("#define X Y\nX don't X /* c */\nX\n").unwrap();
    assert_eq!(o.text, "\nY don't X  \nY\n");
    assert_eq!(o.warnings.len(), 1);
    assert_eq!(o.warnings[0].at.line, 2);
    assert_eq!(o.warnings[0].at.col, 6);
    assert_eq!(
        o.warnings[0].message,
        crate::diag::WarningKind::UnterminatedCharConstant
    );
    let e = err("#if 'a\n#endif\n");
    assert!(matches!(e.kind, PpErrorKind::UnterminatedLiteral('\'')));
    assert_eq!(place(&e), ("m.l", 1, 5));
}

// ---------------------------------------------------------------- limits

#[test]
fn macro_bomb_is_a_located_error() {
    let mut src = String::from("#define A0 x x\n");
    for i in 1..40 {
        src.push_str(&format!("#define A{i} A{} A{}\n", i - 1, i - 1));
    }
    src.push_str("ok\n  A39\n");
    let t = std::time::Instant::now();
    let e = err(&src);
    assert!(t.elapsed().as_secs() < 30);
    assert!(
        matches!(e.kind, PpErrorKind::Limit { limit, .. } if limit == 1 << 21),
        "{e}"
    );
    assert_eq!(place(&e), ("m.l", 42, 3));
    // Just under a small limit it works.
    let limits = Limits {
        max_expansion_tokens: 100,
        ..Limits::default()
    };
    let o = preprocess_with(
        Path::new("m.l"),
        "#define A0 x x\n#define A1 A0 A0\n#define A2 A1 A1\nA2\n",
        &mem(&[]),
        &limits,
    )
    .unwrap();
    assert_eq!(o.text, "\n\n\nx x x x x x x x\n");
}

/// The work of `#include` is bounded over the whole run, not only in
/// depth: the `#include` past the count, or past the bytes of included
/// text (each inclusion counted), is the error.
#[test]
fn includes_are_bounded_in_number_and_bytes() {
    let files = [
        ("e.h", ""),
        ("k.h", "0123456789"),
        ("two.h", "#include \"e.h\"\n#include \"e.h\"\n"),
    ];
    let limits = Limits {
        max_includes: 3,
        ..Limits::default()
    };
    let pp =
        |src: &str, limits: &Limits| preprocess_with(Path::new("m.l"), src, &mem(&files), limits);
    // Three are fine (`A` stays on its line 4).
    let o = pp(
        "#include \"e.h\"\n#include \"e.h\"\n#include \"e.h\"\nA\n",
        &limits,
    )
    .unwrap();
    assert_eq!(o.text, "\n\n\nA\n");
    // The fourth, here the second one inside two.h, is one too many.
    let e = pp("#include \"e.h\"\n  #include \"two.h\"\nA\n", &limits).unwrap_err();
    assert!(matches!(e.kind, PpErrorKind::Limit { limit: 3, .. }), "{e}");
    assert_eq!(place(&e), ("two.h", 2, 1));
    assert!(e.message().contains("too many `#include`s"), "{e}");
    // 25 bytes: two inclusions of k.h's 10 bytes, not a third.
    let limits = Limits {
        max_included_bytes: 25,
        ..Limits::default()
    };
    let o = pp("#include \"k.h\"\n#include \"k.h\"\n", &limits).unwrap();
    assert_eq!(o.text.matches("0123456789").count(), 2);
    let e = pp(
        "#include \"k.h\"\n#include \"k.h\"\n #include \"k.h\"\n",
        &limits,
    )
    .unwrap_err();
    assert!(
        matches!(e.kind, PpErrorKind::Limit { limit: 25, .. }),
        "{e}"
    );
    assert_eq!(place(&e), ("m.l", 3, 2));
    assert!(e.message().contains("too much text included"), "{e}");
    // The defaults.
    let d = Limits::default();
    assert_eq!((d.max_includes, d.max_included_bytes), (1 << 16, 256 << 20));
}

#[test]
fn deep_macro_nesting_is_a_located_error() {
    let mut src = String::from("#define F(x) x\n");
    src.push_str(&"F(".repeat(100));
    src.push('1');
    src.push_str(&")".repeat(100));
    src.push('\n');
    let e = err(&src);
    assert!(
        matches!(e.kind, PpErrorKind::Limit { limit: 64, .. }),
        "{e}"
    );
    assert_eq!(place(&e).1, 2);
    // 60 levels are fine.
    let ok = format!("#define F(x) x\n{}1{}\n", "F(".repeat(60), ")".repeat(60));
    assert_eq!(text(&ok), "\n1\n");
}

#[test]
fn output_size_is_limited() {
    let limits = Limits {
        max_output: 1000,
        ..Limits::default()
    };
    let run = |src: &str| preprocess_with(Path::new("m.l"), src, &mem(&[]), &limits);
    assert!(run(&"F".repeat(999)).is_ok());
    let e = run(&format!("A\n{}\n", "F".repeat(1000))).unwrap_err();
    assert!(
        matches!(e.kind, PpErrorKind::Limit { limit: 1000, .. }),
        "{e}"
    );
    assert_eq!(place(&e).1, 2);
    let e = run("#define X FFFFFFFFFF\n#define Y X X X X X X X X X X\nY Y Y Y Y Y Y Y Y Y Y\n")
        .unwrap_err();
    assert!(
        matches!(e.kind, PpErrorKind::Limit { limit: 1000, .. }),
        "{e}"
    );
    assert_eq!(place(&e).1, 3);
}

#[test]
fn read_file_reads_utf8_and_refuses_others() {
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("a.h");
    std::fs::write(&p, "A\n").unwrap();
    assert_eq!(read_file(&p).unwrap(), "A\n");
    std::fs::write(&p, b"\xff\n").unwrap();
    assert_eq!(
        read_file(&p).unwrap_err().kind(),
        io::ErrorKind::InvalidData
    );
    assert_eq!(
        read_file(&dir.path().join("none")).unwrap_err().kind(),
        io::ErrorKind::NotFound
    );
    // Through preprocess, with the real file system.
    std::fs::write(&p, "#define A B\n").unwrap();
    let main = dir.path().join("m.l");
    let o = preprocess(&main, "#include \"a.h\"\nA\n", &read_file).unwrap();
    assert_eq!(o.text, "\n\nB\n");
}

#[test]
fn map_size_does_not_grow_with_plain_text() {
    // One piece per run of copied text, not one per module.
    let axiom = "F(1)[+F(2)]-F ".repeat(10_000);
    let o = run(&format!("#define X 1\nAxiom: {axiom}\nA --> B\n")).unwrap();
    assert!(o.map.pieces() <= 4, "{} pieces", o.map.pieces());
    let f = o.text.rfind("F(1)").unwrap();
    let at = o.map.locate(f);
    assert_eq!((at.line, at.col), (2, 8 + 14 * 9_999));
    assert_eq!(loc_of(&o, "B", 0), l("m.l", 3, 7));
}

#[test]
fn untaken_elif_is_not_evaluated_and_undef_needs_a_name() {
    assert_eq!(text("#if 1\na\n#elif 1/0\nb\n#endif\n"), "\na\n\n\n\n");
    assert_eq!(
        text("#if 0\n#elif 1\nb\n#elif 1/0\n#endif\n"),
        "\n\nb\n\n\n"
    );
    let e = err("#undef\n");
    assert!(matches!(e.kind, PpErrorKind::InvalidDirective(_)), "{e}");
    let e = err("#undef 3\n");
    assert_eq!(place(&e), ("m.l", 1, 8));
    // A quote inside a string is text.
    assert_eq!(
        text("#define X 1\nprintf(\"it's X\\n\", X);\n"),
        "\nprintf(\"it's X\\n\", 1);\n"
    );
}

#[test]
fn warning_rendering() {
    let o = run("A\n\t#(1)F\n").unwrap();
    assert_eq!(
        o.warnings[0].to_string(),
        "lsgen: m.l:2:2: warning: `#` followed by a symbol is taken as a module, \
         not a directive\n\t#(1)F\n\t^\n"
    );
}

#[test]
fn line_sync_as_vlabcpp() {
    // Output line N is source line N in a file without includes, whatever
    // splices, calls over several lines and comments in directives remove.
    let src = "L1 \\\nL1b\n#define F(a,b) a+b /* c\nc */\nL5 F(1,\n2)\nL7 /* x\n*/ L8\n#if 0\nx\n#endif\nL12\n";
    let o = text(src);
    for (i, line) in o.lines().enumerate() {
        if let Some(w) = line
            .split_whitespace()
            .next()
            .filter(|w| w.starts_with('L'))
        {
            assert_eq!(w, format!("L{}", i + 1), "{o:?}");
        }
    }
    assert_eq!(o.lines().count(), 12, "{o:?}");
    assert!(o.contains("L5 1+2\n") && o.contains("\n L8\n"), "{o:?}");
    // So a TAB line after a call over several lines does not continue the
    // statement, as in cpfg.
    assert_eq!(
        text("#define F(a,b) a b\nF(1,\n2) X\n\tY\n"),
        "\n1 2 X\n\n\tY\n"
    );
    // Nor after an empty included file.
    let o = preprocess(
        Path::new("m.l"),
        "A\n#include \"e.h\"\n\tB\n",
        &mem(&[("e.h", "")]),
    )
    .unwrap();
    assert_eq!(o.text, "A\n\n\tB\n");
}

#[test]
fn random_input_gives_text_or_an_error_never_a_panic() {
    // Fixed-seed LCG over fragments that exercise every path.
    const PIECES: &[&str] = &[
        "#define ",
        "#undef ",
        "#if ",
        "#ifdef ",
        "#elif ",
        "#else",
        "#endif",
        "#include ",
        "\"a.h\"",
        "#",
        "##",
        "(",
        ")",
        ",",
        "\"",
        "'",
        "/*",
        "*/",
        "//",
        "\\\n",
        "\n",
        "\r\n",
        "\t",
        " ",
        "A",
        "B",
        "F",
        "x",
        "defined",
        "1",
        "0",
        ".5",
        "+",
        "-",
        "/",
        "?",
        ":",
        "é",
        "$",
        "F(x) x x",
        "A B",
        "G(a,b) a##b #a",
        "\n#define A B\n",
        "\n#if 1\n",
        "\n#endif\n",
    ];
    let loader = mem(&[("a.h", "#define H 1\nH A\n"), ("b.h", "#include \"a.h\"\n")]);
    let limits = Limits {
        max_output: 1 << 16,
        max_expansion_tokens: 1 << 14,
        ..Limits::default()
    };
    let mut seed: u64 = 0x2545F4914F6CDD1D;
    let mut next = || {
        seed = seed
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        (seed >> 33) as usize
    };
    let (mut ok, mut failed) = (0, 0);
    for _ in 0..5000 {
        let n = next() % 60;
        let src: String = (0..n).map(|_| PIECES[next() % PIECES.len()]).collect();
        match preprocess_with(Path::new("m.l"), &src, &loader, &limits) {
            Ok(o) => {
                ok += 1;
                for off in 0..=o.text.len() {
                    let at = o.map.origin(off).at;
                    assert!(at.line >= 1 && at.col >= 1);
                }
            }
            Err(e) => {
                failed += 1;
                assert!(e.at.line >= 1 && e.at.col >= 1, "{e}");
                let _ = crate::diag::Error::from(e).to_string();
            }
        }
    }
    // Both paths were exercised.
    assert!(ok > 100 && failed > 100, "{ok} ok, {failed} errors");
}
