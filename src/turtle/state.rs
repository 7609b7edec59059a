//! The 3D turtle of ABOP / cpfg. The frame is heading H, left L, up U;
//! it starts as cpfg's: H = (0,1,0) (up the screen), L = (-1,0,0),
//! U = (0,0,-1), at the origin. Rotations follow cpfg's `interpret.c`:
//! `+` turns H towards L, `&` pitches H towards U, `/` rolls L towards U.

use super::movements::{with_frame, Frame, Movements, Moving};
use super::view::{TropismModel, View};
use std::io;

pub type V3 = [f64; 3];

#[inline]
fn add(a: V3, b: V3, k: f64) -> V3 {
    [a[0] + b[0] * k, a[1] + b[1] * k, a[2] + b[2] * k]
}
#[inline]
pub fn cross(a: V3, b: V3) -> V3 {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}
/// a' = c a + s b; b' = c b - s a: cpfg's `change_dir`, in its order of
/// operations (`c b - s a` is `c b + (-s) a` to the bit), shared by
/// lsgen-turtle and the cpfg dialect's query turtle.
#[inline]
pub(crate) fn rot(a: &mut V3, b: &mut V3, s: f64, c: f64) {
    let na = [
        c * a[0] + s * b[0],
        c * a[1] + s * b[1],
        c * a[2] + s * b[2],
    ];
    let nb = [
        c * b[0] - s * a[0],
        c * b[1] - s * a[1],
        c * b[2] - s * a[2],
    ];
    *a = na;
    *b = nb;
}

/// The turns of the frame `(h, l, u)` by the angle of sine `s` and cosine
/// `c` (`|`: half a turn, whatever they are), as cpfg's `InterpretSymbol`
/// makes them: `+`/`-` turn H towards L or away, `&`/`^` H towards U,
/// `/`/`\` L towards U. Shared by lsgen-turtle and the cpfg dialect's
/// query turtle (each works out the angle its own way).
pub(crate) fn turn(sym: char, (h, l, u): (&mut V3, &mut V3, &mut V3), s: f64, c: f64) {
    match sym {
        '+' => rot(h, l, s, c),
        '-' => rot(h, l, -s, c),
        '&' => rot(h, u, s, c),
        '^' => rot(h, u, -s, c),
        '/' => rot(l, u, s, c),
        '\\' => rot(l, u, -s, c),
        '|' => rot(h, l, 0.0, -1.0),
        _ => {}
    }
}

/// cpfg's `bend` (`interpret.c`) of the frame `(h, l, u)` with elasticity
/// `e` and the tropism `t` (of length 1): pitch H towards U by the angle
/// whose sine is e·(T·U), then turn it towards L by the angle whose sine
/// is e·(T·L). Err: a sine past ±1, no angle (cpfg's turtle becomes NaN).
pub(crate) fn bend_cpfg((h, l, u): (&mut V3, &mut V3, &mut V3), e: f64, t: V3) -> Result<(), ()> {
    let s = e * dot(t, *u);
    if !(-1.0..=1.0).contains(&s) {
        return Err(());
    }
    rot(h, u, s, (1.0 - s * s).sqrt());
    let s = e * dot(t, *l);
    if !(-1.0..=1.0).contains(&s) {
        return Err(());
    }
    rot(h, l, s, (1.0 - s * s).sqrt());
    Ok(())
}

#[inline]
pub fn dot(a: V3, b: V3) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}
#[inline]
fn scale(a: V3, k: f64) -> V3 {
    [a[0] * k, a[1] * k, a[2] * k]
}
#[inline]
fn div(a: V3, k: f64) -> V3 {
    [a[0] / k, a[1] / k, a[2] / k]
}
/// `a` scaled to length 1 (by its largest component first, so that 1e200
/// and 1e-200 have a direction); the zero vector stays as it is (no bend).
pub(crate) fn unit_or_zero(a: V3) -> V3 {
    let big = a[0].abs().max(a[1].abs()).max(a[2].abs());
    if big == 0.0 || !big.is_finite() {
        return a;
    }
    // Divided, not multiplied by 1/big: 1/big of a subnormal (1e-320) is
    // past the largest number, and the direction became NaN.
    let b = div(a, big);
    div(b, norm(b))
}

