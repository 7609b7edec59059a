//! cpfg's contour curves: `curveX(id, t)`, `curveY(id, t)`, `curveZ(id, t)`
//! and `curveGAL(id)` (cpfg's `curveXYZ.cpp`, `curveXYZc.cpp`; the view
//! file's `curve: FILE [SAMPLES]` lines, `interpret.c`).
//!
//! A curve is a contour file of vlab's curve editor (`.con`, the
//! `version: 1.4` format): control points (x, y, z) of a cubic spline of
//! one of five kinds (`type:`). When the file is read, cpfg samples the
//! curve at SAMPLES (100 by default) evenly spaced parameters and sums the
//! lengths of the chords between them: that polyline's length is
//! `curveGAL(id)`, and the partial sums, divided by it, map arc length to
//! parameter. `curveX(id, t)` (t clamped to [0, 1]) finds the chord where
//! that fraction of the length is reached, interpolates the parameter
//! linearly within it, and gives the x of the curve's point there. The
//! arithmetic is cpfg's, operation for operation.
//!
//! Curves are numbered 1, 2, ... in the order the files give them
//! (`--functions`, then each view file's `curve:` lines), apart from the
//! functions: cpfg keeps them in a table of their own.

use super::func::{clamped_basis, clamped_sum, Spot, MAX_POINTS};
use crate::diag::{Error, FuncFault, FunctionFileError as E};

/// The samples of a curve whose view line gives none (cpfg's default).
pub const DEFAULT_SAMPLES: i64 = 100;
/// cpfg reads a contour file's lines into a buffer of 256 bytes.
const MAX_LINE: usize = 255;

/// The kinds of curve cpfg evaluates (`type:`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Kind {
    /// `bspline` (and any word cpfg does not know): uniform cubic
    /// B-spline, knots 0, 1, 2, ...
    BSpline,
    /// `bspline-closed`: the first three points again at the end.
    Closed,
    /// `bspline-phantom`: a phantom point mirrored at each end.
    Phantom,
    /// `bspline-endpoint`: knots clamped at both ends (as `func`'s).
    Endpoint,
    /// `bezier`: cubic Bézier segments sharing their end points.
    Bezier,
}

/// Which of cpfg's curve functions.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Coordinate {
    X,
    Y,
    Z,
}

impl Coordinate {
    pub fn name(self) -> &'static str {
        match self {
            Coordinate::X => "curveX",
            Coordinate::Y => "curveY",
            Coordinate::Z => "curveZ",
        }
    }
}

/// One curve, as cpfg holds it once read.
#[derive(Clone, Debug)]
pub struct Curve {
    /// The file, for messages.
    pub source: String,
    kind: Kind,
    /// cpfg's `_ppoint`: the control points with their multiplicities,
    /// and the extra ones of a closed or phantom curve.
    points: Vec<[f64; 3]>,
    /// cpfg's `_apoint[i]._l`: the length up to sample i over the whole.
    fractions: Vec<f64>,
    /// cpfg's `_alength`: the length of the polyline through the samples.
    length: f64,
}

/// cpfg's `Bi1` to `Bi4`: the uniform B-spline basis, knots 0, 1, 2, ...
fn uniform_basis(order: i64, i: i64, t: f64) -> f64 {
    let ti = |j: i64| j as f64;
    if order == 1 {
        return if ti(i) <= t && t < ti(i + 1) {
            1.0
        } else {
            0.0
        };
    }
    (t - ti(i)) / (ti(i + order - 1) - ti(i)) * uniform_basis(order - 1, i, t)
        + (ti(i + order) - t) / (ti(i + order) - ti(i + 1)) * uniform_basis(order - 1, i + 1, t)
}

