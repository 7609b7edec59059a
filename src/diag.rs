//! Errors and their rendering: `FILE:LINE:COL: error: message`, then the
//! source line and a caret under the spot. What went wrong is typed, one
//! enum per stage (`kinds.rs`, shared by both dialects; cpfg's own
//! refusals and preprocessor errors in `cpfg.rs`), warnings one enum
//! (`warning.rs`); the program's name in front (`lsgen: `) and the exit
//! status are the binaries' (`crate::cli::report`).

use std::fmt;

/// Line starts of a text, for offset -> line:column (starlark's CodeMap idea).
pub struct CodeMap<'a> {
    text: &'a str,
    line_starts: Vec<usize>,
    /// Line number of the text's first line (the header starts at 1).
    first_line: usize,
}

impl<'a> CodeMap<'a> {
    pub fn new(text: &'a str) -> Self {
        let mut line_starts = vec![0];
        line_starts.extend(text.match_indices('\n').map(|(i, _)| i + 1));
        CodeMap {
            text,
            line_starts,
            first_line: 1,
        }
    }

    /// Location of byte `offset`: line and column (both 1-based, column in
    /// characters) plus the text of that line.
    pub fn locate(&self, offset: usize) -> (usize, usize, &'a str) {
        let (idx, col, line) = line_col(self.text, &self.line_starts, offset);
        (self.first_line + idx, col, line)
    }
}

/// The line of byte `offset` of `text` (lines starting at `line_starts`):
/// its index (0-based), the column (1-based, in characters) and its text
/// without the line end. The `\r` of a CRLF line end is not a column: an
/// error at the end of the line sits just after its last character. An
/// offset inside a character counts that character once. One copy for
/// both dialects (the cpfg preprocessor's source files too).
pub(crate) fn line_col<'t>(
    text: &'t str,
    line_starts: &[usize],
    offset: usize,
) -> (usize, usize, &'t str) {
    let offset = offset.min(text.len());
    let idx = line_starts.partition_point(|&s| s <= offset) - 1;
    let start = line_starts[idx];
    let end = text[start..].find('\n').map_or(text.len(), |e| start + e);
    let line = &text[start..end];
    let line = line.strip_suffix('\r').unwrap_or(line);
    let offset = offset.min(start + line.len());
    let col = text.as_bytes()[start..offset]
        .iter()
        .filter(|&&b| (b & 0xC0) != 0x80)
        .count()
        + 1;
    (idx, col, line)
}

/// A located error: where, and the source line to show.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Location {
    pub path: String,
    pub line: usize,
    pub col: usize,
    /// The source line (possibly an excerpt) and the 1-based column of the
    /// caret within it.
    pub snippet: String,
    pub caret_col: usize,
}

impl Location {
    pub fn from_map(path: &str, map: &CodeMap, offset: usize) -> Location {
        let (line, col, text) = map.locate(offset);
        let (snippet, caret_col) = excerpt(text, col);
        Location {
            path: path.to_string(),
            line,
            col,
            snippet,
            caret_col,
        }
    }
}

/// Cut a very long line down to a window around the column.
pub fn excerpt(line: &str, col: usize) -> (String, usize) {
    const BEFORE: usize = 60;
    const AFTER: usize = 60;
    let n = line.chars().count();
    if n <= BEFORE + AFTER + 20 {
        return (line.to_string(), col);
    }
    let from = col.saturating_sub(BEFORE + 1);
    let to = (col + AFTER).min(n);
    let mut s = String::new();
    let mut caret = col - from;
    if from > 0 {
        s.push_str("...");
        caret += 3;
    }
    s.extend(line.chars().skip(from).take(to - from));
    if to < n {
        s.push_str("...");
    }
    (s, caret)
}

/// Write `text` to standard error. A closed or full standard error is not
/// an error of the run: a failure is ignored (`eprint!` would panic).
pub fn eprint(text: &str) {
    use std::io::Write;
    let _ = std::io::stderr().write_all(text.as_bytes());
}

/// `n` with a comma between groups of three digits: `18,446,744`.
pub fn group_digits(n: u64) -> String {
    let s = n.to_string();
    let mut out = String::with_capacity(s.len() + s.len() / 3);
    for (i, c) in s.chars().enumerate() {
        if i > 0 && (s.len() - i) % 3 == 0 {
            out.push(',');
        }
        out.push(c);
    }
    out
}

/// Report a located warning: to this thread's collection if there is one
/// ([`collect_warnings`]: a library derivation's, handed to its caller
/// as [`crate::Event::Warning`]), else on standard error
/// ([`print_warning`]).
pub(crate) fn warn(location: Location, kind: &WarningKind) {
    say(Warning::new(kind.clone(), Some(location)));
}

