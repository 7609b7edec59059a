//! The lsgen benchmark suite.
//!
//! ```text
//! cargo bench --bench suite                 # 10^6 .. 10^9 output modules
//! cargo bench --bench suite -- --quick      # 10^6 and 10^7 only (about a minute)
//! cargo bench --bench suite -- --max 1e8    # stop at 10^8
//! cargo bench --bench suite -- --only koch_snowflake,plant_d
//! ```
//!
//! It builds nothing itself: it runs the release binary of lsgen (the one
//! cargo builds for `cargo bench`) as a child process on each workload of
//! `benches/workloads/*.ls`, for each size, choosing `-n` so that the final
//! string is close to the size. Each run writes a real file (`-o`) in a
//! scratch directory that also holds the temporary generations (`--tmpdir`);
//! files are deleted right after each run.
//!
//! Measured per run: wall time of the child (`std::time::Instant` around
//! spawn and wait), its user+system time and peak RSS (GNU `time -f`, the
//! child's rusage), the final module count (from `lsgen -v`) and the size
//! of the output file. The I/O floor is measured in the same run, right
//! after each lsgen run: this program re-invokes itself as a child
//! (`suite --floor BYTES PATH`) to write as many bytes as lsgen's output
//! into a new file in the same directory, a 1 MiB buffer at a time with
//! `File::write_all`, then `sync_all` (lsgen also syncs its output before
//! putting it in place). ratio = lsgen seconds / floor seconds.
//!
//! The Markdown report goes to standard output and to
//! `target/bench-results.md`; progress goes to standard error.
//!
//! Run without `--bench` (as `cargo test --benches` does) it only checks
//! that every workload file parses (`lsgen --check`).

use std::collections::BTreeMap;
use std::ffi::OsString;
use std::fmt::Write as _;
use std::fs::{self, File};
use std::io::Write as _;
use std::path::{Path, PathBuf};
use std::process::{Command, ExitCode, Stdio};
use std::time::Instant;

/// Nominal sizes: output modules of the final string.
const SIZES: [u64; 4] = [1_000_000, 10_000_000, 100_000_000, 1_000_000_000];

/// Repetitions of a run (the best is kept) by expected output size; the
/// I/O floor, cheap, is always measured at least 3 times.
/// A run's (wall s, cpu s, peak RSS KiB), as [`timed`] measures it.
type Timed = (f64, Option<f64>, Option<u64>);

/// Repetitions of each threads row (`-j 1`, `-j 2` and the pair,
/// interleaved), whatever its size: one or two runs of a 10^9 row met or
/// missed 1.7 by which minute of the machine they fell on.
const THREADS_REPS: u32 = 3;

fn default_reps(approx: u64) -> u32 {
    match approx {
        0..=20_000_000 => 3,
        20_000_001..=200_000_000 => 2,
        _ => 1,
    }
}

#[derive(Clone, Copy, PartialEq, Eq, Debug)]
enum Class {
    /// Context-free, deterministic, no parameters (bracketed or not).
    D0l,
    Parametric,
    Stochastic,
    Context,
    Homomorphism,
    /// Issue 11: decomposition, the cut.
    Structural,
}

impl Class {
    fn label(self) -> &'static str {
        match self {
            Class::D0l => "D0L",
            Class::Parametric => "parametric",
            Class::Stochastic => "stochastic",
            Class::Context => "context",
            Class::Homomorphism => "homomorphism",
            Class::Structural => "structural",
        }
    }

    /// Throughput target in modules/s, and whether it is stated by the
    /// issue (false: assumed here).
    fn speed_target(self) -> (f64, bool) {
        match self {
            Class::D0l => (300e6, true),
            Class::Parametric | Class::Stochastic | Class::Context => (30e6, true),
            Class::Homomorphism | Class::Structural => (30e6, false),
        }
    }

    /// Maximum ratio to the I/O floor, where the issue sets one.
    fn floor_target(self) -> Option<f64> {
        match self {
            Class::D0l => Some(3.0),
            _ => None,
        }
    }
}

/// Peak RSS target (KiB), for every workload.
const RSS_TARGET_KIB: u64 = 16 * 1024;

struct Workload {
    name: &'static str,
    class: Class,
    /// The L-system, in benches/workloads/.
    file: &'static str,
    /// Setup, not timed: an L-system in benches/workloads/ whose output
    /// becomes the `--axiom` of the timed run.
    axiom_gen: Option<&'static str>,
    /// With `axiom_gen`: the fixed `-n` of the timed run.
    steps: u64,
    /// Per size of [`SIZES`]: the `-n` (of the timed run, or of the axiom
    /// generator) and the approximate final module count it gives (used
    /// only to predict time and disk use; the table shows the real count).
    plan: [(u64, u64); 4],
}

const WORKLOADS: &[Workload] = &[
    Workload {
        name: "koch_snowflake",
        class: Class::D0l,
        file: "koch_snowflake.ls",
        axiom_gen: None,
        steps: 0,
        plan: [
            (9, 1_835_008),
            (10, 7_340_032),
            (12, 117_440_512),
            (14, 1_879_048_192),
        ],
    },
    Workload {
        name: "dragon_curve",
        class: Class::D0l,
        file: "dragon_curve.ls",
        axiom_gen: None,
        steps: 0,
        plan: [
            (18, 1_048_574),
            (21, 8_388_606),
            (25, 134_217_726),
            (28, 1_073_741_822),
        ],
    },
    Workload {
        name: "plant_d (bracketed)",
        class: Class::D0l,
        file: "plant_d.ls",
        axiom_gen: None,
        steps: 0,
        plan: [
            (11, 1_147_356),
            (13, 10_346_712),
            (15, 93_202_356),
            (17, 839_000_000),
        ],
    },
    Workload {
        name: "parametric_tree",
        class: Class::Parametric,
        file: "parametric_tree.ls",
        axiom_gen: None,
        steps: 0,
        plan: [
            (11, 885_731),
            (13, 7_971_611),
            (16, 143_489_066),
            (18, 1_000_000_000),
        ],
    },
    Workload {
        name: "parametric_tree.l (cpfg dialect)",
        class: Class::Parametric,
        file: "parametric_tree.l",
        axiom_gen: None,
        steps: 0,
        plan: [
            (11, 885_731),
            (13, 7_971_611),
            (16, 143_489_066),
            (18, 1_000_000_000),
        ],
    },
    Workload {
        name: "stochastic_plant",
        class: Class::Stochastic,
        file: "stochastic_plant.ls",
        axiom_gen: None,
        steps: 0,
        plan: [
            (10, 779_316),
            (12, 10_436_326),
            (14, 139_839_656),
            (16, 1_870_000_000),
        ],
    },
    Workload {
        name: "context_signal (ignore:, 1 step)",
        class: Class::Context,
        file: "context_signal.ls",
        axiom_gen: Some("signal_axiom.ls"),
        steps: 1,
        plan: [
            (11, 1_328_584),
            (13, 11_957_416),
            (15, 107_616_000),
            (17, 968_500_000),
        ],
    },
    Workload {
        name: "context_signal (ignore:, 3 steps)",
        class: Class::Context,
        file: "context_signal.ls",
        axiom_gen: Some("signal_axiom.ls"),
        steps: 3,
        plan: [
            (11, 1_751_000),
            (13, 15_766_000),
            (15, 141_900_000),
            (17, 1_277_000_000),
        ],
    },
    Workload {
        name: "skip_branches (A > B)",
        class: Class::Context,
        file: "skip_branches.ls",
        axiom_gen: Some("skip_axiom.ls"),
        steps: 1,
        plan: [
            (11, 797_158),
            (13, 7_174_453),
            (15, 64_570_081),
            (18, 1_743_392_200),
        ],
    },
    Workload {
        name: "koch_homomorphism",
        class: Class::Homomorphism,
        file: "koch_homomorphism.ls",
        axiom_gen: None,
        steps: 0,
        plan: [
            (8, 655_360),
            (10, 10_485_760),
            (12, 167_772_160),
            (13, 671_088_640),
        ],
    },
    Workload {
        name: "shedding_decomposition (decomposition, %)",
        class: Class::Structural,
        file: "shedding_decomposition.ls",
        axiom_gen: None,
        steps: 0,
        plan: [
            (11, 1_942_000),
            (13, 17_478_000),
            (15, 157_300_000),
            (17, 1_416_000_000),
        ],
    },
];

