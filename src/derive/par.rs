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
//! about [`CHUNK`] bytes, and it writes the tasks' text in task order
//! ([`write_in_order`]). Nothing a worker computes depends on which thread
//! runs it or when, so the output is the same for every thread count.
//!
//! A worker never waits for the writer to finish another task while that
//! task is the bottleneck ([`Current`]): a task the writer has not reached
//! keeps up to [`QUEUE`] blocks in memory ([`BUDGET`] for all such tasks),
//! and beyond that, while the writer waits for the task it is on, writes
//! its text to an unnamed spill file in the run's temporary directory,
//! which the writer copies out when it reaches the task; while the writer
//! is busy, spilling would only add to its work, so the worker waits.
//! Memory stays flat (bounded blocks per thread, whatever the string's
//! length); the spill files hold at most the text of the tasks handed out
//! ahead of the writer ([`IN_FLIGHT`] per thread). `LSGEN_DEBUG_PAR=1`
//! reports each thread's CPU time, waits and spills (benches/RESULTS.md).

use super::dfs::{ParamPlan, Split, Walker};
use super::{Deriver, Origin, Out, Strategy};
use crate::diag::{Error, IoAction};
use crate::rules::codec;
use crate::rules::{Alphabet, ConstRun};
use std::cell::{Cell, RefCell};
use std::fs::File;
use std::os::unix::fs::FileExt;
use std::path::PathBuf;
use std::sync::atomic::{AtomicBool, AtomicU64, AtomicUsize, Ordering};
use std::sync::mpsc::{self, Receiver, SyncSender};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

/// A worker sends its text in blocks of about this size.
const CHUNK: usize = 256 << 10;
/// Text blocks a task not being written keeps in memory, at most; the
/// rest waits, or goes to a spill file until the writer reaches it.
const QUEUE: usize = 4;
/// Text blocks kept in memory by all the tasks not being written, at
/// most (about; beyond it they wait or spill).
const BUDGET: usize = 12;
/// Tasks handed out ahead of the writer, per thread.
const IN_FLIGHT: usize = 16;
/// Split at the first generation with at least this many modules per
/// thread (or the one before the last step): deep enough that a module's
/// expansion is rarely more than a few blocks.
const PER_THREAD: u64 = 16384;
/// Aim for tasks of about this much text (the producer batches modules
/// by the text each module gave so far).
const TASK_BYTES: u64 = 256 << 10;
/// Most modules of the split generation in one task (the text per module
/// so far is a poor guide: a module gives from one module to a large
/// subtree, and a batch of 65536 once gave a 43 MB task).
const MAX_BATCH: u64 = 64;
/// Tasks per thread, at least (see [`split_depth`]).
const TASKS: u64 = 16;

/// A thread count that means one per CPU ([`crate::Options::threads_all`]),
/// counted only when a derivation can be split: asking costs a run about
/// 12 k instructions (cgroup files), a tenth of a small run's start-up.
pub(crate) const ALL_CPUS: usize = 0;