impl Curve {
    /// The curve of `control` (points and multiplicities, as read) of this
    /// kind, sampled `samples` times (2 to [`super::func::MAX_SAMPLES`]).
    fn new(
        source: String,
        kind: Kind,
        control: &[([f64; 3], u64)],
        samples: usize,
    ) -> Result<Curve, E> {
        // cpfg's createPPoints.
        let count: u64 = control.iter().map(|c| c.1).sum();
        let (extra, offset) = match kind {
            Kind::Closed => (3, 0),
            Kind::Phantom => (2, 1),
            _ => (0, 0),
        };
        let size = count as usize + extra;
        if size < 4 {
            return Err(E::TooFewCurvePoints(size as u64));
        }
        let mut points = vec![[0.0; 3]; size];
        let mut p = offset;
        for &(point, times) in control {
            for _ in 0..times {
                points[p] = point;
                p += 1;
            }
        }
        if kind == Kind::Closed {
            for i in 0..3 {
                points[size - 3 + i] = points[i];
            }
        }
        if kind == Kind::Phantom {
            let mirror = |a: [f64; 3], b: [f64; 3]| [0, 1, 2].map(|c| 2.0 * a[c] - b[c]);
            points[0] = mirror(points[1], points[2]);
            points[size - 1] = mirror(points[size - 2], points[size - 3]);
        }
        let mut curve = Curve {
            source,
            kind,
            points,
            fractions: Vec::with_capacity(samples),
            length: 0.0,
        };
        // cpfg's createAPoints.
        let mut previous = [0.0; 3];
        for i in 0..samples {
            let t = i as f64 / (samples - 1) as f64;
            let p = curve.point(t);
            if i > 0 {
                let (dx, dy, dz) = (p[0] - previous[0], p[1] - previous[1], p[2] - previous[2]);
                curve.length += (dx * dx + dy * dy + dz * dz).sqrt();
            }
            curve.fractions.push(curve.length);
            previous = p;
        }
        let length = curve.length;
        for l in &mut curve.fractions {
            *l /= length;
        }
        Ok(curve)
    }

    /// cpfg's `calcPValue`: the curve's point at parameter t in [0, 1].
    fn point(&self, t: f64) -> [f64; 3] {
        let p = &self.points;
        let size = p.len() as i64;
        // (Sums written out as cpfg writes them: the first term is not
        // added to +0, which keeps the sign of a zero.)
        let four = |i: usize, b: [f64; 4]| -> [f64; 3] {
            let mut out = [0.0; 3];
            for (c, o) in out.iter_mut().enumerate() {
                *o = p[i][c] * b[0] + p[i + 1][c] * b[1] + p[i + 2][c] * b[2] + p[i + 3][c] * b[3];
            }
            out
        };
        match self.kind {
            Kind::Endpoint => clamped_sum(p, t * (size as f64 - 3.000001)),
            Kind::Bezier => {
                let n = 1 + (size - 4) / 3;
                let c = (t / (1.000001 / n as f64)) as i64;
                let t = (t - c as f64 * (1.0 / n as f64)) * n as f64 / 1.000001;
                let b = [0, 1, 2, 3].map(|k| clamped_basis(4, k, 4, t));
                four(c as usize * 3, b)
            }
            Kind::BSpline | Kind::Closed | Kind::Phantom => {
                let span = size as f64 - 3.000001;
                let i = 3 + (t * span) as i64;
                let u = 3.0 + t * span;
                let b = [i - 3, i - 2, i - 1, i].map(|k| uniform_basis(4, k, u));
                four(i as usize - 3, b)
            }
        }
    }

    /// `curveGAL(id)`: the length of the sampled polyline.
    pub fn length(&self) -> f64 {
        self.length
    }

