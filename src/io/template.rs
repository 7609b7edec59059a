//! Output name templates (`-o 'out/{stem}-{seed}.txt'`): the one place that
//! expands them, for batches (`{stem}`, `{seed}`) and frames (`{n}`).
//!
//! `{stem}` is the input file's name without directory and extension
//! (`stdin` for standard input), `{seed}` the job's seed, `{n}` the
//! generation number. `{{` and `}}` stand for literal braces. Any other
//! `{...}` is a usage error, so a typo never silently becomes part of a
//! file name. Names are bytes, as Unix has them: a template or a stem that
//! is not UTF-8 works as any other.

use crate::diag::{Error, UsageError};
use std::ffi::{OsStr, OsString};
use std::hash::{Hash, Hasher};
use std::os::unix::ffi::{OsStrExt, OsStringExt};
use std::path::{Path, PathBuf};

/// A placeholder of a template.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Field {
    Stem,
    Seed,
    N,
}

impl Field {
    fn name(self) -> &'static str {
        match self {
            Field::Stem => "stem",
            Field::Seed => "seed",
            Field::N => "n",
        }
    }
}

#[derive(Clone, Debug, PartialEq, Eq)]
enum Part {
    Text(Vec<u8>),
    Field(Field),
}

/// A parsed `-o` template.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Template {
    parts: Vec<Part>,
}

/// The values a template is expanded with; a `None` field that the template
/// uses is an error (e.g. `{n}` without frames).
#[derive(Clone, Copy, Debug, Default)]
pub struct Vars<'a> {
    pub stem: Option<&'a OsStr>,
    pub seed: Option<u64>,
    pub n: Option<u64>,
}

impl Template {
    /// Parse `-o`'s name.
    pub fn parse_path(p: &Path) -> Result<Template, Error> {
        Template::parse_bytes(p.as_os_str().as_bytes())
    }

    /// Parse `s` (tests).
    #[cfg(test)]
    fn parse(s: &str) -> Result<Template, Error> {
        Template::parse_bytes(s.as_bytes())
    }

    /// Parse `s`; an unknown or unclosed placeholder is a usage error.
    fn parse_bytes(s: &[u8]) -> Result<Template, Error> {
        let shown = || String::from_utf8_lossy(s).into_owned();
        let mut parts = Vec::new();
        let mut text = Vec::new();
        let mut rest = s;
        while let Some(i) = rest.iter().position(|&b| b == b'{' || b == b'}') {
            text.extend_from_slice(&rest[..i]);
            let tail = &rest[i..];
            if let Some(r) = tail.strip_prefix(b"{{") {
                text.push(b'{');
                rest = r;
            } else if let Some(r) = tail.strip_prefix(b"}}") {
                text.push(b'}');
                rest = r;
            } else if tail.starts_with(b"}") {
                return Err(Error::new(UsageError::LoneCloseBrace(shown())));
            } else {
                let end = tail
                    .iter()
                    .position(|&b| b == b'}')
                    .ok_or_else(|| Error::new(UsageError::UnclosedBrace(shown())))?;
                let field = match &tail[1..end] {
                    b"stem" => Field::Stem,
                    b"seed" => Field::Seed,
                    b"n" => Field::N,
                    other => {
                        return Err(Error::new(UsageError::UnknownPlaceholder {
                            template: shown(),
                            name: String::from_utf8_lossy(other).into_owned(),
                        }))
                    }
                };
                if !text.is_empty() {
                    parts.push(Part::Text(std::mem::take(&mut text)));
                }
                parts.push(Part::Field(field));
                rest = &tail[end + 1..];
            }
        }
        text.extend_from_slice(rest);
        if !text.is_empty() {
            parts.push(Part::Text(text));
        }
        Ok(Template { parts })
    }

    /// The template has no placeholder: a plain file name.
    pub fn is_plain(&self) -> bool {
        !self.parts.iter().any(|p| matches!(p, Part::Field(_)))
    }

