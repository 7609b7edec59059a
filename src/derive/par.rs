//! One string on several threads (`-j N`, issue 15), byte-identical for
//! every N.
//!
//! [`threads_for`] (depth first) and [`step_threads`] (a pass of the step
//! engine) are the one place that decides how many threads a derivation
//! uses. Two splits:
//!
//! - Depth first ([`expand`]), for deterministic parametric systems
//!   ([`ParamPlan`]): a module's expansion depends on the module alone (no
//!   context, no random draw), so the final string is the concatenation,
//!   in string order, of the expansions of the modules of any one
//!   generation. A producer walks the top generations
//!   ([`ParamPlan::split`]) and hands out consecutive runs of modules of a
//!   split generation as tasks; workers expand each task depth first
//!   ([`Walker`]).
//! - Step by step ([`step_pass`]), for a pass without contexts: a producer
//!   scans the generation and cuts it into chunks at module boundaries,
//!   counting modules; a worker rewrites a chunk with its own [`Deriver`],
//!   whose draws are placed by module index, so a chunk draws what one
//!   thread draws there.
//!
//! In both, workers hand their text to the calling thread in blocks of
//! about [`super::handoff::CHUNK`] bytes, and it writes the tasks' text in
//! task order ([`write_in_order`], in `handoff.rs`). Nothing a worker computes depends on which thread
//! runs it or when, so the output is the same for every thread count.
//!
//! A worker never waits for the writer to finish another task while that
//! task is the bottleneck ([`Current`]): a task the writer has not reached
//! keeps up to [`super::handoff::QUEUE`] blocks in memory (`BUDGET` for
//! all such tasks), and beyond that, while the writer waits for the task it is on, writes
//! its text to an unnamed spill file in the run's temporary directory,
//! which the writer copies out when it reaches the task; while the writer
//! is busy, spilling would only add to its work, so the worker waits.
//! Memory stays flat (bounded blocks per thread, whatever the string's
//! length); the spill files hold at most the text of the tasks handed out
//! ahead of the writer ([`IN_FLIGHT`] per thread). `LSGEN_DEBUG_PAR=1`
//! reports each thread's CPU time, waits and spills (benches/RESULTS.md).

use super::dfs::{ParamPlan, Split, Walker};
pub(crate) use super::handoff::Reuse;
use super::handoff::{write_in_order, Current, Msg, Order, Queue, Shared, Slot};
use super::reclaim::Reclaim;
use super::{Deriver, Origin, Out, Strategy};
use crate::diag::{Error, IoAction};
use crate::rules::codec;
use crate::rules::{Alphabet, ConstRun};
use std::fs::File;
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::mpsc::{self, Receiver};
use std::sync::{Arc, Mutex};

/// Tasks handed out ahead of the writer, per thread.
const IN_FLIGHT: usize = 16;
/// A chunk of a step pass weighs one task in the gate per this many bytes
/// of its start state (its left context: O(k x depth)), so that
/// the states ahead of the writer hold about `IN_FLIGHT` of these per
/// thread in all, and a deeply nested string's chunks go one at a time
/// (each start state is the size of one thread's own).
const STATE_UNIT: usize = 64 << 10;
/// Split at the first generation with at least this many modules per
/// thread (or the one before the last step): deep enough that a module's
/// expansion is rarely more than a few blocks.
const PER_THREAD: u64 = 16384;
/// Aim for tasks of about this much text (the producer batches modules
/// by the text each module gave so far).
const TASK_BYTES: u64 = 1 << 20;
/// Most modules of the split generation in one task, at first and again
/// once a task has passed `TASK_BYTES / 2`: the text per module so far is
/// a poor guide (a module gives from one module to a large subtree; a
/// batch of 65536 once gave a 43 MB task, and of 1024 a 20.9 MB one, in
/// parametric_tree -n 16).
const MAX_BATCH: u64 = 64;
/// Most modules in one task while every task done has stayed under
/// `TASK_BYTES / 8` (the cap doubles from [`MAX_BATCH`] each time a task
/// of the cap's size is done): 64-module tasks of 23 KB made `-j 2`
/// slower than `-j 1` on a 25 MB string (benches/RESULTS.md).
const WIDE_BATCH: u64 = 1024;
/// Tasks per thread, at least (see [`split_depth`]).
const TASKS: u64 = 16;

/// A thread count that means one per CPU ([`crate::Options::threads_all`]),
/// counted only when a derivation can be split: asking costs a run about
/// 12 k instructions (cgroup files), a tenth of a small run's start-up.
pub(crate) const ALL_CPUS: usize = 0;

/// `threads`, with [`ALL_CPUS`] counted, and at most [`started`] allows
/// (the CPUs are counted only where that cap can bind: past
/// [`PER_CPU`] threads).
fn resolve(threads: usize) -> usize {
    let cpus = || std::thread::available_parallelism().map_or(1, |n| n.get());
    match threads {
        ALL_CPUS => cpus(),
        1..=PER_CPU => threads,
        _ => started(threads, cpus()),
    }
}

