//! The library facade: [`LSystem`], [`Load`], [`Options`], [`Stats`].

use crate::cpfg::func::Functions;
use crate::cpfg::Dialect;
use crate::derive::random::Random;
use crate::derive::{derive, Event, FrameSink, Frames, Limits, Settings, Strategy};
use crate::diag::{Error, OptionNames, ParseError, RuntimeError, UsageError, Warning, WarningKind};
use crate::io::axiom::AxiomReader;
use crate::io::input::{split_header, Input, Split};
use crate::lang::parse::{locate, UserError};
use crate::rules::codec::Numbers;
use crate::rules::{compile_text, LoadError, Seeds, System};
use std::io::{self, Read, Write};
use std::path::{Path, PathBuf};
use std::sync::Arc;

/// Derivation length when neither the file nor [`Options::steps`] gives one.
pub const DEFAULT_DERIVATION_LENGTH: u64 = 1;

/// An L-system read from `.ls` text: its header parsed and compiled, its
/// axiom still to be streamed.
///
/// ```
/// let mut ls = lsgen::LSystem::parse("productions:\nA -> AB\nB -> A\naxiom: A\n")?;
/// let mut out = Vec::new();
/// let stats = ls.derive(&lsgen::Options::new().steps(4), &mut out)?;
/// assert_eq!(out, b"ABAABABA\n");
/// assert_eq!(stats.modules, 8);
/// # Ok::<(), lsgen::Error>(())
/// ```
pub struct LSystem {
    path: String,
    split: Split,
    /// The rest of the input, at the axiom; None once read.
    input: Option<Input>,
    /// The whole text, when parsed from a string: the axiom can be read
    /// again for another derivation.
    text: Option<String>,
    /// `--axiom`: plain module text replacing the file's axiom.
    axiom: Option<Input>,
    /// The compiled rules, and the command-line seed their random
    /// constants were drawn with (None: the file's `seed:` or `fresh`).
    system: Option<(System, Option<u64>)>,
    /// The seed used when neither the options nor the file give one.
    fresh: u64,
    /// The file's `seed:` (kept apart from `system`, which a derivation
    /// takes).
    file_seed: Option<u64>,
    /// The warnings found when the file was read by [`LSystem::parse`] or
    /// [`LSystem::from_reader`], for each [`LSystem::derive_with`] (the
    /// binary prints its own at once).
    warnings: Vec<Warning>,
    /// A cpfg `.l` file, lowered: the rules are compiled from it, the
    /// axiom is read from its text.
    cpfg: Option<crate::cpfg::Loaded>,
}

/// The input's name, its dialect, and whether it can still be derived
/// (a streamed `.ls` axiom is read once); the rules are compiled code.
impl std::fmt::Debug for LSystem {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let (dialect, derivable) = match &self.cpfg {
            Some(_) => (Dialect::Cpfg, true),
            None => (
                Dialect::Ls,
                self.axiom.is_some() || self.input.is_some() || self.text.is_some(),
            ),
        };
        f.debug_struct("LSystem")
            .field("name", &self.path)
            .field("dialect", &dialect)
            .field("derivable", &derivable)
            .finish_non_exhaustive()
    }
}

/// How to read an L-system: its language, whether a cpfg `.l` text may
/// `#include` files, and the functions, curves and view its `func`,
/// `curveX` and turtle queries read. `Load::new()` (or `default()`) is
/// how [`LSystem::parse`] and [`LSystem::from_reader`] read: the
/// language told from the text, includes read.
///
/// A text from someone else: a `.l` text's `#include "PATH"` reads any
/// file the process may read, and an error there quotes a line of it.
/// `includes(false)` makes every `#include` carried out an error at its
/// line ([`crate::diag::PreprocessError::IncludesOff`]), and
/// `dialect(Dialect::Ls)` reads `.ls` text only, which names no file.
///
/// ```
/// use lsgen::{Dialect, Load};
/// let text = "#include \"/etc/passwd\"\nLsystem: 1\nAxiom: A\nA --> AB\nendlsystem\n";
/// let e = Load::new().includes(false).parse(text).err().unwrap();
/// assert_eq!(
///     e.to_string(),
///     "<input>:1:1: error: `#include` is turned off for this text \
///      (`Load::includes(false)`): no file is read\n#include \"/etc/passwd\"\n^\n"
/// );
/// // Read as `.ls`, the same text is a syntax error.
/// assert!(Load::new().dialect(Dialect::Ls).parse(text).is_err());
/// let mut ls = Load::new()
///     .includes(false)
///     .parse("Lsystem: 1\nderivation length: 2\nAxiom: A\nA --> AB\nendlsystem\n")?;
/// let mut out = Vec::new();
/// ls.derive(&lsgen::Options::new(), &mut out)?;
/// assert_eq!(out, b"ABB\n");
/// # Ok::<(), lsgen::Error>(())
/// ```
#[derive(Clone, Debug)]
pub struct Load {
    dialect: Dialect,
    includes: bool,
    view: Option<PathBuf>,
    functions: Vec<PathBuf>,
}

