//! cpfg's movements: the tropisms and torques of a view file's `tropism:`
//! and `torque:` lines (cpfg's `movements.c`, `turtle.c`'s
//! `adjust_up_and_left`, `quaternions.c`), which turn cpfg's turtle before
//! each move, and the `@T` commands that change their elasticities.
//!
//! Everything is in doubles, operation for operation as cpfg computes it,
//! for the turtle of the queries (`src/cpfg/query.rs`), which must reach
//! cpfg's values to the last bit a float keeps:
//!
//! - A line's text after its label is read as cpfg's `read_movement`:
//!   tokens split at blanks and `:` (numbers also at `,`); `T x y z` the
//!   direction, scaled by the inverse of its length; `I i` multiplies that
//!   factor (then clamped to [-1, 1]: cpfg clamps the factor, not the
//!   length); `A a` the angle gamma in degrees (0: towards the direction,
//!   90: perpendicular to it); `E e` the elasticity; `S s` its increment
//!   (`@Ti`, `@Td`). A line with another command, a zero direction or a
//!   zero intensity is ignored by cpfg (with a message): a warning here.
//! - cpfg sums the tropisms into globals (`gea geb gec`, each tropism's
//!   `cos gamma`, `sin gamma`, `elasticity · sin gamma`, the twist's
//!   direction and length) and updates them by differences whenever an
//!   elasticity changes: `@Ti`, `@Td`, `@Ts`, a `]` that gives an older
//!   elasticity back, and the start of each interpretation, which sets
//!   every elasticity back to the view's. [`Movements`] keeps those sums
//!   from one interpretation to the next, as cpfg does, rounding and all.
//! - Before each `F`, `G`, `f`, `g`: [`Movements::adjust`] (cpfg's
//!   `movement_adjust`): all tropisms together turn the heading by a
//!   quaternion about H × V (V the weighted sum), then `adjust_up_and_left`
//!   turns the up vector as the heading turned since the last `F` or `G`
//!   (`prev_heading`, `prev_up`); then the torques turn the up vector
//!   towards the plane of H and the twist's direction.

// (Index loops, as cpfg's code has them: the order of its operations is
// the point.)
#![allow(clippy::needless_range_loop)]

use super::state::{cross, dot, V3};

/// cpfg's `MAXMOVEMENTS`: a line past it is ignored. cpfg's
/// `movement_adjust` reads one entry past the last movement, past its
/// table with all ten: refused ([`MovementsError::Full`]).
pub const MAX_MOVEMENTS: usize = 10;

/// A movement's kind: the label it comes from.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Kind {
    /// `tropism:`
    Tropism,
    /// `torque:` (cpfg's twist)
    Twist,
}

/// One `tropism:` or `torque:` line as cpfg keeps it.
#[derive(Clone, Debug, PartialEq)]
pub struct Movement {
    pub kind: Kind,
    /// The direction, times the inverse of its length (and the intensity).
    pub dir: V3,
    /// Degrees.
    pub gamma: f64,
    /// The view's elasticity (cpfg's `initial_elasticity`).
    pub elasticity: f64,
    /// `S`: what `@Ti` and `@Td` add or take without a value.
    pub increment: f64,
}

/// Why cpfg ignores a movement line (its message).
pub type Ignored = &'static str;

/// A movement line lsgen does not follow cpfg on (cpfg crashes on it, or
/// reads it as lsgen does not): why, to follow "a line that".
pub type Crash = &'static str;

