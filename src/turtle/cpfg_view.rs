//! cpfg's own files for lsgen-turtle: the view file (`.v`), the colour map
//! (`.map`) and the material file (`.mat`), read as cpfg reads them
//! (`interpret.c`'s `ReadViewData`, `irisGL.c`'s colour map and material
//! loaders), so that a vlab model is drawn with its own angle, widths,
//! colours, tropism and view.
//!
//! A view file goes through cpfg's preprocessor first (lsgen's, as for
//! `--functions`). A line is a label, cpfg's exact spelling with its colon
//! (case and inner blanks count; only spaces before it are skipped), and
//! its arguments. lsgen-turtle takes the labels that decide what is drawn
//! ([`TAKEN`]); the other labels of cpfg (lighting, clipping, surfaces,
//! functions, ...) are passed over, and a label cpfg does not know is a
//! warning, as cpfg warns. A bad argument of a label lsgen-turtle takes is
//! an error at it (cpfg warns and keeps what it scanned).

use super::view::{Direction, Rgb, TropismModel, View, WidthUnit};
use crate::diag::{Error, IoAction, LexicalError, Location, ViewError, Warning, WarningKind};
use std::path::Path;

/// The labels lsgen-turtle takes from a view file.
pub const TAKEN: &[&str] = &[
    "angle factor:",
    "angle increment:",
    "initial color:",
    "color increment:",
    "initial line width:",
    "line width increment:",
    "line style:",
    "tropism direction:",
    "initial elasticity:",
    "elasticity increment:",
    "viewpoint:",
    "view reference point:",
    "twist:",
];

/// cpfg's other view-file labels: what they set is not drawn by
/// lsgen-turtle, or needs files it does not read. Those that change the
/// turtle's geometry get a warning ([`GEOMETRY`]).
const PASSED: &[&str] = &[
    "projection:",
    "front distance:",
    "back distance:",
    "scale factor:",
    "z buffer:",
    "cue range:",
    "shade mode:",
    "light direction:",
    "diffuse reflection:",
    "surface ambient:",
    "surface diffuse:",
    "line:",
    "surface:",
    "box:",
    "background color:",
    "ambient light:",
    "font:",
    "polygonization level:",
    "blob:",
    "tropism:",
    "torque:",
    "light:",
    "texture:",
    "render mode:",
    "tapered lines:",
    "contour sides:",
    "contour:",
    "viewing angle:",
    "background scene:",
    "twist of cylinders:",
    "interpretation step:",
    "interpretation past %:",
    "tsurface:",
    "rayshade objects:",
    "rayshade scale:",
    "initial scale:",
    "scale multiplier:",
    "environment display:",
    "function:",
    "curve:",
    "antialiasing:",
    "function set:",
    "min zoom:",
    "max zoom:",
    "generate on view change:",
    "winfont:",
    "concave polygons:",
    "shadow map:",
    "PS linecap:",
];

/// Passed-over labels that change where cpfg's turtle goes, and why
/// lsgen-turtle's picture differs.
const GEOMETRY: &[(&str, &str)] = &[
    (
        "initial scale:",
        "cpfg's turtle scale is not drawn (lengths and the widths of `!` and `#` are not multiplied by it)",
    ),
    (
        "projection:",
        "lsgen-turtle draws a parallel projection only",
    ),
    (
        "interpretation past %:",
        "lsgen-turtle draws past `%` (cpfg's `on`); cpfg's `off` leaves the rest of a branch after `%` undrawn",
    ),
];

