//! A deterministic fuzz smoke test: a few thousand inputs made with a
//! fixed-seed PRNG (random bytes, token soup, mutations of `examples/*.ls`)
//! go through the same two harnesses as the cargo-fuzz targets in `fuzz/`
//! (`parse`: header + compile + expression; `derive`: a whole derivation
//! with small limits). No input may panic; every error must render as
//! `lsgen: ... error: ...`. Every file in `tests/fuzz_regressions/` (crash
//! reproducers found by `fuzz/run.sh`) is replayed through both harnesses.

use lsgen::engine::Limits;
use std::panic::{self, AssertUnwindSafe};
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

const ROOT: &str = env!("CARGO_MANIFEST_DIR");

/// How many generated inputs.
const CASES: usize = 5000;
/// Fixed seed: the same inputs on every run.
const SEED: u64 = 0x6c73_6765_6e5f_667a;
/// Same caps as the `derive` fuzz target.
const LIMITS: Limits = Limits {
    modules: 20_000,
    bytes: 200_000,
};
/// At least this many of the generated inputs must derive without error
/// (1,111 of 5,000 when this was written): a generator that makes only
/// broken inputs tests the error paths alone.
const MIN_DERIVED: usize = 800;
/// At least this many reproducers in tests/fuzz_regressions/.
const MIN_REGRESSIONS: usize = 30;
/// No single input may take this long (a hang, not slowness).
const SLOW: Duration = Duration::from_secs(5);

/// Tokens of the language, as in `fuzz/ls.dict`.
const TOKENS: &[&str] = &[
    "productions:",
    "axiom:",
    "define:",
    "ignore:",
    "consider:",
    "homomorphism:",
    "derivation length:",
    "seed:",
    "\nproductions:\n",
    "\naxiom:\n",
    "\nhomomorphism:\n",
    "->",
    "-->",
    "<",
    ">",
    ":",
    ",",
    "(",
    ")",
    "[",
    "]",
    "\n",
    "\r\n",
    "/*",
    "*/",
    "/* c */",
    "<=",
    ">=",
    "==",
    "!=",
    "=",
    "&&",
    "||",
    "!",
    "+",
    "-",
    "*",
    "/",
    "^",
    "0",
    "1",
    "0.5",
    ".5",
    "1e308",
    "1e-9",
    "18446744073709551616",
    "4294967296",
    "ran(",
    "nran(",
    "sin(",
    "sqrt(",
    "log(",
    "exp(",
    "floor(",
    "min(",
    "max(",
    "F",
    "f",
    "A",
    "B",
    "x",
    "A(x,y)",
    "F(x)",
    "F[+F]F[-F]F",
    ": x > 1",
    ": 0.5",
    "A < B > C",
    "é",
    "\t",
    " ",
];

/// splitmix64: small, fixed, good enough to pick mutations.
struct Rng(u64);

impl Rng {
    fn next(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9e37_79b9_7f4a_7c15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
        z ^ (z >> 31)
    }
    /// Uniform in `0..n` (n > 0).
    fn below(&mut self, n: usize) -> usize {
        (self.next() % n as u64) as usize
    }
    fn pick<'a, T>(&mut self, v: &'a [T]) -> &'a T {
        &v[self.below(v.len())]
    }
}

fn examples() -> Vec<Vec<u8>> {
    let mut paths: Vec<PathBuf> = std::fs::read_dir(Path::new(ROOT).join("examples"))
        .expect("examples/")
        .map(|e| e.expect("examples/ entry").path())
        .filter(|p| p.extension().is_some_and(|x| x == "ls"))
        .collect();
    paths.sort();
    assert!(!paths.is_empty(), "no examples/*.ls");
    paths
        .iter()
        .map(|p| std::fs::read(p).expect("read example"))
        .collect()
}

