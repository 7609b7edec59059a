//! The warnings, one variant each; `Display` writes the message that
//! [`super::warn`] shows after `FILE:LINE:COL: warning: `. Warnings go to
//! standard error only (no API hands them to a library user), so the enum
//! is the crate's own.

use crate::derive::Pass;
use std::fmt;

/// A warning: the input was processed anyway.
#[derive(Clone, Debug, PartialEq)]
pub(crate) enum Warning {
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
    /// cpfg: a probability in a file without `seed:`.
    ProbabilityWithoutSeed,
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
    /// Decomposition (in a step) or the homomorphism (in
    /// [`Pass::Homomorphism`]) reached its maximum depth with a production
    /// that still applies to this symbol.
    MaximumDepth {
        max: usize,
        symbol: char,
        pass: Pass,
    },
}

impl fmt::Display for Warning {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        use Warning::*;
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
            ProbabilityWithoutSeed => f.write_str(
                "a probability without `seed:` is ignored, as in cpfg (the first applicable production applies; `--seed` makes it count)",
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
        }
    }
}