/// What cpfg's own turtle takes from a view file, in cpfg's arithmetic
/// (its `DRAWPARAM` holds floats): the turtle of the cpfg dialect's
/// queries `?P`, `?H`, `?L`, `?U` (`src/cpfg/query.rs`), which must
/// reach the same positions as cpfg to the last bit a float keeps.
#[derive(Clone, Debug, PartialEq)]
pub struct CpfgTurtle {
    /// `angle factor:` (360 / it, divided in double) or `angle
    /// increment:`, degrees (default 45).
    pub angle: f32,
    /// `tropism direction:` as read (default 0,1,0); cpfg scales it to
    /// length 1 in floats.
    pub tropism: [f32; 3],
    pub elasticity: f32,
    pub elasticity_increment: f32,
    /// `initial scale:` (default 1; cpfg takes 0 as 1): multiplies the
    /// lengths of `F`, `f`, `G`, `g`.
    pub scale: f32,
    /// `interpretation past %:` (cpfg's default `on`); `off`: the turtle
    /// skips the rest of a branch after a `%`.
    pub past_cut: bool,
    /// cpfg's movements: the `tropism:` and `torque:` lines cpfg keeps
    /// (`crate::turtle::movements`), which turn its turtle before each
    /// move.
    pub movements: Vec<super::movements::Movement>,
    /// The label and place of a movement line cpfg cannot take, and why:
    /// a tenth (with ten, cpfg reads past its table), or one cpfg crashes
    /// on (refused with queries).
    pub movements_refused: Option<(String, crate::diag::Location, &'static str)>,
    /// The angle's label and where it is, if the angle is past the
    /// largest float (cpfg keeps it as one: every turn gives NaN).
    pub angle_past: Option<(String, crate::diag::Location)>,
    /// cpfg fills the queries of the string it saves: it interprets that
    /// string to fit the view around it (no `box:`), or after each step
    /// (`environment display: before`). Else the last string keeps the
    /// values its productions gave (each string before a step is filled
    /// all the same).
    pub fills_last: bool,
}

impl Default for CpfgTurtle {
    fn default() -> Self {
        CpfgTurtle {
            angle: 45.0,
            tropism: [0.0, 1.0, 0.0],
            elasticity: 0.0,
            elasticity_increment: 0.0,
            scale: 1.0,
            past_cut: true,
            movements: Vec::new(),
            movements_refused: None,
            angle_past: None,
            fills_last: true,
        }
    }
}

/// Read cpfg's view file `path` for cpfg's turtle ([`CpfgTurtle`]); the
/// same reading as [`read_view`] (its errors too). Gives the warnings
/// about cpfg's turtle itself (a movement line cpfg ignores), for the
/// caller to say; those about drawing are left out.
pub fn read_cpfg_turtle(path: &Path) -> Result<(CpfgTurtle, Vec<Warning>), Error> {
    let mut view = View::default();
    let (mut warnings, turtle) = read_file(path, &mut view)?;
    warnings.retain(|w| matches!(w.kind(), WarningKind::CpfgMovementIgnored { .. }));
    Ok((turtle, warnings))
}

/// Read cpfg's view file `path` into `view`: first cpfg's defaults for
/// everything the file may set (colour index 128, pixel lines of width 1,
/// cpfg's tropism, viewpoint 0,0,1), then the file. Gives the warnings.
pub fn read_view(path: &Path, view: &mut View) -> Result<Vec<Warning>, Error> {
    read_file(path, view).map(|(w, _)| w)
}

fn read_file(path: &Path, view: &mut View) -> Result<(Vec<Warning>, CpfgTurtle), Error> {
    let name = path.display().to_string();
    let text =
        crate::cpfg::func::read_text(path).map_err(|e| Error::io(name, IoAction::Read, e))?;
    let out =
        crate::cpfg::preprocess::preprocess(path, &text, &crate::cpfg::preprocess::read_file)?;
    let mut r = ViewFile {
        view,
        turtle: CpfgTurtle::default(),
        box_given: false,
        display_before: false,
        warnings: crate::diag::FileWarnings::new(),
        viewpoint: [0.0, 0.0, 1.0],
        vrp: [0.0; 3],
        map: &out.map,
    };
    r.defaults();
    let mut offset = 0;
    for line in out.text.split_inclusive('\n') {
        let start = offset;
        offset += line.len();
        r.line(start, line.trim_end_matches(['\n', '\r']))?;
    }
    r.camera();
    r.turtle.fills_last = !r.box_given || r.display_before;
    let warnings = r.warnings.finish(|at, kind| Warning::new(kind, Some(at)));
    Ok((warnings, r.turtle))
}

struct ViewFile<'a> {
    view: &'a mut View,
    turtle: CpfgTurtle,
    box_given: bool,
    display_before: bool,
    warnings: crate::diag::FileWarnings<Warning>,
    viewpoint: [f64; 3],
    vrp: [f64; 3],
    map: &'a crate::cpfg::preprocess::SourceMap,
}

/// A label's arguments, scanned as cpfg's `fscanf` does on one line.
struct Args<'l> {
    line: &'l str,
    at: usize,
    /// Where the line starts in the preprocessed text.
    base: usize,
    label: &'static str,
    /// The last number scanned was past the largest one (its text): the
    /// error says so rather than "takes a number".
    past: Option<String>,
}

