/// A failed allocation is one error line and exit 1, not an abort.
#[global_allocator]
static ALLOC: lsgen::cli::ExitOnOom = lsgen::cli::ExitOnOom("lsgen");

fn main() {
    std::process::exit(lsgen::cli::main_exit_code());
}

/// Runs before Rust's runtime, which quietly gives closed standard
/// descriptors /dev/null: lsgen must know that standard output was closed.
#[used]
#[link_section = ".init_array"]
static NOTE_CLOSED_STANDARD_FDS: extern "C" fn() = {
    extern "C" fn note() {
        lsgen::output::note_closed_standard_fds();
    }
    note
};
