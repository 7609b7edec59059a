//! Deriving: a [`Strategy`] chosen once per run, then either depth first
//! ([`dfs`]: D0L byte plans and deterministic parametric systems, no temp
//! files) or step by step ([`step`], one temp file per generation).
//!
//! The step engine's parts: [`sink`](mod@sink) (output formats, bracket
//! index, limits), [`reader`] (buffered pread readers), [`context`] (left
//! contexts and the right-walker), [`bytetable`] (the D0L byte table).
//! [`par`] splits either strategy between threads (`-j N`).

pub(crate) mod bytetable;
pub(crate) mod choose;
pub(crate) mod context;
pub mod dfs;
pub(crate) mod handoff;
pub mod meter;
pub(crate) mod par;
pub(crate) mod patches;
pub mod random;
pub(crate) mod reader;
pub(crate) mod reclaim;
pub mod sink;
pub(crate) mod spares;
pub(crate) mod split;
pub(crate) mod step;

pub(crate) use bytetable::ASCII;
pub use reader::PosReader;
pub use sink::{Limits, Out};
#[cfg(feature = "cli")]
pub(crate) use spares::KeepSpares;
pub use step::Deriver;

use crate::cpfg::run::When;
use crate::diag::{CodeMap, Error, Location};
use crate::io::axiom::AxiomReader;
use crate::rules::{Laid, System};
use random::{Random, Region};
use std::fs::File;
use std::io::{self, Seek, SeekFrom, Write};
use std::path::PathBuf;
use std::sync::atomic::Ordering;

/// Where a pass's errors point and what they call the pass.
pub struct Origin<'a> {
    pub path: &'a str,
    pub header: &'a str,
    /// A cpfg file: offsets are in its preprocessed text.
    pub map: Option<&'a crate::cpfg::preprocess::SourceMap>,
}

impl Origin<'_> {
    pub(crate) fn locate(&self, offset: usize) -> Location {
        if let Some(map) = self.map {
            return map.location(offset);
        }
        Location::from_map(self.path, &CodeMap::new(self.header), offset)
    }

    /// A runtime error of an expression, in `pass`.
    pub(crate) fn eval_error(&self, e: crate::rules::expr::EvalError, pass: Pass) -> Error {
        Error::at(
            self.locate(e.span.0),
            crate::diag::RuntimeError::Eval {
                error: e.kind,
                pass,
            },
        )
    }
}

/// What one pass is: a numbered step or the homomorphism.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[non_exhaustive]
pub enum Pass {
    /// Derivation step n (from 1).
    Step(u64),
    /// The homomorphism, after the last step.
    Homomorphism,
    /// Reading the axiom (generation 0).
    Axiom,
    /// The homomorphism's image of generation n (0: the axiom) that cpfg's
    /// turtle queries read where the homomorphism can move the turtle
    /// (README, "Coming from cpfg: turtle queries"), also with
    /// `--no-homomorphism`: named by `--max-length`'s error when the image
    /// outgrows it.
    QueryImage(u64),
}

impl std::fmt::Display for Pass {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Pass::Step(n) => write!(f, "step {n}"),
            Pass::Homomorphism => f.write_str("the homomorphism"),
            Pass::Axiom => f.write_str("the axiom"),
            Pass::QueryImage(0) => {
                f.write_str("the homomorphism's image of the axiom (read by the turtle queries)")
            }
            Pass::QueryImage(n) => write!(
                f,
                "the homomorphism's image of the string after step {n} (read by the turtle queries)"
            ),
        }
    }
}

/// How the derivation is carried out (`--strategy`, hidden, for tests).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum Strategy {
    /// Depth first when the system allows it, else step by step.
    #[default]
    Auto,
    /// Always step by step.
    Step,
    /// Depth first, or a usage error.
    DepthFirst,
}

/// How to derive, once the file is loaded.
pub(crate) struct Settings {
    pub steps: u64,
    pub seed: u64,
    pub homomorphism: bool,
    pub limits: Limits,
    pub tmpdir: Option<PathBuf>,
    /// Each generation's length is wanted (by an [`Event`] callback).
    pub lengths: bool,
    pub strategy: Strategy,
    /// The number of this run's first step (`--first-step`, default 1):
    /// the random draws of step k depend on k.
    pub first_step: u64,
    /// Free bytes where the final string goes (a regular file's file
    /// system), when known: a string known in advance to be larger is
    /// refused before anything is written.
    pub space: Option<u64>,
    /// Threads for one derivation (`-j`); 1 is the sequential engine.
    pub threads: usize,
    /// Tests: split into tasks this small (`par::test_split`).
    pub split: Option<u64>,
    /// The output's switch for text made on several threads
    /// ([`crate::Options::direct_output`]).
    pub direct: Option<std::sync::Arc<std::sync::atomic::AtomicU8>>,
    /// How parameters are written (`--precision`, the cpfg dialect's
    /// `%g`): the alphabet's, for every pass and strategy.
    pub numbers: crate::rules::codec::Numbers,
}

/// Which generations `--frames A..B:K` writes: `from..=to`, every
/// `every`-th from `from`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Frames {
    pub from: u64,
    pub to: u64,
    pub every: u64,
}

impl Frames {
    /// Is generation `k` a frame?
    pub fn contains(&self, k: u64) -> bool {
        k >= self.from && k <= self.to && (k - self.from) % self.every == 0
    }

    /// How many frames (generations are at most 2^53: no overflow).
    pub fn count(&self) -> u64 {
        (self.to - self.from) / self.every + 1
    }

    /// The last frame (the derivation goes no further).
    pub fn last(&self) -> u64 {
        self.from + (self.count() - 1) * self.every
    }
}

/// Where frames are written: `frame(n, write)` opens frame n's
/// destination, has `write` fill it (returning its length), and closes it.
pub trait FrameSink {
    #[allow(clippy::type_complexity)]
    fn frame(
        &mut self,
        n: u64,
        write: &mut dyn FnMut(&mut dyn Write, &str) -> Result<(u64, u64), Error>,
    ) -> Result<(u64, u64), Error>;
}

/// What a derivation reports as it goes (see `LSystem::derive_with`).
#[derive(Clone, Debug, PartialEq, Eq)]
#[non_exhaustive]
pub enum Event {
    /// A generation is complete: the axiom (generation 0), a step, or the
    /// homomorphism; its length in modules and in bytes (of the binary
    /// temporary format for intermediate generations, of the text without
    /// its final newline for the last).
    Generation {
        /// Which generation.
        pass: Pass,
        /// Its number of modules.
        modules: u64,
        /// Its size in bytes.
        bytes: u64,
    },
    /// Steps `from..=to` leave the string unchanged (a fixed point), so
    /// they are skipped.
    FixedPoint {
        /// First skipped step.
        from: u64,
        /// Last step.
        to: u64,
    },
    /// A warning: the input was derived anyway. The file's warnings
    /// (found when it was read) come first; one found in a pass comes
    /// before that pass's [`Generation`](Event::Generation).
    Warning(crate::diag::Warning),
    /// The text a cpfg `.l` file's statement block printed with `printf`
    /// or `fprintf(stderr, …)` (one event per call, formatted as C does;
    /// the `lsgen` binary writes it on standard error), in its place
    /// among the warnings and generations: a block of `Start:` before the
    /// axiom's [`Generation`](Event::Generation), a production's block
    /// before its step's, `EndEach:` and `End:` after it.
    Printf(String),
}

