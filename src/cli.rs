//! Command line: parse arguments, load the L-system, derive, write.

pub use crate::api::DEFAULT_DERIVATION_LENGTH;
use crate::api::{LSystem, Options};
use crate::derive::{Event, FrameSink, Frames, Limits, Pass, Strategy};
use crate::diag::{Error, OptionNames, RuntimeError, Stage};
use crate::io::input::Input;
use crate::io::output::Output;
use crate::io::template::{self, Field, Template, Vars};
use clap::{CommandFactory, Parser};
use std::fs::File;
use std::io::{self, Write};
use std::path::{Path, PathBuf};
use std::sync::Arc;

pub mod thread_exit;

/// The end of `--help`: examples, exit codes, where to read more.
const HELP_FOOTER: &str = "\
Examples:
  lsgen -n 5 examples/algae.ls                 derive 5 steps, print the string
  lsgen -n 7 -o plant.txt examples/plant_d.ls  write to plant.txt (atomically)
  lsgen -n 5 --seed 1..100 -o 'forest/{stem}-{seed}.txt' examples/stochastic_plant.ls
                                               100 seeded variants, on all CPUs
  lsgen --check -v my.ls                       parse and check only

Exit status: 0 success; 1 bad input, a runtime error, an I/O failure, or a
failed job of a batch; 2 a usage error (bad command line).

The language, the CLI and the design: README.md, or `lsgen --man`.";

/// Most derivation steps accepted (as for `derivation length:`).
pub const MAX_STEPS: u64 = 1 << 53;

#[derive(Parser, Debug)]
#[command(
    name = "lsgen",
    version,
    about = "Derive an L-system and print the resulting string",
    long_about = "Reads an L-system (.ls) file, derives N generations and writes the final \
                  string on one line. The axiom is read as a stream and generations live in \
                  temporary files, so strings may be far larger than memory.",
    after_help = HELP_FOOTER
)]
pub struct Args {
    /// The .ls file(s); standard input when absent or `-`. Several files
    /// make a batch (see -o and -j).
    #[arg(value_name = "FILE")]
    pub files: Vec<PathBuf>,

    /// Write the string to FILE (`-`: standard output); a regular file is
    /// put in place only when complete, through symbolic links. A template:
    /// {stem} (input file name without extension), {seed}, and n in braces
    /// (the generation number of --frames); {{ and }} for literal braces.
    /// A batch needs one that names each job apart.
    #[arg(short, long, value_name = "FILE")]
    pub output: Option<PathBuf>,

    /// Number of derivation steps (overrides `derivation length:`).
    #[arg(short = 'n', long, value_name = "N", conflicts_with = "frames",
          value_parser = clap::value_parser!(u64).range(..=MAX_STEPS))]
    pub derivation_length: Option<u64>,

    /// Seed of the random generator (overrides `seed:`); a range A..B
    /// (inclusive) runs one job per seed.
    #[arg(long, value_name = "S|A..B", value_parser = parse_seeds)]
    pub seed: Option<Seeds>,

    /// Threads: a batch's jobs run on N workers, one derivation on N
    /// threads (default: the environment variable LSGEN_JOBS if set and
    /// not empty, else the number of CPUs).
    #[arg(short, long, value_name = "N",
          value_parser = clap::value_parser!(u32).range(1..=JOBS_MAX))]
    pub jobs: Option<u32>,

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

    /// Stop with an error when a generation exceeds N modules (5000000, 5M,
    /// 2G) or N bytes (10kB, 512MiB, 2GB).
    #[arg(long, value_name = "N", value_parser = parse_limit)]
    pub max_length: Option<Limits>,

    /// Print parameters with N significant digits, as C's %g (cpfg prints
    /// %g, 6 digits); default: the shortest form that reads back exactly.
    #[arg(long, value_name = "N",
          value_parser = clap::value_parser!(u32).range(1..=crate::rules::codec::MAX_PRECISION as i64))]
    pub precision: Option<u32>,

    /// Directory for the temporary generation files (default: $TMPDIR, or /tmp
    /// when it is unset or empty).
    #[arg(long, value_name = "DIR")]
    pub tmpdir: Option<PathBuf>,

    /// The number of this run's first step (default 1): random draws
    /// depend on it, so `-n 3 --no-homomorphism | -n 2 --first-step 4
    /// --axiom -` gives what `-n 5` gives.
    #[arg(long, value_name = "K", default_value_t = 1,
          value_parser = clap::value_parser!(u64).range(1..))]
    pub first_step: u64,

    /// Write generations A to B (every K-th with `A..B:K`) from one
    /// derivation, each as `-n` would print it: one line each, or with
    /// `-o` one file each, n in braces in its name the generation number.
    // (Not the placeholder itself: clap's help turns it into a line break.)
    #[arg(long, value_name = "A..B[:K]", value_parser = parse_frames)]
    pub frames: Option<Frames>,

    /// Report the seed and each generation's length on standard error.
    #[arg(short, long)]
    pub verbose: bool,

    /// Show progress on standard error even when it is not a terminal
    /// (default: shown on a terminal, unless -v).
    #[arg(long, conflicts_with = "quiet")]
    pub progress: bool,

    /// Show no progress, also on a terminal.
    #[arg(short, long)]
    pub quiet: bool,

    /// Print a completion script for SHELL (bash, zsh, fish, elvish,
    /// powershell) on standard output, and exit.
    #[arg(long, value_name = "SHELL", exclusive = true)]
    pub completions: Option<clap_complete::Shell>,

    /// Print the man page (roff) on standard output, and exit.
    #[arg(long, exclusive = true)]
    pub man: bool,

    /// The language of the input: `cpfg` (L-studio / vlab `.l` files) or
    /// `ls`; default: cpfg for a name ending in `.l` or a file whose first
    /// statement is `Lsystem:` or a `#` directive, else ls.
    #[arg(long, value_name = "cpfg|ls", value_parser = parse_dialect)]
    pub dialect: Option<crate::cpfg::Dialect>,

    /// cpfg's functions and curves for `func(id, x)` and `curveX(id, t)`
    /// (and `curveY`, `curveZ`, `curveGAL`) in `.l` files: the model's
    /// view file (its `function:`, `function set:` and `curve:` lines), a
    /// function set (`.fset`), a function file (`.func`) or a contour file
    /// (`.con`); repeatable, the functions numbered 1, 2, ... in order, the
    /// curves apart. `--curves` is the same option.
    #[arg(long, visible_alias = "curves", value_name = "FILE")]
    pub functions: Vec<PathBuf>,

    /// cpfg's view file (`.v`) of a `.l` model: its turtle's angle,
    /// tropism and scale for the queries `?P`, `?H`, `?L`, `?U` (filled in
    /// each generation as cpfg's turtle interprets it), and its functions
    /// and curves, numbered before those of `--functions`.
    #[arg(long, value_name = "FILE.v")]
    pub cpfg_view: Option<PathBuf>,

    /// For tests (hidden): force the derivation strategy. `auto` (default)
    /// picks depth first when the system allows it, `step` always derives
    /// step by step through temporary files, `dfs` insists on depth first
    /// and is a usage error (exit 2) when the system or options forbid it.
    #[arg(long, hide = true, value_name = "auto|step|dfs",
          value_parser = parse_strategy, default_value = "auto")]
    pub strategy: Strategy,
}