struct Options {
    max: u64,
    only: Option<Vec<String>>,
    reps: Option<u32>,
    cap_secs: f64,
    dir: Option<PathBuf>,
    command: String,
}

const USAGE: &str = "\
usage: cargo bench --bench suite [-- OPTIONS]
  --quick          sizes 10^6 and 10^7 only (same as --max 1e7)
  --max SIZE       largest size, e.g. 1e8 (default 1e9)
  --only A,B       only the workloads whose name starts with A or B
  --reps N         repetitions of every run, the best kept (default: 3 up to
                   2e7 modules, 2 up to 2e8, 1 above; threads rows: 3)
  --cap-secs S     skip a size predicted to take longer than S seconds (default 180)
  --dir DIR        scratch directory for outputs and temp files (default $TMPDIR)
  --floor BYTES PATH   (internal) write BYTES bytes to PATH: the I/O floor";

fn main() -> ExitCode {
    let args: Vec<String> = std::env::args().skip(1).collect();
    if args.first().map(String::as_str) == Some("--floor") {
        return floor_mode(&args[1..]);
    }
    let bench_mode = args.iter().any(|a| a == "--bench");
    let opts = match parse_options(&args) {
        Ok(o) => o,
        Err(e) if e == "help" => {
            println!("{USAGE}");
            return ExitCode::SUCCESS;
        }
        Err(e) => {
            eprintln!("suite: {e}\n{USAGE}");
            return ExitCode::from(2);
        }
    };
    let bin = match lsgen_binary() {
        Ok(b) => b,
        Err(e) => {
            eprintln!("suite: {e}");
            return ExitCode::FAILURE;
        }
    };
    let result = if bench_mode {
        run_suite(&bin, &opts)
    } else {
        check_workloads(&bin)
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("suite: {e}");
            ExitCode::FAILURE
        }
    }
}

fn parse_size(s: &str) -> Result<u64, String> {
    let t = s.replace('_', "").replace("10^", "1e");
    t.parse::<u64>()
        .ok()
        .or_else(|| {
            t.parse::<f64>()
                .ok()
                .filter(|f| f.is_finite() && *f >= 1.0)
                .map(|f| f.round() as u64)
        })
        .ok_or_else(|| format!("`{s}` is not a size (e.g. 1e8)"))
}

fn parse_options(args: &[String]) -> Result<Options, String> {
    let mut o = Options {
        max: SIZES[SIZES.len() - 1],
        only: None,
        reps: None,
        cap_secs: 180.0,
        dir: None,
        command: "cargo bench --bench suite".to_string(),
    };
    let mut shown = Vec::new();
    let mut it = args.iter();
    while let Some(a) = it.next() {
        let mut value = |name: &str| {
            it.next()
                .cloned()
                .ok_or_else(|| format!("{name} needs a value"))
        };
        match a.as_str() {
            // Passed by `cargo bench`; a bare word is cargo's name filter.
            "--bench" => continue,
            "--quick" => o.max = 10_000_000,
            "--max" => {
                let v = value(a)?;
                o.max = parse_size(&v)?;
                shown.push(format!("--max {v}"));
                continue;
            }
            "--only" => {
                let v = value(a)?;
                o.only = Some(v.split(',').map(str::to_string).collect());
                shown.push(format!("--only {v}"));
                continue;
            }
            "--reps" => {
                let v = value(a)?;
                let n: u32 = v.parse().map_err(|_| format!("bad --reps `{v}`"))?;
                o.reps = Some(n.max(1));
                shown.push(format!("--reps {v}"));
                continue;
            }
            "--cap-secs" => {
                let v = value(a)?;
                o.cap_secs = v.parse().map_err(|_| format!("bad --cap-secs `{v}`"))?;
                shown.push(format!("--cap-secs {v}"));
                continue;
            }
            "--dir" => {
                let v = value(a)?;
                o.dir = Some(PathBuf::from(&v));
                shown.push(format!("--dir {v}"));
                continue;
            }
            "-h" | "--help" => return Err("help".into()),
            other => return Err(format!("unknown argument `{other}`")),
        }
        shown.push(a.clone());
    }
    if !shown.is_empty() {
        o.command = format!("{} -- {}", o.command, shown.join(" "));
    }
    Ok(o)
}

/// The lsgen binary: the one cargo built for this bench (release profile
/// under `cargo bench`), else target/release/lsgen, built if missing.
fn lsgen_binary() -> Result<PathBuf, String> {
    if let Some(p) = option_env!("CARGO_BIN_EXE_lsgen") {
        if Path::new(p).exists() {
            return Ok(PathBuf::from(p));
        }
    }
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let p = root.join("target/release/lsgen");
    if !p.exists() {
        let st = Command::new(std::env::var_os("CARGO").unwrap_or_else(|| "cargo".into()))
            .args(["build", "--release", "--bin", "lsgen"])
            .current_dir(root)
            .status()
            .map_err(|e| format!("cannot run cargo build: {e}"))?;
        if !st.success() || !p.exists() {
            return Err("cargo build --release failed".into());
        }
    }
    Ok(p)
}

fn workload_path(file: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("benches/workloads")
        .join(file)
}

/// Test mode: every workload file must parse.
fn check_workloads(bin: &Path) -> Result<(), String> {
    let mut files: Vec<&str> = WORKLOADS.iter().map(|w| w.file).collect();
    files.extend(WORKLOADS.iter().filter_map(|w| w.axiom_gen));
    for f in files {
        let out = Command::new(bin)
            .arg(workload_path(f))
            .arg("--check")
            .output()
            .map_err(|e| format!("cannot run {}: {e}", bin.display()))?;
        if !out.status.success() {
            return Err(format!(
                "{f}: {}",
                String::from_utf8_lossy(&out.stderr).trim()
            ));
        }
    }
    println!(
        "suite: workload files ok; run the benchmarks with `cargo bench --bench suite` \
         (`-- --quick` for a short run)"
    );
    Ok(())
}

/// `--floor BYTES PATH`: write BYTES bytes to a new file PATH, 1 MiB at a
/// time, and sync it. Timed by the parent, like lsgen.
fn floor_mode(args: &[String]) -> ExitCode {
    let (Some(bytes), Some(path)) = (args.first(), args.get(1)) else {
        eprintln!("suite: --floor BYTES PATH");
        return ExitCode::from(2);
    };
    let Ok(mut left) = bytes.parse::<u64>() else {
        eprintln!("suite: bad byte count `{bytes}`");
        return ExitCode::from(2);
    };
    let buf = vec![b'F'; 1 << 20];
    let r = File::create(path).and_then(|mut f| {
        while left > 0 {
            let k = left.min(buf.len() as u64) as usize;
            f.write_all(&buf[..k])?;
            left -= k as u64;
        }
        f.sync_all()
    });
    match r {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("suite: {path}: {e}");
            ExitCode::FAILURE
        }
    }
}

