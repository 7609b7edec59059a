//! `lsgen-turtle`: draw a module string (lsgen's output) with the 3D turtle
//! of ABOP / cpfg. The work is in `lsgen::turtle`; this parses the options.

use clap::Parser;
use lsgen::diag::{Error, IoAction, UsageError};
use lsgen::turtle::cpfg_view;
use lsgen::turtle::view::{self, View};
use lsgen::turtle::{run, Format, Options};
use std::io::Write;
use std::path::PathBuf;

/// A failed allocation is one error line and exit 1, not an abort.
#[global_allocator]
static ALLOC: lsgen::cli::ExitOnOom = lsgen::cli::ExitOnOom("lsgen-turtle");

#[derive(Parser, Debug)]
#[command(
    name = "lsgen-turtle",
    version,
    about = "Draw a module string (lsgen's output) with the 3D turtle of ABOP / cpfg: SVG, PNG, OBJ",
    after_help = "Examples:\n  lsgen examples/plant_a.ls | lsgen-turtle --ls examples/plant_a.ls -o plant_a.png\n  lsgen --functions plant.v plant.l | lsgen-turtle --cpfg-view plant.v --colormap plant.map -o plant.png"
)]
struct Args {
    /// The module string; standard input when absent or `-`
    file: Option<PathBuf>,
    /// Read the view settings (`view: NAME = VALUE` lines) of this .ls file (`-`: standard input)
    #[arg(long, value_name = "FILE")]
    ls: Option<PathBuf>,
    /// Read the view settings of this cpfg view file (.v): angle, widths, colours, tropism, view
    #[arg(long, value_name = "FILE", conflicts_with = "ls")]
    cpfg_view: Option<PathBuf>,
    /// Colours from this cpfg colour map (.map, cpfg's -m): 256 colours, index 0 the background
    #[arg(long, value_name = "FILE")]
    colormap: Option<PathBuf>,
    /// Colours from this cpfg material file (.mat, cpfg's -M): each index's diffuse colour
    #[arg(long, value_name = "FILE", conflicts_with = "colormap")]
    materials: Option<PathBuf>,
    /// Write to FILE (atomically); the format follows its extension unless -f is given
    #[arg(short, long, value_name = "FILE")]
    output: Option<PathBuf>,
    /// Output format: svg, png, obj or segments (default svg, or -o's extension)
    #[arg(short, long, value_name = "FORMAT")]
    format: Option<String>,
    /// Default turning angle in degrees
    #[arg(long, allow_hyphen_values = true, value_parser = number)]
    angle: Option<f64>,
    /// Default step length of F f G g
    #[arg(long, allow_hyphen_values = true, value_parser = number)]
    step: Option<f64>,
    /// Initial line width
    #[arg(long, allow_hyphen_values = true, value_parser = number)]
    width: Option<f64>,
    /// Width change of ! and # without a parameter
    #[arg(long, allow_hyphen_values = true, value_parser = number)]
    width_increment: Option<f64>,
    /// Factor applied to every width when drawn
    #[arg(long, allow_hyphen_values = true, value_parser = number)]
    width_scale: Option<f64>,
    /// What widths are in: model (units of the drawing) or pixels (SVG, PNG)
    #[arg(long, value_name = "UNIT")]
    width_unit: Option<String>,
    /// Colour index change of ' ; , without a parameter
    #[arg(long, allow_hyphen_values = true, value_parser = number)]
    colour_increment: Option<f64>,
    /// Tropism vector "X Y Z"
    #[arg(long, value_name = "X Y Z", allow_hyphen_values = true)]
    tropism: Option<String>,
    /// Elasticity (bending by tropism after each F and G)
    #[arg(long, allow_hyphen_values = true, value_parser = number)]
    elasticity: Option<f64>,
    /// Elasticity change of _ without a parameter
    #[arg(long, allow_hyphen_values = true, value_parser = number)]
    elasticity_increment: Option<f64>,
    /// How tropism bends: abop (about H × T, after F G) or cpfg (cpfg's bend, after F G f g)
    #[arg(long, value_name = "MODEL")]
    tropism_model: Option<String>,
    /// Colours of indices 0, 1, ...: "#rrggbb #rrggbb ..."
    #[arg(long)]
    palette: Option<String>,
    /// Projection: front, side, top, or "AZIMUTH ELEVATION" in degrees
    #[arg(long, value_name = "DIRECTION", allow_hyphen_values = true)]
    view: Option<String>,
    /// Turn the picture on the screen, degrees counter-clockwise
    #[arg(long, allow_hyphen_values = true, value_parser = number)]
    twist: Option<f64>,
    /// Longer side of the picture in pixels (SVG and PNG)
    #[arg(long, default_value_t = 800, value_parser = clap::value_parser!(u32).range(16..=8192))]
    size: u32,
    /// Background colour "#rrggbb" or "none"
    #[arg(long)]
    background: Option<String>,
    /// OBJ: segments as cylinders of the turtle's width
    #[arg(long)]
    cylinders: bool,
}