impl ViewFile<'_> {
    fn defaults(&mut self) {
        let v = &mut *self.view;
        v.angle = 45.0;
        v.colour = 128.0;
        v.colour_increment = 1.0;
        v.width = 1.0;
        v.width_unit = WidthUnit::Pixels;
        v.width_increment = 0.0;
        v.tropism = [0.0, 1.0, 0.0];
        v.elasticity = 0.0;
        v.elasticity_increment = 0.0;
        v.tropism_model = TropismModel::Cpfg;
        v.twist = 0.0;
    }

    /// Note where the turtle's angle, just read at `offset`, is past the
    /// largest float (a later angle label takes its place).
    fn angle_past(&mut self, offset: usize, label: &str) {
        self.turtle.angle_past =
            (!self.turtle.angle.is_finite()).then(|| (label.to_string(), self.location(offset)));
    }

    /// Note the first movement line cpfg cannot take (refused with
    /// queries).
    fn refuse_movement(&mut self, offset: usize, label: &str, why: &'static str) {
        if self.turtle.movements_refused.is_none() {
            let at = self.location(offset);
            self.turtle.movements_refused = Some((label.to_string(), at, why));
        }
    }

    fn location(&self, offset: usize) -> Location {
        self.map.location(offset)
    }

    fn warn(&mut self, offset: usize, kind: WarningKind) {
        let map = self.map;
        self.warnings
            .push(|| map.location(offset), |at| Warning::new(kind, Some(at)));
    }

    /// One line: labels and their arguments, as long as the arguments
    /// of a label lsgen-turtle takes leave more on the line.
    fn line(&mut self, base: usize, line: &str) -> Result<(), Error> {
        let mut i = 0;
        loop {
            // cpfg skips spaces only before a label.
            i += line[i..].len() - line[i..].trim_start_matches(' ').len();
            if line[i..].trim().is_empty() {
                return Ok(());
            }
            let Some(colon) = line[i..].find(':') else {
                let label = shown(line[i..].trim_end());
                self.warn(base + i, WarningKind::CpfgViewLabel(label));
                return Ok(());
            };
            let text = &line[i..=i + colon];
            let Some(&label) = TAKEN.iter().find(|&&l| l == text) else {
                self.cpfg_only(base + i, text, line, i + colon + 1);
                if let Some(&(_, why)) = GEOMETRY.iter().find(|(l, _)| *l == text) {
                    // Two of them change the picture with one value only
                    // (cpfg compares the word's first letters).
                    let value = line[i + colon + 1..].trim_start();
                    let differs = match text {
                        "projection:" => value.starts_with("perspective"),
                        "interpretation past %:" => value.starts_with("off"),
                        _ => true,
                    };
                    if differs {
                        self.warn(
                            base + i,
                            WarningKind::CpfgViewNotDrawn {
                                label: text.to_string(),
                                why,
                            },
                        );
                    }
                } else if !PASSED.contains(&text) {
                    self.warn(base + i, WarningKind::CpfgViewLabel(shown(text)));
                }
                return Ok(());
            };
            let mut a = Args {
                line,
                at: i + colon + 1,
                base,
                label,
                past: None,
            };
            self.take(&mut a)?;
            i = a.at;
        }
    }

    /// A label lsgen-turtle passes over that cpfg's turtle takes
    /// ([`CpfgTurtle`]), its arguments at `line[at..]`. As cpfg reads
    /// them: a bad number leaves the value as it was (cpfg warns).
    fn cpfg_only(&mut self, offset: usize, label: &str, line: &str, at: usize) {
        let value = line[at..].trim_start();
        match label {
            "initial scale:" => {
                let n = crate::cpfg::curve::number_prefix(value);
                if let Ok(v) = value[..n].parse::<f64>() {
                    if v.is_finite() {
                        let v = v as f32;
                        self.turtle.scale = if v == 0.0 { 1.0 } else { v };
                    }
                }
            }
            "interpretation past %:" => self.turtle.past_cut = !value.starts_with("off"),
            // (cpfg: `box:` turns its automatic view volume off; `before`
            // is compared by its first 6 letters.)
            "box:" => self.box_given = true,
            "environment display:" => self.display_before = value.starts_with("before"),
            "tropism:" | "torque:" => {
                use super::movements::{parse, Kind, MAX_MOVEMENTS};
                // (cpfg's `MaxLineLength`, less the NUL.)
                const VIEW_LINE_MAX: usize = 254;
                let kind = if label == "tropism:" {
                    Kind::Tropism
                } else {
                    Kind::Twist
                };
                // (cpfg ignores a line it cannot read, and one past its
                // table, with a message; with ten, its turtle reads past
                // the table: lsgen-turtle draws nine.)
                let ignored = |why: &'static str, crash| WarningKind::CpfgMovementIgnored {
                    label: label.to_string(),
                    why,
                    crash,
                };
                // cpfg reads the rest of the line with `fgets(input_line,
                // 255, fp)`: 254 bytes, the newline counted; a longer one
                // is cut there and its rest read as the next label.
                let parsed = if line[at..].len() + 1 > VIEW_LINE_MAX {
                    Err("is longer than the 254 bytes cpfg reads of it (its rest would be read as a label)")
                } else {
                    parse(kind, &line[at..])
                };
                let why = match parsed {
                    Ok(Ok(m)) if self.turtle.movements.len() < MAX_MOVEMENTS => {
                        self.turtle.movements.push(m.clone());
                        if self.turtle.movements.len() < MAX_MOVEMENTS {
                            self.view.movements.push(m);
                            return;
                        }
                        let refused = "is a tenth movement (cpfg keeps ten, and with ten its turtle reads past its table of them)";
                        self.refuse_movement(offset, label, refused);
                        "nine before it (cpfg reads past its table with ten)"
                    }
                    Ok(Ok(_)) => "ten before it",
                    Ok(Err(why)) => why,
                    Err(why) => {
                        self.refuse_movement(offset, label, why);
                        self.warn(offset, ignored(why, true));
                        return;
                    }
                };
                self.warn(offset, ignored(why, false));
            }
            _ => {}
        }
    }

    fn take(&mut self, a: &mut Args) -> Result<(), Error> {
        let map = self.map;
        let err = |a: &Args, at: usize, kind: ViewError| {
            let kind = match &a.past {
                Some(text) => ViewError::OutOfRange(text.clone()),
                None => kind,
            };
            Error::at(map.location(a.base + at), LexicalError::ViewSetting(kind))
        };
        match a.label {
            "angle factor:" => {
                let (at, n) = a.float().map_err(|at| err(a, at, a.expected("a number")))?;
                let angle = 360.0 / n;
                // (cpfg: a float, divided in double, kept as a float.)
                self.turtle.angle = (360.0 / f64::from(n as f32)) as f32;
                if !angle.is_finite() {
                    return Err(err(
                        a,
                        at,
                        ViewError::CpfgNoValue(a.label, "360 divided by it is no angle"),
                    ));
                }
                self.view.angle = angle;
                self.angle_past(a.base + at, a.label);
            }
            "angle increment:" => {
                let (at, angle) = a.float().map_err(|at| err(a, at, a.expected("a number")))?;
                self.view.angle = angle;
                self.turtle.angle = angle as f32;
                self.angle_past(a.base + at, a.label);
            }
            "initial color:" | "color increment:" => {
                let n = a
                    .int()
                    .map_err(|at| err(a, at, a.expected("a whole number")))?
                    .1;
                // (A second number is the back faces', not drawn.)
                let _ = a.int();
                if a.label == "initial color:" {
                    self.view.colour = n as f64;
                } else {
                    self.view.colour_increment = n as f64;
                }
            }
            "initial line width:" => {
                let (at, w) = a.float().map_err(|at| err(a, at, a.expected("a number")))?;
                if w < 0.0 {
                    return Err(err(a, at, ViewError::Negative));
                }
                self.view.width = w;
                // cpfg: no word after the number is a polygon line; a
                // word starting with `p` pixels (`polygons` too), with `s`
                // a cylinder, any other a polygon.
                self.view.width_unit = match a.word() {
                    Some((_, w)) if w.starts_with('p') => WidthUnit::Pixels,
                    _ => WidthUnit::Model,
                };
            }
            "line width increment:" => {
                self.view.width_increment = a
                    .float()
                    .map_err(|at| err(a, at, a.expected("a number")))?
                    .1;
            }
            "line style:" => {
                let Some((at, w)) = a.word() else {
                    return Err(err(a, a.at, a.expected("`pixel`, `polygon` or `cylinder`")));
                };
                self.view.width_unit = match w {
                    "pixel" => WidthUnit::Pixels,
                    "polygon" | "cylinder" => WidthUnit::Model,
                    _ if w.starts_with('1') => WidthUnit::Pixels,
                    _ if w.starts_with(['2', '3']) => WidthUnit::Model,
                    // cpfg keeps the style it had, without a word.
                    _ => {
                        let kind = WarningKind::CpfgViewNotDrawn {
                            label: format!("line style: {}", shown(w)),
                            why: "no style of cpfg's (`pixel`, `polygon`, `cylinder`, 1 to 3): the style stays, as in cpfg",
                        };
                        self.warn(a.base + at, kind);
                        self.view.width_unit
                    }
                };
            }
            "tropism direction:" => {
                let (at, t) = a
                    .triple()
                    .map_err(|at| err(a, at, a.expected("three numbers `x,y,z`")))?;
                // Scaled first: 1e300,1e300,0 and 1e-320,0,0 have a
                // direction (their squares overflow or vanish).
                let u = super::state::unit_or_zero(t);
                if u == [0.0; 3] {
                    return Err(err(
                        a,
                        at,
                        ViewError::CpfgNoValue(
                            a.label,
                            "it has no direction (cpfg divides by its length)",
                        ),
                    ));
                }
                self.view.tropism = u;
                self.turtle.tropism = t.map(|x| x as f32);
            }
            "initial elasticity:" | "elasticity increment:" => {
                let e = a
                    .float()
                    .map_err(|at| err(a, at, a.expected("a number")))?
                    .1;
                if a.label == "initial elasticity:" {
                    self.view.elasticity = e;
                    self.turtle.elasticity = e as f32;
                } else {
                    self.view.elasticity_increment = e;
                    self.turtle.elasticity_increment = e as f32;
                }
            }
            "viewpoint:" | "view reference point:" => {
                let t = a
                    .triple()
                    .map_err(|at| err(a, at, a.expected("three numbers `x,y,z`")))?
                    .1;
                if a.label == "viewpoint:" {
                    self.viewpoint = t;
                } else {
                    self.vrp = t;
                }
            }
            "twist:" => {
                // Tenths of a degree; cpfg turns the camera's up vector
                // counter-clockwise (as seen by the viewer), the picture
                // clockwise: lsgen's twist turns the picture
                // counter-clockwise.
                let t = a
                    .int()
                    .map_err(|at| err(a, at, a.expected("a whole number (tenths of a degree)")))?
                    .1;
                self.view.twist = -(t as f64) / 10.0;
            }
            _ => unreachable!("a label of TAKEN"),
        }
        Ok(())
    }

    /// The direction from the view reference point to the viewpoint, as
    /// lsgen's azimuth and elevation (cpfg's default when they are the
    /// same point: looking from -Z).
    fn camera(&mut self) {
        // (Scaled: a viewpoint at 1e300,1e300,0 looks from (1,1,0), one at
        // 1e-320,0,0 from +X, one at 1e308 from a reference point at
        // -1e308 along that line.)
        let n = super::state::direction(self.vrp, self.viewpoint).unwrap_or([0.0, 0.0, -1.0]);
        let horizontal = (n[0] * n[0] + n[2] * n[2]).sqrt();
        self.view.direction = Direction {
            azimuth: if horizontal == 0.0 {
                0.0
            } else {
                n[0].atan2(n[2]).to_degrees()
            },
            elevation: n[1].clamp(-1.0, 1.0).asin().to_degrees(),
        };
    }
}

