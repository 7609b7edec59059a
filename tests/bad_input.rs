//! A catalogue of malformed inputs. Each case runs the real binary on an
//! `.ls` file in a fresh temp dir with `-o out.txt` and checks the error
//! contract:
//!
//! * exit status 1, no panic, no backtrace, nothing on stdout;
//! * exactly one line on stderr starting with `lsgen: `, and it is
//!   `lsgen: PATH:LINE:COL: error: MESSAGE` at the expected place with the
//!   expected words in the message;
//! * then the source line (or an excerpt with `...`), then whitespace and a
//!   `^` that sits under the character at LINE:COL;
//! * `out.txt` does not exist and the temp dir holds no new file;
//! * the whole of stderr (the temp dir shown as `$DIR`) is the golden file
//!   `tests/golden/bad_input/NAME.stderr`. After a deliberate change of a
//!   message, rewrite the files with `LSGEN_BLESS=1 cargo test --test
//!   bad_input` and review every changed file by eye: LINE:COL and the
//!   words above are the independent part, the golden file pins the rest.
//!   A message found wrong is not blessed: its golden file holds the right
//!   text, written by hand, and the case is `#[ignore]`d as an lsgen bug
//!   (so never bless with `--ignored`).
//!
//! Cases that lsgen gets wrong are kept, marked
//! `#[ignore = "lsgen bug: ..."]`; cases for bugs since fixed say so.

mod common;

use common::{assert_golden, listing, lsgen, run, run_with_stdin, tempdir, Run};
use std::path::Path;

struct Case {
    src: Vec<u8>,
    /// Acceptable positions; empty: anywhere (the caret check still applies).
    at: Vec<(usize, usize)>,
    /// Words the message must contain.
    msg: Vec<&'static str>,
    /// Extra files in the temp dir, and extra arguments (`{dir}` is the temp
    /// dir).
    files: Vec<(&'static str, Vec<u8>)>,
    args: Vec<String>,
    /// The file the error must name (default `in.ls`).
    err_file: &'static str,
    /// The input may also be accepted, with exactly this output.
    ok_output: Option<Vec<u8>>,
    /// Feed the input (or, with `--axiom -`, the axiom) on standard input;
    /// the error then names `<stdin>`.
    stdin: Option<Vec<u8>>,
}

/// An input that must fail at LINE:COL with MSG in the message.
fn err(src: impl Into<Vec<u8>>, line: usize, col: usize, msg: &'static str) -> Case {
    Case {
        src: src.into(),
        at: vec![(line, col)],
        msg: vec![msg],
        files: Vec::new(),
        args: Vec::new(),
        err_file: "in.ls",
        ok_output: None,
        stdin: None,
    }
}

/// An input that must fail somewhere (an implementation limit) with MSG, or
/// be accepted with output `ok`.
fn err_or_ok(src: impl Into<Vec<u8>>, msg: &'static str, ok: &str) -> Case {
    Case {
        at: Vec::new(),
        ok_output: Some(ok.as_bytes().to_vec()),
        ..err(src, 0, 0, msg)
    }
}

impl Case {
    fn or_at(mut self, line: usize, col: usize) -> Case {
        self.at.push((line, col));
        self
    }
    /// More words the message must contain.
    fn also(mut self, words: &'static str) -> Case {
        self.msg.push(words);
        self
    }
    /// Read the axiom from a file `ax.txt` holding `text`; the error is
    /// expected in that file.
    fn axiom_file(mut self, text: impl Into<Vec<u8>>) -> Case {
        self.files.push(("ax.txt", text.into()));
        self.args.push("--axiom".into());
        self.args.push("{dir}/ax.txt".into());
        self.err_file = "ax.txt";
        self
    }

    /// Read the L-system from standard input (`lsgen - -o out.txt`).
    fn on_stdin(mut self) -> Case {
        self.stdin = Some(std::mem::take(&mut self.src));
        self.err_file = "<stdin>";
        self
    }

    /// Read the axiom from standard input (`--axiom -`), holding `text`.
    fn axiom_from_stdin(mut self, text: impl Into<Vec<u8>>) -> Case {
        self.stdin = Some(text.into());
        self.args.push("--axiom".into());
        self.args.push("-".into());
        self.err_file = "<stdin>";
        self
    }