/// Report a warning made elsewhere (one a reader gathered), as [`warn`]
/// does.
pub(crate) fn say(w: Warning) {
    if let Some(crate::Event::Warning(w)) = collect(crate::Event::Warning(w)) {
        print_warning(&w);
    }
}

/// Report what a cpfg block's `printf` (or `fprintf(stderr, ...)`)
/// printed: to this thread's collection if there is one (handed to a
/// library caller as [`crate::Event::Printf`], in its place among the
/// warnings), else on standard error at once, as cpfg does (the binary).
pub(crate) fn printf(text: String) {
    let back = COLLECTED.with(|c| match c.borrow_mut().as_mut() {
        Some(c) => {
            c.printf(text);
            None
        }
        None => Some(text),
    });
    if let Some(text) = back {
        eprint(&text);
    }
}

/// Put `said` in this thread's collection; without one, give it back.
fn collect(said: crate::Event) -> Option<crate::Event> {
    COLLECTED.with(|c| match c.borrow_mut().as_mut() {
        Some(c) => {
            c.said.push(Said::Now(said));
            None
        }
        None => Some(said),
    })
}

/// Report a warning without a place, however often it is found, once per
/// collection (a derivation), or once per process on standard error
/// (`printed`: whether it was): the cheap test comes first, for a model
/// that finds it at every module.
pub(crate) fn warn_once(kind: &WarningKind, printed: &std::sync::atomic::AtomicBool) {
    let collected = COLLECTED.with(|c| match c.borrow_mut().as_mut() {
        Some(c) => {
            if !c.once.contains(kind) {
                c.once.push(kind.clone());
                c.said.push(Said::Now(crate::Event::Warning(Warning::new(
                    kind.clone(),
                    None,
                ))));
            }
            true
        }
        None => false,
    });
    if !collected && !printed.swap(true, std::sync::atomic::Ordering::Relaxed) {
        print_warning(&Warning::new(kind.clone(), None));
    }
}

/// Print a warning on standard error (`lsgen: FILE:LINE:COL: warning:
/// ...`, the source line and a caret), once per process: a batch's jobs
/// load the same file each, and its warnings are said once.
pub(crate) fn print_warning(w: &Warning) {
    let text = format!("lsgen: {w}");
    if first_time(&text) {
        eprint(&text);
    }
}

/// Has this text not been warned yet? The first 4096 distinct warnings
/// are remembered (by a 64-bit hash); past them every warning is printed.
fn first_time(text: &str) -> bool {
    use std::hash::{Hash, Hasher};
    use std::sync::Mutex;
    static SEEN: Mutex<Vec<u64>> = Mutex::new(Vec::new());
    let mut h = std::hash::DefaultHasher::new();
    text.hash(&mut h);
    let h = h.finish();
    let Ok(mut seen) = SEEN.lock() else {
        return true;
    };
    match seen.binary_search(&h) {
        Ok(_) => false,
        Err(at) => {
            if seen.len() < 4096 {
                seen.insert(at, h);
            }
            true
        }
    }
}

/// What [`print_warning`] prints for a located warning (the cpfg
/// preprocessor's `Display`).
pub(crate) fn warning_text(location: &Location, kind: &WarningKind) -> String {
    format!("lsgen: {}", AsWarning(location, &kind.to_string()))
}

/// What this thread's collection holds: warnings and `printf` text
/// ([`crate::Event::Warning`], [`crate::Event::Printf`]), in the order
/// they were said.
struct Collected {
    said: Vec<Said>,
    /// Those said once per collection, already said.
    once: Vec<WarningKind>,
    /// `printf` text is kept (else dropped at once: [`drop_printf`]).
    keep_printf: bool,
    /// Bytes of `printf` text in `said` (at most [`spill::HELD_MAX`] while
    /// a spill file can be had).
    held: usize,
    /// Past them, until the collection is drained, all text goes to the
    /// file: one entry of `said` for all of it between two warnings.
    spilling: bool,
    /// Where `printf` text past them goes.
    spill: Option<spill::Spill>,
    /// The directory for it ([`Collecting::spill_in`]).
    spill_dir: Option<std::path::PathBuf>,
    /// No spill file could be made: text stays in memory.
    spill_failed: bool,
}

/// One entry of a collection.
enum Said {
    Now(crate::Event),
    /// `printf` texts in the spill file, this range of it.
    Spilled(u64, u64),
}

impl Collected {
    fn new(keep_printf: bool) -> Self {
        Collected {
            said: Vec::new(),
            once: Vec::new(),
            keep_printf,
            held: 0,
            spilling: false,
            spill: None,
            spill_dir: None,
            spill_failed: false,
        }
    }

