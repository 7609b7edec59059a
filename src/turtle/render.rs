//! Output formats: the bounding-box pass, SVG, PNG (tiny-skia), OBJ and the
//! plain segment list.

use super::state::{cross, direction, dot, norm, Sink, V3};
use super::view::{Direction, Rgb, View, WidthUnit};
use crate::codec::NumFmt;
use std::io::{self, Write};

/// Orthographic projection to screen coordinates (u right, v up).
#[derive(Clone, Copy, Debug)]
pub struct Projection {
    right: V3,
    up: V3,
}

impl Projection {
    /// Seen from azimuth `az` about Y (0: from +Z, 90: from +X) and
    /// elevation `el` (90: from above), the picture then turned by `twist`
    /// degrees counter-clockwise.
    pub fn new(d: Direction, twist: f64) -> Projection {
        let (sa, ca) = d.azimuth.to_radians().sin_cos();
        let (se, ce) = d.elevation.to_radians().sin_cos();
        let right = [ca, 0.0, -sa];
        let toward = [sa * ce, se, ca * ce];
        let up = cross(toward, right);
        let (st, ct) = twist.to_radians().sin_cos();
        let mix = |a: V3, ka: f64, b: V3, kb: f64| {
            [
                a[0] * ka + b[0] * kb,
                a[1] * ka + b[1] * kb,
                a[2] * ka + b[2] * kb,
            ]
        };
        Projection {
            right: mix(right, ct, up, -st),
            up: mix(right, st, up, ct),
        }
    }
    #[inline]
    pub fn project(&self, p: V3) -> (f64, f64) {
        (dot(p, self.right), dot(p, self.up))
    }
}

/// The first pass: the projected bounding box, strokes and dots included.
pub struct BBox {
    proj: Projection,
    pub min: (f64, f64),
    pub max: (f64, f64),
    pub any: bool,
    /// Largest coordinate magnitude seen: projected extents within a few
    /// hundred ulps of it are rounding noise (a line seen end-on).
    pub reach: f64,
    /// Widths are pixels ([`WidthUnit::Pixels`]): no part of the extent.
    pixel_widths: bool,
}

impl BBox {
    pub fn new(proj: Projection, unit: WidthUnit) -> BBox {
        BBox {
            proj,
            min: (f64::INFINITY, f64::INFINITY),
            max: (f64::NEG_INFINITY, f64::NEG_INFINITY),
            any: false,
            reach: 0.0,
            pixel_widths: unit == WidthUnit::Pixels,
        }
    }
    /// Add point `p` with a stroke or dot radius `r`. An extent that is
    /// no longer a finite number cannot be laid out: [`ExtentOverflow`].
    #[inline]
    fn add(&mut self, p: V3, r: f64) -> io::Result<()> {
        self.reach = self.reach.max(p[0].abs()).max(p[1].abs()).max(p[2].abs());
        let (u, v) = self.proj.project(p);
        let r = r.max(0.0);
        self.min.0 = self.min.0.min(u - r);
        self.min.1 = self.min.1.min(v - r);
        self.max.0 = self.max.0.max(u + r);
        self.max.1 = self.max.1.max(v + r);
        self.any = true;
        let ok = [u, v, r, self.max.0 - self.min.0, self.max.1 - self.min.1];
        if !ok.iter().all(|x| x.is_finite()) {
            return Err(io::Error::other(ExtentOverflow));
        }
        Ok(())
    }
}

/// The drawing's extent (or a stroke or dot) is too large for a number:
/// it cannot be laid out. [`super::interpret`] reports it at the module.
#[derive(Debug)]
pub struct ExtentOverflow;

impl std::fmt::Display for ExtentOverflow {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        crate::diag::TurtleError::ExtentOverflow.fmt(f)
    }
}

impl std::error::Error for ExtentOverflow {}

impl Sink for BBox {
    fn segment(&mut self, a: V3, b: V3, width: f64, _: i64) -> io::Result<()> {
        let r = if self.pixel_widths { 0.0 } else { width / 2.0 };
        self.add(a, r)?;
        self.add(b, r)
    }
    fn polygon(&mut self, points: &[V3], _: i64) -> io::Result<()> {
        for &p in points {
            self.add(p, 0.0)?;
        }
        Ok(())
    }
    fn dot(&mut self, c: V3, d: f64, _: i64, _: bool) -> io::Result<()> {
        self.add(c, d / 2.0)
    }
}