impl<'l> Args<'l> {
    fn expected(&self, what: &'static str) -> ViewError {
        ViewError::CpfgArguments {
            label: self.label,
            expected: what,
        }
    }

    fn skip_blanks(&mut self) {
        let rest = &self.line[self.at..];
        self.at += rest.len() - rest.trim_start().len();
    }

    /// `%f`: a number after blanks (the longest prefix C's `strtod` takes,
    /// finite). Err: where one was expected.
    fn float(&mut self) -> Result<(usize, f64), usize> {
        self.skip_blanks();
        let at = self.at;
        // The prefix C's `strtod` reads (the curves' scanner); its `inf`
        // and `nan` are no numbers here.
        let n = crate::cpfg::curve::number_prefix(&self.line[at..]);
        let j = at + n;
        let sign_less = self.line[at..j].trim_start_matches(['+', '-']);
        if n == 0 || sign_less.starts_with(|c: char| c.is_ascii_alphabetic()) {
            return Err(at);
        }
        let v: f64 = self.line[at..j].parse().map_err(|_| at)?;
        if !v.is_finite() {
            return Err(self.too_large(at, j));
        }
        self.at = j;
        Ok((at, v))
    }

    /// The number at `at..j` is past the largest one: note its text (cut
    /// at 32 bytes) for the error; Err(at) for the caller.
    fn too_large(&mut self, at: usize, j: usize) -> usize {
        let text = &self.line[at..j];
        self.past = Some(if text.len() > 32 {
            format!("{}...", &text[..32])
        } else {
            text.to_string()
        });
        at
    }

