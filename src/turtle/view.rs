//! View settings: how a model is drawn. They travel with the model as
//! header lines `view: NAME = VALUE` of its `.ls` file, which lsgen checks
//! with [`parse_setting`] and otherwise ignores; `lsgen-turtle --ls FILE`
//! reads them and its options override them.

use crate::diag::{CodeMap, Error, Location, ViewError};

/// An RGB colour.
pub type Rgb = [u8; 3];

/// Where the model is looked at from (SVG and PNG projections).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Direction {
    /// Degrees about the vertical (Y) axis; 0 looks along -Z (front).
    pub azimuth: f64,
    /// Degrees above the horizontal plane; 90 looks down (top).
    pub elevation: f64,
}

/// What a width is measured in.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum WidthUnit {
    /// The model's units: widths scale with the drawing (cpfg's polygon
    /// and cylinder lines).
    Model,
    /// Pixels of SVG and PNG at any zoom (cpfg's pixel lines, its
    /// default); OBJ cylinders still take the width in model units.
    Pixels,
}

/// How tropism bends the turtle after a move.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum TropismModel {
    /// ABOP fig. 2.8: after `F` and `G`, turn by e·|H × T| about H × T.
    Abop,
    /// cpfg's `tropism direction:`/`initial elasticity:` (`interpret.c`'s
    /// `bend`): after `F`, `G`, `f` and `g`, with T of length 1, pitch H
    /// towards U by the angle whose sine is e·(T·U), then turn it towards
    /// L by the angle whose sine is e·(T·L).
    Cpfg,
}

#[derive(Clone, Debug, PartialEq)]
pub struct View {
    pub angle: f64,
    pub step: f64,
    pub width: f64,
    pub width_increment: f64,
    /// Every width is multiplied by this when drawn (cpfg models often
    /// give widths in pixels: this brings them to the model's units).
    pub width_scale: f64,
    pub width_unit: WidthUnit,
    pub colour: f64,
    pub colour_increment: f64,
    pub tropism: [f64; 3],
    pub elasticity: f64,
    /// Elasticity change of `_` without a parameter (cpfg's).
    pub elasticity_increment: f64,
    pub tropism_model: TropismModel,
    pub palette: Vec<Rgb>,
    pub direction: Direction,
    /// Degrees the picture is turned (counter-clockwise) on the screen,
    /// after the projection (cpfg's `twist:`, there in tenths of a degree).
    pub twist: f64,
    pub background: Option<Rgb>,
    /// cpfg's movements (a cpfg view's `tropism:` and `torque:` lines,
    /// [`super::movements`]): they turn the turtle before each move.
    pub movements: Vec<super::movements::Movement>,
}

impl Default for View {
    fn default() -> View {
        View {
            angle: 45.0,
            step: 1.0,
            width: 1.0,
            width_increment: 0.0,
            width_scale: 1.0,
            width_unit: WidthUnit::Model,
            colour: 0.0,
            colour_increment: 1.0,
            tropism: [0.0, 1.0, 0.0],
            elasticity: 0.0,
            elasticity_increment: 0.0,
            tropism_model: TropismModel::Abop,
            palette: DEFAULT_PALETTE.to_vec(),
            direction: Direction {
                azimuth: 0.0,
                elevation: 0.0,
            },
            twist: 0.0,
            background: Some([255, 255, 255]),
            movements: Vec::new(),
        }
    }
}

/// Colour indices 0.. when the model gives no palette.
pub const DEFAULT_PALETTE: [Rgb; 8] = [
    [0x1b, 0x1b, 0x1b],
    [0x2e, 0x7d, 0x32],
    [0x79, 0x55, 0x48],
    [0xc6, 0x28, 0x28],
    [0x15, 0x65, 0xc0],
    [0xf9, 0xa8, 0x25],
    [0x6a, 0x1b, 0x9a],
    [0x00, 0x83, 0x8f],
];

/// One parsed setting.
#[derive(Clone, Debug, PartialEq)]
pub enum Setting {
    Angle(f64),
    Step(f64),
    Width(f64),
    WidthIncrement(f64),
    WidthScale(f64),
    WidthUnit(WidthUnit),
    Colour(f64),
    ColourIncrement(f64),
    Tropism([f64; 3]),
    Elasticity(f64),
    ElasticityIncrement(f64),
    TropismModel(TropismModel),
    Palette(Vec<Rgb>),
    Direction(Direction),
    Twist(f64),
    Background(Option<Rgb>),
}

