//! How the split's threads hand their text to the writer (`-j N`, issue
//! 15), shared by both splits of [`super::par`]: each task's text reaches
//! the calling thread in blocks, in task order ([`write_in_order`]); a
//! task the writer has not reached keeps up to [`QUEUE`] blocks in memory
//! ([`BUDGET`] for all such tasks, [`STEP_BUDGET`] for a step pass's
//! chunks) and beyond that, while the writer waits
//! for the task it is on, spills to an unnamed file in the run's temporary
//! directory ([`Current`]); a chunk's bracket balance is judged in order.

use super::Out;
use crate::diag::{Error, IoAction};
use crate::rules::codec;
use std::cell::{Cell, RefCell};
use std::fs::File;
use std::os::unix::fs::FileExt;
use std::path::PathBuf;
use std::sync::atomic::{AtomicBool, AtomicU64, AtomicUsize, Ordering};
use std::sync::mpsc::{self, Receiver, Sender, SyncSender};
use std::sync::{Condvar, Mutex};
use std::time::{Duration, Instant};

/// A worker sends its text in blocks of about this size.
pub(super) const CHUNK: usize = 256 << 10;
/// Text blocks a task not being written keeps in memory, at most; the
/// rest waits, or goes to a spill file until the writer reaches it.
pub(super) const QUEUE: usize = 8;
/// Text blocks kept in memory by all the tasks not being written, at
/// most (about; beyond it they wait or spill), depth first: a task's
/// text varies a lot in length, and a worker ahead of a long one would
/// otherwise spill on a quiet machine.
pub(super) const BUDGET: usize = 24;
/// The same for the chunks of a step pass, which are each about a block
/// and take about as long as each other (and whose start states take
/// room of their own).
pub(super) const STEP_BUDGET: usize = 12;
/// Text blocks the task being written may add to those in memory past
/// the budget (which the tasks not being written fill): the writer always
/// has some of its text at hand, and memory stays within the budget and
/// these, however long the writer takes to write.
pub(super) const WRITTEN_ROOM: usize = 4;
/// How long a worker with no room in memory waits, from when it found none,
/// before a task's first spill, in a step pass (and the axiom's split): its
/// chunks are of one size and take about as long as each other, so a
/// worker far ahead of the writer means that the one on the chunk being
/// written lost its core to another thread (more threads than cores: the
/// writer, the producer); spilling would take more of the cores it needs.
/// Sleeping gives it one. (Depth first, a task may take far longer than
/// the others, and the worker spills at once.) context_signal 3 steps at
/// 10^8, `-j 2`, spilled 45-50 MB in the axiom's split alone without it,
/// 0.5 MB with 0.5 ms, nothing in any pass with 1 ms.
pub(super) const STEP_PATIENCE: Duration = Duration::from_millis(1);

/// What a run's splits keep from one pass to the next: written text
/// blocks and emptied spill files, and where spill files are made (the
/// run's `--tmpdir`). Each pass starts new threads; blocks made and freed
/// per pass landed in different malloc arenas, and a run's peak RSS grew
/// from pass to pass by megabytes that varied from run to run. Kept here,
/// a run holds the blocks of its busiest pass.
pub(crate) struct Reuse<'a> {
    tmpdir: &'a Option<PathBuf>,
    blocks: Mutex<Vec<Vec<u8>>>,
    spills: Mutex<Vec<File>>,
}

impl<'a> Reuse<'a> {
    pub(crate) fn new(tmpdir: &'a Option<PathBuf>) -> Self {
        Reuse {
            tmpdir,
            blocks: Mutex::default(),
            spills: Mutex::default(),
        }
    }
}

/// Judges each chunk's bracket balance ([`write_in_order`]).
pub(super) type Judge<'j> = Option<&'j mut dyn FnMut(&super::split::Balance) -> Result<(), Error>>;

