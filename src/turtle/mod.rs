//! `lsgen-turtle`: draw a module string with the 3D turtle of ABOP / cpfg,
//! as SVG, PNG, OBJ (+ MTL) or a plain segment list.
//!
//! [`reader`] streams modules from the input; [`state`] is the turtle;
//! [`view`] holds the view settings (`view:` lines of an `.ls` file);
//! [`render`] turns what the turtle draws into the output formats. Memory
//! is the branch stack and the open polygons' vertices, never the string: SVG
//! and PNG need the bounding box first, so the input is read twice (a file
//! from its start again, through the descriptor already open; any other
//! input is spooled to an unnamed temp file).

pub mod cpfg_view;
pub mod movements;
pub mod reader;
pub mod render;
pub mod state;
pub mod view;

use crate::diag::{Error, TurtleError};
use reader::Reader;
use state::{Fault, ModErr, Sink, Turtle};
use std::io::Read;
use view::View;

/// Drive the turtle over a whole module string, sending geometry to `sink`.
pub fn interpret<R: Read>(
    input: R,
    name: &str,
    out_name: &str,
    view: &View,
    sink: &mut dyn Sink,
) -> Result<(), Error> {
    let mut r = Reader::new(input, name);
    let mut t = Turtle::new(view);
    // Where the outermost open polygon began.
    let mut polygon_at = reader::Spot::default();
    // Where the last module began: a letter that joins the bare `@`
    // before it (`@o`) is one module with it, whose errors point at the
    // `@`.
    let mut last_start = reader::Spot::default();
    loop {
        let Some(sym) = r.next_module()? else {
            if t.open_polygons() > 0 {
                return Err(r.error_at(polygon_at, TurtleError::PolygonNotClosed));
            }
            return Ok(());
        };
        if sym == '{' && t.open_polygons() == 0 {
            polygon_at = r.last;
            // Reported at the end of the input if it stays open.
            r.keep(polygon_at);
        }
        let n = r.nparams;
        let params = r.params;
        if t.joins_at(sym) {
            r.last = last_start;
        }
        last_start = r.last;
        match t.module(sym, &params[..n], sink) {
            Ok(()) => {}
            Err(ModErr::Io(e)) => {
                if e.get_ref()
                    .is_some_and(|x| x.is::<render::ExtentOverflow>())
                {
                    return Err(r.error_at(r.last, TurtleError::ExtentOverflow));
                }
                return Err(Error::io(out_name, crate::diag::IoAction::Write, e));
            }
            Err(ModErr::Fault(Fault::UnmatchedClose(c))) => {
                return Err(r.error_at(r.last, TurtleError::UnmatchedClose(c)));
            }
            Err(ModErr::Fault(Fault::Overflow)) => {
                return Err(r.error_at(r.last, TurtleError::Overflow))
            }
            Err(ModErr::Fault(Fault::TropismOverflow)) => {
                return Err(r.error_at(r.last, TurtleError::TropismOverflow))
            }
            Err(ModErr::Fault(Fault::BendPastRightAngle)) => {
                return Err(r.error_at(r.last, TurtleError::BendPastRightAngle))
            }
            Err(ModErr::Fault(Fault::WidthOverflow)) => {
                return Err(r.error_at(r.last, TurtleError::WidthOverflow))
            }
            Err(ModErr::Fault(Fault::PolygonTooLarge)) => {
                return Err(r.error_at(r.last, TurtleError::PolygonTooLarge(state::MAX_VERTICES)))
            }
            Err(ModErr::Fault(Fault::MovementOverflow)) => {
                return Err(r.error_at(r.last, TurtleError::MovementOverflow))
            }
            Err(ModErr::Fault(Fault::TooDeep)) => {
                return Err(r.error_at(r.last, TurtleError::TooDeep))
            }
        }
    }
}

/// Output formats.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Format {
    Svg,
    Png,
    Obj,
    Segments,
}

impl Format {
    pub fn parse(s: &str) -> Option<Format> {
        match s.to_ascii_lowercase().as_str() {
            "svg" => Some(Format::Svg),
            "png" => Some(Format::Png),
            "obj" => Some(Format::Obj),
            "segments" | "txt" => Some(Format::Segments),
            _ => None,
        }
    }
}

/// What to draw and where; the binary fills it from its options.
pub struct Options {
    /// The module string; `None` or `-` for standard input.
    pub input: Option<std::path::PathBuf>,
    pub output: Option<std::path::PathBuf>,
    pub format: Format,
    pub view: View,
    pub size: u32,
    pub cylinders: bool,
}

/// The input, once or twice: a regular file is read again from its
/// start through a second handle of the descriptor already open (never
/// reopened by name: a file replaced in between, as `lsgen -o` replaces
/// one, would give a picture of the new file laid out for the old);
/// anything else (standard input, a FIFO, `<(...)`, a device) is read
/// once and spooled to an unnamed temp file.
enum Source {
    File(std::fs::File),
    Stream,
}