/// One timed lsgen run.
#[derive(Clone, Default)]
struct Run {
    wall: f64,
    cpu: Option<f64>,
    rss_kib: Option<u64>,
    final_modules: u64,
    /// All generations written, the axiom (generation 0) included.
    all_modules: u64,
    bytes: u64,
}

/// A row of the table.
struct Row {
    workload: &'static str,
    class: Class,
    size: u64,
    n_label: String,
    run: Run,
    floor: f64,
}

struct Skip {
    workload: &'static str,
    size: u64,
    why: String,
}

fn run_suite(bin: &Path, o: &Options) -> Result<(), String> {
    let gnu_time = find_gnu_time();
    if gnu_time.is_none() {
        eprintln!("suite: GNU time (/usr/bin/time) not found: no peak RSS or cpu time");
    }
    let base = o.dir.clone().unwrap_or_else(std::env::temp_dir);
    let scratch = base.join(format!("lsgen-bench-{}", std::process::id()));
    fs::create_dir_all(&scratch).map_err(|e| format!("{}: {e}", scratch.display()))?;
    let header = describe(bin, o, &scratch, gnu_time.is_some());
    eprint!("{header}");
    // Run a copy: a concurrent `cargo build` must not swap the binary mid-run.
    let copy = scratch.join("lsgen");
    let res = fs::copy(bin, &copy)
        .map_err(|e| format!("cannot copy {}: {e}", bin.display()))
        .and_then(|_| run_all(&copy, o, &scratch, gnu_time.as_deref()))
        .and_then(|r| Ok((r, run_turtle(&copy, o, &scratch, gnu_time.as_deref())?)))
        .and_then(|(r, t)| Ok((r, t + &run_forest(&copy, o, &scratch)?)))
        .and_then(|(r, t)| {
            let threads = run_threads(&copy, o, &scratch, gnu_time.as_deref())?;
            Ok((r, t + &threads))
        })
        .and_then(|r| Ok((r, run_frames(&copy, o, &scratch, gnu_time.as_deref())?)));
    let _ = fs::remove_dir_all(&scratch);
    let (((rows, skips), turtle), frames) = res?;
    let mut md = header;
    md.push_str(&table(&rows, &skips));
    md.push_str(&turtle);
    md.push_str(&frames);
    print!("{md}");
    let target = Path::new(env!("CARGO_MANIFEST_DIR")).join("target");
    let _ = fs::create_dir_all(&target);
    let path = target.join("bench-results.md");
    fs::write(&path, &md).map_err(|e| format!("{}: {e}", path.display()))?;
    eprintln!("suite: written to {}", path.display());
    Ok(())
}

/// Is the row or workload `name` selected by `--only`?
fn selected(o: &Options, name: &str) -> bool {
    o.only
        .as_ref()
        .is_none_or(|v| v.iter().any(|p| name.starts_with(p.as_str())))
}

fn run_all(
    bin: &Path,
    o: &Options,
    scratch: &Path,
    gnu_time: Option<&Path>,
) -> Result<(Vec<Row>, Vec<Skip>), String> {
    let mut rows = Vec::new();
    let mut skips = Vec::new();
    let out = scratch.join("out.txt");
    let floor_out = scratch.join("floor.txt");
    let axiom = scratch.join("axiom.txt");
    for w in WORKLOADS.iter().filter(|w| selected(o, w.name)) {
        let mut prev: Option<(f64, f64)> = None; // (modules/s, bytes/module)
        for (i, &size) in SIZES.iter().enumerate() {
            if size > o.max {
                break;
            }
            let (n, approx) = w.plan[i];
            // Predict time and disk use from the previous size.
            if let Some((speed, bpm)) = prev {
                let secs = approx as f64 / speed;
                if secs > o.cap_secs {
                    skips.push(Skip {
                        workload: w.name,
                        size,
                        why: format!(
                            "predicted {secs:.0} s (at {:.1} M modules/s) > cap {:.0} s",
                            speed / 1e6,
                            o.cap_secs
                        ),
                    });
                    break;
                }
                let need = (approx as f64 * bpm * 4.0) as u64;
                if let Some(free) = free_bytes(scratch) {
                    if need > free {
                        skips.push(Skip {
                            workload: w.name,
                            size,
                            why: format!(
                                "needs about {} GB of disk, {} GB free",
                                need / 1_000_000_000,
                                free / 1_000_000_000
                            ),
                        });
                        break;
                    }
                }
            }
            let reps = o.reps.unwrap_or_else(|| default_reps(approx));
            let mut args: Vec<OsString> = vec![workload_path(w.file).into()];
            let n_label = if let Some(gen) = w.axiom_gen {
                eprintln!("suite: {} 1e{}: setup: axiom -n {n}", w.name, log10(size));
                let setup: Vec<OsString> = vec![
                    workload_path(gen).into(),
                    "-n".into(),
                    n.to_string().into(),
                    "-o".into(),
                    axiom.clone().into(),
                    "--tmpdir".into(),
                    scratch.into(),
                ];
                let st = Command::new(bin)
                    .args(&setup)
                    .stdout(Stdio::null())
                    .status()
                    .map_err(|e| format!("cannot run {}: {e}", bin.display()))?;
                if !st.success() {
                    return Err(format!("{}: axiom generation failed", w.name));
                }
                args.extend(["--axiom".into(), axiom.clone().into()]);
                args.extend(["-n".into(), w.steps.to_string().into()]);
                format!("{} (axiom -n {n})", w.steps)
            } else {
                args.extend(["-n".into(), n.to_string().into()]);
                n.to_string()
            };
            args.extend([
                "-o".into(),
                out.clone().into(),
                "--tmpdir".into(),
                scratch.into(),
                "-v".into(),
            ]);
            let mut best: Option<Run> = None;
            let mut best_floor = f64::INFINITY;
            for rep in 0..reps {
                let r = run_lsgen(bin, &args, &out, gnu_time)?;
                let _ = fs::remove_file(&out);
                let mut f = f64::INFINITY;
                for _ in 0..3u32.div_ceil(reps) {
                    f = f.min(run_floor(r.bytes, &floor_out)?);
                    let _ = fs::remove_file(&floor_out);
                }
                eprintln!(
                    "suite: {} 1e{} [{}/{reps}]: n {n_label}: {} modules, {} bytes, {:.3} s \
                     ({:.1} M/s), rss {} KiB; floor {:.3} s",
                    w.name,
                    log10(size),
                    rep + 1,
                    r.final_modules,
                    r.bytes,
                    r.wall,
                    r.final_modules as f64 / r.wall / 1e6,
                    r.rss_kib.map_or("?".into(), |k| k.to_string()),
                    f
                );
                best_floor = best_floor.min(f);
                if best.as_ref().is_none_or(|b| r.wall < b.wall) {
                    best = Some(r);
                }
            }
            let _ = fs::remove_file(&axiom);
            let run = best.expect("at least one repetition");
            prev = Some((
                run.final_modules as f64 / run.wall,
                run.bytes as f64 / run.final_modules.max(1) as f64,
            ));
            rows.push(Row {
                workload: w.name,
                class: w.class,
                size,
                n_label,
                run,
                floor: best_floor,
            });
        }
    }
    Ok((rows, skips))
}

