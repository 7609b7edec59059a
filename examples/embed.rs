//! lsgen as a library: derive an L-system from a string, streaming the
//! result into standard output, and report each generation's length,
//! each warning and what a cpfg model's `printf` prints.
//!
//! `cargo run --example embed -- 5` derives ABOP's Koch curve 5 steps.

use std::io::Write;

fn main() -> Result<(), Box<dyn std::error::Error + Send + Sync>> {
    let steps = match std::env::args().nth(1) {
        Some(n) => n.parse()?,
        None => 3,
    };
    let mut koch =
        lsgen::LSystem::parse("/* ABOP fig. 1.7b */\nproductions:\nF -> F+F-F-F+F\naxiom: F\n")?;
    let options = lsgen::Options::new().steps(steps);
    let stdout = std::io::stdout();
    let mut out = stdout.lock();
    let stats = koch.derive_with(&options, &mut out, |event| match event {
        lsgen::Event::Generation { pass, modules, .. } => {
            eprintln!("{pass}: {modules} modules");
        }
        // Rendered as lsgen prints it: place, message, source line, caret.
        lsgen::Event::Warning(w) => eprint!("{w}"),
        // A cpfg `.l` model's `printf` (none in this one).
        lsgen::Event::Printf(text) => eprint!("{text}"),
        _ => {}
    })?;
    out.flush()?;
    eprintln!("{} modules, {} bytes", stats.modules, stats.bytes);
    Ok(())
}
