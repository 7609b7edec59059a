//! Command line: parse arguments, load the L-system, derive, write.

use crate::axiom::AxiomReader;
use crate::diag::{Error, Kind};
use crate::engine::{Deriver, Limits, Origin, Out, Pass};
use crate::input::{split_header, Input};
use crate::output::Output;
use crate::parse::{locate, parse_header};
use crate::random::Random;
use crate::rules::{compile_with, Seeds, System};
use clap::Parser;
use std::fs::File;
use std::io::{self, Seek, SeekFrom, Write};
use std::path::PathBuf;

/// Most derivation steps accepted (as for `derivation length:`).
pub const MAX_STEPS: u64 = 1 << 53;

/// Derivation length when neither the file nor `-n` gives one.
pub const DEFAULT_DERIVATION_LENGTH: u64 = 1;

#[derive(Parser, Debug)]
#[command(
    name = "lsgen",
    version,
    about = "Derive an L-system and print the resulting string",
    long_about = "Reads an L-system (.ls) file, derives N generations and writes the final \
                  string on one line. The axiom is read as a stream and generations live in \
                  temporary files, so strings may be far larger than memory."
)]
pub struct Args {
    /// The .ls file; standard input when absent or `-`.
    pub file: Option<PathBuf>,

    /// Write the string to FILE (`-`: standard output); a regular file is
    /// put in place only when complete, through symbolic links.
    #[arg(short, long, value_name = "FILE")]
    pub output: Option<PathBuf>,

    /// Number of derivation steps (overrides `derivation length:`).
    #[arg(short = 'n', long, value_name = "N",
          value_parser = clap::value_parser!(u64).range(..=MAX_STEPS))]
    pub derivation_length: Option<u64>,

    /// Seed of the random generator (overrides `seed:`).
    #[arg(long, value_name = "S")]
    pub seed: Option<u64>,

    /// Do not apply the homomorphism productions.
    #[arg(long)]
    pub no_homomorphism: bool,

    /// Parse and check the file, derive nothing.
    #[arg(long)]
    pub check: bool,

    /// Read the axiom from FILE (`-` for standard input) instead of the
    /// file's `axiom:` section; it holds modules only, no comments.
    #[arg(long, value_name = "FILE")]
    pub axiom: Option<PathBuf>,

    /// Stop with an error when a generation exceeds N modules, or N bytes
    /// with a suffix: 500M (modules), 2GB, 512MiB, 10kB.
    #[arg(long, value_name = "N", value_parser = parse_limit)]
    pub max_length: Option<Limits>,

    /// Directory for the temporary generation files (default: $TMPDIR).
    #[arg(long, value_name = "DIR")]
    pub tmpdir: Option<PathBuf>,

    /// Report the seed and each generation's length on standard error.
    #[arg(short, long)]
    pub verbose: bool,

    /// For tests: force the derivation strategy (`dfs` fails with exit
    /// status 2 when the system cannot be expanded depth first).
    #[arg(long, hide = true, value_enum, default_value_t = Strategy::Auto)]
    pub strategy: Strategy,
}

/// How to derive: `--strategy` (hidden, for tests).
#[derive(clap::ValueEnum, Clone, Copy, Debug, PartialEq, Eq)]
pub enum Strategy {
    /// Depth first when the system allows it, else step by step.
    Auto,
    /// Always step by step, through temporary files.
    Step,
    /// Depth first, or a usage error.
    Dfs,
}