impl Default for Load {
    fn default() -> Self {
        Load {
            dialect: Dialect::Auto,
            includes: true,
            view: None,
            functions: Vec::new(),
        }
    }
}

impl Load {
    /// The language told from the text ([`crate::cpfg::sniff`]: a name
    /// ending in `.l`, or a first statement `Lsystem:` or `#` directive,
    /// is cpfg's), includes read, no functions.
    pub fn new() -> Self {
        Self::default()
    }

    /// Read the text as this language ([`Dialect::Auto`]: told from the
    /// text). lsgen's `--dialect`.
    pub fn dialect(mut self, dialect: Dialect) -> Self {
        self.dialect = dialect;
        self
    }

    /// Whether a `.l` text's `#include` reads files (default true). Off,
    /// an `#include` carried out (not one in a skipped `#if` branch) is
    /// an error at its line, and no file is read or looked at (not even
    /// the `.v` file beside the text's name that a `func` error would
    /// point to).
    pub fn includes(mut self, on: bool) -> Self {
        self.includes = on;
        self
    }

    /// cpfg's functions for `func(id, x)` and curves for `curveX(id, t)`
    /// (`curveY`, `curveZ`, `curveGAL`) in a `.l` text, read from `files`
    /// as lsgen's `--functions` reads them: each a cpfg view file (its
    /// `function:`, `function set:` and `curve:` lines), a function set,
    /// a `.func` or a `.con` file; functions and curves each numbered in
    /// order (README, "Coming from cpfg: functions", "... curves"). Added
    /// to those given before; read by each `parse` or `from_reader`.
    pub fn functions<P: AsRef<Path>>(mut self, files: impl IntoIterator<Item = P>) -> Self {
        self.functions
            .extend(files.into_iter().map(|f| f.as_ref().to_path_buf()));
        self
    }

    /// cpfg's view file, as lsgen's `--cpfg-view` reads it: its turtle's
    /// settings for a `.l` text's queries `?P`, `?H`, `?L`, `?U` (README,
    /// "Coming from cpfg: turtle queries"), and its functions and curves,
    /// numbered before those of [`functions`](Load::functions).
    pub fn view(mut self, view: impl AsRef<Path>) -> Self {
        self.view = Some(view.as_ref().to_path_buf());
        self
    }

    /// [`LSystem::parse`] read this way.
    pub fn parse(&self, text: &str) -> Result<LSystem, Error> {
        let input = Input::new(Box::new(io::Cursor::new(text.to_string())), "<input>");
        let mut ls = self.load(input)?;
        ls.text = Some(text.to_string());
        Ok(ls)
    }

    /// [`LSystem::from_reader`] read this way.
    pub fn from_reader(
        &self,
        reader: impl Read + Send + 'static,
        name: &str,
    ) -> Result<LSystem, Error> {
        self.load(Input::new(Box::new(reader), name))
    }

    /// Load `input`: its warnings kept for each derivation, or, if it
    /// fails, in the error ([`Error::warnings`]).
    fn load(&self, input: Input) -> Result<LSystem, Error> {
        let functions = Arc::new(Functions::load_with_view(
            self.view.as_deref(),
            &self.functions,
        )?);
        let collecting = crate::diag::collect_warnings();
        let loaded = LSystem::load_dialect(
            input,
            None,
            self.dialect,
            OptionNames::Library,
            (&functions, self.includes),
        )
        .and_then(|ls| ls.require_axiom().map(|()| ls));
        let warnings = collecting.take_warnings();
        match loaded {
            Ok(mut ls) => {
                ls.warnings = warnings;
                Ok(ls)
            }
            Err(e) => Err(e.with_warnings(warnings)),
        }
    }
}

/// How to derive. `Options::new()` (or `default()`) takes the file's
/// settings; each method overrides one.
#[derive(Clone, Debug)]
pub struct Options {
    steps: Option<u64>,
    seed: Option<u64>,
    homomorphism: bool,
    limits: Limits,
    tmpdir: Option<PathBuf>,
    strategy: Strategy,
    first_step: u64,
    precision: Option<u32>,
    space: Option<u64>,
    threads: usize,
    split: Option<u64>,
    direct: Option<std::sync::Arc<std::sync::atomic::AtomicU8>>,
    /// How errors name the options: by these methods, or by the binary's
    /// flags.
    names: OptionNames,
    /// Warnings and cpfg's `printf` text go to standard error as they
    /// are found, not to the events.
    print_warnings: bool,
}

impl Default for Options {
    fn default() -> Self {
        Options {
            steps: None,
            seed: None,
            homomorphism: true,
            limits: Limits::default(),
            tmpdir: None,
            strategy: Strategy::Auto,
            first_step: 1,
            precision: None,
            space: None,
            threads: 1,
            split: None,
            direct: None,
            names: OptionNames::Library,
            print_warnings: false,
        }
    }
}