/// A byte the mutator likes: mostly the language's ASCII, sometimes any.
fn some_byte(r: &mut Rng) -> u8 {
    const ASCII: &[u8] = b"FfAB+-[]()<>:,.*/^=!&|0123456789xyz \n\t#";
    if r.below(4) == 0 {
        r.next() as u8
    } else {
        *r.pick(ASCII)
    }
}

/// Apply one random mutation to `v`.
fn mutate(r: &mut Rng, v: &mut Vec<u8>, pool: &[Vec<u8>]) {
    let at = |r: &mut Rng, v: &Vec<u8>| r.below(v.len() + 1);
    match r.below(8) {
        // Flip one bit.
        0 if !v.is_empty() => {
            let i = r.below(v.len());
            v[i] ^= 1 << r.below(8);
        }
        // Replace a byte.
        1 if !v.is_empty() => {
            let i = r.below(v.len());
            v[i] = some_byte(r);
        }
        // Insert a token (sometimes several times over: nesting).
        2 | 3 => {
            let i = at(r, v);
            let tok = r.pick(TOKENS).as_bytes();
            let times = if r.below(8) == 0 { 1 + r.below(64) } else { 1 };
            for _ in 0..times {
                v.splice(i..i, tok.iter().copied());
            }
        }
        // Delete a range.
        4 if !v.is_empty() => {
            let i = r.below(v.len());
            let n = 1 + r.below(16.min(v.len() - i));
            v.drain(i..i + n);
        }
        // Truncate.
        5 => {
            let i = at(r, v);
            v.truncate(i);
        }
        // Duplicate a line.
        6 => {
            let lines: Vec<&[u8]> = v.split_inclusive(|&b| b == b'\n').collect();
            if !lines.is_empty() {
                let k = r.below(lines.len());
                let mut out = Vec::with_capacity(v.len() * 2);
                for (j, l) in lines.iter().enumerate() {
                    out.extend_from_slice(l);
                    if j == k {
                        out.extend_from_slice(l);
                        if !l.ends_with(b"\n") {
                            out.push(b'\n');
                            out.extend_from_slice(l);
                        }
                    }
                }
                *v = out;
            }
        }
        // Splice in a line of another example.
        _ => {
            let other = r.pick(pool);
            let lines: Vec<&[u8]> = other.split_inclusive(|&b| b == b'\n').collect();
            if !lines.is_empty() {
                let line = *r.pick(&lines);
                let i = at(r, v);
                v.splice(i..i, line.iter().copied());
            }
        }
    }
}

/// One generated input.
fn generate(r: &mut Rng, pool: &[Vec<u8>]) -> Vec<u8> {
    match r.below(10) {
        // Random bytes.
        0 => (0..r.below(200)).map(|_| some_byte(r)).collect(),
        // Token soup, sometimes behind a plausible start.
        1 | 2 => {
            let mut v = Vec::new();
            if r.below(2) == 0 {
                v.extend_from_slice(b"productions:\n");
            }
            for _ in 0..r.below(60) {
                v.extend_from_slice(r.pick(TOKENS).as_bytes());
            }
            if r.below(2) == 0 {
                v.extend_from_slice(b"\naxiom:\nF\n");
            }
            v
        }
        // A mutated example: mostly one or two mutations, up to six.
        _ => {
            let mut v = r.pick(pool).clone();
            let n = if r.below(2) == 0 { 1 } else { 1 + r.below(6) };
            for _ in 0..n {
                mutate(r, &mut v, pool);
            }
            v
        }
    }
}

fn check_rendered(shown: &str, input: &[u8]) {
    assert!(
        // The library names no program (`lsgen: ` is the binary's).
        !shown.starts_with("lsgen: ") && shown.contains("error: ") && shown.ends_with('\n'),
        "badly rendered error {shown:?} for input {:?}",
        String::from_utf8_lossy(input)
    );
}