fn open_file(p: &std::path::Path, name: &str) -> Result<std::fs::File, Error> {
    // `/dev/stdin` with standard input closed (`<&-`): lsgen's error.
    crate::output::check_input_open(p, name)?;
    let f = std::fs::File::open(p).map_err(|e| Error::io(name, crate::diag::IoAction::Open, e))?;
    if f.metadata().map(|m| m.is_dir()).unwrap_or(false) {
        return Err(Error::io(
            name,
            crate::diag::IoAction::Read,
            std::io::Error::from(std::io::ErrorKind::IsADirectory),
        ));
    }
    Ok(f)
}

/// Copies what it reads into a spool file (standard input, read twice).
struct Tee<R: Read> {
    inner: R,
    spool: std::fs::File,
    error: Option<std::io::Error>,
}

impl<R: Read> Read for Tee<R> {
    fn read(&mut self, buf: &mut [u8]) -> std::io::Result<usize> {
        use std::io::Write;
        let n = self.inner.read(buf)?;
        if let Err(e) = self.spool.write_all(&buf[..n]) {
            // Stop reading with an error (not an early end of input, which
            // would be reported as a malformed string); [`run`] reports
            // the spool's own error, kept here.
            self.error = Some(e);
            return Err(std::io::Error::other("spool write failed"));
        }
        Ok(n)
    }
}

/// The second pass over a regular file: exactly the bytes the first pass
/// read. A file grown meanwhile (appended to in place) is drawn as the
/// first pass saw it, so an error in what was added cannot reach the
/// second pass, after SVG has begun on standard output; a file cut
/// shorter is an error, not a picture with part of the string missing.
struct Again<R: Read> {
    inner: std::io::Take<R>,
}

impl<R: Read> Again<R> {
    fn new(inner: R, len: u64) -> Self {
        Again {
            inner: inner.take(len),
        }
    }
}

impl<R: Read> Read for Again<R> {
    fn read(&mut self, buf: &mut [u8]) -> std::io::Result<usize> {
        let n = self.inner.read(buf)?;
        if n == 0 && !buf.is_empty() && self.inner.limit() > 0 {
            return Err(std::io::Error::new(
                std::io::ErrorKind::UnexpectedEof,
                "the file became shorter while it was drawn (read twice: bounding box, then drawing)",
            ));
        }
        Ok(n)
    }
}

