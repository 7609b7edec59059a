//! Any bytes as a cpfg `.l` file: a whole derivation through the cpfg
//! dialect (preprocessor, lexer, grammar, lowering, blocks, cpfg's
//! generators and contexts) with small size limits and at most 4 steps.
//! Must never panic, hang or overflow the stack; an `Err` is fine, but it
//! must render as `FILE:LINE:COL: error: ...` without the program name.
//!
//! Input layout: the first byte chooses the number of steps (b % 5), the
//! rest is the file. `derive_bytes` picks the dialect from the text, so the
//! harness puts `Lsystem: 1` in front when the text does not start a cpfg
//! file by itself. fuzz/run.sh seeds the corpus with tests/cpfg/*.l.
#![no_main]

use libfuzzer_sys::fuzz_target;
use lsgen::engine::Limits;

const LIMITS: Limits = Limits {
    modules: 20_000,
    bytes: 200_000,
};

fuzz_target!(|data: &[u8]| {
    let Some((&ctl, src)) = data.split_first() else {
        return;
    };
    let steps = u64::from(ctl) % 5;
    let mut text = Vec::with_capacity(src.len() + 12);
    if !src.starts_with(b"Lsystem:") && !src.starts_with(b"#") {
        text.extend_from_slice(b"Lsystem: 1\n");
    }
    text.extend_from_slice(src);
    if let Err(e) = lsgen::derive_bytes(&text, Some(steps), None, LIMITS) {
        let shown = e.to_string();
        assert!(
            !shown.starts_with("lsgen: ") && shown.contains("error: ") && shown.ends_with('\n'),
            "badly rendered error: {shown:?}"
        );
    }
});