/// The writer: each task's text, task after task, into `out`: its blocks
/// as they come, and what it spilled while it was not the one written; a
/// chunk's bracket index is completed where it ends ([`Msg::Index`]).
/// `judge` judges each chunk's bracket balance. Returns what a task marked
/// the last ([`Msg::Last`]) said, after which nothing more is written.
pub(super) fn write_in_order(
    order_rx: Receiver<Receiver<Msg>>,
    out: &mut Out,
    shared: &Shared,
    mut judge: Judge,
) -> Result<Option<u64>, Error> {
    let (cpu, began) = (thread_cpu(), Instant::now());
    let (mut waited, mut idle) = (Duration::ZERO, Duration::ZERO);
    // The final text: the output may write it around the page cache
    // (`io::output::WriteBehind`), until this returns.
    // The writer has a thread of its own: it writes them itself.
    let _direct = out.around_cache(false);
    // Tests (`LSGEN_TEST_SPILL`): the writer flushes at the size of a
    // block too, so that its flushes fall inside modules of spilled text.
    let flush_at = out.chunk;
    if shared.eager {
        out.chunk = shared.chunk;
    }
    let mut copy = Vec::new();
    let mut seq = 0;
    let mut last = None;
    let r = loop {
        if last.is_some() {
            break Ok(());
        }
        let t = Instant::now();
        let Ok(rx) = order_rx.recv() else {
            break Ok(());
        };
        idle += t.elapsed();
        shared.gate.reached();
        shared.writing.store(seq, Ordering::SeqCst);
        seq += 1;
        // Where the task's text starts, for its bracket index.
        let base = out.position();
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
                Ok(Msg::Text(block, owner)) => {
                    shared.queued.fetch_sub(1, Ordering::Relaxed);
                    if let Err(e) = out.put_block(&block, 0) {
                        break Err(e);
                    }
                    shared.recycle(block, owner);
                }
                Ok(Msg::Spilled(file, len)) => {
                    if let Err(e) = copy_spill(&file, (len, shared.chunk), &mut copy, out) {
                        break Err(e);
                    }
                    shared.give_back(file);
                }
                Ok(Msg::Index(ci)) => {
                    if let Err(e) = out.apply(&ci, base) {
                        break Err(e);
                    }
                }
                Ok(Msg::Read(to)) => {
                    // The tasks before it are done: nothing reads below
                    // the end of this one's input again.
                    if let Some(r) = shared.reclaim {
                        r.upto(to);
                    }
                }
                Ok(Msg::End(modules)) => {
                    out.extend(&[], modules);
                    break Ok(());
                }
                Ok(Msg::Last(at)) => last = Some(at),
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
    // Workers waiting for room must not wait for a writer that is gone,
    // nor the producer for room in the gate.
    shared.closed.store(true, Ordering::Relaxed);
    shared.gate.close();
    out.chunk = flush_at;
    if shared.debug {
        crate::diag::eprint(&format!(
            "lsgen: par: writer: wall {:.3} s, cpu {:.3} s, waited {:.3} s for text, {:.3} s for tasks; {seq} tasks\n",
            began.elapsed().as_secs_f64(),
            (thread_cpu() - cpu).as_secs_f64(),
            waited.as_secs_f64(),
            idle.as_secs_f64(),
        ));
    }
    r.map(|()| last)
}

/// Write the `len` bytes of a spill file into `out`, through `buf`, in
/// pieces of `piece` bytes (a block: small in tests).
pub(super) fn copy_spill(
    file: &File,
    (len, piece): (u64, usize),
    buf: &mut Vec<u8>,
    out: &mut Out,
) -> Result<(), Error> {
    buf.resize(piece, 0);
    let mut at = 0;
    while at < len {
        let want = (len - at).min(piece as u64) as usize;
        file.read_exact_at(&mut buf[..want], at)
            .map_err(|e| Error::io("temporary file", IoAction::Read, e))?;
        out.put_block(&buf[..want], 0)?;
        at += want as u64;
    }
    Ok(())
}

/// This thread's CPU time.
pub(super) fn thread_cpu() -> Duration {
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

/// Where a task's text goes: its number in string order, and its channel
/// to the writer.
pub(super) type Slot = (u64, SyncSender<Msg>);

/// The workers' end of a queue.
pub(super) type Queue<T> = Mutex<Receiver<(T, Slot)>>;

/// What a task sends to the writer.
pub(super) enum Msg {
    /// A block of text, and the number of the worker that wrote it.
    Text(Vec<u8>, usize),
    /// Text the task wrote to a spill file (from offset 0) before the
    /// writer reached it; the file goes back to [`Reuse`].
    Spilled(File, u64),
    /// The task is complete: its number of modules.
    End(u64),
    /// The task (a chunk of a step pass) has read all it reads of the
    /// input, which ends at this offset (sent before its end).
    Read(u64),
    /// The task is the last to write (sent before its end); what it tells
    /// the caller ([`super::par::axiom_prefix`]: where the axiom's reader
    /// goes on).
    Last(u64),
    /// A chunk's bracket balance (sent before its end or error).
    Balance(Box<super::split::Balance>),
    /// What of a chunk's bracket index its worker left to the writer (sent
    /// after all its text, before its end).
    Index(Box<super::sink::ChunkIndex>),
    Err(Error),
}

/// What the writer, the producer and the workers share.
pub(super) struct Shared<'a> {
    /// The number of the task being written.
    pub(super) writing: AtomicU64,
    /// Text blocks sent and not yet written.
    pub(super) queued: AtomicUsize,
    /// The writer is waiting for text of the task it is on.
    pub(super) starving: AtomicBool,
    /// The writer has stopped (done, or on an error).
    pub(super) closed: AtomicBool,
    /// Written blocks, for reuse, one pool per worker: a worker gets back
    /// the blocks it wrote, whose memory is still in its core's cache (a
    /// block another core wrote last costs a transfer per cache line: about
    /// a tenth of parametric_tree's CPU time at `-j 2`).
    pub(super) pools: Vec<Mutex<Vec<Vec<u8>>>>,
    /// Tasks handed out ahead of the writer.
    pub(super) gate: Gate,
    /// Blocks and spill files of the run's passes before, and for those
    /// after (emptied spill files go there at once, blocks at the end).
    pub(super) reuse: &'a Reuse<'a>,
    /// `LSGEN_DEBUG_PAR`: each thread reports its CPU time and waits.
    pub(super) debug: bool,
    /// The size of a block, the blocks a task not being written keeps in
    /// memory and all such tasks keep: [`CHUNK`], [`QUEUE`] and
    /// [`BUDGET`], or for tests (`LSGEN_TEST_SPILL=N`) N bytes, 1 and 1,
    /// so that small strings spill.
    pub(super) chunk: usize,
    pub(super) queue: usize,
    pub(super) budget: usize,
    /// How long a worker with no room waits before it spills
    /// ([`STEP_PATIENCE`], or none).
    patience: Duration,
    /// Spill as soon as there is no room in memory (tests).
    pub(super) eager: bool,
    /// A step pass's input, given back as its chunks are done
    /// ([`Msg::Read`]).
    reclaim: Option<&'a super::reclaim::Reclaim<'a>>,
}

impl<'a> Shared<'a> {
    /// For a split on `threads` workers whose tasks not being written keep
    /// `budget` blocks in all ([`BUDGET`], [`STEP_BUDGET`]), a worker with
    /// no room waiting `patience` for the writer before it spills, with at
    /// most `ahead` tasks handed out ahead of the writer ([`Gate`]).
    pub(super) fn new(
        reuse: &'a Reuse<'a>,
        (budget, patience): (usize, Duration),
        (threads, ahead): (usize, usize),
    ) -> Self {
        let test = std::env::var("LSGEN_TEST_SPILL")
            .ok()
            .and_then(|v| v.parse().ok())
            .filter(|&n| n > 0);
        let (chunk, queue, budget) = test.map_or((CHUNK, QUEUE, budget), |n| (n, 1, 1));
        Shared {
            writing: AtomicU64::new(0),
            queued: AtomicUsize::new(0),
            starving: AtomicBool::new(false),
            closed: AtomicBool::new(false),
            pools: (0..threads.max(1)).map(|_| Mutex::default()).collect(),
            gate: Gate::new(ahead),
            reuse,
            debug: std::env::var_os("LSGEN_DEBUG_PAR").is_some_and(|v| v == "1"),
            chunk,
            queue,
            budget,
            patience,
            eager: test.is_some(),
            reclaim: None,
        }
    }

    /// A step pass whose input is given back as its chunks are done.
    pub(super) fn giving_back(mut self, reclaim: Option<&'a super::reclaim::Reclaim<'a>>) -> Self {
        self.reclaim = reclaim;
        self
    }

    /// An empty block, written before if there is one: worker `owner`'s
    /// own first, then another's (so that no more blocks exist than one
    /// pool for all would make), then one a pass before wrote.
    pub(super) fn block(&self, owner: usize) -> Vec<u8> {
        let n = self.pools.len();
        let b = (0..n)
            .find_map(|i| self.pool(owner + i).lock().ok().and_then(|mut p| p.pop()))
            .or_else(|| self.reuse.blocks.lock().ok().and_then(|mut p| p.pop()));
        let mut b = b.unwrap_or_else(|| Vec::with_capacity(CHUNK + codec::MAX_MODULE_BYTES * 4));
        b.clear();
        b
    }

    /// Keep a written block for reuse (a few).
    pub(super) fn recycle(&self, block: Vec<u8>, owner: usize) {
        if let Ok(mut pool) = self.pool(owner).lock() {
            // (As many in all as one pool held.)
            if pool.len() < ((self.budget + self.queue) / self.pools.len()).max(self.queue) {
                pool.push(block);
            }
        }
    }

    fn pool(&self, owner: usize) -> &Mutex<Vec<Vec<u8>>> {
        &self.pools[owner % self.pools.len()]
    }

    /// A spill file, emptied.
    pub(super) fn spill_file(&self) -> Result<File, Error> {
        match self.reuse.spills.lock().ok().and_then(|mut s| s.pop()) {
            Some(f) => Ok(f),
            None => super::tempfile(self.reuse.tmpdir),
        }
    }

    /// Empty a spill file and keep it for reuse (or drop it).
    pub(super) fn give_back(&self, file: File) {
        if file.set_len(0).is_ok() {
            if let Ok(mut s) = self.reuse.spills.lock() {
                s.push(file);
            }
        }
    }
}

impl Drop for Shared<'_> {
    /// The pass's blocks go to the run's next pass.
    fn drop(&mut self) {
        if let Ok(mut kept) = self.reuse.blocks.lock() {
            for pool in &self.pools {
                if let Ok(mut pool) = pool.lock() {
                    kept.append(&mut pool);
                }
            }
        }
    }
}