/// lsgen-turtle rows: a 10^7-module string (plant_d, n = 13, derived
/// once, untimed, into a file) drawn to SVG and to PNG at the default size.
const TURTLE_ROWS: [(&str, &str); 2] = [
    ("turtle_svg (plant_d, 10^7 modules)", "svg"),
    ("turtle_png (plant_d, 10^7 modules)", "png"),
];

fn turtle_binary() -> Result<PathBuf, String> {
    if let Some(p) = option_env!("CARGO_BIN_EXE_lsgen-turtle") {
        if Path::new(p).exists() {
            return Ok(PathBuf::from(p));
        }
    }
    let p = Path::new(env!("CARGO_MANIFEST_DIR")).join("target/release/lsgen-turtle");
    if p.exists() {
        Ok(p)
    } else {
        Err("no lsgen-turtle binary: cargo build --release".into())
    }
}

fn run_turtle(
    lsgen: &Path,
    o: &Options,
    scratch: &Path,
    gnu_time: Option<&Path>,
) -> Result<String, String> {
    let rows: Vec<_> = TURTLE_ROWS
        .iter()
        .filter(|(name, _)| selected(o, name))
        .collect();
    if rows.is_empty() || o.max < 10_000_000 {
        return Ok(String::new());
    }
    let turtle = scratch.join("lsgen-turtle");
    fs::copy(turtle_binary()?, &turtle).map_err(|e| format!("cannot copy lsgen-turtle: {e}"))?;
    let model = Path::new(env!("CARGO_MANIFEST_DIR")).join("examples/plant_d.ls");
    let string = scratch.join("string.txt");
    eprintln!("suite: turtle: setup: lsgen -n 13 examples/plant_d.ls");
    let st = Command::new(lsgen)
        .arg(&model)
        .args(["-n", "13", "-o"])
        .arg(&string)
        .status()
        .map_err(|e| format!("cannot run lsgen: {e}"))?;
    if !st.success() {
        return Err("turtle: string generation failed".into());
    }
    let text = fs::read(&string).map_err(|e| format!("{}: {e}", string.display()))?;
    let modules = text.iter().filter(|&&b| b != b'\n').count() as u64;
    drop(text);
    let mut md = String::from(
        "\n### lsgen-turtle\n\n\
         The string is derived once into a file (untimed); each run reads it twice \
         (bounding box, then drawing) and writes the picture with `-o` at the default \
         `--size 800`.\n\n\
         | row | modules | wall s | M modules/s | cpu s | peak RSS MiB | output bytes |\n\
         |---|--:|--:|--:|--:|--:|--:|\n",
    );
    for (name, ext) in rows {
        let out = scratch.join(format!("out.{ext}"));
        let time_file = scratch.join("turtle.time");
        let reps = o.reps.unwrap_or(3);
        let mut best: Option<(f64, Option<f64>, Option<u64>, u64)> = None;
        for rep in 0..reps {
            let mut cmd = match gnu_time {
                Some(t) => {
                    let mut c = Command::new(t);
                    c.args(["-f", "%U %S %M", "-o"])
                        .arg(&time_file)
                        .arg(&turtle);
                    c
                }
                None => Command::new(&turtle),
            };
            cmd.arg(&string).arg("--ls").arg(&model).arg("-o").arg(&out);
            let t0 = Instant::now();
            let r = cmd
                .stdin(Stdio::null())
                .output()
                .map_err(|e| format!("cannot run lsgen-turtle: {e}"))?;
            let wall = t0.elapsed().as_secs_f64();
            if !r.status.success() {
                return Err(format!(
                    "lsgen-turtle failed: {}",
                    String::from_utf8_lossy(&r.stderr).trim()
                ));
            }
            let bytes = fs::metadata(&out).map(|m| m.len()).unwrap_or(0);
            let _ = fs::remove_file(&out);
            let t = fs::read_to_string(&time_file).unwrap_or_default();
            let v: Vec<&str> = t
                .lines()
                .last()
                .unwrap_or_default()
                .split_whitespace()
                .collect();
            let (cpu, rss) = match v[..] {
                [u, s, m] => (
                    u.parse::<f64>()
                        .ok()
                        .zip(s.parse::<f64>().ok())
                        .map(|(u, s)| u + s),
                    m.parse::<u64>().ok(),
                ),
                _ => (None, None),
            };
            eprintln!(
                "suite: {name} [{}/{reps}]: {wall:.3} s, rss {} KiB, {bytes} bytes",
                rep + 1,
                rss.map_or("?".into(), |k| k.to_string())
            );
            if best.as_ref().is_none_or(|b| wall < b.0) {
                best = Some((wall, cpu, rss, bytes));
            }
        }
        let (wall, cpu, rss, bytes) = best.expect("at least one repetition");
        let _ = writeln!(
            md,
            "| {name} | {modules} | {wall:.3} | {:.1} | {} | {} | {bytes} |",
            modules as f64 / wall / 1e6,
            cpu.map_or("?".into(), |c| format!("{c:.3}")),
            rss.map_or("?".into(), |k| format!("{:.1}", k as f64 / 1024.0)),
        );
    }
    Ok(md)
}

/// `--frames` rows (issue 13): (row, workload, frames, the last frame's
/// `-n`). Each writes its frames to files through an `-o` template and is
/// compared with one run of `-n LAST` (the last frame alone).
const FRAME_ROWS: [(&str, &str, &str, u64); 3] = [
    (
        "frames stochastic_plant 0..12",
        "stochastic_plant.ls",
        "0..12",
        12,
    ),
    (
        "frames stochastic_plant 4..12:4",
        "stochastic_plant.ls",
        "4..12:4",
        12,
    ),
    ("frames plant_d 0..13", "plant_d.ls", "0..13", 13),
];

/// One timed run of `bin ARGS` (stdout discarded): wall s, cpu s, peak
/// RSS KiB.
fn timed(
    bin: &Path,
    args: &[OsString],
    time_file: &Path,
    gnu_time: Option<&Path>,
) -> Result<Timed, String> {
    let mut cmd = match gnu_time {
        Some(t) => {
            let mut c = Command::new(t);
            c.args(["-f", "%U %S %M", "-o"]).arg(time_file).arg(bin);
            c
        }
        None => Command::new(bin),
    };
    cmd.args(args).stdin(Stdio::null()).stdout(Stdio::null());
    let t0 = Instant::now();
    let r = cmd
        .output()
        .map_err(|e| format!("cannot run {}: {e}", bin.display()))?;
    let wall = t0.elapsed().as_secs_f64();
    if !r.status.success() {
        return Err(format!(
            "lsgen {args:?} failed: {}",
            String::from_utf8_lossy(&r.stderr).trim()
        ));
    }
    let t = fs::read_to_string(time_file).unwrap_or_default();
    let _ = fs::remove_file(time_file);
    let v: Vec<&str> = t
        .lines()
        .last()
        .unwrap_or_default()
        .split_whitespace()
        .collect();
    Ok(match v[..] {
        [u, s, m] => (
            wall,
            u.parse::<f64>()
                .ok()
                .zip(s.parse::<f64>().ok())
                .map(|(u, s)| u + s),
            m.parse::<u64>().ok(),
        ),
        _ => (wall, None, None),
    })
}