/// `--seed`: one seed, or an inclusive range `A..B`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Seeds {
    pub first: u64,
    pub last: u64,
}

impl Seeds {
    /// Number of seeds (at least 1; the full u64 range saturates).
    fn count(&self) -> u64 {
        (self.last - self.first).saturating_add(1)
    }
}

pub fn parse_seeds(s: &str) -> Result<Seeds, String> {
    let num = |t: &str| {
        t.trim()
            .parse::<u64>()
            .map_err(|_| format!("`{s}` is not a seed: use a number or a range A..B"))
    };
    match s.split_once("..") {
        None => num(s).map(|v| Seeds { first: v, last: v }),
        Some((a, b)) => {
            let (first, last) = (num(a)?, num(b)?);
            if first > last {
                return Err(format!(
                    "`{s}`: an empty range (the first seed is past the last)"
                ));
            }
            Ok(Seeds { first, last })
        }
    }
}

/// `--dialect`: `cpfg` or `ls`.
pub fn parse_dialect(s: &str) -> Result<crate::cpfg::Dialect, String> {
    match s {
        "cpfg" => Ok(crate::cpfg::Dialect::Cpfg),
        "ls" => Ok(crate::cpfg::Dialect::Ls),
        _ => Err(format!("`{s}` is not a dialect: use cpfg or ls")),
    }
}

/// The command line as completion scripts offer it: without hidden
/// options (`--strategy`), which clap_complete's generators would list.
fn completion_command() -> clap::Command {
    let mut full = Args::command();
    full.build();
    let shown: Vec<clap::Arg> = full
        .get_arguments()
        .filter(|a| !a.is_hide_set())
        .cloned()
        .collect();
    // Its own help and version flags are among `shown`; clap asks for the
    // version text that `--version` would print.
    clap::Command::new("lsgen")
        .version(env!("CARGO_PKG_VERSION"))
        .disable_help_flag(true)
        .disable_version_flag(true)
        .args(shown)
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

/// `--frames`: `A..B` or `A..B:K` (inclusive, A <= B, K >= 1, B at most
/// 2^53 like `-n`).
pub fn parse_frames(s: &str) -> Result<Frames, String> {
    let bad = || format!("`{s}` is not a range of generations: use A..B or A..B:K, e.g. 0..10:2");
    let (range, every) = match s.split_once(':') {
        Some((r, k)) => (r, k.trim().parse::<u64>().map_err(|_| bad())?),
        None => (s, 1),
    };
    let (a, b) = range.split_once("..").ok_or_else(bad)?;
    let from: u64 = a.trim().parse().map_err(|_| bad())?;
    let to: u64 = b.trim().parse().map_err(|_| bad())?;
    if from > to {
        return Err(format!("`{s}`: the first generation comes after the last"));
    }
    if every == 0 {
        return Err(format!("`{s}`: the step between frames must be 1 or more"));
    }
    if to > MAX_STEPS {
        return Err(format!("`{s}`: generations go up to {MAX_STEPS}"));
    }
    Ok(Frames { from, to, every })
}

/// Frames one after the other on one stream, a line each.
struct StreamFrames<'a> {
    out: &'a mut dyn Write,
    name: String,
}

impl FrameSink for StreamFrames<'_> {
    fn frame(
        &mut self,
        _n: u64,
        write: &mut dyn FnMut(&mut dyn Write, &str) -> Result<(u64, u64), Error>,
    ) -> Result<(u64, u64), Error> {
        write(self.out, &self.name)
    }
}

/// Frames in files named by a template (`{n}`: the generation), each
/// written as `-o` writes.
struct FileFrames<'a> {
    template: &'a Template,
    stem: &'a std::ffi::OsStr,
    seed: u64,
    /// See [`Job::inputs`].
    inputs: &'a [(u64, u64)],
}

impl FrameSink for FileFrames<'_> {
    fn frame(
        &mut self,
        n: u64,
        write: &mut dyn FnMut(&mut dyn Write, &str) -> Result<(u64, u64), Error>,
    ) -> Result<(u64, u64), Error> {
        let path = self.template.expand(&Vars {
            stem: Some(self.stem),
            seed: Some(self.seed),
            n: Some(n),
        })?;
        let mut output = output_file(&path, self.inputs)?;
        let name = output.name();
        let len = write(output.writer(), &name)?;
        output.commit()?;
        Ok(len)
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
                "unknown unit `{unit}`: modules take k (or K), M, G; bytes take B, kB (or KB), MB, GB, TB, KiB, MiB, GiB, TiB"
            ))
        }
    }
    Ok(l)
}