    fn printf(&mut self, text: String) {
        if !self.keep_printf {
            return;
        }
        if (self.spilling || self.held + text.len() > spill::HELD_MAX) && self.spilled(&text) {
            self.spilling = true;
            return;
        }
        self.held += text.len();
        self.said.push(Said::Now(crate::Event::Printf(text)));
    }

    /// Put `text` in the spill file (made at first); false if it cannot
    /// be, and it is then kept in memory.
    fn spilled(&mut self, text: &str) -> bool {
        if self.spill_failed {
            return false;
        }
        if self.spill.is_none() {
            match spill::Spill::new(self.spill_dir.as_deref()) {
                Ok(s) => self.spill = Some(s),
                Err(e) => {
                    self.cannot_spill(e);
                    return false;
                }
            }
        }
        let pushed = self.spill.as_mut().map(|s| s.push(text));
        let (from, to) = match pushed {
            Some(Ok(range)) => range,
            Some(Err(e)) => {
                // (What the file holds is still read back.)
                self.cannot_spill(e);
                return false;
            }
            None => return false,
        };
        match self.said.last_mut() {
            Some(Said::Spilled(_, end)) if *end == from => *end = to,
            _ => self.said.push(Said::Spilled(from, to)),
        }
        true
    }

    /// No spill file can take `printf` text (`e`): it stays in memory from
    /// now on, said once in the collection.
    fn cannot_spill(&mut self, e: std::io::Error) {
        self.spill_failed = true;
        let held = WarningKind::PrintfHeld(e.to_string());
        self.said
            .push(Said::Now(crate::Event::Warning(Warning::new(held, None))));
    }
}

thread_local! {
    /// Where this thread's warnings go: `None`, standard error.
    static COLLECTED: std::cell::RefCell<Option<Collected>> =
        const { std::cell::RefCell::new(None) };
}

/// While the returned guard lives, the warnings raised on this thread and
/// the text of cpfg's `printf` are collected ([`Collecting::take`]), not
/// printed. A derivation raises every warning and runs every cpfg block
/// on the thread that derives: the passes that can warn (decomposition,
/// the homomorphism's depth, the cpfg dialect) are never split between
/// threads (`derive::par::step_threads`).
pub(crate) fn collect_warnings() -> Collecting {
    // Inside a collection that drops `printf` text, this one drops it too.
    let keep_printf = COLLECTED.with(|c| c.borrow().as_ref().is_none_or(|c| c.keep_printf));
    let fresh = Collected::new(keep_printf);
    let outer = COLLECTED.with(|c| c.replace(Some(fresh)));
    Collecting {
        outer,
        _thread: std::marker::PhantomData,
    }
}

/// A collection ([`collect_warnings`]) that drops cpfg's `printf` text at
/// once, as do the collections opened while it lives: for
/// `LSystem::derive`, which reports nothing, so that a model printing at
/// every module does not fill memory with text no one reads.
pub(crate) fn drop_printf() -> Collecting {
    let c = collect_warnings();
    COLLECTED.with(|c| {
        if let Some(c) = c.borrow_mut().as_mut() {
            c.keep_printf = false;
        }
    });
    c
}

/// A collection ([`collect_warnings`]) that keeps cpfg's `printf` text, as
/// do the collections opened while it lives, even inside one that drops
/// it: for `LSystem::derive_with`, whose events report the text also when
/// it runs inside an `LSystem::derive` on the same thread (from that
/// derivation's writer).
pub(crate) fn keep_printf() -> Collecting {
    let c = collect_warnings();
    COLLECTED.with(|c| {
        if let Some(c) = c.borrow_mut().as_mut() {
            c.keep_printf = true;
        }
    });
    c
}

/// A collection of this thread's warnings; the one before it (if any)
/// comes back when it is dropped.
pub(crate) struct Collecting {
    outer: Option<Collected>,
    /// Bound to its thread.
    _thread: std::marker::PhantomData<*const ()>,
}

impl Collecting {
    /// `printf` text past [`spill::HELD_MAX`] bytes goes to a temporary
    /// file in `dir` (else the system's temporary directory).
    pub(crate) fn spill_in(&self, dir: Option<std::path::PathBuf>) {
        COLLECTED.with(|c| {
            if let Some(c) = c.borrow_mut().as_mut() {
                c.spill_dir = dir;
            }
        });
    }

