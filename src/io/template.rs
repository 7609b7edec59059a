//! Output name templates (`-o 'out/{stem}-{seed}.txt'`): the one place that
//! expands them, for batches (`{stem}`, `{seed}`) and frames (`{n}`).
//!
//! `{stem}` is the input file's name without directory and extension
//! (`stdin` for standard input), `{seed}` the job's seed, `{n}` the
//! generation number. `{{` and `}}` stand for literal braces. Any other
//! `{...}` is a usage error, so a typo never silently becomes part of a
//! file name.

use crate::diag::{Error, UsageError};
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
        Ok(PathBuf::from(s))
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