    /// `%d`: a whole number after blanks.
    fn int(&mut self) -> Result<(usize, i64), usize> {
        self.skip_blanks();
        let at = self.at;
        let b = self.line.as_bytes();
        let mut j = at;
        if j < b.len() && (b[j] == b'+' || b[j] == b'-') {
            j += 1;
        }
        let s = j;
        while j < b.len() && b[j].is_ascii_digit() {
            j += 1;
        }
        if j == s {
            return Err(at);
        }
        // (Digits only, so the one way to fail is a number too large.)
        let v: i64 = match self.line[at..j].parse() {
            Ok(v) => v,
            Err(_) => return Err(self.too_large(at, j)),
        };
        self.at = j;
        Ok((at, v))
    }

    /// `%f,%f,%f`: the commas right after the numbers.
    fn triple(&mut self) -> Result<(usize, [f64; 3]), usize> {
        self.skip_blanks();
        let at = self.at;
        let mut t = [0.0; 3];
        for (k, x) in t.iter_mut().enumerate() {
            *x = self.float()?.1;
            if k < 2 {
                if !self.line[self.at..].starts_with(',') {
                    return Err(self.at);
                }
                self.at += 1;
            }
        }
        Ok((at, t))
    }

    /// `%s`: a word after blanks.
    fn word(&mut self) -> Option<(usize, &'l str)> {
        self.skip_blanks();
        let line = self.line;
        let rest = &line[self.at..];
        let n = rest.find(char::is_whitespace).unwrap_or(rest.len());
        if n == 0 {
            return None;
        }
        let at = self.at;
        self.at += n;
        Some((at, &line[at..at + n]))
    }
}