/// World to pixel: the bounding box scaled to fit `size` pixels (the
/// longer side), with a margin.
#[derive(Clone, Copy, Debug)]
pub struct Layout {
    pub proj: Projection,
    pub width: u32,
    pub height: u32,
    pub scale: f64,
    /// What a line's width is measured in.
    pub unit: WidthUnit,
    min_u: f64,
    max_v: f64,
    margin: f64,
}

/// Largest `--size` accepted.
pub const MAX_SIZE: u32 = 8192;

impl Layout {
    pub fn new(b: &BBox, size: u32, unit: WidthUnit) -> Layout {
        let size = size.clamp(1, MAX_SIZE);
        let margin = (size as f64 * 0.03).round().max(1.0);
        let (min, max) = if b.any {
            (b.min, b.max)
        } else {
            ((0.0, 0.0), (0.0, 0.0))
        };
        // A projected coordinate is exact to a few ulps of the largest
        // coordinate (`reach`), and each rotation of the turtle's frame
        // adds about one: an extent within 512 ulps of reach (2^-43, about
        // 1.1e-13 of it) is below what the numbers resolve, a point or a
        // line seen end-on. (Far larger, 1e-9, flattened real drawings
        // far from the origin: `@M(1e10,0,0)F(5)`.) Points are then laid
        // out relative to the box's corner, so a large offset costs no
        // precision of its own.
        let noise = b.reach * (512.0 * f64::EPSILON);
        let flat = |x: f64| if x <= noise { 0.0 } else { x };
        let (bw, bh) = (flat(max.0 - min.0), flat(max.1 - min.1));
        let inner = (size as f64 - 2.0 * margin).max(1.0);
        let big = bw.max(bh);
        if !(big > 0.0 && big.is_finite() && (inner / big).is_finite()) {
            // Nothing drawn, a point, or an extent so small that fitting
            // it would overflow (`@o(1e-320)`): drawn at scale 1 in the
            // middle of a square of --size.
            let half = f64::from(size) / 2.0;
            return Layout {
                proj: b.proj,
                width: size,
                height: size,
                scale: 1.0,
                unit,
                // (The box's middle, halves first: no overflow.)
                min_u: min.0 / 2.0 + max.0 / 2.0,
                max_v: min.1 / 2.0 + max.1 / 2.0,
                margin: half,
            };
        }
        let scale = inner / big;
        // Never more than --size, whatever the rounding.
        let dim = |x: f64| ((x * scale + 2.0 * margin).ceil() as u32).clamp(1, size);
        Layout {
            proj: b.proj,
            width: dim(bw),
            height: dim(bh),
            scale,
            unit,
            min_u: min.0,
            max_v: max.1,
            margin,
        }
    }
    /// A line's width in pixels.
    #[inline]
    pub fn stroke(&self, width: f64) -> f64 {
        match self.unit {
            WidthUnit::Model => width * self.scale,
            WidthUnit::Pixels => width,
        }
    }
    #[inline]
    pub fn px(&self, p: V3) -> (f64, f64) {
        let (u, v) = self.proj.project(p);
        (
            (u - self.min_u) * self.scale + self.margin,
            (self.max_v - v) * self.scale + self.margin,
        )
    }
}

fn hex(c: Rgb) -> String {
    format!("#{:02x}{:02x}{:02x}", c[0], c[1], c[2])
}

/// The colour of index `i` from formatted palette entries, clamped to the
/// palette as [`View::colour_of`] does.
fn pick(hex: &[String], i: i64) -> &str {
    let last = hex.len().saturating_sub(1) as i64;
    hex.get(i.clamp(0, last) as usize)
        .map_or("#000000", |s| s.as_str())
}

/// Append `x` with two decimals, trailing zeros cut.
fn num2(out: &mut Vec<u8>, x: f64) {
    let r = (x * 100.0).round();
    if !r.is_finite() || r.abs() > 9e15 {
        let _ = write!(out, "{x}");
        return;
    }
    let mut n = r as i64;
    if n < 0 {
        out.push(b'-');
        n = -n;
    }
    let _ = write!(out, "{}", n / 100);
    let f = n % 100;
    if f != 0 {
        if f % 10 == 0 {
            let _ = write!(out, ".{}", f / 10);
        } else {
            let _ = write!(out, ".{f:02}");
        }
    }
}

