//! Issue 9 item 6: memory per production. A header of 10^5 productions is
//! loaded through the library with a counting global allocator (this test
//! is its own binary for that), and the peak of the bytes the load holds at
//! once, per production, must stay within the multiple of the source line
//! measured when this test was written: the whole syntax tree never exists
//! (each production is compiled as it is read) and expressions and constant
//! runs are one block each, the common expression shapes need no block,
//! and a production's slices sit behind thin pointers. The goal, the
//! source's order of magnitude, is met by all six rows in peak RSS
//! (benches/RESULTS.md); lower the factors as it shrinks.
//!
//! Bytes are counted as glibc malloc hands them out (the request plus 8
//! bytes, rounded up to 16, at least 32), so the numbers follow peak RSS.

use std::alloc::{GlobalAlloc, Layout, System};
use std::io::Cursor;
use std::sync::atomic::{AtomicUsize, Ordering};

struct Counting;

static LIVE: AtomicUsize = AtomicUsize::new(0);
static PEAK: AtomicUsize = AtomicUsize::new(0);

fn chunk(size: usize) -> usize {
    ((size + 8 + 15) & !15).max(32)
}

fn grow(n: usize) {
    let now = LIVE.fetch_add(n, Ordering::Relaxed) + n;
    PEAK.fetch_max(now, Ordering::Relaxed);
}

unsafe impl GlobalAlloc for Counting {
    unsafe fn alloc(&self, l: Layout) -> *mut u8 {
        grow(chunk(l.size()));
        unsafe { System.alloc(l) }
    }
    unsafe fn alloc_zeroed(&self, l: Layout) -> *mut u8 {
        grow(chunk(l.size()));
        unsafe { System.alloc_zeroed(l) }
    }
    unsafe fn realloc(&self, p: *mut u8, l: Layout, size: usize) -> *mut u8 {
        // In place, as glibc grows a large block (mremap): the table's
        // arrays are large blocks.
        let (old, new) = (chunk(l.size()), chunk(size));
        if new >= old {
            grow(new - old);
        } else {
            LIVE.fetch_sub(old - new, Ordering::Relaxed);
        }
        unsafe { System.realloc(p, l, size) }
    }
    unsafe fn dealloc(&self, p: *mut u8, l: Layout) {
        LIVE.fetch_sub(chunk(l.size()), Ordering::Relaxed);
        unsafe { System.dealloc(p, l) }
    }
}

#[global_allocator]
static A: Counting = Counting;

/// The counters are global: one test at a time.
static SERIAL: std::sync::Mutex<()> = std::sync::Mutex::new(());

/// 2^17: the production array grows by doubling, so at this count it is
/// full (no spare capacity counted, as peak RSS does not count untouched
/// pages).
const N: usize = 1 << 17;

/// The header of `N` productions, `line(i)` the `i`th, then `axiom`.
fn header(line: &dyn Fn(usize) -> String, axiom: &str) -> String {
    let mut src = String::from("productions:\n");
    for i in 0..N {
        src.push_str(&line(i));
        src.push('\n');
    }
    src.push_str(&format!("axiom: {axiom}\n"));
    src
}

/// Peak bytes held while loading `src` (`N` productions), per production
/// (the source text itself, made before, not counted), and the loaded
/// system.
fn load(src: String) -> (f64, lsgen::LSystem) {
    let reader = Cursor::new(src.into_bytes());
    let base = LIVE.load(Ordering::Relaxed);
    PEAK.store(base, Ordering::Relaxed);
    let ls = lsgen::LSystem::from_reader(reader, "many.ls").expect("the header loads");
    let peak = PEAK.load(Ordering::Relaxed) - base;
    (peak as f64 / N as f64, ls)
}

