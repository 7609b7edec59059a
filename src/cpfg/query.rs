//! cpfg's turtle queries `?P`, `?H`, `?L` and `?U` (cpfg's
//! `InterpretSymbol`, `interpret.c`; `ProcessEnvironment`, `control.c`).
//!
//! A query is two modules, as in cpfg: `?` and the module after it,
//! `P(x,y,z)` (position), `H` (heading), `L` (left) or `U` (up). Before
//! a step rewrites a string, cpfg interprets the whole string with its
//! turtle and writes, at each `?`, the turtle's vector into the first
//! (at most three) parameters of the next module, as floats; the final
//! string is interpreted once more before it is saved (its view volume).
//! lsgen does the same on each generation as soon as it is written
//! ([`fill`]): the generation's temporary file is read once, from its
//! start, and the parameters of its query modules are written over in
//! place. Memory is the turtle's branch stack.
//!
//! The turtle is cpfg's, operation for operation, in cpfg's arithmetic
//! (doubles for the vectors, floats where cpfg keeps floats: the angle,
//! lengths, elasticity, the tropism's direction), so that the values are
//! those cpfg writes to the last bit a float keeps. What it follows:
//! `F` `G` `f` `g` (moves, then cpfg's tropism bend), `+` `-` `&` `^` `/`
//! `\` `|` (turns), `[` `]`, `_` (elasticity), `%` (with `interpretation
//! past %: off`, the rest of the branch is skipped), `@v` and `@M`, and
//! cpfg's movements (the view's `tropism:` and `torque:`, `@T`:
//! `crate::turtle::movements`, whose sums go on from one fill to the
//! next, as cpfg's from one interpretation to the next). Every
//! other module leaves the turtle as it is; what would move it in cpfg
//! and is not followed here (`~`, other `@` modules, ten movements) is
//! refused when the file is loaded (`check`), or where the turtle meets
//! it in an axiom given apart.
//!
//! cpfg's turtle reads the string through the homomorphism: each module
//! is replaced by its homomorphism successor, whose modules go through
//! it in turn (to `maximum depth:`). A homomorphism that cannot move the
//! turtle (nothing moving in a predecessor, nor outside a successor's
//! branches) is not followed: the turtle ends where cpfg's does. One
//! that can is followed by reading its image ([`fill_through`]): the
//! engine's homomorphism pass writes the generation's image to a
//! temporary file, the turtle walks the image, and the values of its
//! k-th query go to the k-th query of the generation (the homomorphism
//! keeps each `?`, and adds none). What that reading cannot follow is
//! refused (`homomorphism_refused`): blocks, probabilities and draws
//! (cpfg evaluates them at each interpretation), a predecessor with
//! `[ ] ? @ % $ ~`, a `?` in a successor, `%` or `$` outside a
//! successor's branches, unbalanced brackets, and a production for a
//! module that a `?` or an `@` reads (cpfg reads it from the string, past
//! the homomorphism).

use super::ast::{AxiomPiece, Expr, Lsystem, Production};
use crate::diag::{Error, Refused, RuntimeError};
use crate::lang::lexer::Span;
use crate::rules::{codec, Alphabet};
use crate::turtle::cpfg_view::CpfgTurtle;
use crate::turtle::movements::{with_frame, Frame, Movements, Moving};
use crate::turtle::state::{bend_cpfg, cross, dot, turn, V3};
use std::fs::File;
use std::os::unix::fs::FileExt;

/// The view file's settings as cpfg's turtle computes with them.
#[derive(Clone, Debug)]
pub struct QueryTurtle {
    sin_a: f64,
    cos_a: f64,
    /// The tropism's direction, of length 1 as cpfg makes it (in floats).
    tropism: V3,
    elasticity: f32,
    elasticity_increment: f32,
    scale: f32,
    past_cut: bool,
    /// The last generation's queries are filled too
    /// ([`CpfgTurtle::fills_last`]).
    pub fills_last: bool,
    /// The homomorphism can move the turtle: each generation is filled
    /// through its image ([`fill_through`]).
    pub through: bool,
    /// cpfg's movements of the view file, as it reads them (none: empty):
    /// each run takes a copy of its own ([`QueryTurtle::movements`]).
    movements: Option<Movements>,
}

/// Degrees to radians as cpfg's `D_TO_R` computes it (times pi, then
/// divided: not times pi/180, which rounds differently).
#[inline]
fn radians(deg: f64) -> f64 {
    deg * std::f64::consts::PI / 180.0
}

impl QueryTurtle {
    /// A run's movements (the view's, their sums as cpfg makes them when
    /// it reads the view), to go from fill to fill; empty without
    /// movement lines (cpfg's `@Tp` and `@Tf` still turn the turtle).
    /// None only with ten, which `check` refuses.
    pub fn movements(&self) -> Option<Movements> {
        self.movements.clone()
    }

    pub fn new(v: &CpfgTurtle) -> QueryTurtle {
        let a = radians(f64::from(v.angle));
        // cpfg: `temp_length = sqrt(x*x + y*y + z*z)` with float x, y, z
        // (float sums), kept as a float; each component divided by it in
        // floats.
        let [x, y, z] = v.tropism;
        let len = f64::from(x * x + y * y + z * z).sqrt() as f32;
        QueryTurtle {
            sin_a: a.sin(),
            cos_a: a.cos(),
            tropism: [f64::from(x / len), f64::from(y / len), f64::from(z / len)],
            elasticity: v.elasticity,
            elasticity_increment: v.elasticity_increment,
            scale: v.scale,
            past_cut: v.past_cut,
            fills_last: v.fills_last,
            through: false,
            // (None only with ten, which `check` refuses first.)
            movements: Movements::new(v.movements.clone()).ok(),
        }
    }
}

