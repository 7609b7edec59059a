//! Any bytes: if UTF-8, parse them as an `.ls` header (and compile the
//! productions when that parses) and as an expression. Must never panic.
#![no_main]

use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let Ok(text) = std::str::from_utf8(data) else {
        return;
    };
    if let Ok(header) = lsgen::parse::parse_header(text) {
        let _ = lsgen::rules::compile(&header);
    }
    let _ = lsgen::parse::parse_expr(text);
});