    /// Hand the warnings and `printf` texts collected since the last call
    /// to `f`, in order. The collection is not borrowed while `f` runs.
    pub(crate) fn drain(&self, f: &mut dyn FnMut(crate::Event)) {
        let (said, spill) = COLLECTED.with(|c| match c.borrow_mut().as_mut() {
            Some(c) => {
                (c.held, c.spilling) = (0, false);
                (std::mem::take(&mut c.said), c.spill.take())
            }
            None => (Vec::new(), None),
        });
        for s in said {
            let (from, to) = match s {
                Said::Now(e) => {
                    f(e);
                    continue;
                }
                Said::Spilled(from, to) => (from, to),
            };
            let read = match &spill {
                Some(sp) => sp.read((from, to), &mut |t| f(crate::Event::Printf(t))),
                None => Err(std::io::Error::other("the file is gone")),
            };
            if let Err(e) = read {
                let lost = WarningKind::PrintfLost(e.to_string());
                f(crate::Event::Warning(Warning::new(lost, None)));
            }
        }
        // The file serves the next texts.
        if let Some(mut sp) = spill {
            sp.reset();
            COLLECTED.with(|c| {
                if let Some(c) = c.borrow_mut().as_mut() {
                    c.spill.get_or_insert(sp);
                }
            });
        }
    }

    /// The warnings and `printf` text collected since the last call, in
    /// order.
    pub(crate) fn take(&self) -> Vec<crate::Event> {
        let mut all = Vec::new();
        self.drain(&mut |e| all.push(e));
        all
    }

    /// The warnings collected since the last call, in order (of a load,
    /// which runs no cpfg block: nothing else is said there).
    pub(crate) fn take_warnings(&self) -> Vec<Warning> {
        self.take()
            .into_iter()
            .filter_map(|e| match e {
                crate::Event::Warning(w) => Some(w),
                _ => None,
            })
            .collect()
    }
}

impl Drop for Collecting {
    fn drop(&mut self) {
        let outer = self.outer.take();
        COLLECTED.with(|c| *c.borrow_mut() = outer);
    }
}

mod cpfg;
mod kinds;
mod spill;
mod warning;
pub use kinds::*;
pub(crate) use warning::FileWarnings;
pub use warning::{Warning, WarningKind, MAX_FILE_WARNINGS};

/// An error: what went wrong ([`ErrorKind`], typed by stage), where (a
/// [`Location`] in the source, or a subject such as a file name), boxed so
/// that `Result<T, Error>` stays two words wide in the hot loop.
///
/// `Display` renders it as `FILE:LINE:COL: error: message`, then the
/// source line and a caret under the spot (without a location,
/// `FILE: error: ...` or `error: ...`); a program puts its name in front.
#[derive(Debug)]
pub struct Error(Box<ErrorInner>);

#[derive(Debug)]
struct ErrorInner {
    kind: ErrorKind,
    location: Option<Location>,
    /// Context without a line, e.g. the file name of an I/O error.
    subject: Option<String>,
    /// The batch job that failed (`[job LABEL]` after the message).
    job: Option<String>,
    /// The warnings found before it, by a load that failed.
    warnings: Vec<Warning>,
}

pub type Result<T> = std::result::Result<T, Error>;

impl Error {
    /// An error without a place.
    pub fn new(kind: impl Into<ErrorKind>) -> Error {
        Error(Box::new(ErrorInner {
            kind: kind.into(),
            location: None,
            subject: None,
            job: None,
            warnings: Vec::new(),
        }))
    }

    /// An error at a place in the source.
    pub fn at(location: Location, kind: impl Into<ErrorKind>) -> Error {
        let mut e = Error::new(kind);
        e.0.location = Some(location);
        e
    }

    /// An error about `subject` (a file name, "standard output", ...).
    pub fn about(subject: impl Into<String>, kind: impl Into<ErrorKind>) -> Error {
        let mut e = Error::new(kind);
        e.0.subject = Some(subject.into());
        e
    }

    /// An I/O error about `subject` while doing `action`.
    pub fn io(subject: impl Into<String>, action: IoAction, e: std::io::Error) -> Error {
        Error::about(
            subject,
            IoError {
                action,
                reason: IoReason::Os(e),
            },
        )
    }

    /// The same error, in a batch job labelled `label`.
    #[doc(hidden)]
    pub fn in_job(mut self, label: impl Into<String>) -> Error {
        self.0.job = Some(label.into());
        self
    }

    /// The job's label ([`Error::in_job`]), taken off: a batch compares
    /// its jobs' errors without it.
    pub fn take_job(&mut self) -> Option<String> {
        self.0.job.take()
    }