impl Options {
    /// The file's settings: its `derivation length:` (else 1 step), its
    /// `seed:` (else a fresh seed), the homomorphism applied, no limits,
    /// temporary files in `$TMPDIR`.
    pub fn new() -> Self {
        Self::default()
    }

    /// Derive `n` steps (overrides `derivation length:`).
    pub fn steps(mut self, n: u64) -> Self {
        self.steps = Some(n);
        self
    }

    /// Seed the random generator (overrides `seed:`, also for random
    /// constants).
    pub fn seed(mut self, seed: u64) -> Self {
        self.seed = Some(seed);
        self
    }

    /// Apply the homomorphism after the last step (default: yes).
    pub fn homomorphism(mut self, on: bool) -> Self {
        self.homomorphism = on;
        self
    }

    /// Stop with an error when a generation exceeds these limits.
    pub fn limits(mut self, limits: Limits) -> Self {
        self.limits = limits;
        self
    }

    /// Directory for the temporary files: generations, and cpfg `printf`
    /// text that [`LSystem::derive_with`] holds (default: `$TMPDIR`). A
    /// derivation of one step or more, or with a homomorphism to apply
    /// (also of no step), first looks it up: one that is not there or is
    /// no directory is an I/O error before the axiom is read,
    /// so a streamed axiom can still be derived with another.
    pub fn tmpdir(mut self, dir: impl Into<PathBuf>) -> Self {
        self.tmpdir = Some(dir.into());
        self
    }

    /// The number of the first step (default 1): random draws depend on
    /// the step number, so deriving 3 steps, then 2 more from the result
    /// with `first_step(4)`, gives what 5 steps give.
    pub fn first_step(mut self, k: u64) -> Self {
        self.first_step = k;
        self
    }

    /// Print the final string's parameters with `digits` significant
    /// digits, as C's `%g` (clamped to 1..=17); default: the shortest form
    /// that reads back to the same number. [`Stats::bytes`] and the byte
    /// limits count the text before this rewriting.
    pub fn precision(mut self, digits: u32) -> Self {
        self.precision = Some(digits);
        self
    }

    /// Refuse, before writing anything, a final string known in advance
    /// (depth-first D0L plans, so up to 65,536 steps) to be larger than
    /// `bytes`: the free space where it goes. Any other derivation is not
    /// checked (`Limits` stops one as it goes).
    pub fn free_space(mut self, bytes: u64) -> Self {
        self.space = Some(bytes);
        self
    }

    /// Derive one string on up to `n` threads (default 1; 0 counts as 1).
    /// The output is byte-identical for every `n`; systems that cannot be
    /// split use one thread (README, Design: parallel derivation). At most
    /// 4 threads per CPU and 256 in all are started, whatever `n` is:
    /// threads past the CPUs only hold memory.
    pub fn threads(mut self, n: usize) -> Self {
        self.threads = n.max(1);
        self
    }

    /// Derive one string on as many threads as there are CPUs (the
    /// binary's default `-j`); the CPUs are counted only when the
    /// derivation can be split.
    #[doc(hidden)]
    pub fn threads_all(mut self) -> Self {
        self.threads = crate::derive::par::ALL_CPUS;
        self
    }

    /// A switch the derivation turns on while it writes text made on
    /// several threads, and off after: the binary's `-o` file then writes
    /// around the page cache (`io::output::WriteBehind`).
    #[doc(hidden)]
    pub fn direct_output(mut self, switch: std::sync::Arc<std::sync::atomic::AtomicU8>) -> Self {
        self.direct = Some(switch);
        self
    }

    /// Errors name the options by the binary's flags (`--first-step`),
    /// not by these methods: the binary's.
    #[doc(hidden)]
    pub fn command_line_names(mut self) -> Self {
        self.names = OptionNames::CommandLine;
        self
    }

    /// Warnings go to standard error as they are found (each text once
    /// per process), and so does what a cpfg block's `printf` prints, not
    /// to [`LSystem::derive_with`]'s events: the binary's, so that they
    /// keep their place among each other and the other lines there
    /// (`-v`).
    #[doc(hidden)]
    pub fn print_warnings(mut self) -> Self {
        self.print_warnings = true;
        self
    }

    /// Split the work between threads into tasks this small (for tests).
    #[doc(hidden)]
    pub fn split(mut self, n: u64) -> Self {
        self.split = Some(n.max(1));
        self
    }

    /// Force a strategy (for tests).
    #[doc(hidden)]
    pub fn strategy(mut self, strategy: Strategy) -> Self {
        self.strategy = strategy;
        self
    }
}

/// What a derivation did.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[non_exhaustive]
pub struct Stats {
    /// The seed of the random generator: [`Options::seed`], else the
    /// file's `seed:`, else for an `.ls` system the fresh one it drew (so
    /// `Options::seed` with it derives the same string again). `None` for
    /// a cpfg `.l` system without either: as in cpfg, it uses no seed
    /// (its weights are ignored; README, "Coming from cpfg: randomness"),
    /// and giving it one would make it stochastic.
    pub seed: Option<u64>,
    /// Derivation steps asked for.
    pub steps: u64,
    /// Modules written.
    pub modules: u64,
    /// Bytes written, without the final newline.
    pub bytes: u64,
}