/// A number option: as f64, but digits past the largest number
/// (`--angle 1e400`) are out of range, not the `inf` they would become.
/// The options take hyphen values: clap's own test for a negative number
/// refuses `-1e-5` and `-.5` ("unexpected argument '-1' found").
fn number(s: &str) -> Result<f64, String> {
    // As a `view:` number (`inf` and `nan` are none), a leading `+` aside;
    // refused here, so the error quotes the word as given (a NaN passed
    // on would be quoted as `NaN`).
    let plain = s
        .strip_prefix('+')
        .filter(|r| r.starts_with(|c: char| c.is_ascii_digit() || c == '.'))
        .unwrap_or(s);
    view::number_word(plain).map_err(|e| e.to_string())
}

fn options(a: Args) -> Result<Options, Error> {
    let mut v = View::default();
    use lsgen::output::reads_stdin;
    if a.file.as_deref().is_none_or(reads_stdin) {
        // The string is read from standard input: no other input may be
        // (a `.v` file's `#include "/dev/stdin"` is refused where it is).
        lsgen::output::note_stdin_taken();
        for (option, path) in [
            ("--ls", &a.ls),
            ("--cpfg-view", &a.cpfg_view),
            ("--colormap", &a.colormap),
            ("--materials", &a.materials),
        ] {
            if path.as_deref().is_some_and(reads_stdin) {
                return Err(Error::new(UsageError::ViewAndStringFromStdin(option)));
            }
        }
    }
    if a.ls.as_ref().is_some_and(|p| p.as_os_str() == "-") {
        // `--ls -`: the view lines from standard input, as lsgen reads
        // `-`; the string then comes from a file.
        lsgen::output::check_stdin_open()?;
        view::read_ls("<stdin>", Box::new(std::io::stdin()), &mut v)?;
    } else if let Some(ls) = &a.ls {
        let name = ls.display().to_string();
        // `--ls /dev/stdin` with standard input closed (`<&-`).
        lsgen::output::check_input_open(ls, &name)?;
        let f = std::fs::File::open(ls).map_err(|e| Error::io(name.clone(), IoAction::Open, e))?;
        if f.metadata().is_ok_and(|m| m.is_dir()) {
            let e = std::io::Error::from(std::io::ErrorKind::IsADirectory);
            return Err(Error::io(name, IoAction::Read, e));
        }
        // lsgen's header reader and lexer: bounded, and the same view lines.
        view::read_ls(&name, Box::new(f), &mut v)?;
    }
    if let Some(p) = &a.cpfg_view {
        let name = p.display().to_string();
        lsgen::output::check_input_open(p, &name)?;
        for w in cpfg_view::read_view(p, &mut v)? {
            lsgen::diag::eprint(&format!("lsgen-turtle: {w}"));
        }
    }
    if let Some(p) = &a.colormap {
        cpfg_view::read_colormap(p, &mut v)?;
    }
    if let Some(p) = &a.materials {
        cpfg_view::read_materials(p, &mut v)?;
    }
    let set = |v: &mut View, name: &str, value: &str| -> Result<(), Error> {
        let text = format!(" {name} = {value}");
        let s = view::parse_setting(&text).map_err(|e| {
            // The direction is given as `--view`.
            let option = match name {
                "direction" => "view".to_string(),
                _ => name.replace(' ', "-"),
            };
            Error::new(UsageError::ViewOption {
                option,
                error: e.kind,
            })
        })?;
        v.apply(s);
        Ok(())
    };
    let num = |x: Option<f64>| x.map(|x| x.to_string());
    for (name, value) in [
        ("angle", num(a.angle)),
        ("step", num(a.step)),
        ("width", num(a.width)),
        ("width increment", num(a.width_increment)),
        ("width scale", num(a.width_scale)),
        ("width unit", a.width_unit.clone()),
        ("colour increment", num(a.colour_increment)),
        ("tropism", a.tropism.clone()),
        ("elasticity", num(a.elasticity)),
        ("elasticity increment", num(a.elasticity_increment)),
        ("tropism model", a.tropism_model.clone()),
        ("palette", a.palette.clone()),
        ("direction", a.view.as_ref().map(|s| s.replace(',', " "))),
        ("twist", num(a.twist)),
        ("background", a.background.clone()),
    ] {
        if let Some(value) = value {
            set(&mut v, name, &value)?;
        }
    }
    let format = match (&a.format, &a.output) {
        (Some(f), _) => {
            Format::parse(f).ok_or_else(|| Error::new(UsageError::UnknownFormat(f.clone())))?
        }
        // (An extension that is not UTF-8 is no format's either: a usage
        // error, not SVG.)
        // A dotfile's name is its extension: `-o .obj` is OBJ (Rust's rule
        // gives `.obj` none, which made it an SVG).
        (None, Some(p)) => match p.extension().or_else(|| {
            let name = p.file_name()?.to_str()?;
            Some(std::ffi::OsStr::new(name.strip_prefix('.')?)).filter(|e| !e.is_empty())
        }) {
            Some(e) => e
                .to_str()
                .and_then(Format::parse)
                .ok_or_else(|| Error::new(UsageError::FormatFromName(p.clone())))?,
            None => Format::Svg,
        },
        (None, None) => Format::Svg,
    };
    Ok(Options {
        input: a.file,
        output: a.output,
        format,
        view: v,
        size: a.size,
        cylinders: a.cylinders,
    })
}