fn tempfile(dir: &Option<PathBuf>) -> Result<File, Error> {
    let r = match dir {
        Some(d) => tempfile::tempfile_in(d),
        None => tempfile::tempfile(),
    };
    r.map_err(|e| tempfile_error(dir, e))
}

/// The error of a temporary file that could not be made in `dir` (None:
/// the system's temporary directory).
pub(crate) fn tempfile_error(dir: &Option<PathBuf>, e: std::io::Error) -> Error {
    Error::io(
        dir.as_ref().map_or_else(
            || std::env::temp_dir().display().to_string(),
            |d| d.display().to_string(),
        ),
        crate::diag::IoAction::CreateTemp,
        e,
    )
}

/// A temporary file holding a generation, emptied when it is dropped,
/// whether the run ends well or not. Emptying was first for ext4, which
/// writes a file truncated to 0 and written again out to disk when it is
/// closed (`auto_da_alloc`), on the closing thread: 0.14 s at the end of a
/// 3-step context run at 10^8, 13 ms emptied. Generations are now written
/// over in place ([`overwrite`]), never truncated to 0 first, and
/// emptying them still pays: without it the same run spent 0.53-0.56 s
/// of system time instead of 0.22-0.25 s.
struct Generation(File, Option<PathBuf>);

impl std::ops::Deref for Generation {
    type Target = File;
    fn deref(&self) -> &File {
        &self.0
    }
}

impl std::ops::DerefMut for Generation {
    fn deref_mut(&mut self) -> &mut File {
        &mut self.0
    }
}

impl Drop for Generation {
    fn drop(&mut self) {
        // (A generation that cannot be emptied is closed as it is; an
        // emptied one a batch's worker keeps for its next job.)
        if self.0.set_len(0).is_ok() {
            spares::leave_generation(&self.1, &self.0);
        }
    }
}

/// A new, empty temporary generation in `dir` (else the system's), or one
/// a batch's worker kept ([`spares`]).
fn generation_file(dir: &Option<PathBuf>) -> Result<Generation, Error> {
    if let Some(mut f) = spares::take_generation(dir) {
        if f.seek(SeekFrom::Start(0)).is_ok() {
            return Ok(Generation(f, dir.clone()));
        }
    }
    tempfile(dir).map(|f| Generation(f, dir.clone()))
}

/// Fill the queries of the generation in `gen` (`generation`: its
/// number) with cpfg's turtle ([`crate::cpfg::query`]): where the
/// homomorphism can move the turtle, the turtle reads the homomorphism's
/// image of the generation, written to a temporary file in `tmpdir` (its
/// name `tmp_name` in errors) and gone when the filling is done.
fn fill_queries(
    d: &mut Deriver,
    (q, homomorphism): (&crate::cpfg::query::QueryTurtle, &crate::rules::Table),
    gen: &File,
    (indexed, (tmpdir, tmp_name, limits)): (bool, (&Option<PathBuf>, &str, Limits)),
    generation: u64,
) -> Result<(), Error> {
    let flags = (indexed, d.counts);
    // (The run's movements, out of `d` while the turtle has them.)
    let mut mv = d.query_movements.take();
    let r = if q.through {
        fill_through_image(
            d,
            (q, mv.as_mut()),
            homomorphism,
            gen,
            (indexed, (tmpdir, tmp_name, limits)),
            generation,
        )
    } else {
        crate::cpfg::query::fill((q, mv.as_mut()), gen, &d.alphabet, flags, generation)
    };
    d.query_movements = mv;
    r
}

/// [`fill_queries`] through the homomorphism's image of `gen`.
fn fill_through_image(
    d: &mut Deriver,
    q: (
        &crate::cpfg::query::QueryTurtle,
        Option<&mut crate::turtle::movements::Movements>,
    ),
    homomorphism: &crate::rules::Table,
    gen: &File,
    (indexed, (tmpdir, tmp_name, limits)): (bool, (&Option<PathBuf>, &str, Limits)),
    generation: u64,
) -> Result<(), Error> {
    let flags = (indexed, d.counts);
    let mut image = Some(generation_file(tmpdir)?);
    {
        let mut none = io::sink();
        let out = sink(&mut image, tmp_name, &mut none, tmp_name, limits, flags)?;
        let mut out = out.for_pass(Pass::QueryImage(generation));
        // (No draw: `check` refuses a homomorphism that draws, or runs a
        // block, with queries it follows.)
        let draws = d.rng.draws();
        d.pass(
            homomorphism,
            (gen, None),
            indexed,
            &mut out,
            Pass::Homomorphism,
        )?;
        out.finish()?;
        debug_assert_eq!(draws, d.rng.draws());
    }
    let image = image.expect("made above");
    // The keys the homomorphism rewrites.
    let mut rewritten = vec![false; d.alphabet.len()];
    for p in &homomorphism.prods {
        for k in std::iter::once(p.key).chain(p.rest().iter().map(|r| r.key)) {
            if let Some(r) = rewritten.get_mut(k as usize) {
                *r = true;
            }
        }
    }
    let rewritten = |k: u32| rewritten.get(k as usize).copied().unwrap_or(false);
    crate::cpfg::query::fill_through(q, (gen, &image), &d.alphabet, flags, &rewritten, generation)
}

/// The sink for a generation: the temp file `dst` (binary, with a bracket
/// index if asked) or, without one, the output (text).
fn sink<'a>(
    dst: &'a mut Option<Generation>,
    tmp_name: &'a str,
    output: &'a mut dyn Write,
    out_name: &'a str,
    limits: Limits,
    (indexed, counts): (bool, bool),
) -> Result<Out<'a>, Error> {
    Ok(match dst {
        Some(f) => {
            let index = if indexed {
                Some(
                    f.try_clone()
                        .map_err(|e| Error::io(tmp_name, crate::diag::IoAction::Write, e))?,
                )
            } else {
                None
            };
            let out = Out::new(&mut f.0, tmp_name, false, limits);
            match index {
                Some(i) => out.with_index(i).with_counts(counts),
                None => out,
            }
        }
        None => Out::new(output, out_name, true, limits),
    })
}

/// Read the rest of the axiom into `out`, module after module (`cuts`: a
/// `%` was read).
fn read_axiom(
    reader: &mut AxiomReader,
    out: &mut Out,
    d: &mut Deriver,
    params: &mut Vec<f64>,
    cuts: &mut bool,
) -> Result<(), Error> {
    let pct = u32::from(b'%');
    loop {
        reader.plain_run(|run| {
            *cuts |= run.contains(&b'%');
            out.plain(run)
        })??;
        d.rng.set_module(out.modules);
        match reader.next(&mut d.alphabet, params, &mut d.rng)? {
            Some(key) => {
                *cuts |= key == pct;
                out.module(key, params, &d.alphabet)?
            }
            None => return Ok(()),
        }
        out.maybe_flush()?;
    }
}

