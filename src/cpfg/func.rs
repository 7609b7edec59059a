//! cpfg's graphically defined functions: `func(id, x)` (cpfg's
//! `splinefun.cpp`, `splinearr.cpp`; the view file's `function:` and
//! `function set:` lines, `interpret.c`).
//!
//! A function is a curve drawn in vlab's function editor: control points
//! (x, y) of a uniform cubic B-spline whose end knots are clamped. Its
//! value at x (clamped to [0, 1]) is the y of the curve point whose x is
//! within 0.001 of it, found by bisection on the curve's parameter; a
//! function with more than 2 samples (its file's `samples:`, or the view
//! line's number for the old format) is evaluated at that many evenly
//! spaced x once, and then read by linear interpolation. The arithmetic is
//! cpfg's, operation for operation: the strings match cpfg's.
//!
//! Functions are numbered 1, 2, ... in the order the files give them
//! (`--functions`, then each view file's lines); a function set's names
//! are object-like macros of the `.l` file's preprocessor, each its
//! number, as cpfg defines them.

use super::curve::{Coordinate, Curve, DEFAULT_SAMPLES};
use crate::diag::{CodeMap, Error, FuncFault, FunctionFileError as E, IoAction, Location};
use std::path::{Path, PathBuf};

/// Most control points of one function (repeated points counted).
pub const MAX_POINTS: u64 = 1 << 16;
/// Most samples of one function's table.
pub const MAX_SAMPLES: u64 = 1 << 16;
/// Most functions in one run.
pub const MAX_FUNCTIONS: u64 = 4096;
/// Most control points, and most samples, of all the functions together
/// (16 and 8 MiB).
pub const MAX_TOTAL: u64 = 1 << 20;
/// The bisection halves the interval until it stops changing (at most
/// about 1,100 times for a double): past this many steps it never ends.
const MAX_BISECTION: u32 = 2000;

/// One function.
#[derive(Clone, Debug)]
pub struct Function {
    /// Where it comes from, for messages: the file, and a set's name.
    pub source: String,
    /// The control points, as cpfg stores them (read as 32-bit floats).
    points: Vec<[f64; 2]>,
    /// The precomputed values (more than 2 samples), else empty.
    table: Vec<f64>,
}

/// The functions of a run, and the macros a function set defines; and
/// its curves (`curveX` and the like, `src/cpfg/curve.rs`), numbered apart
/// as in cpfg.
#[derive(Clone, Debug, Default)]
pub struct Functions {
    items: Vec<Function>,
    curves: Vec<Curve>,
    /// A set's function names (C identifiers) and their numbers.
    macros: Vec<(String, usize)>,
    /// Samples computed so far, also for functions a later `function
    /// set:` replaced: the work of loading is bounded too.
    computed: u64,
    /// The view file (`--cpfg-view`): its turtle's settings are read
    /// where a file has queries (a label they need that cpfg cannot read
    /// is an error there only, as cpfg only warns).
    view: Option<PathBuf>,
}

impl Function {
    /// `points` (at least 4) with `samples` samples (more than 2: a
    /// table). None: the curve does not reach one of the sample x.
    fn new(source: String, points: Vec<[f64; 2]>, samples: i64) -> Result<Function, f64> {
        let mut f = Function {
            source,
            points,
            table: Vec::new(),
        };
        if samples > 2 {
            let s = samples as usize;
            let mut table = Vec::with_capacity(s);
            for i in 0..s {
                let x = i as f64 / (s - 1) as f64;
                table.push(f.exact(x).ok_or(x)?);
            }
            f.table = table;
        }
        Ok(f)
    }

    /// cpfg's `P(d)`: the curve point at parameter d in [0, 1].
    fn point(&self, d: f64) -> [f64; 2] {
        let n = self.points.len() as i64 - 1;
        clamped_sum(&self.points, d * (n - 2) as f64)
    }

    /// cpfg's search: bisect the parameter until the curve's x is within
    /// 0.001 of `x`, and give that point's y. None: it never gets there
    /// (cpfg loops forever).
    fn exact(&self, x: f64) -> Option<f64> {
        let (mut low, mut high) = (0.0f64, 1.0f64);
        for _ in 0..MAX_BISECTION {
            let check = (low + high) / 2.0;
            let p = self.point(check);
            if p[0] > x {
                high = check;
            } else {
                low = check;
            }
            // (A NaN x ends the search at once, as in cpfg.)
            let far = (p[0] - x).abs() > 0.001;
            if !far {
                return Some(p[1]);
            }
        }
        None
    }

