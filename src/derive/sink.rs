//! The sink of one generation: binary (a temp file, optionally with a
//! bracket index) or text (the output), buffered, counting modules and
//! bytes against `--max-length`.

use super::Pass;
use crate::diag::Error;
use crate::rules::codec::{self, MAX_MODULE_BYTES};
use crate::rules::{Alphabet, ConstRun, CLOSE, OPEN};
use std::fs::File;
use std::io::Write;
use std::os::unix::fs::FileExt;

pub(crate) const OUT_CHUNK: usize = 1 << 20;

/// Limits on the size of any generation (`--max-length`).
#[derive(Clone, Copy, Debug)]
pub struct Limits {
    /// Most modules in any generation.
    pub modules: u64,
    /// Most bytes in any generation (of the binary temporary format for
    /// intermediate generations, of the text for the last).
    pub bytes: u64,
}

impl Limits {
    /// Is a generation of `modules` modules and `bytes` bytes, made by
    /// `pass`, too long?
    pub fn check(&self, modules: u64, bytes: u64, pass: Pass) -> Result<(), Error> {
        if modules > self.modules {
            return Err(Error::new(format!(
                "the string grew past --max-length ({} modules) in {pass}",
                self.modules
            )));
        }
        if bytes > self.bytes {
            return Err(Error::new(format!(
                "the string grew past --max-length ({} bytes) in {pass}",
                self.bytes
            )));
        }
        Ok(())
    }
}

impl Limits {
    /// Check the lengths of generations 1, 2, ... against the limits, as
    /// the step engine would: modules for every generation; bytes for those
    /// written in binary (all but the last, which is text, unless a
    /// homomorphism follows it: the text is checked as it is written).
    pub fn check_generations(
        &self,
        lengths: &[(u64, u64)],
        last_is_text: bool,
    ) -> Result<(), Error> {
        for (i, &(n, bytes)) in lengths.iter().enumerate() {
            let bytes = if last_is_text && i + 1 == lengths.len() {
                0
            } else {
                bytes
            };
            self.check(n, bytes, Pass::Step(i as u64 + 1))?;
        }
        Ok(())
    }
}

impl Default for Limits {
    fn default() -> Self {
        Limits {
            modules: u64::MAX,
            bytes: u64::MAX,
        }
    }
}

/// A buffered sink for one generation, binary or text.
pub struct Out<'w> {
    pub(crate) buf: Vec<u8>,
    w: &'w mut dyn Write,
    /// Bracket index mode: each `[` carries the offset just past its `]`,
    /// patched in the buffer or, once flushed, in `file`.
    pub(crate) indexed: Option<File>,
    opens: Vec<u64>,
    name: &'w str,
    pub text: bool,
    pub(crate) modules: u64,
    written: u64,
    num: codec::NumFmt,
    limits: Limits,
    /// What this generation is, for `--max-length` errors.
    pass: Pass,
    /// A progress display's meter, if one is installed.
    meter: Option<std::sync::Arc<super::meter::Meter>>,
}