#[derive(Clone, Copy)]
struct State {
    pos: V3,
    h: V3,
    l: V3,
    u: V3,
    /// cpfg's `prev_heading` and `prev_up`: the frame at the last `F` or
    /// `G` (for its movements, `crate::turtle::movements`).
    prev_h: V3,
    prev_u: V3,
    e: f32,
}

/// Why the turtle stopped.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum QueryFault {
    /// cpfg's bend: elasticity × (T·U) or (T·L) past ±1, no angle (cpfg's
    /// turtle becomes NaN).
    BendPastRightAngle,
    /// cpfg's movements overflowed ([`crate::turtle::movements::Moving::adjust`]).
    MovementOverflow,
    /// A vector a query would give is past the largest number.
    NotFinite,
    /// Branches nested deeper than [`MAX_DEPTH`]: the turtle keeps a
    /// state for each open one.
    TooDeep,
    /// A `?` followed by another module (a production rewrote its query
    /// module), or at the end of the string (None): cpfg warns and skips
    /// the module after it.
    NotAQuery(Option<char>),
    /// A module that moves cpfg's turtle and that this turtle does not
    /// follow (what it is).
    NotFollowed(&'static str),
    /// The module a `?` or `@` reads has a homomorphism production, with
    /// a homomorphism the turtle follows ([`fill_through`]).
    ReadPastHomomorphism(char),
}

/// The deepest nesting of branches the turtle follows (as lsgen-turtle's):
/// a state of 152 bytes for each open branch, and 8 more for each of cpfg's
/// movements: 224 MiB at most.
pub const MAX_DEPTH: usize = crate::turtle::state::MAX_DEPTH;

struct Walker<'q> {
    q: &'q QueryTurtle,
    s: State,
    stack: Vec<State>,
    /// cpfg's movements (the run's; empty without movement lines).
    mv: Option<Moving<&'q mut Movements>>,
}

impl<'q> Walker<'q> {
    /// The turtle at the start of an interpretation; cpfg's movements
    /// (`mv`, the run's: their sums go on from one interpretation to the
    /// next) start again from the view's elasticities.
    fn new(q: &'q QueryTurtle, mv: Option<&'q mut Movements>) -> Walker<'q> {
        Walker {
            q,
            s: State {
                pos: [0.0; 3],
                h: [0.0, 1.0, 0.0],
                l: [-1.0, 0.0, 0.0],
                u: [0.0, 0.0, -1.0],
                prev_h: [0.0, 1.0, 0.0],
                prev_u: [0.0, 0.0, -1.0],
                e: q.elasticity,
            },
            stack: Vec::new(),
            mv: mv.map(Moving::start),
        }
    }

    /// Run `g` on the turtle's frame with its movements, if any.
    fn moving<R>(
        &mut self,
        g: impl FnOnce(&mut Moving<&'q mut Movements>, &mut Frame) -> R,
    ) -> Option<R> {
        let s = &mut self.s;
        let m = self.mv.as_mut()?;
        let v = [&mut s.h, &mut s.l, &mut s.u, &mut s.prev_h, &mut s.prev_u];
        Some(with_frame(v, |f| g(m, f)))
    }

    fn sin_cos(&self, p: &[f64]) -> (f64, f64) {
        match p.first() {
            Some(&d) => radians(d).sin_cos(),
            None => (self.q.sin_a, self.q.cos_a),
        }
    }

    /// cpfg's `bend`, after each move.
    fn bend(&mut self) -> Result<(), QueryFault> {
        if self.s.e == 0.0 {
            return Ok(());
        }
        let st = &mut self.s;
        bend_cpfg(
            (&mut st.h, &mut st.l, &mut st.u),
            f64::from(st.e),
            self.q.tropism,
        )
        .map_err(|()| QueryFault::BendPastRightAngle)
    }

    /// One module `sym(p)` (not `?`, `@` or what follows them).
    fn module(&mut self, sym: char, p: &[f64]) -> Result<(), QueryFault> {
        let st = &mut self.s;
        match sym {
            'F' | 'G' | 'f' | 'g' => {
                // cpfg's movements turn the turtle before the move.
                if let Some(Err(())) = self.moving(|m, f| m.adjust(f)) {
                    return Err(QueryFault::MovementOverflow);
                }
                let st = &mut self.s;
                // cpfg: `internodeLength` is a float, the parameter (or
                // the step size, 1) times the turtle's scale.
                let d = p.first().map_or(1.0, |&x| x as f32) * self.q.scale;
                let d = f64::from(d);
                st.pos[0] += d * st.h[0];
                st.pos[1] += d * st.h[1];
                st.pos[2] += d * st.h[2];
                self.bend()?;
                if matches!(sym, 'F' | 'G') {
                    let st = &mut self.s;
                    (st.prev_h, st.prev_u) = (st.h, st.u);
                }
            }
            '+' | '-' | '&' | '^' | '/' | '\\' | '|' => {
                let (s, c) = self.sin_cos(p);
                let st = &mut self.s;
                turn(sym, (&mut st.h, &mut st.l, &mut st.u), s, c);
            }
            '[' => {
                if self.stack.len() >= MAX_DEPTH {
                    return Err(QueryFault::TooDeep);
                }
                self.stack.push(self.s);
                if let Some(m) = &mut self.mv {
                    m.open();
                }
            }
            // (An unmatched `]`: the engine reports the string's balance.)
            ']' => {
                if let Some(s) = self.stack.pop() {
                    self.s = s;
                    if let Some(m) = &mut self.mv {
                        m.close();
                    }
                }
            }
            '_' => {
                st.e = match p.first() {
                    Some(&e) => e as f32,
                    None => st.e + self.q.elasticity_increment,
                }
            }
            _ => {}
        }
        Ok(())
    }

    /// `@T` followed by the subfunction `sub(p)`: cpfg's movements.
    fn at_t(&mut self, sub: char, p: &[f64]) -> Result<(), QueryFault> {
        match self.moving(|m, f| m.at_t(sub, p, f)) {
            Some(Err(())) => Err(QueryFault::NotFollowed(
                "`@T` with a movement number past a C `short`",
            )),
            _ => Ok(()),
        }
    }

    /// `@` followed by `sym(p)`.
    fn at_module(&mut self, sym: char, p: &[f64]) {
        let st = &mut self.s;
        match sym {
            'v' if st.h[1] < 1.0 && st.h[1] > -1.0 => {
                let mut l = cross([0.0, 1.0, 0.0], st.h);
                let n = dot(l, l).sqrt();
                if n != 0.0 {
                    let r = 1.0 / n;
                    l = [l[0] * r, l[1] * r, l[2] * r];
                }
                st.l = l;
                st.u = cross(l, st.h);
            }
            'M' if p.len() >= 2 => {
                st.pos = [p[0], p[1], p.get(2).copied().unwrap_or(0.0)];
            }
            _ => {}
        }
    }

    /// The vector a query module `sym` reads, if it is one.
    fn query(&self, sym: char) -> Option<V3> {
        match sym {
            'P' => Some(self.s.pos),
            'H' => Some(self.s.h),
            'L' => Some(self.s.l),
            'U' => Some(self.s.u),
            _ => None,
        }
    }
}