    /// cpfg's `GetValue`: x clamped to [0, 1], then the table or the
    /// search.
    pub fn value(&self, x: f64, id: usize) -> Result<f64, FuncFault> {
        // (NaN stays NaN, as in cpfg's comparisons.)
        let x = x.clamp(0.0, 1.0);
        if self.table.is_empty() {
            return self.exact(x).ok_or(FuncFault::NeverReaches { id, x });
        }
        if x.is_nan() {
            return Err(FuncFault::NotANumber);
        }
        let s = self.table.len();
        let index = x * (s - 1) as f64;
        let i = index.floor();
        let (w1, w2) = (1.0 - index + i, index - i);
        let i = i as usize;
        if i == s - 1 {
            return Ok(self.table[i]);
        }
        Ok(w1 * self.table[i] + w2 * self.table[i + 1])
    }
}

/// cpfg's `Uk` (`splinefun.cpp`; `Uk` of `curveXYZ.cpp` too): the knots of
/// a cubic B-spline of `size` control points, clamped at both ends.
#[inline]
fn knot(size: i64, j: i64) -> i64 {
    let n = size - 1;
    if j < 4 {
        0
    } else if j > n {
        n - 2
    } else {
        j - 3
    }
}

/// cpfg's `N(k, t, u)` (`Nk1` to `Nk4` in `curveXYZ.cpp`): the Cox–de Boor
/// recursion on [`knot`], with its half-open first-order test and its
/// skipped zero divisions.
pub(super) fn clamped_basis(size: i64, k: i64, t: i64, u: f64) -> f64 {
    if t == 1 {
        return if knot(size, k) as f64 <= u && u < knot(size, k + 1) as f64 {
            1.0
        } else {
            0.0
        };
    }
    let mut sum = 0.0;
    let div = knot(size, k + t - 1) - knot(size, k);
    if div != 0 {
        sum = (u - knot(size, k) as f64) / div as f64 * clamped_basis(size, k, t - 1, u);
    }
    let div = knot(size, k + t) - knot(size, k + 1);
    if div != 0 {
        sum += (knot(size, k + t) as f64 - u) / div as f64 * clamped_basis(size, k + 1, t - 1, u);
    }
    sum
}

/// The point at knot parameter u of the clamped cubic B-spline of
/// `points`, as cpfg sums it: every control point times its basis
/// function, in order, from +0. Only the four around u are not 0, and
/// adding the others' zeros to a sum that starts at +0 changes nothing, so
/// they are skipped.
pub(super) fn clamped_sum<const D: usize>(points: &[[f64; D]], u: f64) -> [f64; D] {
    let size = points.len() as i64;
    let n = size - 1;
    let mut sum = [0.0; D];
    let c = u.floor() as i64;
    let (from, to) = ((c - 1).max(0), (c + 4).min(n));
    for k in from..=to {
        let b = clamped_basis(size, k, 4, u);
        let p = points[k as usize];
        for (s, v) in sum.iter_mut().zip(p) {
            *s += v * b;
        }
    }
    sum
}

impl Functions {
    /// No functions.
    pub fn none() -> Functions {
        Functions::default()
    }

    /// Read `files` in order: each a cpfg view file, a function set or a
    /// function file, told apart by its first line.
    pub fn load(files: &[PathBuf]) -> Result<Functions, Error> {
        Self::load_with_view(None, files)
    }

    /// [`Functions::load`] after cpfg's view file `view` (`--cpfg-view`):
    /// its functions and curves first, as `--functions` reads them, and
    /// its turtle's settings for the queries.
    pub fn load_with_view(view: Option<&Path>, files: &[PathBuf]) -> Result<Functions, Error> {
        let mut all = Functions::default();
        if let Some(v) = view {
            all.read_any(v)?;
            all.view = Some(v.to_path_buf());
        }
        for f in files {
            all.read_any(f)?;
        }
        Ok(all)
    }

    /// The view file (`--cpfg-view`), if one was given.
    pub fn view(&self) -> Option<&Path> {
        self.view.as_deref()
    }

    /// No function (`func` has none to read; curves aside).
    pub fn is_empty(&self) -> bool {
        self.items.is_empty()
    }

    /// No curve (`curveX` and the like have none to read).
    pub fn no_curves(&self) -> bool {
        self.curves.is_empty()
    }

    /// How many curves.
    pub fn curves(&self) -> usize {
        self.curves.len()
    }

