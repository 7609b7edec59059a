//! The parser hands a header over piece by piece, in file order, as it
//! reduces it: the settings, then each section's start and its productions
//! one at a time. A file of millions of productions is compiled as it is
//! read (rules::Compiler) and never exists as a whole syntax tree; tests and
//! tools that want the tree collect it ([`Collect`]).

use crate::lang::ast::{Header, Production, Section, SectionSetting, Setting};
use crate::lang::lexer::Span;
use crate::lang::parse::UserError;

/// Which section a production belongs to.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SectionKind {
    /// `productions:` (0) or `productions N:`.
    Group(u32),
    Decomposition,
    Homomorphism,
}

/// A section keyword line and its options (`maximum depth:`, `seed:`).
#[derive(Clone, Debug, PartialEq)]
pub struct SectionStart {
    pub kind: SectionKind,
    /// The keyword line.
    pub span: Span,
    pub warnings: bool,
    pub settings: Vec<SectionSetting>,
}

/// Receives a header in file order. `settings` comes exactly once, first;
/// then each section's `section`, followed by its productions.
pub trait HeaderSink {
    fn settings(&mut self, settings: Vec<Setting>);
    fn section(&mut self, start: SectionStart);
    fn production(&mut self, p: Production);
}

/// What the grammar's actions call: passes the header on to a sink and
/// keeps the checks that need more than one production (a group declared
/// twice, a decomposition production with a context), to report them where
/// the whole-tree parser did (after every syntax error).
pub struct Reader<'s> {
    sink: &'s mut dyn HeaderSink,
    section: SectionKind,
    /// The groups declared so far (a set: up to 65,536 of them).
    seen: std::collections::HashSet<u32>,
    twice: Option<UserError>,
    /// The first decomposition production with a context: where to look
    /// for its `<` (or `>`), and where to point if it is not found.
    context: Option<Context>,
}

/// Where a decomposition production's context delimiter is.
#[derive(Clone, Copy, Debug)]
pub struct Context {
    /// Search `text[from..to]` for `delim`.
    pub from: usize,
    pub to: usize,
    pub delim: char,
    /// The predecessor's start, if the delimiter is not found.
    pub fallback: usize,
}

/// What the reader found after the last production.
#[derive(Debug)]
pub struct Finish {
    pub context: Option<Context>,
}

impl<'s> Reader<'s> {
    pub fn new(sink: &'s mut dyn HeaderSink) -> Reader<'s> {
        Reader {
            sink,
            section: SectionKind::Group(0),
            seen: std::collections::HashSet::new(),
            twice: None,
            context: None,
        }
    }

    pub fn settings(&mut self, settings: Vec<Setting>) {
        self.sink.settings(settings);
    }

    pub fn section(&mut self, start: SectionStart) {
        if let SectionKind::Group(n) = start.kind {
            if !self.seen.insert(n) && self.twice.is_none() {
                self.twice = Some(UserError::new(
                    start.span,
                    crate::diag::ParseError::GroupDeclaredTwice(n),
                ));
            }
        }
        self.section = start.kind;
        self.sink.section(start);
    }

    pub fn production(&mut self, p: Production) {
        if self.section == SectionKind::Decomposition && self.context.is_none() {
            self.context = if let Some(l) = p.left.last() {
                Some(Context {
                    from: l.span.1,
                    to: p.pred.span.0,
                    delim: '<',
                    fallback: p.pred.span.0,
                })
            } else {
                p.right.first().map(|r| Context {
                    from: p.pred.span.1,
                    to: r.span.0,
                    delim: '>',
                    fallback: p.pred.span.0,
                })
            };
        }
        self.sink.production(p);
    }

    /// At the end of the header: a group declared twice is an error of the
    /// grammar.
    pub fn finish(&mut self) -> Result<Finish, UserError> {
        match self.twice.take() {
            Some(e) => Err(e),
            None => Ok(Finish {
                context: self.context,
            }),
        }
    }
}

impl Context {
    /// The error, located in the header text.
    pub fn error(&self, text: &str) -> UserError {
        let at = text
            .get(self.from..self.to)
            .and_then(|s| s.find(self.delim))
            .map_or(self.fallback, |i| self.from + i);
        UserError::new((at, at + 1), crate::diag::ParseError::DecompositionContext)
    }
}

/// A sink that builds the whole syntax tree.
#[derive(Default)]
pub struct Collect {
    pub header: Header,
    section: Option<SectionKind>,
}

impl HeaderSink for Collect {
    fn settings(&mut self, settings: Vec<Setting>) {
        self.header.settings = settings;
    }

    fn section(&mut self, start: SectionStart) {
        let h = &mut self.header;
        match start.kind {
            // A group declared twice is an error: its productions may go
            // anywhere.
            SectionKind::Group(0) => {}
            SectionKind::Group(n) => h.groups.push((n, start.span, Vec::new())),
            SectionKind::Decomposition | SectionKind::Homomorphism => {
                let s = Section {
                    span: start.span,
                    warnings: start.warnings,
                    settings: start.settings,
                    productions: Vec::new(),
                };
                if start.kind == SectionKind::Decomposition {
                    h.decomposition = Some(s);
                } else {
                    h.hom = Some(s);
                }
            }
        }
        self.section = Some(start.kind);
    }

    fn production(&mut self, p: Production) {
        let p = p.compact();
        let h = &mut self.header;
        match self.section {
            Some(SectionKind::Group(0)) | None => h.productions.push(p),
            Some(SectionKind::Group(_)) => h.groups.last_mut().unwrap().2.push(p),
            Some(SectionKind::Decomposition) => {
                h.decomposition.as_mut().unwrap().productions.push(p);
            }
            Some(SectionKind::Homomorphism) => h.homomorphism.push(p),
        }
    }
}