/// Append a stroke width or a radius in pixels: two decimals from one
/// pixel up, three significant digits below, so that a small width is
/// never written as 0 (which draws nothing).
fn num_width(out: &mut Vec<u8>, x: f64) {
    let x = x.max(0.0);
    if x >= 1.0 || x == 0.0 || !x.is_finite() {
        return num2(out, x);
    }
    let r: f64 = format!("{x:.2e}").parse().unwrap_or(x);
    if r >= 1.0 {
        return num2(out, r);
    }
    out.extend_from_slice(ryu::Buffer::new().format_finite(r).as_bytes());
}

/// Consecutive segments that join, with one width and colour, become one
/// polyline.
struct Run {
    open: bool,
    end: V3,
    width: f64,
    colour: i64,
    points: usize,
}

impl Run {
    fn new() -> Run {
        Run {
            open: false,
            end: [0.0; 3],
            width: 0.0,
            colour: 0,
            points: 0,
        }
    }
    /// Does a segment from `a` continue the open polyline?
    #[inline]
    fn continues(&self, a: V3, width: f64, colour: i64, max_points: usize) -> bool {
        self.open
            && self.end == a
            && self.width == width
            && self.colour == colour
            && self.points < max_points
    }
}

pub struct Svg<'w> {
    out: &'w mut dyn Write,
    layout: Layout,
    /// The palette as `#rrggbb`, formatted once.
    hex: Vec<String>,
    run: Run,
    buf: Vec<u8>,
}

impl<'w> Svg<'w> {
    pub fn begin(out: &'w mut dyn Write, layout: Layout, view: &View) -> io::Result<Svg<'w>> {
        let (w, h) = (layout.width, layout.height);
        writeln!(
            out,
            "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"{w}\" height=\"{h}\" viewBox=\"0 0 {w} {h}\">"
        )?;
        if let Some(bg) = view.background {
            writeln!(
                out,
                "<rect width=\"{w}\" height=\"{h}\" fill=\"{}\"/>",
                hex(bg)
            )?;
        }
        writeln!(
            out,
            "<g fill=\"none\" stroke-linecap=\"round\" stroke-linejoin=\"round\">"
        )?;
        Ok(Svg {
            out,
            layout,
            hex: view.palette.iter().map(|&c| hex(c)).collect(),
            run: Run::new(),
            buf: Vec::with_capacity(1 << 16),
        })
    }

    fn close_run(&mut self) {
        if self.run.open {
            self.buf.extend_from_slice(b"\"/>\n");
            self.run.open = false;
        }
    }

    fn flush_buf(&mut self) -> io::Result<()> {
        if self.buf.len() >= 1 << 15 {
            self.out.write_all(&self.buf)?;
            self.buf.clear();
        }
        Ok(())
    }

    fn point(&mut self, p: V3) {
        let (x, y) = self.layout.px(p);
        num2(&mut self.buf, x);
        self.buf.push(b',');
        num2(&mut self.buf, y);
    }

    pub fn finish(mut self) -> io::Result<()> {
        self.close_run();
        self.buf.extend_from_slice(b"</g>\n</svg>\n");
        self.out.write_all(&self.buf)?;
        self.out.flush()
    }
}

impl Sink for Svg<'_> {
    fn segment(&mut self, a: V3, b: V3, width: f64, colour: i64) -> io::Result<()> {
        if self.run.continues(a, width, colour, usize::MAX) {
            self.buf.push(b' ');
        } else {
            self.close_run();
            let _ = write!(self.buf, "<polyline stroke=\"");
            self.buf
                .extend_from_slice(pick(&self.hex, colour).as_bytes());
            let w = self.layout.stroke(width);
            if w > 0.0 {
                self.buf.extend_from_slice(b"\" stroke-width=\"");
                num_width(&mut self.buf, w);
                if self.layout.unit == WidthUnit::Pixels {
                    // The same pixels at any zoom, as cpfg's pixel lines.
                    self.buf
                        .extend_from_slice(b"\" vector-effect=\"non-scaling-stroke");
                }
            } else {
                // Width 0 is a hairline, as in PNG: one pixel at any zoom.
                self.buf
                    .extend_from_slice(b"\" stroke-width=\"1\" vector-effect=\"non-scaling-stroke");
            }
            self.buf.extend_from_slice(b"\" points=\"");
            self.point(a);
            self.buf.push(b' ');
            self.run = Run {
                open: true,
                end: a,
                width,
                colour,
                points: 1,
            };
        }
        self.point(b);
        self.run.end = b;
        self.run.points += 1;
        self.flush_buf()
    }
    fn polygon(&mut self, points: &[V3], colour: i64) -> io::Result<()> {
        self.close_run();
        let c = pick(&self.hex, colour);
        let _ = write!(self.buf, "<polygon fill=\"{c}\" stroke=\"none\" points=\"");
        for (i, &p) in points.iter().enumerate() {
            if i > 0 {
                self.buf.push(b' ');
            }
            self.point(p);
        }
        self.buf.extend_from_slice(b"\"/>\n");
        self.flush_buf()
    }
    fn dot(&mut self, centre: V3, d: f64, colour: i64, _: bool) -> io::Result<()> {
        self.close_run();
        let c = pick(&self.hex, colour);
        let (x, y) = self.layout.px(centre);
        let _ = write!(self.buf, "<circle fill=\"{c}\" stroke=\"none\" cx=\"");
        num2(&mut self.buf, x);
        self.buf.extend_from_slice(b"\" cy=\"");
        num2(&mut self.buf, y);
        self.buf.extend_from_slice(b"\" r=\"");
        // A diameter of 0 or less is a dot of one pixel, as in PNG and as
        // a line of width 0 is a hairline (`r="0"` drew nothing).
        let r = d / 2.0 * self.layout.scale;
        num_width(&mut self.buf, if r > 0.0 { r } else { 0.5 });
        self.buf.extend_from_slice(b"\"/>\n");
        self.flush_buf()
    }
}