    /// The template uses `field`.
    pub fn uses(&self, field: Field) -> bool {
        self.parts.contains(&Part::Field(field))
    }

    /// The file name for `vars`.
    pub fn expand(&self, vars: &Vars) -> Result<PathBuf, Error> {
        let mut s = Vec::new();
        for p in &self.parts {
            match p {
                Part::Text(t) => s.extend_from_slice(t),
                Part::Field(f) => {
                    let missing = || Error::new(UsageError::NoValue(f.name()));
                    match f {
                        Field::Stem => {
                            s.extend_from_slice(vars.stem.ok_or_else(missing)?.as_bytes())
                        }
                        Field::Seed => s.extend_from_slice(
                            vars.seed.ok_or_else(missing)?.to_string().as_bytes(),
                        ),
                        Field::N => {
                            s.extend_from_slice(vars.n.ok_or_else(missing)?.to_string().as_bytes())
                        }
                    }
                }
            }
        }
        if s == b"-" && !self.is_plain() {
            // A name made `-` (`{stem}` of `-.ls`) is a file: only `-o -`
            // itself is standard output.
            s.splice(0..0, *b"./");
        }
        Ok(PathBuf::from(OsString::from_vec(s)))
    }
}

/// What a batch expands its template with: one stem per file (distinct),
/// a seed range, the frames (`first`, `count`, step).
#[derive(Clone, Copy, Debug)]
pub struct Ranges<'a> {
    pub stems: &'a [OsString],
    pub seeds: Option<(u64, u64)>,
    pub frames: Option<(u64, u64, u64)>,
}

/// Outputs a batch checks one by one (16 bytes each), at most: for two of
/// the same name when the template alone does not show them distinct, and
/// for two names that are one file (looked up).
pub const MAX_CHECKED_OUTPUTS: u64 = 1 << 21;

impl Ranges<'_> {
    /// How many outputs: files × seeds × frames.
    pub fn count(&self) -> u64 {
        let s = self.seeds.map_or(1, |r| r.1);
        let f = self.frames.map_or(1, |r| r.1);
        (self.stems.len().max(1) as u64)
            .saturating_mul(s)
            .saturating_mul(f)
    }

    /// The values of output `i` (file-major, then seed, then frame).
    pub fn vars(&self, i: u64) -> Vars<'_> {
        let f = self.frames.map_or(1, |r| r.1);
        let s = self.seeds.map_or(1, |r| r.1);
        Vars {
            stem: self
                .stems
                .get((i / f / s) as usize)
                .map(OsString::as_os_str),
            seed: self.seeds.map(|(first, _)| first + (i / f) % s),
            n: self.frames.map(|(first, _, every)| first + (i % f) * every),
        }
    }
}