/// The most threads lsgen starts for one derivation's split or for a
/// batch's jobs: [`PER_CPU`] per CPU and [`MOST_THREADS`] in all, however
/// large `-j` is. The work is CPU-bound: threads past the CPUs only
/// run ahead of the writer, hold blocks and spill them to files (`-j
/// 4096` on two CPUs: 876 MB, or "too many open files" after 10 minutes,
/// for what `-j 2` does in 0.3 s and 12 MB). The output does not depend
/// on the thread count, so this changes nothing but the cost.
pub(crate) fn started(threads: usize, cpus: usize) -> usize {
    threads
        .min(cpus.saturating_mul(PER_CPU))
        .clamp(1, MOST_THREADS)
}

/// Threads per CPU that [`started`] allows: a few, so that `-j 8` on a
/// small machine still splits as it would on eight CPUs.
const PER_CPU: usize = 4;
/// Threads [`started`] allows in all (zstd stops at 200 workers): a
/// pipe's or a file's worth of descriptors each stay far below the usual
/// limit of 1024 open files.
const MOST_THREADS: usize = 256;

/// How many threads the depth-first parametric strategy uses: `threads`
/// (`-j`) when there are at least two steps to split, else 1. (The D0L
/// byte plans are at the speed of writing already and stay on one thread;
/// frames too.)
pub(crate) fn threads_for(threads: usize, steps: u64, strategy: Strategy) -> usize {
    if steps < 2 || strategy == Strategy::Step {
        1
    } else {
        resolve(threads).max(1)
    }
}

/// Can a pass of `table` be split into chunks of the generation, derived
/// concurrently (the step engine, `-j N`)? When a module's rewriting
/// depends on the module, its index and its contexts, which a chunk gets
/// from the scan that cuts the pass (`super::split`; a bracket balance
/// check is judged by the writer, `split::Balance`): not with predecessors
/// of several modules, or the structural features (decomposition, cuts,
/// homomorphism depth) and cpfg's sequential generator (`plain`); no
/// `--max-length` (checked as the text is written, in order, on one
/// thread); and a generation (`len` bytes) of more than one chunk (many
/// steps over a short string must not start threads at each step).
/// (`indexed`: the generations carry a bracket index; split too, see
/// [`step_pass`].)
pub(crate) fn step_threads(
    threads: usize,
    table: &crate::rules::Table,
    (plain, _indexed, limited): (bool, bool, bool),
    (len, split): (u64, Option<u64>),
) -> usize {
    let free = !table.has_multi;
    if plain && free && !limited && len > split.unwrap_or(CHUNK_IN) {
        resolve(threads).max(1)
    } else {
        1
    }
}

/// Bytes of the generation read per chunk of a split pass.
const CHUNK_IN: u64 = 256 << 10;

/// `LSGEN_TEST_SPLIT=N` (or `Options::split`): split at N modules per
/// thread (depth first) and into chunks of N bytes (step by step), so that
/// tests split small strings.
pub(crate) fn test_split() -> Option<u64> {
    std::env::var("LSGEN_TEST_SPLIT")
        .ok()
        .and_then(|v| v.parse().ok())
        .filter(|&n| n > 0)
}