/// Parse the command line and run on a thread with a large stack (the
/// parser and compiler recurse on nested expressions); returns the exit
/// status. A bug shows as one line, not a backtrace.
pub fn main_exit_code() -> i32 {
    ignore_sigxfsz();
    map_large_blocks();
    install_panic_hook();
    let worker = crate::spawn::spawn(
        std::thread::Builder::new()
            .name("lsgen".into())
            .stack_size(STACK),
        main_on_thread,
    );
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

/// Past `ulimit -f`, a write fails with EFBIG (reported) instead of
/// killing the process. Both binaries call this first.
pub fn ignore_sigxfsz() {
    // SAFETY: setting a signal's disposition to SIG_IGN.
    unsafe { libc::signal(libc::SIGXFSZ, libc::SIG_IGN) };
}

/// Allocations of 256 KiB and more (the text blocks of `-j N`, buffers)
/// get pages of their own from glibc, given back when freed, instead of
/// coming from the heap of the thread that asks. glibc's default moves
/// this threshold up to the size of the first such block freed, after
/// which the blocks came from the heaps of several threads and a freed
/// one stayed in its thread's heap while another thread took new pages:
/// context_signal 3 steps at 10^9, `-j 2`, peaked at 13.9-14.9 MB of RSS
/// (16.8 MB in one run with the split's other memory fixes), 11.8-12.0 MB
/// with this. Blocks are reused, so few are mapped. (Other C libraries:
/// nothing to do.)
///
/// Setting that threshold also fixes glibc's trim threshold at its default,
/// 128 KiB: a heap whose free top is larger gives it back
/// (`madvise(MADV_DONTNEED)`, which on a process of several threads
/// flushes every CPU's TLB) and takes the pages again, zeroed, as it
/// grows. A batch's tiny jobs each did that once: 10,000 three-step jobs
/// of a small stochastic plant made 80,000 page faults and 10,000 such
/// flushes. With 1 MiB they make a few hundred in all, and peak RSS of the
/// threads rows is as before (benches/RESULTS.md).
pub fn map_large_blocks() {
    #[cfg(all(target_os = "linux", target_env = "gnu"))]
    // SAFETY: mallopt only sets parameters of glibc's allocator; called
    // before this process starts any thread.
    unsafe {
        libc::mallopt(libc::M_MMAP_THRESHOLD, 256 << 10);
        libc::mallopt(libc::M_TRIM_THRESHOLD, 1 << 20);
    }
}

/// Print clap's `--help` or `--version` text. A failed write
/// (`--version > /dev/full`, standard output closed) is an error; a
/// closed pipe ([`Error::is_broken_pipe`]) callers keep quiet.
pub fn print_help_or_version(e: &clap::Error) -> Result<(), Error> {
    crate::io::output::check_stdout_open().and_then(|()| {
        e.print()
            .and_then(|()| io::stdout().flush())
            .map_err(|e| Error::io("standard output", crate::diag::IoAction::Write, e))
    })
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

/// `Args::try_parse`, without freeing clap's command and matches: the
/// process ends soon after, and freeing the command's 20 arguments and
/// their matches one by one was 1 % of a small run (issue 10).
fn parse_args() -> Result<Args, clap::Error> {
    use clap::FromArgMatches;
    let mut cmd = std::mem::ManuallyDrop::new(Args::command());
    let mut matches =
        std::mem::ManuallyDrop::new(cmd.try_get_matches_from_mut(std::env::args_os())?);
    Args::from_arg_matches_mut(&mut matches).map_err(|e| e.format(&mut cmd))
}

/// The most threads `-j` and `LSGEN_JOBS` take.
const JOBS_MAX: i64 = 4096;

/// `-j`, else `LSGEN_JOBS` (empty: not set), checked as `-j` is; its
/// errors name the variable, not the option.
fn jobs_from_env(jobs: Option<u32>) -> Result<Option<u32>, Error> {
    let value = match (jobs, std::env::var_os("LSGEN_JOBS")) {
        (Some(j), _) => return Ok(Some(j)),
        (None, None) => return Ok(None),
        (None, Some(v)) if v.is_empty() => return Ok(None),
        (None, Some(v)) => v,
    };
    value
        .to_str()
        .and_then(|s| s.parse::<u32>().ok())
        .filter(|&n| n >= 1 && i64::from(n) <= JOBS_MAX)
        .map(Some)
        .ok_or_else(|| {
            Error::new(crate::diag::UsageError::JobsVariable(
                value.to_string_lossy().into_owned(),
            ))
        })
}

fn main_on_thread() -> i32 {
    let mut args = match parse_args() {
        Ok(a) => a,
        Err(e) => {
            return match e.kind() {
                clap::error::ErrorKind::DisplayHelp | clap::error::ErrorKind::DisplayVersion => {
                    match print_help_or_version(&e) {
                        Ok(()) => 0,
                        Err(e) => report("lsgen", &e),
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
    let result = if let Some(shell) = args.completions {
        let mut text = Vec::new();
        clap_complete::generate(shell, &mut completion_command(), "lsgen", &mut text);
        print_stdout(&text)
    } else if args.man {
        let mut text = Vec::new();
        clap_mangen::Man::new(Args::command())
            .render(&mut text)
            .map_err(|e| Error::io("the man page", crate::diag::IoAction::Render, e))
            .and_then(|()| print_stdout(&text))
    } else {
        jobs_from_env(args.jobs).and_then(|jobs| {
            args.jobs = jobs;
            run(&args)
        })
    };
    match result {
        Ok(()) => 0,
        Err(e) => report("lsgen", &e),
    }
}

/// The exit status of a failed run: 2 for a usage error, 0 when the
/// reader closed the output pipe (a quiet end), else 1.
pub fn exit_code(e: &Error) -> i32 {
    if e.is_broken_pipe() {
        0
    } else if e.stage() == Stage::Usage {
        2
    } else {
        1
    }
}

/// Report `e` on standard error as `program` does (`PROGRAM: FILE:LINE:COL:
/// error: ...`; nothing for a closed pipe) and return the exit status.
pub fn report(program: &str, e: &Error) -> i32 {
    if !e.is_broken_pipe() {
        crate::diag::eprint(&format!("{program}: {e}"));
    }
    exit_code(e)
}

/// Write `text` to standard output (for --completions, --man).
fn print_stdout(text: &[u8]) -> Result<(), Error> {
    crate::io::output::check_stdout_open()?;
    let mut out = io::stdout().lock();
    out.write_all(text)
        .and_then(|()| out.flush())
        .map_err(|e| Error::io("standard output", crate::diag::IoAction::Write, e))
}

fn open_input(path: Option<&Path>) -> Result<Input, Error> {
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
            // `/dev/stdin` with standard input closed (`<&-`).
            crate::io::output::check_input_open(p, &name)?;
            let f = File::open(p)
                .map_err(|e| Error::io(name.clone(), crate::diag::IoAction::Open, e))?;
            if f.metadata().map(|m| m.is_dir()).unwrap_or(false) {
                return Err(Error::io(
                    name,
                    crate::diag::IoAction::Read,
                    io::Error::from(io::ErrorKind::IsADirectory),
                ));
            }
            // A regular file may be read at any offset: a long axiom is
            // read on several threads (`derive::par::axiom_prefix`).
            let file = f
                .metadata()
                .is_ok_and(|m| m.is_file())
                .then(|| f.try_clone().ok())
                .flatten();
            let input = Input::new(Box::new(f), name);
            Ok(match file {
                Some(file) => input.with_file(file),
                None => input,
            })
        }
    }
}

/// One job of a run: an input file and a seed.
#[derive(Clone, Copy, Debug)]
struct Job<'a> {
    file: Option<&'a Path>,
    seed: Option<u64>,
    /// A batch's input files ([`batch_inputs`]), which no job may write
    /// over: later jobs read them again.
    inputs: &'a [(u64, u64)],
}

/// `(device, inode)` of the regular files among `paths`.
fn file_ids<'p>(paths: impl Iterator<Item = &'p Path>) -> Vec<(u64, u64)> {
    use std::os::unix::fs::MetadataExt;
    paths
        .filter_map(|p| std::fs::metadata(p).ok().filter(|m| m.is_file()))
        .map(|m| (m.dev(), m.ino()))
        .collect()
}

/// `(device, inode)` of what a batch's jobs read again: its L-system
/// files, `--axiom`, `--cpfg-view`, `--functions`, and the files a `.l`
/// file includes (found by preprocessing it once here). An `#include` of
/// a pipe or a device is a usage error, as a batch's standard input is:
/// it could feed one job only.
fn batch_inputs(
    args: &Args,
    files: &[Option<&Path>],
    functions: &crate::cpfg::func::Functions,
) -> Result<Vec<(u64, u64)>, Error> {
    let given = files.iter().flatten().copied();
    let options = args
        .axiom
        .iter()
        .chain(&args.cpfg_view)
        .chain(&args.functions);
    let mut inputs = file_ids(given.chain(options.map(PathBuf::as_path)));
    let dialect = args.dialect.unwrap_or_default();
    // (A file that is not a regular one is read once, by its job.)
    let regular = |p: &Path| std::fs::metadata(p).is_ok_and(|m| m.is_file());
    for file in files.iter().flatten().copied().filter(|p| regular(p)) {
        match crate::cpfg::included_files(file, dialect, functions) {
            Ok(included) => inputs.extend(file_ids(included.iter().map(PathBuf::as_path))),
            Err(include) => {
                return Err(Error::new(crate::diag::UsageError::StreamIncludeInBatch {
                    file: file.to_path_buf(),
                    include,
                }))
            }
        }
    }
    Ok(inputs)
}

/// `Output::file(path)`, unless `path` is one of a batch's `inputs` (a
/// job's output would change what the later jobs read, and the result
/// would depend on `-j`).
fn output_file(path: &Path, inputs: &[(u64, u64)]) -> Result<Output, Error> {
    if !inputs.is_empty()
        && file_ids(std::iter::once(path))
            .iter()
            .any(|id| inputs.contains(id))
    {
        let e = io::Error::new(
            io::ErrorKind::AlreadyExists,
            "it is an input of this batch, which later jobs read again: not replaced",
        );
        return Err(Error::io(
            path.display().to_string(),
            crate::diag::IoAction::Write,
            e,
        ));
    }
    Output::file(path)
}

impl Job<'_> {
    /// How a batch's messages name the job.
    fn label(&self, seed: Option<u64>) -> String {
        let file = self
            .file
            .map_or("<stdin>".to_string(), |p| p.display().to_string());
        match seed.or(self.seed) {
            Some(s) => format!("{file} (seed {s})"),
            None => file,
        }
    }
}

pub fn run(args: &Args) -> Result<(), Error> {
    let files: Vec<Option<&Path>> = if args.files.is_empty() {
        vec![None]
    } else {
        args.files.iter().map(|p| Some(p.as_path())).collect()
    };
    let seeds = args.seed.map_or(1, |s| s.count());
    let total = (files.len() as u64).saturating_mul(seeds);
    let template = match &args.output {
        Some(o) => Some(Template::parse_path(o)?),
        None => None,
    };
    if let Some(t) = &template {
        // `{n}` numbers frames and has no value in a plain run; frames to
        // files need it. Say so before any job.
        let to_stdout = args.output.as_ref().is_some_and(|p| p.as_os_str() == "-");
        if args.frames.is_some() && !to_stdout && !t.uses(Field::N) {
            return Err(Error::new(crate::diag::UsageError::FramesNeedN));
        }
        t.expand(&Vars {
            stem: Some(std::ffi::OsStr::new("x")),
            seed: Some(0),
            n: args.frames.map(|f| f.from),
        })?;
    }
    let functions = Arc::new(crate::cpfg::func::Functions::load_with_view(
        args.cpfg_view.as_deref(),
        &args.functions,
    )?);
    if total == 1 {
        let job = Job {
            file: files[0],
            seed: args.seed.map(|s| s.first),
            inputs: &[],
        };
        return run_one(args, job, template.as_ref(), &functions, None);
    }
    check_batch(args, &files, seeds, template.as_ref())?;
    let inputs = batch_inputs(args, &files, &functions)?;
    let jobs = |i: u64| Job {
        file: files[(i / seeds) as usize],
        seed: args.seed.map(|s| s.first + i % seeds),
        inputs: &inputs,
    };
    let cpus = std::thread::available_parallelism().map_or(1, |n| n.get());
    let workers = args
        .jobs
        .map_or(cpus, |j| crate::derive::par::started(j as usize, cpus)) as u64;
    let workers = workers.min(total);
    // Before any thread of the batch starts (the progress ticker too):
    // they inherit the mask that leaves termination signals to a thread
    // of their own.
    crate::io::output::signals_to_a_thread_of_their_own();
    let display = crate::progress::wanted(args.progress, args.quiet, args.verbose, false)
        .then(|| crate::progress::Batch::start(total));
    let (failed, failures) = run_batch(total, workers as usize, |i| {
        let job = jobs(i);
        let mut seed = None;
        let r = run_one(args, job, template.as_ref(), &functions, Some(&mut seed)).map_err(|e| {
            // The seed the job used, once known (the file's `seed:`, or a
            // fresh one, without --seed).
            e.in_job(job.label(seed))
        });
        if let Some(d) = &display {
            d.job_done();
        }
        r
    });
    drop(display);
    if failures == 0 {
        return Ok(());
    }
    let shown = failed.len() as u64;
    print_failures(failed);
    if failures > shown {
        crate::diag::eprint(&format!(
            "lsgen: ... and {} more failed jobs, not shown (the first {} are)\n",
            crate::diag::group_digits(failures - shown),
            crate::diag::group_digits(shown)
        ));
    }
    Err(Error::new(RuntimeError::JobsFailed {
        failed: failures,
        total,
    }))
}

/// A batch's failed jobs, in job order; jobs that failed with the same
/// error (a mistake in the file, in every seed's job) print it once, with
/// how many others did and the last of them.
fn print_failures(failed: Vec<(u64, Error)>) {
    // (The error as its first job gave it, how many more, the last one.)
    let mut groups: Vec<(String, u64, String)> = Vec::new();
    let mut by_text: std::collections::HashMap<String, usize> = Default::default();
    for (_, mut e) in failed {
        let label = e.take_job();
        let text = e.to_string();
        match by_text.get(&text) {
            Some(&g) => {
                groups[g].1 += 1;
                groups[g].2 = label.unwrap_or_default();
            }
            None => {
                by_text.insert(text, groups.len());
                let first = match label {
                    Some(l) => e.in_job(l).to_string(),
                    None => e.to_string(),
                };
                groups.push((first, 0, String::new()));
            }
        }
    }
    for (first, more, last) in groups {
        crate::diag::eprint(&format!("lsgen: {first}"));
        match more {
            0 => {}
            1 => crate::diag::eprint(&format!("lsgen: the same error in job {last}\n")),
            n => crate::diag::eprint(&format!(
                "lsgen: the same error in {} more jobs, the last {last}\n",
                crate::diag::group_digits(n)
            )),
        }
    }
}

/// A batch's usage errors, found before any job runs.
fn check_batch(
    args: &Args,
    files: &[Option<&Path>],
    seeds: u64,
    template: Option<&Template>,
) -> Result<(), Error> {
    let stdin_file = files.iter().any(|f| f.is_none_or(|p| p.as_os_str() == "-"));
    if stdin_file {
        return Err(Error::new(crate::diag::UsageError::StdinInBatch));
    }
    if args.axiom.as_ref().is_some_and(|p| p.as_os_str() == "-") {
        return Err(Error::new(crate::diag::UsageError::StdinAxiomInBatch));
    }
    // Every job reads the axiom file, and each seed its L-system file,
    // again: a pipe or a device would give the first job all of it and
    // the others nothing. (A name that cannot be read fails in its jobs.)
    let stream = |p: &Path| std::fs::metadata(p).is_ok_and(|m| !m.is_file());
    if let Some(p) = args.axiom.as_deref().filter(|p| stream(p)) {
        let name = p.to_path_buf();
        return Err(Error::new(crate::diag::UsageError::StreamAxiomInBatch(
            name,
        )));
    }
    if seeds > 1 {
        if let Some(p) = files.iter().flatten().find(|p| stream(p)) {
            let name = p.to_path_buf();
            return Err(Error::new(crate::diag::UsageError::StreamFileInBatch(name)));
        }
    }
    if args.check {
        // Nothing is written: no names to tell apart.
        return Ok(());
    }
    let Some(t) = template.filter(|t| !t.is_plain()) else {
        return Err(Error::new(crate::diag::UsageError::BatchNeedsTemplate));
    };
    if seeds > 1 && !t.uses(Field::Seed) {
        return Err(Error::new(crate::diag::UsageError::SeedRangeNeedsSeed));
    }
    if files.len() > 1 && !t.uses(Field::Stem) {
        return Err(Error::new(crate::diag::UsageError::FilesNeedStem));
    }
    // (No standard input here: every file has a path.)
    let stems: Vec<std::ffi::OsString> = files.iter().map(|p| template::stem(*p)).collect();
    if files.len() > 1 {
        let mut stems: Vec<(&std::ffi::OsString, &Path)> =
            stems.iter().zip(files.iter().flatten().copied()).collect();
        stems.sort();
        for w in stems.windows(2) {
            if w[0].0 == w[1].0 {
                return Err(Error::new(crate::diag::UsageError::SameStem {
                    first: w[0].1.to_path_buf(),
                    second: w[1].1.to_path_buf(),
                    stem: w[0].0.to_string_lossy().into_owned(),
                }));
            }
        }
    }
    // No two outputs of one name (`{stem}{seed}` gives `a11` for a.ls
    // seed 11 and a1.ls seed 1; `{n}{seed}` frame 1 seed 11 and frame 11
    // seed 1): one would replace the other, as the threads' order has it.
    let ranges = template::Ranges {
        stems: &stems,
        seeds: args.seed.map(|s| (s.first, seeds)),
        frames: args
            .frames
            .filter(|_| t.uses(Field::N))
            .map(|f| (f.from, f.count(), f.every)),
    };
    let label = |v: &template::Vars| {
        let at = stems.iter().position(|s| Some(s.as_os_str()) == v.stem);
        let file = at
            .and_then(|i| files[i])
            .map_or(String::new(), |p| p.display().to_string());
        let mut what = Vec::new();
        if let Some(s) = v.seed {
            what.push(format!("seed {s}"));
        }
        if let Some(n) = v.n {
            what.push(format!("generation {n}"));
        }
        match (file.is_empty(), what.is_empty()) {
            (_, true) => file,
            (true, false) => what.join(", "),
            (false, false) => format!("{file} ({})", what.join(", ")),
        }
    };
    if let Some((a, b, name)) = t.collision(&ranges)? {
        return Err(Error::new(crate::diag::UsageError::SameOutput {
            first: label(&a),
            second: label(&b),
            name,
        }));
    }
    // Names apart can still be one file (a job's own seed, without
    // --seed, is not known yet; each job checks its frames then).
    if args.seed.is_some() || !t.uses(Field::Seed) {
        files_apart(t, &ranges, label)?;
    }
    Ok(())
}

/// Outputs whose names differ but lead to one file are a usage error:
/// `{stem}/../x-{seed}`, a linked directory, a name that is a link to
/// another output. Each name is looked up as its job will write it; past
/// [`template::MAX_CHECKED_OUTPUTS`] outputs, none is.
fn files_apart(
    t: &Template,
    ranges: &template::Ranges,
    label: impl Fn(&Vars) -> String,
) -> Result<(), Error> {
    let total = ranges.count();
    if total > template::MAX_CHECKED_OUTPUTS {
        return Ok(());
    }
    let dirs = std::cell::RefCell::new(None);
    let name = |i: u64| t.expand(&ranges.vars(i));
    let one = template::first_alike(total, |i| {
        Ok(crate::io::output::replaced_file(
            &name(i)?,
            &mut dirs.borrow_mut(),
        ))
    })?;
    match one {
        None => Ok(()),
        Some((a, b, _)) => Err(Error::new(crate::diag::UsageError::SameFile {
            first: label(&ranges.vars(a)),
            second: label(&ranges.vars(b)),
            first_name: name(a)?,
            second_name: name(b)?,
        })),
    }
}

/// Failed jobs whose errors a batch keeps to print (the first in job
/// order); the others are counted: a failing seed range of 10^8 jobs
/// would otherwise hold 10^8 errors until the end.
const SHOWN_FAILURES: usize = 1000;

/// Run jobs `0..total` on `workers` threads; the first [`SHOWN_FAILURES`]
/// failures in job order, and how many failed. A job that panics (a bug)
/// fails; the others go on.
fn run_batch(
    total: u64,
    workers: usize,
    job: impl Fn(u64) -> Result<(), Error> + Sync,
) -> (Vec<(u64, Error)>, u64) {
    use std::sync::atomic::{AtomicU64, Ordering};
    use std::sync::Mutex;
    let next = AtomicU64::new(0);
    let count = AtomicU64::new(0);
    let failed: Mutex<Vec<(u64, Error)>> = Mutex::new(Vec::new());
    // One sync per output directory, when this function returns (or when
    // a signal ends the run: the signal thread, started by the caller,
    // syncs them first).
    let _dirs = crate::io::output::DeferDirSync::new();
    let work = || {
        // Job after job on this thread: each job takes the output buffer,
        // number cache and emptied generation files the last one left
        // (derive/spares.rs).
        let _spares = crate::derive::KeepSpares::new();
        loop {
            let i = next.fetch_add(1, Ordering::Relaxed);
            if i >= total {
                break;
            }
            let r = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| job(i)))
                .unwrap_or_else(|_| Err(Error::new(RuntimeError::Internal)));
            if let Err(e) = r {
                count.fetch_add(1, Ordering::Relaxed);
                if let Ok(mut f) = failed.lock() {
                    f.push((i, e));
                    if f.len() >= 2 * SHOWN_FAILURES {
                        f.sort_by_key(|(i, _)| *i);
                        f.truncate(SHOWN_FAILURES);
                    }
                }
            }
        }
    };
    std::thread::scope(|s| {
        let mut handles = Vec::new();
        for w in 0..workers {
            // The parser recurses on nested expressions: big stacks, as
            // the main thread's.
            let h = crate::spawn::spawn_scoped(
                std::thread::Builder::new()
                    .name(format!("lsgen-{w}"))
                    .stack_size(256 << 20),
                s,
                work,
            );
            match h {
                Ok(h) => handles.push(h),
                // No thread to be had: the others (or this one) do the work.
                Err(_) if !handles.is_empty() => break,
                Err(_) => work(),
            }
        }
        // (Where no signal thread could start, the jobs' threads hold
        // termination signals while a job puts its file in place, and
        // this one, waiting, holds them too: taken here, one would end
        // the run with a job's temporary name left beside its output.
        // Threads inherit the mask: held only once they are started.)
        crate::io::output::with_signals_held(|| {
            for h in handles {
                let _ = h.join();
            }
        });
    });
    let mut f = failed.into_inner().unwrap_or_default();
    f.sort_by_key(|(i, _)| *i);
    f.truncate(SHOWN_FAILURES);
    (f, count.into_inner())
}