impl<'w> Out<'w> {
    pub fn new(w: &'w mut dyn Write, name: &'w str, text: bool, limits: Limits) -> Out<'w> {
        Out {
            buf: Vec::with_capacity(OUT_CHUNK + MAX_MODULE_BYTES * 4),
            w,
            indexed: None,
            opens: Vec::new(),
            name,
            text,
            modules: 0,
            written: 0,
            num: codec::NumFmt::new(),
            limits,
            pass: Pass::Axiom,
            meter: super::meter::current(),
        }
    }

    /// Name the pass that makes this generation (default: the axiom).
    pub fn for_pass(mut self, pass: Pass) -> Self {
        self.pass = pass;
        self
    }

    /// Write a bracket index: `file` is the file this sink writes to.
    pub fn with_index(mut self, file: File) -> Self {
        self.indexed = Some(file);
        self
    }

    #[inline]
    pub(crate) fn open(&mut self) {
        if self.indexed.is_some() {
            self.opens.push(self.written + self.buf.len() as u64);
            self.buf.push(b'[');
            self.buf.extend_from_slice(&[0; 8]);
        } else {
            self.buf.push(b'[');
        }
    }

    #[inline]
    pub(crate) fn close(&mut self) -> Result<(), Error> {
        self.buf.push(b']');
        if self.indexed.is_some() {
            let end = self.written + self.buf.len() as u64;
            self.patch(end)?;
        }
        Ok(())
    }

    /// The `]` ending just before offset `end` closes the last open `[`:
    /// write `end` into that `[`'s index bytes, in the buffer or, once
    /// flushed, in the file.
    #[inline]
    pub(crate) fn patch(&mut self, end: u64) -> Result<(), Error> {
        let Some(at) = self.opens.pop() else {
            return Ok(()); // unbalanced: reported by the balance check
        };
        let end = end.to_le_bytes();
        if at >= self.written {
            let i = (at - self.written) as usize + 1;
            self.buf[i..i + 8].copy_from_slice(&end);
        } else if let Some(file) = &self.indexed {
            file.write_all_at(&end, at + 1)
                .map_err(|e| Error::io(self.name, "cannot write", e))?;
        }
        Ok(())
    }

    /// Copy a module given in binary form.
    #[inline]
    pub fn raw(&mut self, key: u32, bytes: &[u8], al: &Alphabet) -> Result<(), Error> {
        self.modules += 1;
        if key < 128 {
            if key == OPEN {
                self.open();
            } else if key == CLOSE {
                self.close()?;
            } else {
                self.buf.push(key as u8);
            }
        } else if !self.text {
            self.buf.extend_from_slice(bytes);
        } else {
            let (_, kl) = codec::get_key(bytes);
            let body = &bytes[kl..];
            self.buf.extend_from_slice(al.text(key));
            let n = al.arity(key);
            if n > 0 {
                self.buf.push(b'(');
                for i in 0..n {
                    if i > 0 {
                        self.buf.push(b',');
                    }
                    self.num.put(&mut self.buf, codec::get_param(body, i));
                }
                self.buf.push(b')');
            }
        }
        Ok(())
    }

    /// Text or binary known to hold `modules` modules, in this sink's format.
    #[inline]
    pub fn extend(&mut self, bytes: &[u8], modules: u64) {
        self.modules += modules;
        self.buf.extend_from_slice(bytes);
    }

    /// Plain modules: ASCII symbols without parameters, one byte each in
    /// both formats.
    #[inline]
    pub fn plain(&mut self, run: &[u8]) -> Result<(), Error> {
        if self.indexed.is_none() {
            self.modules += run.len() as u64;
            self.buf.extend_from_slice(run);
            return Ok(());
        }
        self.modules += run.len() as u64;
        for &b in run {
            match b {
                b'[' => self.open(),
                b']' => self.close()?,
                _ => self.buf.push(b),
            }
        }
        Ok(())
    }

    #[inline]
    pub fn constant(&mut self, c: &ConstRun) -> Result<(), Error> {
        self.modules += c.modules;
        if self.text {
            self.buf.extend_from_slice(c.text());
        } else if self.indexed.is_none() {
            self.buf.extend_from_slice(c.bin());
        } else {
            let base = self.buf.len();
            self.buf.extend_from_slice(c.ibin());
            for &(at, open) in c.brackets.iter() {
                let abs = self.written + (base + at as usize) as u64;
                if open {
                    self.opens.push(abs);
                } else {
                    self.patch(abs + 1)?;
                }
            }
        }
        Ok(())
    }

    #[inline]
    pub fn module(&mut self, key: u32, params: &[f64], al: &Alphabet) -> Result<(), Error> {
        if key == OPEN || key == CLOSE {
            return self.raw(key, &[key as u8], al);
        }
        self.modules += 1;
        if self.text {
            self.num.module(&mut self.buf, al.text(key), params);
        } else {
            codec::put_key(&mut self.buf, key);
            codec::put_params(&mut self.buf, params);
        }
        Ok(())
    }

    #[inline]
    pub fn maybe_flush(&mut self) -> Result<(), Error> {
        if self.buf.len() >= OUT_CHUNK {
            self.flush()?;
        }
        Ok(())
    }

    pub(crate) fn flush(&mut self) -> Result<(), Error> {
        self.flush_but(0)
    }

    /// Flush, not counting the last `uncounted` bytes (the text's final
    /// newline) against `--max-length`.
    pub(crate) fn flush_but(&mut self, uncounted: u64) -> Result<(), Error> {
        self.written += self.buf.len() as u64;
        self.limits
            .check(self.modules, self.written - uncounted, self.pass)?;
        self.w
            .write_all(&self.buf)
            .map_err(|e| Error::io(self.name, "cannot write", e))?;
        self.buf.clear();
        if let Some(m) = &self.meter {
            m.record(self.modules, self.written);
        }
        Ok(())
    }

    /// Flush everything; returns the generation's length: (modules,
    /// bytes), the bytes without the text's final newline.
    pub fn finish(mut self) -> Result<(u64, u64), Error> {
        let newline = u64::from(self.text);
        if self.text {
            self.buf.push(b'\n');
        }
        self.flush_but(newline)?;
        self.w
            .flush()
            .map_err(|e| Error::io(self.name, "cannot write", e))?;
        Ok((self.modules, self.written - newline))
    }
}