/// One pass of the step engine on `threads` threads: the generation in
/// `src` (`indexed`: with a bracket index; `one_byte`: Some(its length)
/// if each of its modules is one byte) is cut into chunks at module
/// boundaries (a scan on the producer thread, [`super::split::Scan`],
/// counting modules for the draw positions and keeping the left context
/// and nesting level each chunk starts from), each chunk rewritten by a
/// worker with its own [`Deriver`] (the same generator, positioned by
/// module index; right contexts read past the chunk's end), and the
/// chunks' output written to `out` in order. When `out` has a bracket
/// index, workers write it for the branches within their blocks and hand
/// the rest (a branch across blocks or chunks) to the writer, which
/// completes it ([`super::sink::ChunkIndex`]). The same bytes, draws and
/// first error as one thread. Returns the number of
/// draws made, or None when no thread could be started (then nothing was
/// written: the caller derives the pass on its own thread).
pub(crate) fn step_pass(
    d: &Deriver,
    table: &crate::rules::Table,
    (src, indexed, one_byte, reclaim): (&File, bool, Option<u64>, Option<&Reclaim>),
    (threads, split, reuse): (usize, Option<u64>, &Reuse),
    out: &mut Out,
    pass: super::Pass,
) -> Result<Option<u64>, Error> {
    debug_assert!(one_byte.is_none_or(|l| src.metadata().is_ok_and(|m| m.len() == l)));
    let draws = AtomicU64::new(0);
    let draws = &draws;
    let shared = &Shared::new(
        reuse,
        (super::handoff::STEP_BUDGET, super::handoff::STEP_PATIENCE),
        (threads, threads * IN_FLIGHT),
    )
    .giving_back(reclaim);
    let text = out.text;
    // The workers write the output's bracket index where they can.
    let out_index = (out.indexed, out.counts());
    let al = &d.alphabet;
    let counts = d.counts;
    let times = super::split::thread_times().then(super::split::CpuTimes::default);
    let times = times.as_ref();
    // Some(the writer's CPU time) when the pass was split.
    let done = std::thread::scope(|s| -> Result<Option<u64>, Error> {
        use super::split::{Chunk, Scan};
        let workers = |w, task_rx: Arc<Queue<Chunk>>| {
            let mut wd = Deriver::new(
                d.alphabet.clone(),
                d.rng.clone(),
                Origin {
                    path: d.origin.path,
                    header: d.origin.header,
                    map: d.origin.map,
                },
            );
            wd.warnings = d.warnings;
            move || {
                let current = Current::new(shared, w);
                let mut sink = std::io::sink();
                let mut out = worker_out(&mut sink, &current, text, out_index);
                let _timed = times.map(|t| super::split::Timed(t, false));
                loop {
                    let Some((chunk, slot)) = current.next(&task_rx) else {
                        break;
                    };
                    current.start(slot);
                    out.begin_chunk();
                    let before = (out.modules, wd.rng.draws());
                    let chunk_exact = chunk.exact;
                    wd.range = Some((chunk.start, chunk.end, chunk.first));
                    wd.chunk_start = Some(chunk.at);
                    wd.balance = table.check_balance.then(Default::default);
                    let r = wd
                        .pass(table, (src, reclaim), indexed, &mut out, pass)
                        .and_then(|()| out.flush());
                    if reclaim.is_some() {
                        // Read: the writer gives it back once the chunks
                        // before it are done too.
                        current.read_to(chunk.end);
                    }
                    out.buf.clear();
                    // (Module indices are only left uncounted where
                    // nothing draws: `Scan::skip`.)
                    debug_assert!(chunk_exact || wd.rng.draws() == before.1);
                    draws.fetch_add(wd.rng.draws() - before.1, Ordering::Relaxed);
                    // A chunk's balance goes before its end or error:
                    // its lows come first in string order.
                    let balance = wd.balance.take().map(Box::new);
                    let index = out.end_chunk();
                    current.end(r.map(|()| out.modules - before.0), balance, index);
                }
                current.report();
            }
        };
        let producer = move |order: &Order, task_tx: mpsc::Sender<(Chunk, Slot)>| {
            // Cut at the first module boundary past every `size` bytes.
            let size = split.unwrap_or(CHUNK_IN);
            let _timed = times.map(|t| super::split::Timed(t, true));
            let mut scan = Scan::new(src, (indexed, counts), table, al, size)
                .one_byte(one_byte)
                .giving_back(reclaim);
            let send = |chunk: Chunk| {
                let state = chunk.at.left.as_ref().map_or(0, |l| l.copy_bytes());
                order
                    .open_weighing(1 + state / STATE_UNIT)
                    .is_some_and(|slot| task_tx.send((chunk, slot)).is_ok())
            };
            loop {
                match scan.next_chunk(al) {
                    Ok(Some(chunk)) => {
                        if !send(chunk) {
                            break;
                        }
                    }
                    Ok(None) => break,
                    Err(e) => {
                        order.fail(Error::io("temporary file", IoAction::Read, e));
                        break;
                    }
                }
            }
        };
        let names = ("lsgen-step", "lsgen-chunks");
        let Some(order_rx) = spawn_split(s, shared, (threads, names), workers, producer) else {
            return Ok(None);
        };
        let writer = times.map(|_| super::split::thread_cpu_ns());
        let mut check = super::split::BalanceCheck::default();
        let mut judge = |b: &super::split::Balance| {
            check
                .next(b)
                .map_err(|culprit| super::step::unbalanced(&d.origin, table, culprit, pass))
        };
        let judge = table
            .check_balance
            .then_some(&mut judge as &mut dyn FnMut(&super::split::Balance) -> Result<(), Error>);
        write_in_order(order_rx, out, shared, judge)?;
        if table.check_balance && check.depth() != 0 {
            return Err(super::step::unclosed(
                &d.origin,
                table,
                check.last_opener,
                pass,
            ));
        }
        Ok(Some(
            writer.map_or(0, |w| super::split::thread_cpu_ns() - w),
        ))
    })?;
    if let (Some(t), Some(writer)) = (times, done) {
        t.report(pass, writer);
    }
    Ok(done.map(|_| draws.load(Ordering::Relaxed)))
}