/// `n` things for `-v`: `1 module`, `2 modules`, `1,024 modules`.
fn counted(n: u64, thing: &str) -> String {
    let s = if n == 1 { "" } else { "s" };
    format!("{} {thing}{s}", count_string(n))
}

/// A count for `-v`: grouped digits; `u64::MAX` stands for a count that
/// does not fit (the depth-first plan saturates), printed as a lower bound.
pub fn count_string(n: u64) -> String {
    if n == u64::MAX {
        format!(">= {}", crate::diag::group_digits(n))
    } else {
        crate::diag::group_digits(n)
    }
}

/// Run one job: load its file, derive with its seed, write its output.
/// `batch`: in a batch, messages name the job, and the seed used is put
/// there.
fn run_one(
    args: &Args,
    job: Job,
    template: Option<&Template>,
    functions: &Arc<crate::cpfg::func::Functions>,
    batch: Option<&mut Option<u64>>,
) -> Result<(), Error> {
    use crate::io::output::reads_stdin;
    let file_is_stdin = job.file.is_none_or(reads_stdin);
    let axiom_is_stdin = args.axiom.as_deref().is_some_and(reads_stdin);
    if file_is_stdin && axiom_is_stdin {
        return Err(Error::new(crate::diag::UsageError::BothFromStdin));
    }
    if file_is_stdin || axiom_is_stdin {
        crate::io::output::note_stdin_taken();
    }
    let input = open_input(job.file)?;
    let dialect = args.dialect.unwrap_or_default();
    let mut ls = LSystem::load_dialect(
        input,
        job.seed,
        dialect,
        OptionNames::CommandLine,
        (functions, true),
    )?;
    if args.axiom.is_none() {
        ls.require_axiom()?;
    }
    if args.check {
        // Read the axiom too, so its errors are reported.
        if let Some(p) = &args.axiom {
            ls.set_axiom(open_input(Some(p.as_path()))?);
        }
        ls.check_axiom()?;
        if args.verbose {
            let (prods, hom) = ls.counts();
            crate::diag::eprint(&format!(
                "lsgen: {}: ok: {}, {}\n",
                ls.path(),
                counted(prods as u64, "production"),
                counted(hom as u64, "homomorphism production")
            ));
        }
        return Ok(());
    }
    let mut options = Options::new()
        .command_line_names()
        .print_warnings()
        .homomorphism(!args.no_homomorphism)
        .limits(args.max_length.unwrap_or_default())
        .strategy(args.strategy);
    if let Some(n) = args.derivation_length {
        options = options.steps(n);
    }
    if let Some(s) = job.seed {
        options = options.seed(s);
    }
    options = options.first_step(args.first_step);
    if let Some(d) = &args.tmpdir {
        options = options.tmpdir(d);
    }
    if let Some(p) = args.precision {
        options = options.precision(p);
    }
    // One derivation on -j threads (default: all CPUs); a batch's jobs
    // already run in parallel, one thread each.
    if batch.is_none() {
        options = match args.jobs {
            Some(j) => options.threads(j as usize),
            None => options.threads_all(),
        };
    }
    // A `.l` file without a seed uses none; lsgen has always said 0 for
    // it (in `-v`, `{seed}` and a job's label), and still does.
    let seed = ls.seed(&options).unwrap_or(0);
    let batch = batch.map(|used| *used = Some(seed)).is_some();
    // In a batch, -v lines name their job.
    let who = if batch {
        format!("{}: ", job.label(Some(seed)))
    } else {
        String::new()
    };
    if args.verbose {
        crate::diag::eprint(&format!("lsgen: {who}seed {seed}\n"));
    }
    let stem = template::stem(job.file);
    // Frames to files (`-o` with `{n}`) open their own outputs, one per
    // frame; everything else has one output.
    let frame_files = template.filter(|t| args.frames.is_some() && t.uses(Field::N));
    let output = match template {
        _ if frame_files.is_some() => None,
        Some(t) => {
            let path = t.expand(&Vars {
                stem: Some(&stem),
                seed: Some(seed),
                n: None,
            })?;
            Some(output_file(&path, job.inputs)?)
        }
        None => Some(Output::stdout()?),
    };
    if let Some(space) = output.as_ref().and_then(Output::free_space) {
        options = options.free_space(space);
    }
    if let Some(switch) = output.as_ref().and_then(Output::direct_switch) {
        options = options.direct_output(switch);
    }
    if let Some(p) = &args.axiom {
        ls.set_axiom(open_input(Some(p.as_path()))?);
    }
    let out_name = output.as_ref().map_or_else(String::new, Output::name);
    // Progress: one display per run, not per job of a batch.
    let to_stdout = matches!(output, Some(Output::Stdout(_)));
    let display = (!batch
        && crate::progress::wanted(args.progress, args.quiet, args.verbose, to_stdout))
    .then(|| {
        // The steps this run derives: up to the last frame with --frames.
        let steps = args.frames.map_or_else(|| ls.steps(&options), |f| f.last());
        crate::progress::Derivation::start(steps)
    });
    let _installed = display
        .as_ref()
        .map(|d| crate::derive::meter::install(d.meter.clone()));
    let mut report = |e: &Event| {
        if let (
            Some(d),
            Event::Generation {
                pass: Pass::Step(k),
                ..
            },
        ) = (&display, e)
        {
            // (Counted from this run's first step: `--first-step`.)
            let done = k.saturating_sub(args.first_step.saturating_sub(1));
            d.done.store(done, std::sync::atomic::Ordering::Relaxed);
        }
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
                format!(
                    "lsgen: {who}{what}: {}, {}\n",
                    counted(modules, "module"),
                    counted(bytes, "byte")
                )
            }
            Event::FixedPoint { from, to } => {
                format!("lsgen: {who}steps {from}..{to}: unchanged (fixed point)\n")
            }
            // Printed as they are found (`print_warnings`).
            Event::Warning(_) | Event::Printf(_) => return,
        };
        crate::diag::eprint(&line);
    };
    let mut output = match output {
        Some(o) => o,
        None => {
            let (frames, template) = args.frames.zip(frame_files).expect("frames to files");
            // A batch that knew every seed has looked its frames up already.
            if !batch || args.seed.is_none() && template.uses(Field::Seed) {
                let stems = [stem.clone()];
                let ranges = template::Ranges {
                    stems: &stems,
                    seeds: Some((seed, 1)),
                    frames: Some((frames.from, frames.count(), frames.every)),
                };
                files_apart(template, &ranges, |v| {
                    format!("generation {}", v.n.unwrap_or_default())
                })?;
            }
            let mut files = FileFrames {
                template,
                stem: &stem,
                seed,
                inputs: job.inputs,
            };
            return derive_frames(
                &mut ls,
                &options,
                args.verbose,
                &mut report,
                frames,
                &mut files,
            );
        }
    };
    if let Some(frames) = args.frames {
        let mut stream = StreamFrames {
            out: output.writer(),
            name: out_name.clone(),
        };
        derive_frames(
            &mut ls,
            &options,
            args.verbose,
            &mut report,
            frames,
            &mut stream,
        )?;
        return output.commit();
    }
    ls.run(
        &options,
        output.writer(),
        &out_name,
        args.verbose,
        &mut report,
        None,
    )?;
    drop(_installed);
    drop(display);
    output.commit()
}