/// How many tasks are handed out ahead of the writer: the producer waits
/// while `most` are, and the writer wakes it only once half of them are
/// reached, so that the producer (and the thread it takes the place of)
/// switches once per `most / 2` tasks, not once per task.
///
/// A task may weigh more than one ([`Order::open_weighing`]): a chunk of a
/// deeply nested string carries a large start state (the left context of
/// every open branch), and `most` of those ahead would hold `most` copies
/// of it. A task heavier than the room left waits until nothing is ahead.
pub(super) struct Gate {
    ahead: Mutex<Ahead>,
    room: Condvar,
    most: usize,
}

struct Ahead {
    /// The weight of the tasks ahead of the writer.
    weight: usize,
    /// Their weights, oldest first, where some weighs more than one (the
    /// writer reaches tasks in the order they entered).
    heavy: std::collections::VecDeque<usize>,
    /// Tasks ahead that entered after the last heavy one, or while none
    /// was ahead, weigh one each: how many lead `heavy`.
    light: usize,
    closed: bool,
}

impl Gate {
    fn new(most: usize) -> Self {
        Gate {
            ahead: Mutex::new(Ahead {
                weight: 0,
                heavy: std::collections::VecDeque::new(),
                light: 0,
                closed: false,
            }),
            room: Condvar::new(),
            most: most.max(2),
        }
    }

