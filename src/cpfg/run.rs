//! What the cpfg dialect adds to a compiled system at run time (issue 12):
//! its randomness settings, filled in by the dialect's front end and read
//! by the one derivation engine (`src/derive/`).

use super::blocks::Block;
use crate::derive::random::Random;
use crate::rules::expr::EvalError;

/// The cpfg dialect's run-time settings. A system from a `.l` file carries
/// one ([`crate::rules::System::cpfg`]); its presence selects cpfg's
/// generators (`src/cpfg/random.rs`) and cpfg's context rules, and keeps
/// the step strategy where cpfg's draws, blocks and queries run in string
/// order (`crate::rules::Table::cpfg_any_order`).
#[derive(Clone, Debug, Default)]
pub struct CpfgRun {
    /// The file's `seed:` (None: no `seed:`, so the productions' weights
    /// are ignored, as in cpfg). `--seed N` replaces it, as if the file
    /// said `seed: N`.
    pub seed: Option<u64>,
    /// `define:`'s arrays set to their initial values, before `Start:`
    /// (cpfg's `ProcessArrayDef`); not a block of the file: it alone does
    /// not keep a derivation from stopping at a fixed point.
    pub define: Block,
    /// `Start:`, `StartEach:`, `EndEach:`, `End:` (empty when absent):
    /// they assign global variables.
    pub start: Block,
    pub start_each: Block,
    pub end_each: Block,
    pub end: Block,
    /// `derivation length:` of the file: `End:` runs after the last step's
    /// `EndEach:` when the run reaches it (cpfg ends there).
    pub derivation_length: u64,
    /// A production (of any section) has a block: one that runs may
    /// change a variable that a later step reads, whatever the string.
    pub production_blocks: bool,
    /// A block assigns cpfg's built-in `Q`: it keeps the value a block
    /// gave it into the homomorphism (cpfg interprets the string after the
    /// steps, reading the global `Q` as the blocks left it), instead of
    /// being set to the last step's number there.
    pub assigns_q: bool,
    /// An axiom whose parameters are not all constants (a global, `ran`,
    /// a `Q` or `Z` that `Start:` assigns): its text, `0` in place of each
    /// such parameter, and each one's offset in the text and code, worked
    /// out after `Start:` ([`CpfgRun::axiom_text`]).
    pub axiom: Option<(String, Vec<(usize, crate::rules::expr::Code)>)>,
    /// What `func(id, x)` reads (`--functions`).
    pub functions: Option<std::sync::Arc<super::func::Functions>>,
    /// The turtle that fills the queries `?P`, `?H`, `?L`, `?U` of each
    /// generation ([`super::query`]), if the file has queries.
    pub queries: Option<std::sync::Arc<super::query::QueryTurtle>>,
}

impl CpfgRun {
    /// Does a block run? A header block, or a production's block (which
    /// runs where the production is tried, the string unchanged or not):
    /// then every step counts, no fixed point.
    pub fn has_blocks(&self) -> bool {
        self.production_blocks
            || !(self.start.is_empty()
                && self.start_each.is_empty()
                && self.end_each.is_empty()
                && self.end.is_empty())
    }

    /// Run a header block, globals in `rng`.
    pub fn run(&self, which: When, rng: &mut Random) -> Result<(), EvalError> {
        let b = match which {
            When::Define => &self.define,
            When::Start => &self.start,
            When::StartEach => &self.start_each,
            When::EndEach => &self.end_each,
            When::End => &self.end,
        };
        if b.is_empty() {
            return Ok(());
        }
        b.run(&mut [], &mut Vec::new(), rng)
    }

    /// The axiom's text with the values its late parameters have now
    /// ([`CpfgRun::axiom`], after `Start:`, globals and generators in
    /// `rng`), in file order; None if it has none.
    pub fn axiom_text(&self, rng: &mut Random) -> Result<Option<String>, EvalError> {
        let Some((text, late)) = &self.axiom else {
            return Ok(None);
        };
        let mut out = String::with_capacity(text.len() + 16 * late.len());
        let mut at = 0;
        let mut stack = Vec::new();
        for (off, code) in late {
            out.push_str(&text[at..*off]);
            let v = code.eval(&[], &mut stack, rng)?;
            out.push_str(&crate::rules::codec::number_string(v));
            // (Past the `0` that held its place.)
            at = off + 1;
        }
        out.push_str(&text[at..]);
        Ok(Some(out))
    }
}