/// A query the turtle met: a `?` and the module after it.
struct Met {
    /// The module after the `?`, its number of parameters, and where its
    /// parameters are in the file.
    sym: char,
    n: usize,
    params: u64,
    what: Reading,
}

/// What the turtle read at a query ([`Met`]).
enum Reading {
    /// The vector the query module asks for.
    Vector(V3),
    /// In the rest of a branch skipped after `%`: cpfg does not interpret
    /// it, and the module keeps its values.
    Skipped,
    /// The module after `?` is not `P`, `H`, `L` or `U`.
    NotAQuery,
}

/// Interpret the generation in `file` (binary, indexed as `indexed` and
/// `counts` say) from its start with cpfg's turtle and write each query's
/// values over its module's parameters. `generation`: its number, for
/// errors.
pub fn fill(
    (q, mv): (&QueryTurtle, Option<&mut Movements>),
    file: &File,
    al: &Alphabet,
    flags: (bool, bool),
    generation: u64,
) -> Result<(), Error> {
    let fault = |fault| Error::new(RuntimeError::Query { fault, generation });
    let mut patch = Vec::with_capacity(24);
    walk(
        (q, mv),
        file,
        al,
        flags,
        generation,
        &mut |m| match m.what {
            Reading::Vector(v) => write_vector(file, &mut patch, (m.params, m.n), v, &fault),
            Reading::Skipped => Ok(()),
            Reading::NotAQuery => Err(fault(QueryFault::NotAQuery(Some(m.sym)))),
        },
    )
}

/// [`fill`] where the homomorphism can move the turtle (`through`): cpfg's
/// turtle interprets each module of the string through it. `image`: the
/// homomorphism's image of the generation in `file`, which the turtle
/// reads; each of its queries is the image of the one at the same place
/// in `file` (the homomorphism copies each `?` as it is, none of its
/// successors holds one: `check`), whose module gets the values.
/// `rewritten`: does the homomorphism have a production for this key?
/// cpfg reads the module after a `?` or an `@` from the string itself,
/// not through the homomorphism: a string that has one of those there
/// (an axiom given apart) is refused.
pub fn fill_through(
    (q, mv): (&QueryTurtle, Option<&mut Movements>),
    (file, image): (&File, &File),
    al: &Alphabet,
    flags: (bool, bool),
    rewritten: &dyn Fn(u32) -> bool,
    generation: u64,
) -> Result<(), Error> {
    let fault = |fault| Error::new(RuntimeError::Query { fault, generation });
    let mut queries = Queries {
        r: crate::derive::reader::PosReader::new(file, 1 << 16, flags.0).with_counts(flags.1),
        al,
        rewritten,
    };
    let mut patch = Vec::with_capacity(24);
    walk((q, mv), image, al, flags, generation, &mut |m| {
        let Some(g) = queries.next().map_err(|e| match e {
            Next::Io(e) => read_error(e),
            Next::Rewritten(sym) => fault(QueryFault::ReadPastHomomorphism(sym)),
        })?
        else {
            // (The image has a query the generation has not.)
            return Err(fault(QueryFault::NotAQuery(Some(m.sym))));
        };
        match m.what {
            Reading::Skipped => Ok(()),
            _ if rewritten(g.key) => Err(fault(QueryFault::ReadPastHomomorphism(g.sym))),
            Reading::NotAQuery => Err(fault(QueryFault::NotAQuery(Some(g.sym)))),
            Reading::Vector(v) => write_vector(file, &mut patch, (g.params, g.n), v, &fault),
        }
    })
}