/// The names a `view:` line may set.
pub const NAMES: &[&str] = &[
    "angle",
    "step",
    "width",
    "width increment",
    "width scale",
    "width unit",
    "colour",
    "colour increment",
    "tropism",
    "elasticity",
    "elasticity increment",
    "tropism model",
    "palette",
    "direction",
    "twist",
    "background",
];

/// A problem in a setting: byte range in the text given and what.
#[derive(Clone, Debug, PartialEq)]
pub struct SettingError {
    pub span: (usize, usize),
    pub kind: ViewError,
}

fn err(span: (usize, usize), kind: ViewError) -> SettingError {
    SettingError { span, kind }
}

/// Words of `s` with their byte offsets.
fn words(s: &str) -> Vec<(usize, &str)> {
    let mut v = Vec::new();
    let mut start = None;
    for (i, c) in s.char_indices() {
        if c.is_whitespace() {
            if let Some(st) = start.take() {
                v.push((st, &s[st..i]));
            }
        } else if start.is_none() {
            start = Some(i);
        }
    }
    if let Some(st) = start {
        v.push((st, &s[st..]));
    }
    v
}

/// `w` as a number; `inf`, `nan` and a leading `+` are refused.
pub fn number_word(w: &str) -> Result<f64, ViewError> {
    match w.parse::<f64>() {
        Ok(_) if w.starts_with(['i', 'I', 'n', 'N', '+']) => {
            Err(ViewError::NotANumber(w.to_string()))
        }
        Ok(v) if v.is_finite() => Ok(v),
        // Digits past the largest number (`1e400`, `-1e400`), not `-inf`.
        Ok(_)
            if w.trim_start_matches('-')
                .starts_with(|c: char| c.is_ascii_digit() || c == '.') =>
        {
            Err(ViewError::OutOfRange(w.to_string()))
        }
        _ => Err(ViewError::NotANumber(w.to_string())),
    }
}

fn number(at: usize, w: &str) -> Result<f64, SettingError> {
    number_word(w).map_err(|kind| err((at, at + w.len()), kind))
}

fn colour(at: usize, w: &str) -> Result<Rgb, SettingError> {
    let bad = || err((at, at + w.len()), ViewError::NotAColour(w.to_string()));
    let hex = w.strip_prefix('#').ok_or_else(bad)?;
    if hex.len() != 6 || !hex.bytes().all(|b| b.is_ascii_hexdigit()) {
        return Err(bad());
    }
    let v = u32::from_str_radix(hex, 16).map_err(|_| bad())?;
    Ok([(v >> 16) as u8, (v >> 8) as u8, v as u8])
}

/// Parse a direction: `front`, `side`, `top` or `AZIMUTH ELEVATION` (degrees).
pub fn parse_direction(s: &str) -> Result<Direction, SettingError> {
    let w = words(s);
    let d = |a, e| Direction {
        azimuth: a,
        elevation: e,
    };
    match w.as_slice() {
        [(_, n)] if n.eq_ignore_ascii_case("front") => Ok(d(0.0, 0.0)),
        [(_, n)] if n.eq_ignore_ascii_case("side") => Ok(d(90.0, 0.0)),
        [(_, n)] if n.eq_ignore_ascii_case("top") => Ok(d(0.0, 90.0)),
        [(a, x), (b, y)] => {
            let e = number(*b, y)?;
            if !(-90.0..=90.0).contains(&e) {
                return Err(err((*b, b + y.len()), ViewError::ElevationRange));
            }
            Ok(d(number(*a, x)?, e))
        }
        _ => Err(err((0, s.len()), ViewError::Direction)),
    }
}