    /// Wait for room for one more task of weight `w` (at least 1) and
    /// count it; false when the writer has stopped.
    fn enter(&self, w: usize) -> bool {
        let w = w.max(1);
        let Ok(mut g) = self.ahead.lock() else {
            return false;
        };
        while g.weight > 0 && g.weight + w > self.most && !g.closed {
            g = match self.room.wait(g) {
                Ok(g) => g,
                Err(_) => return false,
            };
        }
        g.weight += w;
        if w > 1 || !g.heavy.is_empty() {
            // Lights before the first heavy one are counted in `light`;
            // after it, each is queued.
            g.heavy.push_back(w);
        } else {
            g.light += 1;
        }
        !g.closed
    }

    /// The writer reached a task.
    fn reached(&self) {
        if let Ok(mut g) = self.ahead.lock() {
            let w = if g.light > 0 {
                g.light -= 1;
                1
            } else {
                g.heavy.pop_front().unwrap_or(1)
            };
            let before = g.weight;
            g.weight = before.saturating_sub(w);
            // Wake the producer once half the room is free (not at every
            // task), or when nothing is ahead (a heavy task waits for it).
            if (before > self.most / 2 && g.weight <= self.most / 2) || g.weight == 0 {
                self.room.notify_one();
            }
        }
    }

    /// The writer has stopped: nothing waits for room any more.
    fn close(&self) {
        if let Ok(mut g) = self.ahead.lock() {
            g.closed = true;
        }
        self.room.notify_all();
    }
}

/// The producer's end of the writer's queue: numbers the tasks.
pub(super) struct Order<'a> {
    pub(super) tx: Sender<Receiver<Msg>>,
    pub(super) next: Cell<u64>,
    pub(super) waited: Cell<Duration>,
    pub(super) cpu: Duration,
    pub(super) shared: &'a Shared<'a>,
}