fn run_frames(
    lsgen: &Path,
    o: &Options,
    scratch: &Path,
    gnu_time: Option<&Path>,
) -> Result<String, String> {
    let rows: Vec<_> = FRAME_ROWS
        .iter()
        .filter(|(name, ..)| selected(o, name))
        .collect();
    if rows.is_empty() || o.max < 10_000_000 {
        return Ok(String::new());
    }
    let dir = scratch.join("frames");
    let time_file = scratch.join("frames.time");
    let mut md = String::from(
        "\n### Frames\n\n\
         `--frames` derives once and writes each frame to its own file through an `-o` \
         template; `-n LAST` is one run for the last frame alone, for comparison.\n\n\
         | row | frames | bytes of all frames | wall s | `-n LAST` wall s | ratio | cpu s | peak RSS MiB |\n\
         |---|--:|--:|--:|--:|--:|--:|--:|\n",
    );
    for &&(name, file, range, last) in &rows {
        let reps = o.reps.unwrap_or(3);
        let tmpdir: OsString = scratch.into();
        let mut frames_args: Vec<OsString> = vec![workload_path(file).into()];
        frames_args.extend(["--frames".into(), range.into(), "-o".into()]);
        frames_args.push(dir.join("f-{n}.txt").into());
        frames_args.extend(["--tmpdir".into(), tmpdir.clone()]);
        let out = scratch.join("out.txt");
        let mut single_args: Vec<OsString> = vec![workload_path(file).into()];
        single_args.extend(["-n".into(), last.to_string().into(), "-o".into()]);
        single_args.extend([out.clone().into(), "--tmpdir".into(), tmpdir]);
        let (mut best, mut best_single) = (None::<(f64, Option<f64>, Option<u64>)>, f64::INFINITY);
        let (mut count, mut bytes) = (0u64, 0u64);
        for rep in 0..reps {
            let _ = fs::remove_dir_all(&dir);
            fs::create_dir_all(&dir).map_err(|e| format!("{}: {e}", dir.display()))?;
            let r = timed(lsgen, &frames_args, &time_file, gnu_time)?;
            (count, bytes) = (0, 0);
            for e in fs::read_dir(&dir).map_err(|e| format!("{}: {e}", dir.display()))? {
                count += 1;
                bytes += e.and_then(|e| e.metadata()).map_or(0, |m| m.len());
            }
            let _ = fs::remove_dir_all(&dir);
            let single = timed(lsgen, &single_args, &time_file, gnu_time)?.0;
            let _ = fs::remove_file(&out);
            eprintln!(
                "suite: {name} [{}/{reps}]: {count} frames, {bytes} bytes, {:.3} s; -n {last}: {single:.3} s",
                rep + 1,
                r.0
            );
            best_single = best_single.min(single);
            if best.is_none_or(|b| r.0 < b.0) {
                best = Some(r);
            }
        }
        let (wall, cpu, rss) = best.expect("at least one repetition");
        let _ = writeln!(
            md,
            "| {name} | {count} | {bytes} | {wall:.3} | {best_single:.3} | {:.2} | {} | {} |",
            wall / best_single,
            cpu.map_or("?".into(), |c| format!("{c:.3}")),
            rss.map_or("?".into(), |k| format!("{:.1}", k as f64 / 1024.0)),
        );
    }
    Ok(md)
}

/// Seed batches (issue 13): a 100-seed forest of stochastic_plant.ls, one
/// file per seed, at `-j 1` and `-j 2`; target: `-j 2` at least 1.7 times
/// faster than `-j 1` on a machine with 2 free cores. And 10,000 tiny
/// jobs of the same model (`-n 3`, about 150 bytes each), where what a job costs
/// besides its derivation (files, buffers, the allocator) is the time.
fn run_forest(lsgen: &Path, o: &Options, scratch: &Path) -> Result<String, String> {
    let mut md = String::new();
    // (The tiny jobs have no target: their time is mostly the file
    // system's.)
    for (name, n, seeds, target) in [
        ("forest_100_seeds", "10", 100u32, true),
        ("forest_10000_tiny", "3", 10_000, false),
    ] {
        if selected(o, name) {
            md += &run_batch_row(lsgen, o, scratch, (name, n, seeds), target)?;
        }
    }
    Ok(md)
}

fn run_batch_row(
    lsgen: &Path,
    o: &Options,
    scratch: &Path,
    (name, n, seeds): (&str, &str, u32),
    target: bool,
) -> Result<String, String> {
    let model = workload_path("stochastic_plant.ls");
    let dir = scratch.join("forest");
    let range = format!("1..{seeds}");
    let mut md = format!(
        "\n### Seed batch\n\n\
         `lsgen -n {n} --seed {range} -o 'forest/{{seed}}.txt' stochastic_plant.ls`: {seeds} jobs, \
         one output file each (best wall time of the repetitions).\n\n\
         | row | jobs | wall s | speed-up over -j 1 | target |\n\
         |---|--:|--:|--:|---|\n",
    );
    let mut serial = None;
    for j in [1u32, 2] {
        let reps = o.reps.unwrap_or(3);
        let mut best = f64::INFINITY;
        for rep in 0..reps {
            let _ = fs::remove_dir_all(&dir);
            fs::create_dir_all(&dir).map_err(|e| format!("{}: {e}", dir.display()))?;
            let t0 = Instant::now();
            let r = Command::new(lsgen)
                .args(["-n", n, "--seed", &range, "-j", &j.to_string(), "-o"])
                .arg(dir.join("{seed}.txt"))
                .arg(&model)
                .stdin(Stdio::null())
                .output()
                .map_err(|e| format!("cannot run lsgen: {e}"))?;
            let wall = t0.elapsed().as_secs_f64();
            if !r.status.success() {
                return Err(format!(
                    "{name} -j {j} failed: {}",
                    String::from_utf8_lossy(&r.stderr).trim()
                ));
            }
            eprintln!("suite: {name} -j {j} [{}/{reps}]: {wall:.3} s", rep + 1);
            best = best.min(wall);
        }
        let _ = fs::remove_dir_all(&dir);
        let base = *serial.get_or_insert(best);
        let (speedup, target) = if j == 1 {
            ("1.00".to_string(), "")
        } else if !target {
            (format!("{:.2}", base / best), "")
        } else if base / best >= 1.7 {
            (format!("{:.2}", base / best), ">= 1.7: met")
        } else {
            (format!("{:.2}", base / best), ">= 1.7: MISSED")
        };
        let _ = writeln!(
            md,
            "| {name} -j {j} | {seeds} | {best:.3} | {speedup} | {target} |"
        );
    }
    Ok(md)
}

