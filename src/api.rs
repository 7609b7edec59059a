//! The library's entry points.

use crate::cli::DEFAULT_DERIVATION_LENGTH;
use crate::derive::{derive, Limits, Settings, Strategy};
use crate::diag::Error;
use crate::io::axiom::AxiomReader;
use crate::io::input::{split_header, Input};
use crate::lang::parse::{locate, parse_header};
use crate::rules::{compile_with, Seeds, System};
use std::io;

/// Load an L-system from `src` and derive it in full into a byte vector
/// (temp files are still used between steps): for tests and fuzzing.
/// `steps`/`seed` override the file's settings.
pub fn derive_bytes(
    src: &[u8],
    steps: Option<u64>,
    seed: Option<u64>,
    limits: Limits,
) -> Result<Vec<u8>, Error> {
    let mut input = Input::new(Box::new(io::Cursor::new(src.to_vec())), "<input>");
    let seeds = Seeds {
        command_line: seed,
        fallback: 0,
    };
    let (split, path, system) = load(&mut input, seeds)?;
    if !split.has_axiom {
        return Err(missing_axiom(&path, &split.header));
    }
    let settings = Settings {
        steps: steps
            .or(system.derivation_length)
            .unwrap_or(DEFAULT_DERIVATION_LENGTH),
        seed: seed.or(system.seed).unwrap_or(0),
        homomorphism: true,
        limits,
        tmpdir: None,
        verbose: false,
        strategy: Strategy::Auto,
    };
    let mut system = system;
    let consts = std::mem::take(&mut system.consts);
    let reader = AxiomReader::new(input, true, split.axiom_line, split.axiom_col, &consts);
    let mut out = Vec::new();
    derive(
        &settings,
        reader,
        &split.header,
        &path,
        system,
        &mut out,
        "output",
    )?;
    Ok(out)
}

/// Read the header from `input` (leaving it at the axiom), parse and
/// compile it. Returns the split, the input's name and the system.
pub(crate) fn load(
    input: &mut Input,
    seeds: Seeds,
) -> Result<(crate::io::input::Split, String, System), Error> {
    let split = split_header(input)?;
    let path = input.name.clone();
    let header = parse_header(&split.header).map_err(|e| locate(&path, &split.header, e))?;
    let system = compile_with(header, Some(&split.header), seeds)
        .map_err(|e| locate(&path, &split.header, e))?;
    Ok((split, path, system))
}

pub(crate) fn missing_axiom(path: &str, header: &str) -> Error {
    let end = header.trim_end().len();
    let mut e = locate(
        path,
        header,
        crate::lang::parse::UserError::new(
            (end, end),
            "missing `axiom:`: the axiom comes last, after the productions",
        ),
    );
    if header.trim().is_empty() {
        e.message = "empty L-system: no `axiom:` found".into();
    }
    e
}