impl LSystem {
    /// Parse an L-system from `.ls` text.
    ///
    /// A failure is an [`Error`] whose [`kind`](Error::kind) says what went
    /// wrong, with its data, and whose [`warnings`](Error::warnings) are
    /// those found before it; its `Display` is the located message:
    ///
    /// ```
    /// use lsgen::diag::{CompileError, ExprError};
    /// let e = lsgen::LSystem::parse("productions:\nA(x) -> B(y)\naxiom: A(1)\n")
    ///     .err()
    ///     .unwrap();
    /// assert!(matches!(
    ///     e.kind(),
    ///     lsgen::ErrorKind::Compile(CompileError::Expr(ExprError::UnknownIdentifier(n))) if n == "y"
    /// ));
    /// assert_eq!(e.stage(), lsgen::Stage::Compile);
    /// assert_eq!(
    ///     e.to_string(),
    ///     "<input>:2:11: error: unknown identifier `y`\nA(x) -> B(y)\n          ^\n"
    /// );
    /// ```
    pub fn parse(text: &str) -> Result<LSystem, Error> {
        Load::new().parse(text)
    }

    /// Parse an L-system from a reader, named `name` in error messages.
    /// Of an `.ls` text, the header is read now and the axiom streamed by
    /// [`derive`], so it can be derived once (again, or after
    /// [`check`](LSystem::check), which reads the axiom, is
    /// [`RuntimeError::AlreadyDerived`]). A cpfg `.l` text is read whole
    /// now (its preprocessor needs all of it; at most 64 MiB) and keeps
    /// its axiom as text: it derives as often as one from
    /// [`parse`](LSystem::parse), each derivation a whole run that gives
    /// the same string and events (its `Start:` block runs in each, the
    /// draws start again from the seed). [`Load`] sets how it is read.
    ///
    /// [`derive`]: LSystem::derive
    pub fn from_reader(reader: impl Read + Send + 'static, name: &str) -> Result<LSystem, Error> {
        Load::new().from_reader(reader, name)
    }

    /// [`from_reader`](LSystem::from_reader) with cpfg's functions for
    /// `func(id, x)` and curves for `curveX(id, t)` (`curveY`, `curveZ`,
    /// `curveGAL`) in a `.l` text, read from `files` as lsgen's
    /// `--functions` reads them: each a cpfg view file (its `function:`,
    /// `function set:` and `curve:` lines), a function set, a `.func` or a
    /// `.con` file; functions and curves each numbered in order (README,
    /// "Coming from cpfg: functions", "... curves"). The same as
    /// [`Load::functions`].
    pub fn from_reader_with_functions(
        reader: impl Read + Send + 'static,
        name: &str,
        files: &[PathBuf],
    ) -> Result<LSystem, Error> {
        Load::new().functions(files).from_reader(reader, name)
    }

    /// [`from_reader_with_functions`](LSystem::from_reader_with_functions)
    /// after cpfg's view file `view`, as lsgen's `--cpfg-view` reads it:
    /// its turtle's settings for the queries `?P`, `?H`, `?L`, `?U` (README,
    /// "Coming from cpfg: turtle queries"), and its functions and curves,
    /// numbered before those of `files`. The same as [`Load::view`].
    pub fn from_reader_with_view(
        reader: impl Read + Send + 'static,
        name: &str,
        view: &Path,
        files: &[PathBuf],
    ) -> Result<LSystem, Error> {
        Load::new()
            .view(view)
            .functions(files)
            .from_reader(reader, name)
    }

    /// Read and compile the header from `input` (leaving it at the axiom);
    /// random constants drawn with `seed` (else the file's or a fresh one).
    pub(crate) fn load_named(input: Input, seed: Option<u64>) -> Result<LSystem, Error> {
        Self::load_dialect(
            input,
            seed,
            Dialect::Auto,
            OptionNames::Library,
            (&Arc::default(), true),
        )
    }

    /// [`load_named`](Self::load_named) in `dialect` (`Auto`: the file's,
    /// see [`crate::cpfg::sniff`]), its warnings naming the options by
    /// `names`; a `.l` file's `func` reads `functions`, and its `#include`
    /// reads files if `includes`.
    pub(crate) fn load_dialect(
        mut input: Input,
        seed: Option<u64>,
        dialect: Dialect,
        names: OptionNames,
        functions: (&Arc<Functions>, bool),
    ) -> Result<LSystem, Error> {
        let cpfg = match dialect {
            Dialect::Cpfg => true,
            Dialect::Ls => false,
            Dialect::Auto => {
                // Read only as far as the first statement.
                let name = input.name.clone();
                let mut want = 1;
                loop {
                    let head = input.fill(want)?;
                    let complete = head.len() < want || head.len() >= SNIFF;
                    if let Some(cpfg) = crate::cpfg::sniff(&name, head, complete) {
                        break cpfg;
                    }
                    want = head.len() + 1;
                }
            }
        };
        if cpfg {
            return Self::load_cpfg(input, seed, names, functions);
        }
        let fresh = Random::fresh_seed();
        let split = split_header(&mut input)?;
        let path = input.name.clone();
        let system = compile(&path, &split, seed, fresh)?;
        Ok(LSystem {
            path,
            split,
            input: Some(input),
            text: None,
            axiom: None,
            file_seed: system.seed,
            warnings: Vec::new(),
            system: Some((system, seed)),
            fresh,
            cpfg: None,
        })
    }

