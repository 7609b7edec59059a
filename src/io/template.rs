//! Output name templates (`-o 'out/{stem}-{seed}.txt'`): the one place that
//! expands them, for batches (`{stem}`, `{seed}`) and frames (`{n}`).
//!
//! `{stem}` is the input file's name without directory and extension
//! (`stdin` for standard input), `{seed}` the job's seed, `{n}` the
//! generation number. `{{` and `}}` stand for literal braces. Any other
//! `{...}` is a usage error, so a typo never silently becomes part of a
//! file name.

use crate::diag::{Error, UsageError};
use std::hash::{Hash, Hasher};
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
    Text(String),
    Field(Field),
}

/// A parsed `-o` template.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Template {
    parts: Vec<Part>,
    /// A name that is not UTF-8: used as it is, no placeholders.
    raw: Option<PathBuf>,
}

/// The values a template is expanded with; a `None` field that the template
/// uses is an error (e.g. `{n}` without frames).
#[derive(Clone, Copy, Debug, Default)]
pub struct Vars<'a> {
    pub stem: Option<&'a str>,
    pub seed: Option<u64>,
    pub n: Option<u64>,
}

impl Template {
    /// Parse `-o`'s name; one that is not UTF-8 is a plain name.
    pub fn parse_path(p: &Path) -> Result<Template, Error> {
        match p.to_str() {
            Some(s) => Template::parse(s),
            None => Ok(Template {
                parts: Vec::new(),
                raw: Some(p.to_path_buf()),
            }),
        }
    }

    /// Parse `s`; an unknown or unclosed placeholder is a usage error.
    pub fn parse(s: &str) -> Result<Template, Error> {
        let mut parts = Vec::new();
        let mut text = String::new();
        let mut rest = s;
        while let Some(i) = rest.find(['{', '}']) {
            text.push_str(&rest[..i]);
            let tail = &rest[i..];
            if let Some(r) = tail.strip_prefix("{{") {
                text.push('{');
                rest = r;
            } else if let Some(r) = tail.strip_prefix("}}") {
                text.push('}');
                rest = r;
            } else if tail.starts_with('}') {
                return Err(Error::new(UsageError::LoneCloseBrace(s.to_string())));
            } else {
                let end = tail
                    .find('}')
                    .ok_or_else(|| Error::new(UsageError::UnclosedBrace(s.to_string())))?;
                let field = match &tail[1..end] {
                    "stem" => Field::Stem,
                    "seed" => Field::Seed,
                    "n" => Field::N,
                    other => {
                        return Err(Error::new(UsageError::UnknownPlaceholder {
                            template: s.to_string(),
                            name: other.to_string(),
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
        text.push_str(rest);
        if !text.is_empty() {
            parts.push(Part::Text(text));
        }
        Ok(Template { parts, raw: None })
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
        if let Some(raw) = &self.raw {
            return Ok(raw.clone());
        }
        let mut s = String::new();
        for p in &self.parts {
            match p {
                Part::Text(t) => s.push_str(t),
                Part::Field(f) => {
                    let v = match f {
                        Field::Stem => vars.stem.map(str::to_string),
                        Field::Seed => vars.seed.map(|v| v.to_string()),
                        Field::N => vars.n.map(|v| v.to_string()),
                    };
                    let v = v.ok_or_else(|| Error::new(UsageError::NoValue(f.name())))?;
                    s.push_str(&v);
                }
            }
        }
        if s == "-" && !self.is_plain() {
            // A name made `-` (`{stem}` of `-.ls`) is a file: only `-o -`
            // itself is standard output.
            s.insert_str(0, "./");
        }
        Ok(PathBuf::from(s))
    }
}

/// What a batch expands its template with: one stem per file (distinct),
/// a seed range, the frames (`first`, `count`, step).
#[derive(Clone, Copy, Debug)]
pub struct Ranges<'a> {
    pub stems: &'a [String],
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
            stem: self.stems.get((i / f / s) as usize).map(String::as_str),
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
        if self.raw.is_some() || self.distinct(r) {
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
        let mut between: Vec<String> = Vec::new();
        let mut text = String::new();
        let mut seen = false;
        for p in &self.parts {
            match p {
                Part::Text(t) => text.push_str(t),
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
        first.chars().any(|c| {
            let in_a_value =
                c.is_ascii_digit() || stems_vary && r.stems.iter().any(|s| s.contains(c));
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
pub fn stem(file: Option<&Path>) -> String {
    match file {
        None => "stdin".into(),
        Some(p) if p.as_os_str() == "-" => "stdin".into(),
        Some(p) => p
            .file_stem()
            .map(|s| s.to_string_lossy().into_owned())
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
            stem: Some("-"),
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
            let mut stems: Vec<String> = Vec::new();
            let files = if t.uses(Field::Stem) { 1 + next(3) } else { 1 };
            for _ in 0..files {
                let s = stem_pool[next(stem_pool.len() as u64) as usize].to_string();
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
        let stems = ["a".to_string(), "a1".to_string()];
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
            (Some("a"), Some(11), Some("a1"), Some(1))
        );
        assert!(Template::parse("out/{stem}-{seed}").unwrap().distinct(&r));
        let one = ["a".to_string()];
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
            stem: Some("plant"),
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
    fn a_name_that_is_not_utf8_is_plain() {
        use std::os::unix::ffi::OsStrExt;
        let p = Path::new(std::ffi::OsStr::from_bytes(b"out\xff{stem}"));
        let t = Template::parse_path(p).unwrap();
        assert!(t.is_plain());
        assert_eq!(t.expand(&Vars::default()).unwrap(), p);
    }

    #[test]
    fn stems() {
        assert_eq!(stem(Some(Path::new("a/b/plant.ls"))), "plant");
        assert_eq!(stem(Some(Path::new("x.tar.ls"))), "x.tar");
        assert_eq!(stem(Some(Path::new("-"))), "stdin");
        assert_eq!(stem(None), "stdin");
    }
}