/// One string on 1 and 2 threads (issue 15): the workloads the parallel
/// derivation is for, without `-v` (which asks for every generation's
/// length and so keeps parametric systems step by step), at each size from
/// 10^7 up to `--max`. Rows named `threads ...` (`--only threads`).
fn run_threads(
    lsgen: &Path,
    o: &Options,
    scratch: &Path,
    gnu_time: Option<&Path>,
) -> Result<String, String> {
    const ROWS: [&str; 3] = [
        "parametric_tree",
        "stochastic_plant",
        "context_signal (ignore:, 3 steps)",
    ];
    let rows: Vec<&Workload> = WORKLOADS
        .iter()
        .filter(|w| ROWS.contains(&w.name) && selected(o, &format!("threads {}", w.name)))
        .collect();
    if rows.is_empty() || o.max < 10_000_000 {
        return Ok(String::new());
    }
    let out = scratch.join("out.txt");
    let axiom = scratch.join("axiom.txt");
    let time_file = scratch.join("threads.time");
    let mut md = String::from(
        "\n### One string on several threads\n\n\
         `-j 1` and `-j 2` on the same workload (no `-v`; best wall time of the \
         repetitions, 3 unless `--reps` says, each running `-j 1`, `-j 2` and \
         the pair below in turn). Depth-first parametric systems and step-by-step passes \
         (stochastic, and with contexts) split between threads (README, Design: \
         parallel derivation).\n\n\
         The last column is what the machine gave two independent threads right \
         after each `-j 2` run: two `-j 1` runs of the row started together, 2 × \
         the `-j 1` wall time over the later one's (about 2.00 if they did not \
         slow each other down; the best pair). \
         `-j 2` splits one run, with overheads of its own, so expect it near or \
         under that; where the pair got under 1.7, the machine could not give \
         1.7 at that moment.\n\n\
         | row | size | -n | wall s | cpu s | peak RSS MiB | speed-up over -j 1 | target | two -j 1 at once |\n\
         |---|---|---|--:|--:|--:|--:|---|--:|\n",
    );
    for w in rows {
        for (i, &size) in SIZES.iter().enumerate().skip(1) {
            if size > o.max {
                break;
            }
            let (n, _) = w.plan[i];
            let mut args: Vec<OsString> = vec![workload_path(w.file).into()];
            let n_label = if let Some(gen) = w.axiom_gen {
                let st = Command::new(lsgen)
                    .arg(workload_path(gen))
                    .args(["-n", &n.to_string(), "-o"])
                    .arg(&axiom)
                    .stdout(Stdio::null())
                    .status()
                    .map_err(|e| format!("cannot run {}: {e}", lsgen.display()))?;
                if !st.success() {
                    return Err(format!("{}: axiom generation failed", w.name));
                }
                args.extend(["--axiom".into(), axiom.clone().into()]);
                args.extend(["-n".into(), w.steps.to_string().into()]);
                format!("{} (axiom -n {n})", w.steps)
            } else {
                args.extend(["-n".into(), n.to_string().into()]);
                n.to_string()
            };
            args.extend(["-o".into(), out.clone().into()]);
            args.extend(["--tmpdir".into(), scratch.into()]);
            // One seed: every run must write the same string (checked).
            args.extend(["--seed".into(), "1".into()]);
            // Interleaved: each repetition runs `-j 1`, `-j 2` and the pair
            // in turn, so that a slow spell of the machine (minutes long,
            // as seen on this 2-CPU VM) falls on all three instead of on
            // the block of one of them.
            let reps = o.reps.unwrap_or(THREADS_REPS);
            let mut string = None;
            let mut best: [Option<Timed>; 2] = [None, None];
            let mut pair = f64::INFINITY;
            for rep in 0..reps {
                for j in [1u32, 2] {
                    let mut a = args.clone();
                    a.extend(["-j".into(), j.to_string().into()]);
                    let r = timed(lsgen, &a, &time_file, gnu_time)?;
                    let hash = hash_file(&out)?;
                    let _ = fs::remove_file(&out);
                    if *string.get_or_insert(hash) != hash {
                        return Err(format!(
                            "threads {} 1e{} -j {j}: not the string of -j 1",
                            w.name,
                            log10(size)
                        ));
                    }
                    eprintln!(
                        "suite: threads {} 1e{} -j {j} [{}/{reps}]: {:.3} s",
                        w.name,
                        log10(size),
                        rep + 1,
                        r.0
                    );
                    let b = &mut best[j as usize - 1];
                    if b.is_none_or(|b| r.0 < b.0) {
                        *b = Some(r);
                    }
                }
                let p = two_at_once(lsgen, &args, &out, scratch)?;
                eprintln!(
                    "suite: threads {} 1e{}: two -j 1 at once {p:.3} s",
                    w.name,
                    log10(size),
                );
                pair = pair.min(p);
            }
            let base = best[0].expect("at least one repetition").0;
            for j in [1u32, 2] {
                let (wall, cpu, rss) = best[j as usize - 1].expect("at least one repetition");
                let (speedup, target, ceiling) = if j == 1 {
                    ("1.00".to_string(), "", String::new())
                } else {
                    // `base` and `pair` are both bests of `reps` runs.
                    let met = if base / wall >= 1.7 {
                        ">= 1.7: met"
                    } else {
                        ">= 1.7: MISSED"
                    };
                    (
                        format!("{:.2}", base / wall),
                        met,
                        format!("{:.2}", 2.0 * base / pair),
                    )
                };
                let _ = writeln!(
                    md,
                    "| threads {} -j {j} | 10^{} | {n_label} | {wall:.3} | {} | {} | {speedup} | {target} | {ceiling} |",
                    w.name,
                    log10(size),
                    cpu.map_or("?".into(), |c| format!("{c:.2}")),
                    rss.map_or("?".into(), |k| format!("{:.1}", k as f64 / 1024.0)),
                );
            }
            let _ = fs::remove_file(&axiom);
        }
    }
    Ok(md)
}

/// Wall time until the later of two `-j 1` runs of lsgen with `args`
/// (whose `-o` is `out`; the second writes beside it), started together,
/// is done: what the machine gives two independent threads at that
/// moment.
fn two_at_once(lsgen: &Path, args: &[OsString], out: &Path, scratch: &Path) -> Result<f64, String> {
    let other = scratch.join("out-2.txt");
    let second: Vec<OsString> = args
        .iter()
        .map(|a| {
            if a.as_os_str() == out.as_os_str() {
                other.clone().into()
            } else {
                a.clone()
            }
        })
        .collect();
    let start = std::time::Instant::now();
    let run = |a: Vec<OsString>| {
        let bin = lsgen.to_path_buf();
        std::thread::spawn(move || {
            Command::new(bin)
                .args(&a)
                .args(["-j", "1"])
                .stdout(Stdio::null())
                .status()
        })
    };
    let (x, y) = (run(args.to_vec()), run(second));
    let results = [x.join(), y.join()];
    let wall = start.elapsed().as_secs_f64();
    let _ = fs::remove_file(out);
    let _ = fs::remove_file(&other);
    for r in results {
        match r {
            Ok(Ok(st)) if st.success() => {}
            _ => return Err("two -j 1 runs at once: a run failed".into()),
        }
    }
    Ok(wall)
}

/// A hash of the file's bytes, to tell that two runs wrote the same. Read
/// around the page cache (`O_DIRECT`) where the file system allows it: a
/// 1.3 GB output read back through the cache made the next `-j 2` run of
/// parametric_tree 2-3 s slower (11.9-13.1 s against 8.9-9.8 s, more
/// system time), though the file is removed before it, and dropping the
/// pages as they were read (`POSIX_FADV_DONTNEED`) did not help.
fn hash_file(path: &Path) -> Result<u64, String> {
    use std::hash::Hasher;
    use std::io::Read;
    use std::os::unix::fs::OpenOptionsExt;
    let err = |e: std::io::Error| format!("{}: {e}", path.display());
    let mut f = fs::OpenOptions::new()
        .read(true)
        .custom_flags(libc::O_DIRECT)
        .open(path)
        .or_else(|_| fs::File::open(path))
        .map_err(err)?;
    let mut h = std::collections::hash_map::DefaultHasher::new();
    // An aligned buffer, as O_DIRECT needs.
    const ALIGN: usize = 4096;
    let mut space = vec![0u8; (1 << 20) + ALIGN];
    let skip = space.as_ptr().align_offset(ALIGN);
    let buf = &mut space[skip..skip + (1 << 20)];
    loop {
        match f.read(buf) {
            Ok(0) => return Ok(h.finish()),
            Ok(n) => h.write(&buf[..n]),
            Err(e) if e.kind() == std::io::ErrorKind::Interrupted => {}
            Err(e) => return Err(err(e)),
        }
    }
}