/// The threads of a split: up to `threads` workers (`names.0`-w), worker
/// `w` running `make(w, queue)` over the one task queue, and a producer
/// (`names.1`) running `produce(order, tasks)`, which makes the tasks in
/// string order, each with its slot in the writer's order. The order's
/// receiver, for the writer ([`write_in_order`], on this thread); None
/// when no worker or no producer could be started: nothing was written,
/// and the workers end as the queue closes.
fn spawn_split<'scope, T, F>(
    s: &'scope std::thread::Scope<'scope, '_>,
    shared: &'scope Shared<'scope>,
    (threads, names): (usize, (&str, &str)),
    mut make: impl FnMut(usize, Arc<Queue<T>>) -> F,
    produce: impl FnOnce(&Order, mpsc::Sender<(T, Slot)>) + Send + 'scope,
) -> Option<Receiver<Receiver<Msg>>>
where
    T: Send + 'scope,
    F: FnOnce() + Send + 'scope,
{
    let (task_tx, task_rx) = mpsc::channel::<(T, Slot)>();
    let task_rx = Arc::new(Mutex::new(task_rx));
    let (order_tx, order_rx) = mpsc::channel::<Receiver<Msg>>();
    let workers = spawn_workers(s, (threads, names.0), |w| make(w, Arc::clone(&task_rx)));
    if workers == 0 {
        return None;
    }
    let builder = std::thread::Builder::new().name(names.1.into());
    let producer = crate::spawn::spawn_scoped(builder, s, move || {
        let order = Order::new(order_tx, shared);
        produce(&order, task_tx);
        order.report();
    });
    producer.is_ok().then_some(order_rx)
}

/// Start up to `threads` workers, named `name-w`, worker `w` running
/// `make(w)`: the number started (none past a thread that cannot be had).
fn spawn_workers<'scope, F>(
    s: &'scope std::thread::Scope<'scope, '_>,
    (threads, name): (usize, &str),
    mut make: impl FnMut(usize) -> F,
) -> usize
where
    F: FnOnce() + Send + 'scope,
{
    let mut workers = 0;
    for w in 0..threads {
        let builder = std::thread::Builder::new().name(format!("{name}-{w}"));
        let spawned = crate::spawn::spawn_scoped(builder, s, make(w));
        if spawned.is_err() {
            break;
        }
        workers += 1;
    }
    workers
}

/// A worker's sink: its text goes to `current` in blocks; with the
/// output's bracket index (`index`: indexed, with counts), what of it the
/// worker cannot write goes to the writer ([`Out::with_chunk_index`]).
fn worker_out<'w>(
    sink: &'w mut std::io::Sink,
    current: &'w Current,
    text: bool,
    (indexed, counts): (bool, bool),
) -> Out<'w> {
    let block = current.block();
    let mut out = Out::with_buffer(sink, "output", text, super::Limits::default(), block);
    if indexed {
        out = out.with_chunk_index(counts);
    }
    out.chunk = current.shared.chunk;
    out.taker = Some(current);
    out
}

/// Bytes of the axiom's text per task of [`axiom_prefix`].
const AXIOM_CHUNK: u64 = 256 << 10;

/// What [`axiom_prefix`] wrote.
pub(crate) enum AxiomPrefix {
    /// Plain modules up to file offset `at`, where the reader goes on
    /// ([`crate::io::axiom::AxiomReader::skip_plain`]) at nesting depth
    /// `depth`; `percent`: they hold a `%`.
    Upto { at: u64, depth: u64, percent: bool },
    /// A `]` among them closes nothing, or the split stopped short: what
    /// was written is to be dropped, and the axiom read on one thread
    /// (which reports the error where one thread does).
    Again,
}