    /// cpfg's `CurveCXS` and the like: t clamped to [0, 1], then
    /// `calcAValue`, the point at that fraction of the polyline's length.
    pub fn at(&self, t: f64, which: Coordinate, id: usize) -> Result<f64, FuncFault> {
        let name = which.name();
        // (NaN stays NaN, as in cpfg's comparisons.)
        let t = t.clamp(0.0, 1.0);
        if t.is_nan() {
            return Err(FuncFault::CurveNotANumber { name });
        }
        let l = &self.fractions;
        let (mut min, mut max) = (0, l.len() - 1);
        while max - min > 1 {
            let med = (min + max) / 2;
            if l[med] > t {
                max = med;
            } else {
                min = med;
            }
        }
        let u = (min as f64 + ((t - l[min]) / (l[max] - l[min]))) / (l.len() - 1) as f64;
        // A curve of length 0, or a last chord of none at t = 1: 0 / 0,
        // and cpfg indexes its points with (int) NaN.
        if !(0.0..=1.0).contains(&u) {
            return Err(FuncFault::CurveUndefined { name, id, t });
        }
        let p = self.point(u);
        Ok(match which {
            Coordinate::X => p[0],
            Coordinate::Y => p[1],
            Coordinate::Z => p[2],
        })
    }

    /// A contour file (`curve:`'s FILE, or given directly), sampled
    /// `samples` times (checked by the caller).
    pub fn read(name: &str, text: &str, samples: usize) -> Result<Curve, Error> {
        ContourReader::new(name, text).read(samples)
    }

    /// The points kept and the samples computed, for the limits.
    pub fn cost(&self) -> (u64, u64) {
        (self.points.len() as u64, self.fractions.len() as u64)
    }
}

/// C's `isspace` (what `%s` and `%f` skip).
fn c_space(c: char) -> bool {
    matches!(c, ' ' | '\t' | '\n' | '\x0b' | '\x0c' | '\r')
}

/// The longest prefix of `s` that C's `strtod` reads as a decimal number
/// (`[+-] digits [. digits] [e [+-] digits]`, or `inf`, `infinity`,
/// `nan`): its length, 0 if none.
pub(crate) fn number_prefix(s: &str) -> usize {
    let b = s.as_bytes();
    let mut i = 0;
    if i < b.len() && (b[i] == b'+' || b[i] == b'-') {
        i += 1;
    }
    let lower = s[i..].to_ascii_lowercase();
    for word in ["infinity", "inf", "nan"] {
        if lower.starts_with(word) {
            return i + word.len();
        }
    }
    let digits = |mut j: usize| {
        while j < b.len() && b[j].is_ascii_digit() {
            j += 1;
        }
        j
    };
    let int_end = digits(i);
    let mut end = int_end;
    let mut any = int_end > i;
    if end < b.len() && b[end] == b'.' {
        let frac_end = digits(end + 1);
        any |= frac_end > end + 1;
        end = frac_end;
    }
    if !any {
        return 0;
    }
    if end < b.len() && (b[end] == b'e' || b[end] == b'E') {
        let mut j = end + 1;
        if j < b.len() && (b[j] == b'+' || b[j] == b'-') {
            j += 1;
        }
        let exp_end = digits(j);
        if exp_end > j {
            end = exp_end;
        }
    }
    end
}

/// C's `atof` of a word: its longest number prefix, 0 without one. None:
/// a hexadecimal number (which lsgen does not read) or a value that is not
/// finite.
fn atof(w: &str) -> Option<f64> {
    let digits = w.trim_start_matches(['+', '-']);
    if digits.starts_with("0x") || digits.starts_with("0X") {
        return None;
    }
    let n = number_prefix(w);
    let v = if n == 0 {
        0.0
    } else {
        w[..n].parse::<f64>().ok()?
    };
    v.is_finite().then_some(v)
}

/// `sscanf`'s `%f`, `n` times, at the start of `s`: did all match?
fn scan_floats(s: &str, n: usize) -> bool {
    let mut rest = s;
    for _ in 0..n {
        rest = rest.trim_start_matches(c_space);
        let k = number_prefix(rest);
        if k == 0 {
            return false;
        }
        rest = &rest[k..];
    }
    true
}