/// Read the text after a `tropism:` or `torque:` label as cpfg's
/// `read_movement` reads the rest of the line (from `fgets`, so with its
/// newline; a view file is preprocessed first, and every line of the
/// preprocessor's output ends with one): Ok(Ok(movement)), Ok(Err(why
/// cpfg ignores the line)), or Err(why cpfg crashes on it).
pub fn parse(kind: Kind, text: &str) -> Result<Result<Movement, Ignored>, Crash> {
    let mut m = Movement {
        kind,
        dir: [0.0; 3],
        gamma: 0.0,
        elasticity: 0.0,
        increment: 0.0,
    };
    // The inverse length, times the intensity.
    let mut len = 0.0f64;
    let line = format!("{text}\n");
    let mut rest = line.as_str();
    // The first command at " \t:" (a newline is a command there), the
    // others at " \t:\n", the numbers at " ,\t:" (the last one keeps
    // the newline, which `atof` passes over).
    let mut token = strtok(&mut rest, &[' ', '\t', ':']);
    while let Some(t) = token {
        let number = |rest: &mut &str| -> Result<f64, Crash> {
            let t = strtok(rest, &[' ', ',', '\t', ':'])
                .ok_or("lacks a number at its end (cpfg reads past the line)")?;
            let w = t.trim_start();
            let w = w.strip_prefix(['+', '-']).unwrap_or(w);
            if w.starts_with("0x") || w.starts_with("0X") {
                return Err("has a hexadecimal number (cpfg's atof reads it, lsgen does not)");
            }
            let v = atof(t);
            if v.is_finite() {
                Ok(v)
            } else {
                Err("has a number past the largest")
            }
        };
        match t.as_bytes()[0] {
            b'T' => {
                for k in 0..3 {
                    m.dir[k] = number(&mut rest)?;
                }
                let l = dot(m.dir, m.dir);
                if l == 0.0 {
                    return Ok(Err("a direction of length 0"));
                }
                len = 1.0 / l.sqrt();
            }
            b'I' => {
                len *= number(&mut rest)?;
                if len == 0.0 {
                    return Ok(Err("an intensity of 0 (or no direction before it)"));
                }
                len = len.clamp(-1.0, 1.0);
            }
            b'A' => m.gamma = number(&mut rest)?,
            b'E' => m.elasticity = number(&mut rest)?,
            b'S' => m.increment = number(&mut rest)?,
            _ => return Ok(Err("a command but `T`, `I`, `A`, `E` or `S`")),
        }
        token = strtok(&mut rest, &[' ', '\t', ':', '\n']);
    }
    m.dir = [m.dir[0] * len, m.dir[1] * len, m.dir[2] * len];
    Ok(Ok(m))
}

/// C's `strtok` on what `rest` holds: the delimiters skipped, the token up
/// to the next one, which is passed over (None: nothing but delimiters).
fn strtok<'a>(rest: &mut &'a str, delims: &[char]) -> Option<&'a str> {
    let s = rest.trim_start_matches(delims);
    if s.is_empty() {
        *rest = s;
        return None;
    }
    let end = s.find(delims).unwrap_or(s.len());
    let token = &s[..end];
    // (Past the delimiter that ended it: each is one byte.)
    *rest = s.get(end + 1..).unwrap_or("");
    Some(token)
}

/// C's `atof`: the longest number at the start (after blanks), else 0.
fn atof(t: &str) -> f64 {
    let t = t.trim_start();
    let n = crate::cpfg::curve::number_prefix(t);
    t[..n].parse().unwrap_or(0.0)
}

/// What cpfg cannot do with the movements as given.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum MovementsError {
    /// All ten entries used: cpfg's `movement_adjust` reads past its table.
    Full,
}

/// The turtle's frame as the movements change it, with cpfg's
/// `prev_heading` and `prev_up` (the heading and up vector at the last
/// `F` or `G`, `@Tf`, or torque).
#[derive(Clone, Copy, Debug)]
pub struct Frame {
    pub h: V3,
    pub l: V3,
    pub u: V3,
    pub prev_h: V3,
    pub prev_u: V3,
}

/// The movements of a run and cpfg's global sums of them (kept from one
/// interpretation to the next: see the module's documentation).
#[derive(Clone, Debug)]
pub struct Movements {
    list: Vec<Movement>,
    /// Each movement's current elasticity (cpfg's `EPr.movements[i]
    /// .elasticity`).
    elasticity: Vec<f64>,
    /// `gea`, `geb`, `gec`: the sum of cos(gamma) · elasticity · T.
    ge: V3,
    cos_g: Vec<f64>,
    sin_g: Vec<f64>,
    esin_g: Vec<f64>,
    twist: V3,
    twist_len: f64,
}

/// Degrees to radians as cpfg's `D_TO_R`.
#[inline]
fn radians(deg: f64) -> f64 {
    deg * std::f64::consts::PI / 180.0
}

