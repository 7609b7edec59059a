//! What a batch's worker keeps from one job for the next.
//!
//! A batch runs job after job on each of its threads, and a job of a small
//! system costs little derivation: what it cost was what every pass made
//! anew. Each pass's [`Out`](super::Out) made a 1 MiB buffer (its own
//! pages, as large blocks are: mapped and unmapped, and an unmapping on a
//! process of several threads flushes every CPU's TLB) and filled a number
//! cache of 160 KiB; each job made its temporary generations (on ext4 a
//! file made soon after others were deleted costs a search of the inode
//! table: most of a tiny job's time). While a [`KeepSpares`] lives, the
//! thread keeps the last `Out`'s buffer and cache and its emptied
//! generation files for the next ones. Only batch workers do: a library
//! caller's thread would keep them for good.

use crate::rules::codec::NumCache;
use std::cell::{Cell, RefCell};
use std::fs::File;
use std::path::PathBuf;

/// Emptied generation files kept, at most (a run uses three at once).
const FILES: usize = 4;

thread_local! {
    /// Is this thread running job after job ([`KeepSpares`])?
    static KEEP: Cell<bool> = const { Cell::new(false) };
    /// The buffer and number cache of the last `Out` this thread dropped.
    static OUT: RefCell<Option<(Vec<u8>, NumCache)>> = const { RefCell::new(None) };
    /// Emptied generation files and the directory each is in (None: the
    /// system's temporary directory).
    static GENERATIONS: RefCell<Vec<(Option<PathBuf>, File)>> = const { RefCell::new(Vec::new()) };
}

/// While this lives, this thread keeps spares (see the module's doc).
/// Dropping it frees them.
#[cfg_attr(not(feature = "cli"), allow(dead_code))]
pub(crate) struct KeepSpares(());

#[cfg_attr(not(feature = "cli"), allow(dead_code))]
impl KeepSpares {
    pub(crate) fn new() -> KeepSpares {
        KEEP.set(true);
        KeepSpares(())
    }
}

impl Drop for KeepSpares {
    fn drop(&mut self) {
        KEEP.set(false);
        drop(OUT.take());
        drop(GENERATIONS.take());
    }
}

/// Does this thread keep spares?
pub(crate) fn keeping() -> bool {
    KEEP.get()
}

/// The kept `Out` buffer and number cache, if any.
pub(crate) fn take_out() -> Option<(Vec<u8>, NumCache)> {
    if keeping() {
        OUT.take()
    } else {
        None
    }
}

/// Keep an `Out`'s buffer and cache (the caller checked [`keeping`]).
pub(crate) fn leave_out(spare: (Vec<u8>, NumCache)) {
    OUT.set(Some(spare));
}

#[cfg(test)]
pub(crate) fn holds_out() -> bool {
    OUT.with_borrow(|s| s.is_some())
}

#[cfg(test)]
pub(crate) fn holds_generations() -> bool {
    GENERATIONS.with_borrow(|g| !g.is_empty())
}

/// A kept generation file in `dir`, empty, if any.
pub(crate) fn take_generation(dir: &Option<PathBuf>) -> Option<File> {
    if !keeping() {
        return None;
    }
    GENERATIONS.with_borrow_mut(|g| {
        let i = g.iter().position(|(d, _)| d == dir)?;
        Some(g.swap_remove(i).1)
    })
}

/// Keep `file`, emptied, a generation file in `dir`; false if it is not
/// kept (not [`keeping`], or enough are).
pub(crate) fn leave_generation(dir: &Option<PathBuf>, file: &File) -> bool {
    if !keeping() {
        return false;
    }
    GENERATIONS.with_borrow_mut(|g| {
        if g.len() >= FILES {
            return false;
        }
        match file.try_clone() {
            Ok(f) => {
                g.push((dir.clone(), f));
                true
            }
            Err(_) => false,
        }
    })
}