/// Which header block.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum When {
    /// The arrays' initial values, before `Start:`.
    Define,
    /// Before the axiom is read.
    Start,
    /// Before each step.
    StartEach,
    /// After each step.
    EndEach,
    /// After the last step's `EndEach:` (not for 0 steps).
    End,
}

#[cfg(test)]
mod tests {
    use super::CpfgRun;
    use crate::api::{LSystem, Options};

    /// `src` (an `.ls` text) derived `n` steps as a `.l` file with `seed`
    /// would be: cpfg's generators and draw order in the one engine.
    fn cpfg(src: &str, seed: Option<u64>, n: u64) -> String {
        let mut ls = LSystem::parse(src).unwrap();
        ls.as_cpfg(CpfgRun {
            seed,
            ..CpfgRun::default()
        });
        let mut out = Vec::new();
        ls.derive(&Options::new().steps(n), &mut out).unwrap();
        String::from_utf8(out).unwrap()
    }

    fn expected(name: &str) -> String {
        std::fs::read_to_string(format!(
            "{}/tests/expected/cpfg/{name}.txt",
            env!("CARGO_MANIFEST_DIR")
        ))
        .unwrap()
    }

    // tests/cpfg/stochastic.l in the `.ls` syntax (its productions are
    // context-free, so both dialects try them in the same order); the
    // strings are cpfg_ref.py's.
    const STOCHASTIC: &str = "productions:
F(n) -> F(n+1)[+F(0)]F(n+1) : 1
F(n) -> F(n+1)[-F(0)] : 2
F(n) : n > 1 -> G : n / 2
F(n) -> F(n+1)
G -> H : 0
axiom: F(0)
";

    #[test]
    fn seeded_choice_is_cpfgs() {
        for n in [1, 2, 5, 8] {
            assert_eq!(
                cpfg(STOCHASTIC, Some(7), n),
                expected(&format!("stochastic.n{n}")),
                "{n} steps"
            );
        }
        // tests/cpfg/stochastic_seed0.l: glibc's unseeded state.
        let seed0 = "productions:\nA -> AB : 1\nA -> A : 1\nB -> C\nB -> D\naxiom: A\n";
        for n in [1, 4] {
            assert_eq!(
                cpfg(seed0, Some(0), n),
                expected(&format!("stochastic_seed0.n{n}")),
                "seed 0, {n} steps"
            );
        }
    }

    // tests/cpfg/context_*.l in the `.ls` syntax (every production has a
    // context, so both dialects try them in file order); each gives
    // another string under the `.ls` rules (checked by hand: `A > [B`
    // matches there, `]` skips the rest of a branch, brackets are never
    // passed over).
    #[test]
    fn right_contexts_follow_cpfg() {
        let branches = "productions:
A > [B -> a1
A > [X]C -> a2
C > D -> c
D > F -> d1
G > [H]I -> g
E > F -> e
H > ] -> h1
I < J -> i
K > [L]M -> k
L > ]M -> l
M < N -> m1
K < N -> m2
J < N -> n
P < Q -> q
P < R -> r
Q > R -> x
axiom: A[X][BY]C D[E]F G[H]I J[K[L]M]N P[Q]R S
";
        let consider = "consider: ABCD
productions:
A > BC -> a
B > CD -> b
A < C -> c
D > AB -> d
F < D -> f
A > F -> g
axiom: A[B]C F D[F[A]]B
";
        let equals = "productions:
B > =]F -> b
C > =]G -> c
H > =]I -> h
A > [=]F -> a
axiom: A[BC[D]E]F G[H]I
";
        for (src, name) in [
            (branches, "context_branches"),
            (consider, "context_consider"),
            (equals, "context_equals"),
        ] {
            assert_eq!(
                cpfg(src, None, 1),
                expected(&format!("{name}.n1")),
                "{name}"
            );
        }
    }

    #[test]
    fn without_seed_the_weights_are_ignored() {
        // First applicable in file order: F(n) -> F(n+1)[+F(0)]F(n+1).
        assert_eq!(
            cpfg(STOCHASTIC, None, 2),
            "F(2)[+F(0)]F(2)[+F(1)[+F(0)]F(1)]F(2)[+F(0)]F(2)\n"
        );
    }
}
