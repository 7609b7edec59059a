fn main() {
    std::process::exit(lsgen::cli::main_exit_code());
}
