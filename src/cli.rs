//! Command line: parse arguments, load the L-system, derive, write.

pub use crate::api::DEFAULT_DERIVATION_LENGTH;
use crate::api::{LSystem, Options};
use crate::derive::{Event, Limits, Pass, Strategy};
use crate::diag::{Error, Kind};
use crate::io::input::Input;
use crate::io::output::Output;
use clap::Parser;
use std::fs::File;
use std::io::{self, Write};
use std::path::PathBuf;

/// Most derivation steps accepted (as for `derivation length:`).
pub const MAX_STEPS: u64 = 1 << 53;

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

    /// For tests (hidden): force the derivation strategy. `auto` (default)
    /// picks depth first when the system allows it, `step` always derives
    /// step by step through temporary files, `dfs` insists on depth first
    /// and is a usage error (exit 2) when the system or options forbid it.
    #[arg(long, hide = true, value_name = "auto|step|dfs",
          value_parser = parse_strategy, default_value = "auto")]
    pub strategy: Strategy,
}

/// `--strategy`: `auto`, `step` or `dfs`.
pub fn parse_strategy(s: &str) -> Result<Strategy, String> {
    match s {
        "auto" => Ok(Strategy::Auto),
        "step" => Ok(Strategy::Step),
        "dfs" => Ok(Strategy::DepthFirst),
        _ => Err(format!("`{s}` is not a strategy: use auto, step or dfs")),
    }
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
        .stack_size(STACK)
        .spawn(main_on_thread);
    let worker = match worker {
        Ok(w) => w,
        Err(e) => {
            // Typically `ulimit -v` below the stack's reservation: say so
            // instead of dying silently.
            crate::diag::eprint(&format!(
                "lsgen: error: cannot start: {e} (lsgen reserves {} MiB of address space \
                 for its stack; is `ulimit -v` too low?)\n",
                STACK >> 20
            ));
            return 1;
        }
    };
    crate::io::output::leave_termination_signals_to_other_threads();
    // A panic (a bug) was reported by the hook; exit 70 (EX_SOFTWARE).
    worker.join().unwrap_or(70)
}

/// The worker thread's stack: the parser and the expression compiler
/// recurse on nesting, which the grammar bounds.
const STACK: usize = 256 << 20;

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
                    let printed = crate::io::output::check_stdout_open().and_then(|()| {
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
        None => {
            crate::io::output::check_stdin_open()?;
            Ok(Input::new(Box::new(io::stdin()), "<stdin>"))
        }
        Some(p) if p.as_os_str() == "-" => {
            crate::io::output::check_stdin_open()?;
            Ok(Input::new(Box::new(io::stdin()), "<stdin>"))
        }
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
    let input = open_input(args.file.as_ref())?;
    let mut ls = LSystem::load_named(input, args.seed)?;
    if args.axiom.is_none() {
        ls.require_axiom()?;
    }
    if args.check {
        // Read the axiom too, so its errors are reported.
        if let Some(p) = &args.axiom {
            ls.set_axiom(open_input(Some(p))?);
        }
        ls.check()?;
        if args.verbose {
            let (prods, hom) = ls.counts();
            crate::diag::eprint(&format!(
                "lsgen: {}: ok: {prods} productions, {hom} homomorphism productions\n",
                ls.path()
            ));
        }
        return Ok(());
    }
    let mut options = Options::new()
        .homomorphism(!args.no_homomorphism)
        .limits(args.max_length.unwrap_or_default())
        .strategy(args.strategy);
    if let Some(n) = args.derivation_length {
        options = options.steps(n);
    }
    if let Some(s) = args.seed {
        options = options.seed(s);
    }
    if let Some(d) = &args.tmpdir {
        options = options.tmpdir(d);
    }
    if args.verbose {
        crate::diag::eprint(&format!("lsgen: seed {}\n", ls.seed(&options)));
    }
    let mut output = match &args.output {
        Some(p) => Output::file(p)?,
        None => Output::stdout()?,
    };
    if let Some(p) = &args.axiom {
        ls.set_axiom(open_input(Some(p))?);
    }
    let out_name = output.name();
    let mut report = |e: &Event| {
        if !args.verbose {
            return;
        }
        let line = match *e {
            Event::Generation {
                pass,
                modules,
                bytes,
            } => {
                let what = match pass {
                    Pass::Axiom => "axiom".to_string(),
                    p => p.to_string(),
                };
                format!("lsgen: {what}: {modules} modules, {bytes} bytes\n")
            }
            Event::FixedPoint { from, to } => {
                format!("lsgen: steps {from}..{to}: unchanged (fixed point)\n")
            }
        };
        crate::diag::eprint(&line);
    };
    ls.run(
        &options,
        output.writer(),
        &out_name,
        args.verbose,
        &mut report,
    )?;
    output.commit()
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