/// Derive once and write `frames` to `sink`, one output per frame; the
/// derivation's own output is discarded.
fn derive_frames(
    ls: &mut LSystem,
    options: &Options,
    verbose: bool,
    report: &mut dyn FnMut(&Event),
    frames: Frames,
    sink: &mut dyn FrameSink,
) -> Result<(), Error> {
    ls.run(
        options,
        io::sink(),
        "",
        verbose,
        report,
        Some((frames, sink)),
    )?;
    Ok(())
}

/// The binaries' global allocator: the system's, except that a failed
/// allocation ends the process with one line (`PROGRAM: error: out of
/// memory ...`) and exit status 1 instead of Rust's abort (exit 134). It
/// writes with `write(2)` and allocates nothing; unnamed temporary files
/// vanish with the process, and a named `-o` temporary file is removed by
/// the next run (README, "Leftover temporary files").
pub struct ExitOnOom(pub &'static str);

impl ExitOnOom {
    #[cold]
    fn fail(&self, size: usize) -> ! {
        use std::sync::atomic::{AtomicBool, Ordering};
        static FAILED: AtomicBool = AtomicBool::new(false);
        if FAILED.swap(true, Ordering::SeqCst) {
            // Another thread is saying it and ending the process: two
            // threads out of memory at once used to interleave their
            // pieces of the line (`lsgenlsgen: error: ...`).
            loop {
                // SAFETY: waits for a signal; the process ends first.
                unsafe { libc::pause() };
            }
        }
        // The line in one buffer (no allocation), written in one call.
        let mut line = [0u8; 192];
        let mut len = 0;
        let mut put = |b: &[u8]| {
            let n = b.len().min(line.len() - len);
            line[len..len + n].copy_from_slice(&b[..n]);
            len += n;
        };
        let mut digits = [0u8; 20];
        let mut i = digits.len();
        let mut n = size;
        loop {
            i -= 1;
            digits[i] = b'0' + (n % 10) as u8;
            n /= 10;
            if n == 0 {
                break;
            }
        }
        put(&self.0.as_bytes()[..self.0.len().min(64)]);
        put(b": error: out of memory (");
        put(&digits[i..]);
        put(b" more bytes wanted; see `ulimit -v`)\n");
        // SAFETY: writing a valid buffer to descriptor 2; errors ignored.
        let _ = unsafe { libc::write(2, line.as_ptr().cast(), len) };
        // SAFETY: ending the process without running anything else.
        unsafe { libc::_exit(1) }
    }
}

// SAFETY: every call is forwarded to the system allocator; a null result
// never returns (the process ends).
unsafe impl std::alloc::GlobalAlloc for ExitOnOom {
    unsafe fn alloc(&self, l: std::alloc::Layout) -> *mut u8 {
        let p = std::alloc::System.alloc(l);
        if p.is_null() {
            self.fail(l.size());
        }
        p
    }
    unsafe fn alloc_zeroed(&self, l: std::alloc::Layout) -> *mut u8 {
        let p = std::alloc::System.alloc_zeroed(l);
        if p.is_null() {
            self.fail(l.size());
        }
        p
    }
    unsafe fn realloc(&self, p: *mut u8, l: std::alloc::Layout, size: usize) -> *mut u8 {
        let q = std::alloc::System.realloc(p, l, size);
        if q.is_null() {
            self.fail(size);
        }
        q
    }
    unsafe fn dealloc(&self, p: *mut u8, l: std::alloc::Layout) {
        std::alloc::System.dealloc(p, l)
    }
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
