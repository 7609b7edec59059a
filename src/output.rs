//! Where the final string goes: standard output, or `-o FILE` written to an
//! unnamed temp file in FILE's directory and put in place only on success,
//! so a failed or killed run never leaves a partial file or clobbers one.

use crate::diag::Error;
use std::fs::File;
use std::io::{self, Write};
use std::path::{Path, PathBuf};

pub enum Output {
    Stdout(io::Stdout),
    /// A regular file, written beside its final name.
    Atomic {
        file: File,
        path: PathBuf,
        dir: PathBuf,
        /// Permissions the new file gets: the replaced file's, or the
        /// default for a new file (0666 less the umask).
        mode: u32,
    },
    /// An existing non-regular file (a device, a FIFO): written in place.
    Direct(File, PathBuf),
}

impl Output {
    pub fn stdout() -> Output {
        Output::Stdout(io::stdout())
    }

    pub fn file(path: &Path) -> Result<Output, Error> {
        let name = path.display().to_string();
        if let Ok(meta) = std::fs::metadata(path) {
            if meta.is_dir() {
                return Err(Error::io(
                    name,
                    "cannot write",
                    io::Error::from(io::ErrorKind::IsADirectory),
                ));
            }
            if !meta.is_file() {
                let f = std::fs::OpenOptions::new()
                    .write(true)
                    .open(path)
                    .map_err(|e| Error::io(name, "cannot write", e))?;
                return Ok(Output::Direct(f, path.to_path_buf()));
            }
        }
        use std::os::unix::fs::PermissionsExt;
        let mode = match std::fs::metadata(path) {
            Ok(m) => m.permissions().mode() & 0o7777,
            Err(_) => 0o666 & !umask(),
        };
        let dir = match path.parent() {
            Some(d) if !d.as_os_str().is_empty() => d.to_path_buf(),
            _ => PathBuf::from("."),
        };
        // O_TMPFILE on Linux: the file has no name until it is complete.
        let file = tempfile::tempfile_in(&dir).map_err(|e| Error::io(name, "cannot write", e))?;
        Ok(Output::Atomic {
            file,
            path: path.to_path_buf(),
            dir,
            mode,
        })
    }

    pub fn name(&self) -> String {
        match self {
            Output::Stdout(_) => "standard output".into(),
            Output::Atomic { path, .. } => path.display().to_string(),
            Output::Direct(_, path) => path.display().to_string(),
        }
    }

    pub fn writer(&mut self) -> &mut dyn Write {
        match self {
            Output::Stdout(s) => s,
            Output::Atomic { file, .. } | Output::Direct(file, _) => file,
        }
    }

    /// Put a complete file in place. Not calling this discards the output.
    pub fn commit(self) -> Result<(), Error> {
        let Output::Atomic {
            file,
            path,
            dir,
            mode,
        } = self
        else {
            return Ok(());
        };
        let name = path.display().to_string();
        {
            use std::os::unix::fs::PermissionsExt;
            file.set_permissions(std::fs::Permissions::from_mode(mode))
                .and_then(|_| file.sync_all())
                .map_err(|e| Error::io(name.clone(), "cannot write", e))?;
        }
        // Ctrl-C (or SIGTERM) while the file gets its name would leave a
        // named temp file behind: hold such signals until it is in place.
        let result = with_signals_held(|| Self::put_in_place(file, &dir, &path, &name));
        // Make the rename durable.
        if let Ok(d) = File::open(&dir) {
            let _ = d.sync_all();
        }
        result
    }

    fn put_in_place(file: File, dir: &Path, path: &Path, name: &str) -> Result<(), Error> {
        match link_into_place(&file, dir, path) {
            Ok(()) => Ok(()),
            // No O_TMPFILE here (tempfile fell back to a deleted named file,
            // which cannot be linked again): copy into a named temp file.
            Err(e) if e.raw_os_error() == Some(rustix::io::Errno::NOENT.raw_os_error()) => {
                copy_into_place(file, dir, path).map_err(|e| Error::io(name, "cannot write", e))
            }
            Err(e) => Err(Error::io(name, "cannot write", e)),
        }
    }
}