fn read_error(e: std::io::Error) -> Error {
    Error::io("temporary generation", crate::diag::IoAction::Read, e)
}

/// Write the first (at most 3) components of `v` as floats over the `n`
/// parameters at `at` in `file`.
fn write_vector(
    file: &File,
    patch: &mut Vec<u8>,
    (at, n): (u64, usize),
    v: V3,
    fault: &dyn Fn(QueryFault) -> Error,
) -> Result<(), Error> {
    patch.clear();
    for &x in &v[..n.min(3)] {
        let x = x as f32;
        if !x.is_finite() {
            return Err(fault(QueryFault::NotFinite));
        }
        patch.extend_from_slice(&f64::from(x).to_le_bytes());
    }
    file.write_all_at(patch, at)
        .map_err(|e| Error::io("temporary generation", crate::diag::IoAction::Write, e))
}

/// Interpret the generation in `file` from its start with cpfg's turtle,
/// telling `on` each query it meets, in string order, skipped ones too.
fn walk(
    (q, mv): (&QueryTurtle, Option<&mut Movements>),
    file: &File,
    al: &Alphabet,
    (indexed, counts): (bool, bool),
    generation: u64,
    on: &mut dyn FnMut(Met) -> Result<(), Error>,
) -> Result<(), Error> {
    let fault = |fault| Error::new(RuntimeError::Query { fault, generation });
    let mut r = crate::derive::reader::PosReader::new(file, 1 << 16, indexed).with_counts(counts);
    let mut w = Walker::new(q, mv);
    let mut params = [0.0f64; 255];
    // Where an `@` command or a `?` is, also in a skipped branch.
    let mut cursor = Cursor::default();
    // Inside a branch's rest skipped after `%` (its depth).
    let mut skipping: Option<usize> = None;
    loop {
        let at = r.offset();
        let Some((key, s, e)) = r.next_module(al).map_err(read_error)? else {
            break;
        };
        let sym = al.symbol(key);
        let n = al.arity(key);
        let bytes = r.bytes(s, e);
        let key_len = bytes.len() - codec::body(bytes).len();
        let met = |what| Met {
            sym,
            n,
            params: at + key_len as u64,
            what,
        };
        let mut place = cursor.next(sym, n);
        if let Some(depth) = &mut skipping {
            // (A skipped `?`'s query module keeps its values; it is
            // reported, to keep [`fill_through`]'s queries in step.)
            if place == Place::Queried {
                on(met(Reading::Skipped))?;
            }
            match sym {
                '[' => {
                    *depth += 1;
                    continue;
                }
                // (The turtle goes on from this `]`, read as one.)
                ']' if *depth == 0 => {
                    skipping = None;
                    place = Place::Own;
                }
                ']' => {
                    *depth -= 1;
                    continue;
                }
                // cpfg's skip stops at these (`SkipCutPart`, generate.c)
                // and its turtle goes on from there.
                '$' => {
                    return Err(fault(QueryFault::NotFollowed(
                        "`$` (the end of a sub-L-system) after a `%`",
                    )))
                }
                '%' if n > 0 => return Err(fault(QueryFault::NotFollowed("`%` with parameters"))),
                _ => continue,
            }
        }
        let body = codec::body(r.bytes(s, e));
        // (cpfg's turtle reads floats: the cpfg dialect keeps its
        // parameters as floats already.)
        for (i, p) in params[..n].iter_mut().enumerate() {
            *p = f64::from(codec::get_param(body, i) as f32);
        }
        let p = &params[..n];
        // (What the file's own strings cannot hold, checked when it was
        // loaded, may still come from an axiom given apart, `--axiom`.)
        match role(place, sym, n) {
            Err(u) => return Err(fault(QueryFault::NotFollowed(u.at_run()))),
            Ok(Role::At(f)) => w.at_module(f, p),
            Ok(Role::AtT(f)) => w.at_t(f, p).map_err(fault)?,
            Ok(Role::Part) => {}
            Ok(Role::Queried) => on(met(match w.query(sym) {
                Some(v) => Reading::Vector(v),
                None => Reading::NotAQuery,
            }))?,
            Ok(Role::Turtle) => match sym {
                '?' => {}
                '%' if !q.past_cut => skipping = Some(0),
                _ => w.module(sym, p).map_err(fault)?,
            },
        }
    }
    // (A string that ends in a skipped rest ends nothing the turtle
    // reads: `%?` and `%@G` at its end are skipped.)
    if skipping.is_some() {
        return Ok(());
    }
    if cursor.asking() {
        return Err(fault(QueryFault::NotAQuery(None)));
    }
    if cursor.in_command() {
        return Err(fault(QueryFault::NotFollowed(
            "an `@` at the end of the string",
        )));
    }
    Ok(())
}

/// The queries of a generation in string order ([`fill_through`]).
struct Queries<'a> {
    r: crate::derive::reader::PosReader<'a>,
    al: &'a Alphabet,
    rewritten: &'a dyn Fn(u32) -> bool,
}

/// A query module of a generation ([`Queries`]).
struct Found {
    sym: char,
    key: u32,
    n: usize,
    /// Where its parameters are.
    params: u64,
}

/// Why [`Queries`] stopped.
enum Next {
    Io(std::io::Error),
    /// The module an `@` reads (its function, `@G`'s subfunction) has a
    /// homomorphism production.
    Rewritten(char),
}

