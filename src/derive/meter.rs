//! How far a derivation is, for a progress display: the current
//! generation's modules and bytes so far, and the final size when the
//! depth-first plan knows it in advance. The sink ([`super::Out`]) updates
//! it as it flushes (one relaxed store per 64 KiB chunk), so every strategy
//! reports through the same place. A meter is installed for the current
//! thread ([`install`]), so batch workers each have their own.

use std::cell::Cell;
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::{Arc, Mutex};

#[derive(Debug, Default)]
pub struct Meter {
    /// Modules of the generation being written.
    pub modules: AtomicU64,
    /// Bytes of the generation being written.
    pub bytes: AtomicU64,
    /// The final text's size with its newline, when known in advance
    /// (u64::MAX: larger than that); 0: unknown.
    pub final_bytes: AtomicU64,
    /// The final string is written depth first, all steps in one pass.
    pub depth_first: AtomicBool,
}

impl Meter {
    pub(crate) fn record(&self, modules: u64, bytes: u64) {
        self.modules.store(modules, Ordering::Relaxed);
        self.bytes.store(bytes, Ordering::Relaxed);
    }
}

/// The installed meters, by slot ([`install`]); a thread holds its slot's
/// number (0: none) in [`CURRENT`].
static METERS: Mutex<Vec<Option<Arc<Meter>>>> = Mutex::new(Vec::new());

thread_local! {
    /// This thread's meter: 1 + its slot in [`METERS`], 0 for none. A
    /// number, not the `Arc`: a thread-local that needs dropping has its
    /// destructor registered with the C library at the first access, and
    /// glibc aborts the process when that registration finds no memory.
    /// Every split worker asks for its meter (`Out::with_buffer`) as it
    /// starts, when an address-space cap (`ulimit -v`) is likeliest to be
    /// reached: one run in 16 of tests/hardening.rs's
    /// `threads_out_of_memory_at_once_give_one_line` died of that abort.
    static CURRENT: Cell<usize> = const { Cell::new(0) };
}

/// The meter of this thread's derivation, if any.
pub(crate) fn current() -> Option<Arc<Meter>> {
    let slot = CURRENT.with(Cell::get).checked_sub(1)?;
    let meters = METERS.lock().ok()?;
    meters.get(slot).cloned().flatten()
}

/// Report this thread's derivations to `meter` until the guard is dropped.
#[cfg_attr(not(feature = "cli"), allow(dead_code))] // the binary's progress display
pub fn install(meter: Arc<Meter>) -> Installed {
    let Ok(mut meters) = METERS.lock() else {
        return Installed(0);
    };
    let slot = match meters.iter().position(Option::is_none) {
        Some(i) => {
            meters[i] = Some(meter);
            i
        }
        None => {
            meters.push(Some(meter));
            meters.len() - 1
        }
    };
    CURRENT.with(|c| c.set(slot + 1));
    Installed(slot + 1)
}

/// Removes the meter when dropped.
#[cfg_attr(not(feature = "cli"), allow(dead_code))]
pub struct Installed(usize);

impl Drop for Installed {
    fn drop(&mut self) {
        if let (Some(slot), Ok(mut meters)) = (self.0.checked_sub(1), METERS.lock()) {
            meters[slot] = None;
        }
        CURRENT.with(|c| c.set(0));
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Each thread sees the meter it installed, none before or after, and
    /// slots are reused.
    #[test]
    fn a_meter_is_the_installing_thread_s_until_its_guard_drops() {
        assert!(current().is_none());
        let a = Arc::new(Meter::default());
        let guard = install(a.clone());
        assert!(Arc::ptr_eq(&current().unwrap(), &a));
        let other = std::thread::spawn(|| {
            assert!(current().is_none());
            let b = Arc::new(Meter::default());
            let _g = install(b.clone());
            Arc::ptr_eq(&current().unwrap(), &b)
        });
        assert!(other.join().unwrap());
        assert!(Arc::ptr_eq(&current().unwrap(), &a));
        drop(guard);
        assert!(current().is_none());
        assert_eq!(Arc::strong_count(&a), 1);
    }
}