impl Movements {
    /// The movements of a view file's lines, in order, summed as cpfg's
    /// `read_movement` does.
    pub fn new(list: Vec<Movement>) -> Result<Movements, MovementsError> {
        if list.len() >= MAX_MOVEMENTS {
            return Err(MovementsError::Full);
        }
        let n = list.len();
        let mut m = Movements {
            elasticity: list.iter().map(|m| m.elasticity).collect(),
            list,
            ge: [0.0; 3],
            cos_g: vec![0.0; n],
            sin_g: vec![0.0; n],
            esin_g: vec![0.0; n],
            twist: [0.0; 3],
            twist_len: 0.0,
        };
        for i in 0..n {
            let (dir, elast) = (m.list[i].dir, m.list[i].elasticity);
            match m.list[i].kind {
                Kind::Tropism => {
                    let g = radians(m.list[i].gamma);
                    m.cos_g[i] = g.cos();
                    m.sin_g[i] = g.sin();
                    m.esin_g[i] = elast * m.sin_g[i];
                    for k in 0..3 {
                        m.ge[k] += m.cos_g[i] * elast * dir[k];
                    }
                }
                Kind::Twist => {
                    for k in 0..3 {
                        m.twist[k] += elast * dir[k];
                    }
                    m.twist_len = dot(m.twist, m.twist).sqrt();
                }
            }
        }
        Ok(m)
    }

    /// How many there are.
    pub fn len(&self) -> usize {
        self.list.len()
    }

    pub fn is_empty(&self) -> bool {
        self.list.is_empty()
    }

    /// cpfg's `update_movement`: movement `i`'s elasticity changes by
    /// `delta`, and the sums with it.
    pub fn update(&mut self, i: usize, delta: f64) {
        let dir = self.list[i].dir;
        self.elasticity[i] += delta;
        match self.list[i].kind {
            Kind::Tropism => {
                if self.cos_g[i] != 0.0 {
                    for k in 0..3 {
                        self.ge[k] += self.cos_g[i] * delta * dir[k];
                    }
                }
                if self.sin_g[i] != 0.0 {
                    self.esin_g[i] += delta * self.sin_g[i];
                }
            }
            Kind::Twist => {
                for k in 0..3 {
                    self.twist[k] += delta * dir[k];
                }
                self.twist_len = dot(self.twist, self.twist).sqrt();
            }
        }
    }

    /// The start of an interpretation: the turtle's elasticities (`own`)
    /// are the view's again, and the sums change by the difference.
    pub fn start(&mut self, own: &mut [f64]) {
        for (i, e) in own.iter_mut().enumerate() {
            let initial = self.list[i].elasticity;
            *e = initial;
            self.update(i, initial - self.elasticity[i]);
        }
    }

    /// A `]`: the turtle's elasticities go from `now` back to `saved`.
    pub fn restore(&mut self, now: &[f64], saved: &[f64]) {
        for (i, (&s, &n)) in saved.iter().zip(now).enumerate() {
            let delta = s - n;
            if delta != 0.0 {
                self.update(i, delta);
            }
        }
    }

    /// `@T` followed by `sub` with parameters `p` (cpfg's `call_blackbox`,
    /// `case 'T'`): `i` adds to a movement's elasticity (the second
    /// parameter, else its increment), `d` takes it away, `s` sets it (to
    /// the second parameter, else 0); the first parameter numbers the
    /// movement from 1 (0 without one; out of range: nothing). None of
    /// these changes anything without a parameter. `p` turns the up vector
    /// as the heading turned since the last move (`adjust_up_and_left`),
    /// `f` takes the frame as the last move's; `x` (a texture) and any
    /// other subfunction leave the turtle as it is. `own`: the turtle's
    /// elasticities. Err: a movement number past a C `short`, which cpfg
    /// converts to one (no number of its).
    #[allow(clippy::result_unit_err)]
    pub fn at_t(&mut self, sub: char, p: &[f64], own: &mut [f64], f: &mut Frame) -> Result<(), ()> {
        let index = match p.first() {
            None => 0,
            // (cpfg: `(short)(parameter2 - 1)`, towards 0.)
            Some(&x) => {
                let i = (x - 1.0).trunc();
                if !(f64::from(i16::MIN)..=f64::from(i16::MAX)).contains(&i) {
                    return Err(());
                }
                if !(0.0..self.len() as f64).contains(&i) {
                    return Ok(());
                }
                i as usize
            }
        };
        match sub {
            // (cpfg: without a parameter the index is 0, unchecked, and
            // `p` and `f` turn the frame with no movements at all.)
            'p' => {
                adjust_up_and_left(f);
                return Ok(());
            }
            'f' => {
                f.prev_h = f.h;
                f.prev_u = f.u;
                return Ok(());
            }
            _ => {}
        }
        if sub == 'x' || index >= self.len() {
            return Ok(());
        }
        let mut aux = p.get(1).copied().unwrap_or(self.list[index].increment);
        match sub {
            'i' => {}
            'd' => aux = -aux,
            // (cpfg: the second parameter minus the elasticity, else the
            // elasticity negated: not 0 minus it, whose zero has no sign.)
            's' => {
                aux = match p.get(1) {
                    Some(&e) => e - own[index],
                    None => -own[index],
                }
            }
            _ => return Ok(()),
        }
        if !p.is_empty() {
            own[index] += aux;
            self.update(index, aux);
        }
        Ok(())
    }