    /// Read a cpfg `.l` file whole (at most the preprocessor's limit),
    /// preprocess, parse, lower and compile it.
    fn load_cpfg(
        mut input: Input,
        seed: Option<u64>,
        names: OptionNames,
        functions: (&Arc<Functions>, bool),
    ) -> Result<LSystem, Error> {
        let path = input.name.clone();
        let mut bytes = Vec::new();
        let limit = crate::cpfg::preprocess::MAX_FILE_SIZE as usize;
        loop {
            let n = input.fill(1 << 16)?.len();
            if n == 0 {
                break;
            }
            bytes.extend_from_slice(&input.available()[..n]);
            input.consume(n);
            if bytes.len() > limit {
                return Err(Error::about(
                    path,
                    crate::diag::LexicalError::FileTooLarge {
                        mib: limit as u64 >> 20,
                    },
                ));
            }
        }
        let bytes = bytes
            .strip_prefix(b"\xEF\xBB\xBF".as_slice())
            .unwrap_or(&bytes);
        let source = match std::str::from_utf8(bytes) {
            Ok(s) => s,
            Err(e) => {
                let at = e.valid_up_to();
                let text = String::from_utf8_lossy(&bytes[..at]).into_owned();
                let map = crate::diag::CodeMap::new(&text);
                return Err(Error::at(
                    crate::diag::Location::from_map(&path, &map, at),
                    crate::diag::LexicalError::InvalidUtf8,
                ));
            }
        };
        let (loaded, system) = crate::cpfg::load(&path, source, seed.is_some(), names, functions)?;
        Ok(LSystem {
            path,
            split: Split {
                header: String::new(),
                has_axiom: true,
                axiom_line: 1,
                axiom_col: 1,
            },
            input: None,
            text: None,
            axiom: None,
            file_seed: system.seed,
            warnings: Vec::new(),
            system: Some((system, seed)),
            fresh: 0,
            cpfg: Some(loaded),
        })
    }

    /// The compiled rules for `seed`.
    fn compile_system(&self, seed: Option<u64>) -> Result<System, Error> {
        match &self.cpfg {
            Some(c) => compile_cpfg(c, seed),
            None => compile(&self.path, &self.split, seed, self.fresh),
        }
    }

    #[cfg(feature = "cli")]
    /// The input's name, as error messages give it.
    pub(crate) fn path(&self) -> &str {
        &self.path
    }

    /// An error unless the file has an `axiom:` section.
    pub(crate) fn require_axiom(&self) -> Result<(), Error> {
        if self.split.has_axiom {
            return Ok(());
        }
        let header = &self.split.header;
        let end = header.trim_end().len();
        let kind = if header.trim().is_empty() {
            ParseError::EmptySystem
        } else {
            ParseError::MissingAxiom
        };
        Err(locate(&self.path, header, UserError::new((end, end), kind)))
    }

    #[cfg(feature = "cli")]
    /// Read the axiom from `input` (plain module text, no comments)
    /// instead of the file's `axiom:` section.
    pub(crate) fn set_axiom(&mut self, input: Input) {
        self.axiom = Some(input);
    }

    #[cfg(feature = "cli")]
    /// Numbers of productions and homomorphism productions.
    pub(crate) fn counts(&self) -> (usize, usize) {
        self.system.as_ref().map_or((0, 0), |(s, _)| {
            (s.productions.prods.len(), s.homomorphism.prods.len())
        })
    }

    /// Derive as a `.l` file with these settings would (tests of the
    /// engine's cpfg pieces on `.ls` texts).
    #[cfg(test)]
    pub(crate) fn as_cpfg(&mut self, run: crate::cpfg::run::CpfgRun) {
        if let Some((s, _)) = &mut self.system {
            s.cpfg = Some(Box::new(run));
        }
    }

    /// The compiled rules for `seed`, and the axiom reader's input.
    fn take(&mut self, seed: Option<u64>) -> Result<(System, Input, bool, usize, usize), Error> {
        let system = self.take_system(seed)?;
        let (input, comments, line, col) = self.take_input()?;
        Ok((system, input, comments, line, col))
    }