impl Queries<'_> {
    /// The module after the next `?` (None: no `?` left, or one at the
    /// end).
    fn next(&mut self) -> Result<Option<Found>, Next> {
        // (Each call ends after a query module, where a cursor starts.)
        let mut cursor = Cursor::default();
        loop {
            let at = self.r.offset();
            let Some((key, s, e)) = self.r.next_module(self.al).map_err(Next::Io)? else {
                return Ok(None);
            };
            let sym = self.al.symbol(key);
            let n = self.al.arity(key);
            match cursor.next(sym, n) {
                Place::Queried => {
                    let bytes = self.r.bytes(s, e);
                    let key_len = bytes.len() - codec::body(bytes).len();
                    return Ok(Some(Found {
                        sym,
                        key,
                        n,
                        params: at + key_len as u64,
                    }));
                }
                Place::Function | Place::Sub(_) if (self.rewritten)(key) => {
                    return Err(Next::Rewritten(sym))
                }
                _ => {}
            }
        }
    }
}

/// Where a file with queries has something lsgen's query turtle does not
/// follow, or nothing to read its settings from. `view`: the view file's
/// turtle settings (`--cpfg-view`). Ok(None): no query; else the turtle,
/// and the view file's warnings about it (said if the file is taken).
pub(crate) fn check(
    tree: &Lsystem,
    text: &str,
    view: Option<&std::path::Path>,
) -> Result<Option<(QueryTurtle, Vec<crate::diag::Warning>)>, CheckError> {
    // The axiom's modules without parameters keep no span: the first
    // such symbol in the axiom's text.
    let in_axiom = |c: char| {
        let (s, e) = tree.axiom_span;
        let at = text.get(s..e).and_then(|t| t.find(c)).map_or(s, |i| s + i);
        (at, at + c.len_utf8())
    };
    let Some(first) = first_query(tree, text, in_axiom('?')) else {
        return Ok(None);
    };
    let Some(view) = view else {
        return Err(CheckError::At(first, Refused::QueryWithoutView));
    };
    let (view, warnings) =
        crate::turtle::cpfg_view::read_cpfg_turtle(view).map_err(CheckError::ViewFile)?;
    // cpfg's turtle interprets the string through the homomorphism. One
    // that cannot move it is not followed (the turtle ends where cpfg's
    // does); one that can is, through its image of each generation
    // (`fill_through`).
    let hom: Vec<&Production> = tree
        .homomorphism
        .iter()
        .flat_map(|h| &h.productions)
        .map(|p| &**p)
        .collect();
    if let Some((at, why)) = hom.iter().find_map(|p| homomorphism_refused(p, text)) {
        return Err(CheckError::At(at, Refused::QueryWithHomomorphism(why)));
    }
    let through = hom.iter().any(|p| homomorphism_moves(p, text));
    if through {
        // cpfg reads the module after a `?` or an `@` from the string,
        // past the homomorphism; the image has it rewritten. And cpfg's
        // homomorphism reads its contexts in the string as it is being
        // filled: a query module in a left context is filled already,
        // where the image was made from the string before the fill.
        let (queried, read) = read_past(tree, text);
        for p in &hom {
            let mut pred = p.pred.shapes(text).map_while(Result::ok);
            if let Some((sym, _, span)) = pred.find(|(sym, ..)| read.contains(sym)) {
                let why = format!("a predecessor `{sym}`, which a `?` or an `@` reads");
                return Err(CheckError::At(span, Refused::QueryWithHomomorphism(why)));
            }
            let mut left = p
                .left
                .iter()
                .flat_map(|l| l.shapes(text).map_while(Result::ok));
            if let Some((sym, _, span)) = left.find(|(sym, ..)| queried.contains(sym)) {
                let why = format!("a left context `{sym}`, which a query fills");
                return Err(CheckError::At(span, Refused::QueryWithHomomorphism(why)));
            }
        }
    }
    // Each list of modules (the axiom, each successor) in turn, without a
    // copy: (symbol, parameters, span; None for the axiom's modules
    // without parameters, found in its text only for a message).
    let axiom = tree
        .axiom
        .iter()
        .flat_map(|piece| -> Box<dyn Iterator<Item = _>> {
            match piece {
                AxiomPiece::Symbols(s) => Box::new(s.chars().map(|c| (c, 0, None))),
                AxiomPiece::Module(m) => {
                    Box::new(std::iter::once((m.sym, m.params.len(), Some(m.span))))
                }
            }
        });
    let at = |(c, _, span): (char, usize, Option<Span>)| span.unwrap_or_else(|| in_axiom(c));
    check_list(axiom).map_err(|(m, r)| CheckError::At(at(m), r))?;
    // Every list of every section, contexts and predecessors too (as the
    // reference checks them). A homomorphism's successors too where the
    // turtle follows it; else only still modules outside their branches
    // (`homomorphism_moves`), and whatever a branch holds, its `]` gives
    // the whole turtle back.
    let sections = std::iter::once((&tree.productions, true))
        .chain(tree.decomposition.iter().map(|s| (&s.productions, true)))
        .chain(tree.homomorphism.iter().map(|s| (&s.productions, through)));
    for (p, successor) in sections.flat_map(|(ps, succ)| ps.iter().map(move |p| (p, succ))) {
        for list in p.heads() {
            let list = list.shapes(text).map_while(Result::ok);
            let list = list.map(|(sym, n, span)| (sym, n, Some(span)));
            check_list(list).map_err(|(m, r)| CheckError::At(at(m), r))?;
        }
        if successor {
            // (A module the text does not give again is the lowering's
            // error.)
            let list = p.succ.shapes(text).map_while(Result::ok);
            let list = list.map(|(sym, n, span)| (sym, n, Some(span)));
            check_list(list).map_err(|(m, r)| CheckError::At(at(m), r))?;
        }
    }
    if let Some((label, at, why)) = &view.movements_refused {
        let r = Refused::QueryMovements(label.clone(), why);
        return Err(CheckError::View(at.clone(), r));
    }
    if let Some((label, at)) = &view.angle_past {
        let r = Refused::QueryAngle(label.clone());
        return Err(CheckError::View(at.clone(), r));
    }
    let mut q = QueryTurtle::new(&view);
    q.through = through;
    Ok(Some((q, warnings)))
}