/// The `parse` fuzz target, plus error rendering through `locate`.
fn parse_target(data: &[u8]) {
    let Ok(text) = std::str::from_utf8(data) else {
        return;
    };
    let header = lsgen::parse::parse_header(text);
    let compiled = header.map(|h| lsgen::rules::compile(&h).map(|_| ()));
    if let Err(e) | Ok(Err(e)) = compiled {
        let shown = lsgen::parse::locate("<input>", text, e).to_string();
        check_rendered(&shown, data);
    }
    let _ = lsgen::parse::parse_expr(text);
}

/// `derive_bytes` with the given settings; only the error's rendering is
/// checked. Did it derive?
fn derive(src: &[u8], steps: u64, seed: Option<u64>) -> bool {
    match lsgen::derive_bytes(src, Some(steps), seed, LIMITS) {
        Ok(_) => true,
        Err(e) => {
            check_rendered(&e.to_string(), src);
            false
        }
    }
}

/// The `derive` fuzz target: the first byte chooses steps and seed.
fn derive_target(data: &[u8]) -> bool {
    let Some((&ctl, src)) = data.split_first() else {
        return false;
    };
    let seed = if ctl & 8 != 0 {
        None
    } else {
        Some(u64::from(ctl >> 4))
    };
    derive(src, u64::from(ctl & 7) % 5, seed)
}

/// Run `f`, turning a panic into an error message naming the input.
fn guarded(what: &str, input: &[u8], f: impl FnOnce()) -> Result<(), String> {
    panic::catch_unwind(AssertUnwindSafe(f)).map_err(|p| {
        let msg = p
            .downcast_ref::<&str>()
            .map(|s| s.to_string())
            .or_else(|| p.downcast_ref::<String>().cloned())
            .unwrap_or_default();
        format!(
            "{what}: panic `{msg}` on input (hex {}): {:?}",
            hex(input),
            String::from_utf8_lossy(input)
        )
    })
}

fn hex(b: &[u8]) -> String {
    b.iter().map(|x| format!("{x:02x}")).collect()
}

/// Run `body` on a thread with the stack libFuzzer's main thread has
/// (8 MiB), not the test harness's 2 MiB.
fn on_big_stack(body: impl FnOnce() + Send + 'static) {
    std::thread::Builder::new()
        .name("fuzz_smoke".into())
        .stack_size(8 << 20)
        .spawn(body)
        .expect("spawn")
        .join()
        .unwrap_or_else(|p| panic::resume_unwind(p));
}

#[test]
fn generated_inputs_do_not_panic() {
    on_big_stack(|| {
        let pool = examples();
        let mut r = Rng(SEED);
        let mut failures = Vec::new();
        let mut slowest = (Duration::ZERO, Vec::new());
        let mut derived = 0;
        let start = Instant::now();
        for case in 0..CASES {
            let input = generate(&mut r, &pool);
            let steps = r.below(5) as u64;
            let seed = (r.below(4) != 0).then(|| r.next() % 1000);
            let t = Instant::now();
            let results = [
                guarded("parse", &input, || parse_target(&input)),
                guarded("derive", &input, || {
                    derived += usize::from(derive(&input, steps, seed));
                }),
            ];
            let took = t.elapsed();
            if took > slowest.0 {
                slowest = (took, input.clone());
            }
            for res in results {
                if let Err(e) = res {
                    failures.push(format!("case {case} (steps {steps}, seed {seed:?}): {e}"));
                }
            }
        }
        eprintln!(
            "fuzz_smoke: {CASES} inputs ({derived} derived without error) in {:.2?}, \
             slowest {:.2?}",
            start.elapsed(),
            slowest.0
        );
        assert!(
            failures.is_empty(),
            "{} of {CASES} inputs failed:\n{}",
            failures.len(),
            failures.join("\n")
        );
        assert!(
            derived >= MIN_DERIVED,
            "only {derived} of {CASES} inputs derived without error (want {MIN_DERIVED}): \
             the generator makes too few valid inputs"
        );
        assert!(
            slowest.0 < SLOW,
            "an input took {:.2?}: {:?}",
            slowest.0,
            String::from_utf8_lossy(&slowest.1)
        );
    });
}

