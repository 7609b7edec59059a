//! The parser hands a header over piece by piece, in file order, as it
//! reduces it: the settings, then each section's start and its productions
//! one at a time, each in three parts: its head (what comes before `->`),
//! its successor in batches of at most [`BATCH`] modules, its end. A file
//! of millions of productions, or one successor of millions of modules, is
//! compiled as it is read (rules::Compiler) and never exists as a whole
//! syntax tree; tests and tools that want the tree collect it
//! ([`Collect`]).

use crate::lang::ast::{Expr, Header, Module, Production, Section, SectionSetting, Setting};
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

/// Successor modules handed over at once: a successor's modules cost
/// their syntax tree (about 50 bytes and more each) only this many at a
/// time, not for a whole line (a 64 MiB line of one-letter modules would
/// take gigabytes).
pub const BATCH: usize = 1024;

/// Receives a header in file order. `settings` comes exactly once, first;
/// then each section's `section`, followed by its productions, each as a
/// `head`, any number of `successor` batches and an `end`.
pub trait HeaderSink {
    fn settings(&mut self, settings: Vec<Setting>);
    fn section(&mut self, start: SectionStart);
    /// A production's head: `p` without its successor and probability
    /// (`succ` empty, `prob` none), `span` the head's (up to the `->`).
    fn head(&mut self, p: Production);
    /// The next modules of the successor of the production whose head came
    /// last, in order; the sink takes them (`modules` is left empty).
    fn successor(&mut self, modules: &mut Vec<Module>);
    /// The production's probability, and the span of its whole line.
    fn end(&mut self, prob: Option<Box<Expr>>, span: Span);

    /// A whole production, as the three parts above.
    fn production(&mut self, mut p: Production) {
        let mut succ = std::mem::take(&mut p.succ);
        let prob = p.prob.take();
        let span = p.span;
        self.head(p);
        self.successor(&mut succ);
        self.end(prob, span);
    }
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
    /// The current production's start and its successor modules not yet
    /// handed over (at most [`BATCH`]).
    start: usize,
    succ: Vec<Module>,
    /// The current production's head is wrong (a grammar error, reported
    /// at its end, so that a syntax error later on its line comes first):
    /// nothing of it goes to the sink.
    bad_head: Option<UserError>,
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
            start: 0,
            succ: Vec::new(),
            bad_head: None,
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

    /// A production's head (see [`HeaderSink::head`]).
    pub fn head(&mut self, p: Production) {
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
        self.start = p.span.0;
        self.sink.head(p);
    }

    /// A production's head that the grammar rejects: `error` is returned
    /// at the production's end.
    pub fn bad_head(&mut self, error: UserError) {
        self.bad_head = Some(error);
    }

    /// The next module of the current production's successor.
    pub fn successor(&mut self, m: Module) {
        if self.bad_head.is_some() {
            return;
        }
        self.succ.push(m);
        if self.succ.len() >= BATCH {
            self.sink.successor(&mut self.succ);
        }
    }

    /// The current production's end: its probability, and where its line
    /// ends (before the newline).
    pub fn end(&mut self, prob: Option<Box<Expr>>, end: usize) -> Result<(), UserError> {
        if let Some(e) = self.bad_head.take() {
            return Err(e);
        }
        if !self.succ.is_empty() {
            self.sink.successor(&mut self.succ);
        }
        self.sink.end(prob, (self.start, end));
        Ok(())
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
    /// The production being read.
    pending: Option<Production>,
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

    fn head(&mut self, p: Production) {
        self.pending = Some(p);
    }

    fn successor(&mut self, modules: &mut Vec<Module>) {
        let p = self.pending.as_mut().expect("a successor after its head");
        p.succ.append(modules);
    }

    fn end(&mut self, prob: Option<Box<Expr>>, span: Span) {
        let mut p = self.pending.take().expect("an end after its head");
        p.prob = prob;
        p.span = span;
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