/// `--max-length`: a module count (`1000000`, `5M`, `2G`) or a byte size
/// (`10kB`, `512MiB`, `2GB`, `1TB`).
pub fn parse_limit(s: &str) -> Result<Limits, String> {
    let t = s.trim();
    let split = t
        .find(|c: char| !c.is_ascii_digit() && c != '_')
        .unwrap_or(t.len());
    let (num, unit) = t.split_at(split);
    let n: u64 = num
        .replace('_', "")
        .parse()
        .map_err(|_| format!("`{s}` is not a length: use e.g. 1000000, 5M, 2GB, 512MiB"))?;
    let mul = |m: u64| {
        n.checked_mul(m)
            .ok_or_else(|| format!("`{s}` is too large"))
    };
    let mut l = Limits::default();
    match unit {
        "" => l.modules = n,
        "k" | "K" => l.modules = mul(1_000)?,
        "M" => l.modules = mul(1_000_000)?,
        "G" => l.modules = mul(1_000_000_000)?,
        "B" => l.bytes = n,
        "kB" | "KB" => l.bytes = mul(1_000)?,
        "MB" => l.bytes = mul(1_000_000)?,
        "GB" => l.bytes = mul(1_000_000_000)?,
        "TB" => l.bytes = mul(1_000_000_000_000)?,
        "KiB" => l.bytes = mul(1 << 10)?,
        "MiB" => l.bytes = mul(1 << 20)?,
        "GiB" => l.bytes = mul(1 << 30)?,
        "TiB" => l.bytes = mul(1 << 40)?,
        _ => {
            return Err(format!(
                "unknown unit `{unit}`: modules take k, M, G; bytes take B, kB, MB, GB, TB, KiB, MiB, GiB, TiB"
            ))
        }
    }
    Ok(l)
}

/// Parse the command line and run on a thread with a large stack (the
/// parser and compiler recurse on nested expressions); returns the exit
/// status. A bug shows as one line, not a backtrace.
pub fn main_exit_code() -> i32 {
    // Past `ulimit -f`, a write fails with EFBIG (reported) instead of
    // killing the process.
    // SAFETY: setting a signal's disposition to SIG_IGN.
    unsafe { libc::signal(libc::SIGXFSZ, libc::SIG_IGN) };
    install_panic_hook();
    let worker = std::thread::Builder::new()
        .name("lsgen".into())
        .stack_size(256 << 20)
        .spawn(main_on_thread);
    crate::output::leave_termination_signals_to_other_threads();
    worker.ok().and_then(|t| t.join().ok()).unwrap_or(70)
}

/// Report a panic (a bug) as one line on standard error, never panicking
/// again, also when standard error cannot be written.
pub fn install_panic_hook() {
    std::panic::set_hook(Box::new(|info| {
        let msg = info
            .payload()
            .downcast_ref::<&str>()
            .map(|s| s.to_string())
            .or_else(|| info.payload().downcast_ref::<String>().cloned())
            .unwrap_or_default();
        let at = info
            .location()
            .map(|l| format!(" at {}:{}", l.file(), l.line()))
            .unwrap_or_default();
        // Never eprintln! here: a panic in the hook aborts.
        crate::diag::eprint(&format!(
            "lsgen: internal error: {msg}{at} (please report this)\n"
        ));
    }));
}

fn main_on_thread() -> i32 {
    let args = match Args::try_parse() {
        Ok(a) => a,
        Err(e) => {
            return match e.kind() {
                clap::error::ErrorKind::DisplayHelp | clap::error::ErrorKind::DisplayVersion => {
                    // A failed write (`--version > /dev/full`, stdout closed)
                    // is an error; a closed pipe is not.
                    let printed = crate::output::check_stdout_open().and_then(|()| {
                        e.print()
                            .and_then(|()| io::stdout().flush())
                            .map_err(|e| Error::io("standard output", "cannot write", e))
                    });
                    match printed {
                        Ok(()) => 0,
                        Err(e) => {
                            if e.kind != Kind::BrokenPipe {
                                crate::diag::eprint(&e.to_string());
                            }
                            e.exit_code()
                        }
                    }
                }
                _ => {
                    // Usage errors read like every other error: `lsgen: error: ...`.
                    let _ = write!(io::stderr(), "lsgen: {}", e.render());
                    2
                }
            };
        }
    };
    match run(&args) {
        Ok(()) => 0,
        Err(e) => {
            if e.kind != Kind::BrokenPipe {
                crate::diag::eprint(&e.to_string());
            }
            e.exit_code()
        }
    }
}