    /// cpfg's `movement_adjust`, before each move.
    pub fn adjust(&self, f: &mut Frame) {
        if self.list.is_empty() {
            return;
        }
        let mut des = self.ge;
        for (i, m) in self.list.iter().enumerate() {
            if m.kind != Kind::Tropism || self.sin_g[i] == 0.0 {
                continue;
            }
            let mut vec = cross(f.h, m.dir);
            let mut len = norm(vec);
            if len < 0.0000001 {
                // H along T_i: turn about L instead.
                vec = f.l;
                len = 1.0;
            }
            let vec2 = cross(m.dir, vec);
            let k = self.esin_g[i] / len;
            for j in 0..3 {
                des[j] += k * vec2[j];
            }
        }
        let rot = cross(f.h, des);
        adjust_by_orthotropism(f, rot);
        if self.twist != [0.0; 3] {
            let mut dir = self.twist;
            normalize(&mut dir);
            let vec = cross(f.h, dir);
            if dot(vec, vec) > 0.00000001 {
                let mut des = cross(vec, f.h);
                for d in &mut des {
                    *d *= self.twist_len;
                }
                if rotate_to_vector(&mut f.u, des) {
                    f.l = cross(f.h, f.u);
                }
                f.prev_h = f.h;
                f.prev_u = f.u;
            }
        }
    }
}

/// A turtle's side of cpfg's movements in one interpretation: the run's
/// [`Movements`] (owned, or borrowed from where they go on from one
/// interpretation to the next), the turtle's own elasticity of each, and
/// those the open branches saved. One for both turtles: the queries' and
/// lsgen-turtle's.
pub struct Moving<M> {
    pub movements: M,
    own: Vec<f64>,
    saved: Vec<f64>,
}

impl<M: std::borrow::BorrowMut<Movements>> Moving<M> {
    /// The start of an interpretation ([`Movements::start`]).
    pub fn start(mut movements: M) -> Moving<M> {
        let m = movements.borrow_mut();
        let mut own = vec![0.0; m.len()];
        m.start(&mut own);
        Moving {
            movements,
            own,
            saved: Vec::new(),
        }
    }

    /// A `[`: the elasticities are saved with the turtle.
    pub fn open(&mut self) {
        self.saved.extend_from_slice(&self.own);
    }

    /// A `]` that closes a branch: its elasticities back, the sums
    /// changed by the differences ([`Movements::restore`]).
    pub fn close(&mut self) {
        let n = self.own.len();
        let Some(at) = self.saved.len().checked_sub(n) else {
            return;
        };
        self.movements
            .borrow_mut()
            .restore(&self.own, &self.saved[at..]);
        self.own.copy_from_slice(&self.saved[at..]);
        self.saved.truncate(at);
    }

    /// Before a move ([`Movements::adjust`]). An error where the frame
    /// is left no frame: elasticities near the largest number overflow
    /// cpfg's sums (its quaternion's length becomes infinite, its inverse
    /// 0), and the heading collapses to 0 or becomes NaN, where cpfg's
    /// turtle draws on with NaN.
    #[allow(clippy::result_unit_err)]
    pub fn adjust(&self, f: &mut Frame) -> Result<(), ()> {
        self.movements.borrow().adjust(f);
        // (Far from 1 however much rounding a long run has gathered.)
        let unit = (norm(f.h) - 1.0).abs() < 0.5;
        if unit && [f.h, f.l, f.u].iter().flatten().all(|x| x.is_finite()) {
            Ok(())
        } else {
            Err(())
        }
    }

    /// `@T` and its subfunction ([`Movements::at_t`]).
    #[allow(clippy::result_unit_err)]
    pub fn at_t(&mut self, sub: char, p: &[f64], f: &mut Frame) -> Result<(), ()> {
        self.movements.borrow_mut().at_t(sub, p, &mut self.own, f)
    }
}