/// `threads`, with [`ALL_CPUS`] counted.
fn resolve(threads: usize) -> usize {
    if threads == ALL_CPUS {
        std::thread::available_parallelism().map_or(1, |n| n.get())
    } else {
        threads
    }
}

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
/// `src` (`indexed`: with a bracket index) is cut into chunks at module
/// boundaries (a scan on the producer thread, [`super::split::Scan`],
/// counting modules for the draw positions and keeping the left context
/// and nesting level each chunk starts from), each chunk rewritten by a
/// worker with its own [`Deriver`] (the same generator, positioned by
/// module index; right contexts read past the chunk's end), and the
/// chunks' output written to `out` in order. Workers write no bracket
/// index (a branch may open in one chunk and close in another): when
/// `out` has one, the writer puts each block's brackets through it. The
/// same bytes, draws and first error as one thread. Returns the number of
/// draws made, or None when no thread could be started (then nothing was
/// written: the caller derives the pass on its own thread).
pub(crate) fn step_pass(
    d: &Deriver,
    table: &crate::rules::Table,
    (src, indexed): (&File, bool),
    (threads, split, tmpdir): (usize, Option<u64>, &Option<PathBuf>),
    out: &mut Out,
    pass: super::Pass,
) -> Result<Option<u64>, Error> {
    let draws = AtomicU64::new(0);
    let draws = &draws;
    let shared = &Shared::new(tmpdir);
    let text = out.text;
    let al = &d.alphabet;
    let counts = d.counts;
    let times = super::split::thread_times().then(super::split::CpuTimes::default);
    let times = times.as_ref();
    // Some(the writer's CPU time) when the pass was split.
    let done = std::thread::scope(|s| -> Result<Option<u64>, Error> {
        use super::split::{Chunk, Scan};
        let (task_tx, task_rx) = mpsc::channel::<(Chunk, Slot)>();
        let task_rx = Arc::new(Mutex::new(task_rx));
        let (order_tx, order_rx) = mpsc::sync_channel::<Receiver<Msg>>(threads * IN_FLIGHT);
        let mut workers = 0;
        for w in 0..threads {
            let task_rx = Arc::clone(&task_rx);
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
            let h = std::thread::Builder::new()
                .name(format!("lsgen-step-{w}"))
                .spawn_scoped(s, move || {
                    let current = Current::new(shared);
                    let mut sink = std::io::sink();
                    let mut out = Out::new(&mut sink, "output", text, super::Limits::default());
                    out.chunk = shared.chunk;
                    out.taker = Some(&current);
                    let _timed = times.map(|t| super::split::Timed(t, false));
                    loop {
                        let Some((chunk, slot)) = current.next(&task_rx) else {
                            break;
                        };
                        current.start(slot);
                        let before = (out.modules, wd.rng.draws());
                        wd.range = Some((chunk.start, chunk.end, chunk.first));
                        wd.chunk_start = Some(chunk.at);
                        wd.balance = table.check_balance.then(Default::default);
                        let r = wd
                            .pass(table, src, indexed, &mut out, pass)
                            .and_then(|()| out.flush());
                        out.buf.clear();
                        draws.fetch_add(wd.rng.draws() - before.1, Ordering::Relaxed);
                        // A chunk's balance goes before its end or error:
                        // its lows come first in string order.
                        let balance = wd.balance.take().map(Box::new);
                        current.end(r.map(|()| out.modules - before.0), balance);
                    }
                    current.report();
                });
            if h.is_err() {
                break;
            }
            workers += 1;
        }
        if workers == 0 {
            return Ok(None);
        }
        let producer = std::thread::Builder::new()
            .name("lsgen-chunks".into())
            .spawn_scoped(s, move || {
                let order = Order::new(order_tx, shared);
                // Cut at the first module boundary past every `size` bytes.
                let size = split.unwrap_or(CHUNK_IN);
                let _timed = times.map(|t| super::split::Timed(t, true));
                let mut scan = Scan::new(src, (indexed, counts), table, al, size);
                let send = |chunk: Chunk| {
                    order
                        .open()
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
                order.report();
            });
        if producer.is_err() {
            // The workers end when their task channel closes.
            return Ok(None);
        }
        // Brackets through `out`'s index, if it has one.
        let reindex = out.indexed.is_some().then_some(al);
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
        write_in_order(order_rx, out, shared, (reindex, judge))?;
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

/// Judges each chunk's bracket balance ([`write_in_order`]).
type Judge<'j> = Option<&'j mut dyn FnMut(&super::split::Balance) -> Result<(), Error>>;

/// The writer: each task's text, task after task, into `out`: its blocks
/// as they come, and what it spilled while it was not the one written. With
/// `reindex`, the blocks are binary modules without a bracket index, and
/// their brackets go through `out`'s ([`super::split::put_indexed`]).
/// `judge` judges each chunk's bracket balance.
fn write_in_order(
    order_rx: Receiver<Receiver<Msg>>,
    out: &mut Out,
    shared: &Shared,
    (reindex, mut judge): (Option<&Alphabet>, Judge),
) -> Result<(), Error> {
    let cpu = thread_cpu();
    let (mut waited, mut idle) = (Duration::ZERO, Duration::ZERO);
    let mut copy = Vec::new();
    let mut seq = 0;
    let r = loop {
        let t = Instant::now();
        let Ok(rx) = order_rx.recv() else {
            break Ok(());
        };
        idle += t.elapsed();
        shared.writing.store(seq, Ordering::SeqCst);
        seq += 1;
        let r = loop {
            let msg = match rx.try_recv() {
                Ok(msg) => Ok(msg),
                Err(_) => {
                    let t = Instant::now();
                    shared.starving.store(true, Ordering::Relaxed);
                    let msg = rx.recv();
                    shared.starving.store(false, Ordering::Relaxed);
                    waited += t.elapsed();
                    msg
                }
            };
            match msg {
                Ok(Msg::Text(block)) => {
                    shared.queued.fetch_sub(1, Ordering::Relaxed);
                    let r = match reindex {
                        Some(al) => super::split::put_indexed(out, &block, al)
                            .and_then(|()| out.maybe_flush()),
                        None => out.put_block(&block, 0),
                    };
                    if let Err(e) = r {
                        break Err(e);
                    }
                    shared.recycle(block);
                }
                Ok(Msg::Spilled(file, len)) => {
                    if let Err(e) = copy_spill(&file, (len, shared.chunk), &mut copy, out, reindex)
                    {
                        break Err(e);
                    }
                    shared.give_back(file);
                }
                Ok(Msg::End(modules)) => {
                    // (Reindexed blocks are counted module by module.)
                    out.extend(&[], if reindex.is_some() { 0 } else { modules });
                    break Ok(());
                }
                Ok(Msg::Balance(b)) => {
                    if let Some(judge) = &mut judge {
                        if let Err(e) = judge(&b) {
                            break Err(e);
                        }
                    }
                }
                Ok(Msg::Err(e)) => break Err(e),
                Err(_) => break Err(Error::new(crate::diag::RuntimeError::WorkerStopped)),
            }
        };
        if r.is_err() {
            break r;
        }
    };
    // Workers waiting for room must not wait for a writer that is gone.
    shared.closed.store(true, Ordering::Relaxed);
    if shared.debug {
        crate::diag::eprint(&format!(
            "lsgen: par: writer: cpu {:.3} s, waited {:.3} s for text, {:.3} s for tasks; {seq} tasks\n",
            (thread_cpu() - cpu).as_secs_f64(),
            waited.as_secs_f64(),
            idle.as_secs_f64(),
        ));
    }
    r
}

/// Write the `len` bytes of a spill file into `out`, through `buf`, in
/// pieces of `piece` bytes (a block: small in tests) (with
/// `reindex`, its brackets through `out`'s index: [`super::split::put_indexed`]).
fn copy_spill(
    file: &File,
    (len, piece): (u64, usize),
    buf: &mut Vec<u8>,
    out: &mut Out,
    reindex: Option<&Alphabet>,
) -> Result<(), Error> {
    let read = |buf: &mut [u8], at: u64| {
        file.read_exact_at(buf, at)
            .map_err(|e| Error::io("temporary file", IoAction::Read, e))
    };
    let Some(al) = reindex else {
        buf.resize(piece, 0);
        let mut at = 0;
        while at < len {
            let want = (len - at).min(piece as u64) as usize;
            read(&mut buf[..want], at)?;
            out.put_block(&buf[..want], 0)?;
            at += want as u64;
        }
        return Ok(());
    };
    // Reindexed: whole modules only, so a module cut by the end of a read
    // waits in `buf` for the rest of its bytes.
    buf.clear();
    let mut at = 0;
    loop {
        let keep = buf.len();
        let want = (len - at).min(piece as u64) as usize;
        buf.resize(keep + want, 0);
        read(&mut buf[keep..], at)?;
        at += want as u64;
        let last = at == len;
        let used = super::split::put_indexed_part(out, buf, al, last)?;
        out.maybe_flush()?;
        buf.drain(..used);
        if last {
            return Ok(());
        }
    }
}

/// This thread's CPU time.
fn thread_cpu() -> Duration {
    let mut ts = libc::timespec {
        tv_sec: 0,
        tv_nsec: 0,
    };
    // SAFETY: `ts` is a valid timespec for the call to fill.
    let ok = unsafe { libc::clock_gettime(libc::CLOCK_THREAD_CPUTIME_ID, &mut ts) } == 0;
    if ok {
        Duration::new(ts.tv_sec as u64, ts.tv_nsec as u32)
    } else {
        Duration::ZERO
    }
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

/// Where a task's text goes: its number in string order, and its channel
/// to the writer.
type Slot = (u64, SyncSender<Msg>);

/// The workers' queue: each task with its slot.
type Tasks<'t> = mpsc::Sender<(Task<'t>, Slot)>;

/// The workers' end of a queue.
type Queue<T> = Mutex<Receiver<(T, Slot)>>;

/// What a task sends to the writer.
enum Msg {
    Text(Vec<u8>),
    /// Text the task wrote to a spill file (from offset 0) before the
    /// writer reached it; the file goes back to [`Shared::spills`].
    Spilled(File, u64),
    /// The task is complete: its number of modules.
    End(u64),
    /// A chunk's bracket balance (sent before its end or error).
    Balance(Box<super::split::Balance>),
    Err(Error),
}

/// What the writer, the producer and the workers share.
struct Shared<'a> {
    /// The number of the task being written.
    writing: AtomicU64,
    /// Text blocks sent and not yet written.
    queued: AtomicUsize,
    /// The writer is waiting for text of the task it is on.
    starving: AtomicBool,
    /// The writer has stopped (done, or on an error).
    closed: AtomicBool,
    /// Written blocks, for reuse.
    pool: Mutex<Vec<Vec<u8>>>,
    /// Emptied spill files, for reuse.
    spills: Mutex<Vec<File>>,
    /// Where spill files are made (the run's `--tmpdir`).
    tmpdir: &'a Option<PathBuf>,
    /// `LSGEN_DEBUG_PAR`: each thread reports its CPU time and waits.
    debug: bool,
    /// The size of a block, the blocks a task not being written keeps in
    /// memory and all such tasks keep: [`CHUNK`], [`QUEUE`] and
    /// [`BUDGET`], or for tests (`LSGEN_TEST_SPILL=N`) N bytes, 1 and 1,
    /// so that small strings spill.
    chunk: usize,
    queue: usize,
    budget: usize,
    /// Spill as soon as there is no room in memory (tests).
    eager: bool,
}

impl<'a> Shared<'a> {
    fn new(tmpdir: &'a Option<PathBuf>) -> Self {
        let test = std::env::var("LSGEN_TEST_SPILL")
            .ok()
            .and_then(|v| v.parse().ok())
            .filter(|&n| n > 0);
        let (chunk, queue, budget) = test.map_or((CHUNK, QUEUE, BUDGET), |n| (n, 1, 1));
        Shared {
            writing: AtomicU64::new(0),
            queued: AtomicUsize::new(0),
            starving: AtomicBool::new(false),
            closed: AtomicBool::new(false),
            pool: Mutex::default(),
            spills: Mutex::default(),
            tmpdir,
            debug: std::env::var_os("LSGEN_DEBUG_PAR").is_some_and(|v| v == "1"),
            chunk,
            queue,
            budget,
            eager: test.is_some(),
        }
    }

    /// An empty block, written before if there is one.
    fn block(&self) -> Vec<u8> {
        let b = self.pool.lock().ok().and_then(|mut p| p.pop());
        let mut b = b.unwrap_or_else(|| Vec::with_capacity(CHUNK + codec::MAX_MODULE_BYTES * 4));
        b.clear();
        b
    }

    /// Keep a written block for reuse (a few).
    fn recycle(&self, block: Vec<u8>) {
        if let Ok(mut pool) = self.pool.lock() {
            if pool.len() < self.budget + self.queue {
                pool.push(block);
            }
        }
    }

    /// A spill file, emptied.
    fn spill_file(&self) -> Result<File, Error> {
        match self.spills.lock().ok().and_then(|mut s| s.pop()) {
            Some(f) => Ok(f),
            None => super::tempfile(self.tmpdir),
        }
    }

    /// Empty a spill file and keep it for reuse (or drop it).
    fn give_back(&self, file: File) {
        if file.set_len(0).is_ok() {
            if let Ok(mut s) = self.spills.lock() {
                s.push(file);
            }
        }
    }
}

/// The producer's end of the writer's queue: numbers the tasks.
struct Order<'a> {
    tx: SyncSender<Receiver<Msg>>,
    next: Cell<u64>,
    waited: Cell<Duration>,
    cpu: Duration,
    shared: &'a Shared<'a>,
}

impl<'a> Order<'a> {
    fn new(tx: SyncSender<Receiver<Msg>>, shared: &'a Shared<'a>) -> Self {
        Order {
            tx,
            next: Cell::new(0),
            waited: Cell::new(Duration::ZERO),
            cpu: thread_cpu(),
            shared,
        }
    }

    /// The next task's slot, its channel queued for the writer (waiting
    /// while [`IN_FLIGHT`] tasks per thread are ahead of it); None when
    /// the writer is gone.
    fn open(&self) -> Option<Slot> {
        // Room for QUEUE blocks, a chunk's balance, the spill file and the end: a task not
        // being written never waits for the writer.
        let (tx, rx) = mpsc::sync_channel(QUEUE + 3);
        let t = Instant::now();
        let sent = self.tx.send(rx).is_ok();
        self.waited.set(self.waited.get() + t.elapsed());
        let seq = self.next.get();
        self.next.set(seq + 1);
        sent.then_some((seq, tx))
    }

    /// `e` in place of the next task.
    fn fail(&self, e: Error) {
        if let Some((_, tx)) = self.open() {
            let _ = tx.send(Msg::Err(e));
        }
    }

    fn report(&self) {
        if self.shared.debug {
            crate::diag::eprint(&format!(
                "lsgen: par: producer: cpu {:.3} s, waited {:.3} s for the writer; {} tasks\n",
                (thread_cpu() - self.cpu).as_secs_f64(),
                self.waited.get().as_secs_f64(),
                self.next.get(),
            ));
        }
    }
}

/// The task a worker is on, and how its text reaches the writer: while
/// the writer is on the task, blocks go to its channel (waiting when it
/// is full); before, up to [`QUEUE`] blocks (and [`BUDGET`] in all) go to
/// the channel, and the rest, while the writer waits for text of the task
/// it is on, to a spill file, handed to the writer when it reaches the
/// task or at the task's end (while the writer is busy, the worker waits
/// instead). So memory stays bounded, and a worker waits for the writer
/// only while the writer is the bottleneck.
struct Current<'a> {
    tx: RefCell<Option<SyncSender<Msg>>>,
    seq: Cell<u64>,
    /// Blocks sent before the writer reached the task.
    ahead: Cell<usize>,
    /// Bytes of text of the task so far.
    bytes: Cell<u64>,
    /// The spill file and its length.
    spill: RefCell<Option<(File, u64)>>,
    /// A spill file's error (reported as such, not as the output's).
    spill_err: RefCell<Option<Error>>,
    shared: &'a Shared<'a>,
    // For `LSGEN_DEBUG_PAR`.
    cpu: Duration,
    waited: Cell<Duration>,
    idle: Cell<Duration>,
    spilled: Cell<u64>,
    tasks: Cell<u64>,
    largest: Cell<u64>,
    spills: Cell<u64>,
    spills_failed: Cell<u64>,
}

impl<'a> Current<'a> {
    fn new(shared: &'a Shared<'a>) -> Self {
        Current {
            tx: RefCell::new(None),
            seq: Cell::new(0),
            ahead: Cell::new(0),
            bytes: Cell::new(0),
            spill: RefCell::new(None),
            spill_err: RefCell::new(None),
            shared,
            cpu: thread_cpu(),
            waited: Cell::new(Duration::ZERO),
            idle: Cell::new(Duration::ZERO),
            spilled: Cell::new(0),
            tasks: Cell::new(0),
            largest: Cell::new(0),
            spills: Cell::new(0),
            spills_failed: Cell::new(0),
        }
    }

    /// The next task from `queue`, None when there are no more.
    fn next<T>(&self, queue: &Queue<T>) -> Option<(T, Slot)> {
        let t = Instant::now();
        let next = match queue.lock() {
            Ok(rx) => rx.recv().ok(),
            Err(_) => None,
        };
        self.idle.set(self.idle.get() + t.elapsed());
        next
    }

    fn start(&self, (seq, tx): Slot) {
        *self.tx.borrow_mut() = Some(tx);
        self.seq.set(seq);
        self.ahead.set(0);
        self.bytes.set(0);
        self.tasks.set(self.tasks.get() + 1);
    }

    /// The task is done (its number of modules) or failed: tell the
    /// writer, after what the task spilled.
    fn end(&self, r: Result<u64, Error>, balance: Option<Box<super::split::Balance>>) {
        let spill = self.spill.borrow_mut().take();
        let err = self.spill_err.borrow_mut().take();
        self.largest.set(self.largest.get().max(self.bytes.get()));
        let Some(tx) = self.tx.borrow_mut().take() else {
            return;
        };
        if let Some(b) = balance {
            if tx.send(Msg::Balance(b)).is_err() {
                return;
            }
        }
        match r {
            Ok(modules) => {
                if let Some((file, len)) = spill {
                    if tx.send(Msg::Spilled(file, len)).is_err() {
                        return;
                    }
                }
                let _ = tx.send(Msg::End(modules));
            }
            Err(e) => {
                if let Some((file, _)) = spill {
                    self.spills_failed.set(self.spills_failed.get() + 1);
                    self.shared.give_back(file);
                }
                let _ = tx.send(Msg::Err(err.unwrap_or(e)));
            }
        }
    }

    /// Send `block` of the task's text on its way to the writer.
    fn send(&self, block: Vec<u8>) -> std::io::Result<()> {
        let gone = || std::io::Error::from(std::io::ErrorKind::BrokenPipe);
        let tx = self.tx.borrow();
        let tx = tx.as_ref().ok_or_else(gone)?;
        let shared = self.shared;
        let mut since = None;
        loop {
            if shared.writing.load(Ordering::SeqCst) == self.seq.get() {
                // Being written: what was spilled first, then the block,
                // waiting while the channel is full.
                let t = *since.get_or_insert_with(Instant::now);
                if let Some((file, len)) = self.spill.borrow_mut().take() {
                    tx.send(Msg::Spilled(file, len)).map_err(|_| gone())?;
                }
                shared.queued.fetch_add(1, Ordering::Relaxed);
                tx.send(Msg::Text(block)).map_err(|_| gone())?;
                self.waited.set(self.waited.get() + t.elapsed());
                return Ok(());
            }
            let spilling = self.spill.borrow().is_some();
            if !spilling
                && self.ahead.get() < shared.queue
                && shared.queued.load(Ordering::Relaxed) < shared.budget
            {
                // (Never waits: the channel has room for QUEUE blocks.)
                self.ahead.set(self.ahead.get() + 1);
                shared.queued.fetch_add(1, Ordering::Relaxed);
                if let Some(t) = since {
                    self.waited.set(self.waited.get() + t.elapsed());
                }
                return tx.send(Msg::Text(block)).map_err(|_| gone());
            }
            // No room in memory. While the writer is waiting for the task
            // it is on, spill: that task is the bottleneck, and this
            // worker must not wait for it. Otherwise the writer is busy
            // (the bottleneck itself): spilling would only add to its
            // work, so wait a little for it.
            if shared.eager || shared.starving.load(Ordering::Relaxed) {
                if let Some(t) = since {
                    self.waited.set(self.waited.get() + t.elapsed());
                }
                return self.spill(block);
            }
            if shared.closed.load(Ordering::Relaxed) {
                return Err(gone());
            }
            since.get_or_insert_with(Instant::now);
            std::thread::sleep(Duration::from_micros(100));
        }
    }

    /// Append `block` to the task's spill file.
    fn spill(&self, block: Vec<u8>) -> std::io::Result<()> {
        let mut spill = self.spill.borrow_mut();
        if spill.is_none() {
            match self.shared.spill_file() {
                Ok(f) => {
                    *spill = Some((f, 0));
                    self.spills.set(self.spills.get() + 1);
                }
                Err(e) => return Err(self.failed(e)),
            }
        }
        let (file, len) = spill.as_mut().expect("a spill file");
        if let Err(e) = file.write_all_at(&block, *len) {
            let e = Error::io("temporary file", IoAction::Write, e);
            return Err(self.failed(e));
        }
        *len += block.len() as u64;
        self.spilled.set(self.spilled.get() + block.len() as u64);
        self.shared.recycle(block);
        Ok(())
    }

    /// Keep `e` to report, and fail the write.
    fn failed(&self, e: Error) -> std::io::Error {
        *self.spill_err.borrow_mut() = Some(e);
        std::io::Error::other("spill file")
    }

    fn report(&self) {
        if self.shared.debug {
            let name = std::thread::current()
                .name()
                .unwrap_or("worker")
                .to_string();
            crate::diag::eprint(&format!(
                "lsgen: par: {name}: cpu {:.3} s, waited {:.3} s for the writer, {:.3} s for tasks; \
                 {} tasks (largest {} bytes), {} spilled {} bytes, {} failed after spilling\n",
                (thread_cpu() - self.cpu).as_secs_f64(),
                self.waited.get().as_secs_f64(),
                self.idle.get().as_secs_f64(),
                self.tasks.get(),
                self.largest.get(),
                self.spills.get(),
                self.spilled.get(),
                self.spills_failed.get(),
            ));
        }
    }
}

impl super::sink::Take for Current<'_> {
    fn take(&self, buf: &mut Vec<u8>) -> std::io::Result<()> {
        if buf.is_empty() {
            return Ok(());
        }
        self.bytes.set(self.bytes.get() + buf.len() as u64);
        let block = std::mem::replace(buf, self.shared.block());
        self.send(block)
    }
}

