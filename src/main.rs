// Start-up cost (issue 10): lsgen has its own C `main` instead of Rust's
// runtime start. That start installs a SIGSEGV handler that prints "has
// overflowed its stack" before aborting, and for it asks glibc for the
// main thread's stack bounds (pthread_getattr_np), which parses all of
// /proc/self/maps with sscanf: about 112 000 instructions, 10 % of a small
// derivation. A stack overflow is a crash either way (SIGABRT after that
// line, now SIGSEGV; the grammar bounds nesting, and tests/common's
// `assert_no_crash` catches both). The rest of that start on Linux is done
// here or happens without it: standard descriptors closed at start get
// /dev/null (`NOTE_CLOSED_STANDARD_FDS` below), SIGPIPE is ignored (a
// closed pipe is an EPIPE error, handled quietly), `std::env::args` reads
// glibc's argv through .init_array, and `process::exit` flushes standard
// output. (Not in `cargo test`'s build of this file, whose harness brings
// its own `main`.)
#![cfg_attr(not(test), no_main)]

/// A failed allocation is one error line and exit 1, not an abort.
#[global_allocator]
static ALLOC: lsgen::cli::ExitOnOom = lsgen::cli::ExitOnOom("lsgen");

/// Thread-local destructors are registered without allocating, so that
/// starting a thread under an address-space cap cannot abort the process
/// (`lsgen::cli::thread_exit`). The standard library calls this symbol,
/// which takes the place of glibc's.
#[cfg(not(test))]
#[no_mangle]
unsafe extern "C" fn __cxa_thread_atexit_impl(
    dtor: lsgen::cli::thread_exit::Dtor,
    obj: *mut std::ffi::c_void,
    dso: *mut std::ffi::c_void,
) -> std::ffi::c_int {
    // SAFETY: the caller's contract is the C library's, which `register`'s is.
    unsafe { lsgen::cli::thread_exit::register(dtor, obj, dso) }
}

#[cfg(not(test))]
#[no_mangle]
extern "C" fn main(
    _argc: std::ffi::c_int,
    _argv: *const *const std::ffi::c_char,
) -> std::ffi::c_int {
    // SAFETY: setting a signal's disposition to SIG_IGN, as Rust's
    // runtime start does by default.
    unsafe { libc::signal(libc::SIGPIPE, libc::SIG_IGN) };
    std::process::exit(lsgen::cli::main_exit_code());
}

/// Runs before `main`, and before Rust's runtime where that is used, which
/// quietly gives closed standard descriptors /dev/null: lsgen must know that
/// standard output was closed. It gives them /dev/null itself.
#[used]
#[link_section = ".init_array"]
static NOTE_CLOSED_STANDARD_FDS: extern "C" fn() = {
    extern "C" fn note() {
        lsgen::output::note_closed_standard_fds();
    }
    note
};
