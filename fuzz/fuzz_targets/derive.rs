//! Any bytes: a whole derivation through `derive_bytes`, with small size
//! limits and at most 4 steps. Must never panic, hang or overflow the
//! stack; an `Err` is fine, but it must render as `lsgen: ... error: ...`.
//!
//! Input layout: the first byte chooses the run (bits 0-2: steps = b % 5;
//! bit 3: keep the file's `seed:`, else seed = b >> 4), the rest is the
//! `.ls` file. fuzz/run.sh seeds the corpus with the examples behind such
//! a byte.
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
    let steps = u64::from(ctl & 7) % 5;
    let seed = if ctl & 8 != 0 {
        None
    } else {
        Some(u64::from(ctl >> 4))
    };
    if let Err(e) = lsgen::derive_bytes(src, Some(steps), seed, LIMITS) {
        let shown = e.to_string();
        assert!(
            !shown.starts_with("lsgen: ") && shown.contains("error: ") && shown.ends_with('\n'),
            "badly rendered error: {shown:?}"
        );
    }
});