/// Make `f`, a generation no longer needed, ready to take the next one,
/// written over it in place (then cut at its end, [`cut_to_written`]). Not
/// truncated first: the new generation overwrites the old one's cached
/// pages instead of freeing them and taking fresh ones (a 3-step context
/// run at 10^8 spends a quarter less system time).
fn overwrite(f: &mut File, name: &str) -> Result<(), Error> {
    f.seek(SeekFrom::Start(0))
        .map(drop)
        .map_err(|e| Error::io(name, crate::diag::IoAction::Write, e))
}

/// The file for the next generation: `other`, the one before the last,
/// to be written over ([`overwrite`]), or a new one in `dir`.
fn next_generation(
    other: Option<Generation>,
    dir: &Option<PathBuf>,
    name: &str,
) -> Result<Generation, Error> {
    match other {
        Some(mut f) => {
            overwrite(&mut f, name)?;
            Ok(f)
        }
        None => generation_file(dir),
    }
}

/// End the generation just written to `f` where its writing stopped: an
/// older, longer one it was written over ([`overwrite`]) must not show
/// through. Before anything reads it (readers stop at the file's length).
fn cut_to_written(f: &mut File, name: &str) -> Result<(), Error> {
    f.stream_position()
        .and_then(|end| f.set_len(end))
        .map_err(|e| Error::io(name, crate::diag::IoAction::Write, e))
}