    /// The same error, naming the options it mentions by `names`: the
    /// derivation engine makes its errors with the library's names, and
    /// `LSystem::run` gives them the caller's.
    pub(crate) fn with_option_names(mut self, names: OptionNames) -> Error {
        match &mut self.0.kind {
            ErrorKind::Runtime(
                RuntimeError::TooLong { names: n, .. } | RuntimeError::NoSpace { names: n, .. },
            )
            | ErrorKind::Usage(UsageError::StepsOverflow { names: n, .. }) => *n = names,
            _ => {}
        }
        self
    }

    /// The same error, with the warnings found before it.
    pub(crate) fn with_warnings(mut self, warnings: Vec<Warning>) -> Error {
        self.0.warnings = warnings;
        self
    }

    /// The warnings found before the error, in order, when
    /// [`LSystem::parse`] or [`LSystem::from_reader`] failed (a cpfg `.l`
    /// file's preprocessor and lowering warnings, with a place each; its
    /// `Display` does not show them). Empty for other errors: a
    /// derivation hands its warnings to
    /// [`LSystem::derive_with`]'s events, also when it fails.
    ///
    /// ```
    /// let src = "Lsystem: 1\nderivation length: 1\nAxiom: A(y)\n\
    ///            A : {z = foo(1);} * --> B\nendlsystem\n";
    /// let e = lsgen::LSystem::parse(src).err().unwrap();
    /// assert_eq!(e.to_string().lines().next(), Some(
    ///     "<input>:4:10: error: unknown function `foo`"
    /// ));
    /// assert!(matches!(
    ///     e.warnings()[0].kind(),
    ///     lsgen::diag::WarningKind::NotDefined(y) if y == "y"
    /// ));
    /// ```
    ///
    /// [`LSystem::parse`]: crate::LSystem::parse
    /// [`LSystem::from_reader`]: crate::LSystem::from_reader
    /// [`LSystem::derive_with`]: crate::LSystem::derive_with
    pub fn warnings(&self) -> &[Warning] {
        &self.0.warnings
    }

    /// What went wrong.
    pub fn kind(&self) -> &ErrorKind {
        &self.0.kind
    }

    /// Which stage found it.
    pub fn stage(&self) -> Stage {
        self.0.kind.stage()
    }

    /// Where in the source, if anywhere.
    pub fn location(&self) -> Option<&Location> {
        self.0.location.as_ref()
    }

    /// What it is about when it has no place in the source (a file name,
    /// "standard output").
    pub fn subject(&self) -> Option<&str> {
        self.0.subject.as_deref()
    }

    /// The message alone, without place, source line and caret.
    pub fn message(&self) -> String {
        match &self.0.job {
            Some(label) => format!("{} [job {label}]", self.0.kind),
            None => self.0.kind.to_string(),
        }
    }

    /// Writing failed because the reader closed the pipe: a quiet end.
    pub fn is_broken_pipe(&self) -> bool {
        matches!(&self.0.kind, ErrorKind::Io(e)
            if e.os_error().is_some_and(|e| e.kind() == std::io::ErrorKind::BrokenPipe))
    }
}

/// The OS message without Rust's " (os error N)" suffix.
pub(crate) fn io_message(e: &std::io::Error) -> String {
    if e.raw_os_error() == Some(libc::EFBIG) {
        return "File too large (past `ulimit -f`, or the file system's largest file)".into();
    }
    let s = e.to_string();
    match s.find(" (os error") {
        Some(i) => s[..i].to_string(),
        None => s,
    }
}

/// The message with its location, the source line and a caret (the one
/// renderer of errors and warnings), without the program's name.
impl fmt::Display for Error {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        render(f, self, "error")
    }
}

fn render(f: &mut fmt::Formatter<'_>, e: &Error, severity: &str) -> fmt::Result {
    let message = e.message();
    match (&e.0.location, &e.0.subject) {
        (Some(l), _) => render_at(f, l, severity, &message),
        (None, Some(s)) => writeln!(f, "{}", visible(&format!("{s}: {severity}: {message}"))),
        (None, None) => writeln!(f, "{severity}: {}", visible(&message)),
    }
}

/// A message line with its control characters escaped (`\n`, `\u{1b}`):
/// a file name holding a line break or a terminal escape (`$'b\e[31m.ls'`)
/// must not split the one line an error is, or reach the terminal raw.
fn visible(line: &str) -> std::borrow::Cow<'_, str> {
    if !line.chars().any(not_shown_raw) {
        return line.into();
    }
    let mut out = String::with_capacity(line.len() + 8);
    for c in line.chars() {
        if not_shown_raw(c) {
            out.extend(c.escape_default());
        } else {
            out.push(c);
        }
    }
    out.into()
}

/// A character never written to the terminal as it is: a control
/// character other than a tab.
fn not_shown_raw(c: char) -> bool {
    c.is_control() && c != '\t'
}