/// At most `factor` times the source line (with its newline) per
/// production (the header's own copy of the text counts once); a failure
/// is added to `failed`.
fn check(
    name: &str,
    line: &dyn Fn(usize) -> String,
    axiom: &str,
    factor: f64,
    failed: &mut Vec<String>,
) {
    let src = header(line, axiom);
    let source = (src.len() - "productions:\n".len()) as f64 / N as f64;
    let (per, ls) = load(src);
    drop(ls);
    eprintln!(
        "{name:<32} {per:7.1} bytes per production, {:.1}x the source",
        per / source
    );
    if per > factor * source {
        failed.push(format!(
            "`{name}`: {per:.1} bytes per production, more than {factor} x {source:.1} (the source line)"
        ));
    }
}

#[test]
fn bytes_per_production_stay_near_the_source_size() {
    let _one = SERIAL.lock().unwrap_or_else(|e| e.into_inner());
    // One after the other: the counters are global.
    // Measured at 10.8x, 6.4x, 9.6x, 8.4x, 16.7x and 8.3x after the
    // third round (Production 64 bytes with thin slices and both contexts
    // in one block, a constant run behind a thin pointer or in its place,
    // common expressions in place, key texts in place; the count includes the header buffer's
    // spare capacity, which peak RSS does not: 9.8x there); 20.8x, 11.4x, 20.6x, 15.4x, 23.7x and 16.9x
    // before it (main 22555ac, where these bounds fail); 25.8x, 13.9x,
    // 22.0x, 17.9x, 25.6x and 18.0x before the second. The goal, the
    // source's order of magnitude (about 10x), was not met by the
    // distinct-symbol row (benches/RESULTS.md). Fourth round: that row at
    // 11.4x (16.7x on main 4baaef2, where its bound fails: a key's
    // one-production list in place in a tagged word, the interning map of
    // key numbers only, a short run of non-ASCII symbols in a 32-byte
    // chunk; 9.7x in peak RSS), the others unchanged.
    let mut failed = Vec::new();
    let same = |l: &'static str| move |_: usize| l.to_string();
    check("F -> FF", &same("F -> FF"), "F", 11.3, &mut failed);
    check(
        "F : 1 > 0 -> FF",
        &same("F : 1 > 0 -> FF"),
        "F",
        6.9,
        &mut failed,
    );
    let param = "F(x) : x > 1 -> F(x/2)F(x/2)";
    check(param, &same(param), "F(4)", 10.2, &mut failed);
    check(
        "A < F > B -> FF",
        &same("A < F > B -> FF"),
        "AFB",
        8.9,
        &mut failed,
    );
    let distinct = |i: usize| {
        let c = char::from_u32(0x10000 + i as u32).unwrap();
        format!("{c} -> {c}{c}")
    };
    check(
        "distinct symbols X -> XX",
        &distinct,
        "F",
        11.7,
        &mut failed,
    );
    let pdistinct = |i: usize| format!("F(x) : x > {i} -> F(x/2)F(x+{i})");
    check(
        "F(x) : x > i -> F(x/2)F(x+i)",
        &pdistinct,
        "F(4)",
        8.9,
        &mut failed,
    );
    assert!(failed.is_empty(), "{}", failed.join("\n"));
}

/// Deriving one step of a parametric system depth first adds little per
/// production to what the load holds: the plan's note of which successor
/// items go out as text is a byte each and 4 bytes a production, built
/// once (it was two boxed slices per production, 63 bytes here, in each
/// thread).
#[test]
fn deriving_adds_little_per_production() {
    let _one = SERIAL.lock().unwrap_or_else(|e| e.into_inner());
    let line = |_: usize| "F(x) : x > 1 -> F(x/2)F(x/2)".to_string();
    let (_, mut ls) = load(header(&line, "F(4)"));
    let base = LIVE.load(Ordering::Relaxed);
    PEAK.store(base, Ordering::Relaxed);
    let mut out = Vec::new();
    ls.derive(&lsgen::Options::new().steps(1), &mut out)
        .expect("derives");
    let per = (PEAK.load(Ordering::Relaxed) - base) as f64 / N as f64;
    eprintln!("deriving one step: {per:.1} bytes per production more");
    assert_eq!(out, b"F(2)F(2)\n");
    assert!(
        per < 24.0,
        "deriving one step holds {per:.1} bytes per production more"
    );
}