    /// The curve `id` (as C's `(int)` makes it), or why there is none.
    fn curve(&self, name: &'static str, id: f64) -> Result<(usize, &Curve), FuncFault> {
        let count = self.curves.len();
        let n = id.trunc();
        if !(n >= 1.0 && n <= count as f64) {
            return Err(FuncFault::NoSuchCurve { name, id: n, count });
        }
        Ok((n as usize, &self.curves[n as usize - 1]))
    }

    /// `curveX(id, t)`, `curveY(id, t)`, `curveZ(id, t)`.
    pub fn curve_value(&self, which: Coordinate, id: f64, t: f64) -> Result<f64, FuncFault> {
        let (i, c) = self.curve(which.name(), id)?;
        c.at(t, which, i)
    }

    /// `curveGAL(id)`: the curve's length.
    pub fn curve_length(&self, id: f64) -> Result<f64, FuncFault> {
        Ok(self.curve("curveGAL", id)?.1.length())
    }

    pub fn len(&self) -> usize {
        self.items.len()
    }

    /// The macros a function set defines (name, number).
    pub fn macros(&self) -> &[(String, usize)] {
        &self.macros
    }

    /// `func(id, x)`: id as C's `(int)` converts it (toward zero).
    pub fn value(&self, id: f64, x: f64) -> Result<f64, FuncFault> {
        let count = self.items.len();
        let n = id.trunc();
        if !(n >= 1.0 && n <= count as f64) {
            return Err(FuncFault::NoSuchFunction { id: n, count });
        }
        let i = n as usize;
        self.items[i - 1].value(x, i)
    }

    /// Add `f`, within the limits (the error's place is the caller's).
    fn push(&mut self, f: Function) -> Result<(), E> {
        if self.items.len() as u64 >= MAX_FUNCTIONS {
            return Err(E::TooMany {
                what: "functions",
                limit: MAX_FUNCTIONS,
            });
        }
        let total = |g: &dyn Fn(&Function) -> usize| {
            self.items.iter().map(g).sum::<usize>() as u64 + g(&f) as u64
        };
        self.computed += f.table.len() as u64;
        let curve_points: u64 = self.curves.iter().map(|c| c.cost().0).sum();
        if total(&|g| g.points.len()) + curve_points > MAX_TOTAL
            || total(&|g| g.table.len()) > MAX_TOTAL
            || self.computed > MAX_TOTAL
        {
            return Err(E::TooMany {
                what: "control points or samples in all the functions and curves",
                limit: MAX_TOTAL,
            });
        }
        self.items.push(f);
        Ok(())
    }

    /// Add `c`, within the limits (points and samples counted with the
    /// functions').
    fn push_curve(&mut self, c: Curve) -> Result<(), E> {
        if self.curves.len() as u64 >= MAX_FUNCTIONS {
            return Err(E::TooMany {
                what: "curves",
                limit: MAX_FUNCTIONS,
            });
        }
        let (points, samples) = c.cost();
        self.computed += samples;
        let held: u64 = self
            .items
            .iter()
            .map(|g| g.points.len() as u64)
            .sum::<u64>()
            + self.curves.iter().map(|c| c.cost().0).sum::<u64>();
        if held + points > MAX_TOTAL || self.computed > MAX_TOTAL {
            return Err(E::TooMany {
                what: "control points or samples in all the functions and curves",
                limit: MAX_TOTAL,
            });
        }
        self.curves.push(c);
        Ok(())
    }

    /// A contour file with `samples` samples (a view line's, checked here).
    fn read_curve(&mut self, name: &str, text: &str, samples: i64) -> Result<(), Placed> {
        if samples < 2 {
            return Err(Placed::Here(E::CurveSamples));
        }
        if samples as u64 > MAX_SAMPLES {
            return Err(Placed::Here(E::TooMany {
                what: "samples",
                limit: MAX_SAMPLES,
            }));
        }
        let c = Curve::read(name, text, samples as usize).map_err(Placed::There)?;
        self.push_curve(c).map_err(Placed::Here)
    }