/// Write generation 0 (`input`) expanded by `steps` steps (homomorphism
/// applied) into `out` on `threads` threads; the same bytes as
/// [`ParamPlan::expand`]. An error is the first one in string order of
/// those the split found (a runtime error is then looked for again step by
/// step by the caller, as for one thread).
#[allow(clippy::too_many_arguments)]
pub(crate) fn expand(
    plan: &ParamPlan,
    input: &File,
    al: &Alphabet,
    origin: &Origin,
    steps: u64,
    (threads, split, tmpdir): (usize, Option<u64>, &Option<PathBuf>),
    out: &mut Out,
) -> Result<(), Error> {
    let per_thread = split.unwrap_or(PER_THREAD);
    let (depth, most) = split_depth(plan, input, al, origin, steps, (threads, per_thread))?;
    // Modules of the split generation expanded so far and their text, for
    // sizing the next tasks.
    let done_modules = AtomicU64::new(0);
    let done_bytes = AtomicU64::new(0);
    let (done_modules, done_bytes) = (&done_modules, &done_bytes);
    let shared = &Shared::new(tmpdir);
    std::thread::scope(|s| -> Result<(), Error> {
        let (task_tx, task_rx) = mpsc::channel::<(Task, Slot)>();
        let task_rx = Arc::new(Mutex::new(task_rx));
        let (order_tx, order_rx) = mpsc::sync_channel::<Receiver<Msg>>(threads * IN_FLIGHT);
        let mut workers = 0;
        for w in 0..threads {
            let task_rx = Arc::clone(&task_rx);
            let h = std::thread::Builder::new()
                .name(format!("lsgen-par-{w}"))
                .spawn_scoped(s, move || {
                    work(
                        plan,
                        al,
                        origin,
                        steps,
                        (&task_rx, shared),
                        (done_modules, done_bytes),
                    )
                });
            if h.is_err() {
                break;
            }
            workers += 1;
        }
        let producer = (workers > 0).then(|| {
            std::thread::Builder::new()
                .name("lsgen-split".into())
                .spawn_scoped(s, move || {
                    let order = Order::new(order_tx, shared);
                    produce(
                        plan,
                        input,
                        al,
                        origin,
                        (depth, most),
                        (task_tx, &order),
                        (done_modules, done_bytes),
                    );
                    order.report();
                })
        });
        if !matches!(producer, Some(Ok(_))) {
            // No thread to be had: one thread does it all (the workers
            // end when their task channel closes).
            drop(order_rx);
            return plan.expand(input, al, origin, steps, out);
        }
        // Write the tasks' text in task order.
        write_in_order(order_rx, out, shared, (None, None))
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
    let mut depth = 0;
    loop {
        let mut n = 0u64;
        plan.split(input, al, origin, depth, |_| {
            n += 1;
            Ok(n < cap)
        })?;
        if n >= want || depth == last {
            return Ok((depth, (n / (TASKS * threads as u64)).max(1)));
        }
        depth += 1;
    }
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
    (done_modules, done_bytes): (&AtomicU64, &AtomicU64),
) {
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
        // Batch as many modules as gave about TASK_BYTES of text so far.
        let (m, b) = (
            done_modules.load(Ordering::Relaxed),
            done_bytes.load(Ordering::Relaxed),
        );
        // Growing at most twofold from task to task, and at most `most`.
        let batch = TASK_BYTES
            .saturating_mul(m)
            .checked_div(b)
            .map_or(1, |n| n.clamp(1, MAX_BATCH));
        let batch = batch.min(last_batch * 2).min(most);
        if task.items.len() as u64 >= batch {
            last_batch = batch;
            if !send(&mut task) {
                stopped = true;
                return Ok(false);
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
    plan: &ParamPlan,
    al: &Alphabet,
    origin: &Origin,
    steps: u64,
    (tasks, shared): (&Queue<Task>, &Shared),
    (done_modules, done_bytes): (&AtomicU64, &AtomicU64),
) {
    let mut walker = Walker::new(plan, al, steps);
    let current = Current::new(shared);
    let mut sink = std::io::sink();
    let mut out = Out::new(&mut sink, "output", true, super::Limits::default());
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
            done_modules.fetch_add(task.items.len() as u64, Ordering::Relaxed);
            done_bytes.fetch_add(current.bytes.get(), Ordering::Relaxed);
        }
        current.end(r.map(|()| out.modules - before), None);
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
    fn all_cpus_is_counted_where_a_derivation_splits() {
        use super::{threads_for, ALL_CPUS};
        use crate::derive::Strategy;
        let cpus = std::thread::available_parallelism().map_or(1, |n| n.get());
        assert_eq!(threads_for(ALL_CPUS, 1, Strategy::DepthFirst), 1);
        assert_eq!(threads_for(ALL_CPUS, 5, Strategy::Step), 1);
        assert_eq!(threads_for(ALL_CPUS, 5, Strategy::DepthFirst), cpus);
        assert_eq!(threads_for(3, 5, Strategy::DepthFirst), 3);
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