/// Run `lsgen-turtle`.
pub fn run(o: &Options) -> Result<(), Error> {
    use crate::output::Output;
    use std::io::Seek;
    // Open the input first: a missing input must not create the output.
    let (src, in_name, first): (Source, String, Box<dyn Read>) = match &o.input {
        Some(p) if p.as_os_str() != "-" => {
            let name = p.display().to_string();
            let f = open_file(p, &name)?;
            if f.metadata().is_ok_and(|m| m.is_file()) {
                let again = f
                    .try_clone()
                    .map_err(|e| Error::io(name.clone(), crate::diag::IoAction::Open, e))?;
                (Source::File(again), name, Box::new(f))
            } else {
                // Reading it again would find it empty (or block).
                (Source::Stream, name, Box::new(f))
            }
        }
        _ => {
            // Closed (`<&-`), it would read as empty: lsgen's error.
            crate::output::check_stdin_open()?;
            (
                Source::Stream,
                "<stdin>".to_string(),
                Box::new(std::io::stdin()),
            )
        }
    };
    let mut out = match &o.output {
        Some(p) => Output::file(p)?,
        None => Output::stdout()?,
    };
    let out_name = out.name();
    let file_path = out.file_path().map(|p| p.to_path_buf());
    let werr = |e: std::io::Error| Error::io(out_name.clone(), crate::diag::IoAction::Write, e);
    match o.format {
        Format::Segments | Format::Obj => {
            let mut mtl_out = None;
            {
                let w = out.writer();
                if o.format == Format::Segments {
                    let mut s = render::Segments::new(w);
                    interpret(first, &in_name, &out_name, &o.view, &mut s)?;
                    s.finish().map_err(werr)?;
                } else {
                    // Materials only beside a regular file (the link's
                    // target, named after it); a stream gets none.
                    // (`-f obj -o x.mtl` would overwrite itself: no MTL.)
                    let mtl_path = file_path
                        .as_ref()
                        .map(|p| p.with_extension("mtl"))
                        .filter(|m| Some(m) != file_path.as_ref());
                    // The name's bytes as they are (an OBJ reader opens
                    // that file).
                    let lib = mtl_path
                        .as_ref()
                        .and_then(|p| p.file_name())
                        .map(std::os::unix::ffi::OsStrExt::as_bytes);
                    // `mtllib` takes names separated by blanks: one with
                    // blanks (or a line break) would not be found.
                    if let Some(n) = lib
                        .map(String::from_utf8_lossy)
                        .filter(|n| n.contains(char::is_whitespace))
                    {
                        return Err(Error::new(crate::diag::UsageError::MtlNameWithBlanks(
                            n.into_owned(),
                        )));
                    }
                    // Not a name the user gave: a FIFO there would block the
                    // run at its end, and a directory be named as `-o`'s.
                    if let Some(m) = mtl_path
                        .as_ref()
                        .filter(|m| std::fs::metadata(m).is_ok_and(|md| !md.is_file()))
                    {
                        return Err(Error::new(crate::diag::UsageError::MtlNotAFile(m.clone())));
                    }
                    let mut s = render::Obj::begin(w, &o.view, lib, o.cylinders).map_err(werr)?;
                    interpret(first, &in_name, &out_name, &o.view, &mut s)?;
                    s.finish().map_err(werr)?;
                    if let Some(mp) = mtl_path {
                        let mut m = Output::file(&mp)?;
                        let mname = m.name();
                        m.writer()
                            .write_all(render::mtl(&o.view).as_bytes())
                            .map_err(|e| Error::io(mname, crate::diag::IoAction::Write, e))?;
                        mtl_out = Some(m);
                    }
                }
            }
            // The pair is put in place under one hold of termination
            // signals: between the two renames a Ctrl-C would leave a new
            // MTL beside the old OBJ.
            crate::io::output::with_signals_held(|| {
                if let Some(m) = mtl_out {
                    m.commit()?;
                }
                out.commit()
            })
        }
        Format::Svg | Format::Png => {
            let proj = render::Projection::new(o.view.direction, o.view.twist);
            let mut bbox = render::BBox::new(proj, o.view.width_unit);
            // Pass 1: the bounding box (a stream is spooled meanwhile).
            let second: Box<dyn Read> = match src {
                Source::File(mut f) => {
                    interpret(first, &in_name, &out_name, &o.view, &mut bbox)?;
                    // (`f` shares the offset pass 1 read up to: its end
                    // of file then.)
                    let seen = f
                        .stream_position()
                        .and_then(|n| f.rewind().map(|()| n))
                        .map_err(|e| Error::io(in_name.clone(), crate::diag::IoAction::Read, e))?;
                    Box::new(Again::new(f, seen))
                }
                Source::Stream => {
                    let spool = tempfile::tempfile()
                        .map_err(|e| crate::derive::tempfile_error(&None, e))?;
                    let mut tee = Tee {
                        inner: first,
                        spool,
                        error: None,
                    };
                    let r = interpret(&mut tee, &in_name, &out_name, &o.view, &mut bbox);
                    if let Some(e) = tee.error {
                        return Err(Error::io("temporary file", crate::diag::IoAction::Write, e));
                    }
                    r?;
                    let mut spool = tee.spool;
                    spool
                        .rewind()
                        .map_err(|e| Error::io("temporary file", crate::diag::IoAction::Read, e))?;
                    Box::new(std::io::BufReader::with_capacity(1 << 16, spool))
                }
            };
            let layout = render::Layout::new(&bbox, o.size, o.view.width_unit);
            {
                let w = out.writer();
                if o.format == Format::Svg {
                    let mut s = render::Svg::begin(w, layout, &o.view).map_err(werr)?;
                    interpret(second, &in_name, &out_name, &o.view, &mut s)?;
                    s.finish().map_err(werr)?;
                } else {
                    let mut s = render::Png::new(layout, &o.view).map_err(werr)?;
                    interpret(second, &in_name, &out_name, &o.view, &mut s)?;
                    s.finish(w).map_err(werr)?;
                }
            }
            out.commit()
        }
    }
}

#[cfg(test)]
mod tests {
    use super::Again;
    use std::io::Read;

    #[test]
    fn the_second_pass_reads_what_the_first_read() {
        // Grown since: the bytes added are not read.
        let mut s = String::new();
        Again::new(&b"F+F]"[..], 3).read_to_string(&mut s).unwrap();
        assert_eq!(s, "F+F");
        // Cut shorter: an error, not a shorter string.
        let e = Again::new(&b"F+"[..], 3)
            .read_to_string(&mut s)
            .unwrap_err();
        assert_eq!(e.kind(), std::io::ErrorKind::UnexpectedEof);
        assert!(e.to_string().contains("became shorter"), "{e}");
        // The same length: as it is.
        let mut v = Vec::new();
        Again::new(&b"F+F"[..], 3).read_to_end(&mut v).unwrap();
        assert_eq!(v, b"F+F");
    }
}