/// The unit vector from `a` to `b` (finite points), without overflow or
/// underflow: a difference past the largest number is halved first, and
/// [`unit_or_zero`] scales by the largest component before the length is
/// taken, so any two distinct points have a direction (`F(1e200)`,
/// `F(1e-320)`); `None` when they are equal.
pub(crate) fn direction(a: V3, b: V3) -> Option<V3> {
    let mut d = [b[0] - a[0], b[1] - a[1], b[2] - a[2]];
    if !d.iter().all(|x| x.is_finite()) {
        d = [
            b[0] * 0.5 - a[0] * 0.5,
            b[1] * 0.5 - a[1] * 0.5,
            b[2] * 0.5 - a[2] * 0.5,
        ];
    }
    let u = unit_or_zero(d);
    (u != [0.0; 3] && u.iter().all(|x| x.is_finite())).then_some(u)
}

#[inline]
pub fn norm(a: V3) -> f64 {
    dot(a, a).sqrt()
}

/// Receives what the turtle draws.
pub trait Sink {
    /// A line from `a` to `b`.
    fn segment(&mut self, a: V3, b: V3, width: f64, colour: i64) -> io::Result<()>;
    /// A filled polygon.
    fn polygon(&mut self, points: &[V3], colour: i64) -> io::Result<()>;
    /// `@o` (a disc facing the viewer) or `@O` (a sphere) of diameter `d`.
    fn dot(&mut self, centre: V3, d: f64, colour: i64, sphere: bool) -> io::Result<()>;
}

#[derive(Clone, Copy, Debug)]
struct State {
    pos: V3,
    h: V3,
    l: V3,
    u: V3,
    width: f64,
    colour: f64,
    /// Set and changed by `_` (cpfg's), kept by `[` as cpfg keeps it.
    elasticity: f64,
    /// The heading and up vector at the last `F` or `G` (cpfg's
    /// `prev_heading`, `prev_up`), for cpfg's movements.
    prev_h: V3,
    prev_u: V3,
}

/// Deepest branch nesting accepted (each level is one saved state).
pub const MAX_DEPTH: usize = 1 << 20;

/// Most vertices the open polygons (`{ ... }`) may hold together: each
/// is held in memory until its `}`.
pub const MAX_VERTICES: usize = 1 << 20;

pub struct Turtle {
    s: State,
    stack: Vec<State>,
    /// The vertices of all open polygons (`{`), outermost first: only the
    /// innermost collects, so it is always the top of this one stack and
    /// its `}` gives its vertices back. At most [`MAX_VERTICES`] in all.
    vertices: Vec<V3>,
    /// Where each open polygon's vertices start in `vertices`.
    polygon_starts: Vec<usize>,
    cos_a: f64,
    sin_a: f64,
    step: f64,
    width_inc: f64,
    width_scale: f64,
    colour_inc: f64,
    tropism: V3,
    elasticity_inc: f64,
    /// cpfg's bend ([`TropismModel::Cpfg`]): after `f` and `g` too, with
    /// `tropism` scaled to length 1.
    cpfg_bend: bool,
    /// The previous module was `@` (without parameters): a letter now
    /// makes a two-character module with it.
    at: bool,
    /// The previous modules were `@T`: this one is its subfunction.
    at_t: bool,
    /// cpfg's movements of a cpfg view ([`super::movements`]).
    movements: Option<Moving<Movements>>,
}

/// A misuse of the string that the turtle cannot follow.
#[derive(Debug, PartialEq)]
pub enum Fault {
    UnmatchedClose(char),
    TooDeep,
    /// A move took the turtle past the largest number.
    Overflow,
    /// elasticity × |tropism| is past the largest number.
    TropismOverflow,
    /// cpfg's bend: the sine of an angle past ±1.
    BendPastRightAngle,
    /// The width drawn (width × width scale) is past the largest number.
    WidthOverflow,
    /// Open polygons with more than [`MAX_VERTICES`] vertices in all.
    PolygonTooLarge,
    /// cpfg's movements (tropisms, torque) left no heading: numbers past
    /// the largest (an elasticity of 1e308) made the frame NaN or zero.
    MovementOverflow,
}

