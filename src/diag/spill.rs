//! cpfg `printf` text that a library derivation's collection
//! ([`super::collect_warnings`]) holds past [`HELD_MAX`] bytes: appended
//! to an unnamed temporary file as records (the text's length, 8 bytes
//! little-endian, then the text) and read back in order when the
//! collection hands its events over. A model that prints at every module
//! holds at most [`HELD_MAX`] bytes of text in memory, not a step's.

use std::fs::File;
use std::io;
use std::os::unix::fs::FileExt;
use std::path::Path;

/// Bytes of `printf` text a collection holds in memory before it spills.
pub(crate) const HELD_MAX: usize = 1 << 20;

/// Bytes read back at a time.
const READ: usize = 64 << 10;

/// Length prefix of a record.
const LEN: usize = 8;

pub(crate) struct Spill {
    file: File,
    /// End of the records written.
    len: u64,
    /// One record, reused.
    rec: Vec<u8>,
}

impl Spill {
    /// An unnamed file in `dir` (else the system's temporary directory),
    /// deleted when dropped.
    pub(crate) fn new(dir: Option<&Path>) -> io::Result<Spill> {
        let file = match dir {
            Some(d) => tempfile::tempfile_in(d)?,
            None => tempfile::tempfile()?,
        };
        Ok(Spill {
            file,
            len: 0,
            rec: Vec::new(),
        })
    }

    /// Append `text`; returns the range of the file its record takes. On
    /// an error nothing counts as written (the next record goes where
    /// this one was to go).
    pub(crate) fn push(&mut self, text: &str) -> io::Result<(u64, u64)> {
        self.rec.clear();
        self.rec
            .extend_from_slice(&(text.len() as u64).to_le_bytes());
        self.rec.extend_from_slice(text.as_bytes());
        self.file.write_all_at(&self.rec, self.len)?;
        let from = self.len;
        self.len += self.rec.len() as u64;
        Ok((from, self.len))
    }

    /// Hand the texts of the records in `from..to` to `f`, in order.
    pub(crate) fn read(&self, (from, to): (u64, u64), f: &mut dyn FnMut(String)) -> io::Result<()> {
        let bad = || io::Error::new(io::ErrorKind::InvalidData, "a record past its range");
        let mut buf = Vec::new();
        // `buf` holds the file's bytes from `at`.
        let mut at = from;
        let mut i = 0;
        while at + (i as u64) < to {
            if buf.len() - i < LEN {
                // Refill from the record's start.
                at += i as u64;
                let want = READ.min((to - at) as usize);
                buf.resize(want, 0);
                self.file.read_exact_at(&mut buf, at)?;
                i = 0;
                if buf.len() < LEN {
                    return Err(bad());
                }
            }
            let n = u64::from_le_bytes(buf[i..i + LEN].try_into().expect("8 bytes"));
            let end = (at + (i + LEN) as u64).checked_add(n).ok_or_else(bad)?;
            if end > to {
                return Err(bad());
            }
            let n = n as usize;
            let text = if i + LEN + n <= buf.len() {
                buf[i + LEN..i + LEN + n].to_vec()
            } else {
                // Not all in the buffer: read it whole.
                let mut t = vec![0; n];
                self.file.read_exact_at(&mut t, at + (i + LEN) as u64)?;
                t
            };
            let text = String::from_utf8(text).map_err(|_| bad())?;
            f(text);
            if i + LEN + n <= buf.len() {
                i += LEN + n;
            } else {
                at = end;
                i = 0;
                buf.clear();
            }
        }
        Ok(())
    }

    /// Forget the records: the next goes at the file's start.
    pub(crate) fn reset(&mut self) {
        self.len = 0;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Records of every size around the read size come back in order,
    /// and in two ranges as written.
    #[test]
    fn records_come_back_in_order() {
        let mut s = Spill::new(None).unwrap();
        let texts: Vec<String> = [
            0,
            1,
            7,
            8,
            9,
            READ - 9,
            READ - 8,
            READ,
            READ + 1,
            3 * READ,
            5,
        ]
        .iter()
        .enumerate()
        .map(|(k, &n)| ((b'a' + k as u8) as char).to_string().repeat(n))
        .collect();
        let mut ranges = Vec::new();
        for t in &texts {
            ranges.push(s.push(t).unwrap());
        }
        let split = 6;
        let mut got = Vec::new();
        s.read((ranges[0].0, ranges[split - 1].1), &mut |t| got.push(t))
            .unwrap();
        s.read((ranges[split].0, ranges.last().unwrap().1), &mut |t| {
            got.push(t)
        })
        .unwrap();
        assert_eq!(got, texts);
        // Many small records across the read size.
        s.reset();
        let small: Vec<String> = (0..20_000).map(|k| format!("line {k}\n")).collect();
        let (from, mut to) = (0, 0);
        for t in &small {
            to = s.push(t).unwrap().1;
        }
        let mut got = Vec::new();
        s.read((from, to), &mut |t| got.push(t)).unwrap();
        assert_eq!(got, small);
    }

    /// A range that ends inside a record is an error, not a short text.
    #[test]
    fn a_cut_range_is_an_error() {
        let mut s = Spill::new(None).unwrap();
        let (from, to) = s.push("hello").unwrap();
        let r = s.read((from, to - 1), &mut |_| panic!("no text"));
        assert_eq!(r.unwrap_err().kind(), io::ErrorKind::InvalidData);
    }
}