fn log10(size: u64) -> u32 {
    size.ilog10()
}

fn find_gnu_time() -> Option<PathBuf> {
    let p = PathBuf::from("/usr/bin/time");
    let ok = Command::new(&p)
        .args(["-f", "%M", "-o", "/dev/null", "true"])
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .status()
        .is_ok_and(|s| s.success());
    ok.then_some(p)
}

fn run_lsgen(
    bin: &Path,
    args: &[OsString],
    out: &Path,
    gnu_time: Option<&Path>,
) -> Result<Run, String> {
    let time_file = out.with_extension("time");
    let mut cmd = match gnu_time {
        Some(t) => {
            let mut c = Command::new(t);
            c.args(["-f", "%U %S %M", "-o"]).arg(&time_file).arg(bin);
            c
        }
        None => Command::new(bin),
    };
    cmd.args(args).stdin(Stdio::null()).stdout(Stdio::null());
    let t0 = Instant::now();
    let child = cmd
        .stderr(Stdio::piped())
        .output()
        .map_err(|e| format!("cannot run {}: {e}", bin.display()))?;
    let wall = t0.elapsed().as_secs_f64();
    let stderr = String::from_utf8_lossy(&child.stderr);
    if !child.status.success() {
        return Err(format!("lsgen {:?} failed: {}", args, stderr.trim()));
    }
    let mut run = Run {
        wall,
        ..Run::default()
    };
    // `lsgen: step 3: 1,448 modules, 1,448 bytes`, one line per generation.
    let mut last_bytes = 0;
    for line in stderr.lines() {
        let Some(rest) = line.rsplit(": ").next() else {
            continue;
        };
        let mut words = rest.split_whitespace();
        if let (Some(m), Some("modules,"), Some(b), Some("bytes")) =
            (words.next(), words.next(), words.next(), words.next())
        {
            // `-v` groups digits: `1,193 bytes`.
            let (m, b) = (m.replace(',', ""), b.replace(',', ""));
            if let (Ok(m), Ok(b)) = (m.parse::<u64>(), b.parse::<u64>()) {
                run.all_modules += m;
                run.final_modules = m;
                last_bytes = b;
            }
        }
    }
    run.bytes = fs::metadata(out)
        .map_err(|e| format!("{}: {e}", out.display()))?
        .len();
    if run.bytes != last_bytes {
        eprintln!(
            "suite: warning: output has {} bytes, lsgen -v said {last_bytes}",
            run.bytes
        );
    }
    if gnu_time.is_some() {
        let t = fs::read_to_string(&time_file).unwrap_or_default();
        let _ = fs::remove_file(&time_file);
        let v: Vec<&str> = t
            .lines()
            .last()
            .unwrap_or_default()
            .split_whitespace()
            .collect();
        if let [u, s, m] = v[..] {
            run.cpu = u
                .parse::<f64>()
                .ok()
                .zip(s.parse::<f64>().ok())
                .map(|(u, s)| u + s);
            run.rss_kib = m.parse().ok();
        }
    }
    Ok(run)
}

fn run_floor(bytes: u64, path: &Path) -> Result<f64, String> {
    let me = std::env::current_exe().map_err(|e| format!("current_exe: {e}"))?;
    let t0 = Instant::now();
    let st = Command::new(me)
        .arg("--floor")
        .arg(bytes.to_string())
        .arg(path)
        .status()
        .map_err(|e| format!("cannot run the floor: {e}"))?;
    let secs = t0.elapsed().as_secs_f64();
    if !st.success() {
        return Err("the I/O floor run failed".into());
    }
    Ok(secs)
}

/// Free bytes in the file system of `dir`, from `df -Pk`.
fn free_bytes(dir: &Path) -> Option<u64> {
    let out = Command::new("df").arg("-Pk").arg(dir).output().ok()?;
    let s = String::from_utf8_lossy(&out.stdout);
    let kib: u64 = s.lines().nth(1)?.split_whitespace().nth(3)?.parse().ok()?;
    Some(kib * 1024)
}

fn command_line(prog: &str, args: &[&str]) -> Option<String> {
    let out = Command::new(prog).args(args).output().ok()?;
    out.status
        .success()
        .then(|| String::from_utf8_lossy(&out.stdout).trim().to_string())
}

/// The report's header: date, command, machine, method.
fn describe(bin: &Path, o: &Options, scratch: &Path, gnu_time: bool) -> String {
    let cpuinfo = fs::read_to_string("/proc/cpuinfo").unwrap_or_default();
    let model = cpuinfo
        .lines()
        .find(|l| l.starts_with("model name"))
        .and_then(|l| l.split(':').nth(1))
        .map_or("unknown".into(), |s| s.trim().to_string());
    let meminfo = fs::read_to_string("/proc/meminfo").unwrap_or_default();
    let mem_gib = meminfo
        .lines()
        .find(|l| l.starts_with("MemTotal:"))
        .and_then(|l| l.split_whitespace().nth(1))
        .and_then(|k| k.parse::<f64>().ok())
        .map_or("unknown".into(), |k| format!("{:.1} GiB", k / 1048576.0));
    let nproc = command_line("nproc", &[]).unwrap_or_else(|| "?".into());
    let kernel = command_line("uname", &["-sr"]).unwrap_or_else(|| "?".into());
    let rustc = command_line("rustc", &["--version"]).unwrap_or_else(|| "?".into());
    let date = command_line("date", &["-u", "+%Y-%m-%d %H:%M UTC"]).unwrap_or_default();
    let load = fs::read_to_string("/proc/loadavg")
        .ok()
        .map(|s| s.split_whitespace().take(3).collect::<Vec<_>>().join(" "))
        .unwrap_or_default();
    let root = env!("CARGO_MANIFEST_DIR");
    let rev = command_line("git", &["-C", root, "rev-parse", "--short", "HEAD"])
        .map(|r| {
            let dirty = command_line("git", &["-C", root, "status", "--porcelain", "src"])
                .is_some_and(|s| !s.is_empty());
            if dirty {
                format!("{r} + uncommitted changes in src/")
            } else {
                r
            }
        })
        .unwrap_or_else(|| "?".into());
    let fs_type = command_line("df", &["-PT", &scratch.display().to_string()])
        .and_then(|s| {
            let l = s.lines().nth(1)?.to_string();
            let v: Vec<&str> = l.split_whitespace().collect();
            Some(format!("{} on {}", v.get(1)?, v.first()?))
        })
        .unwrap_or_else(|| "?".into());
    let mut s = String::new();
    let _ = writeln!(s, "## lsgen benchmark suite\n");
    let _ = writeln!(s, "- command: `{}`", o.command);
    let _ = writeln!(s, "- date: {date}");
    let _ = writeln!(
        s,
        "- machine: {nproc} CPUs (nproc), {model}, {mem_gib} RAM, {kernel}, {rustc}"
    );
    let _ = writeln!(s, "- load average at start: {load}");
    let _ = writeln!(
        s,
        "- lsgen: `{}` (git {rev}), copied to the scratch directory at start",
        bin.display()
    );
    let _ = writeln!(
        s,
        "- output: a real file, `-o {dir}/out.txt`, temp generations in `--tmpdir {dir}` \
         ({fs_type}); deleted after each run",
        dir = scratch.display()
    );
    let _ = writeln!(
        s,
        "- wall: elapsed time of the child process, best of {}; cpu = user + system time{}",
        o.reps.map_or(
            "3 runs up to 2·10^7 modules, 2 up to 2·10^8, 1 above (threads rows: 3)".into(),
            |r| { format!("{r} runs") }
        ),
        if gnu_time {
            "; peak RSS = maxrss of lsgen (GNU `time -f %M`)"
        } else {
            " and peak RSS unavailable (no GNU time)"
        }
    );
    let _ = writeln!(
        s,
        "- I/O floor: `suite --floor BYTES PATH` as a child process: writes the same number \
         of bytes as lsgen's output to a new file in the same directory, 1 MiB \
         `File::write_all` at a time, then `sync_all` (lsgen syncs its output too), best \
         of at least 3 after each lsgen run; × floor = lsgen wall / floor wall"
    );
    let _ = writeln!(
        s,
        "- all generations: modules written over the whole derivation (axiom included); \
         M/s = final modules / wall (by cpu: / cpu, when cpu ≥ 0.05 s); \
         MB/s = output bytes / wall\n"
    );
    s
}