impl Turtle {
    pub fn new(v: &View) -> Turtle {
        let a = v.angle.to_radians();
        Turtle {
            s: State {
                pos: [0.0; 3],
                h: [0.0, 1.0, 0.0],
                l: [-1.0, 0.0, 0.0],
                u: [0.0, 0.0, -1.0],
                width: v.width,
                colour: v.colour,
                elasticity: v.elasticity,
                prev_h: [0.0, 1.0, 0.0],
                prev_u: [0.0, 0.0, -1.0],
            },
            stack: Vec::new(),
            vertices: Vec::new(),
            polygon_starts: Vec::new(),
            cos_a: a.cos(),
            sin_a: a.sin(),
            step: v.step,
            width_inc: v.width_increment,
            width_scale: v.width_scale,
            colour_inc: v.colour_increment,
            tropism: match v.tropism_model {
                TropismModel::Abop => v.tropism,
                TropismModel::Cpfg => unit_or_zero(v.tropism),
            },
            elasticity_inc: v.elasticity_increment,
            cpfg_bend: v.tropism_model == TropismModel::Cpfg,
            at: false,
            at_t: false,
            // (Empty without movement lines: cpfg's `@Tp` and `@Tf` turn
            // the turtle all the same. The view keeps nine at most, which
            // `Movements::new` takes.)
            movements: Movements::new(v.movements.clone()).ok().map(Moving::start),
        }
    }

    /// Run `g` on the turtle's frame with its movements, if any.
    fn moving<R>(&mut self, g: impl FnOnce(&mut Moving<Movements>, &mut Frame) -> R) -> Option<R> {
        let s = &mut self.s;
        let m = self.movements.as_mut()?;
        let v = [&mut s.h, &mut s.l, &mut s.u, &mut s.prev_h, &mut s.prev_u];
        Some(with_frame(v, |f| g(m, f)))
    }

    /// cpfg's movements turn the turtle before a move (an error where
    /// they overflow, [`Moving::adjust`]).
    fn movements_adjust(&mut self) -> Result<(), ModErr> {
        match self.moving(|m, f| m.adjust(f)) {
            Some(Err(())) => Err(ModErr::Fault(Fault::MovementOverflow)),
            _ => Ok(()),
        }
    }

    #[inline]
    fn sincos(&self, p: &[f64]) -> (f64, f64) {
        match p.first() {
            Some(&d) => d.to_radians().sin_cos(),
            None => (self.sin_a, self.cos_a),
        }
    }

    fn colour(&self) -> i64 {
        let c = self.s.colour.round();
        if c.is_finite() {
            c.clamp(i64::MIN as f64 / 2.0, i64::MAX as f64 / 2.0) as i64
        } else {
            0
        }
    }

    /// ABOP fig. 2.8: rotate the frame by e|H x T| about H x T; or cpfg's
    /// bend ([`Turtle::bend_cpfg`]).
    fn bend(&mut self) -> Result<(), ModErr> {
        if self.s.elasticity == 0.0 {
            return Ok(());
        }
        if self.cpfg_bend {
            return self.bend_cpfg();
        }
        // The angle is elasticity × |H × T|, about the axis H × T. T is
        // scaled to its largest component first: |H × T| of a tropism of
        // 1e200 overflowed when squared, one of 1e-200 underflowed to 0 (no
        // bend at any elasticity).
        let t = self.tropism;
        let big = t[0].abs().max(t[1].abs()).max(t[2].abs());
        if big == 0.0 {
            return Ok(());
        }
        let axis = cross(self.s.h, div(t, big));
        let n = norm(axis);
        let angle = self.s.elasticity * (n * big);
        if !angle.is_finite() {
            return Err(ModErr::Fault(Fault::TropismOverflow));
        }
        if n == 0.0 || angle == 0.0 {
            // (H along T: no axis, no bend.)
            return Ok(());
        }
        let k = scale(axis, 1.0 / n);
        let (sa, ca) = angle.sin_cos();
        let r = |v: V3| -> V3 {
            let kv = cross(k, v);
            let kd = dot(k, v) * (1.0 - ca);
            [
                v[0] * ca + kv[0] * sa + k[0] * kd,
                v[1] * ca + kv[1] * sa + k[1] * kd,
                v[2] * ca + kv[2] * sa + k[2] * kd,
            ]
        };
        self.s.h = r(self.s.h);
        self.s.l = r(self.s.l);
        self.s.u = r(self.s.u);
        Ok(())
    }