fn open_input(path: Option<&PathBuf>) -> Result<Input, Error> {
    match path {
        None => Ok(Input::new(Box::new(io::stdin()), "<stdin>")),
        Some(p) if p.as_os_str() == "-" => Ok(Input::new(Box::new(io::stdin()), "<stdin>")),
        Some(p) => {
            let name = p.display().to_string();
            let f = File::open(p).map_err(|e| Error::io(name.clone(), "cannot open", e))?;
            if f.metadata().map(|m| m.is_dir()).unwrap_or(false) {
                return Err(Error::io(
                    name,
                    "cannot read",
                    io::Error::from(io::ErrorKind::IsADirectory),
                ));
            }
            Ok(Input::new(Box::new(f), name))
        }
    }
}

pub fn run(args: &Args) -> Result<(), Error> {
    let file_is_stdin = args.file.as_ref().is_none_or(|p| p.as_os_str() == "-");
    let axiom_is_stdin = args.axiom.as_ref().is_some_and(|p| p.as_os_str() == "-");
    if file_is_stdin && axiom_is_stdin {
        return Err(Error::usage(
            "the L-system and `--axiom -` cannot both come from standard input",
        ));
    }
    let mut input = open_input(args.file.as_ref())?;
    let fresh = Random::fresh_seed();
    let seeds = Seeds {
        command_line: args.seed,
        fallback: fresh,
    };
    let (split, path, system) = load(&mut input, seeds)?;
    if !split.has_axiom && args.axiom.is_none() {
        return Err(missing_axiom(&path, &split.header));
    }
    if args.check {
        // Read the axiom too, so its errors are reported.
        let mut al = system.alphabet;
        let mut reader = axiom_reader(args, input, &split, &system.consts)?;
        let mut p = Vec::new();
        let mut rng = Random::new(0);
        loop {
            reader.plain_run(|_| {})?;
            if reader.next(&mut al, &mut p, &mut rng)?.is_none() {
                break;
            }
        }
        if args.verbose {
            crate::diag::eprint(&format!(
                "lsgen: {path}: ok: {} productions, {} homomorphism productions\n",
                system.productions.prods.len(),
                system.homomorphism.prods.len()
            ));
        }
        return Ok(());
    }
    let steps = args
        .derivation_length
        .or(system.derivation_length)
        .unwrap_or(DEFAULT_DERIVATION_LENGTH);
    let seed = args.seed.or(system.seed).unwrap_or(fresh);
    if args.verbose {
        crate::diag::eprint(&format!("lsgen: seed {seed}\n"));
    }
    let mut output = match &args.output {
        Some(p) => Output::file(p)?,
        None => Output::stdout()?,
    };
    let mut system = system;
    let consts = std::mem::take(&mut system.consts);
    let reader = axiom_reader(args, input, &split, &consts)?;
    let out_name = output.name();
    let settings = Settings {
        steps,
        seed,
        homomorphism: !args.no_homomorphism,
        limits: args.max_length.unwrap_or_default(),
        tmpdir: args.tmpdir.clone(),
        verbose: args.verbose,
        strategy: args.strategy,
    };
    derive(
        &settings,
        reader,
        &split.header,
        &path,
        system,
        output.writer(),
        &out_name,
    )?;
    output.commit()
}

/// How to derive, once the file is loaded.
pub struct Settings {
    pub steps: u64,
    pub seed: u64,
    pub homomorphism: bool,
    pub limits: Limits,
    pub tmpdir: Option<PathBuf>,
    pub verbose: bool,
    pub strategy: Strategy,
}