/// Deep nesting of every kind, as long as a fuzz input (4 KiB) allows: the
/// parser, compiler and evaluator must not overflow an 8 MiB stack.
#[test]
fn deep_nesting() {
    const N: usize = 2000;
    let wrap =
        |pre: &str, mid: &str, post: &str| format!("{}{mid}{}", pre.repeat(N), post.repeat(N));
    let exprs = [
        wrap("(", "1", ")"),
        wrap("-", "1", ""),
        wrap("!", "1", ""),
        wrap("+", "1", ""),
        wrap("", "1", "^1"),
        wrap("", "1", "+1"),
        wrap("", "1", "*1"),
        wrap("", "1", "<1"),
        wrap("", "1", "&&1"),
        wrap("", "1", "||1"),
        wrap("sin(", "1", ")"),
        wrap("min(1,", "1", ")"),
        wrap("ran(", "1", ")"),
    ];
    let mut inputs = Vec::new();
    for e in &exprs {
        inputs.push(e.clone());
        inputs.push(format!("productions:\nA -> B({e})\naxiom:\nA\n"));
        inputs.push(format!("productions:\nA(x) : {e} -> B\naxiom:\nA(1)\n"));
        inputs.push(format!(
            "define: c = {e}\nproductions:\nA -> B(c)\naxiom:\nA\n"
        ));
        inputs.push(format!("derivation length: {e}\nproductions:\naxiom:\nA\n"));
        inputs.push(format!("productions:\nA(x) -> B(x)\naxiom:\nA({e})\n"));
    }
    inputs.push(format!(
        "productions:\nA -> [A]\naxiom:\n{}",
        wrap("[", "A", "]")
    ));
    inputs.push(format!(
        "productions:\nA -> {}\naxiom:\nA",
        wrap("[", "A", "]")
    ));
    inputs.push(format!("ignore: {}\naxiom:\nA", wrap("(", "", ")")));
    on_big_stack(move || {
        let mut failures = Vec::new();
        for input in &inputs {
            let data = input.as_bytes();
            let results = [
                guarded("parse", data, || parse_target(data)),
                guarded("derive", data, || {
                    derive(data, 2, Some(1));
                }),
            ];
            failures.extend(results.into_iter().filter_map(Result::err));
        }
        assert!(failures.is_empty(), "{}", failures.join("\n"));
    });
}

#[test]
fn fuzz_regressions_replay() {
    on_big_stack(|| {
        let dir = Path::new(ROOT).join("tests/fuzz_regressions");
        let entries = std::fs::read_dir(&dir).expect("tests/fuzz_regressions/");
        let mut paths: Vec<PathBuf> = entries
            .map(|e| e.expect("tests/fuzz_regressions/ entry").path())
            .filter(|p| p.is_file())
            .filter(|p| {
                let name = p.file_name().unwrap_or_default().to_string_lossy();
                !name.starts_with('.') && !name.starts_with("README")
            })
            .collect();
        paths.sort();
        assert!(
            paths.len() >= MIN_REGRESSIONS,
            "only {} reproducers in tests/fuzz_regressions/",
            paths.len()
        );
        let mut failures = Vec::new();
        for p in &paths {
            let data = std::fs::read(p).expect("read reproducer");
            let name = p.display().to_string();
            let t = Instant::now();
            let results = [
                guarded(&format!("{name} (parse)"), &data, || parse_target(&data)),
                guarded(&format!("{name} (derive)"), &data, || {
                    derive_target(&data);
                }),
                guarded(&format!("{name} (derive, 2 steps)"), &data, || {
                    derive(&data, 2, Some(1));
                }),
            ];
            failures.extend(results.into_iter().filter_map(Result::err));
            if t.elapsed() > SLOW {
                failures.push(format!("{name}: took {:.2?}", t.elapsed()));
            }
        }
        assert!(
            failures.is_empty(),
            "{} regression(s):\n{}",
            failures.len(),
            failures.join("\n")
        );
    });
}