/// Load `src`, a header with one long line of `line` bytes: at most
/// `factor` times the line at peak (the header's text counted), else a
/// failure added to `failed`.
fn check_line(name: &str, src: String, line: usize, factor: f64, failed: &mut Vec<String>) {
    check_file(name, src, "long.ls", line, factor, failed)
}

/// [`check_line`] for a file called `file` (`.l`: cpfg's dialect).
fn check_file(
    name: &str,
    src: String,
    file: &str,
    line: usize,
    factor: f64,
    failed: &mut Vec<String>,
) {
    let source = line as f64;
    let reader = Cursor::new(src.into_bytes());
    let base = LIVE.load(Ordering::Relaxed);
    PEAK.store(base, Ordering::Relaxed);
    let ls = lsgen::LSystem::from_reader(reader, file).expect("the file loads");
    let peak = (PEAK.load(Ordering::Relaxed) - base) as f64;
    drop(ls);
    eprintln!("{name:<32} {:.1}x the line", peak / source);
    if peak > factor * source {
        failed.push(format!(
            "`{name}`: {peak} bytes, more than {factor} x {source} (the line)"
        ));
    }
}

/// One production with a long successor is compiled as it is read: the
/// parser hands its modules over in batches, so the syntax tree of a whole
/// line (about 50 bytes a module) never exists, and the peak is what the
/// compiled successor holds while it is built (its text, binary forms and
/// bracket list, and their copy into one block at the end). Measured at
/// 11.7x, 50.7x and 17.3x the line (the header text included); 59.6x,
/// 98.6x and 74.6x before, where these bounds fail (every module of the
/// line held as a tree node until its end: `A -> ` and 20 million `B`
/// took 1.1 GB of peak RSS, 199 MB now).
#[test]
fn one_long_successor_costs_its_compiled_form() {
    let _one = SERIAL.lock().unwrap_or_else(|e| e.into_inner());
    let mut failed = Vec::new();
    for (name, module, axiom, factor) in [
        ("A -> B...", "B", "A", 13.0),
        ("A -> [B]...", "[B]", "A", 56.0),
        ("A(x) -> B(x+1)...", "B(x+1)", "A(1)", 20.0),
    ] {
        let pred = axiom.replace('1', "x");
        let line = format!("{pred} -> {}", module.repeat(N * 4 / module.len()));
        let src = format!("productions:\n{line}\naxiom: {axiom}\n");
        check_line(name, src, line.len(), factor, &mut failed);
    }
    assert!(failed.is_empty(), "{}", failed.join("\n"));
}

/// An `ignore:` or `consider:` line is a set of symbols: the parser keeps
/// each symbol once as it reads the line, so a line of 4 * 2^17 modules
/// costs the header text and the little the line names. Measured 2.1x the
/// line; 48x before, where this bound fails (every module of the line held
/// as a tree node until its end: a 10 MB `ignore:` line peaked at 480 MB
/// of RSS).
#[test]
fn a_long_ignore_line_costs_its_symbols() {
    let _one = SERIAL.lock().unwrap_or_else(|e| e.into_inner());
    let mut failed = Vec::new();
    for (keyword, symbols) in [("ignore:", "+-&^"), ("consider:", "ABCD")] {
        let line = format!("{keyword} {}", symbols.repeat(N));
        let src = format!("{line}\nproductions:\nA < B -> C\naxiom: AB\n");
        check_line(keyword, src, line.len(), 4.0, &mut failed);
    }
    assert!(failed.is_empty(), "{}", failed.join("\n"));
}