pub(crate) fn render_at(
    f: &mut fmt::Formatter<'_>,
    l: &Location,
    severity: &str,
    message: &str,
) -> fmt::Result {
    let head = format!("{}:{}:{}: {severity}: {message}", l.path, l.line, l.col);
    writeln!(f, "{}", visible(&head))?;
    // Control characters (a NUL, a stray `\r`) are shown as
    // U+FFFD, as undecodable bytes are: never sent raw.
    let shown: String = l
        .snippet
        .chars()
        .map(|c| if not_shown_raw(c) { '\u{FFFD}' } else { c })
        .collect();
    writeln!(f, "{shown}")?;
    writeln!(f, "{}^", caret_pad(&l.snippet, l.caret_col))?;
    // (A `\r\n` pair ends a line; a `\r` left in one ended none.)
    if l.snippet.contains('\r') {
        writeln!(
            f,
            "note: a `\\r` (shown as \u{FFFD}) without a `\\n` after it ends no line: lines \
             end with `\\n` or `\\r\\n`, so a file whose lines end with `\\r` alone is one line"
        )?;
    }
    Ok(())
}

/// A located warning message, rendered as an error is.
struct AsWarning<'a>(&'a Location, &'a str);

impl fmt::Display for AsWarning<'_> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        render_at(f, self.0, "warning", self.1)
    }
}