    fn check(self, name: &str) {
        let dir = tempdir();
        let d = dir.path();
        let input = d.join("in.ls");
        std::fs::write(&input, &self.src).unwrap();
        for (name, bytes) in &self.files {
            std::fs::write(d.join(name), bytes).unwrap();
        }
        let before = listing(d);
        let out = d.join("out.txt");
        let mut cmd = lsgen();
        // Standard input holds the L-system unless it holds `--axiom -`.
        if self.stdin.is_some() && self.args.is_empty() {
            cmd.arg("-");
        } else {
            cmd.arg(&input);
        }
        cmd.arg("-o").arg(&out);
        for a in &self.args {
            cmd.arg(a.replace("{dir}", &d.display().to_string()));
        }
        let r = match &self.stdin {
            Some(bytes) => run_with_stdin(&mut cmd, bytes.clone()),
            None => run(&mut cmd),
        };
        r.assert_no_crash();
        if r.code() == Some(0) {
            if let Some(want) = &self.ok_output {
                assert!(r.stderr.is_empty(), "stderr: {}", r.stderr);
                let got = std::fs::read(&out).expect("accepted, so out.txt exists");
                assert!(got == *want, "accepted with the wrong output");
                let mut after = listing(d);
                after.remove("out.txt");
                assert_eq!(after, before, "files left in the temp dir");
                return;
            }
        }
        let err_path = if self.err_file == "<stdin>" {
            std::path::PathBuf::from("<stdin>")
        } else {
            d.join(self.err_file)
        };
        let err_src = if let Some(bytes) = &self.stdin {
            bytes.clone()
        } else if self.err_file == "in.ls" {
            self.src.clone()
        } else {
            self.files
                .iter()
                .find(|(n, _)| *n == self.err_file)
                .unwrap()
                .1
                .clone()
        };
        check_error(&r, &err_path, &err_src, &self.at, &self.msg);
        assert!(
            r.stdout.is_empty(),
            "stdout: {}",
            String::from_utf8_lossy(&r.stdout)
        );
        assert!(!out.exists(), "out.txt was created by a failing run");
        assert_eq!(listing(d), before, "files left in the temp dir");
        let shown = r.stderr.replace(&d.display().to_string(), "$DIR");
        assert_golden(&format!("bad_input/{name}.stderr"), &shown);
    }
}

/// Line `line` (1-based) of `src`, decoded as lsgen shows it.
fn source_line(src: &[u8], line: usize) -> Option<String> {
    let raw = src.split(|&b| b == b'\n').nth(line - 1)?;
    let s = String::from_utf8_lossy(raw);
    // Control characters are shown as U+FFFD, as undecodable bytes are.
    Some(
        s.strip_suffix('\r')
            .unwrap_or(&s)
            .chars()
            .map(|c| {
                if c.is_control() && c != '\t' {
                    '\u{FFFD}'
                } else {
                    c
                }
            })
            .collect(),
    )
}

/// Terminal columns of a character, for the few kinds the catalogue uses
/// (a hand-made table, independent of lsgen's): combining accents take
/// none, CJK ideographs, Hangul, fullwidth forms and emoji take two.
fn columns(c: char) -> usize {
    match c as u32 {
        0x0300..=0x036F => 0,
        0x1100..=0x115F
        | 0x2E80..=0x303E
        | 0x3041..=0x33FF
        | 0x3400..=0x4DBF
        | 0x4E00..=0x9FFF
        | 0xAC00..=0xD7A3
        | 0xF900..=0xFAFF
        | 0xFF00..=0xFF60
        | 0x1F300..=0x1F64F
        | 0x1F900..=0x1F9FF => 2,
        _ => 1,
    }
}

/// The characters of `snippet` that a caret line of `pad` sits under: the
/// pad must be exactly the blanks (a tab for a tab) of the characters
/// before one of them (several when some take no column); `None` is the
/// spot just past the end.
fn chars_under_caret(snippet: &str, pad: &str) -> Vec<Option<char>> {
    let mut want = String::new();
    let mut under = Vec::new();
    for c in snippet.chars() {
        if want == pad {
            under.push(Some(c));
        }
        if c == '\t' {
            want.push('\t');
        } else {
            want.extend(std::iter::repeat_n(' ', columns(c)));
        }
    }
    if want == pad {
        under.push(None);
    }
    under
}

fn check_error(r: &Run, path: &Path, src: &[u8], at: &[(usize, usize)], msg: &[&str]) {
    let head = r.assert_one_error();
    assert!(
        !r.stderr.contains('\r'),
        "a carriage return on stderr: {:?}",
        r.stderr
    );
    let lines: Vec<&str> = r.stderr.lines().collect();
    let show = || {
        // Long lines are cut for the failure message.
        r.stderr
            .lines()
            .map(|l| l.chars().take(300).collect::<String>())
            .collect::<Vec<_>>()
            .join("\n")
    };
    assert_eq!(
        lines.len(),
        3,
        "expected an error line, a source line and a caret line:\n{}",
        show()
    );
    assert_eq!(lines[0], head, "the error comes first:\n{}", show());
    let prefix = format!("lsgen: {}:", path.display());
    let rest = head
        .strip_prefix(&prefix)
        .unwrap_or_else(|| panic!("error does not name {}:\n{}", path.display(), show()));
    let (line, rest) = rest.split_once(':').expect("LINE:");
    let (col, rest) = rest.split_once(':').expect("COL:");
    let line: usize = line.parse().unwrap_or_else(|_| panic!("LINE: {}", show()));
    let col: usize = col.parse().unwrap_or_else(|_| panic!("COL: {}", show()));
    let message = rest
        .strip_prefix(" error: ")
        .unwrap_or_else(|| panic!("no ` error: `:\n{}", show()));
    for words in msg {
        assert!(
            message.contains(words),
            "message should contain {words:?}:\n{}",
            show()
        );
    }
    assert!(line >= 1 && col >= 1, "{}", show());
    if !at.is_empty() {
        assert!(
            at.contains(&(line, col)),
            "expected the error at {at:?}, got {line}:{col}:\n{}",
            show()
        );
    }
    let caret = lines[2];
    assert!(
        caret.ends_with('^')
            && caret[..caret.len() - 1]
                .chars()
                .all(|c| c == ' ' || c == '\t'),
        "third line should be blanks and a caret:\n{}",
        show()
    );
    let snippet = lines[1];
    let text = source_line(src, line)
        .unwrap_or_else(|| panic!("line {line} is past the end of the input:\n{}", show()));
    let core = snippet.strip_prefix("...").unwrap_or(snippet);
    let core = core.strip_suffix("...").unwrap_or(core);
    assert!(
        text.contains(core),
        "the second line is not (an excerpt of) source line {line}:\n{}",
        show()
    );
    let under_caret = chars_under_caret(snippet, &caret[..caret.len() - 1]);
    let at_col = text.chars().nth(col - 1);
    assert!(
        under_caret.contains(&at_col),
        "the caret is not under the character at {line}:{col}:\n{}",
        show()
    );
}

macro_rules! cases {
    ($( $(#[$attr:meta])* $name:ident => $case:expr; )*) => {
        $(
            #[test]
            $(#[$attr])*
            fn $name() {
                $case.check(stringify!($name));
            }
        )*
        /// Every case of the catalogue, by name.
        const CASES: &[&str] = &[$(stringify!($name)),*];
    };
}

const TEN_MB: usize = 10_000_000;

cases! {
    // --- comments, settings, structure -------------------------------------
    unterminated_comment_in_header =>
        err("productions:\nF -> F /* open\naxiom: F\n", 2, 8, "unterminated comment");
    unterminated_comment_in_axiom =>
        err("productions:\nF -> FF\naxiom: F /* open\nG\n", 3, 10, "unterminated comment");
    // Not a keyword: before `productions:` the line cannot start a setting.
    unknown_setting_before_productions =>
        err("derivation lenght: 3\nproductions:\nF -> FF\naxiom: F\n", 1, 1, "unexpected symbol `d`");
    // Among productions it reads as `derivationlenght : 3` (modules and a
    // condition) with the arrow missing at the end of the line.
    unknown_setting_parsed_as_production =>
        err("productions:\nF -> FF\nderivation lenght: 3\naxiom: F\n", 3, 21, "expected `->`");
    missing_axiom =>
        err("productions:\nF -> FF\n", 2, 8, "missing `axiom:`");
    missing_axiom_after_comment =>
        err("/* nothing */\n\n", 1, 14, "missing `axiom:`");
    empty_file => err("", 1, 1, "empty L-system");
    blank_file => err("\n  \n\n", 1, 1, "empty L-system");
    settings_after_productions =>
        err("productions:\nF -> F\nderivation length: 3\naxiom: F\n", 3, 1, "out of place");
    // (issue 11: `productions:` is group 0, and a group is declared once)
    productions_twice =>
        err("productions:\nF -> FF\nproductions:\nG -> H\naxiom: F\n", 3, 1, "group 0 is declared twice");
    homomorphism_before_productions =>
        err("homomorphism:\nF -> G\nproductions:\nF -> H\naxiom: F\n", 3, 1, "out of place");
    seed_twice => err("seed: 1\nseed: 2\naxiom: F\n", 2, 1, "set twice");
    derivation_length_fraction =>
        err("derivation length: 2.5\naxiom: F\n", 1, 20, "whole number");
    derivation_length_negative =>
        err("derivation length: -1\naxiom: F\n", 1, 20, "whole number");
    // 2^53 + 1 as digits: read exactly, not rounded to 2^53 (lsgen
    // 9d04726 derived 2^53 steps); the message quotes it as written.
    derivation_length_past_2_53 =>
        err("derivation length: 9007199254740993\naxiom: F\n", 1, 20, "to 2^53, not 9007199254740993");
    derivation_length_unknown_name =>
        err("derivation length: n\naxiom: F\n", 1, 20, "unknown identifier `n`");
    seed_fraction => err("seed: 3.5\naxiom: F\n", 1, 7, "whole number");
    duplicate_define => err("define: a = 1\ndefine: a = 2\naxiom: F\n", 2, 1, "defined twice");
    ignore_and_consider =>
        err("ignore: +\nconsider: F\naxiom: F\n", 2, 1, "cannot both be used");
    ignore_with_parameters => err("ignore: F(1)\naxiom: F\n", 1, 9, "without parameters");
    // A symbol's later module with parameters is still found where it is
    // (the line keeps each symbol once as it is read).
    ignore_with_parameters_later =>
        err("consider: F G F(1) G(2)\naxiom: F\n", 1, 15, "without parameters");

    // --- numbers -----------------------------------------------------------
    bad_number_trailing_e =>
        err("define: a = 1e\naxiom: F\n", 1, 14, "unexpected identifier `e`");
    // The message quotes the number as written, `.3`, not as read (`0.3`).
    bad_number_two_points =>
        err("define: a = 1.2.3\naxiom: F\n", 1, 16, "unexpected number");
    bad_number_in_axiom_trailing_e => err("axiom: F(1e)\n", 1, 11, "unexpected identifier `e`");
    bad_number_in_axiom_two_points => err("axiom: F(1.2.3)\n", 1, 13, "unexpected number");
    number_out_of_range_in_header =>
        err("define: a = 1e309\naxiom: F\n", 1, 13, "out of range");
    number_out_of_range_in_axiom => err("axiom: F(1e309)\n", 1, 10, "out of range");

    // --- parentheses -------------------------------------------------------
    unclosed_paren_in_successor =>
        err("productions:\nA -> B(1\naxiom: F\n", 2, 9, "unexpected end of line");
    extra_paren_in_successor =>
        err("productions:\nA -> B(1))\naxiom: F\n", 2, 10, "unexpected `)`");
    unclosed_paren_in_predecessor =>
        err("productions:\nA(x -> B\naxiom: F\n", 2, 5, "unexpected `->`");
    unclosed_paren_in_axiom =>
        err("productions:\nA -> B\naxiom: F(1\n", 3, 9, "never closed");
    extra_paren_in_axiom => err("axiom: F(1))\n", 1, 12, "`)` is reserved");
    unclosed_paren_in_multiline_axiom_parameters =>
        err("axiom: F(1,\n 2, 3 +)\n", 2, 8, "unexpected end of input");
    empty_parameter_in_axiom => err("axiom: F(1,)\n", 1, 12, "empty parameter");

    // --- reserved characters as axiom symbols ------------------------------
    reserved_rparen_in_axiom =>
        err("productions:\nA -> B\naxiom: FF)\n", 3, 10, "`)` is reserved");
    reserved_colon_in_axiom =>
        err("productions:\nA -> B\naxiom: FF:\n", 3, 10, "`:` is reserved");
    reserved_lt_in_axiom =>
        err("productions:\nA -> B\naxiom: FF<\n", 3, 10, "`<` is reserved");
    reserved_gt_in_axiom =>
        err("productions:\nA -> B\naxiom: FF>\n", 3, 10, "`>` is reserved");
    reserved_lparen_first_in_axiom => err("axiom: (F\n", 1, 8, "`(` is reserved");

    // --- productions -------------------------------------------------------
    missing_arrow => err("productions:\nF FF\naxiom: F\n", 2, 5, "expected `->`");
    stray_gt_in_successor =>
        err("productions:\nF -> F > G\naxiom: F\n", 2, 8, "unexpected `>`");
    stray_lt_in_successor =>
        err("productions:\nF -> F < G\naxiom: F\n", 2, 8, "unexpected `<`");
    predecessor_with_two_modules =>
        err("productions:\nA B -> C\naxiom: A\n", 2, 3, "a predecessor is one module");
    formal_parameter_not_a_name =>
        err("productions:\nA(1) -> B\naxiom: A\n", 2, 3, "formal parameter must be a name");
    parameter_bound_twice =>
        err("productions:\nA(x, x) -> B\naxiom: A\n", 2, 6, "bound twice");
    // At the second place in the text, as within one module (it pointed
    // at the first here, as the predecessor is bound first).
    parameter_bound_twice_across_a_context =>
        err("productions:\nA(x) < B(x) -> B\naxiom: A\n", 2, 10, "bound twice");
    brackets_cannot_be_rewritten =>
        err("productions:\n[ -> F\naxiom: F\n", 2, 1, "brackets cannot be rewritten");
    bracket_in_left_context =>
        err("productions:\nF [ < A -> B\naxiom: F\n", 2, 3, "left context cannot hold brackets");
    bracket_with_parameters_in_right_context =>
        err("productions:\nA > [(1)B -> C\naxiom: F\n", 2, 5, "bracket takes no parameters");

    // --- names, functions --------------------------------------------------
    undefined_identifier_in_condition =>
        err("productions:\nA(x) : y > 1 -> B\naxiom: A(1)\n", 2, 8, "unknown identifier `y`");
    condition_on_parameter_the_predecessor_lacks =>
        err("productions:\nA : x > 1 -> B\naxiom: A\n", 2, 5, "unknown identifier `x`");
    condition_on_context_parameter_missing =>
        err("productions:\nA < B(x) : y > 1 -> B\naxiom: A\n", 2, 12, "unknown identifier `y`");
    undefined_identifier_in_successor =>
        err("productions:\nA(x) -> B(y)\naxiom: A(1)\n", 2, 11, "unknown identifier `y`");
    undefined_identifier_in_probability =>
        err("productions:\nA(x) -> B : q\naxiom: A(1)\n", 2, 13, "unknown identifier `q`");
    // The successor comes before the probability on the line, so its
    // error is the one reported (the probability's came first while a
    // production was compiled only once read whole).
    undefined_identifiers_in_successor_and_probability =>
        err("productions:\nA(x) -> B(y) : q\naxiom: A(1)\n", 2, 11, "unknown identifier `y`");
    // Past the parser's first batches of successor modules (1024 each).
    undefined_identifier_deep_in_a_long_successor =>
        err(format!("productions:\nA(x) -> {}C(y)\naxiom: A(1)\n", "B".repeat(3000)), 2, 3011, "unknown identifier `y`");
    undefined_identifier_in_define =>
        err("define: a = b\ndefine: b = 1\naxiom: F\n", 1, 13, "unknown identifier `b`");
    undefined_identifier_in_axiom =>
        err("axiom: F(1,\n 2, q)\n", 2, 5, "unknown identifier `q`");
    unknown_function =>
        err("productions:\nA(x) -> B(foo(x))\naxiom: A(1)\n", 2, 11, "unknown function `foo`");
    wrong_arity_too_many =>
        err("productions:\nA(x) -> B(sin(x, 2))\naxiom: A(1)\n", 2, 11, "takes 1 argument, not 2");
    wrong_arity_too_few =>
        err("productions:\nA(x) -> B(atan2(x))\naxiom: A(1)\n", 2, 11, "takes 2 arguments, not 1");

    // --- probabilities -----------------------------------------------------
    negative_probability_constant =>
        err("productions:\nA -> B : -1\nA -> C : 1\naxiom: A\n", 2, 10, "cannot be negative");
    negative_probability_at_runtime =>
        err("productions:\nA(x) -> B : x\nA(x) -> C : 1\naxiom: A(-2)\n", 2, 13, "cannot be negative").also("-2").also("step 1");
    // Each weight finite, their sum not: every draw took the last one
    // (BBBB) without a word. Also with weights worked out at run time.
    probabilities_add_up_past_the_largest_number =>
        err("productions:\nA -> A : 1e308\nA -> B : 1e308\naxiom: AAAA\n", 2, 1, "add up to more than the largest number").also("step 1");
    probabilities_add_up_past_the_largest_number_at_runtime =>
        err("productions:\nA(x) -> A(x) : x\nA(x) -> B : x\naxiom: A(1e308)\n", 2, 1, "add up to more than the largest number").also("step 1");

    // --- arithmetic --------------------------------------------------------
    division_by_zero_in_step_3 =>
        err("derivation length: 5\nproductions:\nA(x) -> A(x-1) B(10/x)\naxiom: A(2)\n", 3, 18, "division by zero").also("step 3");
    division_by_zero_in_condition_in_step_3 =>
        err("derivation length: 4\nproductions:\nA(x) : 1/x > 0 -> A(x-1)\naxiom: A(2)\n", 3, 8, "division by zero").also("step 3");
    division_by_zero_with_context_in_step_3 =>
        err("derivation length: 4\nproductions:\nB(y) < A(x) : 1/(x-y) > 0 -> A(x-1)\naxiom: B(0) A(2)\n", 3, 15, "division by zero").also("step 3");
    division_by_zero_in_homomorphism =>
        err("derivation length: 2\nproductions:\nA(x) -> A(x-1)\nhomomorphism:\nA(x) -> F(1/x)\naxiom: A(2)\n", 5, 11, "division by zero").also("homomorphism");
    division_by_zero_constant =>
        err("productions:\nA -> B : 1\nA -> C : 1 / 0\naxiom: A\n", 3, 10, "division by zero");
    division_by_zero_in_probability =>
        err("productions:\nA(x) -> B : 1/x\nA(x) -> C : 1\naxiom: A(0)\n", 2, 13, "division by zero").also("step 1");
    exp_overflow_in_step_3 =>
        err("derivation length: 3\nproductions:\nA(x) -> A(x*10) B(exp(x))\naxiom: A(10)\n", 3, 19, "exp").also("step 3");
    log_of_zero_in_step_3 =>
        err("derivation length: 3\nproductions:\nA(x) -> A(x-1) B(log(x))\naxiom: A(2)\n", 3, 18, "log").also("step 3");
    power_not_a_number =>
        err("productions:\nA(x) -> B(x^(1/3))\naxiom: A(-8)\n", 2, 11, "not a number").also("step 1");
    division_by_zero_in_axiom => err("axiom: F(2, 1/0)\n", 1, 13, "division by zero");
    sqrt_of_negative_in_step_3 =>
        err("derivation length: 5\nproductions:\nA(x) -> A(x-1) B(sqrt(x))\naxiom: A(1)\n", 3, 18, "sqrt").also("step 3");
    sqrt_of_negative_constant =>
        err("define: a = sqrt(-1)\naxiom: F\n", 1, 13, "sqrt is undefined");
    overflow_at_runtime =>
        err("derivation length: 5\nproductions:\nA(x) -> A(x*1e300)\naxiom: A(10)\n", 3, 11, "overflow").also("step 2");
    overflow_constant =>
        err("define: a = 1e300 * 1e300\naxiom: F\n", 1, 13, "overflows");
    // Issue 9: seeds are read exactly; the depth-first expansion would meet
    // A's step-2 error before B's step-1 error.
    seed_above_u64 =>
        err("seed: 18446744073709551616\naxiom: F\n", 1, 7, "from 0 to 18446744073709551615");
    seed_computed_at_2_53_or_more => err("seed: 2^53+1\naxiom: F\n", 1, 7, "below 2^53");
    seed_from_a_random_constant =>
        err("define: R = ran(9)\nseed: R\naxiom: F\n", 2, 7, "cannot depend on random");
    earliest_steps_first_error =>
        err("derivation length: 2\nproductions:\nA(x) -> A(1/(x-1))\nB(x) -> B(1/x)\naxiom: A(2) B(0)\n", 4, 11, "division by zero").also("step 1");

    // --- brackets ----------------------------------------------------------
    // lsgen af84e48 reported this at 4:1, a line past the end of the file,
    // with an empty source line.
    unclosed_bracket_in_axiom =>
        err("productions:\nF -> FF\naxiom: F[F\n", 3, 9, "never closed").or_at(3, 11);
    unclosed_bracket_in_axiom_without_final_newline =>
        err("productions:\nF -> FF\naxiom: F[F", 3, 9, "never closed").or_at(3, 11);
    unopened_bracket_in_axiom =>
        err("productions:\nF -> FF\naxiom: F]F\n", 3, 9, "`]` without `[`");
    step_produces_unopened_bracket =>
        err("productions:\nA -> ]\naxiom: F A\n", 2, 1, "`]` without `[`").also("step 1");
    step_produces_unclosed_bracket =>
        err("productions:\nA -> [\naxiom: F A\n", 2, 1, "unbalanced brackets").also("`[`").also("step 1");
    step_3_produces_unclosed_bracket =>
        err("derivation length: 3\nproductions:\nA -> B\nB -> C\nC -> [\naxiom: F A\n", 5, 1, "unbalanced brackets").also("`[`").also("step 3");
    // A `]` produced inside a branch closes it early; lsgen af84e48 called
    // the extra `]` "a `[` left open" and blamed `X -> Y` on line 2.
    step_produces_unopened_bracket_inside_branch =>
        err("productions:\nX -> Y\nA -> ]\naxiom: [A]\n", 3, 1, "`]` without `[`");

    // --- encoding and odd characters ---------------------------------------
    invalid_utf8_in_header =>
        err(&b"productions:\nF -> F\xff\naxiom: F\n"[..], 2, 7, "invalid UTF-8");
    invalid_utf8_in_header_comment =>
        err(&b"/* \xff */\nproductions:\nF -> FF\naxiom: F\n"[..], 1, 4, "invalid UTF-8");
    invalid_utf8_in_axiom =>
        err(&b"productions:\nF -> FF\naxiom: F\xffF\n"[..], 3, 9, "invalid UTF-8");
    invalid_utf8_in_axiom_second_line =>
        err(&b"productions:\nF -> FF\naxiom: FF\n F\xc3(\n"[..], 4, 3, "invalid UTF-8");
    invalid_utf8_in_axiom_parameter =>
        err(&b"productions:\nF -> FF\naxiom: F(\xff)\n"[..], 3, 10, "invalid UTF-8");
    control_character_in_header =>
        err("productions:\nF -> F\u{1}F\naxiom: F\n", 2, 7, "control character");
    control_character_in_predecessor =>
        err("productions:\nF\u{2} -> FF\naxiom: F\n", 2, 2, "control character");
    control_character_in_axiom =>
        err("productions:\nF -> FF\naxiom: A\u{1}\n", 3, 9, "control character");
    nul_in_axiom => err("productions:\nF -> FF\naxiom: A\0\n", 3, 9, "control character");
    delete_in_axiom => err("productions:\nF -> FF\naxiom: A\u{7f}\n", 3, 9, "control character");
    // U+FEFF is skipped at the start of a file and of `--axiom` text: as
    // a module it would not read back, so it is none.
    byte_order_mark_in_successor =>
        err("productions:\nA -> \u{FEFF}B\naxiom: A\n", 2, 6, "U+FEFF (a byte-order mark");
    byte_order_mark_in_axiom =>
        err("productions:\nA -> B\naxiom: A\u{FEFF}\n", 3, 9, "cannot be a symbol");

    // --- columns and lines: tabs, CRLF, wide characters, comments ----------
    crlf_line_endings =>
        err("productions:\r\nF -> F>\r\naxiom: F\r\n", 2, 7, "unexpected `>`");
    crlf_line_endings_in_axiom =>
        err("productions:\r\nF -> FF\r\naxiom: F)\r\n", 3, 9, "`)` is reserved");
    columns_count_characters =>
        err("productions:\nΩ -> αβ>\naxiom: F\n", 2, 8, "unexpected `>`");
    tabs_in_header => err("productions:\n\tF -> F\t>\naxiom: F\n", 2, 9, "unexpected `>`");
    tabs_in_axiom => err("productions:\nF -> G\n\taxiom:\tF\t)\n", 3, 11, "`)` is reserved");
    shebang_line_counts =>
        err("#!/usr/bin/env lsgen\nproductions:\nF -> F>\naxiom: F\n", 3, 7, "unexpected `>`");
    axiom_inside_header_comment_is_skipped =>
        err("/* header\naxiom: not this\n*/\naxiom: X)\n", 4, 9, "`)` is reserved");
    axiom_lines_after_comments =>
        err("#!/bin/lsgen\naxiom: X /* a\nb\n*/ Y\n\n  Z )\n", 6, 5, "`)` is reserved");

    // --- arity limits ------------------------------------------------------
    too_many_parameters_in_axiom =>
        err(format!("productions:\nF -> FF\naxiom: A({})\n", vec!["1"; 256].join(",")), 3, 520, "at most 255 parameters");
    too_many_parameters_in_successor =>
        err(format!("productions:\nF -> G({})\naxiom: F\n", vec!["1"; 256].join(",")), 2, 6, "at most 255 parameters");
    too_many_parameters_in_predecessor =>
        err(format!("productions:\nF({}) -> G\naxiom: F\n",
            (0..256).map(|i| format!("x{i}")).collect::<Vec<_>>().join(",")), 2, 1, "at most 255 parameters");

    // --- issue 9: the reader -----------------------------------------------
    // (4) The header is checked as it is read: a NUL stops it at once, and
    // so does a header over 64 MiB = 2^26 bytes: 2^23 lines of 8 bytes fill
    // it, so the error is at the start of line 2^23 + 1 (lsgen 9bc7f68 read
    // on until memory ran out).
    nul_in_header_on_stdin => err(vec![0u8; 1 << 20], 1, 1, "NUL").on_stdin();
    nul_in_header_comment => err(&b"/* a\0 */\naxiom: F\n"[..], 1, 5, "NUL");
    header_over_64_mib =>
        err("F -> FF\n".repeat((1 << 23) + 1000), (1 << 23) + 1, 1, "too long");
    // (11) A comment before a keyword on its line (lsgen 9bc7f68: `1:9:
    // unexpected symbol 'd'`); the error below is in the axiom, so the
    // keywords were read.
    comment_before_keywords =>
        err("/* c */ derivation length: 1\n/* c */ productions:\nF -> FF\naxiom: F)\n", 4, 9, "`)` is reserved");
    // (12) `axiom:` after a comment on its line, and after a comment that
    // ends on it.
    comment_before_axiom =>
        err("productions:\nF -> FF\n/* c */ axiom: F)\n", 3, 17, "`)` is reserved");
    comment_ending_on_the_axiom_line =>
        err("productions:\nF -> FF\n/* a\nb */ axiom: F)\n", 4, 14, "`)` is reserved");
    // (13) A `,` or `)` in a comment in an axiom parameter list separates
    // nothing: the error is the one after it.
    comma_and_paren_in_comment_in_axiom_parameters =>
        err("axiom: F(1 /* a, b) */)G F(1, /* a, b */ 2) F(x)\n", 1, 47, "unknown identifier `x`");
    // (14) `(` attaches to the symbol after a comment or any blank, at
    // every place in the axiom (lsgen 9bc7f68: "`(` is reserved" here).
    parameters_after_comment_and_blanks_in_axiom =>
        err("axiom: GF/* c */(1) GF\u{a0}(2) GF\u{b}(3) GF(q)\n", 1, 38, "unknown identifier `q`");
    // (15) A multi-line parameter list: the error on the line it is on
    // (lsgen 9bc7f68 said 2:9).
    multi_line_axiom_parameter =>
        err("axiom:\nF(1 +\n  x)\n", 3, 3, "unknown identifier `x`");
    // (16) CRLF: an error at the end of a line is just after its last
    // character (lsgen 9bc7f68: 2:10), and no `\r` is printed.
    crlf_error_at_end_of_line =>
        err("productions:\r\nA -> B(1\r\naxiom: F\r\n", 2, 9, "unexpected end of line");
    crlf_invalid_utf8_in_header_comment =>
        err(&b"/* \xff */\r\nproductions:\r\nF -> FF\r\naxiom: F\r\n"[..], 1, 4, "invalid UTF-8");
    // (17) The caret under the spot after wide and combining characters:
    // 漢字 and 😀 take two columns each, e + U+0301 one.
    caret_after_wide_characters =>
        err("productions:\n漢字 -> F>\naxiom: F\n", 2, 8, "unexpected `>`");
    caret_after_emoji_and_combining_mark =>
        err("productions:\n😀😀e\u{301} -> F>\naxiom: F\n", 2, 10, "unexpected `>`");
    caret_after_combining_marks =>
        err("productions:\ne\u{301}e\u{301} -> F>\naxiom: F\n", 2, 10, "unexpected `>`");
    // (19) Misleading messages.
    chained_comparison_in_condition =>
        err("productions:\nA(x) : 1 < x < 3 -> B\naxiom: A(2)\n", 2, 14, "comparisons do not chain");
    six_thousand_parameters_in_successor =>
        err(format!("productions:\nF -> G({})\naxiom: F\n", vec!["1"; 6000].join(",")), 2, 6, "at most 255 parameters");
    // (23) Invalid UTF-8 in an axiom comment is refused as in the header.
    invalid_utf8_in_axiom_comment =>
        err(&b"productions:\nF -> FF\naxiom: F /* \xff */\n"[..], 3, 13, "invalid UTF-8");
    nul_in_axiom_comment =>
        err(&b"productions:\nF -> FF\naxiom: F /* \0 */\n"[..], 3, 13, "NUL");

    // --- `--axiom FILE` ----------------------------------------------------
    axiom_file_with_reserved_character =>
        err("productions:\nF -> FF\naxiom: F\n", 1, 4, "`)` is reserved").axiom_file("F F)\n");
    axiom_file_with_unclosed_paren =>
        err("productions:\nF -> FF\naxiom: F\n", 2, 4, "never closed").axiom_file("F\nF F(1,\n");

    // --- standard input ----------------------------------------------------
    error_in_standard_input =>
        err("productions:\nF -> FF\naxiom: F)\n", 3, 9, "`)` is reserved").on_stdin();
    error_in_axiom_from_standard_input =>
        err("productions:\nF -> FF\naxiom: F\n", 1, 4, "never closed").axiom_from_stdin("F F(1,\n");

    // --- huge lines --------------------------------------------------------
    // 10 MB axiom line, error at its very end (lsgen af84e48 quoted it as
    // `......FFF)`, with a doubled ellipsis).
    long_axiom_line_error_at_end =>
        err(format!("productions:\nF -> FF\naxiom: {})\n", "F".repeat(TEN_MB)), 3, TEN_MB + 8, "`)` is reserved");
    long_header_line_error_at_end =>
        err(format!("productions:\nF -> F /* {} */ >\naxiom: F\n", "x".repeat(TEN_MB)), 2, TEN_MB + 15, "unexpected `>`");
    long_header_expression =>
        err_or_ok(format!("define: x = {}1\naxiom: F(x)\n", "1+".repeat(TEN_MB / 2)), "", "F(5000001)\n");
    #[ignore = "slow: a 10 MB successor of 10^7 modules takes ~6 s and 500 MB in a debug build"]
    long_header_successor_line_error_at_end =>
        err(format!("productions:\nF -> {}>\naxiom: F\n", "F".repeat(TEN_MB)), 2, TEN_MB + 6, "unexpected `>`");
    // An unclosed `(` found far behind the read position (lsgen af84e48
    // quoted the text near the read position, the caret under a `1`).
    unclosed_paren_far_back_in_axiom =>
        err(format!("axiom: F({}\n", "1".repeat(200_000)), 1, 9, "");
    // An unterminated comment reported at its start, far behind the read
    // position (lsgen 9855045 quoted `(...`, not in the input, or the
    // comment's parameter list from its `(`, with the caret under column 1
    // or the `(`).
    unterminated_comment_far_back_in_axiom =>
        err(format!("axiom: F /*{}", "a".repeat(200_000)), 1, 10, "unterminated comment").on_stdin();
    unterminated_comment_far_back_in_axiom_file =>
        err(format!("axiom:\nFFF\n{} /*{}", "G".repeat(1000), "a".repeat(300_000)), 3, 1002, "unterminated comment");
    unterminated_comment_far_back_in_parameters =>
        err(format!("axiom: F(1 /* {}", "a".repeat(300_000)), 1, 12, "unterminated comment").on_stdin();
    unterminated_comment_far_back_in_parameters_file =>
        err(format!("axiom:\nFFF\n  G(1, 2 /* {}", "a".repeat(300_000)), 3, 10, "unterminated comment");

    // --- deep nesting: a clear error or the right result, never a crash ----
    deep_parens_in_define =>
        err_or_ok(format!("define: x = {}1{}\naxiom: F(x)\n", "(".repeat(100_000), ")".repeat(100_000)), "", "F(1)\n");
    deep_parens_in_successor =>
        err_or_ok(format!("productions:\nA(y) -> B({}y{})\naxiom: A(1)\n", "(".repeat(100_000), ")".repeat(100_000)), "", "B(1)\n");
    deep_unclosed_parens_in_define =>
        err(format!("define: x = {}1\naxiom: F(x)\n", "(".repeat(100_000)), 0, 0, "").or_any();
    // (lsgen af84e48 quoted `...)))...` with the caret under a `)`.)
    deep_parens_in_axiom =>
        err_or_ok(format!("axiom: F({}1{})\n", "(".repeat(100_000), ")".repeat(100_000)), "", "F(1)\n");
    deep_unary_minus_chain =>
        err_or_ok(format!("define: x = {}1\naxiom: F(x)\n", "-".repeat(100_000)), "", "F(1)\n");
    long_sum_in_successor =>
        err_or_ok(format!("productions:\nA(y) -> B({}y)\naxiom: A(1)\n", "y+".repeat(100_000)), "", "B(100001)\n");

    // --- view: lines (lsgen-turtle's settings, checked by lsgen) -----------
    view_unknown_setting =>
        err("view: angel = 25\nproductions:\nF -> FF\naxiom: F\n", 1, 7, "unknown view setting `angel`");
    view_bad_number =>
        err("productions:\n  view: step = 1x /* c */\nF -> FF\naxiom: F\n", 2, 16, "`1x` is not a number");
    view_bad_colour =>
        err("view: palette = #2e7d32 green\naxiom: F\n", 1, 25, "not a colour");
    // --- keyword lines with comments and Unicode blanks between their words:
    // still keyword lines, their errors at their place (lsgen 9b99c7d took
    // spaces and tabs only there, and refused or misplaced every one) ---
    keyword_line_derivation_length_after_a_blank =>
        err("derivation\u{a0}length: -1\naxiom: F\n", 1, 20, "the derivation length must be a whole number");
    keyword_line_derivation_length_after_a_comment =>
        err("derivation /* c */ length: 2.5\naxiom: F\n", 1, 28, "the derivation length must be a whole number");
    keyword_line_groups_not_a_number_after_a_comment =>
        err("groups: 1 /* 漢字 */ x\nproductions 1:\nL -> F\naxiom: L\n", 1, 20, "`groups:` takes whole group numbers");
    keyword_line_groups_out_of_range_after_blanks =>
        err("groups:\u{a0}1\u{a0}70000\nproductions 1:\nL -> F\naxiom: L\n", 1, 11, "a production group is a whole number from 0 to 65535");
    keyword_line_production_group_after_a_comment =>
        err("productions\u{a0}/* c */ 1.5:\nL -> F\naxiom: L\n", 1, 21, "a production group is a whole number from 0 to 65535");
    keyword_line_decomposition_group_after_a_comment =>
        err("decomposition /* c */ 1:\nL -> F\naxiom: L\n", 1, 23, "decomposition has no groups");
    keyword_line_warnings_typo_after_a_comment =>
        err("homomorphism:\u{a0}/* c */ no maybe\nL -> F\naxiom: L\n", 1, 23, "expected `warnings` or `no warnings` after `homomorphism:`");
    keyword_line_maximum_depth_after_blanks =>
        err("homomorphism:\nmaximum\u{a0}/* c */\u{a0}depth: 0\nL -> F\naxiom: L\n", 2, 24, "maximum depth must be a whole number from 1 to 10000");
    keyword_line_view_setting_after_comments =>
        err("view: width /* c */ increment = /* 漢 */ 1x\naxiom: F\n", 1, 41, "`1x` is not a number");
    // --- issue 11: structural rewriting (docs/structural.md, section 9) ----
    decomposition_left_context =>
        err("productions:\nA -> AL\ndecomposition:\nA < L -> X\naxiom: A\n", 4, 3, "decomposition production has no context");
    decomposition_right_context =>
        err("productions:\nA -> AL\ndecomposition:\nL > A -> X\naxiom: A\n", 4, 3, "decomposition is context-free");
    decomposition_after_homomorphism =>
        err("productions:\nA -> AL\nhomomorphism:\nL -> F\ndecomposition:\nL -> X\naxiom: A\n", 5, 1, "comes after the productions and before `homomorphism:`");
    decomposition_twice =>
        err("productions:\nA -> AL\ndecomposition:\nL -> F\ndecomposition:\nL -> X\naxiom: A\n", 5, 1, "second `decomposition:` section");
    homomorphism_twice =>
        err("productions:\nA -> AL\nhomomorphism:\nL -> F\nhomomorphism:\nL -> X\naxiom: A\n", 5, 1, "second `homomorphism:` section");
    maximum_depth_negative =>
        err("decomposition:\nmaximum depth: -1\nL -> F\naxiom: L\n", 2, 16, "maximum depth must be a whole number from 1 to 10000");
    maximum_depth_zero =>
        err("homomorphism:\nmaximum depth: 0\nL -> F\naxiom: L\n", 2, 16, "whole number from 1 to 10000");
    maximum_depth_fraction =>
        err("decomposition:\nmaximum depth: 2.5\nL -> F\naxiom: L\n", 2, 16, "whole number from 1 to 10000");
    maximum_depth_too_large =>
        err("decomposition:\nmaximum depth: 10001\nL -> F\naxiom: L\n", 2, 16, "whole number from 1 to 10000");
    maximum_depth_twice =>
        err("decomposition:\nmaximum depth: 2\nmaximum depth: 3\nL -> F\naxiom: L\n", 3, 1, "comes once, among the settings right after the section keyword");
    maximum_depth_after_production =>
        err("homomorphism:\nL -> F\nmaximum depth: 3\naxiom: L\n", 3, 1, "comes once, among the settings right after the section keyword");
    maximum_depth_among_settings =>
        err("maximum depth: 3\nproductions:\nL -> F\naxiom: L\n", 1, 1, "belongs to `decomposition:` or `homomorphism:`");
    maximum_depth_in_productions =>
        err("productions:\nmaximum depth: 3\nL -> F\naxiom: L\n", 2, 1, "belongs to `decomposition:` or `homomorphism:`");
    seed_in_decomposition =>
        err("decomposition:\nseed: 3\nL -> F\naxiom: L\n", 2, 1, "decomposition uses the main random generator");
    homomorphism_warnings_typo =>
        err("homomorphism: maybe\nL -> F\naxiom: L\n", 1, 15, "expected `warnings` or `no warnings` after `homomorphism:`");
    production_group_negative =>
        err("productions -1:\nL -> F\naxiom: L\n", 1, 13, "a production group is a whole number from 0 to 65535");
    production_group_fraction =>
        err("productions 1.5:\nL -> F\naxiom: L\n", 1, 13, "whole number from 0 to 65535");
    production_group_name =>
        err("productions x:\nL -> F\naxiom: L\n", 1, 13, "whole number from 0 to 65535");
    production_group_too_large =>
        err("productions 70000:\nL -> F\naxiom: L\n", 1, 13, "whole number from 0 to 65535");
    production_group_twice =>
        err("groups: 2\nproductions 2:\nL -> F\nproductions 2:\nL -> G\naxiom: L\n", 4, 1, "group 2 is declared twice");
    production_group_zero_twice =>
        err("productions:\nL -> F\nproductions 0:\nL -> G\naxiom: L\n", 3, 1, "group 0 is declared twice");
    decomposition_group =>
        err("decomposition 1:\nL -> F\naxiom: L\n", 1, 15, "decomposition has no groups");
    homomorphism_group =>
        err("homomorphism 1:\nL -> F\naxiom: L\n", 1, 14, "homomorphism has no groups");
    groups_unknown_group =>
        err("groups: 1 3\nproductions 1:\nL -> F\naxiom: L\n", 1, 11, "unknown group 3: there is no `productions 3:` section");
    groups_empty =>
        err("groups:\nproductions:\nL -> F\naxiom: L\n", 1, 1, "`groups:` takes whole group numbers separated by blanks");
    groups_not_a_number =>
        err("groups: 1 x\nproductions 1:\nL -> F\naxiom: L\n", 1, 11, "`groups:` takes whole group numbers");
    groups_and_group =>
        err("groups: 1\ngroup: 1\nproductions 1:\nL -> F\naxiom: L\n", 2, 1, "use either `groups:` or `group:`, not both");
    group_with_ran =>
        err("group: ran(3)\nproductions 1:\nL -> F\naxiom: L\n", 1, 8, "`group:` cannot use ran or nran");
    group_never_used =>
        err("productions 1:\nL -> F\naxiom: L\n", 1, 1, "group 1 is never used");
    group_expression_gives_undeclared_group =>
        err("derivation length: 3\ngroup: step\nproductions 1:\nL -> LF\naxiom: L\n", 2, 8, "group: gives 2 in step 2, but there is no `productions 2:` section");
    group_expression_gives_fraction =>
        err("derivation length: 3\ngroup: step / 2\nproductions 1:\nL -> LF\naxiom: L\n", 2, 8, "group: gives 0.5 in step 1, not a group number");
    decomposition_unbalanced =>
        err("productions:\nX -> XL\ndecomposition:\nL -> [F\naxiom: X\n", 4, 1, "a decomposition successor must balance its brackets");
    deep_homomorphism_unbalanced =>
        err("homomorphism:\nmaximum depth: 2\nL -> F]\naxiom: L\n", 3, 1, "a homomorphism successor must balance its brackets");
    step_in_define =>
        err("define: x = step\naxiom: F(x)\n", 1, 13, "unknown identifier `step`");
    step_in_axiom =>
        err("axiom: F(step)\n", 1, 10, "`step`");

    // --- the cpfg dialect (issue 12): tests/cpfg/refused/, each construct
    // named with its reason; detected by the first statement `Lsystem:` ---
    cpfg_refused_array =>
        err(include_str!("cpfg/refused/array.l"), 5, 6, "`a` is not an array of `define:`");
    cpfg_refused_at_s =>
        err(include_str!("cpfg/refused/at_s.l"), 5, 7, "`@S` (a surface");
    cpfg_refused_atan2 =>
        err(include_str!("cpfg/refused/atan2.l"), 5, 12, "`atan2` is reserved in cpfg");
    cpfg_refused_curve =>
        err(include_str!("cpfg/refused/curve.l"), 5, 12, "`curveX` needs the model's curves");
    cpfg_refused_duplicate_formal =>
        err(include_str!("cpfg/refused/duplicate_formal.l"), 5, 10, "formal parameter `x` is named twice");
    cpfg_refused_environment =>
        err(include_str!("cpfg/refused/environment.l"), 4, 8, "`?E` (communication with an environment program)");
    cpfg_refused_exponent =>
        err(include_str!("cpfg/refused/exponent.l"), 4, 10, "a dot in an exponent literal");
    cpfg_refused_func =>
        err(include_str!("cpfg/refused/func.l"), 5, 12, "`func` needs the model's function files");
    cpfg_refused_no_endlsystem =>
        err(include_str!("cpfg/refused/no_endlsystem.l"), 5, 8, "missing `endlsystem`");
    cpfg_refused_object_production =>
        err(include_str!("cpfg/refused/object_production.l"), 5, 3, "`-o>` (an object production");
    cpfg_refused_query_p =>
        err(include_str!("cpfg/refused/query_p.l"), 5, 8, "needs cpfg's view file: give it with --cpfg-view FILE.v");
    cpfg_refused_remainder_zero =>
        err(include_str!("cpfg/refused/remainder_zero.l"), 5, 16, "remainder by zero");
    cpfg_refused_ring =>
        err(include_str!("cpfg/refused/ring.l"), 3, 1, "`ring lsystem` is not supported");
    cpfg_refused_right_context_ends_in_skip =>
        err(include_str!("cpfg/refused/right_context_ends_in_skip.l"), 6, 6, "a right context cannot end with `=`");
    cpfg_refused_sublsystem =>
        err(include_str!("cpfg/refused/sublsystem.l"), 5, 7, "`?(id,s)` (a sub-L-system call)");
    cpfg_refused_two_lsystems =>
        err(include_str!("cpfg/refused/two_lsystems.l"), 7, 1, "several L-systems in one file");
    cpfg_refused_vv =>
        err(include_str!("cpfg/refused/vv.l"), 5, 12, "`vvXmin` is not supported");
    cpfg_setting_after_axiom =>
        err("Lsystem: 1\nAxiom: A\nderivation length: 2\nA --> B\nendlsystem\n", 3, 1, "unexpected `derivation length:`");
    cpfg_missing_arrow =>
        err("Lsystem: 1\nAxiom: A\nA B\nendlsystem\n", 3, 4, "expected");
    cpfg_unclosed_parameters =>
        err("Lsystem: 1\nAxiom: A(1\nendlsystem\n", 2, 11, "unexpected end of line");
    cpfg_star_predecessor =>
        err("Lsystem: 1\nAxiom: A\n* --> B\nendlsystem\n", 3, 1, "the strict predecessor cannot be `*`");
    cpfg_unknown_function =>
        err("Lsystem: 1\nAxiom: A(1)\nA(x) --> A(min(x, 2))\nendlsystem\n", 3, 12, "unknown function `min`");
    // cpfg's statement blocks (issue 12, the runtime)
    cpfg_runaway_while =>
        err("Lsystem: 1\nderivation length: 1\nStart: {i = 0; while (i < 1) {j = 1;}}\nAxiom: A\nendlsystem\n", 3, 16, "the loops of this block ran 10000000 times in one run of it: lsgen stops this `while` (cpfg would hang)");
    cpfg_runaway_do_while =>
        err("Lsystem: 1\nderivation length: 1\nAxiom: A\nA : {do {k = 1;} while (1);} * --> B\nendlsystem\n", 4, 6, "ran 10000000 times in one run of it: lsgen stops this `do … while`");
    // Nested loops share the block's budget: 9 million times 9 million
    // iterations ran for days, each loop under its own limit. Stopped at
    // the inner loop, the one running when the 10^7th iteration comes.
    cpfg_runaway_nested_loops =>
        err("Lsystem: 1\nderivation length: 1\nStart: {i = 0; while (i < 9000000) {i = i + 1; j = 0; while (j < 9000000) {j = j + 1;}}}\nAxiom: A\nendlsystem\n", 3, 55, "ran 10000000 times in one run of it: lsgen stops this `while`");
    cpfg_printf_values =>
        err("Lsystem: 1\nEnd: {printf(\"%g %g\\n\", 1);}\nAxiom: A\nendlsystem\n", 2, 7, "printf: the format takes 2 values, 1 given");
    cpfg_printf_conversion =>
        err("Lsystem: 1\nEnd: {printf(\"%s\\n\", 1);}\nAxiom: A\nendlsystem\n", 2, 7, "printf: `%s` is not a conversion lsgen prints");
}

impl Case {
    /// Any position (the caret must still be under the right character).
    fn or_any(mut self) -> Case {
        self.at.clear();
        self
    }
}

#[test]
fn catalogue_has_at_least_45_cases() {
    assert!(CASES.len() >= 45, "only {} cases", CASES.len());
}

/// Every golden file belongs to a case of the catalogue (a renamed or
/// removed case leaves none behind), and the failing cases have one.
#[test]
fn golden_files_match_the_catalogue() {
    let dir = Path::new(common::ROOT).join("tests/golden/bad_input");
    let names = listing(&dir);
    for n in &names {
        let case = n
            .strip_suffix(".stderr")
            .unwrap_or_else(|| panic!("tests/golden/bad_input/{n}: not NAME.stderr"));
        assert!(
            CASES.contains(&case),
            "tests/golden/bad_input/{n}: no such case"
        );
    }
    assert!(
        names.len() + 10 >= CASES.len(),
        "only {} golden files for {} cases",
        names.len(),
        CASES.len()
    );
}

/// A valid file that lsgen must accept: the `axiom:` line is found even when
/// the bytes after the keyword are multi-byte characters.
/// (lsgen af84e48 rejected it: `unexpected symbol `a`` at 1:1, because
/// input::split_header decoded a 16-byte probe ending inside a character.)
#[test]
fn axiom_line_with_multibyte_symbols_is_accepted() {
    let dir = tempdir();
    let input = dir.path().join("in.ls");
    std::fs::write(&input, "productions:\nα -> β\naxiom: ααααα\n").unwrap();
    let r = run(lsgen().arg(&input));
    r.assert_no_crash();
    assert_eq!(r.code(), Some(0), "stderr:\n{}", r.stderr);
    assert_eq!(String::from_utf8_lossy(&r.stdout), "βββββ\n");
}

/// The same file with one character fewer is accepted (the probe then ends
/// on a character boundary): a control for the case above.
#[test]
fn axiom_line_with_four_multibyte_symbols_is_accepted() {
    let dir = tempdir();
    let input = dir.path().join("in.ls");
    std::fs::write(&input, "productions:\nα -> β\naxiom: αααα\n").unwrap();
    let r = run(lsgen().arg(&input));
    r.assert_no_crash();
    assert_eq!(r.code(), Some(0), "stderr:\n{}", r.stderr);
    assert_eq!(String::from_utf8_lossy(&r.stdout), "ββββ\n");
}

/// Usage errors exit with status 2, create nothing, and do not panic.
#[test]
fn usage_errors_exit_2() {
    let dir = tempdir();
    let d = dir.path();
    let input = d.join("in.ls");
    std::fs::write(&input, "productions:\nF -> FF\naxiom: F\n").unwrap();
    let out = d.join("out.txt");
    let bad: &[&[&str]] = &[
        &["--no-such-flag"],
        &["-n", "many"],
        &["-n", "-3"],
        &["--max-length", "12parsecs"],
        &["--max-length", "99999999999999999999TB"],
        &["--seed"],
    ];
    for args in bad {
        let r = run(lsgen().arg(&input).arg("-o").arg(&out).args(*args));
        r.assert_no_crash();
        assert_eq!(r.code(), Some(2), "{args:?}: stderr:\n{}", r.stderr);
        assert!(!r.stderr.is_empty(), "{args:?}: no message");
    }
    // Both the L-system and the axiom from standard input.
    let r = run(lsgen().args(["-", "--axiom", "-", "-o"]).arg(&out));
    r.assert_no_crash();
    assert_eq!(r.code(), Some(2), "stderr:\n{}", r.stderr);
    assert!(r.stderr.starts_with("lsgen: "), "stderr:\n{}", r.stderr);
    assert!(!out.exists());
    let names = listing(d);
    assert_eq!(names.len(), 1, "{names:?}");
}