#[allow(clippy::too_many_arguments)]
pub(crate) fn derive(
    settings: &Settings,
    mut reader: AxiomReader,
    header: &str,
    path: &str,
    system: System,
    (output, out_name): (&mut dyn Write, &str),
    events: &mut dyn FnMut(&Event),
    frames: Option<(Frames, &mut dyn FrameSink)>,
) -> Result<(u64, u64), Error> {
    let Settings {
        steps,
        seed,
        limits,
        ref tmpdir,
        first_step,
        ..
    } = *settings;
    // Blocks and spill files the splits keep from pass to pass.
    let reuse = par::Reuse::new(tmpdir);
    // The number of the i-th step of this run.
    let step_no = |i: u64| first_step + (i - 1);
    let System {
        alphabet,
        productions,
        homomorphism,
        groups,
        schedule,
        group_expr,
        decomposition,
        hom_depth,
        hom_seed,
        warnings,
        step_hidden,
        cpfg,
        source_map,
        ..
    } = system;
    let hom = settings.homomorphism && !homomorphism.is_empty();
    // cpfg's turtle queries: each generation's filled as it is written,
    // the last step's too, then copied to the output as text (one pass
    // more).
    let queries = cpfg.as_ref().and_then(|c| c.queries.clone());
    // (Filled through the homomorphism's image where it can move the
    // turtle, with or without `--no-homomorphism`: cpfg's turtle reads
    // the string through it.)
    let through = queries.as_ref().is_some_and(|q| q.through);
    // Right contexts skip branches in O(1) through a bracket index.
    let indexed = productions.has_right
        || decomposition.as_ref().is_some_and(|(d, _)| d.has_right)
        || groups.iter().any(|(_, g)| g.own().has_right)
        || ((hom || through) && homomorphism.has_right);
    let passes = steps + u64::from(hom || queries.is_some());
    let strategy = settings.strategy;
    let not_depth_first = || Error::new(crate::diag::UsageError::NotDepthFirst);
    if strategy == Strategy::DepthFirst && (passes == 0 || frames.is_some()) {
        return Err(not_depth_first());
    }
    // The cpfg dialect: cpfg's generators (README, "Coming from cpfg").
    let rng = match &cpfg {
        Some(c) => Random::cpfg(c.seed, c.functions.clone()),
        None => Random::new(seed),
    };
    let (mut productions, mut homomorphism, mut decomposition, mut groups) =
        (productions, homomorphism, decomposition, groups);
    if let Some(c) = &cpfg {
        if c.seed.is_some() {
            productions.cpfg_seeded();
        }
        // cpfg's right contexts (README, "Coming from cpfg").
        productions.for_cpfg(&alphabet);
        homomorphism.for_cpfg(&alphabet);
        if let Some((t, _)) = &mut decomposition {
            t.for_cpfg(&alphabet);
        }
    }
    // Numbers become text in one form, the alphabet's: modules as they are
    // written, the constant runs of successors now.
    let mut alphabet = alphabet;
    if settings.numbers != alphabet.numbers() {
        alphabet.set_numbers(settings.numbers);
        productions.retext(&alphabet);
        homomorphism.retext(&alphabet);
        if let Some((t, _)) = &mut decomposition {
            t.retext(&alphabet);
        }
        for (_, g) in &mut groups {
            g.retext(&alphabet);
        }
    }
    let mut d = Deriver::new(
        alphabet,
        rng,
        Origin {
            path,
            header,
            map: source_map.as_deref(),
        },
    );
    d.cpfg_contexts = cpfg.is_some();
    d.query_movements = queries.as_ref().and_then(|q| q.movements());
    let is_cpfg = cpfg.is_some();
    // Blocks run every step (header blocks) or where a production is
    // tried (a production's): no fixed point.
    let blocks = cpfg.as_ref().is_some_and(|c| c.has_blocks());
    d.cpfg = cpfg;
    for span in step_hidden {
        crate::diag::warn(
            d.origin.locate(span.0),
            &crate::diag::WarningKind::StepHidden,
        );
    }
    d.hom_depth = hom_depth;
    d.hom_tries = is_cpfg && homomorphism.tries_have_effects();
    d.warnings = warnings;
    // Rules that change from step to step: a step that leaves the string
    // as it was says nothing of the next one. (Not the homomorphism: it
    // reads the number of the step it follows, also after a fixed point.)
    let varies_by_step = !schedule.is_empty()
        || group_expr.is_some()
        || std::iter::once(&productions)
            .chain(groups.iter().map(|(_, g)| g.own()))
            .chain(decomposition.iter().map(|(t, _)| t))
            .any(uses_step);
    let hom_uses_step = uses_step(&homomorphism);
    // Passes only the step engine makes. A decomposition and a homomorphism
    // with depth (or its depth warning) are functions of the string alone,
    // and the warnings are said once: they do not stop a fixed point. A
    // homomorphism none of whose successors holds a module it rewrites
    // applies once at any depth from 1, and never says its depth warning.
    let hom_recurses = hom && homomorphism.rewrites_own_successors(&d.alphabet);
    let structural = varies_by_step
        || hom_uses_step
        || decomposition.is_some()
        || (hom && hom_depth == 0)
        || (hom_recurses && (hom_depth != 1 || warnings[1]));
    d.decomp_tries = is_cpfg
        && decomposition
            .as_ref()
            .is_some_and(|(t, _)| t.tries_have_effects());
    d.decomp = decomposition;
    // Can a step make a `%`? Then indexed generations also hold module
    // counts, so a cut skips its branch in O(1) (an axiom's `%` alone cuts
    // once, in step 1, by one scan of its branch).
    let percent = makes_percent(&d, &productions, &groups);
    d.counts = indexed && percent;
    let mut generation = |pass: Pass, (modules, bytes): (u64, u64)| {
        events(&Event::Generation {
            pass,
            modules,
            bytes,
        });
        (modules, bytes)
    };

    let tmp_name = format!(
        "temporary file in {}",
        tmpdir.clone().unwrap_or_else(std::env::temp_dir).display()
    );
    // Generation 0: the axiom (does it hold a `%`?).
    let mut axiom_cuts = false;
    let mut cur = if passes == 0 && frames.is_none() {
        None
    } else {
        Some(generation_file(tmpdir)?)
    };
    // cpfg's `Start:` runs before the axiom is read, and the axiom's
    // parameters that are no constants see what it did.
    d.cpfg_block(When::Define, Pass::Axiom)?;
    d.cpfg_block(When::Start, Pass::Axiom)?;
    if let Some(text) = d.cpfg_axiom()? {
        reader = reader.with_text(text);
    }
    let axiom_len = {
        let index = (indexed, d.counts);
        let mut params = Vec::new();
        let limited = limits.modules != u64::MAX || limits.bytes != u64::MAX;
        // A long axiom in a regular file, written to a temporary file: its
        // leading plain modules on several threads (`par::axiom_prefix`;
        // not with `--max-length`, checked in order on one thread).
        let split = (
            settings.threads,
            settings.split.or_else(par::test_split),
            &reuse,
        );
        let name = reader.name().to_string();
        let mut out = sink(&mut cur, &tmp_name, output, out_name, limits, index)?;
        let prefix = match reader.file_rest()? {
            // With where the reader is (the split's workers read the file
            // at their own offsets: it has not moved).
            Some(rest) if !out.text && !limited => {
                par::axiom_prefix(rest, split, (&name, &mut out))?.map(|p| (p, reader.state()))
            }
            _ => None,
        };
        let read = &mut |reader: &mut AxiomReader, out: &mut Out, cuts: &mut bool| {
            read_axiom(reader, out, &mut d, &mut params, cuts)
        };
        // Where to read the axiom again from, if it must be.
        let again = match prefix {
            None => {
                read(&mut reader, &mut out, &mut axiom_cuts)?;
                None
            }
            Some((par::AxiomPrefix::Upto { at, depth, percent }, start)) => {
                axiom_cuts |= percent;
                reader.skip_plain(at, depth)?;
                read(&mut reader, &mut out, &mut axiom_cuts)
                    .is_err()
                    .then_some(start)
            }
            Some((par::AxiomPrefix::Again, start)) => Some(start),
        };
        let len = if let Some(start) = again {
            // An error after the split (or an unbalanced `]` in it): read
            // the axiom again from its start on one thread, which reports
            // the error as one thread does, with the same quote.
            drop(out);
            if let Some(f) = cur.as_mut() {
                overwrite(f, &tmp_name)?;
            }
            reader.back_to(&start)?;
            axiom_cuts = false;
            let mut out = sink(&mut cur, &tmp_name, output, out_name, limits, index)?;
            read(&mut reader, &mut out, &mut axiom_cuts)?;
            out.finish()?
        } else {
            out.finish()?
        };
        if let Some(f) = cur.as_mut() {
            cut_to_written(f, &tmp_name)?;
            // (Frames fill their generations themselves.)
            if let (Some(q), None) = (&queries, &frames) {
                if steps > 0 || q.fills_last {
                    let at = (&settings.tmpdir, tmp_name.as_str(), limits);
                    fill_queries(&mut d, (q, &homomorphism), f, (indexed, at), 0)?;
                }
            }
        }
        let len = generation(Pass::Axiom, len);
        if passes == 0 && frames.is_none() {
            return Ok(len);
        }
        len
    };
    drop(reader);
    // Issue 11: groups, decomposition, homomorphism depth and cuts are
    // implemented by the step engine only; a `%` that can be a cut makes a
    // module's expansion depend on its neighbours.
    // A `%` that no production rewrites is a cut (docs/structural.md,
    // section 5); the step engine looks for cuts only if a `%` can occur.
    d.cut = axiom_cuts || percent;
    // The cpfg dialect draws in string order from one sequential
    // generator (`ran`, the stochastic choice), runs its blocks and fills
    // its queries there, and warns on the thread that derives: such a
    // file only step by step. One with none of them gives the same string
    // in any order (README, "Coming from cpfg").
    let cpfg_ordered = d.cpfg.as_ref().is_some_and(|c| {
        c.seed.is_some()
            || c.has_blocks()
            || c.queries.is_some()
            || !productions.cpfg_any_order()
            || (hom && !homomorphism.cpfg_any_order())
            // (cpfg tries the productions of its homomorphism's successors'
            // modules at its depth limit, and a try can fail.)
            || (hom_recurses && d.hom_tries)
    });
    let step_only = structural || cpfg_ordered || d.cut;
    let strategy = if step_only {
        if strategy == Strategy::DepthFirst && is_cpfg {
            return Err(Error::new(crate::diag::UsageError::CpfgNotDepthFirst));
        }
        if strategy == Strategy::DepthFirst {
            return Err(not_depth_first());
        }
        Strategy::Step
    } else {
        strategy
    };
    // The step engine's tables, for frames and for step-by-step passes.
    let mut tables = Tables {
        productions: &mut productions,
        groups: &mut groups,
        schedule: &schedule,
        group_expr: group_expr.as_ref(),
        hom_seed,
        fixed_points: !varies_by_step && !blocks && queries.is_none(),
        plain: !step_only,
    };
    if let Some((frames, frame_sink)) = frames {
        let cur = cur.take().expect("generation 0 in a file");
        let tables = (&mut tables, &homomorphism, hom);
        let names = (frame_sink, tmp_name.as_str());
        return frame_passes(
            &mut d, cur, tables, settings, frames, names, indexed, events,
        );
    }

    // Deterministic context-free byte systems: depth first, no temp files.
    let plan = crate::derive::dfs::Plan::new(
        tables.productions,
        hom.then_some(&homomorphism),
        &d.alphabet,
        steps,
    )
    .filter(|_| strategy != Strategy::Step);
    if let (Some(plan), Some(src)) = (plan, &cur) {
        if let Some(m) = meter::current() {
            let census = crate::derive::dfs::census(src, &d.alphabet)?;
            let size = plan.final_text_bytes(&census, steps);
            let size = u64::try_from(size).unwrap_or(u64::MAX).max(1);
            m.final_bytes.store(size, Ordering::Relaxed);
            m.depth_first.store(true, Ordering::Relaxed);
        }
        if let Some(space) = settings.space {
            let census = crate::derive::dfs::census(src, &d.alphabet)?;
            let size = plan.final_text_bytes(&census, steps);
            if size > u128::from(space) {
                use crate::diag::group_digits;
                let size = match u64::try_from(size) {
                    Ok(n) if n != u64::MAX => format!("{} bytes", group_digits(n)),
                    _ => format!("more than {} bytes", group_digits(u64::MAX)),
                };
                return Err(Error::about(
                    out_name,
                    crate::diag::RuntimeError::NoSpace {
                        size,
                        free: space,
                        names: crate::diag::OptionNames::Library,
                    },
                ));
            }
        }
        if settings.lengths || limits.modules != u64::MAX || limits.bytes != u64::MAX {
            let census = crate::derive::dfs::census(src, &d.alphabet)?;
            let lengths = plan.lengths(&census, steps);
            limits.check_generations(&lengths, !hom, first_step)?;
            let shown = if hom {
                lengths.len()
            } else {
                lengths.len() - 1
            };
            for (i, &len) in lengths[..shown].iter().enumerate() {
                generation(Pass::Step(step_no(i as u64 + 1)), len);
            }
        }
        let last = if hom {
            Pass::Homomorphism
        } else {
            Pass::Step(step_no(steps))
        };
        let mut none = None;
        let no_index = (false, false);
        let mut out =
            sink(&mut none, &tmp_name, output, out_name, limits, no_index)?.for_pass(last);
        plan.expand(src, &d.alphabet, steps, &mut out)?;
        return Ok(generation(last, out.finish()?));
    }

    // Deterministic context-free systems with parameters: depth first too,
    // unless generation lengths are asked for (-v, --max-length).
    let quiet = !settings.lengths && limits.modules == u64::MAX && limits.bytes == u64::MAX;
    let plan = crate::derive::dfs::ParamPlan::new(
        tables.productions,
        hom.then_some(&homomorphism),
        steps,
        &d.rng,
    )
    .filter(|_| strategy != Strategy::Step);
    if strategy == Strategy::DepthFirst && !(plan.is_some() && quiet) {
        return Err(not_depth_first());
    }
    // A runtime error found depth first may not be the first one in step
    // order: then derive again step by step, output discarded, so every
    // strategy reports the earliest step's first error in string order.
    let mut depth_first_error = None;
    if let (Some(plan), Some(src), true) = (plan, &cur, quiet) {
        if let Some(m) = meter::current() {
            m.depth_first.store(true, Ordering::Relaxed);
        }
        let mut none = None;
        let mut out = sink(
            &mut none,
            &tmp_name,
            output,
            out_name,
            limits,
            (false, false),
        )?;
        let threads = par::threads_for(settings.threads, steps, strategy);
        out.direct = settings.direct.clone();
        let expanded = if threads > 1 {
            let split = (threads, settings.split.or_else(par::test_split), &reuse);
            par::expand(&plan, src, &d.alphabet, &d.origin, steps, split, &mut out)
        } else {
            let _direct = out.around_cache(true);
            plan.expand(src, &d.alphabet, &d.origin, steps, &mut out)
        };
        match expanded.and_then(|()| out.finish()) {
            Ok(len) => {
                let last = if hom {
                    Pass::Homomorphism
                } else {
                    Pass::Step(step_no(steps))
                };
                return Ok(generation(last, len));
            }
            Err(e) if e.location().is_some() => depth_first_error = Some(e),
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
        (cur, axiom_len),
        (&mut tables, &homomorphism, hom),
        (settings, &reuse),
        (output, out_name, &tmp_name),
        indexed,
        events,
    );
    match depth_first_error {
        Some(e) => Err(stepwise.err().unwrap_or(e)),
        None => stepwise,
    }
}

/// The steps, then the homomorphism, one temp file each, from generation 0
/// in `cur` (of `len`: modules, bytes).
fn step_passes(
    d: &mut Deriver,
    (mut cur, len): (Option<Generation>, (u64, u64)),
    (tables, homomorphism, hom): (&mut Tables, &crate::rules::Table, bool),
    (settings, reuse): (&Settings, &par::Reuse),
    (output, out_name, tmp_name): (&mut dyn Write, &str, &str),
    indexed: bool,
    events: &mut dyn FnMut(&Event),
) -> Result<(u64, u64), Error> {
    let Settings {
        steps,
        limits,
        ref tmpdir,
        first_step,
        ..
    } = *settings;
    let queries = d.cpfg.as_ref().and_then(|c| c.queries.clone());
    // With queries, the last step writes a generation too, filled, which
    // the homomorphism or else a plain copy (`copies`) writes out.
    let copy = crate::rules::Table::default();
    let copies = queries.is_some() && !hom;
    let passes = steps + u64::from(hom || queries.is_some());
    let (hom_seed, plain, fixed_points) = (tables.hom_seed, tables.plain, tables.fixed_points);
    // The last generation's (modules, bytes): `cur`'s, until the last pass.
    let mut last_len = len;
    let mut other: Option<Generation> = None;
    let mut i = 1;
    while i <= passes {
        // Step i of this run draws on stream `first_step + i - 1`; the
        // homomorphism on the last step's. (A step's table is laid for
        // the pass and taken off at the end of this iteration.)
        let laid;
        let (table, pass): (&crate::rules::Table, Pass) = if i <= steps {
            let k = first_step + (i - 1);
            d.rng.start_pass(k, Region::Step);
            // The built-in `step` and the group schedule count the steps
            // as the draws do (`--first-step`), so chained runs agree.
            d.rng.set_step(k);
            laid = tables.table_for(k, d)?;
            (&*laid, Pass::Step(k))
        } else if copies {
            (&copy, Pass::Step(first_step + steps.max(1) - 1))
        } else {
            let k = first_step + steps - 1;
            if let Some(s) = hom_seed {
                // The homomorphism's own key (its `seed:`); same stream
                // and positions (docs/structural.md, section 8). The last
                // pass: nothing to restore.
                d.rng.begin_homomorphism(s);
            }
            d.rng.start_pass(k, Region::Homomorphism);
            if !d.keeps_q() {
                d.rng.set_step(k);
            }
            (homomorphism, Pass::Homomorphism)
        };
        let src = cur.take().expect("a generation to read");
        let mut dst = if i == passes {
            None
        } else {
            Some(next_generation(other.take(), tmpdir, tmp_name)?)
        };
        let draws = d.rng.draws();
        let mut drew = 0;
        let step = i <= steps;
        // The copy of the last generation: no decomposition, no cut (it
        // had them), as a frame's plain copy.
        let copying = !step && copies;
        let kept = copying.then(|| (d.decomp.take(), std::mem::replace(&mut d.cut, false)));
        // A step that drew nothing and left the string as it was is a fixed
        // point: every later step does the same. Then the run goes on with
        // the last pass (the homomorphism, or the last step, which writes
        // the text). Asked after this pass, which reads `src` again.
        let last = if hom { passes } else { steps };
        let compares = fixed_points && i < steps && last > i + 1;
        // The last two passes read generations whose files are not written
        // over again (a generation's file takes the one two passes later):
        // give back what each has read ([`reclaim`]). (No fixed-point test,
        // which reads a pass's input again, follows them: `compares` is
        // false there.)
        // (`passes - i`, not `i + 2`: after a fixed point `i` may be
        // 2^64 - 2, with `steps(u64::MAX - 1)`.)
        debug_assert!(passes - i >= 2 || !compares);
        let reclaim = (passes - i < 2).then(|| {
            let small = settings.split.or_else(par::test_split).is_some();
            reclaim::Reclaim::new(&src, small)
        });
        let reclaim = reclaim.as_ref();
        if step {
            d.cpfg_block(When::StartEach, pass)?;
        }
        {
            let mut out = sink(
                &mut dst,
                tmp_name,
                output,
                out_name,
                limits,
                (indexed, d.counts),
            )?
            .for_pass(pass);
            let limited = limits.modules != u64::MAX || limits.bytes != u64::MAX;
            let split = settings.split.or_else(par::test_split);
            let len = src.metadata().map_or(u64::MAX, |m| m.len());
            let flags = (plain, indexed, limited);
            let threads = par::step_threads(settings.threads, table, flags, (len, split));
            let split = (threads, split, reuse);
            out.direct = settings.direct.clone();
            match (threads > 1)
                .then(|| {
                    // Each module one byte (as many as bytes)?
                    let one_byte = (last_len.0 == last_len.1).then_some(last_len.1);
                    let src = (&*src, indexed, one_byte, reclaim);
                    par::step_pass(d, table, src, split, &mut out, pass)
                })
                .transpose()?
                .flatten()
            {
                Some(n) => drew = n,
                None => {
                    let _direct = out.around_cache(true);
                    d.pass(table, (&src, reclaim), indexed, &mut out, pass)?
                }
            }
            let (modules, bytes) = out.finish()?;
            if let Some(f) = &mut dst {
                cut_to_written(f, tmp_name)?;
            }
            // (The last step's generation is told as its copy.)
            if !(copies && step && i == steps) {
                events(&Event::Generation {
                    pass,
                    modules,
                    bytes,
                });
            }
            last_len = (modules, bytes);
        }
        if let Some((decomp, cut)) = kept {
            d.decomp = decomp;
            d.cut = cut;
        }
        if step {
            d.cpfg_block(When::EndEach, pass)?;
            // `End:` after the last step, when the run reaches the file's
            // derivation length (cpfg's end of derivation).
            if i == steps && d.cpfg.as_ref().is_some_and(|c| i >= c.derivation_length) {
                d.cpfg_block(When::End, pass)?;
            }
        }
        // The queries: filled after the step's `EndEach:` (and `End:`), as
        // cpfg fills the string before the next step's `StartEach:`, or
        // the saved string at the end: a homomorphism that moves the
        // turtle reads the globals those blocks left.
        if let (Some(q), Some(f)) = (&queries, &dst) {
            if step && (i < steps || q.fills_last) {
                let generation = first_step + i - 1;
                let at = (tmpdir, tmp_name, limits);
                fill_queries(d, (q, homomorphism), f, (indexed, at), generation)?;
            }
        }
        if compares {
            if let Some(next) = &dst {
                if fixed_point(
                    fixed_points,
                    d.rng.draws() == draws && drew == 0,
                    &src,
                    next,
                )? {
                    events(&Event::FixedPoint {
                        from: first_step + i,
                        to: first_step + (steps - 1),
                    });
                    other = Some(src);
                    cur = dst;
                    i = last;
                    continue;
                }
            }
        }
        other = Some(src);
        cur = dst;
        if i == passes {
            // (The last pass may be number 2^64 - 1: the homomorphism
            // after `steps(u64::MAX - 1)`.)
            break;
        }
        i += 1;
    }
    Ok(last_len)
}

/// `--frames`: the steps up to the last frame, one temp file each; each
/// frame is the homomorphism (or a plain copy) of its generation, written
/// as text to its own destination, while the steps go on from the
/// generation itself.
#[allow(clippy::too_many_arguments)]
fn frame_passes(
    d: &mut Deriver,
    mut cur: Generation,
    (tables, homomorphism, hom): (&mut Tables, &crate::rules::Table, bool),
    settings: &Settings,
    frames: Frames,
    (sink_of_frames, tmp_name): (&mut dyn FrameSink, &str),
    indexed: bool,
    events: &mut dyn FnMut(&Event),
) -> Result<(u64, u64), Error> {
    let Settings {
        limits,
        ref tmpdir,
        first_step,
        ..
    } = *settings;
    let copy = crate::rules::Table::default();
    let (hom_seed, fixed_points) = (tables.hom_seed, tables.fixed_points);
    let mut last_len = (0, 0);
    let mut emit = |d: &mut Deriver, gen: &File, k: u64| -> Result<(), Error> {
        // Writing a frame leaves the generators as they were: the cpfg
        // dialect's choice draws once per module of every step pass, the
        // plain copy below included, and the next steps must draw what
        // `-n` draws.
        let rng = d.rng.clone();
        let written = sink_of_frames.frame(k, &mut |w, name| {
            let mut none = None;
            let mut out = sink(&mut none, tmp_name, w, name, limits, (false, false))?;
            if hom {
                // The homomorphism of generation k, as `lsgen -n k` applies
                // it: with its own `seed:`, a generator for this frame only.
                let stream = first_step + k - 1;
                let main = hom_seed.map(|s| d.rng.begin_homomorphism(s));
                d.rng.start_pass(stream, Region::Homomorphism);
                if !d.keeps_q() {
                    d.rng.set_step(stream);
                }
                let mut out = out.for_pass(Pass::Homomorphism);
                let r = d.pass(
                    homomorphism,
                    (gen, None),
                    indexed,
                    &mut out,
                    Pass::Homomorphism,
                );
                if let Some(main) = main {
                    d.rng.end_homomorphism(main);
                }
                r?;
                out.finish()
            } else {
                let pass = if k == 0 {
                    Pass::Axiom
                } else {
                    Pass::Step(first_step + (k - 1))
                };
                out = out.for_pass(pass);
                // A plain copy: no decomposition, no cut (the generation
                // already had them).
                let decomp = d.decomp.take();
                let cut = std::mem::replace(&mut d.cut, false);
                let r = d.pass(&copy, (gen, None), indexed, &mut out, pass);
                d.decomp = decomp;
                d.cut = cut;
                r?;
                out.finish()
            }
        });
        d.rng = rng;
        last_len = written?;
        Ok(())
    };
    // Each generation's queries filled before the next step reads it; a
    // frame is printed with them filled if cpfg fills its last string
    // (`fills_last`), else as the step left it.
    let queries = d.cpfg.as_ref().and_then(|c| c.queries.clone());
    let fill = |d: &mut Deriver, gen: &File, k: u64| match &queries {
        Some(q) => {
            let at = (tmpdir, tmp_name, limits);
            fill_queries(d, (q, homomorphism), gen, (indexed, at), k)
        }
        None => Ok(()),
    };
    let fills_last = queries.as_ref().is_some_and(|q| q.fills_last);
    if fills_last {
        fill(d, &cur, 0)?;
    }
    if frames.contains(0) {
        emit(d, &cur, 0)?;
    }
    if !fills_last {
        fill(d, &cur, 0)?;
    }
    let mut other: Option<Generation> = None;
    for i in 1..=frames.last() {
        let k = first_step + (i - 1);
        d.rng.start_pass(k, Region::Step);
        d.rng.set_step(k);
        let table = tables.table_for(k, d)?;
        let pass = Pass::Step(k);
        let mut dst = Some(next_generation(other.take(), tmpdir, tmp_name)?);
        let draws = d.rng.draws();
        d.cpfg_block(When::StartEach, pass)?;
        {
            let mut discard = io::sink();
            let mut out = sink(
                &mut dst,
                tmp_name,
                &mut discard,
                "",
                limits,
                (indexed, d.counts),
            )?
            .for_pass(pass);
            d.pass(&table, (&cur, None), indexed, &mut out, pass)?;
            let (modules, bytes) = out.finish()?;
            if let Some(f) = &mut dst {
                cut_to_written(f, tmp_name)?;
            }
            events(&Event::Generation {
                pass,
                modules,
                bytes,
            });
        }
        d.cpfg_block(When::EndEach, pass)?;
        if i == frames.last() && d.cpfg.as_ref().is_some_and(|c| i >= c.derivation_length) {
            d.cpfg_block(When::End, pass)?;
        }
        let dst = dst.expect("a generation");
        // (After `EndEach:` and `End:`, as `step_passes` fills.)
        if fills_last {
            fill(d, &dst, k)?;
        }
        // A step that drew nothing and left the string as it was is a
        // fixed point (as in `step_passes`): the later frames are this
        // generation, and are written without deriving the steps between
        // (`--frames` up to 2^53 would otherwise step through them all).
        drop(table);
        let fixed =
            i < frames.last() && fixed_point(fixed_points, d.rng.draws() == draws, &cur, &dst)?;
        other = Some(std::mem::replace(&mut cur, dst));
        if frames.contains(i) {
            emit(d, &cur, i)?;
        }
        if !fills_last && i < frames.last() {
            fill(d, &cur, k)?;
        }
        if fixed {
            events(&Event::FixedPoint {
                from: first_step + i,
                to: first_step + (frames.last() - 1),
            });
            // The frames after `i`, checked: `from + K` may pass 2^64 - 1.
            let mut k = if i < frames.from {
                Some(frames.from)
            } else {
                ((i - frames.from) / frames.every + 1)
                    .checked_mul(frames.every)
                    .and_then(|x| x.checked_add(frames.from))
            };
            while let Some(n) = k.filter(|&n| n <= frames.last()) {
                emit(d, &cur, n)?;
                k = n.checked_add(frames.every);
            }
            break;
        }
    }
    Ok(last_len)
}

/// The production tables of the steps (issue 11: groups and schedule).
struct Tables<'t> {
    productions: &'t mut crate::rules::Table,
    groups: &'t mut [(u32, crate::rules::Group)],
    schedule: &'t [u32],
    group_expr: Option<&'t crate::rules::expr::Code>,
    hom_seed: Option<u64>,
    /// A step that changed nothing means every later step changes
    /// nothing (not with groups, `step`, ...).
    fixed_points: bool,
    /// No structural rewriting and no `%` (a pass may be split between
    /// threads, `par::step_threads`).
    plain: bool,
}