/// Load an L-system from `src` and derive it in full into a byte vector
/// (temp files are still used between steps): for tests and fuzzing.
/// `steps`/`seed` override the file's settings.
pub fn derive_bytes(
    src: &[u8],
    steps: Option<u64>,
    seed: Option<u64>,
    limits: Limits,
) -> Result<Vec<u8>, Error> {
    let mut input = Input::new(Box::new(io::Cursor::new(src.to_vec())), "<input>");
    let seeds = Seeds {
        command_line: seed,
        fallback: 0,
    };
    let (split, path, system) = load(&mut input, seeds)?;
    if !split.has_axiom {
        return Err(missing_axiom(&path, &split.header));
    }
    let settings = Settings {
        steps: steps
            .or(system.derivation_length)
            .unwrap_or(DEFAULT_DERIVATION_LENGTH),
        seed: seed.or(system.seed).unwrap_or(0),
        homomorphism: true,
        limits,
        tmpdir: None,
        verbose: false,
        strategy: Strategy::Auto,
    };
    let mut system = system;
    let consts = std::mem::take(&mut system.consts);
    let reader = AxiomReader::new(input, true, split.axiom_line, split.axiom_col, &consts);
    let mut out = Vec::new();
    derive(
        &settings,
        reader,
        &split.header,
        &path,
        system,
        &mut out,
        "output",
    )?;
    Ok(out)
}

/// Read the header from `input` (leaving it at the axiom), parse and
/// compile it. Returns the split, the input's name and the system.
fn load(input: &mut Input, seeds: Seeds) -> Result<(crate::input::Split, String, System), Error> {
    let split = split_header(input)?;
    let path = input.name.clone();
    let header = parse_header(&split.header).map_err(|e| locate(&path, &split.header, e))?;
    let system = compile_with(header, Some(&split.header), seeds)
        .map_err(|e| locate(&path, &split.header, e))?;
    Ok((split, path, system))
}

fn missing_axiom(path: &str, header: &str) -> Error {
    let end = header.trim_end().len();
    let mut e = locate(
        path,
        header,
        crate::parse::UserError::new(
            (end, end),
            "missing `axiom:`: the axiom comes last, after the productions",
        ),
    );
    if header.trim().is_empty() {
        e.message = "empty L-system: no `axiom:` found".into();
    }
    e
}

/// The axiom: the file's `axiom:` section (comments allowed), or the
/// `--axiom` stream (plain module text).
fn axiom_reader<'c>(
    args: &Args,
    input: Input,
    split: &crate::input::Split,
    consts: &'c std::collections::HashMap<String, f64>,
) -> Result<AxiomReader<'c>, Error> {
    Ok(match &args.axiom {
        Some(p) => AxiomReader::new(open_input(Some(p))?, false, 1, 1, consts),
        None => AxiomReader::new(input, true, split.axiom_line, split.axiom_col, consts),
    })
}

fn tempfile(dir: &Option<PathBuf>) -> Result<File, Error> {
    let r = match dir {
        Some(d) => tempfile::tempfile_in(d),
        None => tempfile::tempfile(),
    };
    r.map_err(|e| {
        Error::io(
            dir.as_ref().map_or_else(
                || std::env::temp_dir().display().to_string(),
                |d| d.display().to_string(),
            ),
            "cannot create a temporary file",
            e,
        )
    })
}

/// The sink for a generation: the temp file `dst` (binary, with a bracket
/// index if asked) or, without one, the output (text).
fn sink<'a>(
    dst: &'a mut Option<File>,
    tmp_name: &'a str,
    output: &'a mut dyn Write,
    out_name: &'a str,
    limits: Limits,
    indexed: bool,
) -> Result<Out<'a>, Error> {
    Ok(match dst {
        Some(f) => {
            let index = if indexed {
                Some(
                    f.try_clone()
                        .map_err(|e| Error::io(tmp_name, "cannot write", e))?,
                )
            } else {
                None
            };
            let out = Out::new(f, tmp_name, false, limits);
            match index {
                Some(i) => out.with_index(i),
                None => out,
            }
        }
        None => Out::new(output, out_name, true, limits),
    })
}

fn rewind(f: &mut File) -> Result<(), Error> {
    f.set_len(0)
        .and_then(|_| f.seek(SeekFrom::Start(0)).map(|_| ()))
        .map_err(|e| Error::io("temporary file", "cannot write", e))
}

