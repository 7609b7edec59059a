//! How far a derivation is, for a progress display: the current
//! generation's modules and bytes so far, and the final size when the
//! depth-first plan knows it in advance. The sink ([`super::Out`]) updates
//! it as it flushes (one relaxed store per 64 KiB chunk), so every strategy
//! reports through the same place. A meter is installed for the current
//! thread ([`install`]), so batch workers each have their own.

use std::cell::RefCell;
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::Arc;

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

thread_local! {
    static CURRENT: RefCell<Option<Arc<Meter>>> = const { RefCell::new(None) };
}

/// The meter of this thread's derivation, if any.
pub(crate) fn current() -> Option<Arc<Meter>> {
    CURRENT.with(|c| c.borrow().clone())
}

/// Report this thread's derivations to `meter` until the guard is dropped.
#[cfg_attr(not(feature = "cli"), allow(dead_code))] // the binary's progress display
pub fn install(meter: Arc<Meter>) -> Installed {
    CURRENT.with(|c| *c.borrow_mut() = Some(meter));
    Installed(())
}

/// Removes the meter when dropped.
#[cfg_attr(not(feature = "cli"), allow(dead_code))]
pub struct Installed(());

impl Drop for Installed {
    fn drop(&mut self) {
        CURRENT.with(|c| *c.borrow_mut() = None);
    }
}