/// Generation 0 on `threads` threads: the leading plain modules of the
/// axiom in the regular file `file` from offset `from` (of `len` bytes;
/// `comments`: `/` may open one), each its own byte (an axiom of many
/// megabytes is mostly such). The text is cut into pieces of
/// [`AXIOM_CHUNK`] bytes, at any byte: within plain modules every byte is
/// a module. A worker reads a piece (and two bytes past it) and writes
/// the modules [`crate::io::axiom::plain_prefix`] finds there, with the
/// bracket index as a chunk of a step pass does ([`step_pass`]); a piece
/// that ends early (parameters, blanks, a comment, the end of the axiom)
/// is the last written, and the one-thread reader goes on after it. The
/// writer judges each piece's brackets in order ([`super::split::Balance`]).
/// None when no thread could be started or the text is short (nothing
/// written).
pub(crate) fn axiom_prefix(
    (file, from, len, comments): (&File, u64, u64, bool),
    (threads, split, reuse): (usize, Option<u64>, &Reuse),
    (name, out): (&str, &mut Out),
) -> Result<Option<AxiomPrefix>, Error> {
    use crate::io::axiom::plain_prefix;
    let size = split.unwrap_or(AXIOM_CHUNK).max(1);
    if len.saturating_sub(from) <= 2 * size {
        return Ok(None);
    }
    let threads = resolve(threads);
    if threads < 2 {
        return Ok(None);
    }
    let shared = &Shared::new(
        reuse,
        (super::handoff::STEP_BUDGET, super::handoff::STEP_PATIENCE),
        (threads, threads * IN_FLIGHT),
    );
    let out_index = (out.indexed, out.counts());
    // The start of the first piece whose plain modules hold a `%`: only
    // those before where the reader goes on are written (a worker may read
    // a piece after that, whose `%` the reader may then take as a comment's
    // or a parameter's).
    let percent = &AtomicU64::new(u64::MAX);
    let mut check = super::split::BalanceCheck::default();
    let mut unbalanced = false;
    let written = std::thread::scope(|s| -> Result<Option<Option<u64>>, Error> {
        let workers = |w, task_rx: Arc<Queue<(u64, u64)>>| {
            move || {
                let current = Current::new(shared, w);
                let mut sink = std::io::sink();
                let mut out = worker_out(&mut sink, &current, false, out_index);
                let mut bytes = Vec::new();
                while let Some(((start, end), slot)) = current.next(&task_rx) {
                    current.start(slot);
                    out.begin_chunk();
                    let before = out.modules;
                    let mut balance = super::split::Balance::default();
                    let r = (|| {
                        bytes.resize(((end + 2).min(len) - start) as usize, 0);
                        // The file may hold less than its size said
                        // (sysfs; truncated meanwhile): its end is then
                        // the axiom's, as the reader finds it.
                        let got = read_upto_at(file, &mut bytes, start)
                            .map_err(|e| Error::io(name, IoAction::Read, e))?;
                        bytes.truncate(got);
                        let whole = ((end - start) as usize).min(got);
                        let p = plain_prefix(&bytes, whole, comments);
                        let plain = &bytes[..p.len];
                        if plain.contains(&b'%') {
                            percent.fetch_min(start, Ordering::Relaxed);
                        }
                        out.plain_in_blocks(plain)?;
                        out.flush()?;
                        if p.low < 0 {
                            balance.lows.push((p.low, None));
                        }
                        balance.depth = p.depth;
                        if p.stopped {
                            current.last(start + p.len as u64);
                        }
                        Ok(())
                    })();
                    out.buf.clear();
                    let index = out.end_chunk();
                    let modules = out.modules - before;
                    current.end(r.map(|()| modules), Some(Box::new(balance)), index);
                }
                current.report();
            }
        };
        let producer = move |order: &Order, task_tx: mpsc::Sender<((u64, u64), Slot)>| {
            let mut start = from;
            while start < len {
                let end = (start + size).min(len);
                let sent = order
                    .open()
                    .is_some_and(|slot| task_tx.send(((start, end), slot)).is_ok());
                if !sent {
                    break;
                }
                start = end;
            }
        };
        let names = ("lsgen-axiom", "lsgen-axiom");
        let Some(order_rx) = spawn_split(s, shared, (threads, names), workers, producer) else {
            return Ok(None);
        };
        let mut judge = |b: &super::split::Balance| {
            check.next(b).map_err(|_| {
                unbalanced = true;
                Error::new(crate::diag::RuntimeError::WorkerStopped)
            })
        };
        match write_in_order(order_rx, out, shared, Some(&mut judge)) {
            Ok(last) => Ok(Some(last)),
            Err(_) if unbalanced => Ok(Some(None)),
            Err(e) => Err(e),
        }
    })?;
    Ok(written.map(|last| match last {
        Some(at) => AxiomPrefix::Upto {
            at,
            depth: u64::try_from(check.depth()).unwrap_or(0),
            percent: percent.load(Ordering::Relaxed) < at,
        },
        None => AxiomPrefix::Again,
    }))
}

/// Read `buf.len()` bytes of `file` from offset `at`, fewer where the
/// file ends first: the number read.
fn read_upto_at(file: &File, buf: &mut [u8], at: u64) -> std::io::Result<usize> {
    use std::os::unix::fs::FileExt;
    let mut got = 0;
    while got < buf.len() {
        match file.read_at(&mut buf[got..], at + got as u64) {
            Ok(0) => break,
            Ok(n) => got += n,
            Err(e) if e.kind() == std::io::ErrorKind::Interrupted => {}
            Err(e) => return Err(e),
        }
    }
    Ok(got)
}

/// One task: modules (binary) of various generations, or inert runs, in
/// string order.
struct Task<'t> {
    items: Vec<Item<'t>>,
    bin: Vec<u8>,
}

enum Item<'t> {
    /// Generation, and the module's bytes in `bin`.
    Module(usize, usize, usize),
    Inert(&'t ConstRun),
}

/// The workers' queue: each task with its slot.
type Tasks<'t> = mpsc::Sender<(Task<'t>, Slot)>;

/// Write generation 0 (`input`) expanded by `steps` steps (homomorphism
/// applied) into `out` on `threads` threads; the same bytes as
/// [`ParamPlan::expand`]. An error is the first one in string order of
/// those the split found (a runtime error is then looked for again step by
/// step by the caller, as for one thread).
#[allow(clippy::too_many_arguments)]
pub(crate) fn expand<'t>(
    plan: &ParamPlan<'t>,
    input: &File,
    al: &Alphabet,
    origin: &Origin,
    steps: u64,
    (threads, split, reuse): (usize, Option<u64>, &Reuse),
    out: &mut Out,
) -> Result<(), Error> {
    let per_thread = split.unwrap_or(PER_THREAD);
    let (depth, most) = split_depth(plan, input, al, origin, steps, (threads, per_thread))?;
    let sizes = &Sizes::default();
    let shared = &Shared::new(
        reuse,
        (super::handoff::BUDGET, std::time::Duration::ZERO),
        (threads, threads * IN_FLIGHT),
    );
    std::thread::scope(|s| -> Result<(), Error> {
        let workers = |w, task_rx: Arc<Queue<Task<'t>>>| {
            move || work((plan, w), al, origin, steps, (&task_rx, shared), sizes)
        };
        let producer = move |order: &Order, task_tx: Tasks<'t>| {
            produce(
                plan,
                input,
                al,
                origin,
                (depth, most),
                (task_tx, order),
                sizes,
            );
        };
        let names = ("lsgen-par", "lsgen-split");
        let Some(order_rx) = spawn_split(s, shared, (threads, names), workers, producer) else {
            // No thread to be had: one thread does it all.
            return plan.expand(input, al, origin, steps, out);
        };
        // Write the tasks' text in task order.
        write_in_order(order_rx, out, shared, None).map(|_| ())
    })
}