    /// cpfg's `bend` (`interpret.c`): pitch H towards U by the angle whose
    /// sine is e·(T·U), then turn it towards L by the angle whose sine is
    /// e·(T·L) (T of length 1). A sine past ±1 is no angle (cpfg's turtle
    /// becomes NaN there): an error.
    fn bend_cpfg(&mut self) -> Result<(), ModErr> {
        let st = &mut self.s;
        bend_cpfg(
            (&mut st.h, &mut st.l, &mut st.u),
            st.elasticity,
            self.tropism,
        )
        .map_err(|()| ModErr::Fault(Fault::BendPastRightAngle))
    }

    /// Roll about H so that L is horizontal (`$` of ABOP, `@v` of cpfg):
    /// L = Y × H / |Y × H| (ABOP p. 57's L = V × H, cpfg's `blackbox.c`),
    /// U = L × H. A roll keeps the frame's handedness (H × L = −U, cpfg's),
    /// so U then points as far *down* as it can and `&` pitches down.
    fn level(&mut self) {
        let l = cross([0.0, 1.0, 0.0], self.s.h);
        let n = norm(l);
        if n < 1e-12 {
            return;
        }
        self.s.l = scale(l, 1.0 / n);
        self.s.u = cross(self.s.l, self.s.h);
    }

    fn forward(&mut self, p: &[f64]) -> Result<V3, ModErr> {
        let d = p.first().copied().unwrap_or(self.step);
        let from = self.s.pos;
        let to = add(from, self.s.h, d);
        if !(to[0].is_finite() && to[1].is_finite() && to[2].is_finite()) {
            return Err(ModErr::Fault(Fault::Overflow));
        }
        self.s.pos = to;
        Ok(from)
    }

    /// Does `sym`, read next, make one module with the bare `@` before
    /// it (`@o`, `@M`, ...)? Before anything else `@` stood alone and
    /// `sym` is a module of its own, as lsgen (every symbol one
    /// character) reads `@[`.
    pub fn joins_at(&self, sym: char) -> bool {
        self.at && sym.is_alphabetic()
    }