fn sci(size: u64) -> String {
    format!("10^{}", log10(size))
}

fn verdicts(r: &Row) -> String {
    let mut v = Vec::new();
    let speed = r.run.final_modules as f64 / r.run.wall;
    let (target, stated) = r.class.speed_target();
    let mark = if stated { "" } else { " (assumed)" };
    if speed >= target {
        v.push(format!("≥{:.0} M/s{mark}: met", target / 1e6));
    } else {
        // On a loaded machine wall time can exceed cpu time by far: say so.
        let by_cpu = r
            .run
            .cpu
            .filter(|&c| c >= 0.05)
            .map(|c| r.run.final_modules as f64 / c);
        let note = match by_cpu {
            Some(c) if c >= target => " but met by cpu time",
            _ => "",
        };
        v.push(format!(
            "≥{:.0} M/s{mark}: **missed** ({:.0}%){note}",
            target / 1e6,
            speed / target * 100.0
        ));
    }
    if let Some(t) = r.class.floor_target() {
        let ratio = r.run.wall / r.floor;
        if ratio <= t {
            v.push(format!("≤{t:.0}× floor: met"));
        } else {
            v.push(format!("≤{t:.0}× floor: **missed** ({ratio:.1}×)"));
        }
    }
    if let Some(k) = r.run.rss_kib {
        if k <= RSS_TARGET_KIB {
            v.push("RSS ≤16 MiB: met".into());
        } else {
            v.push(format!(
                "RSS ≤16 MiB: **missed** ({:.1} MiB)",
                k as f64 / 1024.0
            ));
        }
    }
    v.join("; ")
}

fn table(rows: &[Row], skips: &[Skip]) -> String {
    let mut s = String::new();
    let _ = writeln!(
        s,
        "| workload | class | size | -n | final modules | all generations | output bytes | \
         wall s | cpu s | M modules/s | (by cpu) | MB/s | peak RSS MiB | floor s | × floor | \
         targets |"
    );
    let _ = writeln!(
        s,
        "|---|---|---|---|--:|--:|--:|--:|--:|--:|--:|--:|--:|--:|--:|---|"
    );
    for r in rows {
        let run = &r.run;
        let _ = writeln!(
            s,
            "| {} | {} | {} | {} | {} | {} | {} | {:.3} | {} | {:.1} | {} | {:.1} | {} | {:.3} | {:.2} | {} |",
            r.workload,
            r.class.label(),
            sci(r.size),
            r.n_label,
            group(run.final_modules),
            group(run.all_modules),
            group(run.bytes),
            run.wall,
            run.cpu.map_or("?".into(), |c| format!("{c:.2}")),
            run.final_modules as f64 / run.wall / 1e6,
            run.cpu
                .filter(|&c| c >= 0.05)
                .map_or("—".into(), |c| format!(
                    "{:.1}",
                    run.final_modules as f64 / c / 1e6
                )),
            run.bytes as f64 / run.wall / 1e6,
            run.rss_kib
                .map_or("?".into(), |k| format!("{:.1}", k as f64 / 1024.0)),
            r.floor,
            run.wall / r.floor,
            verdicts(r),
        );
    }
    if !skips.is_empty() {
        let _ = writeln!(s, "\nNot run (and no larger size of that workload):\n");
        for k in skips {
            let _ = writeln!(s, "- {} at {}: {}", k.workload, sci(k.size), k.why);
        }
    }
    // Scaling: modules/s per size, and over all generations written.
    let mut by: BTreeMap<usize, Vec<&Row>> = BTreeMap::new();
    for r in rows {
        let i = WORKLOADS
            .iter()
            .position(|w| w.name == r.workload)
            .unwrap_or(0);
        by.entry(i).or_default().push(r);
    }
    let _ = writeln!(
        s,
        "\nScaling: M final modules/s (ns per module of all generations) per size; \
         flat = the ns per module of all generations at the largest size is within \
         1.5× of the best size ≥ 10^7 (in brackets: largest / best).\n"
    );
    let _ = writeln!(s, "| workload | 10^6 | 10^7 | 10^8 | 10^9 | flat? |");
    let _ = writeln!(s, "|---|--:|--:|--:|--:|---|");
    for rs in by.values() {
        let mut cells = vec![String::from("—"); SIZES.len()];
        for r in rs {
            if let Some(i) = SIZES.iter().position(|&z| z == r.size) {
                cells[i] = format!(
                    "{:.1} ({:.2})",
                    r.run.final_modules as f64 / r.run.wall / 1e6,
                    r.run.wall * 1e9 / r.run.all_modules.max(1) as f64
                );
            }
        }
        // Cost linear in the generations written: the wall time per module
        // of all generations at the largest size is within 1.5x of the best
        // size >= 10^7 (smaller ones pay the start-up).
        let costs: Vec<f64> = rs
            .iter()
            .filter(|r| r.size >= 10_000_000)
            .map(|r| r.run.wall / r.run.all_modules.max(1) as f64)
            .collect();
        let flat = match costs.last() {
            Some(&last) if costs.len() >= 2 => {
                let best = costs.iter().cloned().fold(f64::INFINITY, f64::min);
                if last <= best * 1.5 {
                    format!("yes ({:.2}×)", last / best)
                } else {
                    format!("**no** ({:.2}×)", last / best)
                }
            }
            _ => "—".to_string(),
        };
        let _ = writeln!(s, "| {} | {} | {flat} |", rs[0].workload, cells.join(" | "));
    }
    s
}

/// 1234567 -> 1 234 567 (thin groups, readable in Markdown).
fn group(n: u64) -> String {
    let d = n.to_string();
    let mut out = String::new();
    for (i, c) in d.chars().enumerate() {
        if i > 0 && (d.len() - i) % 3 == 0 {
            out.push('\u{202f}');
        }
        out.push(c);
    }
    out
}