/// Parse the text after `view:`: `NAME = VALUE`. Offsets in errors are
/// relative to `text`.
pub fn parse_setting(text: &str) -> Result<Setting, SettingError> {
    let Some(eq) = text.find('=') else {
        return Err(err((0, text.len()), ViewError::Syntax));
    };
    let name = words(&text[..eq])
        .iter()
        .map(|(_, w)| w.to_ascii_lowercase())
        .collect::<Vec<_>>()
        .join(" ");
    let name = name.replace("color", "colour");
    let vstart = eq + 1;
    let value = &text[vstart..];
    let w: Vec<(usize, &str)> = words(value)
        .into_iter()
        .map(|(i, s)| (i + vstart, s))
        .collect();
    let name_words = words(&text[..eq]);
    let name_span = match (name_words.first(), name_words.last()) {
        (Some(&(a, _)), Some(&(b, w))) => (a, b + w.len()),
        _ => (0, eq),
    };
    let one = |w: &[(usize, &str)]| -> Result<f64, SettingError> {
        match w {
            [(a, x)] => number(*a, x),
            _ => Err(err((vstart, text.len()), ViewError::OneNumber)),
        }
    };
    let non_negative = |v: f64| -> Result<f64, SettingError> {
        if v < 0.0 {
            Err(err((vstart, text.len()), ViewError::Negative))
        } else {
            Ok(v)
        }
    };
    // One of `names`, by its place.
    let pick = |names: &'static [&'static str]| -> Result<usize, SettingError> {
        match w.as_slice() {
            [(_, n)] => names.iter().position(|x| n.eq_ignore_ascii_case(x)),
            _ => None,
        }
        .ok_or_else(|| err((vstart, text.len()), ViewError::OneOf(names)))
    };
    Ok(match name.as_str() {
        "angle" => Setting::Angle(one(&w)?),
        "step" => Setting::Step(one(&w)?),
        "width" => Setting::Width(non_negative(one(&w)?)?),
        "width increment" => Setting::WidthIncrement(one(&w)?),
        "width scale" => Setting::WidthScale(non_negative(one(&w)?)?),
        "colour" => Setting::Colour(one(&w)?),
        "colour increment" => Setting::ColourIncrement(one(&w)?),
        "elasticity" => Setting::Elasticity(one(&w)?),
        "elasticity increment" => Setting::ElasticityIncrement(one(&w)?),
        "width unit" => {
            Setting::WidthUnit([WidthUnit::Model, WidthUnit::Pixels][pick(&["model", "pixels"])?])
        }
        "tropism model" => Setting::TropismModel(
            [TropismModel::Abop, TropismModel::Cpfg][pick(&["abop", "cpfg"])?],
        ),
        "tropism" => match w.as_slice() {
            [(a, x), (b, y), (c, z)] => {
                Setting::Tropism([number(*a, x)?, number(*b, y)?, number(*c, z)?])
            }
            _ => return Err(err((vstart, text.len()), ViewError::Tropism)),
        },
        "palette" => {
            if w.is_empty() {
                return Err(err((vstart, text.len()), ViewError::Palette));
            }
            Setting::Palette(
                w.iter()
                    .map(|(a, s)| colour(*a, s))
                    .collect::<Result<_, _>>()?,
            )
        }
        "direction" => Setting::Direction(parse_direction(value).map_err(|mut e| {
            e.span = (e.span.0 + vstart, e.span.1 + vstart);
            e
        })?),
        "twist" => Setting::Twist(one(&w)?),
        "background" => match w.as_slice() {
            [(_, n)] if n.eq_ignore_ascii_case("none") => Setting::Background(None),
            [(a, s)] => Setting::Background(Some(colour(*a, s)?)),
            _ => return Err(err((vstart, text.len()), ViewError::Background)),
        },
        _ if name.is_empty() => return Err(err(name_span, ViewError::Syntax)),
        _ => return Err(err(name_span, ViewError::Unknown(name))),
    })
}

impl View {
    pub fn apply(&mut self, s: Setting) {
        match s {
            Setting::Angle(v) => self.angle = v,
            Setting::Step(v) => self.step = v,
            Setting::Width(v) => self.width = v,
            Setting::WidthIncrement(v) => self.width_increment = v,
            Setting::WidthScale(v) => self.width_scale = v,
            Setting::WidthUnit(v) => self.width_unit = v,
            Setting::Colour(v) => self.colour = v,
            Setting::ColourIncrement(v) => self.colour_increment = v,
            Setting::Tropism(v) => self.tropism = v,
            Setting::Elasticity(v) => self.elasticity = v,
            Setting::ElasticityIncrement(v) => self.elasticity_increment = v,
            Setting::TropismModel(v) => self.tropism_model = v,
            Setting::Palette(v) => self.palette = v,
            Setting::Direction(v) => self.direction = v,
            Setting::Twist(v) => self.twist = v,
            Setting::Background(v) => self.background = v,
        }
    }

    /// The colour of index `i`: indices past either end of the palette
    /// take its first or last colour.
    pub fn colour_of(&self, i: i64) -> Rgb {
        let last = self.palette.len().saturating_sub(1) as i64;
        self.palette
            .get(i.clamp(0, last) as usize)
            .copied()
            .unwrap_or([0, 0, 0])
    }
}