/// Run `g` on a turtle's frame given as its vectors (H, L, U, and the
/// previous H and U), which take what `g` leaves.
pub fn with_frame<R>(v: [&mut V3; 5], g: impl FnOnce(&mut Frame) -> R) -> R {
    let [h, l, u, prev_h, prev_u] = v;
    let mut f = Frame {
        h: *h,
        l: *l,
        u: *u,
        prev_h: *prev_h,
        prev_u: *prev_u,
    };
    let r = g(&mut f);
    (*h, *l, *u, *prev_h, *prev_u) = (f.h, f.l, f.u, f.prev_h, f.prev_u);
    r
}

/// `sqrt(x*x + y*y + z*z)`, as cpfg writes it out.
#[inline]
fn norm(v: V3) -> f64 {
    (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt()
}

/// cpfg's `DNormalize`: times the inverse of the length, if not 0.
fn normalize(v: &mut V3) {
    let n = dot(*v, *v).sqrt();
    if n != 0.0 {
        let r = 1.0 / n;
        for x in v.iter_mut() {
            *x *= r;
        }
    }
}

type Quat = [f64; 4];

/// cpfg's `mult_quats`, in its order of operations.
fn mult(q1: Quat, q2: Quat) -> Quat {
    [
        q1[0] * q2[0] - (q1[1] * q2[1] + q1[2] * q2[2] + q1[3] * q2[3]),
        q1[0] * q2[1] + q2[0] * q1[1] + q1[2] * q2[3] - q1[3] * q2[2],
        q1[0] * q2[2] + q2[0] * q1[2] + q1[3] * q2[1] - q1[1] * q2[3],
        q1[0] * q2[3] + q2[0] * q1[3] + q1[1] * q2[2] - q1[2] * q2[1],
    ]
}

/// cpfg's `rot_by_quat`: v as q⁻¹ v q.
fn rot_by_quat(v: &mut V3, q: Quat) {
    let size = 1.0 / (q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3]);
    let qi = [size * q[0], -size * q[1], -size * q[2], -size * q[3]];
    let r = mult(mult(qi, [0.0, v[0], v[1], v[2]]), q);
    *v = [r[1], r[2], r[3]];
}

/// The quaternion of a turn by `angle` (already halved) about the unit
/// vector `v`.
#[inline]
fn quat(angle: f64, v: V3) -> Quat {
    let s = angle.sin();
    [angle.cos(), s * v[0], s * v[1], s * v[2]]
}

/// cpfg's `adjust_by_orthotropism`: H turns about `vec` by half its
/// length (at most 1/2), then U and L follow ([`adjust_up_and_left`]).
fn adjust_by_orthotropism(f: &mut Frame, mut vec: V3) {
    let mut len = norm(vec);
    if len < 0.000001 {
        return;
    }
    if len > 1.0 {
        len = 1.0;
    }
    let angle = -len * 0.5;
    let r = 1.0 / len;
    for x in &mut vec {
        *x *= r;
    }
    rot_by_quat(&mut f.h, quat(angle, vec));
    adjust_up_and_left(f);
}

/// cpfg's `adjust_up_and_left` (turtle.c): the up vector turned from the
/// last move's as the heading turned, then L = H × U.
pub fn adjust_up_and_left(f: &mut Frame) {
    let mut rot = cross(f.h, f.prev_h);
    let mut len = norm(rot);
    if len > 0.000001 {
        f.u = f.prev_u;
        if len > 1.0 {
            len = 1.0;
        }
        let mut angle = len.asin() * 0.5;
        if dot(f.h, f.prev_h) < 0.0 {
            angle = std::f64::consts::PI * 0.5 - angle;
        }
        for x in &mut rot {
            *x /= len;
        }
        rot_by_quat(&mut f.u, quat(angle, rot));
    }
    f.l = cross(f.h, f.u);
}