/// Points per PNG path before it is stroked (bounds memory).
const PNG_RUN: usize = 4096;

pub struct Png {
    pixmap: tiny_skia::Pixmap,
    layout: Layout,
    view: View,
    run: Run,
    path: tiny_skia::PathBuilder,
}

impl Png {
    pub fn new(layout: Layout, view: &View) -> io::Result<Png> {
        let mut pixmap = tiny_skia::Pixmap::new(layout.width, layout.height)
            .ok_or_else(|| io::Error::other("image too large"))?;
        if let Some(bg) = view.background {
            pixmap.fill(tiny_skia::Color::from_rgba8(bg[0], bg[1], bg[2], 255));
        }
        Ok(Png {
            pixmap,
            layout,
            view: view.clone(),
            run: Run::new(),
            path: tiny_skia::PathBuilder::new(),
        })
    }

    /// Fill `path` with palette colour `colour`.
    fn fill(&mut self, path: &tiny_skia::Path, colour: i64) {
        let paint = self.paint(colour);
        self.pixmap.fill_path(
            path,
            &paint,
            tiny_skia::FillRule::Winding,
            tiny_skia::Transform::identity(),
            None,
        );
    }

    fn paint(&self, colour: i64) -> tiny_skia::Paint<'static> {
        let c = self.view.colour_of(colour);
        let mut p = tiny_skia::Paint::default();
        p.set_color_rgba8(c[0], c[1], c[2], 255);
        p.anti_alias = true;
        p
    }

    fn stroke_run(&mut self) {
        if !self.run.open {
            return;
        }
        self.run.open = false;
        let pb = std::mem::take(&mut self.path);
        if let Some(path) = pb.finish() {
            let paint = self.paint(self.run.colour);
            let stroke = tiny_skia::Stroke {
                width: self.layout.stroke(self.run.width).max(0.0) as f32,
                line_cap: tiny_skia::LineCap::Round,
                line_join: tiny_skia::LineJoin::Round,
                ..Default::default()
            };
            self.pixmap.stroke_path(
                &path,
                &paint,
                &stroke,
                tiny_skia::Transform::identity(),
                None,
            );
            // Keep the builder's allocation for the next run.
            self.path = path.clear();
        }
    }

    pub fn finish(mut self, out: &mut dyn Write) -> io::Result<()> {
        self.stroke_run();
        // Opaque pictures are written as RGB, and every PNG with the best
        // compression: the gallery's files stay small.
        let (w, h) = (self.pixmap.width(), self.pixmap.height());
        let opaque = self.view.background.is_some();
        let mut data = Vec::with_capacity((w * h * 4) as usize);
        for p in self.pixmap.pixels() {
            let c = p.demultiply();
            data.extend_from_slice(&[c.red(), c.green(), c.blue()]);
            if !opaque {
                data.push(c.alpha());
            }
        }
        let mut enc = png::Encoder::new(&mut *out, w, h);
        enc.set_color(if opaque {
            png::ColorType::Rgb
        } else {
            png::ColorType::Rgba
        });
        enc.set_depth(png::BitDepth::Eight);
        enc.set_compression(png::Compression::Best);
        enc.set_adaptive_filter(png::AdaptiveFilterType::Adaptive);
        let mut writer = enc.write_header().map_err(png_err)?;
        writer.write_image_data(&data).map_err(png_err)?;
        writer.finish().map_err(png_err)?;
        out.flush()
    }
}