/// What [`check`] refuses: at a span of the `.l` file, or a label of the
/// view file.
#[derive(Debug)]
pub(crate) enum CheckError {
    At(Span, Refused),
    View(crate::diag::Location, Refused),
    /// The view file could not be read, or has a bad argument where the
    /// turtle needs it.
    ViewFile(Error),
}

/// Where a module stands for cpfg's turtle, given the modules before it
/// (`interpret.c`, `blackbox.c`): an `@` reads the module after it as its
/// function, and a function `P T G m D b` without parameters one more, its
/// subfunction; a `?` without parameters reads the module after it, its
/// query module, which is then not interpreted. One rule for the file's
/// lists ([`check_list`], [`read_past`]) and for the strings the turtle
/// reads ([`walk`]) and takes its queries from ([`Queries`]).
#[derive(Default)]
struct Cursor {
    /// The `@`, `?` or function whose module comes next.
    after: Option<char>,
}

/// A module's place ([`Cursor::next`]).
#[derive(Clone, Copy, Debug, PartialEq)]
enum Place {
    /// Read as a module of its own.
    Own,
    /// The function of an `@`.
    Function,
    /// The subfunction of `@` and this function.
    Sub(char),
    /// The query module of a `?`.
    Queried,
}

impl Cursor {
    /// The place of the module `sym` with `n` parameters, read next.
    fn next(&mut self, sym: char, n: usize) -> Place {
        match self.after.take() {
            None => {
                if n == 0 && matches!(sym, '@' | '?') {
                    self.after = Some(sym);
                }
                Place::Own
            }
            Some('@') => {
                if n == 0 && "PTGmDb".contains(sym) {
                    self.after = Some(sym);
                }
                Place::Function
            }
            Some('?') => Place::Queried,
            Some(f) => Place::Sub(f),
        }
    }

    /// The list or string ended within an `@` command.
    fn in_command(&self) -> bool {
        self.after.is_some_and(|c| c != '?')
    }

    /// It ended right after a `?`.
    fn asking(&self) -> bool {
        self.after == Some('?')
    }
}

/// A module's part in the turtle's reading ([`role`]).
enum Role {
    /// Interpreted as a module of its own.
    Turtle,
    /// The function of an `@` command (`o O c v M`).
    At(char),
    /// The subfunction of an `@T` command (`i d s p f x`: cpfg's
    /// movements).
    AtT(char),
    /// Read as part of an `@` command, not interpreted.
    Part,
    /// The module after a `?`, which it fills.
    Queried,
}

/// A module the query turtle does not follow (it moves cpfg's turtle).
#[derive(Clone, Copy, Debug, PartialEq)]
enum Unfollowed {
    /// An `@` function but `o O c v M G`.
    At(char),
    /// An `@G` subfunction but `s c e t r`.
    AtG(char),
    /// An `@T` subfunction but `i d s p f x`, or `x` without a parameter.
    AtT(char),
    /// `@T` with parameters.
    AtTParams,
    /// `@G` with parameters.
    AtGParams,
    /// `~`, a surface.
    Surface,
    /// `s(x,y[,z])`, cpfg's older position query.
    OldQuery,
    /// `%` with parameters.
    CutWithParams,
    /// `?` with parameters, a sub-L-system call.
    SubLsystem,
}

impl Unfollowed {
    /// As a message about the file names it.
    fn in_file(self) -> String {
        match self {
            Unfollowed::At(c) => format!("`@{c}`"),
            Unfollowed::AtG(c) => format!("`@G{c}`"),
            Unfollowed::AtT(c) => format!("`@T{c}`"),
            Unfollowed::AtTParams => "`@T` with parameters".into(),
            Unfollowed::AtGParams => "`@G` with parameters".into(),
            Unfollowed::Surface => "`~` (a surface)".into(),
            Unfollowed::OldQuery => {
                "`s` with 2 or 3 parameters (cpfg's older position query)".into()
            }
            Unfollowed::CutWithParams => "`%` with parameters".into(),
            Unfollowed::SubLsystem => "`?` with parameters (a sub-L-system call)".into(),
        }
    }

    /// As a message about a string the turtle reads names it.
    fn at_run(self) -> &'static str {
        match self {
            Unfollowed::At(_) => "an `@` module",
            Unfollowed::AtG(_) => "an `@G` module",
            Unfollowed::AtT(_) => "an `@T` module",
            Unfollowed::AtTParams => "`@T` with parameters",
            Unfollowed::AtGParams => "`@G` with parameters",
            Unfollowed::Surface => "`~` (a surface)",
            Unfollowed::OldQuery => "`s` with 2 or 3 parameters",
            Unfollowed::CutWithParams => "`%` with parameters",
            Unfollowed::SubLsystem => "`?` with parameters (a sub-L-system call)",
        }
    }
}