/// A label as a warning shows it: control characters escaped (`\t`, a
/// NUL as `\u{0}`), not written raw to the terminal.
fn shown(label: &str) -> String {
    label
        .chars()
        .map(|c| {
            if c.is_control() {
                c.escape_default().to_string()
            } else {
                c.to_string()
            }
        })
        .collect()
}

/// cpfg's colour map (`-m FILE`): 256 colours of 3 bytes (red, green,
/// blue), nothing else. Index 0 is also the background, as in cpfg.
pub fn read_colormap(path: &Path, view: &mut View) -> Result<(), Error> {
    let data = read_binary(path, 768)?;
    if data.len() != 768 {
        return Err(bad_size(
            path,
            data.len(),
            768,
            "a colour map is 768 bytes: 256 colours of red, green and blue",
        ));
    }
    view.palette = data.chunks_exact(3).map(|c| [c[0], c[1], c[2]]).collect();
    view.background = Some(view.palette[0]);
    Ok(())
}

/// cpfg's material file (`-M FILE`): records of 15 bytes (index,
/// transparency, then ambient, diffuse, emissive and specular red, green
/// and blue, shininess), any number of them. A colour is its material's
/// diffuse colour, as cpfg draws without lighting; an index without a
/// record is cpfg's default material (white). The background is the
/// emissive colour of material 0, as in cpfg.
pub fn read_materials(path: &Path, view: &mut View) -> Result<(), Error> {
    const LIMIT: usize = 15 * 256 * 16;
    let data = read_binary(path, LIMIT as u64)?;
    if data.len() > LIMIT {
        return Err(bad_size(
            path,
            data.len(),
            LIMIT,
            "lsgen-turtle reads material files of at most 4096 records of 15 bytes (16 for each of the 256 indices)",
        ));
    }
    if data.len() % 15 != 0 {
        return Err(bad_size(
            path,
            data.len(),
            LIMIT,
            "a material file is records of 15 bytes",
        ));
    }
    let mut palette: Vec<Rgb> = vec![[255, 255, 255]; 256];
    let mut background: Rgb = [0, 0, 0];
    for r in data.chunks_exact(15) {
        let i = usize::from(r[0]);
        palette[i] = [r[5], r[6], r[7]];
        if i == 0 {
            background = [r[8], r[9], r[10]];
        }
    }
    view.palette = palette;
    view.background = Some(background);
    Ok(())
}

/// The file's first `limit + 1` bytes: more than `limit` is a file too
/// large (its size unknown: [`bad_size`] says "more than").
fn read_binary(path: &Path, limit: u64) -> Result<Vec<u8>, Error> {
    use std::io::Read;
    let name = path.display().to_string();
    crate::output::check_input_open(path, &name)?;
    let mut data = Vec::new();
    std::fs::File::open(path)
        .map_err(|e| Error::io(name.clone(), IoAction::Open, e))?
        .take(limit + 1)
        .read_to_end(&mut data)
        .map_err(|e| Error::io(name, IoAction::Read, e))?;
    Ok(data)
}