    fn read_any(&mut self, path: &Path) -> Result<(), Error> {
        let name = path.display().to_string();
        let text = read_text(path).map_err(|e| Error::io(name.clone(), IoAction::Read, e))?;
        let first = text.lines().next().unwrap_or("").trim_start();
        let start = Spot {
            name: name.clone(),
            text: text.clone(),
            offset: 0,
        };
        if first.starts_with("funcgalleryver") {
            self.read_set(&name, &text)
        } else if first.starts_with("fver") || first.starts_with("range:") {
            let mut r = Reader::new(&name, &text);
            let f = r.function(name.clone(), -1)?;
            self.push(f).map_err(|e| start.error(e))
        } else if first.starts_with("version:") || name.ends_with(".con") {
            // A contour file (cpfg reads it with `curve:` only).
            self.read_curve(&name, &text, DEFAULT_SAMPLES)
                .map_err(|e| e.at(|e| start.error(e)))
        } else if name.ends_with(".func") || name.ends_with(".fset") {
            // (A function file whose first line is wrong: a typo, an empty
            // line. cpfg would count it as one flat function; read as a
            // view file it would give none and renumber the files after
            // it.)
            Err(start.error(E::UnknownFormat))
        } else {
            // (A view file without functions is a model's view file, as
            // cpfg gets it: nothing to read there.)
            self.read_view(path, &text).map(|_| ())
        }
    }

    /// A function set: `funcgalleryver 1 1`, `items: N`, N functions.
    fn read_set(&mut self, name: &str, text: &str) -> Result<(), Error> {
        let mut r = Reader::new(name, text);
        let (major, minor) = r.version("funcgalleryver", "function set")?;
        if (major, minor) != (1, 1) {
            return Err(r.spot().error(E::Version {
                what: "function set",
                major,
                minor,
            }));
        }
        let items = r.keyword_int("items:", "`items: N`")?;
        let at = r.spot();
        if items < 0 {
            return Err(at.error(E::Expected("`items: N` with N at least 0")));
        }
        for _ in 0..items {
            // (cpfg's gallery reads an old-format item with 100 samples.)
            let f = r.function(String::new(), 100)?;
            let id = self.items.len() + 1;
            let fname = f.source.clone();
            self.push(Function {
                source: format!("{name} ({fname})"),
                ..f
            })
            .map_err(|e| at.error(e))?;
            // (cpfg's `-DNAME=N`: a later name replaces an earlier one;
            // `defined` cannot be a macro.)
            if is_identifier(&fname) && fname != "defined" {
                self.macros.retain(|(n, _)| *n != fname);
                self.macros.push((fname, id));
            }
        }
        Ok(())
    }

    /// A view file: only its `function:` and `function set:` lines (after
    /// the preprocessor, as cpfg runs it); file names relative to it. As
    /// in cpfg, a `function set:` replaces the functions the file listed
    /// before it, and a `function:` after a set ends the set's names.
    /// Gives how many `function:` and `function set:` lines it has.
    fn read_view(&mut self, path: &Path, text: &str) -> Result<usize, Error> {
        let out = super::preprocess::preprocess(path, text, &super::preprocess::read_file)?;
        let dir = path.parent().unwrap_or(Path::new(""));
        let (first, first_macro) = (self.items.len(), self.macros.len());
        let mut lines = 0;
        let mut offset = 0;
        for line in out.text.split_inclusive('\n') {
            let start = offset;
            offset += line.len();
            let Some((label, rest)) = line.split_once(':') else {
                continue;
            };
            let label: Vec<&str> = label.split_whitespace().collect();
            let (set, curve) = match label.as_slice() {
                ["function"] => (false, false),
                ["function", "set"] => (true, false),
                ["curve"] => (false, true),
                _ => continue,
            };
            lines += 1;
            let what = match (set, curve) {
                (true, _) => "function set:",
                (_, true) => "curve:",
                _ => "function:",
            };
            let mut words = rest.split_whitespace();
            let Some(file) = words.next() else {
                // (At the colon: the rest of the line is empty.)
                let colon = start + line.len() - rest.len() - 1;
                return Err(Error::at(out.map.location(colon), E::MissingFile(what)));
            };
            let rest_at = start + line.len() - rest.trim_start().len();
            let locate = |e: E| Error::at(out.map.location(rest_at), e);
            let file = dir.join(file);
            let fname = file.display().to_string();
            let body = read_text(&file).map_err(|source| {
                locate(E::Unreadable {
                    path: file.clone(),
                    source,
                })
            })?;
            if curve {
                // `curve: FILE SAMPLES` (cpfg's fscanf; none: 100).
                let samples = words
                    .next()
                    .and_then(leading_int)
                    .unwrap_or(DEFAULT_SAMPLES);
                self.read_curve(&fname, &body, samples)
                    .map_err(|e| e.at(locate))?;
                continue;
            }
            if set {
                self.items.truncate(first);
                self.macros.truncate(first_macro);
                self.read_set(&fname, &body)?;
                continue;
            }
            self.macros.truncate(first_macro);
            // `function: FILE SAMPLES`: the samples of an old-format file
            // (cpfg's fscanf reads a number; anything else is none).
            let samples = words.next().and_then(leading_int).unwrap_or(-1);
            if samples > MAX_SAMPLES as i64 {
                return Err(locate(E::TooMany {
                    what: "samples",
                    limit: MAX_SAMPLES,
                }));
            }
            let mut r = Reader::new(&fname, &body);
            let f = r.function(fname.clone(), samples)?;
            self.push(f).map_err(locate)?;
        }
        Ok(lines)
    }
}

