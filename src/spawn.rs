//! Starting a thread: std's `Builder::spawn` and `spawn_scoped`, after
//! [`prime`]. Every thread lsgen starts goes through here.

use std::io;
use std::thread::{Builder, JoinHandle, Scope, ScopedJoinHandle};

/// Leave freed blocks of the small sizes in this thread's cache of the C
/// allocator, for the one allocation of a thread's start that does not go
/// through the global allocator.
///
/// std allocates each new thread's handle (48 bytes in Rust 1.95) with the
/// system allocator directly, and a failure there aborts the process
/// ("memory allocation of 48 bytes failed", SIGABRT) where every other
/// allocation gives lsgen's one-line out-of-memory error (`ExitOnOom` in
/// `src/cli.rs`): under `ulimit -v 287000`, 11 of 60 `-j 8` runs of the
/// parametric_tree workload did. Blocks of 16 to 128 bytes allocated here
/// (through the global allocator: if memory is already short, that is
/// lsgen's error) and freed at once stay in glibc's per-thread cache (its
/// `tcache`, else the arena's free lists), and the handle is served from
/// there without asking for memory: none of 760 such runs aborted (the
/// same cap and workload). Four of each size class, for the few blocks
/// `spawn` allocates before the handle.
#[inline(never)]
fn prime() {
    let held: [Vec<u8>; 32] = std::array::from_fn(|i| Vec::with_capacity(16 * (1 + i % 8)));
    // (Kept, so that the allocations are not optimized away.)
    std::hint::black_box(&held);
}

/// `builder.spawn(f)`, after [`prime`].
pub(crate) fn spawn<F, T>(builder: Builder, f: F) -> io::Result<JoinHandle<T>>
where
    F: FnOnce() -> T + Send + 'static,
    T: Send + 'static,
{
    prime();
    builder.spawn(f)
}

/// `builder.spawn_scoped(scope, f)`, after [`prime`].
pub(crate) fn spawn_scoped<'scope, 'env, F, T>(
    builder: Builder,
    scope: &'scope Scope<'scope, 'env>,
    f: F,
) -> io::Result<ScopedJoinHandle<'scope, T>>
where
    F: FnOnce() -> T + Send + 'scope,
    T: Send + 'scope,
{
    prime();
    builder.spawn_scoped(scope, f)
}