impl<'t> Tables<'t> {
    /// The table of step `step` (1 for the first; `d.rng` has its number):
    /// group 0's, or the step's group laid over it until the result is
    /// dropped.
    fn table_for(&mut self, step: u64, d: &mut Deriver) -> Result<Laid<'_>, Error> {
        let g = if let Some(code) = self.group_expr {
            let v = code
                .eval(&[], &mut Vec::new(), &mut d.rng)
                .map_err(|e| d.origin.eval_error(e, Pass::Step(step)))?;
            let at = d.origin.locate(code.start());
            if !(0.0..=65535.0).contains(&v) || v.fract() != 0.0 {
                return Err(Error::at(
                    at,
                    crate::diag::RuntimeError::GroupNotNumber { value: v, step },
                ));
            }
            let g = v as u32;
            if g != 0 && !self.groups.iter().any(|(n, _)| *n == g) {
                return Err(Error::at(
                    at,
                    crate::diag::RuntimeError::GroupMissing {
                        group: g.into(),
                        step,
                    },
                ));
            }
            g
        } else if self.schedule.is_empty() {
            return Ok(Laid::plain(self.productions));
        } else {
            self.schedule[((step - 1) % self.schedule.len() as u64) as usize]
        };
        Ok(match self.groups.iter_mut().find(|(n, _)| *n == g) {
            Some((_, group)) => self.productions.lay(group),
            None => Laid::plain(self.productions),
        })
    }
}