    /// Interpret one module.
    pub fn module(&mut self, sym: char, p: &[f64], sink: &mut dyn Sink) -> Result<(), ModErr> {
        if self.at_t {
            // `@T`'s subfunction.
            self.at_t = false;
            // (A movement number past a C `short`: nothing drawn for it.)
            let _ = self.moving(|m, f| m.at_t(sym, p, f));
            return Ok(());
        }
        if self.at {
            let joins = self.joins_at(sym);
            self.at = false;
            if joins {
                return self.at_module(sym, p, sink);
            }
        }
        match sym {
            'F' | 'G' => {
                self.movements_adjust()?;
                let from = self.forward(p)?;
                let to = self.s.pos;
                let width = self.drawn_width()?;
                sink.segment(from, to, width, self.colour())?;
                if sym == 'F' {
                    self.vertex(to)?;
                }
                self.bend()?;
                (self.s.prev_h, self.s.prev_u) = (self.s.h, self.s.u);
            }
            'f' | 'g' => {
                self.movements_adjust()?;
                self.forward(p)?;
                if sym == 'f' {
                    self.vertex(self.s.pos)?;
                }
                if self.cpfg_bend {
                    self.bend()?;
                }
            }
            '+' | '-' | '&' | '^' | '/' | '\\' | '|' => {
                let (s, c) = self.sincos(p);
                let st = &mut self.s;
                turn(sym, (&mut st.h, &mut st.l, &mut st.u), s, c);
            }
            '$' => self.level(),
            '[' => {
                if self.stack.len() >= MAX_DEPTH {
                    return Err(ModErr::Fault(Fault::TooDeep));
                }
                self.stack.push(self.s);
                if let Some(m) = &mut self.movements {
                    m.open();
                }
            }
            ']' => match self.stack.pop() {
                Some(s) => {
                    self.s = s;
                    if let Some(m) = &mut self.movements {
                        m.close();
                    }
                }
                None => return Err(ModErr::Fault(Fault::UnmatchedClose(']'))),
            },
            '{' => {
                if self.polygon_starts.len() >= MAX_DEPTH {
                    return Err(ModErr::Fault(Fault::TooDeep));
                }
                self.polygon_starts.push(self.vertices.len());
            }
            '}' => {
                let Some(start) = self.polygon_starts.pop() else {
                    return Err(ModErr::Fault(Fault::UnmatchedClose('}')));
                };
                let colour = self.colour();
                let poly = &self.vertices[start..];
                if poly.len() >= 3 {
                    sink.polygon(poly, colour)?;
                }
                self.vertices.truncate(start);
            }
            '.' => {
                self.vertex(self.s.pos)?;
            }
            '!' => match p.first() {
                Some(&w) => self.s.width = w,
                None => self.s.width -= self.width_inc,
            },
            '#' => match p.first() {
                Some(&w) => self.s.width = w,
                None => self.s.width += self.width_inc,
            },
            '\'' | ';' => match p.first() {
                Some(&c) => self.s.colour = c,
                None => self.s.colour += self.colour_inc,
            },
            ',' => match p.first() {
                Some(&c) => self.s.colour = c,
                None => self.s.colour -= self.colour_inc,
            },
            '_' => match p.first() {
                Some(&e) => self.s.elasticity = e,
                None => self.s.elasticity += self.elasticity_inc,
            },
            '@' => self.at = p.is_empty(),
            _ => {}
        }
        Ok(())
    }

    fn at_module(&mut self, sym: char, p: &[f64], sink: &mut dyn Sink) -> Result<(), ModErr> {
        match sym {
            'o' | 'O' => {
                let d = match p.first() {
                    Some(&d) => d,
                    None => self.drawn_width()?,
                };
                sink.dot(self.s.pos, d, self.colour(), sym == 'O')?;
            }
            'v' => self.level(),
            'M' if p.len() >= 3 => self.s.pos = [p[0], p[1], p[2]],
            // cpfg's movements: the subfunction is the next module.
            'T' if p.is_empty() => self.at_t = true,
            _ => {}
        }
        Ok(())
    }

    /// The width a line or a dot is drawn with: an error where it
    /// overflows (`!(1e308)` with `--width-scale 10`), which formats
    /// would print as `inf` or take as no width.
    fn drawn_width(&self) -> Result<f64, ModErr> {
        let w = self.s.width * self.width_scale;
        if w.is_finite() {
            Ok(w)
        } else {
            Err(ModErr::Fault(Fault::WidthOverflow))
        }
    }

    #[inline]
    fn vertex(&mut self, p: V3) -> Result<(), ModErr> {
        if !self.polygon_starts.is_empty() {
            if self.vertices.len() >= MAX_VERTICES {
                return Err(ModErr::Fault(Fault::PolygonTooLarge));
            }
            self.vertices.push(p);
        }
        Ok(())
    }

    /// Polygons opened (`{`) and not closed yet.
    pub fn open_polygons(&self) -> usize {
        self.polygon_starts.len()
    }

    /// Branches and polygons left open at the end are dropped, as cpfg does.
    pub fn depth(&self) -> usize {
        self.stack.len()
    }
}

/// Why a module could not be interpreted.
#[derive(Debug)]
pub enum ModErr {
    Fault(Fault),
    Io(io::Error),
}

impl From<io::Error> for ModErr {
    fn from(e: io::Error) -> ModErr {
        ModErr::Io(e)
    }
}