/// A context is compiled as it is read: the parser hands the head over
/// module by module, so a context of 4 * 2^17 modules costs its compiled
/// patterns (8 bytes a module, 12 in a right context, and their copy into
/// the production), not a syntax tree node per module (about 50 bytes).
/// Measured 18.6x, 26.6x and 22.3x the line; 58.6x, 62.6x and 60.3x
/// before, where these bounds fail (a 10 MB left context peaked at 560 MB
/// of RSS, 170 MB now).
#[test]
fn a_long_context_costs_its_compiled_form() {
    let _one = SERIAL.lock().unwrap_or_else(|e| e.into_inner());
    let mut failed = Vec::new();
    let many = |m: &str| m.repeat(N * 4 / m.len());
    for (name, line, factor) in [
        ("B... < A -> C", format!("{} < A -> C", many("B")), 20.0),
        ("A > B... -> C", format!("A > {} -> C", many("B")), 28.0),
        (
            "B... < A > [B]... -> C",
            format!("{} < A > {} -> C", many("B"), many("[B]")),
            24.0,
        ),
    ] {
        let src = format!("productions:\n{line}\naxiom: A\n");
        check_line(name, src, line.len(), factor, &mut failed);
    }
    assert!(failed.is_empty(), "{}", failed.join("\n"));
}

/// A `groups:` line keeps two bytes an entry while it is read (and where
/// each group is named first), then the schedule four: a line of 4 * 2^17
/// entries peaks at a few times the line. Measured 5.3x; 16.3x before
/// (24 bytes an entry), where this bound fails (a 64 MiB line peaked at
/// about 1 GB of RSS, 270 MB now).
#[test]
fn a_long_groups_line_costs_its_schedule() {
    let _one = SERIAL.lock().unwrap_or_else(|e| e.into_inner());
    let mut failed = Vec::new();
    let line = format!("groups: {}", "1 2 ".repeat(N * 2));
    let src = format!("{line}\nproductions 1:\nA -> B\nproductions 2:\nB -> A\naxiom: A\n");
    check_line("groups:", src, line.len(), 6.0, &mut failed);
    assert!(failed.is_empty(), "{}", failed.join("\n"));
}

/// A cpfg `.l` file is parsed whole (its lowering needs the whole file),
/// but the tree keeps a production's predecessor, contexts and successor
/// as places in its text, read again when it is lowered, and the lowering
/// hands each production to the compiler as it goes, its successor in
/// batches: no tree of the shared language is made, and none is kept.
/// Measured 15.7x, 21.3x, 19.5x and 16.1x the file (the file's source, its
/// preprocessed copy and the tree all count). 111.6x, 152.9x and 97.8x
/// before 0f8188b, where these bounds fail (a tree node per module, the
/// shared tree lowered from it, a copy of that for the compiler, the
/// shared tree kept: a 10 MB successor line peaked at 1.07 GB of RSS,
/// 132 MB now); the many productions 30.6x and 29.5x while their heads
/// were tree nodes (each formal parameter a name of its own), where the
/// last two bounds fail.
#[test]
fn a_cpfg_file_is_compiled_as_it_is_lowered() {
    let _one = SERIAL.lock().unwrap_or_else(|e| e.into_inner());
    let mut failed = Vec::new();
    let lsystem =
        |body: &str| format!("Lsystem: 1\nderivation length: 1\nAxiom: A(1)\n{body}\nendlsystem\n");
    for (name, body, factor) in [
        ("A --> B...", format!("A --> {}", "B".repeat(N * 4)), 17.0),
        (
            "A(x) --> B(x+1)...",
            format!("A(x) --> {}", "B(x+1)".repeat(N * 4 / 6)),
            23.0,
        ),
        (
            "A < B > C --> DE, many",
            "A < B > C --> DE\n".repeat(N / 4),
            22.0,
        ),
        (
            "A(x) < B(y) > C(z) ..., many",
            "A(x) < B(y) > C(z) : x > 1 --> D(x+y)E(z)\n".repeat(N / 12),
            18.0,
        ),
    ] {
        let src = lsystem(&body);
        let len = src.len();
        check_file(name, src, "long.l", len, factor, &mut failed);
    }
    assert!(failed.is_empty(), "{}", failed.join("\n"));
}