fn derive(
    settings: &Settings,
    mut reader: AxiomReader,
    header: &str,
    path: &str,
    system: System,
    output: &mut dyn Write,
    out_name: &str,
) -> Result<(), Error> {
    let Settings {
        steps,
        seed,
        limits,
        ref tmpdir,
        ..
    } = *settings;
    let System {
        alphabet,
        productions,
        homomorphism,
        ..
    } = system;
    let hom = settings.homomorphism && !homomorphism.is_empty();
    // Right contexts skip branches in O(1) through a bracket index.
    let indexed = productions.has_right || (hom && homomorphism.has_right);
    let passes = steps + u64::from(hom);
    let mut d = Deriver::new(alphabet, Random::new(seed), Origin { path, header });
    let verbose = |what: &str, (m, b): (u64, u64)| {
        if settings.verbose {
            crate::diag::eprint(&format!("lsgen: {what}: {m} modules, {b} bytes\n"));
        }
    };

    let tmp_name = format!(
        "temporary file in {}",
        tmpdir.clone().unwrap_or_else(std::env::temp_dir).display()
    );
    // Generation 0: the axiom.
    let mut cur = if passes == 0 {
        None
    } else {
        Some(tempfile(tmpdir)?)
    };
    {
        let mut out = sink(&mut cur, &tmp_name, output, out_name, limits, indexed)?;
        let mut params = Vec::new();
        loop {
            reader.plain_run(|run| out.plain(run))??;
            match reader.next(&mut d.alphabet, &mut params, &mut d.rng)? {
                Some(key) => out.module(key, &params, &d.alphabet)?,
                None => break,
            }
            out.maybe_flush()?;
        }
        verbose("axiom", out.finish()?);
    }
    drop(reader);

    // Deterministic context-free byte systems: depth first, no temp files.
    let plan = crate::dfs::Plan::new(
        &productions,
        hom.then_some(&homomorphism),
        &d.alphabet,
        steps,
    )
    .filter(|_| settings.strategy != Strategy::Step);
    if let (Some(plan), Some(src)) = (plan, &cur) {
        if settings.verbose || limits.modules != u64::MAX || limits.bytes != u64::MAX {
            let census = crate::dfs::census(src, &d.alphabet)?;
            let lengths = plan.lengths(&census, steps);
            crate::dfs::check_limits(&lengths, limits, !hom)?;
            let shown = if hom {
                lengths.len()
            } else {
                lengths.len() - 1
            };
            for (i, &len) in lengths[..shown].iter().enumerate() {
                verbose(&Pass::Step(i as u64 + 1).to_string(), len);
            }
        }
        let last = if hom {
            Pass::Homomorphism
        } else {
            Pass::Step(steps)
        };
        let mut none = None;
        let mut out = sink(&mut none, &tmp_name, output, out_name, limits, false)?.for_pass(last);
        plan.expand(src, &d.alphabet, steps, &mut out)?;
        verbose(&last.to_string(), out.finish()?);
        return Ok(());
    }

    // Deterministic context-free systems with parameters: depth first too,
    // unless generation lengths are asked for (-v, --max-length).
    let quiet = !settings.verbose && limits.modules == u64::MAX && limits.bytes == u64::MAX;
    let plan = crate::dfs::ParamPlan::new(&productions, hom.then_some(&homomorphism), steps)
        .filter(|_| settings.strategy != Strategy::Step);
    if settings.strategy == Strategy::Dfs && cur.is_some() && !(plan.is_some() && quiet) {
        return Err(Error::usage(
            "--strategy dfs: this system cannot be expanded depth first",
        ));
    }
    // A runtime error found depth first may not be the first one in step
    // order: then derive again step by step, output discarded, so every
    // strategy reports the earliest step's first error in string order.
    let mut depth_first_error = None;
    if let (Some(plan), Some(src), true) = (plan, &cur, quiet) {
        let mut none = None;
        let mut out = sink(&mut none, &tmp_name, output, out_name, limits, false)?;
        match plan
            .expand(src, &d.alphabet, &d.origin, steps, &mut out)
            .and_then(|()| out.finish())
        {
            Ok(_) => return Ok(()),
            Err(e) if e.location.is_some() => depth_first_error = Some(e),
            Err(e) => return Err(e),
        }
    }
    let mut discard = io::sink();
    let output: &mut dyn Write = if depth_first_error.is_some() {
        &mut discard
    } else {
        output
    };
    let stepwise = step_passes(
        &mut d,
        cur,
        (&productions, &homomorphism, hom),
        settings,
        (output, out_name, &tmp_name),
        indexed,
    );
    match depth_first_error {
        Some(e) => Err(stepwise.err().unwrap_or(e)),
        None => stepwise,
    }
}