/// Give the unnamed file a temporary name in `dir` (linkat through
/// /proc/self/fd), then rename it over `path` atomically.
fn link_into_place(file: &File, dir: &Path, path: &Path) -> io::Result<()> {
    use rustix::fs::{linkat, AtFlags, CWD};
    use std::os::fd::AsRawFd;
    let proc_path = format!("/proc/self/fd/{}", file.as_raw_fd());
    for attempt in 0..100u32 {
        let tmp = dir.join(format!(
            ".lsgen-{}-{}-{attempt}.tmp",
            std::process::id(),
            std::time::SystemTime::now()
                .duration_since(std::time::UNIX_EPOCH)
                .map_or(0, |d| d.subsec_nanos())
        ));
        match linkat(CWD, proc_path.as_str(), CWD, &tmp, AtFlags::SYMLINK_FOLLOW) {
            Ok(()) => {
                return std::fs::rename(&tmp, path).inspect_err(|_| {
                    let _ = std::fs::remove_file(&tmp);
                });
            }
            Err(e) if e == rustix::io::Errno::EXIST => continue,
            Err(e) => return Err(e.into()),
        }
    }
    Err(io::Error::from(io::ErrorKind::AlreadyExists))
}

/// The process umask, read from /proc (022 if it cannot be read).
fn umask() -> u32 {
    std::fs::read_to_string("/proc/self/status")
        .ok()
        .and_then(|s| {
            s.lines()
                .find_map(|l| l.strip_prefix("Umask:"))
                .and_then(|v| u32::from_str_radix(v.trim(), 8).ok())
        })
        .unwrap_or(0o022)
}

fn copy_into_place(mut file: File, dir: &Path, path: &Path) -> io::Result<()> {
    use std::io::{Seek, SeekFrom};
    let mut tmp = tempfile::Builder::new()
        .prefix(".lsgen-")
        .tempfile_in(dir)?;
    file.seek(SeekFrom::Start(0))?;
    io::copy(&mut file, tmp.as_file_mut())?;
    tmp.as_file()
        .set_permissions(file.metadata()?.permissions())?;
    tmp.as_file().sync_all()?;
    tmp.persist(path).map(|_| ()).map_err(|e| e.error)
}

/// The signals that end a run from outside (SIGKILL aside).
fn termination_signals() -> libc::sigset_t {
    // SAFETY: sigemptyset/sigaddset only write the set we own.
    unsafe {
        let mut set: libc::sigset_t = std::mem::zeroed();
        libc::sigemptyset(&mut set);
        for s in [libc::SIGINT, libc::SIGTERM, libc::SIGHUP, libc::SIGQUIT] {
            libc::sigaddset(&mut set, s);
        }
        set
    }
}

/// Run `f` with termination signals held for this thread; one that arrives
/// meanwhile takes effect when `f` is done.
fn with_signals_held<T>(f: impl FnOnce() -> T) -> T {
    let set = termination_signals();
    // SAFETY: pthread_sigmask changes this thread's mask only; the old mask
    // is restored below.
    let mut old: libc::sigset_t = unsafe { std::mem::zeroed() };
    unsafe { libc::pthread_sigmask(libc::SIG_BLOCK, &set, &mut old) };
    let r = f();
    unsafe { libc::pthread_sigmask(libc::SIG_SETMASK, &old, std::ptr::null_mut()) };
    r
}

/// Let termination signals reach only the other threads (the worker): the
/// main thread, which only waits, must not take them while the worker
/// holds them.
pub fn leave_termination_signals_to_other_threads() {
    let set = termination_signals();
    // SAFETY: changes this thread's signal mask only.
    unsafe { libc::pthread_sigmask(libc::SIG_BLOCK, &set, std::ptr::null_mut()) };
}