    /// The compiled rules for `seed` (those compiled for it, else compiled
    /// now).
    fn take_system(&mut self, seed: Option<u64>) -> Result<System, Error> {
        Ok(match self.system.take() {
            // A cpfg system draws no random constants: any seed will do
            // that agrees on whether the weights count.
            Some((s, with))
                if with == seed
                    || self
                        .cpfg
                        .as_ref()
                        .is_some_and(|c| weights_count(c, with) == weights_count(c, seed)) =>
            {
                s
            }
            _ => self.compile_system(seed)?,
        })
    }

    /// The axiom reader's input: a stream from
    /// [`from_reader`](LSystem::from_reader) can be taken once.
    fn take_input(&mut self) -> Result<(Input, bool, usize, usize), Error> {
        if let Some(a) = self.axiom.take() {
            return Ok((a, false, 1, 1));
        }
        if let Some(c) = &self.cpfg {
            let text = c.axiom.clone();
            let input = Input::new(Box::new(io::Cursor::new(text)), self.path.clone());
            return Ok((input, false, 1, 1));
        }
        let input = match (self.input.take(), &self.text) {
            (Some(i), _) => i,
            (None, Some(text)) => {
                let mut i = Input::new(Box::new(io::Cursor::new(text.clone())), "<input>");
                split_header(&mut i)?;
                i
            }
            (None, None) => return Err(Error::new(RuntimeError::AlreadyDerived)),
        };
        let (line, col) = (self.split.axiom_line, self.split.axiom_col);
        Ok((input, true, line, col))
    }

    /// Read the axiom, reporting its errors, and derive nothing (its
    /// warnings are not reported). The axiom of an `.ls` text from
    /// [`from_reader`](LSystem::from_reader) is streamed: once checked,
    /// it cannot be derived.
    pub fn check(&mut self) -> Result<(), Error> {
        let _silent = crate::diag::collect_warnings();
        self.check_axiom()
    }

    /// [`check`](LSystem::check), its warnings reported as
    /// [`crate::diag::warn`] does (the binary collects them).
    pub(crate) fn check_axiom(&mut self) -> Result<(), Error> {
        let (mut system, input, comments, line, col) = self.take(None)?;
        let consts = std::mem::take(&mut system.consts);
        let mut reader = AxiomReader::new(input, comments, line, col, &consts);
        let mut p = Vec::new();
        let mut rng = Random::new(0);
        loop {
            reader.plain_run(|_| {})?;
            if reader
                .next(&mut system.alphabet, &mut p, &mut rng)?
                .is_none()
            {
                break;
            }
        }
        drop(reader);
        system.consts = consts;
        self.system = Some((system, None));
        Ok(())
    }

    /// Derive and stream the final string, one line, into `out`.
    /// Generations in between live in temporary files, so memory does not
    /// grow with the string. Warnings and what a cpfg block's `printf`
    /// prints are not reported (nor written on standard error):
    /// [`derive_with`](LSystem::derive_with) reports them.
    pub fn derive(&mut self, options: &Options, out: impl Write) -> Result<Stats, Error> {
        // No one reads it: not kept until the end of the pass.
        let _unread = crate::diag::drop_printf();
        self.run(options, out, "output", false, &mut |_| {}, None)
    }

    /// [`derive`](LSystem::derive), calling `on_event` as each generation
    /// is complete (with its length), when a fixed point ends the steps
    /// early, and with each warning ([`Event::Warning`]): the file's, found
    /// when it was read, first (each derivation reports them again), then
    /// the derivation's own, each before the event of the generation it
    /// was found in; and with the text each `printf` of a cpfg block
    /// prints ([`Event::Printf`]), in its place among them (held until
    /// the event that follows it: past 1 MiB of such text, in a
    /// temporary file in [`Options::tmpdir`]'s directory, so that a model
    /// that prints at every module does not hold a step's text in
    /// memory). Asking for
    /// every generation's length may take the step-by-step strategy where
    /// depth first would do.
    ///
    /// ```
    /// // `step` is a built-in name: a parameter of that name hides it.
    /// let src = "productions:\nA(step) -> A(step+1)\naxiom: A(0)\n";
    /// let mut ls = lsgen::LSystem::parse(src)?;
    /// let mut warnings = Vec::new();
    /// ls.derive_with(&lsgen::Options::new(), Vec::new(), |e| {
    ///     if let lsgen::Event::Warning(w) = e {
    ///         warnings.push(w.to_string());
    ///     }
    /// })?;
    /// assert_eq!(
    ///     warnings,
    ///     ["<input>:2:3: warning: `step` hides the built-in step number\nA(step) -> A(step+1)\n  ^\n"]
    /// );
    /// # Ok::<(), lsgen::Error>(())
    /// ```
    pub fn derive_with(
        &mut self,
        options: &Options,
        out: impl Write,
        mut on_event: impl FnMut(&Event),
    ) -> Result<Stats, Error> {
        // Its events report `printf` text, also inside a `derive` (from
        // that one's writer), whose collection drops it.
        let _reported = (!options.print_warnings).then(crate::diag::keep_printf);
        self.run(options, out, "output", true, &mut on_event, None)
    }