/// An error of reading a curve: at the place that names the file (its
/// view line, or the file's start), or already at its place in the file.
enum Placed {
    Here(E),
    There(Error),
}

impl Placed {
    fn at(self, locate: impl FnOnce(E) -> Error) -> Error {
        match self {
            Placed::Here(e) => locate(e),
            Placed::There(e) => e,
        }
    }
}

/// A file's text as cpfg reads it (bytes: a byte that is no UTF-8, in a
/// comment say, is read as U+FFFD), without a UTF-8 byte-order mark; at
/// most the preprocessor's file size.
pub(crate) fn read_text(path: &Path) -> std::io::Result<String> {
    use std::io::Read;
    if crate::io::output::leads_to_closed_fd(path) {
        return Err(std::io::Error::other(
            "Bad file descriptor (closed at startup)",
        ));
    }
    let limit = super::preprocess::MAX_FILE_SIZE;
    let mut buf = Vec::new();
    std::fs::File::open(path)?
        .take(limit + 1)
        .read_to_end(&mut buf)?;
    if buf.len() as u64 > limit {
        return Err(std::io::Error::other(format!(
            "file larger than {} MiB",
            limit >> 20
        )));
    }
    let text = String::from_utf8_lossy(&buf);
    Ok(text.strip_prefix('\u{feff}').unwrap_or(&text).to_string())
}

/// A C identifier (a name the preprocessor can define).
fn is_identifier(s: &str) -> bool {
    let mut c = s.chars();
    c.next()
        .is_some_and(|f| f.is_ascii_alphabetic() || f == '_')
        && c.all(|c| c.is_ascii_alphanumeric() || c == '_')
}

/// The integer `sscanf("%d")` reads at the start of `w`.
fn leading_int(w: &str) -> Option<i64> {
    let end = w
        .char_indices()
        .find(|&(i, c)| !(c.is_ascii_digit() || (i == 0 && (c == '-' || c == '+'))))
        .map_or(w.len(), |(i, _)| i);
    w[..end]
        .parse::<i64>()
        .ok()
        .map(|v| v.clamp(-1, i64::from(i32::MAX)))
}

/// A number as cpfg reads a coordinate (`%f`, `std::stof`): a 32-bit
/// float, then used as a double.
fn coordinate(w: &str) -> Option<f64> {
    let v: f32 = w.parse().ok()?;
    v.is_finite().then_some(f64::from(v))
}

/// A place in a function file, for its errors.
pub(super) struct Spot {
    pub name: String,
    pub text: String,
    pub offset: usize,
}

impl Spot {
    pub(super) fn error(&self, e: E) -> Error {
        let map = CodeMap::new(&self.text);
        Error::at(Location::from_map(&self.name, &map, self.offset), e)
    }
}

/// Line by line through a function file.
struct Reader<'a> {
    name: &'a str,
    text: &'a str,
    /// Start of the next line, and of the current one.
    pos: usize,
    line_at: usize,
}

