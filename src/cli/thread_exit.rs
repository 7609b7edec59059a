//! Thread-local destructors registered without allocating: the lsgen
//! binary's `__cxa_thread_atexit_impl` (`src/main.rs`) is [`register`].
//!
//! Rust's standard library registers each thread-local value that needs
//! dropping with the C library's `__cxa_thread_atexit_impl`, and every
//! thread it starts registers one (its spawn hooks) before any of lsgen's
//! code runs there. glibc's registration allocates, and when that
//! allocation fails it aborts the process ("Fatal glibc error: failed to
//! register TLS destructor: out of memory", SIGABRT): under an
//! address-space cap (`ulimit -v`), a `-j 8` run that should end with
//! lsgen's one-line out-of-memory error (`super::ExitOnOom`) died that way
//! about once in thirty runs. Here each thread keeps its destructors in a
//! fixed table of its own, so registering never allocates and never fails.
//! They run as glibc runs them: last registered first, when the thread
//! ends (the destructor of a pthread key, which every thread that
//! registers sets), and for the thread that calls `exit`, at `exit` (an
//! `atexit` handler; exit does not run key destructors).

use std::cell::Cell;
use std::ffi::{c_int, c_void};
use std::sync::OnceLock;

/// A destructor as the C library's registration takes it.
pub type Dtor = unsafe extern "C" fn(*mut c_void);

/// Destructors a thread can have registered at once. A thread of lsgen has
/// a handful (the standard library's own and the few thread-locals that
/// need dropping); past this many, one is never run (its value leaks when
/// the thread ends), where glibc would have aborted.
const SLOTS: usize = 128;

thread_local! {
    // (Constant, without a destructor: using them registers nothing.)
    static LIST: [Cell<Option<(Dtor, *mut c_void)>>; SLOTS] =
        const { [const { Cell::new(None) }; SLOTS] };
    static LEN: Cell<usize> = const { Cell::new(0) };
}

/// The key whose destructor runs a thread's table when it ends; None if
/// none could be made (then nothing registered is run: leaked).
fn key() -> Option<libc::pthread_key_t> {
    static KEY: OnceLock<Option<libc::pthread_key_t>> = OnceLock::new();
    *KEY.get_or_init(|| {
        let mut key = 0;
        // SAFETY: `key` is a valid place for the new key; the destructor
        // is an `extern "C"` function that lives as long as the process.
        if unsafe { libc::pthread_key_create(&mut key, Some(at_thread_end)) } != 0 {
            return None;
        }
        // SAFETY: registering an `extern "C"` function with no arguments.
        // (glibc's first 32 handlers take no allocation; if it fails, the
        // thread that calls `exit` does not run its destructors, which
        // Rust does not promise for that thread anyway.)
        unsafe { libc::atexit(at_exit) };
        Some(key)
    })
}

/// Register `dtor(obj)` to run when the calling thread ends (the C
/// library's `__cxa_thread_atexit_impl`; `dso`, which glibc uses to keep
/// a shared object loaded while it has destructors, is not needed by a
/// binary that loads none). Never allocates; returns 0.
///
/// # Safety
///
/// `dtor(obj)` must be sound to call once, on this thread, as it ends.
pub unsafe fn register(dtor: Dtor, obj: *mut c_void, _dso: *mut c_void) -> c_int {
    let Some(key) = key() else {
        return 0;
    };
    LEN.with(|len| {
        let n = len.get();
        if n == SLOTS {
            return;
        }
        LIST.with(|list| list[n].set(Some((dtor, obj))));
        len.set(n + 1);
        if n == 0 {
            // Non-null: the key's destructor runs at this thread's end.
            // (Below 32 keys, glibc sets a value without allocating.)
            // SAFETY: `key` was made by `pthread_key_create`.
            unsafe { libc::pthread_setspecific(key, std::ptr::dangling::<c_void>()) };
        }
    });
    0
}

/// Run the calling thread's destructors, last registered first,
/// including those they register themselves.
fn run_all() {
    loop {
        let next = LEN.with(|len| {
            let n = len.get().checked_sub(1)?;
            len.set(n);
            LIST.with(|list| list[n].take())
        });
        let Some((dtor, obj)) = next else {
            return;
        };
        // SAFETY: registered to be called once, on this thread, as it
        // ends (`register`).
        unsafe { dtor(obj) };
    }
}

extern "C" fn at_thread_end(_: *mut c_void) {
    run_all();
}

extern "C" fn at_exit() {
    run_all();
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::sync::atomic::{AtomicUsize, Ordering};
    use std::sync::Mutex;

    static ORDER: Mutex<Vec<usize>> = Mutex::new(Vec::new());
    static AGAIN: AtomicUsize = AtomicUsize::new(0);

    unsafe extern "C" fn note(obj: *mut c_void) {
        ORDER.lock().unwrap().push(obj.addr());
    }

    /// Registers one more destructor while the thread's are being run.
    unsafe extern "C" fn note_and_register(obj: *mut c_void) {
        ORDER.lock().unwrap().push(obj.addr());
        if AGAIN.fetch_add(1, Ordering::SeqCst) == 0 {
            unsafe {
                register(
                    note,
                    std::ptr::without_provenance_mut(99),
                    std::ptr::null_mut(),
                )
            };
        }
    }

    /// A thread's destructors run when it ends, last registered first,
    /// those registered meanwhile too; past the table's size they are
    /// dropped, not an error.
    #[test]
    fn destructors_run_at_thread_end_last_first() {
        std::thread::spawn(|| unsafe {
            register(
                note,
                std::ptr::without_provenance_mut(1),
                std::ptr::null_mut(),
            );
            register(
                note_and_register,
                std::ptr::without_provenance_mut(2),
                std::ptr::null_mut(),
            );
            register(
                note,
                std::ptr::without_provenance_mut(3),
                std::ptr::null_mut(),
            );
        })
        .join()
        .unwrap();
        assert_eq!(*ORDER.lock().unwrap(), [3, 2, 99, 1]);
        ORDER.lock().unwrap().clear();
        std::thread::spawn(|| unsafe {
            for i in 0..SLOTS + 5 {
                assert_eq!(
                    register(
                        note,
                        std::ptr::without_provenance_mut(i),
                        std::ptr::null_mut()
                    ),
                    0
                );
            }
        })
        .join()
        .unwrap();
        let ran = std::mem::take(&mut *ORDER.lock().unwrap());
        assert_eq!(ran, (0..SLOTS).rev().collect::<Vec<_>>());
    }
}