fn bad_size(path: &Path, len: usize, limit: usize, what: &str) -> Error {
    // read_binary stops after limit + 1 bytes: the size is not known then.
    let has = if len > limit {
        format!("more than {limit}")
    } else {
        len.to_string()
    };
    let e = std::io::Error::new(
        std::io::ErrorKind::InvalidData,
        format!("{what} (this one has {has} bytes)"),
    );
    Error::io(path.display().to_string(), IoAction::Read, e)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn read(text: &str) -> Result<(View, Vec<Warning>), Error> {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("m.v");
        std::fs::write(&p, text).unwrap();
        let mut v = View::default();
        let w = read_view(&p, &mut v)?;
        Ok((v, w))
    }

    #[test]
    fn cpfg_defaults_then_the_file() {
        let (v, w) = read("").unwrap();
        assert!(w.is_empty());
        assert_eq!((v.angle, v.colour, v.width), (45.0, 128.0, 1.0));
        assert_eq!(v.width_unit, WidthUnit::Pixels);
        assert_eq!(v.tropism_model, TropismModel::Cpfg);
        assert_eq!(
            v.direction,
            Direction {
                azimuth: 0.0,
                elevation: 0.0
            }
        );
        let (v, w) = read(
            "angle factor: 16\ninitial color: 3 7\ncolor increment: 2\n\
             initial line width: 2.5\nline width increment: 0.5\n\
             tropism direction: 0,-2,0\ninitial elasticity: 0.25\n\
             elasticity increment: -0.5\n\
             viewpoint: 1,0,0\nview reference point: 0,0,0\ntwist: 450\n\
             z buffer: on\nlight: O: 1 1 1\n",
        )
        .unwrap();
        assert!(w.is_empty(), "{w:?}");
        assert_eq!(v.angle, 22.5);
        assert_eq!((v.colour, v.colour_increment), (3.0, 2.0));
        // No word after the width: a polygon line, in model units.
        assert_eq!((v.width, v.width_unit), (2.5, WidthUnit::Model));
        assert_eq!(v.width_increment, 0.5);
        assert_eq!(v.tropism, [0.0, -1.0, 0.0]);
        assert_eq!((v.elasticity, v.elasticity_increment), (0.25, -0.5));
        assert_eq!(
            v.direction,
            Direction {
                azimuth: 90.0,
                elevation: 0.0
            }
        );
        assert_eq!(v.twist, -45.0);
    }

    #[test]
    fn empty_file_is_cpfgs_initialize_parameters() {
        let (v, _) = read("").unwrap();
        assert_eq!((v.colour_increment, v.width_increment), (1.0, 0.0));
        assert_eq!((v.elasticity, v.elasticity_increment), (0.0, 0.0));
        assert_eq!((v.tropism, v.twist), ([0.0, 1.0, 0.0], 0.0));
    }

    #[test]
    fn huge_and_tiny_vectors_keep_their_direction() {
        // Their squares overflow or vanish: scaled first, not cpfg's
        // default view nor "no direction".
        let dir = |t: &str| read(t).unwrap().0.direction;
        let want = dir("viewpoint: 1,1,0");
        assert_eq!(dir("viewpoint: 1e300,1e300,0"), want);
        assert_eq!(dir("viewpoint: 1e-320,1e-320,0"), want);
        assert_eq!(
            dir("viewpoint: 1e308,1e308,0\nview reference point: -1e308,-1e308,0"),
            want
        );
        let t = |t: &str| read(t).unwrap().0.tropism;
        assert_eq!(
            t("tropism direction: 1e300,-1e300,0"),
            t("tropism direction: 1,-1,0")
        );
        assert_eq!(t("tropism direction: 0,0,-1e-320"), [0.0, 0.0, -1.0]);
    }

    #[test]
    fn line_width_words_as_cpfg() {
        for (text, unit) in [
            ("initial line width: 2 pixels", WidthUnit::Pixels),
            ("initial line width: 2 polygons", WidthUnit::Pixels),
            ("initial line width: 2 solid", WidthUnit::Model),
            ("initial line width: 2 x", WidthUnit::Model),
            ("initial line width: 2   ", WidthUnit::Model),
            (
                "initial line width: 2 p\nline style: polygon",
                WidthUnit::Model,
            ),
            ("line style: pixel", WidthUnit::Pixels),
            ("line style: 3", WidthUnit::Model),
            // cpfg's digits: '1' pixel, '2' polygon, '3' cylinder.
            ("initial line width: 2\nline style: 1", WidthUnit::Pixels),
            ("initial line width: 2 p\nline style: 2", WidthUnit::Model),
            // Not a style: it stays (a warning).
            (
                "initial line width: 2 p\nline style: wireframe",
                WidthUnit::Pixels,
            ),
        ] {
            assert_eq!(read(text).unwrap().0.width_unit, unit, "{text}");
        }
    }

    #[test]
    fn camera_from_viewpoint_and_reference_point() {
        let dir = |t: &str| read(t).unwrap().0.direction;
        assert_eq!(
            dir("viewpoint: 0,5,0"),
            Direction {
                azimuth: 0.0,
                elevation: 90.0
            }
        );
        assert_eq!(
            dir("viewpoint: 1,0,0\nview reference point: 1,0,-3"),
            Direction {
                azimuth: 0.0,
                elevation: 0.0
            }
        );
        // The same point: cpfg looks from -Z.
        assert_eq!(
            dir("viewpoint: 2,2,2\nview reference point: 2,2,2"),
            Direction {
                azimuth: 180.0,
                elevation: 0.0
            }
        );
        let d = dir("viewpoint: 1,1,1");
        assert!((d.azimuth - 45.0).abs() < 1e-12);
        assert!((d.elevation - (1.0f64 / 3f64.sqrt()).asin().to_degrees()).abs() < 1e-12);
    }

    #[test]
    fn labels_as_cpfg_spells_them() {
        let (v, w) = read("Angle factor: 8\nangle  factor: 8\n  angle factor: 8\n").unwrap();
        // Case and inner blanks count; leading spaces do not.
        assert_eq!(v.angle, 45.0);
        assert_eq!(w.len(), 2);
        assert!(
            w[0].message().contains("`Angle factor:`"),
            "{}",
            w[0].message()
        );
        // Control characters are shown escaped, not written raw.
        let (_, w) = read("\tangle factor: 8\nx\0y\n").unwrap();
        assert!(w[0].message().contains("`\\tangle factor:`"), "{w:?}");
        assert!(w[1].message().contains("`x\\u{0}y`"), "{w:?}");
        // Several labels on one line, as cpfg's scanner allows.
        let (v, _) = read("viewpoint: 0,0,1 twist: 900\n").unwrap();
        assert_eq!(v.twist, -90.0);
        // The preprocessor runs first.
        let (v, _) = read("#define A 10\nangle factor: A /* c */\n").unwrap();
        assert_eq!(v.angle, 36.0);
        // (cpfg's movements are drawn: no warning.)
        let (v, w) =
            read("tropism: T: 0,1,0\nprojection: perspective\nprojection: parallel\n").unwrap();
        assert_eq!(w.len(), 1, "{w:?}");
        assert_eq!(v.movements.len(), 1);
        let (_, w) = read(
            "initial scale: 2\ntorque: T: 0,1,0\n\
             interpretation past %: on\ninterpretation past %: off\n",
        )
        .unwrap();
        assert_eq!(w.len(), 2, "{w:?}");
        assert!(w[1].message().contains("`interpretation past %:`"), "{w:?}");
        assert!(w[0].message().contains("`initial scale:`"), "{w:?}");
    }

    #[test]
    fn bad_arguments_are_located() {
        for (text, col, what) in [
            ("angle factor: x", 15, "a number"),
            ("angle factor: 0", 15, "no angle"),
            ("viewpoint: 1 2 3", 13, "x,y,z"),
            ("tropism direction: 0,0,0", 20, "no direction"),
            ("twist: .5", 8, "whole number"),
            ("initial line width: -1", 21, "negative"),
            ("angle increment: 1e999", 18, "`1e999` is out of range"),
            ("viewpoint: 0,-1e999,0", 14, "`-1e999` is out of range"),
            (
                "initial color: 99999999999999999999",
                16,
                "`99999999999999999999` is out of range",
            ),
            ("twist: -9223372036854775809", 8, "out of range"),
        ] {
            let e = read(text).unwrap_err();
            let l = e.location().unwrap();
            assert_eq!((l.line, l.col), (1, col), "{text}: {e}");
            assert!(e.to_string().contains(what), "{text}: {e}");
        }
    }

    #[test]
    fn colour_maps_and_materials() {
        let dir = tempfile::tempdir().unwrap();
        let map = dir.path().join("c.map");
        let mut data: Vec<u8> = (0..768u32).map(|i| (i % 251) as u8).collect();
        data[0..3].copy_from_slice(&[1, 2, 3]);
        std::fs::write(&map, &data).unwrap();
        let mut v = View::default();
        read_colormap(&map, &mut v).unwrap();
        assert_eq!(v.palette.len(), 256);
        assert_eq!(v.palette[0], [1, 2, 3]);
        assert_eq!(
            v.palette[200],
            [(600 % 251) as u8, (601 % 251) as u8, (602 % 251) as u8]
        );
        assert_eq!(v.background, Some([1, 2, 3]));
        std::fs::write(&map, &data[..767]).unwrap();
        assert!(read_colormap(&map, &mut v)
            .unwrap_err()
            .to_string()
            .contains("768 bytes"));

        let mat = dir.path().join("m.mat");
        let rec = |i: u8, d: [u8; 3], e: [u8; 3]| {
            vec![
                i, 0, 9, 9, 9, d[0], d[1], d[2], e[0], e[1], e[2], 7, 7, 7, 30,
            ]
        };
        let mut data = rec(5, [10, 20, 30], [0, 0, 0]);
        data.extend(rec(0, [1, 1, 1], [40, 50, 60]));
        std::fs::write(&mat, &data).unwrap();
        read_materials(&mat, &mut v).unwrap();
        assert_eq!(v.palette[5], [10, 20, 30]);
        assert_eq!(v.palette[6], [255, 255, 255]);
        assert_eq!(v.background, Some([40, 50, 60]));
        std::fs::write(&mat, &data[..16]).unwrap();
        assert!(read_materials(&mat, &mut v).is_err());
        // A repeated index: its last record, as cpfg (material 0's
        // background too).
        data.extend(rec(5, [11, 21, 31], [0, 0, 0]));
        data.extend(rec(0, [1, 1, 1], [41, 51, 61]));
        std::fs::write(&mat, &data).unwrap();
        read_materials(&mat, &mut v).unwrap();
        assert_eq!(v.palette[5], [11, 21, 31]);
        assert_eq!(v.background, Some([41, 51, 61]));
        // Too large: its size is not known (it was read up to the limit).
        std::fs::write(&mat, vec![0u8; 15 * 4097]).unwrap();
        let e = read_materials(&mat, &mut v).unwrap_err().to_string();
        assert!(
            e.contains("4096 records") && e.contains("more than 61440"),
            "{e}"
        );
        std::fs::write(&map, vec![0u8; 1000]).unwrap();
        let e = read_colormap(&map, &mut v).unwrap_err().to_string();
        assert!(e.contains("more than 768 bytes"), "{e}");
    }
}