/// What the query turtle makes of the module `sym` with `n` parameters at
/// `place`: `@G`'s subfunctions `s c e t r` (generalized cylinders,
/// `general.c`) set the spline's state, never the turtle's place; `@T`'s
/// `i d s p f` change cpfg's movements (`crate::turtle::movements`), `x` a
/// texture. One rule for the file's lists when it is loaded
/// ([`check_list`]) and for the strings the turtle reads ([`fill`]).
fn role(place: Place, sym: char, n: usize) -> Result<Role, Unfollowed> {
    match place {
        Place::Function => match sym {
            'o' | 'O' | 'c' | 'v' | 'M' => Ok(Role::At(sym)),
            'G' | 'T' if n == 0 => Ok(Role::Part),
            // (cpfg: `@G` or `@T` with a parameter reads no
            // subfunction, and its turtle goes on from the `G` or `T`
            // as a module of its own: `@G(x)` moves it.)
            'G' => Err(Unfollowed::AtGParams),
            'T' => Err(Unfollowed::AtTParams),
            _ => Err(Unfollowed::At(sym)),
        },
        Place::Sub('G') if matches!(sym, 's' | 'c' | 'e' | 't' | 'r') => Ok(Role::Part),
        Place::Sub('G') => Err(Unfollowed::AtG(sym)),
        // (`@Tx` without a parameter: cpfg goes on from the `T`.)
        Place::Sub('T') if matches!(sym, 'i' | 'd' | 's' | 'p' | 'f') || (sym == 'x' && n > 0) => {
            Ok(Role::AtT(sym))
        }
        Place::Sub('T') => Err(Unfollowed::AtT(sym)),
        // (The function of the others is refused first.)
        Place::Sub(f) => Err(Unfollowed::At(f)),
        Place::Queried => Ok(Role::Queried),
        Place::Own => match sym {
            '~' => Err(Unfollowed::Surface),
            's' if n == 2 || n == 3 => Err(Unfollowed::OldQuery),
            '%' if n > 0 => Err(Unfollowed::CutWithParams),
            '?' if n > 0 => Err(Unfollowed::SubLsystem),
            '@' if n == 0 => Ok(Role::Part),
            _ => Ok(Role::Turtle),
        },
    }
}

/// A module of a list: symbol, number of parameters, span if known.
type Item = (char, usize, Option<Span>);

/// The first module of a list (axiom or successor) that lsgen's query
/// turtle does not follow, and why.
fn check_list(list: impl Iterator<Item = Item>) -> Result<(), (Item, Refused)> {
    let not = |what: String| Refused::QueryNotFollowed(what);
    let mut cursor = Cursor::default();
    // The `@` of the command being read: errors in it are located there.
    let mut command = None;
    for m in list {
        let (sym, n, _) = m;
        match role(cursor.next(sym, n), sym, n) {
            Ok(Role::Part) if sym == '@' => command = Some(m),
            Ok(_) => {}
            Err(u) => {
                return Err((
                    command
                        .filter(|_| {
                            matches!(
                                u,
                                Unfollowed::At(_)
                                    | Unfollowed::AtG(_)
                                    | Unfollowed::AtT(_)
                                    | Unfollowed::AtTParams
                                    | Unfollowed::AtGParams
                            )
                        })
                        .unwrap_or(m),
                    not(u.in_file()),
                ))
            }
        }
    }
    match command {
        Some(a) if cursor.in_command() => Err((a, not("`@` at the end of a successor".into()))),
        _ => Ok(()),
    }
}

/// Does cpfg's turtle stay as it is on the module `sym` (whatever its
/// parameters)?
fn still(sym: char) -> bool {
    !matches!(
        sym,
        'F' | 'f'
            | 'G'
            | 'g'
            | '+'
            | '-'
            | '&'
            | '^'
            | '/'
            | '\\'
            | '|'
            | '_'
            | '['
            | ']'
            | '@'
            | '~'
            | '?'
            | '%'
            | '$'
    )
}

/// Calls that change cpfg's globals or random streams when evaluated.
const DRAWS: &[&str] = &["ran", "nran", "bran", "biran", "srand"];

/// The first call of [`DRAWS`] in `e`.
fn draws(e: &Expr) -> Option<Span> {
    match e {
        Expr::Call(name, args, span) => {
            if DRAWS.contains(&name.as_str()) {
                Some(*span)
            } else {
                args.iter().find_map(draws)
            }
        }
        Expr::Unary(_, a, _) => draws(a),
        Expr::Binary(_, a, b, _) => draws(a).or_else(|| draws(b)),
        Expr::Cond(c, a, b, _) => draws(c).or_else(|| draws(a)).or_else(|| draws(b)),
        Expr::Index(_, subs, _) => subs.iter().find_map(draws),
        Expr::Num(..) | Expr::Var(..) | Expr::Str(..) => None,
    }
}