/// `sscanf`'s `%i` at the start of `s` (decimal, `0x` hexadecimal, `0`
/// octal), within i64.
fn scan_int(s: &str) -> Option<i64> {
    let s = s.trim_start_matches(c_space);
    let (neg, s) = match s.as_bytes().first() {
        Some(b'-') => (true, &s[1..]),
        Some(b'+') => (false, &s[1..]),
        _ => (false, s),
    };
    let (radix, digits) = if let Some(h) = s.strip_prefix("0x").or(s.strip_prefix("0X")) {
        if h.starts_with(|c: char| c.is_ascii_hexdigit()) {
            (16, h)
        } else {
            (10, "0")
        }
    } else if s.starts_with('0') {
        (8, s)
    } else {
        (10, s)
    };
    let end = digits
        .find(|c: char| !c.is_digit(radix))
        .unwrap_or(digits.len());
    let v = i64::from_str_radix(&digits[..end], radix).ok()?;
    Some(if neg { -v } else { v })
}

/// Line by line through a contour file, as cpfg's `openCurve` and
/// `readCurve` read it.
struct ContourReader<'a> {
    name: &'a str,
    text: &'a str,
    /// Start of the current line.
    line_at: usize,
}

impl<'a> ContourReader<'a> {
    fn new(name: &'a str, text: &'a str) -> ContourReader<'a> {
        ContourReader {
            name,
            text,
            line_at: 0,
        }
    }

    fn fail<T>(&self, e: E) -> Result<T, Error> {
        Err(Spot {
            name: self.name.to_string(),
            text: self.text.to_string(),
            offset: self.line_at,
        }
        .error(e))
    }

    fn read(&mut self, samples: usize) -> Result<Curve, Error> {
        let text = self.text;
        let mut kind = Kind::BSpline;
        // After `points: N`: N, and the dimension of its point lines.
        let mut declared: Option<usize> = None;
        let mut dimension = 2;
        let mut control: Vec<([f64; 3], u64)> = Vec::new();
        let mut total: u64 = 0;
        let mut offset = 0;
        while offset < text.len() {
            self.line_at = offset;
            let Some(end) = text[offset..].find('\n') else {
                // cpfg reads characters until a newline, past its buffer.
                return self.fail(E::Expected("a newline at the end of the last line"));
            };
            let line = &text[offset..offset + end];
            offset += end + 1;
            if line.len() > MAX_LINE {
                return self.fail(E::TooMany {
                    what: "characters in a line (cpfg's buffer holds 255)",
                    limit: MAX_LINE as u64,
                });
            }
            // cpfg's labels, in its order, each a prefix of the line.
            const LABELS: [&str; 12] = [
                "//",
                "version:",
                "contact:",
                "end:",
                "heading:",
                "up:",
                "size:",
                "points:",
                "range:",
                "dim:",
                "dimension:",
                "type:",
            ];
            let label = LABELS.iter().find(|l| line.starts_with(**l));
            let rest = label.map_or("", |l| &line[l.len()..]);
            let floats = |n: usize, what: &'static str| {
                if scan_floats(rest, n) {
                    Ok(())
                } else {
                    self.fail(E::Expected(what))
                }
            };
            match label.copied() {
                Some("//") => {}
                Some("version:") => {
                    if rest.trim_start_matches(c_space).is_empty() {
                        return self.fail(E::Expected("`version: V`"));
                    }
                }
                Some("contact:") => floats(3, "`contact: X Y Z`")?,
                Some("end:") => floats(3, "`end: X Y Z`")?,
                Some("heading:") => floats(3, "`heading: X Y Z`")?,
                Some("up:") => floats(3, "`up: X Y Z`")?,
                Some("size:") => floats(1, "`size: S`")?,
                Some("range:") => floats(2, "`range: LOW HIGH`")?,
                Some("points:") => {
                    let Some(n) = scan_int(rest) else {
                        return self.fail(E::Expected("`points: N`"));
                    };
                    if declared.is_some() {
                        // cpfg's editor nests a curve under the last point
                        // read (a "variety"); lsgen reads one curve.
                        return self.fail(E::CurveUnsupported(
                            "a second `points:` line (a curve nested in a point)",
                        ));
                    }
                    if n < 0 {
                        return self.fail(E::Expected("`points: N` with N at least 0"));
                    }
                    if n as u64 > MAX_POINTS {
                        return self.fail(E::TooMany {
                            what: "control points",
                            limit: MAX_POINTS,
                        });
                    }
                    declared = Some(n as usize);
                    dimension = 2;
                }
                Some("dim:") | Some("dimension:") => {
                    let Some(d) = scan_int(rest) else {
                        return self.fail(E::Expected("`dimension: D`"));
                    };
                    if declared.is_none() {
                        return self.fail(E::Expected("`points: N` before `dimension:`"));
                    }
                    if !(2..=4).contains(&d) {
                        return self.fail(E::CurveUnsupported(
                            "a dimension other than 2, 3 or 4 (x y, x y z, x y z multiplicity)",
                        ));
                    }
                    dimension = d as usize;
                }
                Some(_) => {
                    // `type:`
                    let word = rest.split(c_space).find(|w| !w.is_empty());
                    let Some(word) = word else {
                        return self.fail(E::Expected("`type: TYPE`"));
                    };
                    if declared.is_none() {
                        return self.fail(E::Expected("`points: N` before `type:`"));
                    }
                    kind = match word {
                        "bezier-surface" => {
                            return self.fail(E::CurveUnsupported("`type: bezier-surface`"))
                        }
                        "bezier" => Kind::Bezier,
                        "bspline-phantom" => Kind::Phantom,
                        "bspline-endpoint" => Kind::Endpoint,
                        "bspline-closed" => Kind::Closed,
                        _ => Kind::BSpline,
                    };
                }
                None if line.len() <= 2 || line.contains(':') => {}
                None => {
                    let Some(n) = declared else {
                        return self.fail(E::Expected("`points: N` before the points"));
                    };
                    let words: Vec<&str> = line.split(c_space).filter(|w| !w.is_empty()).collect();
                    if words.len().min(4) != dimension {
                        return self.fail(E::Expected(match dimension {
                            2 => "a point `X Y` (dimension 2)",
                            3 => "a point `X Y Z` (dimension 3)",
                            _ => "a point `X Y Z MULTIPLICITY` (dimension 4)",
                        }));
                    }
                    if control.len() >= n {
                        return self.fail(E::Expected("no more points than `points:` gives"));
                    }
                    let mut v = [0.0; 4];
                    for (slot, w) in v.iter_mut().zip(&words) {
                        let Some(x) = atof(w) else {
                            return self.fail(E::Expected("a finite decimal number"));
                        };
                        *slot = x;
                    }
                    let times = if dimension == 4 { v[3].trunc() } else { 1.0 };
                    if times < 0.0 {
                        return self.fail(E::Expected("a multiplicity of 0 or more"));
                    }
                    total = total.saturating_add(times.min(u64::MAX as f64) as u64);
                    if total > MAX_POINTS {
                        return self.fail(E::TooMany {
                            what: "control points",
                            limit: MAX_POINTS,
                        });
                    }
                    let z = if dimension > 2 { v[2] } else { 0.0 };
                    control.push(([v[0], v[1], z], times as u64));
                }
            }
        }
        // Points `points:` promises but the file lacks are cpfg's default
        // ones: the origin, once.
        let n = declared.unwrap_or(0);
        let missing = n.saturating_sub(control.len());
        self.line_at = 0;
        if total + missing as u64 > MAX_POINTS {
            return self.fail(E::TooMany {
                what: "control points",
                limit: MAX_POINTS,
            });
        }
        control.resize(control.len() + missing, ([0.0; 3], 1));
        Curve::new(self.name.to_string(), kind, &control, samples).or_else(|e| self.fail(e))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn curve(text: &str, samples: usize) -> Curve {
        Curve::read("c.con", text, samples).unwrap()
    }

    const HEAD: &str =
        "version: 1.4\ncontact: 0 0 0\nend: 0 0 0\nheading: 0 1 0\nup: 0 0 -1\nsize: 1\n";

    #[test]
    fn a_straight_line_is_its_own_arc_length() {
        // Control points k (3, 4), k = 0..3: the uniform B-spline is
        // (u - 2) (3, 4) at knot parameter u, which runs from 3 to
        // 4 - 1e-6: from (3, 4) to (6, 8) less 1e-6 of (3, 4), linearly
        // in t, length 5 (1 - 1e-6).
        let text = format!(
            "{HEAD}points: 4\nrange: 0.0 1.0\ndimension: 4\ntype: bspline\n0 0 0 1\n3 4 0 1\n6 8 0 1\n9 12 0 1\n"
        );
        let c = curve(&text, 100);
        assert!((c.length() - 4.999995).abs() < 1e-12, "{}", c.length());
        for t in [0.0, 0.1, 0.5, 0.77, 1.0] {
            let x = c.at(t, Coordinate::X, 1).unwrap();
            let y = c.at(t, Coordinate::Y, 1).unwrap();
            let s = 1.0 + t * (1.0 - 1e-6);
            assert!(
                (x - 3.0 * s).abs() < 1e-12 && (y - 4.0 * s).abs() < 1e-12,
                "{t}: {x} {y}"
            );
            assert_eq!(c.at(t, Coordinate::Z, 1).unwrap(), 0.0);
        }
        // End points 3 times (as vlab's editor writes them): from (0, 0)
        // to (3, 4) along the line, not at constant speed; the chords of
        // 100 samples give x = 3t within 1e-3.
        let text = format!("{HEAD}points: 2\ndimension: 4\n0 0 0 3\n3 4 0 3\n");
        let c = curve(&text, 100);
        assert!((c.length() - 5.0).abs() < 1e-5, "{}", c.length());
        for t in [0.0, 0.1, 0.5, 0.77, 1.0] {
            let x = c.at(t, Coordinate::X, 1).unwrap();
            assert!((x - 3.0 * t).abs() < 1e-3, "{t}: {x}");
        }
        assert_eq!(c.at(-2.0, Coordinate::X, 1), c.at(0.0, Coordinate::X, 1));
        assert_eq!(c.at(9.0, Coordinate::Y, 1), c.at(1.0, Coordinate::Y, 1));
        assert_eq!(
            c.at(f64::NAN, Coordinate::X, 1),
            Err(FuncFault::CurveNotANumber { name: "curveX" })
        );
    }

    #[test]
    fn kinds_are_cpfg_s() {
        // The same four points, read as each kind.
        let pts = "0 0 0\n1 2 0\n2 2 1\n3 0 1\n";
        let of = |kind: &str| curve(&format!("points: 4\ndimension: 3\ntype: {kind}\n{pts}"), 2);
        // Bézier and clamped: through the end points at t = 0.
        for k in ["bezier", "bspline-endpoint"] {
            assert_eq!(of(k).point(0.0), [0.0, 0.0, 0.0], "{k}");
        }
        // Uniform: at t = 0, (P0 + 4 P1 + P2) / 6.
        let p = of("bspline").point(0.0);
        let want = [(0.0 + 4.0 + 2.0) / 6.0, (0.0 + 8.0 + 2.0) / 6.0, 1.0 / 6.0];
        for c in 0..3 {
            assert!((p[c] - want[c]).abs() < 1e-12, "{p:?}");
        }
        // Closed: three more points, the first three again.
        let c = of("bspline-closed");
        assert_eq!(c.points.len(), 7);
        assert_eq!(c.points[4..], c.points[..3]);
        // Phantom: mirrored ends.
        let c = of("bspline-phantom");
        assert_eq!(c.points[0], [-1.0, -2.0, 0.0]);
        assert_eq!(c.points[5], [4.0, -2.0, 1.0]);
        // An unknown word is a uniform B-spline.
        assert_eq!(of("spline").kind, Kind::BSpline);
        // One Bézier segment: the Bernstein polynomials at t / 1.000001
        // (cpfg's divisor keeps t inside the segment).
        let c = of("bezier");
        let pts = [
            [0.0, 0.0, 0.0],
            [1.0, 2.0, 0.0],
            [2.0, 2.0, 1.0],
            [3.0, 0.0, 1.0],
        ];
        for t in [0.0, 0.3, 0.5, 1.0] {
            let s = t / 1.000001;
            let w = [
                (1.0 - s) * (1.0 - s) * (1.0 - s),
                3.0 * s * (1.0 - s) * (1.0 - s),
                3.0 * s * s * (1.0 - s),
                s * s * s,
            ];
            let p = c.point(t);
            for d in 0..3 {
                let want: f64 = (0..4).map(|k| w[k] * pts[k][d]).sum();
                assert!((p[d] - want).abs() < 1e-12, "{t}: {p:?}");
            }
        }
    }

    #[test]
    fn multiplicities_and_missing_points() {
        let c = curve("points: 3\ndimension: 4\n0 0 0 2\n1 1 0 0\n2 0 0 3\n", 2);
        assert_eq!(
            c.points,
            vec![
                [0.0; 3],
                [0.0; 3],
                [2.0, 0.0, 0.0],
                [2.0, 0.0, 0.0],
                [2.0, 0.0, 0.0]
            ]
        );
        // Points the file promises but lacks are the origin.
        let c = curve("points: 5\n1 1\n2 2\n", 2);
        assert_eq!(c.points[2..], [[0.0; 3]; 3]);
    }

    #[test]
    fn length_zero_has_no_arc_length() {
        let c = curve("points: 4\n0 0\n0 0\n0 0\n0 0\n", 10);
        assert_eq!(c.length(), 0.0);
        assert!(matches!(
            c.at(0.5, Coordinate::Y, 2),
            Err(FuncFault::CurveUndefined { id: 2, .. })
        ));
    }

    #[test]
    fn lines_are_read_as_cpfg_reads_them() {
        // Short lines, unknown labels and indented labels are skipped; a
        // point's fifth word is ignored; atof reads prefixes.
        let c = curve(
            "name: x\n  points: 9\n12\npoints: 4\ndimension: 4\n0 0 0 1 extra\n1e0x 0 0 1\nab 0 0 1\n3 0 0 1\n",
            2,
        );
        assert_eq!(c.points[1], [1.0, 0.0, 0.0]);
        assert_eq!(c.points[2], [0.0, 0.0, 0.0]);
        assert_eq!(scan_int(" 010"), Some(8));
        assert_eq!(scan_int("0x1f"), Some(31));
        assert_eq!(number_prefix("-1.5e3x"), 6);
        assert_eq!(number_prefix("1e"), 1);
        assert_eq!(number_prefix("."), 0);
    }

    #[test]
    fn bad_files_are_located_errors() {
        let cases = [
            ("points: 4\n0 0\n1 1\n2 2\n3 3", 5, "newline"),
            ("0 0\npoints: 4\n", 1, "`points: N` before the points"),
            ("dimension: 3\npoints: 4\n", 1, "before `dimension:`"),
            ("points: 4\ntype: bezier-surface\n", 2, "bezier-surface"),
            ("points: 4\n0 0\npoints: 2\n", 3, "second `points:`"),
            ("points: 2\n0 0\n1 1\n2 2\n", 4, "no more points"),
            ("points: 4\ndimension: 4\n0 0 0 -1\n", 3, "multiplicity"),
            ("points: 4\ndimension: 3\n0 0\n", 3, "`X Y Z`"),
            ("points: 4\ndimension: 5\n", 2, "dimension other"),
            ("contact: 0 0\n", 1, "`contact: X Y Z`"),
            ("points: 3\n0 0\n1 1\n2 2\n", 1, "at least 4"),
            ("points: 4\n0x1 0\n", 2, "finite decimal"),
            // Multiplicities, then points promised but missing.
            (
                "points: 9\ndimension: 4\n0 0 0 65530\n",
                1,
                "more than 65536 control points",
            ),
        ];
        for (text, line, msg) in cases {
            let e = Curve::read("x.con", text, 100).unwrap_err().to_string();
            assert!(e.starts_with(&format!("x.con:{line}:")), "{text:?}: {e}");
            assert!(e.contains(msg), "{text:?}: {e}");
        }
    }
}