    pub(crate) fn run(
        &mut self,
        options: &Options,
        out: impl Write,
        out_name: &str,
        lengths: bool,
        events: &mut dyn FnMut(&Event),
        frames: Option<(Frames, &mut dyn FrameSink)>,
    ) -> Result<Stats, Error> {
        if options.print_warnings {
            // The binary loaded the file with its own names, and its
            // warnings went to standard error then.
            return self.run_inner(options, out, out_name, lengths, events, frames);
        }
        // Warnings go to `events`: the file's first, then those found on
        // the way, and what cpfg's `printf` prints, each before the next
        // event (and the last ones at the end, whatever the outcome), the
        // warnings with the caller's option names.
        let collecting = crate::diag::collect_warnings();
        // (`printf` text past a bound waits in a file of its own.)
        collecting.spill_in(options.tmpdir.clone());
        let names = options.names;
        let mut forward = |event: Option<&Event>| {
            collecting.drain(&mut |said| {
                events(&match said {
                    Event::Warning(w) => Event::Warning(w.with_option_names(names)),
                    other => other,
                })
            });
            if let Some(e) = event {
                events(e);
            }
        };
        for w in &self.warnings {
            // `Options::seed` makes a `.l` file's weights count.
            let counted = options.seed.is_some()
                && matches!(w.kind(), WarningKind::ProbabilityWithoutSeed { .. });
            if !counted {
                forward(Some(&Event::Warning(w.clone().with_option_names(names))));
            }
        }
        let r = self.run_inner(
            options,
            out,
            out_name,
            lengths,
            &mut |e| forward(Some(e)),
            frames,
        );
        forward(None);
        r
    }

    fn run_inner(
        &mut self,
        options: &Options,
        mut out: impl Write,
        out_name: &str,
        lengths: bool,
        events: &mut dyn FnMut(&Event),
        frames: Option<(Frames, &mut dyn FrameSink)>,
    ) -> Result<Stats, Error> {
        if options.first_step == 0 {
            return Err(Error::new(UsageError::FirstStepZero));
        }
        let mut system = self.take_system(options.seed)?;
        let steps = match &frames {
            Some((f, _)) => f.last(),
            None => options
                .steps
                .or(system.derivation_length)
                .unwrap_or(DEFAULT_DERIVATION_LENGTH),
        };
        if options.first_step.checked_add(steps).is_none() {
            // A usage error: the axiom stream is still unread, and the
            // rules are kept for the next derivation.
            self.system = Some((system, options.seed));
            return Err(Error::new(UsageError::StepsOverflow {
                first: options.first_step,
                steps,
                names: options.names,
            }));
        }
        if let Some(dir) = options.tmpdir.as_ref().filter(|_| steps > 0) {
            // A directory where no temporary file can be made (not there,
            // not a directory, not writable, or one like /proc that takes
            // no files whatever its mode says) is found before the axiom
            // stream is taken, so that the next derivation can read it:
            // one file made there and dropped (an unnamed one where the
            // file system has them), about 6 µs. A stat, or `access`,
            // would miss the last two cases for root.
            if let Err(e) = tempfile::tempfile_in(dir) {
                self.system = Some((system, options.seed));
                return Err(crate::derive::tempfile_error(&options.tmpdir, e));
            }
        }
        let (input, comments, line, col) = self.take_input()?;
        let seed = options.seed.or(system.seed).unwrap_or(self.fresh);
        if let (Some(c), Some(s)) = (system.cpfg.as_mut(), options.seed) {
            // `--seed N` on a `.l` file: as if it said `seed: N`.
            c.seed = Some(s);
        }
        // A `.l` file seeds its generators only with a seed (`seed:` or
        // `--seed`); `seed` above then serves nothing.
        let seed_used = match &system.cpfg {
            Some(c) => c.seed,
            None => Some(seed),
        };
        // (Unit tests derive `.ls` texts as cpfg, `as_cpfg`: not these.)
        debug_assert!(
            system.cpfg.is_some() != self.cpfg.is_some() || seed_used == self.seed(options),
            "LSystem::seed"
        );
        // cpfg prints parameters with C's `%g`: 6 significant digits.
        // (`--precision` and the cpfg dialect's form are the alphabet's:
        // every strategy and frame writes its numbers in it.)
        let precision = options.precision.or(system.cpfg.is_some().then_some(6));
        let numbers = match precision {
            Some(digits) => Numbers::Significant {
                digits,
                c_exponent: system.cpfg.is_some(),
            },
            None => Numbers::Shortest,
        };
        let settings = Settings {
            steps,
            seed,
            homomorphism: options.homomorphism,
            limits: options.limits,
            tmpdir: options.tmpdir.clone(),
            lengths,
            strategy: options.strategy,
            first_step: options.first_step,
            space: options.space,
            threads: options.threads,
            split: options.split,
            direct: options.direct.clone(),
            numbers,
        };
        let consts = std::mem::take(&mut system.consts);
        let reader = AxiomReader::new(input, comments, line, col, &consts);
        let (modules, bytes) = derive(
            &settings,
            reader,
            &self.split.header,
            &self.path,
            system,
            (&mut out, out_name),
            events,
            frames,
        )
        .map_err(|e| e.with_option_names(options.names))?;
        Ok(Stats {
            seed: seed_used,
            steps,
            modules,
            bytes,
        })
    }