impl<'a> Reader<'a> {
    fn new(name: &'a str, text: &'a str) -> Reader<'a> {
        Reader {
            name,
            text,
            pos: 0,
            line_at: 0,
        }
    }

    fn spot(&self) -> Spot {
        Spot {
            name: self.name.to_string(),
            text: self.text.to_string(),
            offset: self.line_at,
        }
    }

    fn fail<T>(&self, e: E) -> Result<T, Error> {
        Err(self.spot().error(e))
    }

    /// The next line (without its newline); at the end, an empty one.
    fn line(&mut self) -> &'a str {
        let rest = &self.text[self.pos..];
        self.line_at = self.pos;
        let (line, next) = match rest.find('\n') {
            Some(i) => (&rest[..i], self.pos + i + 1),
            None => (rest, self.text.len()),
        };
        self.pos = next;
        line.strip_suffix('\r').unwrap_or(line)
    }

    /// Does the next line start with `c` (cpfg peeks one character)?
    fn peek(&self, c: char) -> bool {
        self.text[self.pos..].starts_with(c)
    }

    /// `WORD MAJOR MINOR`.
    fn version(&mut self, word: &'static str, what: &'static str) -> Result<(i64, i64), Error> {
        let line = self.line();
        let mut w = line.split_whitespace();
        let ok = w.next() == Some(word);
        let major = w.next().and_then(leading_int);
        let minor = w.next().and_then(leading_int);
        match (ok, major, minor) {
            (true, Some(a), Some(b)) => Ok((a, b)),
            _ => self.fail(if what == "function set" {
                E::Expected("`funcgalleryver 1 1`")
            } else {
                E::UnknownFormat
            }),
        }
    }

    /// `KEYWORD N` on the next line.
    fn keyword_int(&mut self, keyword: &str, expected: &'static str) -> Result<i64, Error> {
        let line = self.line();
        match line.trim_start().strip_prefix(keyword).map(str::trim_start) {
            Some(rest) => match leading_int(rest) {
                Some(v) => Ok(v),
                None => self.fail(E::Expected(expected)),
            },
            None => self.fail(E::Expected(expected)),
        }
    }

    /// One function, either format; `source` names it (a set's items
    /// take their `name:`); `samples` is the view line's, for the old
    /// format.
    fn function(&mut self, source: String, samples: i64) -> Result<Function, Error> {
        let first_at = self.pos;
        let first = self.line();
        if first.trim_start().starts_with("range:") {
            let n = self.keyword_int("points:", "`points: N`")?;
            let points = self.points(n, false)?;
            return self.finish(source, points, samples, first_at);
        }
        self.pos = first_at;
        let (major, minor) = self.version("fver", "function")?;
        if (major, minor) != (1, 1) {
            return self.fail(E::Version {
                what: "function file",
                major,
                minor,
            });
        }
        let line = self.line();
        let name = match line.trim_start().strip_prefix("name:") {
            Some(n) => n.split_whitespace().next(),
            None => None,
        };
        let Some(name) = name else {
            return self.fail(E::Expected("`name: NAME`"));
        };
        let source = if source.is_empty() {
            name.to_string()
        } else {
            source
        };
        let samples = self.keyword_int("samples:", "`samples: N`")?;
        if samples > MAX_SAMPLES as i64 {
            return self.fail(E::TooMany {
                what: "samples",
                limit: MAX_SAMPLES,
            });
        }
        // A background image: two lines, ignored.
        if self.peek('b') {
            self.line();
            self.line();
        }
        // Markers: `markers: K` and K lines, ignored.
        if self.peek('m') {
            let k = self.keyword_int("markers:", "`markers: K`")?;
            for _ in 0..k.max(0) {
                if self.pos >= self.text.len() {
                    return self.fail(E::Expected("a marker line `mI X Y`"));
                }
                self.line();
            }
        }
        // `flip:`, ignored.
        self.line();
        let n = self.keyword_int("points:", "`points: N`")?;
        let points = self.points(n, true)?;
        self.finish(source, points, samples, first_at)
    }

    /// `n` lines of `x y` (and, in the new format, a multiplicity).
    fn points(&mut self, n: i64, multiplicity: bool) -> Result<Vec<[f64; 2]>, Error> {
        if n < 4 {
            return self.fail(E::TooFewPoints(n.max(0) as u64));
        }
        if n as u64 > MAX_POINTS {
            return self.fail(E::TooMany {
                what: "control points",
                limit: MAX_POINTS,
            });
        }
        let expected = if multiplicity {
            "a point `X Y` or `X Y MULTIPLICITY`"
        } else {
            "a point `X Y`"
        };
        let mut points = Vec::with_capacity(n as usize);
        for _ in 0..n {
            let end = self.pos >= self.text.len();
            let line = self.line();
            let w: Vec<&str> = line.split_whitespace().collect();
            let xy = match w.as_slice() {
                [x, y] | [x, y, _] if !end => coordinate(x).zip(coordinate(y)),
                _ => None,
            };
            let Some((x, y)) = xy else {
                return self.fail(E::Expected(expected));
            };
            let times = match w.get(2) {
                Some(_) if !multiplicity => return self.fail(E::Expected(expected)),
                // `std::stof`, then an int: toward zero.
                Some(m) => match m.parse::<f32>() {
                    Ok(m) if m.is_finite() => (m.trunc().max(0.0)) as u64,
                    _ => return self.fail(E::Expected(expected)),
                },
                None => 1,
            };
            if (points.len() as u64).saturating_add(times) > MAX_POINTS {
                return self.fail(E::TooMany {
                    what: "control points",
                    limit: MAX_POINTS,
                });
            }
            for _ in 0..times {
                points.push([x, y]);
            }
        }
        if points.len() < 4 {
            return self.fail(E::TooFewPoints(points.len() as u64));
        }
        Ok(points)
    }

    /// The function read (it started at `first_at`, where a curve that
    /// misses a sample's x is refused).
    fn finish(
        &mut self,
        source: String,
        points: Vec<[f64; 2]>,
        samples: i64,
        first_at: usize,
    ) -> Result<Function, Error> {
        if samples as u64 > MAX_SAMPLES && samples > 0 {
            return self.fail(E::TooMany {
                what: "samples",
                limit: MAX_SAMPLES,
            });
        }
        Function::new(source, points, samples).or_else(|x| {
            self.line_at = first_at;
            self.fail(E::NeverReaches(x))
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn f(points: &[[f64; 2]], samples: i64) -> Function {
        Function::new("t".into(), points.to_vec(), samples).unwrap()
    }

    /// de Boor's algorithm on the same clamped knots: a second way to the
    /// curve point.
    fn de_boor(p: &[[f64; 2]], d: f64) -> [f64; 2] {
        let n = p.len() - 1;
        let m = (n - 2) as f64;
        let u = d * m;
        // Knot vector: 0,0,0,0,1,2,...,n-3,n-2,n-2,n-2,n-2.
        let mut t = vec![0.0; 4];
        for j in 1..(n - 2) {
            t.push(j as f64);
        }
        t.extend([m; 4]);
        let mut k = 3;
        while k + 1 < t.len() - 4 && u >= t[k + 1] {
            k += 1;
        }
        let mut dd: Vec<[f64; 2]> = (0..4).map(|j| p[j + k - 3]).collect();
        for r in 1..4 {
            for j in (r..4).rev() {
                let i = j + k - 3;
                let a = (u - t[i]) / (t[i + 4 - r] - t[i]);
                dd[j] = [
                    (1.0 - a) * dd[j - 1][0] + a * dd[j][0],
                    (1.0 - a) * dd[j - 1][1] + a * dd[j][1],
                ];
            }
        }
        dd[3]
    }

    #[test]
    fn the_curve_is_the_clamped_cubic_b_spline() {
        let pts = [
            [0.0, 0.2],
            [0.1, 0.9],
            [0.35, -0.4],
            [0.5, 0.5],
            [0.8, 1.7],
            [1.0, 0.3],
        ];
        let g = f(&pts, 0);
        for i in 0..1000 {
            let d = i as f64 / 1000.0;
            let (a, b) = (g.point(d), de_boor(&pts, d));
            assert!(
                (a[0] - b[0]).abs() < 1e-12 && (a[1] - b[1]).abs() < 1e-12,
                "{d}: {a:?} {b:?}"
            );
        }
        // It starts at the first control point.
        assert_eq!(g.point(0.0), [0.0, 0.2]);
    }

    #[test]
    fn a_straight_line_gives_x_within_the_search_tolerance() {
        let g = f(
            &[
                [0.0, 0.0],
                [1.0 / 3.0, 1.0 / 3.0],
                [2.0 / 3.0, 2.0 / 3.0],
                [1.0, 1.0],
            ],
            0,
        );
        for x in [0.0, 0.1, 0.25, 0.5, 0.77, 0.999] {
            let y = g.value(x, 1).unwrap();
            assert!((y - x).abs() <= 0.001 + 1e-9, "{x} -> {y}");
        }
        // Clamped to [0, 1].
        assert_eq!(g.value(-3.0, 1), g.value(0.0, 1));
        assert_eq!(g.value(7.0, 1), g.value(1.0, 1));
    }

    #[test]
    fn a_table_interpolates_its_samples() {
        let pts = [[0.0, 0.0], [0.3, 1.0], [0.6, -1.0], [1.0, 0.5]];
        let g = f(&pts, 11);
        let exact = f(&pts, 0);
        assert_eq!(g.table.len(), 11);
        for i in 0..11 {
            let x = i as f64 / 10.0;
            assert_eq!(g.table[i], exact.exact(x).unwrap());
        }
        let (a, b) = (g.table[2], g.table[3]);
        let x = 0.25;
        let want = (1.0 - 2.5 + 2.0) * a + (2.5 - 2.0) * b;
        assert_eq!(g.value(x, 1).unwrap(), want);
        assert_eq!(g.value(1.0, 1).unwrap(), g.table[10]);
        assert_eq!(g.value(f64::NAN, 1), Err(FuncFault::NotANumber));
        // Without a table, NaN ends the search at once: the point at 0.5.
        assert_eq!(exact.value(f64::NAN, 1).unwrap(), exact.point(0.5)[1]);
    }

    #[test]
    fn a_curve_that_misses_x_is_refused() {
        let pts = vec![[0.0, 0.0], [0.1, 0.0], [0.2, 0.0], [0.5, 0.0]];
        assert!(Function::new("t".into(), pts.clone(), 5).is_err());
        let g = f(&pts, 0);
        assert_eq!(
            g.value(0.9, 3),
            Err(FuncFault::NeverReaches { id: 3, x: 0.9 })
        );
    }

    #[test]
    fn ids_are_truncated_and_checked() {
        let all = Functions {
            items: vec![f(&[[0.0, 1.0], [0.3, 1.0], [0.6, 1.0], [1.0, 1.0]], 0)],
            macros: vec![],
            curves: vec![],
            computed: 0,
            view: None,
        };
        assert!((all.value(1.9, 0.5).unwrap() - 1.0).abs() < 1e-12);
        assert_eq!(
            all.value(2.0, 0.5),
            Err(FuncFault::NoSuchFunction { id: 2.0, count: 1 })
        );
        assert!(all.value(0.5, 0.5).is_err());
        assert!(all.value(f64::NAN, 0.5).is_err());
        assert!(all.value(-1.0, 0.5).is_err());
    }

    #[test]
    fn both_file_formats_read() {
        let new = "fver 1 1\nname: elas\nsamples: 10\nflip: off\npoints: 4\n\
                   0.000000 0.495280 1\n0.301001 0.479716 2\n0.621178 0.408565 1\n1.000000 0.235135 1\n";
        let mut r = Reader::new("e.func", new);
        let g = r.function(String::new(), -1).unwrap();
        assert_eq!(g.source, "elas");
        assert_eq!(g.points.len(), 5);
        assert_eq!(
            g.points[1],
            [f64::from(0.301001f32), f64::from(0.479716f32)]
        );
        assert_eq!(g.table.len(), 10);
        let old = "range: 0.0 1.0\npoints: 4\n0 0\n0.3 1\n0.6 1\n1 0\n";
        let mut r = Reader::new("o.func", old);
        let g = r.function("o.func".into(), 100).unwrap();
        assert_eq!(g.table.len(), 100);
        let mut r = Reader::new("o.func", old);
        assert!(r.function("o.func".into(), -1).unwrap().table.is_empty());
        // In a set, an old-format function has 100 samples (cpfg's
        // gallery constructor's default).
        let mut set = Functions::default();
        set.read_set("s.fset", &format!("funcgalleryver 1 1\nitems: 1\n{old}"))
            .unwrap();
        assert_eq!(set.items[0].table.len(), 100);
        assert!(set.macros.is_empty());
        let with_markers = "fver 1 1\nname: m\nsamples: 0\nbackground: x\nsomething\nmarkers: 2\n\
                            m1 0.1 0.1\nm2 0.2 0.2\nflip: on\npoints: 4\n0 0\n0.3 1\n0.6 1\n1 0\n";
        let mut r = Reader::new("m.func", with_markers);
        assert_eq!(r.function(String::new(), -1).unwrap().points.len(), 4);
    }

    #[test]
    fn bad_files_are_located_errors() {
        let cases = [
            (
                "fver 1 1\nname: a\nsamples: 0\nflip: off\npoints: 3\n0 0\n0.5 0\n1 0\n",
                5,
                "at least 4",
            ),
            ("fver 1 2\n", 1, "version 1.2"),
            (
                "fver 1 1\nname: a\nsamples: 0\nflip: off\npoints: 4\n0 0\n0.5 x\n",
                7,
                "expected a point",
            ),
            ("fver 1 1\nsamples: 0\n", 2, "`name: NAME`"),
            (
                "range: 0 1\npoints: 4\n0 0\n0.5 0\n0.6 0\n",
                6,
                "expected a point",
            ),
            // A multiplicity past u64 saturates: no overflow to a small
            // count (that pushed points without end).
            (
                "fver 1 1\nname: a\nsamples: 0\nflip: off\npoints: 4\n0 0\n0.3 0.3 1e20\n0.6 0.6\n1 1\n",
                7,
                "more than 65536 control points",
            ),
        ];
        for (text, line, msg) in cases {
            let mut r = Reader::new("x.func", text);
            let e = r.function(String::new(), -1).unwrap_err();
            let s = e.to_string();
            assert!(s.starts_with(&format!("x.func:{line}:")), "{s}");
            assert!(s.contains(msg), "{s}");
        }
    }
}