fn main() {
    // Shared with lsgen: a write past `ulimit -f` is an error (EFBIG).
    lsgen::cli::ignore_sigxfsz();
    std::panic::set_hook(Box::new(|info| {
        let at = info
            .location()
            .map(|l| format!(" at {}:{}", l.file(), l.line()))
            .unwrap_or_default();
        let _ = writeln!(
            std::io::stderr(),
            "lsgen-turtle: internal error{at} (please report this)"
        );
    }));
    let code = match Args::try_parse() {
        Err(e) => match e.kind() {
            clap::error::ErrorKind::DisplayHelp | clap::error::ErrorKind::DisplayVersion => {
                match lsgen::cli::print_help_or_version(&e) {
                    Ok(()) => 0,
                    Err(e) => lsgen::cli::report("lsgen-turtle", &e),
                }
            }
            _ => {
                let _ = write!(std::io::stderr(), "lsgen-turtle: {}", e.render());
                2
            }
        },
        Ok(a) => match options(a).and_then(|o| run(&o)) {
            Ok(()) => 0,
            Err(e) => lsgen::cli::report("lsgen-turtle", &e),
        },
    };
    std::process::exit(code);
}

/// Runs before Rust's runtime, which quietly gives closed standard
/// descriptors /dev/null: as lsgen, lsgen-turtle must know that standard
/// output was closed (`>&-`) and fail instead of losing the output.
#[used]
#[link_section = ".init_array"]
static NOTE_CLOSED_STANDARD_FDS: extern "C" fn() = {
    extern "C" fn note() {
        lsgen::output::note_closed_standard_fds();
    }
    note
};