impl std::error::Error for Error {
    fn source(&self) -> Option<&(dyn std::error::Error + 'static)> {
        match &self.0.kind {
            ErrorKind::Io(e) => e
                .os_error()
                .map(|e| e as &(dyn std::error::Error + 'static)),
            ErrorKind::Preprocess(e) => e
                .os_error()
                .map(|e| e as &(dyn std::error::Error + 'static)),
            ErrorKind::FunctionFile(e) => e
                .os_error()
                .map(|e| e as &(dyn std::error::Error + 'static)),
            _ => None,
        }
    }
}

/// The blanks that put a caret under character `caret_col` (1-based) of
/// `snippet` on a terminal: a tab for a tab, else as many spaces as the
/// text before it is wide (two for CJK and emoji, none for a combining
/// mark). The text between tabs is measured whole, not a character at a
/// time: an emoji sequence joined by U+200D (`👩‍👩‍👧`), a flag or an
/// emoji with U+FE0F is one picture two columns wide.
pub fn caret_pad(snippet: &str, caret_col: usize) -> String {
    use unicode_width::UnicodeWidthStr;
    let end = snippet
        .char_indices()
        .nth(caret_col.saturating_sub(1))
        .map_or(snippet.len(), |(i, _)| i);
    let mut pad = String::new();
    for (k, piece) in snippet[..end].split('\t').enumerate() {
        if k > 0 {
            pad.push('\t');
        }
        // (Control characters count one column each.)
        pad.extend(std::iter::repeat_n(' ', piece.width()));
    }
    pad
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn line_col_counts_characters_and_not_the_cr_of_a_crlf_end() {
        let text = "ab\r\nxé\u{4e2d}z\r\nlast";
        let starts = [0, 4, 13];
        // 'a', the end of line 1 (its '\r', then its '\n').
        assert_eq!(line_col(text, &starts, 0), (0, 1, "ab"));
        assert_eq!(line_col(text, &starts, 2), (0, 3, "ab"));
        assert_eq!(line_col(text, &starts, 3), (0, 3, "ab"));
        // 'z' after a 2-byte and a 3-byte character; inside the 3-byte one.
        assert_eq!(line_col(text, &starts, 10), (1, 4, "xé\u{4e2d}z"));
        assert_eq!(line_col(text, &starts, 8), (1, 4, "xé\u{4e2d}z"));
        // Past the end: the last line's end.
        assert_eq!(line_col(text, &starts, 99), (2, 5, "last"));
        let map = CodeMap::new(text);
        assert_eq!(map.locate(3), (1, 3, "ab"));
    }

    #[test]
    fn errors_are_std_errors_and_keep_the_io_source() {
        fn std_error<E: std::error::Error + Send + Sync + 'static>(_: &E) {}
        let e = Error::io(
            "out.txt",
            crate::diag::IoAction::Write,
            std::io::Error::from_raw_os_error(libc::ENOSPC),
        );
        std_error(&e);
        let source = std::error::Error::source(&e).expect("an I/O source");
        let io = source.downcast_ref::<std::io::Error>().unwrap();
        assert_eq!(io.raw_os_error(), Some(libc::ENOSPC));
        let no_source = Error::new(RuntimeError::AlreadyDerived);
        assert!(std::error::Error::source(&no_source).is_none());
        // `?` turns it into a boxed error.
        assert_eq!(e.stage(), Stage::Io);
        let boxed: Box<dyn std::error::Error + Send + Sync> = e.into();
        assert_eq!(
            boxed.to_string(),
            "out.txt: error: cannot write: No space left on device\n"
        );
    }

    #[test]
    fn locate_lines_and_columns() {
        let text = "ab\ncdé f\n\nx";
        let m = CodeMap::new(text);
        assert_eq!(m.locate(0), (1, 1, "ab"));
        assert_eq!(m.locate(3), (2, 1, "cdé f"));
        // 'f' is at byte 8 (é is two bytes), column 5
        assert_eq!(m.locate(8), (2, 5, "cdé f"));
        assert_eq!(m.locate(10), (3, 1, ""));
        assert_eq!(m.locate(11), (4, 1, "x"));
        assert_eq!(m.locate(99), (4, 2, "x"));
    }

    #[test]
    fn render_with_caret() {
        let m = CodeMap::new("F -> G\n\tA(x) -> B(y)\n");
        let e = Error::at(
            Location::from_map("p.ls", &m, 17),
            CompileError::Expr(ExprError::UnknownIdentifier("y".into())),
        );
        assert_eq!(
            e.to_string(),
            "p.ls:2:11: error: unknown identifier `y`\n\tA(x) -> B(y)\n\t         ^\n"
        );
        assert_eq!(e.stage(), Stage::Compile);
    }

    #[test]
    fn the_stage_follows_the_payload() {
        let m = CodeMap::new("F -> G(\n");
        let e = Error::at(
            Location::from_map("p.ls", &m, 7),
            ParseError::Unexpected {
                found: "end of line".into(),
                expected: Expected::Nothing,
            },
        );
        assert_eq!(
            e.to_string(),
            "p.ls:1:8: error: unexpected end of line\nF -> G(\n       ^\n"
        );
        assert_eq!(e.stage(), Stage::Parse);
        let usage = Error::new(UsageError::FirstStepZero);
        assert_eq!(
            usage.to_string(),
            "error: the first step is step 1 or later\n"
        );
        assert_eq!(usage.stage(), Stage::Usage);
        let e = Error::new(RuntimeError::AlreadyDerived).in_job("a.ls");
        assert_eq!(
            e.message(),
            "the axiom stream was already read (by a derivation or a check): it can be read once [job a.ls]"
        );
    }

    #[test]
    fn expected_tokens_are_listed_up_to_six() {
        let names = |n: usize| Expected::OneOf((0..n).map(|i| format!("`{i}`")).collect());
        assert_eq!(names(1).to_string(), "expected `0`");
        assert_eq!(names(3).to_string(), "expected `0`, `1` or `2`");
        assert_eq!(names(7).to_string(), "");
        assert_eq!(Expected::Arrow.to_string(), "expected `->`");
    }

    #[test]
    fn crlf_line_end_is_not_a_column() {
        let m = CodeMap::new("ab\r\ncd\r\n");
        assert_eq!(m.locate(2), (1, 3, "ab"));
        assert_eq!(m.locate(3), (1, 3, "ab"));
        assert_eq!(m.locate(7), (2, 3, "cd"));
    }

    #[test]
    fn caret_under_wide_and_combining_characters() {
        // 漢 and 😀 are two columns wide, e\u{301} is one column.
        assert_eq!(caret_pad("漢😀e\u{301}\tx", 6), "     \t");
        // A family (three emoji joined by U+200D), a flag and a heart
        // with U+FE0F are two columns each on a terminal, not six, four
        // and one.
        let family = "\u{1f469}\u{200d}\u{1f469}\u{200d}\u{1f467}";
        assert_eq!(caret_pad(&format!("F -> {family} F )"), 14), " ".repeat(10));
        assert_eq!(
            caret_pad("\u{1f1eb}\u{1f1f7}\t\u{2764}\u{fe0f}x", 6),
            "  \t  "
        );
        // A control character is one column; the caret past the end pads
        // the whole line.
        assert_eq!(caret_pad("a\u{1}b", 9), "   ");
        let m = CodeMap::new("漢字 -> F>\n");
        let e = Error::at(
            Location::from_map("p.ls", &m, 11),
            ParseError::Unexpected {
                found: "`>`".into(),
                expected: Expected::Nothing,
            },
        );
        assert_eq!(
            e.to_string(),
            "p.ls:1:8: error: unexpected `>`\n漢字 -> F>\n         ^\n"
        );
    }

    #[test]
    fn printf_text_is_collected_in_order_or_dropped() {
        let m = CodeMap::new("A\n");
        let at = Location::from_map("p.l", &m, 0);
        let said = |c: &Collecting| -> Vec<String> {
            c.take()
                .iter()
                .map(|e| match e {
                    crate::Event::Printf(t) => t.clone(),
                    crate::Event::Warning(w) => w.message(),
                    e => format!("{e:?}"),
                })
                .collect()
        };
        let c = collect_warnings();
        printf("one\n".into());
        warn(at.clone(), &WarningKind::StepHidden);
        printf("two\n".into());
        assert_eq!(
            said(&c),
            ["one\n", "`step` hides the built-in step number", "two\n"]
        );
        drop(c);
        // Dropped where nothing is reported, also by a collection opened
        // inside (a derivation's); warnings are still collected.
        let outer = drop_printf();
        let inner = collect_warnings();
        printf("lost\n".into());
        warn(at, &WarningKind::StepHidden);
        assert_eq!(said(&inner), ["`step` hides the built-in step number"]);
        drop(inner);
        assert!(outer.take().is_empty());
    }

    /// Text past the bound goes to the spill file: memory holds at most
    /// the bound and one entry per stretch of spilled text; every text
    /// comes back in its place, around a warning; the next round (the
    /// file reused) too.
    #[test]
    fn printf_text_past_the_bound_is_spilled_in_order() {
        use crate::Event::{Printf, Warning as W};
        let m = CodeMap::new("A\n");
        let at = Location::from_map("p.l", &m, 0);
        let line = |k: usize| format!("line {k} {}\n", "x".repeat(k % 300));
        let (lines, warn_at) = (40_000, 30_000);
        let c = collect_warnings();
        for (round, kind) in [WarningKind::DivisionByZero, WarningKind::StepHidden]
            .into_iter()
            .enumerate()
        {
            let mut total = 0;
            for k in 0..lines {
                printf(line(k));
                total += line(k).len();
                if k == warn_at {
                    warn(at.clone(), &kind);
                }
            }
            assert!(total > 3 * spill::HELD_MAX, "{total}");
            COLLECTED.with(|c| {
                let c = c.borrow();
                let c = c.as_ref().unwrap();
                assert!(c.held <= spill::HELD_MAX, "{}", c.held);
                let spilled = c.said.iter().filter(|s| matches!(s, Said::Spilled(..)));
                // Before and after the warning.
                assert_eq!(spilled.count(), 2, "round {round}");
                assert!(c.said.len() < 20_000, "{}", c.said.len());
            });
            let mut want: Vec<crate::Event> = (0..lines).map(|k| Printf(line(k))).collect();
            want.insert(warn_at + 1, W(Warning::new(kind, Some(at.clone()))));
            let mut got = Vec::new();
            c.drain(&mut |e| got.push(e));
            assert!(
                got == want,
                "round {round}: {} events, {} wanted",
                got.len(),
                want.len()
            );
        }
    }

    /// Where no spill file can be made, the text stays in memory, all of
    /// it in order, and a warning says so once, where it began.
    #[test]
    fn printf_text_that_cannot_spill_is_held_with_one_warning() {
        use crate::Event::{Printf, Warning as W};
        let line = |k: usize| format!("line {k} {}\n", "y".repeat(k % 200));
        let c = collect_warnings();
        c.spill_in(Some("/nonexistent/lsgen-spill-test".into()));
        let (lines, mut total, mut first) = (30_000, 0, None);
        for k in 0..lines {
            if first.is_none() && total + line(k).len() > spill::HELD_MAX {
                first = Some(k);
            }
            total += line(k).len();
            printf(line(k));
        }
        assert!(total > 2 * spill::HELD_MAX, "{total}");
        let mut got = Vec::new();
        c.drain(&mut |e| got.push(e));
        let held: Vec<usize> = (got.iter().enumerate())
            .filter(|(_, e)| matches!(e, W(w) if matches!(w.kind(), WarningKind::PrintfHeld(_))))
            .map(|(i, _)| i)
            .collect();
        assert_eq!(
            held,
            [first.unwrap()],
            "one warning, before the first held text"
        );
        got.remove(held[0]);
        let want: Vec<crate::Event> = (0..lines).map(|k| Printf(line(k))).collect();
        assert!(got == want, "{} events", got.len());
    }

    #[test]
    fn long_lines_are_excerpted() {
        let line = "F".repeat(10_000);
        let (s, c) = excerpt(&line, 5000);
        assert!(s.len() < 200);
        assert_eq!(s.chars().nth(c - 1), Some('F'));
        assert!(s.starts_with("...") && s.ends_with("..."));
    }
}