/// The generation to split at: the first with at least `PER_THREAD`
/// modules per thread, at most the one before the last step; and the most
/// modules of it in one task, so that there are at least `TASKS` tasks per
/// thread (the modules of a generation expand to very different lengths).
fn split_depth(
    plan: &ParamPlan,
    input: &File,
    al: &Alphabet,
    origin: &Origin,
    steps: u64,
    (threads, per_thread): (usize, u64),
) -> Result<(usize, u64), Error> {
    let want = per_thread * threads as u64;
    let last = (steps - 1) as usize;
    // (Counting stops at `want`: past it the count only sizes `most`, and
    // a deep split generation costs a walk of all of it.)
    let cap = want;
    // Each try walks the path down to its generation again: in a string
    // that grows slowly (a chain, `A(x) -> F A(x+1)`) that is quadratic
    // in the steps (65,536 steps took over a minute at -j 2). Past this
    // much work the generation reached is taken, however few its modules
    // (a few large tasks: the same string, as at any depth).
    let budget = 8 * want;
    let mut spent = 0u64;
    let mut depth = 0;
    loop {
        let mut n = 0u64;
        plan.split(input, al, origin, depth, |_| {
            n += 1;
            Ok(n < cap)
        })?;
        spent += n + depth as u64;
        if n >= want || depth == last || spent > budget {
            return Ok((depth, (n / (TASKS * threads as u64)).max(1)));
        }
        depth += 1;
    }
}

/// The tasks done so far, for sizing the next ones: modules of the split
/// generation and their text in all, the most text of one task, the most
/// modules of one task.
#[derive(Default)]
struct Sizes {
    modules: AtomicU64,
    bytes: AtomicU64,
    largest: AtomicU64,
    widest: AtomicU64,
}

/// The producer: walk to generation `depth`, batch its modules into tasks
/// in string order, hand each to the workers and its result channel to
/// the writer. An error goes to the writer in its place.
fn produce<'t>(
    plan: &ParamPlan<'t>,
    input: &File,
    al: &Alphabet,
    origin: &Origin,
    (depth, most): (usize, u64),
    (task_tx, order): (Tasks<'t>, &Order),
    sizes: &Sizes,
) {
    let mut cap = MAX_BATCH;
    let mut task = Task {
        items: Vec::new(),
        bin: Vec::new(),
    };
    let mut stopped = false;
    let mut last_batch = 1u64;
    let send = |task: &mut Task<'t>| -> bool {
        let task = std::mem::replace(
            task,
            Task {
                items: Vec::new(),
                bin: Vec::new(),
            },
        );
        order
            .open()
            .is_some_and(|slot| task_tx.send((task, slot)).is_ok())
    };
    let r = plan.split(input, al, origin, depth, |item| {
        match item {
            Split::Module(j, key, params) => {
                let start = task.bin.len();
                codec::put_key(&mut task.bin, key);
                codec::put_params(&mut task.bin, params);
                task.items.push(Item::Module(j, start, task.bin.len()));
            }
            Split::Inert(c) => task.items.push(Item::Inert(c)),
        }
        // Batch as many modules as gave about TASK_BYTES of text so far,
        // at most `cap`.
        let (m, b) = (
            sizes.modules.load(Ordering::Relaxed),
            sizes.bytes.load(Ordering::Relaxed),
        );
        // Growing at most twofold from task to task, and at most `most`.
        let batch = TASK_BYTES
            .saturating_mul(m)
            .checked_div(b)
            .map_or(1, |n| n.clamp(1, cap));
        let batch = batch.min(last_batch * 2).min(most);
        if task.items.len() as u64 >= batch {
            last_batch = batch;
            if !send(&mut task) {
                stopped = true;
                return Ok(false);
            }
            let largest = sizes.largest.load(Ordering::Relaxed);
            if largest > TASK_BYTES / 2 {
                cap = MAX_BATCH;
            } else if largest < TASK_BYTES / 8 && sizes.widest.load(Ordering::Relaxed) >= cap {
                cap = (cap * 2).min(WIDE_BATCH);
            }
        }
        Ok(true)
    });
    if stopped {
        return;
    }
    match r {
        Ok(()) => {
            if !task.items.is_empty() {
                send(&mut task);
            }
        }
        Err(e) => {
            if !task.items.is_empty() && !send(&mut task) {
                return;
            }
            order.fail(e);
        }
    }
}