/// Does a production of `t` read the built-in `step`?
fn uses_step(t: &crate::rules::Table) -> bool {
    t.prods.iter().any(|p| {
        p.cond
            .as_deref()
            .into_iter()
            .chain(p.prob())
            .any(|c| c.uses_step())
            || p.succ.iter().any(|i| match i {
                crate::rules::Item::Module { params, .. } => params.iter().any(|c| c.uses_step()),
                crate::rules::Item::Const(_) => false,
            })
    })
}

/// Can a production or decomposition successor make a `%`?
fn makes_percent(
    d: &Deriver,
    productions: &crate::rules::Table,
    groups: &[(u32, crate::rules::Group)],
) -> bool {
    let pct = u32::from(b'%');
    let tables = std::iter::once(productions)
        .chain(groups.iter().map(|(_, g)| g.own()))
        .chain(d.decomp.iter().map(|(t, _)| t));
    tables.flat_map(|t| t.prods.iter()).any(|p| {
        p.succ.iter().any(|i| match i {
            crate::rules::Item::Const(c) => {
                let b = c.bin();
                let mut i = 0;
                while i < b.len() {
                    let (k, kl) = crate::rules::codec::get_key(&b[i..]);
                    if k == pct {
                        return true;
                    }
                    i += kl + 8 * d.alphabet.arity(k);
                }
                false
            }
            crate::rules::Item::Module { key, .. } => *key == pct,
        })
    })
}