/// cpfg's `rotate_to_vector` (the torque): `v` turns towards `des` by half
/// the length of v × des (at most 1/2); false if they are aligned.
fn rotate_to_vector(v: &mut V3, des: V3) -> bool {
    let mut vec = cross(*v, des);
    let mut len = norm(vec);
    if len < 0.0000001 {
        return false;
    }
    if len > 1.0 {
        len = 1.0;
    }
    let angle = len * 0.5;
    for x in &mut vec {
        *x /= len;
    }
    rot_by_quat(v, quat(angle, vec));
    true
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn lines_read_as_cpfg_reads_them() {
        let read = |t: &str| parse(Kind::Tropism, t).unwrap().unwrap();
        let m = read(" T: 0.0  2.0 0.0  A:90");
        assert_eq!(m.dir, [0.0, 1.0, 0.0]);
        assert_eq!(m.gamma, 90.0);
        let m = read("T: 0,3,4 E: 0.2 S:0.05");
        assert_eq!(m.dir, [0.0, 0.6000000000000001, 0.8], "{m:?}");
        assert_eq!((m.elasticity, m.increment), (0.2, 0.05));
        // The intensity times the inverse length, clamped to 1: T of
        // length 2, I 3 gives 1.5, so the direction keeps length 2.
        let m = read("T 0 2 0 I 3");
        assert_eq!(m.dir, [0.0, 2.0, 0.0]);
        // The line's newline as a number is 0 (`E:` last); as the first
        // command, no command of cpfg's (an empty line is ignored).
        assert_eq!(read("T: 1 0 0 E:").elasticity, 0.0);
        assert_eq!(read("T: 1 0 ").dir, [1.0, 0.0, 0.0]);
        for (text, why) in [
            ("", "a command but"),
            ("T: 0 0 0", "length 0"),
            ("I: 2 T: 0 1 0", "intensity of 0"),
            ("T: 0 1 0 X: 1", "a command but"),
        ] {
            let e = parse(Kind::Tropism, text).unwrap().unwrap_err();
            assert!(e.contains(why), "{text}");
        }
        // A number missing past the last one: cpfg reads past the line.
        for (text, why) in [
            ("T: 1 0", "lacks a number"),
            ("E: 1e999", "past the largest"),
            ("E: -0x1", "hexadecimal"),
        ] {
            assert!(
                parse(Kind::Tropism, text).unwrap_err().contains(why),
                "{text}"
            );
        }
        // No direction: none (cpfg scales the zero vector by 0).
        assert_eq!(read("E: 1").dir, [0.0; 3]);
    }

    /// A quaternion turn of (0,1,0) by 90° about +z (angle 45°, halved),
    /// as q⁻¹ v q: cpfg's convention turns it to (1,0,0) (the other way
    /// round from q v q⁻¹).
    #[test]
    fn quaternions_turn_as_cpfg_turns() {
        let mut v = [0.0, 1.0, 0.0];
        rot_by_quat(&mut v, quat(std::f64::consts::FRAC_PI_4, [0.0, 0.0, 1.0]));
        assert!((v[0] - 1.0).abs() < 1e-15 && v[1].abs() < 1e-15, "{v:?}");
    }

    /// The sums come back by differences: +0.3 then -0.3 from 0.2 is not
    /// always 0.2 in doubles, and cpfg keeps what it gets.
    #[test]
    fn sums_change_by_differences() {
        let m = parse(Kind::Tropism, "T: 1 0 0 E: 0.2").unwrap().unwrap();
        let mut ms = Movements::new(vec![m]).unwrap();
        assert_eq!(ms.ge, [0.2, 0.0, 0.0]);
        let mut own = [0.0];
        ms.start(&mut own);
        assert_eq!(own, [0.2]);
        let mut f = Frame {
            h: [0.0, 1.0, 0.0],
            l: [-1.0, 0.0, 0.0],
            u: [0.0, 0.0, -1.0],
            prev_h: [0.0, 1.0, 0.0],
            prev_u: [0.0, 0.0, -1.0],
        };
        ms.at_t('s', &[1.0, 0.5], &mut own, &mut f).unwrap();
        assert_eq!(own, [0.5]);
        assert_eq!(ms.ge[0], 0.2 + (0.5 - 0.2));
        ms.restore(&[0.5], &[0.2]);
        assert_eq!(ms.ge[0], 0.2 + (0.5 - 0.2) + (0.2 - 0.5));
        // Out of range, or without a parameter: nothing.
        ms.at_t('i', &[2.0, 1.0], &mut own, &mut f).unwrap();
        ms.at_t('i', &[], &mut own, &mut f).unwrap();
        assert_eq!(own, [0.5]);
        // A movement number cpfg's `(short)` cannot hold.
        assert!(ms.at_t('i', &[40000.0], &mut own, &mut f).is_err());
        let twist = parse(Kind::Twist, "T 1 0 0").unwrap().unwrap();
        assert!(Movements::new(vec![twist; 10]).is_err());
    }
}