impl<'a> Order<'a> {
    pub(super) fn new(tx: Sender<Receiver<Msg>>, shared: &'a Shared<'a>) -> Self {
        Order {
            tx,
            next: Cell::new(0),
            waited: Cell::new(Duration::ZERO),
            cpu: thread_cpu(),
            shared,
        }
    }

    /// The next task's slot, its channel queued for the writer (waiting
    /// for room in the [`Gate`]); None when the writer is gone.
    pub(super) fn open(&self) -> Option<Slot> {
        self.open_weighing(1)
    }

    /// [`Order::open`] for a task that weighs `w` in the [`Gate`].
    pub(super) fn open_weighing(&self, w: usize) -> Option<Slot> {
        // Room for QUEUE blocks, a chunk's balance, the spill file, its
        // index, whether it is the last, how far it read, and the end: a
        // task not being written never waits for the writer.
        let (tx, rx) = mpsc::sync_channel(QUEUE + 6);
        let t = Instant::now();
        let sent = self.shared.gate.enter(w) && self.tx.send(rx).is_ok();
        self.waited.set(self.waited.get() + t.elapsed());
        let seq = self.next.get();
        self.next.set(seq + 1);
        sent.then_some((seq, tx))
    }

    /// `e` in place of the next task.
    pub(super) fn fail(&self, e: Error) {
        if let Some((_, tx)) = self.open() {
            let _ = tx.send(Msg::Err(e));
        }
    }