impl Template {
    /// Two outputs of a batch that the template gives the same name:
    /// their values and the name. The template shows its names distinct
    /// when at most one of its placeholders varies (stems are distinct),
    /// or when some character, not a digit and in no stem, stands in its
    /// text between every two varying placeholders: a name then splits at
    /// that character into the same pieces, each holding at most one
    /// varying value. Otherwise up to [`MAX_CHECKED_OUTPUTS`] names are
    /// compared by hash (equal hashes by name); past that, an error.
    pub fn collision<'r>(
        &self,
        r: &'r Ranges<'r>,
    ) -> Result<Option<(Vars<'r>, Vars<'r>, PathBuf)>, Error> {
        if self.distinct(r) {
            return Ok(None);
        }
        let total = r.count();
        if total > MAX_CHECKED_OUTPUTS {
            return Err(Error::new(UsageError::OutputNamesUnchecked(total)));
        }
        let first = first_alike(total, |i| self.expand(&r.vars(i)).map(Some))?;
        Ok(first.map(|(a, b, n)| (r.vars(a), r.vars(b), n)))
    }

    /// Does the template alone show the names of `r` distinct?
    fn distinct(&self, r: &Ranges) -> bool {
        let varies = |f: Field| match f {
            Field::Stem => r.stems.len() > 1,
            Field::Seed => r.seeds.is_some_and(|s| s.1 > 1),
            Field::N => r.frames.is_some_and(|f| f.1 > 1),
        };
        let fields = [Field::Stem, Field::Seed, Field::N];
        if fields
            .iter()
            .filter(|&&f| self.uses(f) && varies(f))
            .count()
            <= 1
        {
            return true;
        }
        // The text between consecutive varying placeholders (a fixed one
        // is text too: the same in every name, ignored here).
        let mut between: Vec<Vec<u8>> = Vec::new();
        let mut text = Vec::new();
        let mut seen = false;
        for p in &self.parts {
            match p {
                Part::Text(t) => text.extend_from_slice(t),
                Part::Field(f) if varies(*f) => {
                    if seen {
                        between.push(std::mem::take(&mut text));
                    }
                    text.clear();
                    seen = true;
                }
                Part::Field(_) => {}
            }
        }
        let stems_vary = self.uses(Field::Stem) && varies(Field::Stem);
        let Some(first) = between.first() else {
            return true;
        };
        // (Bytes, not characters: the proof holds for any alphabet.)
        first.iter().any(|c| {
            let in_a_value = c.is_ascii_digit()
                || stems_vary && r.stems.iter().any(|s| s.as_bytes().contains(c));
            !in_a_value && between.iter().all(|t| t.contains(c))
        })
    }
}

/// The first two of `0..total` (in that order: the pair with the smallest
/// first, then second, index) whose keys are equal, and that key; `None`
/// keys are never alike. 16 bytes per index are held (a hash of each key),
/// keys are compared exactly where hashes agree.
pub fn first_alike<K: Hash + Eq>(
    total: u64,
    key: impl Fn(u64) -> Result<Option<K>, Error>,
) -> Result<Option<(u64, u64, K)>, Error> {
    let mut hashes = Vec::with_capacity(usize::try_from(total).unwrap_or(0));
    for i in 0..total {
        if let Some(k) = key(i)? {
            let mut h = std::hash::DefaultHasher::new();
            k.hash(&mut h);
            hashes.push((h.finish(), i));
        }
    }
    hashes.sort_unstable();
    let mut first: Option<(u64, u64)> = None;
    for w in hashes.windows(2) {
        let ((ha, a), (hb, b)) = (w[0], w[1]);
        // Sorted by hash then index: `a < b`.
        if ha == hb && first.is_none_or(|f| (a, b) < f) && key(a)? == key(b)? {
            first = Some((a, b));
        }
    }
    match first {
        Some((a, b)) => Ok(key(a)?.map(|k| (a, b, k))),
        None => Ok(None),
    }
}

