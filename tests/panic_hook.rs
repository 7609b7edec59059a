//! lsgen's panic hook with an unwritable standard error: the panic is
//! reported (or not) and unwinds normally; it never panics again (which
//! aborts the process, as `eprintln!` in the hook did). Without libtest's
//! harness (`harness = false` in Cargo.toml): libtest captures `eprintln!`,
//! so the hook would never see the real standard error.

use std::os::fd::AsRawFd;

fn main() {
    let Ok(full) = std::fs::OpenOptions::new().write(true).open("/dev/full") else {
        println!("panic_hook: skipped: no /dev/full");
        return;
    };
    lsgen::cli::install_panic_hook();
    // SAFETY: fd 2 is saved, pointed at /dev/full, and restored below.
    let saved = unsafe { libc::dup(2) };
    assert!(saved >= 0);
    // SAFETY: as above.
    assert_eq!(unsafe { libc::dup2(full.as_raw_fd(), 2) }, 2);
    let r = std::panic::catch_unwind(|| panic!("a bug"));
    // SAFETY: as above.
    unsafe {
        libc::dup2(saved, 2);
        libc::close(saved);
    }
    let _ = std::panic::take_hook();
    assert!(r.is_err(), "the panic did not unwind");
    println!("panic_hook: ok: the hook survived a full standard error");
}