impl Sink for Png {
    fn segment(&mut self, a: V3, b: V3, width: f64, colour: i64) -> io::Result<()> {
        if !self.run.continues(a, width, colour, PNG_RUN) {
            self.stroke_run();
            let (x, y) = self.layout.px(a);
            self.path.move_to(x as f32, y as f32);
            self.run = Run {
                open: true,
                end: a,
                width,
                colour,
                points: 1,
            };
        }
        let (x, y) = self.layout.px(b);
        self.path.line_to(x as f32, y as f32);
        self.run.end = b;
        self.run.points += 1;
        Ok(())
    }
    fn polygon(&mut self, points: &[V3], colour: i64) -> io::Result<()> {
        self.stroke_run();
        let mut pb = tiny_skia::PathBuilder::new();
        for (i, &p) in points.iter().enumerate() {
            let (x, y) = self.layout.px(p);
            if i == 0 {
                pb.move_to(x as f32, y as f32);
            } else {
                pb.line_to(x as f32, y as f32);
            }
        }
        pb.close();
        if let Some(path) = pb.finish() {
            self.fill(&path, colour);
        }
        Ok(())
    }
    fn dot(&mut self, centre: V3, d: f64, colour: i64, _: bool) -> io::Result<()> {
        self.stroke_run();
        let (x, y) = self.layout.px(centre);
        let r = (d / 2.0 * self.layout.scale) as f32;
        if let Some(path) = tiny_skia::PathBuilder::from_circle(x as f32, y as f32, r.max(0.5)) {
            self.fill(&path, colour);
        }
        Ok(())
    }
}

fn png_err(e: png::EncodingError) -> io::Error {
    match e {
        png::EncodingError::IoError(e) => e,
        e => io::Error::other(e),
    }
}

/// Sides of a `--cylinders` tube.
const SIDES: usize = 8;

/// Append `v` as lsgen prints numbers (shortest round trip).
fn put_num(fmt: &mut NumFmt, out: &mut Vec<u8>, v: f64) {
    if v.is_finite() {
        fmt.put(out, v);
    } else {
        let _ = write!(out, "{v}");
    }
}

pub struct Obj<'w> {
    out: io::BufWriter<&'w mut dyn Write>,
    fmt: NumFmt,
    line: Vec<u8>,
    palette_len: i64,
    cylinders: bool,
    /// Vertices written so far (OBJ indices are 1-based).
    vertices: u64,
    run: Run,
    material: Option<i64>,
}