/// A worker: expand tasks until the producer is done. One [`Out`] (one
/// buffer, one number cache) for all its tasks.
fn work(
    (plan, id): (&ParamPlan, usize),
    al: &Alphabet,
    origin: &Origin,
    steps: u64,
    (tasks, shared): (&Queue<Task>, &Shared),
    sizes: &Sizes,
) {
    let mut walker = Walker::new(plan, al, steps);
    let current = Current::new(shared, id);
    let mut sink = std::io::sink();
    let block = current.block();
    let mut out = Out::with_buffer(&mut sink, "output", true, super::Limits::default(), block);
    out.chunk = shared.chunk;
    out.taker = Some(&current);
    while let Some((task, slot)) = current.next(tasks) {
        current.start(slot);
        let before = out.modules;
        let r = task
            .items
            .iter()
            .try_for_each(|item| match *item {
                Item::Module(j, s, e) => walker.expand(j, &task.bin[s..e], al, origin, &mut out),
                Item::Inert(c) => out.constant(c),
            })
            .and_then(|()| out.flush());
        // After an error the buffer holds text of this task only.
        out.buf.clear();
        if r.is_ok() {
            let (n, b) = (task.items.len() as u64, current.bytes.get());
            sizes.modules.fetch_add(n, Ordering::Relaxed);
            sizes.bytes.fetch_add(b, Ordering::Relaxed);
            sizes.largest.fetch_max(b, Ordering::Relaxed);
            sizes.widest.fetch_max(n, Ordering::Relaxed);
        }
        current.end(r.map(|()| out.modules - before), None, None);
    }
    current.report();
}

#[cfg(test)]
mod tests {
    use crate::api::{LSystem, Options};

    fn derive(src: &str, steps: u64, threads: usize, split: u64) -> Result<String, String> {
        let mut ls = LSystem::parse(src).map_err(|e| e.to_string())?;
        let mut out = Vec::new();
        let options = Options::new()
            .steps(steps)
            .seed(3)
            .threads(threads)
            .split(split);
        ls.derive(&options, &mut out).map_err(|e| e.to_string())?;
        Ok(String::from_utf8(out).unwrap())
    }

    /// The binary's default `-j` (one thread per CPU) is counted only
    /// where a derivation can be split, and never reaches a split as 0.
    #[test]
    fn started_threads_are_a_few_per_cpu_and_256_at_most() {
        use super::started;
        assert_eq!(started(8, 2), 8);
        assert_eq!(started(9, 2), 8);
        assert_eq!(started(4096, 2), 8);
        assert_eq!(started(64, 64), 64);
        assert_eq!(started(4096, 64), 256);
        assert_eq!(started(3, 1), 3);
        assert_eq!(started(0, 0), 1);
    }

    #[test]
    fn all_cpus_is_counted_where_a_derivation_splits() {
        use super::{threads_for, ALL_CPUS};
        use crate::derive::Strategy;
        let cpus = std::thread::available_parallelism().map_or(1, |n| n.get());
        assert_eq!(threads_for(ALL_CPUS, 1, Strategy::DepthFirst), 1);
        assert_eq!(threads_for(ALL_CPUS, 5, Strategy::Step), 1);
        assert_eq!(threads_for(ALL_CPUS, 5, Strategy::DepthFirst), cpus);
        assert_eq!(threads_for(3, 5, Strategy::DepthFirst), 3.min(4 * cpus));
        assert_eq!(
            threads_for(4096, 5, Strategy::DepthFirst),
            (4 * cpus).min(256)
        );
        let src = "productions:\nA(x) -> A(x+1)[B(x)]A(x+2)\naxiom: A(0)\n";
        let derive_all = || {
            let mut ls = LSystem::parse(src).unwrap();
            let mut out = Vec::new();
            let options = Options::new().steps(6).seed(3).threads_all().split(1);
            ls.derive(&options, &mut out).unwrap();
            String::from_utf8(out).unwrap()
        };
        assert_eq!(Ok(derive_all()), derive(src, 6, 1, 1));
    }

    /// Passes with left and right contexts split (issue 15), and so do
    /// passes that check bracket balance.
    #[test]
    fn context_and_balance_checked_passes_split() {
        use super::step_threads;
        let table = |src: &str| {
            let h = crate::lang::parse::parse_header(src).unwrap();
            crate::rules::compile(&h).unwrap().productions
        };
        let flags = (true, true, false);
        for src in [
            "productions:\nA < B -> C\n",
            "productions:\nA > [B]C -> C\n",
            "ignore: +\nproductions:\nA < B > C -> C : 1\nB -> D : 2\n",
        ] {
            assert_eq!(
                step_threads(3, &table(src), flags, (100, Some(5))),
                3,
                "{src}"
            );
            // A generation of one chunk is not split.
            assert_eq!(
                step_threads(3, &table(src), flags, (5, Some(5))),
                1,
                "{src}"
            );
        }
        // Bracket balance is judged by the writer: split too.
        let unbalanced = table("productions:\nA < B -> C]\n");
        assert!(unbalanced.check_balance);
        assert_eq!(step_threads(3, &unbalanced, flags, (100, Some(5))), 3);
    }

