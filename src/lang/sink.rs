//! The parser hands a header over piece by piece, in file order, as it
//! reduces it: the settings, then each section's start and its productions
//! one at a time, each in three parts: its head (what comes before `->`)
//! module by module, its successor in batches of at most [`BATCH`]
//! modules, its end. A file of millions of productions, or one context or
//! successor of millions of modules, is compiled as it is read
//! (rules::Compiler) and never exists as a whole syntax tree; tests and
//! tools that want the tree collect it ([`Collect`]).

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

/// Which part of a production's head a module belongs to.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum HeadPart {
    Left,
    /// The (strict) predecessor: exactly one per head.
    Pred,
    /// The rest of a predecessor of several modules (cpfg dialect).
    Rest,
    Right,
}

/// Receives a header in file order. `settings` comes exactly once, first;
/// then each section's `section`, followed by its productions, each as
/// its head's modules (`head_module`, in text order: left context,
/// predecessor, its rest, right context) and `head_end`, any number of
/// `successor` batches and an `end`. A head that turns out wrong (two
/// modules where the predecessor goes) gets no `head_end`: the parse stops
/// with that error at the production's end.
pub trait HeaderSink {
    fn settings(&mut self, settings: Vec<Setting>);
    fn section(&mut self, start: SectionStart);
    /// The next module of a production's head; a long context is handed
    /// over as it is read, never held whole.
    fn head_module(&mut self, part: HeadPart, m: Module);
    /// The head is complete: its condition, and `span` the head's (up to
    /// the `->`).
    fn head_end(&mut self, cond: Option<Box<Expr>>, span: Span);
    /// The next modules of the successor of the production whose head came
    /// last, in order; the sink takes them (`modules` is left empty).
    fn successor(&mut self, modules: &mut Vec<Module>);
    /// The production's probability, and the span of its whole line.
    fn end(&mut self, prob: Option<Box<Expr>>, span: Span);

    /// A whole production, as the parts above.
    fn production(&mut self, p: Production) {
        let Production {
            left,
            pred,
            pred_rest,
            right,
            cond,
            mut succ,
            prob,
            span,
        } = p;
        let parts = [
            (HeadPart::Left, left),
            (HeadPart::Pred, vec![pred]),
            (HeadPart::Rest, pred_rest),
            (HeadPart::Right, right),
        ];
        for (part, modules) in parts {
            for m in modules {
                self.head_module(part, m);
            }
        }
        self.head_end(cond, span);
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
    /// nothing more of it goes to the sink.
    bad_head: Option<UserError>,
    head: HeadState,
}

/// Where the parser is in a production's head, and what the checks need of
/// it: its modules go on to the sink as they come, so that a context of
/// millions of modules is never held whole.
#[derive(Default)]
struct HeadState {
    /// The list the next module belongs to: `None` for the one the head
    /// starts with (the left context if a `<` follows, else the
    /// predecessor), `Pred` after a `<`, `Right` after a `>`.
    part: Option<HeadPart>,
    /// The first list's first module, until it is known to be the left
    /// context (a `<` or a second module follows) or the predecessor.
    held: Option<Module>,
    /// Modules so far in the current list.
    count: usize,
    /// From the current list's second module to its last: where a
    /// predecessor of several modules is reported.
    extra: Option<Span>,
    /// Such a predecessor, found.
    several: Option<Span>,
    left_end: Option<usize>,
    pred: Option<Span>,
    right_start: Option<usize>,
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
            head: HeadState::default(),
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

    /// The next module of a production's head.
    pub fn head_module(&mut self, m: Module) {
        let h = &mut self.head;
        h.count += 1;
        if h.count >= 2 {
            h.extra = Some((h.extra.map_or(m.span.0, |e| e.0), m.span.1));
        }
        match h.part {
            None if h.count == 1 => h.held = Some(m),
            None => {
                if let Some(first) = h.held.take() {
                    self.left(first);
                }
                self.left(m);
            }
            Some(HeadPart::Pred) => {
                // A second module is reported at the head's end.
                if h.count == 1 {
                    h.pred = Some(m.span);
                    self.sink.head_module(HeadPart::Pred, m);
                }
            }
            Some(_) => {
                h.right_start.get_or_insert(m.span.0);
                self.sink.head_module(HeadPart::Right, m);
            }
        }
    }

    fn left(&mut self, m: Module) {
        self.head.left_end = Some(m.span.1);
        self.sink.head_module(HeadPart::Left, m);
    }

    /// A `<`: the modules before it are the left context.
    pub fn head_lt(&mut self) {
        if let Some(first) = self.head.held.take() {
            self.left(first);
        }
        let h = &mut self.head;
        (h.part, h.count, h.extra) = (Some(HeadPart::Pred), 0, None);
    }

    /// A `>`: the predecessor is complete.
    pub fn head_gt(&mut self) {
        self.pred_done();
        let h = &mut self.head;
        (h.part, h.count, h.extra) = (Some(HeadPart::Right), 0, None);
    }

    /// The list that holds the predecessor is over: it must be one module.
    fn pred_done(&mut self) {
        let h = &mut self.head;
        if let Some(m) = h.held.take() {
            h.pred = Some(m.span);
            self.sink.head_module(HeadPart::Pred, m);
        }
        let h = &mut self.head;
        h.several = h.several.or(h.extra.take());
    }

    /// The head is complete (`span` up to the `->`).
    pub fn head_end(&mut self, cond: Option<Box<Expr>>, span: Span) {
        if self.head.part != Some(HeadPart::Right) {
            self.pred_done();
        }
        let h = std::mem::take(&mut self.head);
        if let Some(at) = h.several {
            // Reported at the line's end, after any syntax error in it.
            self.bad_head = Some(UserError::new(
                at,
                crate::diag::ParseError::PredecessorIsOneModule,
            ));
            return;
        }
        let pred = h.pred.expect("a head has a predecessor");
        if self.section == SectionKind::Decomposition && self.context.is_none() {
            self.context = if let Some(end) = h.left_end {
                Some(Context {
                    from: end,
                    to: pred.0,
                    delim: '<',
                    fallback: pred.0,
                })
            } else {
                h.right_start.map(|start| Context {
                    from: pred.1,
                    to: start,
                    delim: '>',
                    fallback: pred.0,
                })
            };
        }
        self.start = span.0;
        self.sink.head_end(cond, span);
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
    /// The head being read: its left context, predecessor, rest and right
    /// context.
    head: (Vec<Module>, Option<Module>, Vec<Module>, Vec<Module>),
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

    fn head_module(&mut self, part: HeadPart, m: Module) {
        let h = &mut self.head;
        match part {
            HeadPart::Left => h.0.push(m),
            HeadPart::Pred => h.1 = Some(m),
            HeadPart::Rest => h.2.push(m),
            HeadPart::Right => h.3.push(m),
        }
    }

    fn head_end(&mut self, cond: Option<Box<Expr>>, span: Span) {
        let (left, pred, pred_rest, right) = std::mem::take(&mut self.head);
        self.pending = Some(Production {
            left,
            pred: pred.expect("a head has a predecessor"),
            pred_rest,
            right,
            cond,
            succ: Vec::new(),
            prob: None,
            span,
        });
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
