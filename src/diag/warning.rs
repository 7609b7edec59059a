//! The warnings: what each says ([`WarningKind`], one variant each, whose
//! `Display` is the message) and where ([`Warning`], rendered as an error
//! is, `FILE:LINE:COL: warning: `, the line and a caret). A derivation
//! hands them to its caller as [`crate::Event::Warning`]; the binaries
//! print them on standard error ([`super::warn`]).

use super::{Location, OptionNames};
use crate::derive::Pass;
use std::fmt;

/// What a warning says: the input was processed anyway.
#[derive(Clone, Debug, PartialEq, Eq)]
#[non_exhaustive]
pub enum WarningKind {
    /// cpfg preprocessor: a line starting with `#` and a symbol.
    HashModule,
    /// cpfg preprocessor: `#warning` with its text.
    UserDirective(String),
    /// cpfg preprocessor: `#pragma`.
    PragmaIgnored,
    /// cpfg preprocessor: tokens after a directive (as the message quotes
    /// it) that takes no more.
    ExtraTokens(String),
    /// cpfg preprocessor: a macro defined again.
    MacroRedefined(String),
    /// cpfg preprocessor: a `'` not closed on its line of text.
    UnterminatedCharConstant,
    /// cpfg: a name that is neither a parameter nor a variable (it is 0).
    NotDefined(String),
    /// cpfg: a probability in a file without `seed:`; `names`: whose
    /// name the message gives the seed's option.
    ProbabilityWithoutSeed { names: OptionNames },
    /// cpfg: a left context holding `[` or `]` (at this one), which never
    /// matches.
    LeftContextBracket,
    /// cpfg: a probability in a section (its name and a blank).
    ProbabilityInSection(&'static str),
    /// A parameter or constant named `step`.
    StepHidden,
    /// cpfg: a division by zero, which divides by 1 (given once per
    /// process, without a place).
    DivisionByZero,
    /// cpfg: an array subscript past its dimension, which reads or writes
    /// the nearest element (given once per process, without a place).
    SubscriptClamped,
    /// cpfg: an array's initial values, fewer or more than its elements
    /// (the name, how many given, how many elements).
    ArrayInitialisers {
        name: String,
        given: usize,
        size: u64,
    },
    /// Decomposition (in a step) or the homomorphism (in
    /// [`Pass::Homomorphism`]) reached its maximum depth with a production
    /// that still applies to this symbol.
    MaximumDepth {
        max: usize,
        symbol: char,
        pass: Pass,
    },
    /// lsgen-turtle: a label in a cpfg view file that cpfg does not know
    /// either (as written, colon included).
    CpfgViewLabel(String),
    /// lsgen-turtle: a cpfg view-file label that changes cpfg's picture
    /// but not lsgen-turtle's, and why.
    CpfgViewNotDrawn { label: String, why: &'static str },
    /// A cpfg view file's `tropism:` or `torque:` line that cpfg ignores
    /// (the label, and what the line has), or that lsgen does not follow
    /// cpfg on (`crash`: cpfg crashes on it or reads it otherwise; what
    /// the line does).
    CpfgMovementIgnored {
        label: String,
        why: &'static str,
        crash: bool,
    },
    /// A library derivation: cpfg `printf` text held in a temporary file
    /// could not be read back (why).
    PrintfLost(String),
    /// A library derivation: cpfg `printf` text past 1 MiB in one step
    /// could not go to a temporary file (why), and is held in memory.
    PrintfHeld(String),
    /// Reading one file (the cpfg preprocessor's, a cpfg view file's)
    /// found this many more warnings after its first
    /// [`MAX_FILE_WARNINGS`], from here on: not kept, not shown.
    MoreWarnings(u64),
}

/// Most warnings one file's reading keeps (the cpfg preprocessor's, a
/// cpfg view file's), then one [`WarningKind::MoreWarnings`] counts the
/// rest: a file of a million lines that each warn would otherwise hold
/// (and print) a million located warnings, each with its line.
pub const MAX_FILE_WARNINGS: usize = 100;

/// The warnings of one file's reading: the first [`MAX_FILE_WARNINGS`],
/// then, at the first one past them, one [`WarningKind::MoreWarnings`]
/// counting the rest (whose places are never worked out).
pub(crate) struct FileWarnings<W> {
    kept: Vec<W>,
    more: u64,
    more_at: Option<Location>,
}

impl<W> FileWarnings<W> {
    pub(crate) fn new() -> Self {
        FileWarnings {
            kept: Vec::new(),
            more: 0,
            more_at: None,
        }
    }

    /// A warning at `at` (asked for only if it is kept or the first past
    /// the limit), made by `make`.
    pub(crate) fn push(&mut self, at: impl FnOnce() -> Location, make: impl FnOnce(Location) -> W) {
        if self.kept.len() < MAX_FILE_WARNINGS {
            self.kept.push(make(at()));
        } else {
            if self.more == 0 {
                self.more_at = Some(at());
            }
            self.more += 1;
        }
    }

    /// The warnings kept, and the count of the others at the end (`make`
    /// makes it a `W`).
    pub(crate) fn finish(mut self, make: impl FnOnce(Location, WarningKind) -> W) -> Vec<W> {
        if let Some(at) = self.more_at.take() {
            self.kept
                .push(make(at, WarningKind::MoreWarnings(self.more)));
        }
        self.kept
    }
}

impl fmt::Display for WarningKind {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        use WarningKind::*;
        match self {
            HashModule => {
                f.write_str("`#` followed by a symbol is taken as a module, not a directive")
            }
            UserDirective(m) => write!(f, "#warning {m}"),
            PragmaIgnored => f.write_str("#pragma ignored"),
            ExtraTokens(directive) => write!(f, "extra tokens after `{directive}` ignored"),
            MacroRedefined(name) => write!(f, "macro `{name}` redefined"),
            UnterminatedCharConstant => f.write_str(
                "unterminated character constant: the rest of the line is kept as it is, without macro expansion, as vlabcpp does",
            ),
            NotDefined(name) => write!(f, "`{name}` is not defined: it is 0 here, as in cpfg"),
            ProbabilityWithoutSeed { names } => write!(
                f,
                "a probability without `seed:` is ignored, as in cpfg (the first applicable production applies; {} makes it count)",
                match names {
                    OptionNames::Library => "`seed(N)`",
                    OptionNames::CommandLine => "`--seed`",
                }
            ),
            LeftContextBracket => f.write_str(
                "a left context with `[` or `]` never matches, as in cpfg (its matcher passes over the string's brackets): this production never applies",
            ),
            ProbabilityInSection(section) => write!(
                f,
                "a probability in the {section}section is ignored, as in cpfg (the first applicable {section}production applies)"
            ),
            StepHidden => f.write_str("`step` hides the built-in step number"),
            DivisionByZero => f.write_str(
                "division by zero in a cpfg expression: divided by 1 instead, as cpfg does",
            ),
            SubscriptClamped => f.write_str(
                "an array subscript out of range: the nearest element is used instead, as cpfg does",
            ),
            ArrayInitialisers { name, given, size } if (*given as u64) < *size => write!(
                f,
                "too few initial values for `{name}`: {given} for {size} elements (the others are 0, as in cpfg)"
            ),
            ArrayInitialisers { name, given, size } => write!(
                f,
                "too many initial values for `{name}`: {given} for {size} elements (the rest are ignored, as in cpfg)"
            ),
            MaximumDepth { max, symbol, pass } => match pass {
                Pass::Step(k) => write!(
                    f,
                    "decomposition stopped at maximum depth {max}, but this production still applies (to module {symbol}, in step {k})"
                ),
                _ => write!(
                    f,
                    "homomorphism stopped at maximum depth {max}, but this production still applies (to module {symbol})"
                ),
            },
            CpfgViewLabel(label) => write!(
                f,
                "`{label}` is no label of cpfg's view files (as cpfg, lsgen-turtle skips the line)"
            ),
            CpfgViewNotDrawn { label, why } => write!(f, "`{label}` ignored: {why}"),
            CpfgMovementIgnored { label, why, crash } => {
                if *crash {
                    write!(
                        f,
                        "`{label}` ignored: lsgen does not follow cpfg on a movement line that {why}"
                    )
                } else {
                    write!(f, "`{label}` ignored: cpfg ignores a movement with {why}")
                }
            }
            PrintfHeld(why) => write!(
                f,
                "text that cpfg's `printf` prints past 1 MiB in a step is held in memory: no temporary file could take it ({why})"
            ),
            PrintfLost(why) => write!(
                f,
                "text that cpfg's `printf` printed is lost: it was held in a temporary file that could not be read back ({why})"
            ),
            MoreWarnings(n) => write!(
                f,
                "{} more {} from here on not shown (a file's first {MAX_FILE_WARNINGS} are)",
                super::group_digits(*n),
                if *n == 1 { "warning" } else { "warnings" }
            ),
        }
    }
}

impl WarningKind {
    /// The same warning, naming the options it mentions by `names`.
    pub(crate) fn with_option_names(mut self, names: OptionNames) -> WarningKind {
        if let WarningKind::ProbabilityWithoutSeed { names: n } = &mut self {
            *n = names;
        }
        self
    }
}

/// A warning: what it says ([`kind`](Warning::kind)) and where in the
/// source, if it has a place. `Display` renders it as an [`Error`] is,
/// without a program's name: `FILE:LINE:COL: warning: message`, the source
/// line and a caret (`warning: message` without a place).
///
/// [`Error`]: super::Error
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Warning {
    kind: WarningKind,
    location: Option<Location>,
}

impl Warning {
    pub(crate) fn new(kind: WarningKind, location: Option<Location>) -> Warning {
        Warning { kind, location }
    }

    /// What it says.
    pub fn kind(&self) -> &WarningKind {
        &self.kind
    }

    /// Where in the source, if anywhere.
    pub fn location(&self) -> Option<&Location> {
        self.location.as_ref()
    }

    /// The message alone, without its place.
    pub fn message(&self) -> String {
        self.kind.to_string()
    }

    /// The same warning, naming the options it mentions by `names`.
    pub(crate) fn with_option_names(self, names: OptionNames) -> Warning {
        Warning {
            kind: self.kind.with_option_names(names),
            location: self.location,
        }
    }
}

impl fmt::Display for Warning {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match &self.location {
            Some(l) => super::render_at(f, l, "warning", &self.message()),
            None => writeln!(f, "warning: {}", self.kind),
        }
    }
}