    /// The writer's verdict on chunks' bracket balance is one thread's:
    /// the first dip below depth 0, blaming the production one thread
    /// blames (a closer of an earlier chunk when the chunk has none yet).
    #[test]
    fn the_writer_judges_bracket_balance_across_chunks() {
        use super::super::split::{Balance, BalanceCheck};
        let mut check = BalanceCheck::default();
        // Chunk 1 ends 2 deeper; its last opener is production 4, its
        // last closer 5.
        let dip = |lows: Vec<(i64, Option<u32>)>, depth, opener, closer| Balance {
            lows,
            depth,
            last_opener: opener,
            last_closer: closer,
        };
        assert_eq!(check.next(&dip(vec![], 2, Some(4), Some(5))), Ok(()));
        // Depth 2 here: dips to -1 and -2 are fine, -3 is the error,
        // blaming the last closer before this chunk (5); a chunk judged
        // wrong changes nothing.
        let b = dip(
            vec![(-1, Some(6)), (-2, Some(7)), (-3, None)],
            -3,
            None,
            None,
        );
        assert_eq!(check.next(&b), Err(Some(5)));
        let b = dip(vec![(-1, Some(6)), (-2, Some(7))], -2, None, Some(7));
        assert_eq!(check.next(&b), Ok(()));
        assert_eq!((check.depth(), check.last_opener), (0, Some(4)));
        assert_eq!(
            check.next(&dip(vec![(-1, Some(9))], 0, None, None)),
            Err(Some(9))
        );
    }

    #[test]
    fn every_split_and_thread_count_gives_the_same_string() {
        // Depth first: branches, leaves above the split (B has no
        // production; C(x) for x >= 3 rewrites to itself), inert constant
        // runs ([+ ... ]), a homomorphism, and an error in step 4 of one
        // subtree only. Step by step: draws (a probability, ran), modules
        // with parameters of several bytes, an error in a late chunk.
        let systems = [
            "productions:\nA(x) : x < 5 -> F(x)[+A(x+1)]B[-A(x+2)]C(x)\n\
             A(x) : x >= 5 -> F(x)\nF(x) -> F(x*1.5)\n\
             C(x) : x < 3 -> C(x+1)[+B]\nC(x) : x >= 3 -> C(x)\n\
             homomorphism:\nB -> G(1)\naxiom: A(0)BA(1)\n",
            "productions:\nA(x) -> A(x+1)[B(x)]A(x+2)\nB(x) -> B(1/(x-7))\naxiom: A(0)\n",
            "productions:\nF -> F[+F]F[-F]F\naxiom: F\n",
            "productions:\nF -> F[+F]F : 1\nF -> F[-F]F : 2\nF -> FF : 1\naxiom: F\n",
            "productions:\nA(x) -> A(x+ran(1))[B(ran(2))]A(x*2)\nB(x) : x > 1.9 -> B(1/(x-x))\n\
             B(x) -> C\naxiom: A(0)\n",
            // Contexts (issue 15): left and right across branches and
            // chunks, ignored modules, draws, and an error in a late chunk.
            "ignore: +\nproductions:\nA < B -> B[+A]\nB > [A] -> AB\nA -> B+A\naxiom: AB\n",
            "productions:\nA(x) < A(y) > A(z) : y > 12 -> A(1/(z-z))\n\
             A(x) < A(y) > A(z) : x+y+z > 2 -> A(x+y+z)[A(1/(9-x))]\n\
             A(x) -> A(x+1)A(0)\naxiom: A(0)\n",
            "ignore: F\nproductions:\nX < Y > X -> F[Y]X : 1\nX < Y > X -> YF : 1\n\
             Y < X -> XY[X]\nX -> Y\nY -> XX\naxiom: XY\n",
            // Bracket balance judged across chunks: balanced; a `]` without
            // `[` (a production's, a copied one blaming a closer of an
            // earlier chunk); a `[` left open.
            "productions:\nA -> A[B\nC -> ]C\naxiom: AC\n",
            "productions:\nA -> A[B\nC -> ]C\nD -> ]\naxiom: FFFFFAFFFFFDC\n",
            "productions:\nB -> BB\nA -> ]\naxiom: [AFFFFFFFFFFB]\n",
            "productions:\nA -> [X\nB -> [Y\nC -> ]\naxiom: AFFFFBFFFFFCFFFF\n",
        ];
        for src in systems {
            for steps in 1..=6 {
                let one = derive(src, steps, 1, 1);
                for split in [1, 2, 5, 256] {
                    for threads in [2, 3, 8] {
                        let many = derive(src, steps, threads, split);
                        assert_eq!(one, many, "{src} -n {steps} -j {threads} ({split})");
                    }
                }
            }
        }
    }
}