    pub(super) fn report(&self) {
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
/// is full, or [`WRITTEN_ROOM`] past the budget); before, up to
/// [`QUEUE`] blocks (and [`BUDGET`] in all) go to the channel, and the
/// rest, while the writer waits for text of the task it is on, to a
/// spill file (in a step pass after waiting up to [`STEP_PATIENCE`] for
/// room), handed to the writer when it reaches the task or at the task's
/// end (while the writer is busy, the worker waits instead). So memory
/// stays bounded, and a worker waits for the writer only while the writer
/// is the bottleneck.
pub(super) struct Current<'a> {
    pub(super) tx: RefCell<Option<SyncSender<Msg>>>,
    pub(super) seq: Cell<u64>,
    /// Blocks sent before the writer reached the task.
    pub(super) ahead: Cell<usize>,
    /// Bytes of text of the task so far.
    pub(super) bytes: Cell<u64>,
    /// The spill file and its length.
    pub(super) spill: RefCell<Option<(File, u64)>>,
    /// A spill file's error (reported as such, not as the output's).
    pub(super) spill_err: RefCell<Option<Error>>,
    pub(super) shared: &'a Shared<'a>,
    /// The worker's number (its pool of blocks).
    id: usize,
    // For `LSGEN_DEBUG_PAR`.
    pub(super) cpu: Duration,
    pub(super) waited: Cell<Duration>,
    pub(super) idle: Cell<Duration>,
    pub(super) spilled: Cell<u64>,
    pub(super) tasks: Cell<u64>,
    pub(super) largest: Cell<u64>,
    pub(super) spills: Cell<u64>,
    pub(super) spills_failed: Cell<u64>,
}

impl<'a> Current<'a> {
    /// Worker `id`'s.
    pub(super) fn new(shared: &'a Shared<'a>, id: usize) -> Self {
        Current {
            id,
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
    pub(super) fn next<T>(&self, queue: &Queue<T>) -> Option<(T, Slot)> {
        let t = Instant::now();
        let next = match queue.lock() {
            Ok(rx) => rx.recv().ok(),
            Err(_) => None,
        };
        self.idle.set(self.idle.get() + t.elapsed());
        next
    }

    /// An empty block for the worker's sink to start with.
    pub(super) fn block(&self) -> Vec<u8> {
        self.shared.block(self.id)
    }

    pub(super) fn start(&self, (seq, tx): Slot) {
        *self.tx.borrow_mut() = Some(tx);
        self.seq.set(seq);
        self.ahead.set(0);
        self.bytes.set(0);
        self.tasks.set(self.tasks.get() + 1);
    }

    /// The task (a chunk of a step pass) read its input up to `to`: the
    /// writer gives that back when it reaches the task ([`Msg::Read`]).
    pub(super) fn read_to(&self, to: u64) {
        if let Some(tx) = &*self.tx.borrow() {
            let _ = tx.send(Msg::Read(to));
        }
    }

    /// The task is done (its number of modules) or failed: tell the
    /// writer, after what the task spilled.
    pub(super) fn end(
        &self,
        r: Result<u64, Error>,
        balance: Option<Box<super::split::Balance>>,
        index: Option<Box<super::sink::ChunkIndex>>,
    ) {
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
                if let Some(ci) = index {
                    if tx.send(Msg::Index(ci)).is_err() {
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

    /// The task is the last one the writer writes ([`Msg::Last`]).
    pub(super) fn last(&self, at: u64) {
        if let Some(tx) = self.tx.borrow().as_ref() {
            let _ = tx.send(Msg::Last(at));
        }
    }

    /// Send `block` of the task's text on its way to the writer.
    pub(super) fn send(&self, block: Vec<u8>) -> std::io::Result<()> {
        let gone = || std::io::Error::from(std::io::ErrorKind::BrokenPipe);
        let tx = self.tx.borrow();
        let tx = tx.as_ref().ok_or_else(gone)?;
        let shared = self.shared;
        let mut since = None;
        loop {
            if shared.writing.load(Ordering::SeqCst) == self.seq.get() {
                // Being written: what was spilled first, then the block,
                // waiting while the channel is full, and while the blocks
                // in memory are [`WRITTEN_ROOM`] past the budget, unless
                // the writer waits for this task's text: so a writer held
                // up in its writes does not let this task's blocks pile
                // up on top of the budget the others keep.
                let t = *since.get_or_insert_with(Instant::now);
                if shared.queued.load(Ordering::Relaxed) >= shared.budget + WRITTEN_ROOM
                    && !shared.starving.load(Ordering::Relaxed)
                    && !shared.closed.load(Ordering::Relaxed)
                {
                    std::thread::sleep(Duration::from_micros(100));
                    continue;
                }
                if let Some((file, len)) = self.spill.borrow_mut().take() {
                    tx.send(Msg::Spilled(file, len)).map_err(|_| gone())?;
                }
                shared.queued.fetch_add(1, Ordering::Relaxed);
                tx.send(Msg::Text(block, self.id)).map_err(|_| gone())?;
                self.waited.set(self.waited.get() + t.elapsed());
                return Ok(());
            }
            let spilling = self.spill.borrow().is_some();
            // (Counted only below the budget, in one step: workers that
            // looked and then counted could pass it together, by up to a
            // block each, and hold the task being written back.)
            if !spilling
                && self.ahead.get() < shared.queue
                && shared
                    .queued
                    .fetch_update(Ordering::Relaxed, Ordering::Relaxed, |q| {
                        (q < shared.budget).then_some(q + 1)
                    })
                    .is_ok()
            {
                // (Never waits: the channel has room for QUEUE blocks.)
                self.ahead.set(self.ahead.get() + 1);
                if let Some(t) = since {
                    self.waited.set(self.waited.get() + t.elapsed());
                }
                return tx.send(Msg::Text(block, self.id)).map_err(|_| gone());
            }
            // No room in memory. While the writer is waiting for the task
            // it is on, spill (a task's first spill after `patience`,
            // [`STEP_PATIENCE`]): that task is the bottleneck, and this
            // worker must not wait for it. Otherwise the writer is busy
            // (the bottleneck itself): spilling would only add to its
            // work, so wait a little for it.
            let t = *since.get_or_insert_with(Instant::now);
            let patient = !spilling && t.elapsed() < shared.patience;
            if shared.eager || (shared.starving.load(Ordering::Relaxed) && !patient) {
                self.waited.set(self.waited.get() + t.elapsed());
                return self.spill(block);
            }
            if shared.closed.load(Ordering::Relaxed) {
                return Err(gone());
            }
            std::thread::sleep(Duration::from_micros(100));
        }
    }

    /// Append `block` to the task's spill file.
    pub(super) fn spill(&self, block: Vec<u8>) -> std::io::Result<()> {
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
        self.shared.recycle(block, self.id);
        Ok(())
    }

    /// Keep `e` to report, and fail the write.
    pub(super) fn failed(&self, e: Error) -> std::io::Error {
        *self.spill_err.borrow_mut() = Some(e);
        std::io::Error::other("spill file")
    }

    pub(super) fn report(&self) {
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
        let block = std::mem::replace(buf, self.shared.block(self.id));
        self.send(block)
    }
}

#[cfg(test)]
mod tests {
    use super::{Gate, Shared};
    use std::time::Duration;

    /// The producer waits while `most` tasks are ahead of the writer and
    /// is let in again only once half of them are reached; closing lets
    /// every waiter through, refused.
    #[test]
    fn the_gate_lets_the_producer_in_by_halves_and_opens_on_close() {
        use std::sync::atomic::{AtomicUsize, Ordering};
        let gate = Gate::new(4);
        for _ in 0..4 {
            assert!(gate.enter(1));
        }
        let entered = AtomicUsize::new(0);
        std::thread::scope(|s| {
            s.spawn(|| {
                assert!(gate.enter(1));
                entered.fetch_add(1, Ordering::SeqCst);
                // Refused once closed (it waits for room before).
                while gate.enter(1) {}
                entered.fetch_add(1, Ordering::SeqCst);
            });
            let settle = || std::thread::sleep(std::time::Duration::from_millis(50));
            settle();
            assert_eq!(entered.load(Ordering::SeqCst), 0, "entered a full gate");
            // One reached: 3 ahead, above half, still no room.
            gate.reached();
            settle();
            assert_eq!(entered.load(Ordering::SeqCst), 0, "woken before half");
            // Two reached: half (2), the producer is let in.
            gate.reached();
            settle();
            assert_eq!(entered.load(Ordering::SeqCst), 1);
            gate.close();
        });
        assert_eq!(entered.load(Ordering::SeqCst), 2);
    }

    /// A heavy task takes the room of its weight, and one heavier than the
    /// room left waits until nothing is ahead; the writer gives back each
    /// task's own weight, in the order they entered.
    #[test]
    fn heavy_tasks_take_their_weight_in_the_gate() {
        use std::sync::atomic::{AtomicUsize, Ordering};
        let gate = Gate::new(8);
        // Ahead: 1, 5, 1 (7 of 8).
        assert!(gate.enter(1));
        assert!(gate.enter(5));
        assert!(gate.enter(1));
        let entered = AtomicUsize::new(0);
        std::thread::scope(|s| {
            s.spawn(|| {
                // 20: more than the gate holds, waits for an empty gate.
                assert!(gate.enter(20));
                entered.fetch_add(1, Ordering::SeqCst);
            });
            let settle = || std::thread::sleep(std::time::Duration::from_millis(50));
            settle();
            assert_eq!(entered.load(Ordering::SeqCst), 0);
            gate.reached(); // the 1: 6 ahead
            gate.reached(); // the 5: 1 ahead
            settle();
            assert_eq!(
                entered.load(Ordering::SeqCst),
                0,
                "let in with a task ahead"
            );
            gate.reached(); // the last 1: none ahead
            settle();
            assert_eq!(entered.load(Ordering::SeqCst), 1);
        });
        // The 20 is ahead alone: a task of 1 waits for it to be reached.
        assert_eq!(gate.ahead.lock().unwrap().weight, 20);
        gate.reached();
        assert_eq!(gate.ahead.lock().unwrap().weight, 0);
        assert!(gate.ahead.lock().unwrap().heavy.is_empty());
    }

    /// A block goes back to the pool of the worker that wrote it, and that
    /// worker gets it again: not another worker's.
    #[test]
    fn each_worker_gets_back_its_own_blocks() {
        let tmpdir = None;
        let reuse = super::Reuse::new(&tmpdir);
        let shared = Shared::new(&reuse, (4, Duration::ZERO), (2, 8));
        let (a, b) = (shared.block(0), shared.block(1));
        let (pa, pb) = (a.as_ptr(), b.as_ptr());
        shared.recycle(a, 0);
        shared.recycle(b, 1);
        // LIFO in one pool for all would give worker 0 `b`.
        let (a, b) = (shared.block(0), shared.block(1));
        assert_eq!(a.as_ptr(), pa);
        assert_eq!(b.as_ptr(), pb);
        // With its own pool empty, a worker takes another's block rather
        // than a new one.
        let c = shared.block(1);
        let pc = c.as_ptr();
        shared.recycle(c, 0);
        let c = shared.block(1);
        assert_eq!(c.as_ptr(), pc);
    }

    /// A worker ahead of the writer with no room in memory, while the
    /// writer waits for text, spills: at once without patience, after it
    /// with ([`super::STEP_PATIENCE`]), and once spilling, at once.
    #[test]
    fn a_worker_without_room_waits_its_patience_then_spills() {
        use super::Current;
        use std::sync::atomic::Ordering;
        use std::time::Instant;
        let patience = Duration::from_millis(300);
        for p in [Duration::ZERO, patience] {
            let tmpdir = None;
            let reuse = super::Reuse::new(&tmpdir);
            let shared = Shared::new(&reuse, (1, p), (2, 8));
            shared.starving.store(true, Ordering::Relaxed);
            let current = Current::new(&shared, 0);
            let (tx, _rx) = std::sync::mpsc::sync_channel(16);
            // Task 1; the writer is on task 0.
            current.start((1, tx));
            current.send(vec![1; 10]).unwrap();
            assert!(current.spill.borrow().is_none(), "spilled with room");
            let t = Instant::now();
            current.send(vec![2; 10]).unwrap();
            let took = t.elapsed();
            assert!(current.spill.borrow().is_some(), "no spill");
            if p.is_zero() {
                assert!(took < patience, "waited {took:?} without patience");
            } else {
                assert!(took >= p, "spilled after {took:?}");
            }
            // Spilling, it goes on spilling at once.
            let t = Instant::now();
            current.send(vec![3; 10]).unwrap();
            assert!(t.elapsed() < patience, "waited again: {:?}", t.elapsed());
            assert_eq!(current.spill.borrow().as_ref().map(|s| s.1), Some(20));
        }
    }

    /// The task being written adds at most [`super::WRITTEN_ROOM`] blocks
    /// past the budget while the writer is busy (held up in its writes),
    /// and sends at once when the writer waits for its text.
    #[test]
    fn the_task_being_written_waits_past_the_budget_unless_the_writer_waits() {
        use super::{Current, Msg, WRITTEN_ROOM};
        use std::sync::atomic::Ordering;
        use std::sync::mpsc::TryRecvError;
        let tmpdir = None;
        let reuse = super::Reuse::new(&tmpdir);
        let shared = Shared::new(&reuse, (2, Duration::ZERO), (2, 8));
        let full = shared.budget + WRITTEN_ROOM;
        shared.queued.store(full, Ordering::Relaxed);
        let (tx, rx) = std::sync::mpsc::sync_channel(16);
        let text = |rx: &std::sync::mpsc::Receiver<Msg>| match rx.try_recv() {
            Ok(Msg::Text(b, _)) => Ok(b[0]),
            Ok(_) => panic!("not text"),
            Err(e) => Err(e),
        };
        let settle = || std::thread::sleep(Duration::from_millis(100));
        // A failed assertion must not leave the sender waiting: the
        // writer closes.
        struct Close<'s, 'a>(&'s Shared<'a>);
        impl Drop for Close<'_, '_> {
            fn drop(&mut self) {
                self.0
                    .closed
                    .store(true, std::sync::atomic::Ordering::Relaxed);
            }
        }
        std::thread::scope(|s| {
            let _close = Close(&shared);
            let sender = s.spawn(|| {
                let current = Current::new(&shared, 0);
                // Task 0: the one being written.
                current.start((0, tx));
                let _ = current.send(vec![1; 10]);
                let _ = current.send(vec![2; 10]);
            });
            settle();
            assert_eq!(text(&rx), Err(TryRecvError::Empty), "sent past the room");
            // The writer takes a block: room for one.
            shared.queued.fetch_sub(1, Ordering::Relaxed);
            match rx.recv_timeout(Duration::from_secs(10)) {
                Ok(Msg::Text(b, _)) => assert_eq!(b[0], 1),
                _ => panic!("no room for the task being written"),
            }
            settle();
            assert_eq!(text(&rx), Err(TryRecvError::Empty), "sent past the room");
            assert_eq!(shared.queued.load(Ordering::Relaxed), full);
            // The writer waits for this task's text: no waiting for room.
            shared.starving.store(true, Ordering::Relaxed);
            match rx.recv_timeout(Duration::from_secs(10)) {
                Ok(Msg::Text(b, _)) => assert_eq!(b[0], 2),
                _ => panic!("waited while the writer waited for its text"),
            }
            assert!(sender.join().is_ok());
        });
    }

    /// The next pass of a run writes into the blocks of the pass before
    /// (through the run's [`super::Reuse`]), not new ones.
    #[test]
    fn a_pass_reuses_the_blocks_of_the_pass_before() {
        let tmpdir = None;
        let reuse = super::Reuse::new(&tmpdir);
        {
            let shared = Shared::new(&reuse, (4, Duration::ZERO), (2, 8));
            // (Capacities no new block has.)
            shared.recycle(Vec::with_capacity(1001), 0);
            shared.recycle(Vec::with_capacity(1002), 1);
        }
        let shared = Shared::new(&reuse, (4, Duration::ZERO), (2, 8));
        let mut got = [shared.block(0).capacity(), shared.block(1).capacity()];
        got.sort();
        assert_eq!(got, [1001, 1002]);
    }
}