impl<'w> Obj<'w> {
    pub fn begin(
        out: &'w mut dyn Write,
        view: &View,
        mtllib: Option<&[u8]>,
        cylinders: bool,
    ) -> io::Result<Obj<'w>> {
        let mut out = io::BufWriter::with_capacity(1 << 16, out);
        writeln!(out, "# lsgen-turtle")?;
        if let Some(m) = mtllib {
            out.write_all(b"mtllib ")?;
            out.write_all(m)?;
            out.write_all(b"\n")?;
        }
        Ok(Obj {
            out,
            fmt: NumFmt::new(),
            line: Vec::with_capacity(128),
            palette_len: view.palette.len().max(1) as i64,
            cylinders,
            vertices: 0,
            run: Run::new(),
            material: None,
        })
    }

    /// Write vertex `p`. A coordinate past the largest number (a tube of
    /// huge width) cannot be written: [`ExtentOverflow`], as in SVG/PNG.
    fn v(&mut self, p: V3) -> io::Result<u64> {
        if !p.iter().all(|x| x.is_finite()) {
            return Err(io::Error::other(ExtentOverflow));
        }
        self.line.clear();
        self.line.push(b'v');
        for x in p {
            self.line.push(b' ');
            put_num(&mut self.fmt, &mut self.line, x);
        }
        self.line.push(b'\n');
        self.out.write_all(&self.line)?;
        self.vertices += 1;
        Ok(self.vertices)
    }

    fn material(&mut self, colour: i64) -> io::Result<()> {
        let m = colour.clamp(0, self.palette_len - 1);
        if self.material != Some(m) {
            writeln!(self.out, "usemtl c{m}")?;
            self.material = Some(m);
        }
        Ok(())
    }

    fn cylinder(&mut self, a: V3, b: V3, r: f64) -> io::Result<()> {
        let Some(d) = direction(a, b) else {
            return Ok(());
        };
        if r <= 0.0 {
            return Ok(());
        }
        let other = if d[0].abs() < 0.9 {
            [1.0, 0.0, 0.0]
        } else {
            [0.0, 1.0, 0.0]
        };
        let e1 = cross(d, other);
        let n1 = norm(e1);
        let e1 = [e1[0] / n1, e1[1] / n1, e1[2] / n1];
        let e2 = cross(d, e1);
        // All 16 vertices first: one past the largest number is an error
        // before any of the tube is written.
        let mut ring = [[0.0; 3]; 2 * SIDES];
        for (i, end) in [a, b].into_iter().enumerate() {
            for k in 0..SIDES {
                let (s, c) = (k as f64 * std::f64::consts::TAU / SIDES as f64).sin_cos();
                ring[i * SIDES + k] = [
                    end[0] + r * (c * e1[0] + s * e2[0]),
                    end[1] + r * (c * e1[1] + s * e2[1]),
                    end[2] + r * (c * e1[2] + s * e2[2]),
                ];
            }
        }
        if !ring.iter().flatten().all(|x| x.is_finite()) {
            return Err(io::Error::other(ExtentOverflow));
        }
        let first = self.vertices + 1;
        for p in ring {
            self.v(p)?;
        }
        for k in 0..SIDES as u64 {
            let k1 = (k + 1) % SIDES as u64;
            let n = SIDES as u64;
            writeln!(
                self.out,
                "f {} {} {} {}",
                first + k,
                first + k1,
                first + n + k1,
                first + n + k
            )?;
        }
        Ok(())
    }

    pub fn finish(mut self) -> io::Result<()> {
        self.out.flush()
    }
}

impl Sink for Obj<'_> {
    fn segment(&mut self, a: V3, b: V3, width: f64, colour: i64) -> io::Result<()> {
        self.material(colour)?;
        if self.cylinders {
            return self.cylinder(a, b, width / 2.0);
        }
        if self.run.continues(a, width, colour, usize::MAX) {
            let prev = self.vertices;
            let i = self.v(b)?;
            writeln!(self.out, "l {prev} {i}")?;
        } else {
            let i = self.v(a)?;
            let j = self.v(b)?;
            writeln!(self.out, "l {i} {j}")?;
            self.run = Run {
                open: true,
                end: a,
                width,
                colour,
                points: 1,
            };
        }
        self.run.end = b;
        Ok(())
    }
    fn polygon(&mut self, points: &[V3], colour: i64) -> io::Result<()> {
        self.run.open = false;
        self.material(colour)?;
        let first = self.vertices + 1;
        for &p in points {
            self.v(p)?;
        }
        write!(self.out, "f")?;
        for k in 0..points.len() as u64 {
            write!(self.out, " {}", first + k)?;
        }
        writeln!(self.out)
    }
    fn dot(&mut self, centre: V3, _: f64, colour: i64, _: bool) -> io::Result<()> {
        self.run.open = false;
        self.material(colour)?;
        let i = self.v(centre)?;
        writeln!(self.out, "p {i}")
    }
}