/// Do two generation files hold the same bytes?
/// Is a step from `before` to `after` a fixed point, every later step
/// doing the same: it drew nothing (`drew_nothing`), its rules allow it
/// ([`Tables::fixed_points`]) and it left the string as it was.
fn fixed_point(
    fixed_points: bool,
    drew_nothing: bool,
    before: &File,
    after: &File,
) -> Result<bool, Error> {
    Ok(fixed_points && drew_nothing && same_contents(before, after)?)
}

fn same_contents(a: &File, b: &File) -> Result<bool, Error> {
    use std::os::unix::fs::FileExt;
    let read_err = |e| Error::io("temporary file", crate::diag::IoAction::Read, e);
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
    use crate::api::{LSystem, Options};

    /// A batch's worker ([`spares::KeepSpares`]) gets back the generation
    /// files its last job emptied, at offset 0, for the same directory
    /// only, and derives as without them; other threads never do.
    #[test]
    fn a_batch_worker_reuses_its_emptied_generation_files() {
        use std::os::unix::fs::MetadataExt;
        let system = None;
        let dir = tempfile::tempdir().unwrap();
        let other = Some(dir.path().to_path_buf());
        let ino = |g: &Generation| g.metadata().unwrap().ino();
        let mut g = generation_file(&system).unwrap();
        g.write_all(b"abc").unwrap();
        drop(g);
        assert!(
            spares::take_generation(&system).is_none(),
            "kept without KeepSpares"
        );

        let keep = spares::KeepSpares::new();
        let mut g = generation_file(&system).unwrap();
        g.write_all(b"abc").unwrap();
        let kept = ino(&g);
        drop(g);
        let elsewhere = generation_file(&other).unwrap();
        assert_ne!(ino(&elsewhere), kept, "another directory's");
        let mut g = generation_file(&system).unwrap();
        assert_eq!(ino(&g), kept);
        assert_eq!(g.metadata().unwrap().len(), 0);
        assert_eq!(g.stream_position().unwrap(), 0);
        drop((g, elsewhere));
        // Jobs on a worker print what they print alone.
        let src = "productions:\nF -> F[+F]F : 0.5\nF -> FF-F : 0.5\naxiom: F\n";
        let options = Options::new().steps(4).seed(3).threads(1);
        let alone = {
            drop(keep);
            run(src, &options).unwrap().0
        };
        let _keep = spares::KeepSpares::new();
        for _ in 0..3 {
            assert_eq!(run(src, &options).unwrap().0, alone);
            // (The jobs went through kept files: they left some.)
            assert!(spares::holds_generations(), "a job left no generation file");
        }
    }

    fn run(src: &str, options: &Options) -> Result<(String, Vec<Event>), Error> {
        let mut ls = LSystem::parse(src)?;
        let mut out = Vec::new();
        let mut events = Vec::new();
        ls.derive_with(options, &mut out, |e| events.push(e.clone()))?;
        Ok((String::from_utf8(out).unwrap(), events))
    }

    #[test]
    fn every_strategy_derives_the_same_string() {
        // By hand: A, AB, ABA, ABAAB, ABAABABA, ABAABABAABAAB; and
        // F(1), F(2)[B], F(3)[B][BB], F(3)[BB][BBBB] (F(3) stays).
        let cases = [
            (
                "productions:\nA -> AB\nB -> A\naxiom: A\n",
                5,
                "ABAABABAABAAB\n",
            ),
            (
                "productions:\nF(x) : x < 3 -> F(x+1)[B]\nB -> BB\naxiom: F(1)\n",
                3,
                "F(3)[BB][BBBB]\n",
            ),
        ];
        for (src, n, want) in cases {
            for strategy in [Strategy::Auto, Strategy::Step, Strategy::DepthFirst] {
                // Depth first gives no lengths of the parametric system's
                // generations, so derive without asking for them.
                let mut ls = LSystem::parse(src).unwrap();
                let mut out = Vec::new();
                ls.derive(&Options::new().steps(n).strategy(strategy), &mut out)
                    .unwrap();
                assert_eq!(String::from_utf8(out).unwrap(), want, "{strategy:?}");
            }
        }
    }

    /// The last two passes give back what they have read of their input
    /// (`reclaim`; byte by byte where tests split), on one thread or
    /// split; the string is the one derived by hand.
    #[test]
    fn the_last_two_passes_give_back_what_they_read() {
        use super::reclaim::GIVEN_BACK;
        // A signal moving right from B, one moving left from C.
        let src = "productions:\nB < A -> B\nA > C -> C\naxiom: BAAAAAAAAAC\n";
        for threads in [1, 2, 8] {
            for n in 1..=4 {
                GIVEN_BACK.with(|g| g.set(0));
                let options = Options::new()
                    .steps(n)
                    .strategy(Strategy::Step)
                    .threads(threads)
                    .split(1);
                let (out, _) = run(src, &options).unwrap();
                let n = n as usize;
                let want = "B".repeat(n + 1) + &"A".repeat(9 - 2 * n) + &"C".repeat(n + 1) + "\n";
                assert_eq!(out, want, "-j {threads}, {n} steps");
                // All of each of the last two passes' input (11 bytes
                // each; one pass when n = 1).
                let given = GIVEN_BACK.with(|g| g.get());
                assert_eq!(given, 11 * n.min(2) as u64, "-j {threads}, {n} steps");
            }
        }
        // A fixed point is still found: the generations it compares are
        // not given back.
        GIVEN_BACK.with(|g| g.set(0));
        let options = Options::new().steps(6).strategy(Strategy::Step).split(1);
        let (out, events) = run("productions:\nA -> A\naxiom: AAAAAA\n", &options).unwrap();
        assert_eq!(out, "AAAAAA\n");
        assert!(events.iter().any(|e| matches!(e, Event::FixedPoint { .. })));
        assert!(
            GIVEN_BACK.with(|g| g.get()) <= 6,
            "only the last pass's input"
        );
    }

    #[test]
    fn step_by_step_reports_each_generation_and_the_fixed_point() {
        let src = "productions:\nA -> A\naxiom: AA\n";
        let (out, events) = run(src, &Options::new().steps(4).strategy(Strategy::Step)).unwrap();
        assert_eq!(out, "AA\n");
        let g = |pass, modules| Event::Generation {
            pass,
            modules,
            bytes: modules,
        };
        assert_eq!(
            events,
            [
                g(Pass::Axiom, 2),
                g(Pass::Step(1), 2),
                Event::FixedPoint { from: 2, to: 4 },
                g(Pass::Step(4), 2),
            ]
        );
    }

    /// Issue 11: with the bracket index (right contexts), a cut skips the
    /// rest of its branch in constant time, and the modules after it keep
    /// their draw positions (module indices of the old generation).
    #[test]
    fn a_cut_over_an_indexed_branch_does_not_scan_it() {
        use crate::derive::step::CUT_SCANNED;
        let n = 1_000_000;
        let fs = "F".repeat(n);
        let cs = "C".repeat(24);
        let derive = |prods: &str, first: &str| {
            CUT_SCANNED.with(|c| c.set(0));
            let src = format!("productions:\n{prods}\naxiom: [{first}{fs}]B{cs}\n");
            let (out, _) = run(&src, &Options::new().steps(1).seed(7)).unwrap();
            (out, CUT_SCANNED.with(|c| c.get()))
        };
        // `Z -> %`: a step can make a `%` (Z never occurs), so indexed
        // generations hold module counts.
        let stochastic = "C -> E : 1\nC -> G : 1\nZ -> %";
        // By hand: the `%` drops the F's, its `]` stays; B sees C.
        let (out, scanned) = derive(&format!("B > C -> D\n{stochastic}"), "%");
        assert_eq!(scanned, 0, "the cut walked the branch");
        assert_eq!(&out[..3], "[]D");
        // The C's draw as if the dropped modules were still there: as in
        // the same string with an X (no cut) instead of the `%`. 24 fair
        // draws: equal by chance once in 2^24.
        let (whole, _) = derive(&format!("B > C -> D\n{stochastic}"), "X");
        assert_eq!(whole, format!("[X{fs}]D{}", &out[3..]));
        assert!(out[3..].contains('E') && out[3..].contains('G'));
        // Without right contexts there is no index: the cut walks the
        // branch (so the count above can fail), with the same result.
        let (plain, scanned) = derive(&format!("B -> D\n{stochastic}"), "%");
        assert_eq!(scanned, n as u64 + 1, "the F's and the `]`");
        assert_eq!(plain, out);
        // Nor when only the axiom has a `%` (no counts in the index).
        let once = "B > C -> D\nC -> E : 1\nC -> G : 1";
        let (plain, scanned) = derive(once, "%");
        assert_eq!(scanned, n as u64 + 1);
        assert_eq!(plain, out);
    }

    #[test]
    fn depth_first_is_refused_where_it_does_not_apply() {
        let src = "productions:\nA < B -> A\naxiom: AB\n";
        let e = run(src, &Options::new().steps(2).strategy(Strategy::DepthFirst)).unwrap_err();
        assert!(matches!(
            e.kind(),
            crate::diag::ErrorKind::Usage(crate::diag::UsageError::NotDepthFirst)
        ));
        let (out, _) = run(src, &Options::new().steps(2)).unwrap();
        assert_eq!(out, "AA\n");
    }
}