/// Read the `view:` lines of an `.ls` file's header into `view`, the way
/// lsgen reads that header: lsgen's header reader (at most
/// [`crate::input::MAX_HEADER`] bytes, UTF-8 without NUL, a byte-order
/// mark and a `#!` line skipped) up to `axiom:`, then lsgen's lexer, so
/// a line is a view line for lsgen-turtle exactly when it is one for lsgen.
pub fn read_ls(
    name: &str,
    input: Box<dyn std::io::Read + Send>,
    view: &mut View,
) -> Result<(), Error> {
    let mut input = crate::input::Input::new(input, name);
    let split = crate::input::split_header(&mut input)?;
    let text = &split.header;
    match crate::lexer::view_settings(text) {
        Ok(settings) => {
            for s in settings {
                view.apply(s);
            }
            Ok(())
        }
        Err(e) => {
            let map = CodeMap::new(text);
            Err(Error::at(Location::from_map(name, &map, e.span.0), e.kind))
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn settings() {
        assert_eq!(parse_setting(" angle = 25.7"), Ok(Setting::Angle(25.7)));
        assert_eq!(
            parse_setting(" Width  Increment = 0.5 "),
            Ok(Setting::WidthIncrement(0.5))
        );
        assert_eq!(
            parse_setting(" color increment = 2"),
            Ok(Setting::ColourIncrement(2.0))
        );
        assert_eq!(
            parse_setting(" tropism = 0 -1 0"),
            Ok(Setting::Tropism([0.0, -1.0, 0.0]))
        );
        assert_eq!(
            parse_setting(" palette = #2e7d32 #795548"),
            Ok(Setting::Palette(vec![
                [0x2e, 0x7d, 0x32],
                [0x79, 0x55, 0x48]
            ]))
        );
        assert_eq!(
            parse_setting(" direction = 30 20"),
            Ok(Setting::Direction(Direction {
                azimuth: 30.0,
                elevation: 20.0
            }))
        );
        assert_eq!(
            parse_setting(" direction = top"),
            Ok(Setting::Direction(Direction {
                azimuth: 0.0,
                elevation: 90.0
            }))
        );
    }

    #[test]
    fn errors_are_located() {
        let e = parse_setting(" angel = 3").unwrap_err();
        assert_eq!(e.span, (1, 6));
        assert_eq!(e.kind, ViewError::Unknown("angel".into()));
        let e = parse_setting(" angle = 2x").unwrap_err();
        assert_eq!(e.span, (9, 11));
        let e = parse_setting(" palette = #12345").unwrap_err();
        assert_eq!(e.span, (11, 17));
        assert!(parse_setting(" angle 3").is_err());
        assert!(parse_setting(" angle = inf").is_err());
        let e = parse_setting(" angle = 1e400").unwrap_err();
        assert_eq!(e.kind, ViewError::OutOfRange("1e400".into()));
        assert_eq!(e.span, (9, 14));
        assert!(parse_setting(" width = -1").is_err());
    }

    fn read(text: &str, v: &mut View) -> Result<(), Error> {
        let bytes = text.as_bytes().to_vec();
        read_ls("t.ls", Box::new(std::io::Cursor::new(bytes)), v)
    }

    #[test]
    fn reads_header_lines_only() {
        // As lsgen's lexer: a comment that spans lines ends its line, so
        // `*/ view:` starts a view line; so does `/* c */ view:`.
        let text = "/* view: angle = 1\n*/ view: step = 2\nview: angle = 3 /* c */\n\
                    /* c */ view: width = 4\naxiom:\nview: width = 9\n";
        let mut v = View::default();
        read(text, &mut v).unwrap();
        assert_eq!((v.angle, v.step, v.width), (3.0, 2.0, 4.0));
        // After a byte-order mark and a `#!` line too.
        read("\u{feff}view: step = 7\n", &mut v).unwrap();
        assert_eq!(v.step, 7.0);
        read("#!/usr/bin/env lsgen\nview: step = 8\n", &mut v).unwrap();
        assert_eq!(v.step, 8.0);
        let e = read("F\n  view: step = x\n", &mut v).unwrap_err();
        let l = e.location().unwrap().clone();
        assert_eq!((l.line, l.col), (2, 16));
        let e = read("/* c */ view: angel = 3\n", &mut v).unwrap_err();
        let l = e.location().unwrap().clone();
        assert_eq!((l.line, l.col), (1, 15));
    }
}