/// The MTL file for an OBJ: one material `cN` per palette entry.
pub fn mtl(view: &View) -> String {
    let mut s = String::from("# lsgen-turtle\n");
    for (i, c) in view.palette.iter().enumerate() {
        s += &format!(
            "newmtl c{i}\nKd {:.4} {:.4} {:.4}\n",
            c[0] as f64 / 255.0,
            c[1] as f64 / 255.0,
            c[2] as f64 / 255.0
        );
    }
    s
}

/// The plain list: `x1 y1 z1 x2 y2 z2 width colour` per segment,
/// `polygon colour x y z x y z ...` and `dot x y z diameter colour`
/// (`sphere ...` for `@O`).
pub struct Segments<'w> {
    out: io::BufWriter<&'w mut dyn Write>,
    fmt: NumFmt,
    line: Vec<u8>,
}

impl<'w> Segments<'w> {
    pub fn new(out: &'w mut dyn Write) -> Segments<'w> {
        Segments {
            out: io::BufWriter::with_capacity(1 << 16, out),
            fmt: NumFmt::new(),
            line: Vec::with_capacity(256),
        }
    }
    pub fn finish(mut self) -> io::Result<()> {
        self.out.flush()
    }
    fn nums(&mut self, v: &[f64]) {
        for &x in v {
            self.line.push(b' ');
            put_num(&mut self.fmt, &mut self.line, x);
        }
    }
    fn emit(&mut self) -> io::Result<()> {
        self.line.push(b'\n');
        let r = self.out.write_all(&self.line);
        self.line.clear();
        r
    }
}

impl Sink for Segments<'_> {
    fn segment(&mut self, a: V3, b: V3, width: f64, colour: i64) -> io::Result<()> {
        self.line.clear();
        put_num(&mut self.fmt, &mut self.line, a[0]);
        self.nums(&[a[1], a[2], b[0], b[1], b[2], width]);
        let _ = write!(self.line, " {colour}");
        self.emit()
    }
    fn polygon(&mut self, points: &[V3], colour: i64) -> io::Result<()> {
        self.line.clear();
        let _ = write!(self.line, "polygon {colour}");
        for p in points {
            self.nums(p);
        }
        self.emit()
    }
    fn dot(&mut self, c: V3, d: f64, colour: i64, sphere: bool) -> io::Result<()> {
        self.line.clear();
        self.line
            .extend_from_slice(if sphere { b"sphere" } else { b"dot" });
        self.nums(&[c[0], c[1], c[2], d]);
        let _ = write!(self.line, " {colour}");
        self.emit()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn widths_below_a_pixel_keep_three_digits() {
        let w = |x: f64| {
            let mut v = Vec::new();
            num_width(&mut v, x);
            String::from_utf8(v).unwrap()
        };
        assert_eq!(w(376.0), "376");
        assert_eq!(w(125.0 + 1.0 / 3.0), "125.33");
        assert_eq!(w(0.752), "0.752");
        assert_eq!(w(0.0030079), "0.00301");
        assert_eq!(w(1e-10), "1e-10");
        assert_eq!(w(0.9996), "1");
        assert_eq!(w(0.0), "0");
        assert_eq!(w(-1.0), "0");
    }

    #[test]
    fn directions_neither_overflow_nor_underflow() {
        let o = [0.0; 3];
        assert_eq!(direction(o, [0.0, 1e200, 0.0]), Some([0.0, 1.0, 0.0]));
        assert_eq!(direction(o, [0.0, 0.0, -1e-320]), Some([0.0, 0.0, -1.0]));
        assert_eq!(
            direction([-1e308, 0.0, 0.0], [1e308, 0.0, 0.0]),
            Some([1.0, 0.0, 0.0])
        );
        let d = direction([1e300, 1e300, 0.0], [-1e300, -1e300, 0.0]).unwrap();
        let h = -std::f64::consts::FRAC_1_SQRT_2;
        assert!((d[0] - h).abs() < 1e-15 && (d[1] - h).abs() < 1e-15 && d[2] == 0.0);
        assert_eq!(direction([5e-324, 1.0, 2.0], [5e-324, 1.0, 2.0]), None);
    }
}