/// Why the query turtle cannot follow cpfg's through the homomorphism
/// production `p` (None: it can). cpfg evaluates a production's
/// condition, blocks and parameters at each interpretation: they must not
/// draw nor assign. Its predecessor must not be a module the turtle reads
/// with the module after it, or changes on without moving (`[ ] ? @ % $
/// ~`); its successor must not hold a `?` (each query of the image is
/// then its string's) nor a `%` or `$` outside its own branches, and its
/// brackets must balance.
fn homomorphism_refused(p: &Production, text: &str) -> Option<(Span, String)> {
    if p.blocks.is_some() {
        return Some((p.span, "a block".into()));
    }
    if let Some(e) = &p.prob {
        return Some((e.span(), "a probability".into()));
    }
    let mut succ = p.succ.modules(text).map_while(Result::ok);
    let in_succ = || succ.find_map(|m| m.params.iter().find_map(draws));
    if let Some(at) = p.cond.as_deref().and_then(draws).or_else(in_succ) {
        return Some((at, "a random draw".into()));
    }
    let read = |c| matches!(c, '[' | ']' | '?' | '@' | '%' | '$' | '~');
    let mut pred = p.pred.shapes(text).map_while(Result::ok);
    if let Some((sym, _, span)) = pred.find(|&(sym, ..)| read(sym)) {
        return Some((span, format!("a predecessor with `{sym}`")));
    }
    let mut depth = 0usize;
    for (sym, _, span) in p.succ.shapes(text).map_while(Result::ok) {
        match sym {
            '?' => return Some((span, "a `?` in its successor".into())),
            '[' => depth += 1,
            ']' if depth == 0 => return Some((span, "a `]` without its `[`".into())),
            ']' => depth -= 1,
            c @ ('%' | '$') if depth == 0 => {
                return Some((span, format!("`{c}` outside a branch of its successor")))
            }
            _ => {}
        }
    }
    if depth > 0 {
        return Some((p.span, "a `[` without its `]`".into()));
    }
    None
}

/// Can the homomorphism production `p` (not refused,
/// [`homomorphism_refused`]) move cpfg's turtle? Its predecessor, which it
/// replaces, or its successor outside its own branches (a `]` gives the
/// whole turtle back) has a module that does.
fn homomorphism_moves(p: &Production, text: &str) -> bool {
    // (`@T` changes cpfg's movements, whose sums a `]` gives back by a
    // difference, not exactly: in a branch too.)
    let mut after_at = false;
    let at_t = p.succ.shapes(text).map_while(Result::ok).any(|(sym, ..)| {
        let t = after_at && sym == 'T';
        after_at = sym == '@';
        t
    });
    if at_t {
        return true;
    }
    let mut depth = 0usize;
    let succ = p.succ.shapes(text).map_while(Result::ok).any(|(sym, ..)| {
        match sym {
            '[' => depth += 1,
            ']' => depth = depth.saturating_sub(1),
            c => return depth == 0 && !still(c),
        }
        false
    });
    succ || p
        .pred
        .shapes(text)
        .map_while(Result::ok)
        .any(|(sym, ..)| !still(sym))
}

/// The symbols the file's strings have after a `?` (the query modules),
/// and those after a `?`, an `@` or an `@G`: cpfg's turtle reads them
/// from the string itself.
fn read_past(tree: &Lsystem, text: &str) -> (Vec<char>, Vec<char>) {
    let (mut queried, mut read) = (Vec::new(), Vec::new());
    let mut list = |l: &mut dyn Iterator<Item = (char, usize)>| {
        let mut cursor = Cursor::default();
        for (sym, n) in l {
            let place = cursor.next(sym, n);
            if place != Place::Own && !read.contains(&sym) {
                read.push(sym);
            }
            if place == Place::Queried && !queried.contains(&sym) {
                queried.push(sym);
            }
        }
    };
    list(
        &mut tree
            .axiom
            .iter()
            .flat_map(|piece| -> Box<dyn Iterator<Item = _>> {
                match piece {
                    AxiomPiece::Symbols(s) => Box::new(s.chars().map(|c| (c, 0))),
                    AxiomPiece::Module(m) => Box::new(std::iter::once((m.sym, m.params.len()))),
                }
            }),
    );
    let sections = std::iter::once(&tree.productions)
        .chain(tree.decomposition.iter().map(|s| &s.productions))
        .chain(tree.homomorphism.iter().map(|s| &s.productions));
    for p in sections.flatten() {
        for l in p.heads() {
            let l = l.shapes(text).map_while(Result::ok);
            list(&mut l.map(|(sym, n, _)| (sym, n)));
        }
        let succ = p.succ.shapes(text).map_while(Result::ok);
        list(&mut succ.map(|(sym, n, _)| (sym, n)));
    }
    (queried, read)
}

/// The first `?` of the file (axiom, predecessors, contexts, successors).
fn first_query(tree: &Lsystem, text: &str, in_axiom: Span) -> Option<Span> {
    let mut found: Option<Span> = None;
    let mut see = |sym: char, span: Span| {
        if sym == '?' && found.is_none_or(|f| span.0 < f.0) {
            found = Some(span);
        }
    };
    for piece in &tree.axiom {
        match piece {
            AxiomPiece::Symbols(s) if s.contains('?') => see('?', in_axiom),
            AxiomPiece::Module(m) => see(m.sym, m.span),
            _ => {}
        }
    }
    let sections = std::iter::once(&tree.productions)
        .chain(tree.decomposition.iter().map(|s| &s.productions))
        .chain(tree.homomorphism.iter().map(|s| &s.productions));
    for p in sections.flatten() {
        for h in p.heads() {
            let h = h.shapes(text).map_while(Result::ok);
            h.for_each(|(sym, _, span)| see(sym, span));
        }
        let succ = p.succ.shapes(text).map_while(Result::ok);
        succ.for_each(|(sym, _, span)| see(sym, span));
    }
    found
}