/// `{stem}` of an input: its file name without directory and extension;
/// `stdin` for standard input (None or `-`).
pub fn stem(file: Option<&Path>) -> OsString {
    match file {
        None => "stdin".into(),
        Some(p) if p.as_os_str() == "-" => "stdin".into(),
        Some(p) => p
            .file_stem()
            .map(OsStr::to_os_string)
            .unwrap_or_else(|| "stdin".into()),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Random small batches: the template's proof of distinct names is
    /// never wrong, and `collision` finds two names alike exactly when
    /// expanding every output and comparing (by a set) does.
    #[test]
    fn a_name_made_a_dash_is_a_file() {
        let v = Vars {
            stem: Some(OsStr::new("-")),
            ..Vars::default()
        };
        let t = Template::parse("{stem}").unwrap();
        assert_eq!(t.expand(&v).unwrap(), PathBuf::from("./-"));
        let t = Template::parse("-").unwrap();
        assert_eq!(t.expand(&v).unwrap(), PathBuf::from("-"));
    }

    #[test]
    fn collisions_are_found_exactly_and_proofs_are_sound() {
        use std::collections::HashSet;
        let mut x = 0x9e37_79b9_7f4a_7c15u64;
        let mut next = |m: u64| {
            x ^= x << 13;
            x ^= x >> 7;
            x ^= x << 17;
            x % m
        };
        let texts = ["", "", "", "", "1", "0", "-", "a", "x-", "_"];
        let stem_pool = ["a", "a1", "1", "11", "a-1", "b_", "", "x"];
        let (mut proofs, mut found) = (0, 0);
        for _ in 0..20_000 {
            let mut t = String::new();
            for _ in 0..1 + next(4) {
                t.push_str(texts[next(texts.len() as u64) as usize]);
                t.push_str(["{stem}", "{seed}", "{n}"][next(3) as usize]);
            }
            t.push_str(texts[next(texts.len() as u64) as usize]);
            let t = Template::parse(&t).unwrap();
            // As a batch must (the usage checks before this one): each
            // placeholder that varies is in the template.
            let mut stems: Vec<OsString> = Vec::new();
            let files = if t.uses(Field::Stem) { 1 + next(3) } else { 1 };
            for _ in 0..files {
                let s = OsString::from(stem_pool[next(stem_pool.len() as u64) as usize]);
                if !stems.contains(&s) {
                    stems.push(s);
                }
            }
            let vary = |f: Field, n: u64| if t.uses(f) { n } else { 1 };
            let r = Ranges {
                stems: &stems,
                seeds: Some((next(12), vary(Field::Seed, 1 + next(30)))),
                frames: Some((next(12), vary(Field::N, 1 + next(30)), 1 + next(3))),
            };
            let mut names = HashSet::new();
            let mut dup = false;
            for stem in &stems {
                for seed in r.seeds.unwrap().0..r.seeds.unwrap().0 + r.seeds.unwrap().1 {
                    let (f0, fc, fe) = r.frames.unwrap();
                    for k in 0..fc {
                        let v = Vars {
                            stem: Some(stem),
                            seed: Some(seed),
                            n: Some(f0 + k * fe),
                        };
                        dup |= !names.insert(t.expand(&v).unwrap());
                    }
                }
            }
            if t.distinct(&r) {
                proofs += 1;
                assert!(!dup, "{t:?} {r:?}");
            }
            let c = t.collision(&r).unwrap();
            assert_eq!(c.is_some(), dup, "{t:?} {r:?}");
            if let Some((a, b, name)) = c {
                found += 1;
                assert_eq!(t.expand(&a).unwrap(), name);
                assert_eq!(t.expand(&b).unwrap(), name);
                assert!((a.stem, a.seed, a.n) != (b.stem, b.seed, b.n));
            }
        }
        // Both kinds of batch were met, often.
        assert!(proofs > 2_000 && found > 100, "{proofs} {found}");
        // The two of the review: stems `a` and `a1` with seeds 1..11, and
        // frames 1..11 with seeds 1..11; with a `-` between, none.
        let stems = [OsString::from("a"), OsString::from("a1")];
        let r = Ranges {
            stems: &stems,
            seeds: Some((1, 11)),
            frames: None,
        };
        let t = Template::parse("out/{stem}{seed}").unwrap();
        let (a, b, name) = t.collision(&r).unwrap().unwrap();
        assert_eq!(name, PathBuf::from("out/a11"));
        assert_eq!(
            (a.stem, a.seed, b.stem, b.seed),
            (
                Some(OsStr::new("a")),
                Some(11),
                Some(OsStr::new("a1")),
                Some(1)
            )
        );
        assert!(Template::parse("out/{stem}-{seed}").unwrap().distinct(&r));
        let one = [OsString::from("a")];
        let r = Ranges {
            stems: &one,
            seeds: Some((1, 11)),
            frames: Some((1, 11, 1)),
        };
        let (a, b, name) = Template::parse("fr/{n}{seed}")
            .unwrap()
            .collision(&r)
            .unwrap()
            .unwrap();
        assert_eq!(name, PathBuf::from("fr/111"));
        assert_eq!(
            (a.seed, a.n, b.seed, b.n),
            (Some(1), Some(11), Some(11), Some(1))
        );
        // Too many to check one by one, and not shown distinct: an error.
        let r = Ranges {
            stems: &one,
            seeds: Some((1, MAX_CHECKED_OUTPUTS)),
            frames: Some((1, 2, 1)),
        };
        assert!(Template::parse("{n}{seed}").unwrap().collision(&r).is_err());
        assert!(Template::parse("{n}.{seed}")
            .unwrap()
            .collision(&r)
            .unwrap()
            .is_none());
    }

    fn vars() -> Vars<'static> {
        Vars {
            stem: Some(OsStr::new("plant")),
            seed: Some(7),
            n: Some(3),
        }
    }

    #[test]
    fn expands_fields_and_escapes() {
        let t = Template::parse("out/{stem}-{seed}.{n}.{{x}}").unwrap();
        assert_eq!(
            t.expand(&vars()).unwrap(),
            PathBuf::from("out/plant-7.3.{x}")
        );
        assert!(t.uses(Field::Stem) && t.uses(Field::Seed) && t.uses(Field::N));
        let plain = Template::parse("a}}b{{.txt").unwrap();
        assert!(plain.is_plain());
        assert_eq!(plain.expand(&vars()).unwrap(), PathBuf::from("a}b{.txt"));
    }

    #[test]
    fn rejects_unknown_and_unclosed() {
        for bad in ["{x}", "a{stem", "a}b", "{}", "{Stem}"] {
            let e = Template::parse(bad).unwrap_err();
            assert_eq!(e.stage(), crate::diag::Stage::Usage, "{bad}");
        }
    }

    #[test]
    fn missing_value_is_an_error() {
        let t = Template::parse("f{n}").unwrap();
        assert!(t.expand(&Vars::default()).is_err());
    }

    #[test]
    fn names_that_are_not_utf8_are_templates_too() {
        let p = Path::new(OsStr::from_bytes(b"out\xff/{stem}-{seed}\xfe"));
        let t = Template::parse_path(p).unwrap();
        assert!(t.uses(Field::Stem) && t.uses(Field::Seed));
        let v = Vars {
            stem: Some(OsStr::from_bytes(b"pl\xe9")),
            seed: Some(7),
            n: None,
        };
        assert_eq!(
            t.expand(&v).unwrap(),
            Path::new(OsStr::from_bytes(b"out\xff/pl\xe9-7\xfe"))
        );
        let bad = Path::new(OsStr::from_bytes(b"o\xff{bogus}"));
        assert!(Template::parse_path(bad).is_err());
        // A separator byte that is in no stem shows them apart.
        let stems = [OsString::from_vec(b"a\xff".to_vec()), OsString::from("a")];
        let r = Ranges {
            stems: &stems,
            seeds: Some((1, 20)),
            frames: None,
        };
        let apart = Path::new(OsStr::from_bytes(b"{stem}\xfe{seed}"));
        assert!(Template::parse_path(apart).unwrap().distinct(&r));
        let not = Path::new(OsStr::from_bytes(b"{stem}\xff{seed}"));
        assert!(!Template::parse_path(not).unwrap().distinct(&r));
    }

    #[test]
    fn stems() {
        assert_eq!(stem(Some(Path::new("a/b/plant.ls"))), "plant");
        assert_eq!(stem(Some(Path::new("x.tar.ls"))), "x.tar");
        assert_eq!(stem(Some(Path::new("-"))), "stdin");
        assert_eq!(stem(None), "stdin");
        let odd = Path::new(OsStr::from_bytes(b"d/pl\xe9.ls"));
        assert_eq!(stem(Some(odd)).as_bytes(), b"pl\xe9");
    }
}