/// The steps, then the homomorphism, one temp file each, from generation 0
/// in `cur`.
fn step_passes(
    d: &mut Deriver,
    mut cur: Option<File>,
    (productions, homomorphism, hom): (&crate::rules::Table, &crate::rules::Table, bool),
    settings: &Settings,
    (output, out_name, tmp_name): (&mut dyn Write, &str, &str),
    indexed: bool,
) -> Result<(), Error> {
    let Settings {
        steps,
        limits,
        ref tmpdir,
        ..
    } = *settings;
    let passes = steps + u64::from(hom);
    let verbose = |what: &str, (m, b): (u64, u64)| {
        if settings.verbose {
            crate::diag::eprint(&format!("lsgen: {what}: {m} modules, {b} bytes\n"));
        }
    };
    let mut other: Option<File> = None;
    let mut i = 1;
    while i <= passes {
        let (table, pass) = if i <= steps {
            (productions, Pass::Step(i))
        } else {
            (homomorphism, Pass::Homomorphism)
        };
        let src = cur.take().expect("a generation to read");
        let mut dst = if i == passes {
            None
        } else {
            Some(match other.take() {
                Some(mut f) => {
                    rewind(&mut f)?;
                    f
                }
                None => tempfile(tmpdir)?,
            })
        };
        let draws = d.rng.draws();
        {
            let mut out =
                sink(&mut dst, tmp_name, output, out_name, limits, indexed)?.for_pass(pass);
            d.pass(table, &src, indexed, &mut out, pass)?;
            verbose(&pass.to_string(), out.finish()?);
        }
        // A step that drew nothing and left the string as it was is a fixed
        // point: every later step does the same. Go on with the last pass
        // (the homomorphism, or the last step, which writes the text).
        let last = if hom { passes } else { steps };
        if i < steps && last > i + 1 && d.rng.draws() == draws {
            if let Some(next) = &dst {
                if same_contents(&src, next)? {
                    if settings.verbose {
                        crate::diag::eprint(&format!(
                            "lsgen: steps {}..{steps}: unchanged (fixed point)\n",
                            i + 1
                        ));
                    }
                    other = Some(src);
                    cur = dst;
                    i = last;
                    continue;
                }
            }
        }
        other = Some(src);
        cur = dst;
        i += 1;
    }
    Ok(())
}

/// Do two generation files hold the same bytes?
fn same_contents(a: &File, b: &File) -> Result<bool, Error> {
    use std::os::unix::fs::FileExt;
    let read_err = |e| Error::io("temporary file", "cannot read", e);
    let len = a.metadata().map_err(read_err)?.len();
    if b.metadata().map_err(read_err)?.len() != len {
        return Ok(false);
    }
    const CHUNK: usize = 1 << 16;
    let (mut x, mut y) = (vec![0u8; CHUNK], vec![0u8; CHUNK]);
    let mut off = 0u64;
    while off < len {
        let n = CHUNK.min((len - off) as usize);
        a.read_exact_at(&mut x[..n], off).map_err(read_err)?;
        b.read_exact_at(&mut y[..n], off).map_err(read_err)?;
        if x[..n] != y[..n] {
            return Ok(false);
        }
        off += n as u64;
    }
    Ok(true)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn limits() {
        assert_eq!(parse_limit("1000").unwrap().modules, 1000);
        assert_eq!(parse_limit("5M").unwrap().modules, 5_000_000);
        assert_eq!(parse_limit("2GB").unwrap().bytes, 2_000_000_000);
        assert_eq!(parse_limit("512MiB").unwrap().bytes, 512 << 20);
        assert!(parse_limit("12 parsecs").is_err());
        assert!(parse_limit("").is_err());
    }
}