    /// The number of steps a derivation with `options` would take.
    #[cfg_attr(not(feature = "cli"), allow(dead_code))] // the progress display's
    pub(crate) fn steps(&self, options: &Options) -> u64 {
        let file = self.system.as_ref().and_then(|(s, _)| s.derivation_length);
        options.steps.or(file).unwrap_or(DEFAULT_DERIVATION_LENGTH)
    }

    /// The seed of the random generator of a derivation with `options`,
    /// as its [`Stats::seed`] reports it: [`Options::seed`], else the
    /// file's `seed:`, else for an `.ls` system the fresh seed drawn when
    /// it was read (every derivation of this `LSystem` without a seed
    /// uses that one); `None` for a cpfg `.l` system that neither
    /// `options` nor its file seeds (it uses no seed). The answer is the
    /// same before and after a derivation: the seed the next one uses,
    /// or for a system read from a stream (which derives once) the one
    /// its derivation used.
    pub fn seed(&self, options: &Options) -> Option<u64> {
        match (options.seed.or(self.file_seed), &self.cpfg) {
            (None, Some(_)) => None,
            (seed, _) => Some(seed.unwrap_or(self.fresh)),
        }
    }

    /// Use `seed` when neither the options nor the file give one, instead
    /// of a fresh one (for reproducible tests and fuzzing; the binary
    /// does not call it). Compiling again says nothing on standard error:
    /// the file's warnings were found when it was read.
    #[doc(hidden)]
    pub fn with_fallback_seed(mut self, seed: u64) -> Result<Self, Error> {
        self.fresh = seed;
        if let Some((_, with)) = self.system.take() {
            let _known = crate::diag::collect_warnings();
            self.system = Some((self.compile_system(with)?, with));
        }
        Ok(self)
    }
}

/// Bytes looked at to tell a cpfg file from an `.ls` one.
pub(crate) const SNIFF: usize = 1 << 16;

/// Do a cpfg file's production weights count, derived with `seed`
/// (`--seed`)? Only with a seed: without one cpfg never evaluates them.
fn weights_count(c: &crate::cpfg::Loaded, seed: Option<u64>) -> bool {
    seed.is_some() || c.seeded
}

/// Compile a loaded cpfg file again, to be derived with `seed` (`--seed`).
/// Where its weights do not count they are left out, unevaluated, as cpfg
/// leaves them: `A --> B : -1` is no error there.
fn compile_cpfg(c: &crate::cpfg::Loaded, seed: Option<u64>) -> Result<System, Error> {
    crate::cpfg::compile(c, seed.is_some())
}

/// Parse and compile the header of `split`.
fn compile(path: &str, split: &Split, seed: Option<u64>, fresh: u64) -> Result<System, Error> {
    let seeds = Seeds {
        command_line: seed,
        fallback: fresh,
    };
    // Each production is compiled as it is read (no whole syntax tree).
    compile_text(&split.header, seeds).map_err(|e| match e {
        LoadError::Parse(e) | LoadError::Compile(e) => locate(path, &split.header, e),
    })
}

/// Load an L-system from `src` and derive it in full into a byte vector
/// (temp files are still used between steps): for tests and fuzzing (the
/// binary does not call it). `steps`/`seed` override the file's settings;
/// without either seed, 0. Warnings and a cpfg block's `printf` text are
/// dropped, as [`LSystem::derive`] drops them: nothing is written on
/// standard error.
#[doc(hidden)]
pub fn derive_bytes(
    src: &[u8],
    steps: Option<u64>,
    seed: Option<u64>,
    limits: Limits,
) -> Result<Vec<u8>, Error> {
    derive_bytes_on(src, steps, seed, limits, (1, None))
}

/// [`derive_bytes`] on `threads` threads (`-j`), split into tasks of
/// `split` (modules per thread depth first, bytes step by step): for tests.
#[doc(hidden)]
pub fn derive_bytes_on(
    src: &[u8],
    steps: Option<u64>,
    seed: Option<u64>,
    limits: Limits,
    (threads, split): (usize, Option<u64>),
) -> Result<Vec<u8>, Error> {
    let input = Input::new(Box::new(io::Cursor::new(src.to_vec())), "<input>");
    let loading = crate::diag::collect_warnings();
    let mut ls = LSystem::load_named(input, seed)?.with_fallback_seed(0)?;
    ls.require_axiom()?;
    drop(loading);
    let mut options = Options::new().limits(limits).threads(threads);
    options.split = split;
    options.steps = steps;
    options.seed = seed;
    let mut out = Vec::new();
    ls.derive(&options, &mut out)?;
    Ok(out)
}
