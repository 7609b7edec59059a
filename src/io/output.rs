//! Where the final string goes: standard output; a stream (`-o` naming a
//! device, a FIFO, `/dev/stdout`, `/dev/fd/N`); or a regular file, written
//! to an unnamed temp file in its directory and put in place only on
//! success, so a failed or killed run never leaves a partial file or
//! clobbers one. `-o` follows symbolic links: the link's target is replaced
//! and the link kept, as the shell's `>` writes through it.

use crate::diag::{Error, IoAction, IoError, IoReason};
use std::fs::{self, File};
use std::io::{self, Write};
use std::mem::ManuallyDrop;
use std::os::unix::ffi::OsStrExt;
use std::os::unix::fs::{FileTypeExt, MetadataExt, OpenOptionsExt, PermissionsExt};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, AtomicU8, Ordering};

pub enum Output {
    /// File descriptor 1, written directly: whole blocks go to `write(2)`
    /// as they are (std's line-buffered stdout scans each for `\n`).
    /// Never closed (`ManuallyDrop`): the descriptor is not ours.
    Stdout(ManuallyDrop<File>),
    /// A regular file, written beside its final name.
    Atomic {
        file: WriteBehind,
        /// The final name: the target of `-o`'s symbolic link(s), if any.
        path: PathBuf,
        dir: PathBuf,
        /// Permissions the new file gets: the replaced file's, or the
        /// default for a new file (0666 less the umask).
        mode: u32,
        /// `-o` as given, for messages.
        name: String,
    },
    /// A stream: a device, a FIFO, or one of lsgen's own open files
    /// (`/dev/stdout`, `/dev/fd/N`): written in place.
    Direct(File, String),
}

/// Bit n set: standard file descriptor n was closed when lsgen started.
static CLOSED_AT_START: AtomicU8 = AtomicU8::new(0);

/// The directories of the files a batch has put in place, while a
/// [`DeferDirSync`] lives (else None): their syncs wait for its end.
static DEFERRED_DIRS: std::sync::Mutex<Option<std::collections::HashSet<PathBuf>>> =
    std::sync::Mutex::new(None);

/// While this lives, [`Output::commit`] leaves the sync of the directory
/// (what makes the new name durable) to this guard's drop, once per
/// directory. A batch of tiny jobs into one directory synced it after
/// every job: one of a job's two `fsync`s, which were most of its time on
/// a disk. The files themselves are still synced before they get their
/// names, so a crash never leaves a partial file; it may lose names given
/// since the batch began, as a crash before the end loses the later jobs.
#[cfg_attr(not(feature = "cli"), allow(dead_code))]
pub(crate) struct DeferDirSync(());

#[cfg_attr(not(feature = "cli"), allow(dead_code))]
impl DeferDirSync {
    pub(crate) fn new() -> DeferDirSync {
        if let Ok(mut d) = DEFERRED_DIRS.lock() {
            *d = Some(Default::default());
        }
        DeferDirSync(())
    }
}

impl Drop for DeferDirSync {
    fn drop(&mut self) {
        let dirs = DEFERRED_DIRS.lock().ok().and_then(|mut d| d.take());
        for dir in dirs.into_iter().flatten() {
            sync_dir(&dir);
        }
    }
}

/// Make the names given in `dir` durable (best effort: a directory that
/// cannot be opened or synced is left as it is).
fn sync_dir(dir: &Path) {
    if let Ok(d) = File::open(dir) {
        let _ = d.sync_all();
    }
}

/// Sync `dir` now, or note it for the batch's end ([`DeferDirSync`]).
fn sync_dir_now_or_later(dir: &Path) {
    if let Ok(mut d) = DEFERRED_DIRS.lock() {
        if let Some(set) = d.as_mut() {
            if !set.contains(dir) {
                set.insert(dir.to_path_buf());
            }
            return;
        }
    }
    sync_dir(dir);
}

/// Note which standard descriptors are closed (`>&-`, `2>&-`) and give
/// them /dev/null, so that no file lsgen opens takes their number (a
/// diagnostic would land in it); output for a closed standard output is
/// then an error, not silently discarded. Rust's runtime also gives them
/// /dev/null before `main`, so the binary calls this earlier, from an
/// `.init_array` constructor (src/main.rs).
pub fn note_closed_standard_fds() {
    let mut closed = 0u8;
    for fd in 0..3 {
        // SAFETY: F_GETFD only queries the descriptor.
        if unsafe { libc::fcntl(fd, libc::F_GETFD) } != -1 {
            continue;
        }
        closed |= 1 << fd;
        // SAFETY: open/dup2/close on descriptors this function owns; open
        // takes the lowest free number, normally `fd` itself.
        unsafe {
            let got = libc::open(c"/dev/null".as_ptr(), libc::O_RDWR);
            if got >= 0 && got != fd {
                libc::dup2(got, fd);
                libc::close(got);
            }
        }
    }
    CLOSED_AT_START.store(closed, Ordering::Relaxed);
}

/// This run reads its standard input itself (lsgen: the L-system or
/// `--axiom`; lsgen-turtle: the module string).
static STDIN_TAKEN: AtomicBool = AtomicBool::new(false);

/// Note that this run reads standard input itself: an `#include` of that
/// stream (by any of its names: [`is_stdin_stream`]) is then refused.
pub fn note_stdin_taken() {
    STDIN_TAKEN.store(true, Ordering::Relaxed);
}

/// Does opening `path` read the stream that this run reads as its
/// standard input ([`note_stdin_taken`])?
/// `/dev/stdin`, a link to it, or the FIFO or device standard input is:
/// what it read would be taken from the L-system or the axiom. (A
/// regular file on standard input, opened again, reads from its start:
/// no conflict.)
pub(crate) fn takes_stdin(path: &Path) -> bool {
    STDIN_TAKEN.load(Ordering::Relaxed) && is_stdin_stream(path)
}

/// Is `path` the stream standard input is (`/dev/stdin`, `/dev/fd/0`, a
/// link to them, the FIFO or device itself)? Two readers of it share its
/// bytes. (A regular file on standard input opened by name reads from its
/// start: not a stream.)
pub fn is_stdin_stream(path: &Path) -> bool {
    let Ok(m) = fs::metadata(path) else {
        return false;
    };
    let Ok(s) = rustix::fs::fstat(std::io::stdin()) else {
        return false;
    };
    !m.is_file() && m.dev() == s.st_dev && m.ino() == s.st_ino
}

/// Does the input named `path` read standard input: `-`, or a name of
/// its stream ([`is_stdin_stream`])?
pub fn reads_stdin(path: &Path) -> bool {
    path.as_os_str() == "-" || is_stdin_stream(path)
}

/// Standard file descriptor `fd` was closed when lsgen started.
fn closed_at_start(fd: i32) -> bool {
    (0..3).contains(&fd) && CLOSED_AT_START.load(Ordering::Relaxed) & (1 << fd) != 0
}

/// The error for writing to a closed standard output.
pub fn check_stdout_open() -> Result<(), Error> {
    if closed_at_start(1) {
        return Err(fail(
            "standard output",
            IoAction::Write,
            IoReason::ClosedAtStartup,
        ));
    }
    Ok(())
}

/// The error for reading a closed standard input (`<&-`), which would
/// otherwise read as empty.
pub fn check_stdin_open() -> Result<(), Error> {
    if closed_at_start(0) {
        return Err(fail(
            "standard input",
            IoAction::Read,
            IoReason::ClosedWhenStarted,
        ));
    }
    Ok(())
}

/// The error for reading `path` (named `name`) when it leads to one of
/// this process's standard descriptors that was closed when it started
/// (`/dev/stdin`, `/dev/fd/0`, `/proc/self/fd/0`, a link to one): that
/// descriptor holds /dev/null since ([`note_closed_standard_fds`]), and
/// would read as empty, as `-` would without [`check_stdin_open`]. Its
/// symbolic links are followed only when a descriptor was closed.
pub fn check_input_open(path: &Path, name: &str) -> Result<(), Error> {
    if leads_to_closed_fd(path) {
        return Err(fail(name, IoAction::Read, IoReason::ClosedWhenStarted));
    }
    Ok(())
}

/// Does `path` lead to a standard descriptor closed at start (see
/// [`check_input_open`])?
pub(crate) fn leads_to_closed_fd(path: &Path) -> bool {
    if CLOSED_AT_START.load(Ordering::Relaxed) == 0 {
        return false;
    }
    let mut p = path.to_path_buf();
    for _ in 0..MAX_LINKS {
        if let Some((true, fd)) = proc_fd(&p) {
            return closed_at_start(fd);
        }
        match fs::symlink_metadata(&p) {
            Ok(m) if m.file_type().is_symlink() => {
                let Ok(to) = fs::read_link(&p) else {
                    return false;
                };
                p = link_target(&p, to);
            }
            // Not a link (or not there): opening it says what it is.
            _ => return false,
        }
    }
    false
}

/// An error about `-o NAME` with a reason of our own.
fn fail(name: &str, action: IoAction, reason: IoReason) -> Error {
    Error::about(name, IoError { action, reason })
}

/// Where `-o` leads, its symbolic links followed.
enum Target {
    /// One of lsgen's own file descriptors (`/dev/stdout`, `/dev/fd/N`,
    /// `/proc/self/fd/N`).
    Fd(i32),
    /// An existing file that is not a regular file, or another process's
    /// descriptor under /proc: opened and written in place.
    Stream(PathBuf),
    /// A regular file, existing or not: replaced atomically.
    File(PathBuf),
}

/// Symbolic links followed before giving up (Linux's own limit).
const MAX_LINKS: usize = 40;

/// Follow `path`'s symbolic links (the last component's; the kernel follows
/// those in the directories) to what `-o` writes.
fn resolve(path: &Path, name: &str) -> Result<Target, Error> {
    let mut p = path.to_path_buf();
    for _ in 0..MAX_LINKS {
        check_not_a_directory_name(&p, name)?;
        // /proc's fd links are not real paths (`pipe:[123]`, a deleted
        // file, another mount namespace): write to the descriptor.
        match proc_fd(&p) {
            Some((true, fd)) => return Ok(Target::Fd(fd)),
            Some((false, _)) => return Ok(Target::Stream(p)),
            None => {}
        }
        match fs::symlink_metadata(&p) {
            Ok(m) if m.file_type().is_symlink() => {
                let to = fs::read_link(&p)
                    .map_err(|e| Error::io(name, crate::diag::IoAction::ReadLink, e))?;
                p = link_target(&p, to);
            }
            Ok(m) if m.is_dir() => return Err(fail(name, IoAction::Write, IoReason::IsADirectory)),
            Ok(m) if !m.is_file() => return Ok(Target::Stream(p)),
            Ok(_) => return Ok(Target::File(p)),
            Err(e) if e.kind() == io::ErrorKind::NotFound => return Ok(Target::File(p)),
            Err(e) => {
                return Err(Error::io(
                    name,
                    crate::diag::IoAction::CreateIn(parent_dir(&p).to_path_buf()),
                    e,
                ))
            }
        }
    }
    Err(Error::io(
        name,
        crate::diag::IoAction::Write,
        io::Error::from_raw_os_error(libc::ELOOP),
    ))
}

/// The file `-o path` replaces, as batches tell their outputs apart: the
/// (device, inode) of its directory and its name there, symbolic links
/// followed as [`Output::file`] follows them (`a/../x` and `b/../x`, a
/// linked directory, a name linked to another are one file). A stream is
/// the (device, inode) of what it writes to, and an empty name: two jobs
/// writing to one FIFO, socket or pipe (two names of `/dev/stdout`), or to
/// a file through lsgen's own descriptor, would mix their text; a
/// character device (`/dev/null`) is `None`, as are standard output and a
/// name that cannot be written (its job fails on its own). `dirs`
/// remembers the last directory looked up.
pub fn replaced_file(
    path: &Path,
    dirs: &mut Option<(PathBuf, Option<(u64, u64)>)>,
) -> Option<(u64, u64, std::ffi::OsString)> {
    if path.as_os_str() == "-" {
        return None;
    }
    let p = match resolve(path, "") {
        Ok(Target::File(p)) => p,
        Ok(Target::Fd(_) | Target::Stream(_)) => {
            let m = fs::metadata(path).ok()?;
            return (!m.file_type().is_char_device())
                .then(|| (m.dev(), m.ino(), std::ffi::OsString::new()));
        }
        Err(_) => return None,
    };
    let name = p.file_name()?.to_os_string();
    let dir = parent_dir(&p);
    let id = match dirs {
        Some((d, id)) if d.as_path() == dir => *id,
        _ => {
            let id = fs::metadata(dir)
                .ok()
                .filter(|m| m.is_dir())
                .map(|m| (m.dev(), m.ino()));
            *dirs = Some((dir.to_path_buf(), id));
            id
        }
    };
    id.map(|(dev, ino)| (dev, ino, name))
}

/// Where the symbolic link `link`, which holds `to`, leads: a relative
/// target is relative to the link's directory.
fn link_target(link: &Path, to: PathBuf) -> PathBuf {
    match link.parent() {
        Some(d) => d.join(to),
        None => to,
    }
}

/// `-o dir/` (or `.`, `..`): a name that can only be a directory.
fn check_not_a_directory_name(p: &Path, name: &str) -> Result<(), Error> {
    let b = p.as_os_str().as_bytes();
    let dir_like =
        b.ends_with(b"/") || b == b"." || b == b".." || b.ends_with(b"/.") || b.ends_with(b"/..");
    if !dir_like {
        return Ok(());
    }
    Err(fail(
        name,
        IoAction::Write,
        match fs::metadata(p) {
            Ok(m) if m.is_dir() => IoReason::IsADirectory,
            Ok(_) => IoReason::NotADirectory,
            // `file/`: the kernel says so rather than "no such file".
            Err(e) if e.raw_os_error() == Some(libc::ENOTDIR) => IoReason::NotADirectory,
            Err(_) => IoReason::NoSuchDirectory,
        },
    ))
}

/// `p` is `/proc/PID/fd/N` (or `/proc/PID/task/TID/fd/N`, reached through
/// `/dev/fd`, `/proc/self`, ...): whether PID is this process, and N.
fn proc_fd(p: &Path) -> Option<(bool, i32)> {
    let fd: u32 = p.file_name()?.to_str()?.parse().ok()?;
    let fd = i32::try_from(fd).ok()?;
    let dir = fs::canonicalize(parent_dir(p)).ok()?;
    let parts: Vec<&[u8]> = dir.iter().map(|c| c.as_bytes()).collect();
    let numeric = |s: &[u8]| !s.is_empty() && s.iter().all(u8::is_ascii_digit);
    let pid = match parts.as_slice() {
        [b"/", b"proc", pid, b"fd"] if numeric(pid) => *pid,
        [b"/", b"proc", pid, b"task", tid, b"fd"] if numeric(pid) && numeric(tid) => *pid,
        _ => return None,
    };
    let me = fs::read_link("/proc/self").ok()?;
    Some((me.as_os_str().as_bytes() == pid, fd))
}

/// The directory a path's last component is in (`.` for a bare name).
fn parent_dir(p: &Path) -> &Path {
    match p.parent() {
        Some(d) if !d.as_os_str().is_empty() => d,
        _ => Path::new("."),
    }
}

/// A new descriptor for this process's open file `fd`, sharing its offset.
fn dup_fd(fd: i32) -> io::Result<File> {
    use std::os::fd::FromRawFd;
    if closed_at_start(fd) {
        return Err(io::Error::from_raw_os_error(libc::EBADF));
    }
    // SAFETY: F_DUPFD_CLOEXEC returns a new descriptor we then own.
    let new = unsafe { libc::fcntl(fd, libc::F_DUPFD_CLOEXEC, 0) };
    if new < 0 {
        return Err(io::Error::last_os_error());
    }
    // SAFETY: `new` is open and owned by nothing else.
    Ok(unsafe { File::from_raw_fd(new) })
}

impl Output {
    pub fn stdout() -> Result<Output, Error> {
        check_stdout_open()?;
        use std::os::fd::FromRawFd;
        // Anything written through std's stdout so far reaches the
        // descriptor first.
        let _ = io::stdout().flush();
        // SAFETY: nothing in lsgen closes descriptor 1 (closed at start,
        // it is /dev/null and we stopped above); the File is never
        // dropped, so it never closes it either.
        Ok(Output::Stdout(ManuallyDrop::new(unsafe {
            File::from_raw_fd(1)
        })))
    }

    /// `-o PATH`: `-` is standard output.
    pub fn file(path: &Path) -> Result<Output, Error> {
        if path.as_os_str() == "-" {
            return Output::stdout();
        }
        let name = path.display().to_string();
        let p = match resolve(path, &name)? {
            Target::Fd(fd) => {
                if fd == 1 {
                    check_stdout_open()?;
                }
                let f =
                    dup_fd(fd).map_err(|e| Error::io(&name, crate::diag::IoAction::Write, e))?;
                return Ok(Output::Direct(f, name));
            }
            Target::Stream(p) => {
                let f = fs::OpenOptions::new()
                    .write(true)
                    .open(&p)
                    .map_err(|e| Error::io(&name, crate::diag::IoAction::Write, e))?;
                // Another process's regular file: start it afresh, as `>`.
                if f.metadata().is_ok_and(|m| m.is_file()) {
                    f.set_len(0)
                        .map_err(|e| Error::io(&name, crate::diag::IoAction::Write, e))?;
                }
                return Ok(Output::Direct(f, name));
            }
            Target::File(p) => p,
        };
        // A file `>` could not write is not replaced either (the rename
        // would do it, as the directory allows): refused, as the shell does.
        // (A file not there yet is ENOENT: nothing to refuse.)
        use rustix::fs::{accessat, Access, AtFlags, CWD};
        if let Err(rustix::io::Errno::ACCESS) =
            accessat(CWD, &p, Access::WRITE_OK, AtFlags::EACCESS)
        {
            let e = std::io::Error::from_raw_os_error(rustix::io::Errno::ACCESS.raw_os_error());
            return Err(Error::io(&name, crate::diag::IoAction::Write, e));
        }
        let old = fs::metadata(&p).ok();
        let mode = match &old {
            Some(m) => m.mode() & 0o7777,
            None => 0o666 & !umask(),
        };
        let dir = parent_dir(&p).to_path_buf();
        // In a sticky directory (`/tmp`) only the file's owner, the
        // directory's or root may replace it (rename(2): EPERM), though
        // `>` could write it: refused now, before the derivation, saying
        // why (the rename at the end would say "Operation not permitted").
        if let (Some(f), Ok(d)) = (&old, fs::metadata(&dir)) {
            // SAFETY: geteuid cannot fail.
            let uid = unsafe { libc::geteuid() };
            if d.mode() & 0o1000 != 0 && uid != 0 && f.uid() != uid && d.uid() != uid {
                let e = std::io::Error::new(
                    std::io::ErrorKind::PermissionDenied,
                    "another user's file in a sticky directory, which lsgen cannot \
                     replace (it writes a new file and renames it over the old one); \
                     write to standard output and redirect it with `>`",
                );
                return Err(Error::io(&name, crate::diag::IoAction::Write, e));
            }
        }
        remove_leftovers(&dir);
        // O_TMPFILE on Linux: the file has no name until it is complete.
        let file = tempfile::tempfile_in(&dir)
            .map_err(|e| Error::io(&name, crate::diag::IoAction::CreateIn(dir.to_path_buf()), e))?;
        Ok(Output::Atomic {
            file: WriteBehind::new(file),
            path: p,
            dir,
            mode,
            name,
        })
    }

    /// The regular file this output will replace, its symbolic links
    /// followed; `None` for a stream (standard output, a device, a FIFO).
    pub fn file_path(&self) -> Option<&Path> {
        match self {
            Output::Atomic { path, .. } => Some(path),
            _ => None,
        }
    }

    pub fn name(&self) -> String {
        match self {
            Output::Stdout(_) => "standard output".into(),
            Output::Atomic { name, .. } | Output::Direct(_, name) => name.clone(),
        }
    }

    /// Free bytes for an unprivileged writer on a regular file's file
    /// system (statvfs); None for streams and standard output. The hidden
    /// environment variable LSGEN_TEST_FREE_BYTES stands in for statvfs in
    /// tests.
    pub fn free_space(&self) -> Option<u64> {
        let Output::Atomic { file, .. } = self else {
            return None;
        };
        if let Some(v) = std::env::var_os("LSGEN_TEST_FREE_BYTES") {
            return v.to_str().and_then(|s| s.parse().ok());
        }
        let st = rustix::fs::fstatvfs(&file.file).ok()?;
        Some(st.f_bavail.saturating_mul(st.f_frsize))
    }

    /// A regular file's switch for writing around the page cache while
    /// the text comes from several threads ([`WriteBehind`]), for
    /// [`crate::Options::direct_output`]; None for streams.
    pub fn direct_switch(&self) -> Option<std::sync::Arc<std::sync::atomic::AtomicU8>> {
        match self {
            Output::Atomic { file, .. } => Some(file.want.clone()),
            _ => None,
        }
    }

    pub fn writer(&mut self) -> &mut dyn Write {
        match self {
            Output::Stdout(s) => &mut **s,
            Output::Atomic { file, .. } => file,
            Output::Direct(file, _) => file,
        }
    }

    /// Put a complete file in place. Not calling this discards the output.
    pub fn commit(self) -> Result<(), Error> {
        let Output::Atomic {
            file,
            path,
            dir,
            mode,
            name,
        } = self
        else {
            return Ok(());
        };
        let mut file = file;
        // (Out::finish flushed it; a stage left by anything else is written.)
        file.flush()
            .map_err(|e| Error::io(&name, crate::diag::IoAction::Write, e))?;
        file.behind = None;
        let file = file.file;
        file.set_permissions(fs::Permissions::from_mode(mode))
            .and_then(|_| file.sync_all())
            .map_err(|e| Error::io(&name, crate::diag::IoAction::Write, e))?;
        // Ctrl-C (or SIGTERM) while the file gets its name would leave a
        // named temp file behind: hold such signals until it is in place,
        // and its directory synced or noted for the batch's end.
        with_signals_held(|| {
            let _naming = NAMING.read().unwrap_or_else(|e| e.into_inner());
            let result = Self::put_in_place(file, &dir, &path, &name);
            // Make the rename durable (at a batch's end: DeferDirSync).
            if result.is_ok() {
                sync_dir_now_or_later(&dir);
            }
            result
        })
    }

    fn put_in_place(file: File, dir: &Path, path: &Path, name: &str) -> Result<(), Error> {
        match link_into_place(&file, dir, path) {
            Ok(()) => Ok(()),
            // No O_TMPFILE here (tempfile fell back to a deleted named file,
            // which cannot be linked again): copy into a named temp file.
            Err(e) if e.raw_os_error() == Some(libc::ENOENT) => copy_into_place(file, dir, path)
                .map_err(|e| Error::io(name, crate::diag::IoAction::Write, e)),
            Err(e) => Err(Error::io(name, crate::diag::IoAction::Write, e)),
        }
    }
}

// Named temp files beside the output: `.lsgen-PID-START-NANOS-K.tmp`, PID
// and START (its start time in clock ticks since boot, /proc/PID/stat field
// 22) naming the run that made it. A run that is killed (SIGKILL) while one
// exists leaves it; later runs writing into that directory remove those
// whose process no longer runs (see `remove_leftovers`).

const TEMP_PREFIX: &str = ".lsgen-";
const TEMP_SUFFIX: &str = ".tmp";

/// Start time of process `pid` (field 22 of /proc/PID/stat); None if no
/// such process, Err if that cannot be told.
fn process_start(pid: u32) -> io::Result<Option<u64>> {
    use rustix::fs::{open, Mode, OFlags};
    use rustix::io::Errno;
    // Reads into one buffer of fixed capacity (the line is well under
    // 1 KiB), not `fs::read` (a metadata call, a growing buffer): an -o
    // run that replaces a file reads its own.
    let unreadable = || io::Error::other("unreadable /proc stat");
    let fd = match open(
        format!("/proc/{pid}/stat").as_str(),
        OFlags::RDONLY | OFlags::CLOEXEC,
        Mode::empty(),
    ) {
        Ok(fd) => fd,
        Err(e) if e == Errno::NOENT => return Ok(None),
        Err(e) => return Err(e.into()),
    };
    let mut stat = Vec::with_capacity(4096);
    loop {
        match rustix::io::read(&fd, rustix::buffer::spare_capacity(&mut stat)) {
            Ok(0) => break,
            Ok(_) => {}
            Err(e) if e == Errno::INTR => continue,
            Err(e) => return Err(e.into()),
        }
        if stat.len() == stat.capacity() {
            return Err(unreadable());
        }
    }
    // The command name (field 2) is in parentheses and may hold anything.
    let after = stat
        .iter()
        .rposition(|&b| b == b')')
        .map(|i| &stat[i + 1..])
        .ok_or_else(unreadable)?;
    std::str::from_utf8(after)
        .ok()
        .and_then(|s| s.split_ascii_whitespace().nth(22 - 3))
        .and_then(|s| s.parse().ok())
        .map(Some)
        .ok_or_else(unreadable)
}

/// This process's start time (`process_start` of its own PID), read from
/// /proc at most once per run and only when needed: a run whose directory
/// holds no `.lsgen-` names and whose output is new never reads it.
fn own_start() -> Option<u64> {
    static START: std::sync::OnceLock<Option<u64>> = std::sync::OnceLock::new();
    *START.get_or_init(|| process_start(std::process::id()).ok().flatten())
}

/// This process's temp file name for attempt `k`.
fn temp_name(k: u32) -> String {
    let pid = std::process::id();
    let start = own_start().unwrap_or(0);
    let nanos = std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map_or(0, |d| d.subsec_nanos());
    format!("{TEMP_PREFIX}{pid}-{start}-{nanos}-{k}{TEMP_SUFFIX}")
}

/// PID and START of a name made by `temp_name`.
fn parse_temp_name(name: &[u8]) -> Option<(u32, u64)> {
    let s = std::str::from_utf8(name).ok()?;
    let s = s.strip_prefix(TEMP_PREFIX)?.strip_suffix(TEMP_SUFFIX)?;
    let parts: Vec<&str> = s.split('-').collect();
    let [pid, start, nanos, k] = parts.as_slice() else {
        return None;
    };
    let digits = |x: &str| !x.is_empty() && x.bytes().all(|b| b.is_ascii_digit());
    if !(digits(nanos) && digits(k)) {
        return None;
    }
    Some((pid.parse().ok()?, start.parse().ok()?))
}

/// Remove the temp files of killed lsgen runs from `dir`: regular files of
/// ours named by `temp_name` whose process is gone (no such PID, or a PID
/// now used by a process started at another time). Nothing when /proc
/// cannot tell; errors are ignored. Once per directory and process (a
/// batch writing N files into one directory read it N times: 8,000
/// outputs beside 30,000 files took 44 s); the set of directories swept is
/// forgotten past [`SWEPT_MAX`] of them, so that it stays small.
/// Directories [`remove_leftovers`] remembers having swept, at most.
const SWEPT_MAX: usize = 4096;

fn remove_leftovers(dir: &Path) {
    static SWEPT: std::sync::Mutex<Option<std::collections::HashSet<PathBuf>>> =
        std::sync::Mutex::new(None);
    if let Ok(mut swept) = SWEPT.lock() {
        let swept = swept.get_or_insert_with(Default::default);
        if swept.len() >= SWEPT_MAX {
            swept.clear();
        }
        if !swept.insert(dir.to_path_buf()) {
            return;
        }
    }
    let Ok(entries) = fs::read_dir(dir) else {
        return;
    };
    for entry in entries.flatten() {
        let Some((pid, start)) = parse_temp_name(entry.file_name().as_bytes()) else {
            continue;
        };
        // Only once there is a candidate: can /proc tell at all?
        if own_start().is_none() {
            return;
        }
        match process_start(pid) {
            Ok(None) => {}
            Ok(Some(s)) if s != start => {}
            _ => continue,
        }
        let p = entry.path();
        // SAFETY: geteuid cannot fail.
        let uid = unsafe { libc::geteuid() };
        if fs::symlink_metadata(&p).is_ok_and(|m| m.is_file() && m.uid() == uid) {
            let _ = fs::remove_file(&p);
        }
    }
}

/// Give the unnamed file its name (linkat through /proc/self/fd): straight
/// away when `path` does not exist yet, else under a temporary name in
/// `dir` that is then renamed over `path` atomically.
fn link_into_place(file: &File, dir: &Path, path: &Path) -> io::Result<()> {
    use rustix::fs::{linkat, AtFlags, CWD};
    use rustix::io::Errno;
    use std::os::fd::AsRawFd;
    let proc_path = format!("/proc/self/fd/{}", file.as_raw_fd());
    match linkat(CWD, proc_path.as_str(), CWD, path, AtFlags::SYMLINK_FOLLOW) {
        Ok(()) => return Ok(()),
        Err(e) if e == Errno::EXIST => {}
        Err(e) => return Err(e.into()),
    }
    // A kill -9 between linkat and rename leaves the temp name behind, for
    // a later run to remove.
    for attempt in 0..100u32 {
        let tmp = dir.join(temp_name(attempt));
        match linkat(CWD, proc_path.as_str(), CWD, &tmp, AtFlags::SYMLINK_FOLLOW) {
            Ok(()) => {
                return fs::rename(&tmp, path).inspect_err(|_| {
                    let _ = fs::remove_file(&tmp);
                });
            }
            Err(e) if e == Errno::EXIST => continue,
            Err(e) => return Err(e.into()),
        }
    }
    Err(io::Error::from(io::ErrorKind::AlreadyExists))
}

/// The process umask, read from /proc (022 if it cannot be read).
fn umask() -> u32 {
    fs::read_to_string("/proc/self/status")
        .ok()
        .and_then(|s| {
            s.lines()
                .find_map(|l| l.strip_prefix("Umask:"))
                .and_then(|v| u32::from_str_radix(v.trim(), 8).ok())
        })
        .unwrap_or(0o022)
}

/// Copy the complete output into a named temp file in `dir` and rename it
/// over `path`. A kill -9 during the copy leaves the temp file behind, for
/// a later run to remove.
fn copy_into_place(mut file: File, dir: &Path, path: &Path) -> io::Result<()> {
    use std::io::{Seek, SeekFrom};
    let (tmp, mut out) = (|| {
        for attempt in 0..100u32 {
            let tmp = dir.join(temp_name(attempt));
            match fs::OpenOptions::new()
                .write(true)
                .create_new(true)
                .mode(0o600)
                .open(&tmp)
            {
                Ok(f) => return Ok((tmp, f)),
                Err(e) if e.kind() == io::ErrorKind::AlreadyExists => continue,
                Err(e) => return Err(e),
            }
        }
        Err(io::Error::from(io::ErrorKind::AlreadyExists))
    })()?;
    let r = (|| {
        file.seek(SeekFrom::Start(0))?;
        io::copy(&mut file, &mut out)?;
        out.set_permissions(file.metadata()?.permissions())?;
        out.sync_all()?;
        fs::rename(&tmp, path)
    })();
    if r.is_err() {
        let _ = fs::remove_file(&tmp);
    }
    r
}

/// The signals that end a run from outside (SIGKILL aside).
const TERMINATION: [libc::c_int; 4] = [libc::SIGINT, libc::SIGTERM, libc::SIGHUP, libc::SIGQUIT];

/// [`TERMINATION`] as a set.
fn termination_signals() -> libc::sigset_t {
    // SAFETY: sigemptyset/sigaddset only write the set we own.
    unsafe {
        let mut set: libc::sigset_t = std::mem::zeroed();
        libc::sigemptyset(&mut set);
        for s in TERMINATION {
            libc::sigaddset(&mut set, s);
        }
        set
    }
}

/// Run `f` with termination signals held for this thread; one that arrives
/// meanwhile takes effect when `f` is done (or reaches another thread that
/// does not hold it).
pub(crate) fn with_signals_held<T>(f: impl FnOnce() -> T) -> T {
    let set = termination_signals();
    // SAFETY: pthread_sigmask changes this thread's mask only; the old mask
    // is restored below.
    let mut old: libc::sigset_t = unsafe { std::mem::zeroed() };
    unsafe { libc::pthread_sigmask(libc::SIG_BLOCK, &set, &mut old) };
    let r = f();
    unsafe { libc::pthread_sigmask(libc::SIG_SETMASK, &old, std::ptr::null_mut()) };
    r
}

/// Held (shared) while a file gets its name and its directory is synced or
/// noted; taken for good by a batch's signal thread
/// ([`signals_to_a_thread_of_their_own`]) before it ends the run.
static NAMING: std::sync::RwLock<()> = std::sync::RwLock::new(());

/// From now on termination signals (Ctrl-C, SIGTERM, SIGHUP, SIGQUIT) are
/// taken by a thread of their own, for a batch: this thread holds them,
/// and so do the threads it starts after (they inherit its mask). The
/// signal thread waits for one, lets a file that is getting its name
/// finish (no other starts), syncs the directories noted so far
/// ([`DeferDirSync`]) and ends the run by the signal, as it would have
/// ended. A job's thread cannot hold the signals for itself alone: one
/// sent to the process goes to any thread that does not hold it, whose
/// default action ended the run there, between another job's two steps
/// of naming its file (its temporary name was left behind), and before
/// the directories were synced. Once per process; where no thread can be
/// started, the signals are left as they were.
#[cfg_attr(not(feature = "cli"), allow(dead_code))]
pub(crate) fn signals_to_a_thread_of_their_own() {
    static STARTED: std::sync::Once = std::sync::Once::new();
    STARTED.call_once(|| {
        // Not those the run was started with ignored (`nohup`, `&` in a
        // script): held, they would reach the thread, not be dropped.
        let mut set = termination_signals();
        let mut any = false;
        for s in TERMINATION {
            // SAFETY: sigaction with no new action only reads the current
            // one; sigdelset writes the set we own.
            unsafe {
                let mut now: libc::sigaction = std::mem::zeroed();
                if libc::sigaction(s, std::ptr::null(), &mut now) == 0
                    && now.sa_sigaction == libc::SIG_IGN
                {
                    libc::sigdelset(&mut set, s);
                } else {
                    any = true;
                }
            }
        }
        if !any {
            return;
        }
        let mut old: libc::sigset_t = unsafe { std::mem::zeroed() };
        // SAFETY: changes this thread's signal mask only (restored below if
        // no thread takes the signals).
        unsafe { libc::pthread_sigmask(libc::SIG_BLOCK, &set, &mut old) };
        let builder = std::thread::Builder::new()
            .name("lsgen-signals".into())
            .stack_size(64 << 10);
        let waiter = crate::spawn::spawn(builder, move || {
            let mut sig: libc::c_int = 0;
            // SAFETY: sigwait reads the set (held by every thread) and
            // writes `sig`.
            while unsafe { libc::sigwait(&set, &mut sig) } != 0 {}
            let _no_more_names = NAMING.write().unwrap_or_else(|e| e.into_inner());
            let dirs = DEFERRED_DIRS.lock().ok().and_then(|mut d| d.take());
            for dir in dirs.into_iter().flatten() {
                sync_dir(&dir);
            }
            // SAFETY: the default action again, and the signal let
            // through to this thread alone, which raises it: the run
            // ends as the signal would have ended it.
            unsafe {
                libc::signal(sig, libc::SIG_DFL);
                libc::pthread_sigmask(libc::SIG_UNBLOCK, &set, std::ptr::null_mut());
                libc::raise(sig);
            }
            std::process::exit(128 + sig)
        });
        if waiter.is_err() {
            // SAFETY: restores this thread's mask.
            unsafe { libc::pthread_sigmask(libc::SIG_SETMASK, &old, std::ptr::null_mut()) };
        }
    });
}

/// Let termination signals reach only the other threads (the worker): the
/// main thread, which only waits, must not take them while the worker
/// holds them.
pub fn leave_termination_signals_to_other_threads() {
    let set = termination_signals();
    // SAFETY: changes this thread's signal mask only.
    unsafe { libc::pthread_sigmask(libc::SIG_BLOCK, &set, std::ptr::null_mut()) };
}

/// How `-o`'s file takes the final text: the values of the switch
/// ([`Output::direct_switch`]) that turns writing around the page cache on.
pub mod around_cache {
    /// Through the page cache.
    pub const OFF: u8 = 0;
    /// Around it, written by the thread that writes the text (the split's
    /// writer, a thread of its own that would otherwise wait for text).
    pub const HERE: u8 = 1;
    /// Around it, full buffers written by a thread of the output's own
    /// while the caller goes on (one thread deriving).
    pub const BEHIND: u8 = 2;
}

/// The new file of `-o`, asking the kernel to start writing each 32 MiB
/// to disk as soon as it is complete (`sync_file_range`, which does not
/// wait). Without it a file smaller than the kernel's dirty limits waits in
/// the page cache until `commit`'s `fsync`, which then writes all of it
/// while nothing else runs: about 0.6 s for 1.4 GB here, a serial tail that
/// no thread count shortens.
///
/// While the derivation writes its final text ([`want`] set by the derive
/// code around the passes that make text slower than a disk takes it:
/// parametric and step-by-step passes, the split's writer), the text past
/// the file's first 4 MiB (`DIRECT_AFTER`) goes to disk directly
/// (`O_DIRECT`, through aligned `Stage`s) instead of through the page
/// cache: the kernel's copy of every byte into the cache costs CPU time
/// the derivation needs (parametric_tree 10^8: `-j 2` 1.76 s → 1.58 s;
/// `-j 1` 0.41 s of system time). On one thread
/// ([`around_cache::BEHIND`]) full stages are written by a thread of their
/// own (`Behind`), which only waits for the disk, while the caller fills
/// the next one; the split's writer, a thread of its own that would wait
/// for text anyway, writes them itself ([`around_cache::HERE`]: one stage,
/// not two and a thread, keeps `-j 2` under 16 MiB). D0L expansion, which
/// makes text faster than this disk takes direct writes, keeps the page
/// cache, as does a file system that refuses `O_DIRECT`.
///
/// [`want`]: Output::direct_switch
pub struct WriteBehind {
    file: File,
    written: u64,
    started: u64,
    want: std::sync::Arc<std::sync::atomic::AtomicU8>,
    /// Writing with `O_DIRECT`: the bytes not yet written.
    stage: Option<Stage>,
    /// `O_DIRECT` was refused: never asked for again.
    refused: bool,
    /// The thread writing full stages, once one was full.
    behind: Option<Behind>,
    /// `DIRECT_AFTER` (0 in unit tests).
    direct_after: u64,
}

impl WriteBehind {
    const STEP: u64 = 32 << 20;
    /// The first bytes of a file go through the page cache: a small file
    /// (a frame, one of a forest of seeds) would only wait for the disk.
    const DIRECT_AFTER: u64 = 4 << 20;

    fn new(file: File) -> Self {
        WriteBehind {
            file,
            written: 0,
            started: 0,
            want: Default::default(),
            stage: None,
            refused: false,
            behind: None,
            direct_after: Self::DIRECT_AFTER,
        }
    }

    /// Ask the kernel to start writing what is complete of each `STEP`.
    fn write_behind(&mut self) {
        if self.written - self.started >= Self::STEP {
            use std::os::fd::AsRawFd;
            // SAFETY: a plain system call on our own open descriptor. A
            // failure only means the data waits for `fsync`, as before.
            unsafe {
                libc::sync_file_range(
                    self.file.as_raw_fd(),
                    self.started as libc::off64_t,
                    (self.written - self.started) as libc::off64_t,
                    libc::SYNC_FILE_RANGE_WRITE,
                );
            }
            self.started = self.written;
        }
    }

    /// Turn `O_DIRECT` on or off; false if the file system refuses it.
    fn set_direct(&self, on: bool) -> bool {
        set_direct(&self.file, on)
    }

    /// Write the stage's whole units directly, here (the rest stays
    /// staged).
    fn write_staged(&mut self) -> io::Result<()> {
        if let Some(stage) = &mut self.stage {
            self.refused |= write_units(&self.file, stage)?;
        }
        Ok(())
    }

    /// The stage is full: the writing thread takes it (started the first
    /// time; without it the stage is written here) and an empty one takes
    /// its place.
    fn hand_over(&mut self) -> io::Result<()> {
        if self.want.load(Ordering::Relaxed) != around_cache::BEHIND {
            if let Some(behind) = &mut self.behind {
                self.refused |= behind.drain()?;
            }
            return self.write_staged();
        }
        if self.behind.is_none() {
            self.behind = Behind::start(&self.file);
        }
        match (&mut self.behind, self.stage.take()) {
            (Some(behind), Some(full)) => {
                let (empty, refused) = behind.exchange(full)?;
                self.refused |= refused;
                self.stage = Some(empty);
                Ok(())
            }
            (_, stage) => {
                self.stage = stage;
                self.write_staged()
            }
        }
    }

    /// Back to the page cache: what the thread has is written, then what
    /// is staged (its whole units directly, the rest through the cache).
    fn leave_direct(&mut self) -> io::Result<()> {
        if let Some(behind) = &mut self.behind {
            self.refused |= behind.drain()?;
        }
        if !self.refused {
            self.write_staged()?;
        }
        if let Some(stage) = self.stage.take() {
            self.set_direct(false);
            self.file.write_all(stage.bytes())?;
        }
        Ok(())
    }
}

impl Write for WriteBehind {
    fn write(&mut self, buf: &[u8]) -> io::Result<usize> {
        let want = self.want.load(Ordering::Relaxed) != around_cache::OFF
            && !self.refused
            && self.written >= self.direct_after;
        if want != self.stage.is_some() {
            if !want {
                self.leave_direct()?;
            } else if self.written % Stage::UNIT as u64 != 0 {
                // Direct writes start at a whole unit of the file: up to
                // there through the page cache.
                let to = Stage::UNIT - (self.written % Stage::UNIT as u64) as usize;
                let n = self.file.write(&buf[..to.min(buf.len())])?;
                self.written += n as u64;
                return Ok(n);
            } else if self.set_direct(true) {
                self.stage = Some(Stage::new());
            } else {
                self.refused = true;
            }
        }
        let n = match &mut self.stage {
            Some(stage) => {
                let n = stage.put(buf);
                if stage.is_full() {
                    self.hand_over()?;
                }
                n
            }
            None => self.file.write(buf)?,
        };
        self.written += n as u64;
        self.write_behind();
        Ok(n)
    }

    fn flush(&mut self) -> io::Result<()> {
        self.leave_direct()?;
        self.file.flush()
    }
}

/// Write a stage's whole units to a file in `O_DIRECT` mode, dropping
/// what each write took from the stage at once. If the file system takes
/// the mode but refuses the write (`EINVAL`), the file leaves the mode and
/// the whole stage goes through the page cache: true. A short write
/// leaves the rest staged.
fn write_units(mut file: &File, stage: &mut Stage) -> io::Result<bool> {
    loop {
        let whole = stage.len / Stage::UNIT * Stage::UNIT;
        if whole == 0 {
            return Ok(false);
        }
        match file.write(&stage.bytes()[..whole]) {
            Ok(0) => return Err(io::ErrorKind::WriteZero.into()),
            Ok(n) => stage.consume(n),
            Err(e) if e.kind() == io::ErrorKind::Interrupted => {}
            Err(e) if e.raw_os_error() == Some(libc::EINVAL) => return through_cache(file, stage),
            Err(e) => return Err(e),
        }
    }
}

/// Leave `O_DIRECT` and write the rest of the stage through the page
/// cache; true (direct writes are over for this file).
fn through_cache(mut file: &File, stage: &mut Stage) -> io::Result<bool> {
    set_direct(file, false);
    file.write_all(stage.bytes())?;
    stage.consume(stage.len);
    Ok(true)
}

/// The thread that writes full stages to disk while the caller fills the
/// next one: it only waits for the disk. At most [`Behind::AHEAD`] stages
/// are out at a time, so the stages of a run hold at most
/// `(AHEAD + 1) × Stage::SIZE` bytes.
struct Behind {
    to: Option<std::sync::mpsc::Sender<Stage>>,
    back: std::sync::mpsc::Receiver<(Stage, io::Result<bool>)>,
    /// Stages sent and not yet back.
    out: usize,
    /// Stages back, empty.
    free: Vec<Stage>,
    thread: Option<std::thread::JoinHandle<()>>,
}

impl Behind {
    const AHEAD: usize = 1;

    /// None if no thread can be started (the caller writes itself).
    fn start(file: &File) -> Option<Behind> {
        // A duplicate shares the file's offset and its `O_DIRECT` flag;
        // while stages are out, only the thread writes.
        let file = file.try_clone().ok()?;
        let (to, stages) = std::sync::mpsc::channel::<Stage>();
        let (done, back) = std::sync::mpsc::channel();
        let builder = std::thread::Builder::new().name("lsgen-write".into());
        let thread = crate::spawn::spawn(builder, move || {
            for mut stage in stages {
                // A short write that left less than a unit puts the
                // file's end off the units: this rest and all that
                // follows go through the page cache.
                let r = write_units(&file, &mut stage).and_then(|refused| match stage.len {
                    0 => Ok(refused),
                    _ => through_cache(&file, &mut stage),
                });
                if done.send((stage, r)).is_err() {
                    break;
                }
            }
        })
        .ok()?;
        Some(Behind {
            to: Some(to),
            back,
            out: 0,
            free: Vec::new(),
            thread: Some(thread),
        })
    }

    /// Send a full stage; an empty one back, and whether the file system
    /// refused a direct write (its stage went through the page cache).
    fn exchange(&mut self, full: Stage) -> io::Result<(Stage, bool)> {
        let gone = || io::Error::other("the writing thread ended");
        self.to
            .as_ref()
            .ok_or_else(gone)?
            .send(full)
            .map_err(|_| gone())?;
        self.out += 1;
        let mut refused = false;
        while let Ok(r) = self.back.try_recv() {
            refused |= self.took(r)?;
        }
        while self.out > Self::AHEAD {
            let r = self.back.recv().map_err(|_| gone())?;
            refused |= self.took(r)?;
        }
        Ok((self.free.pop().unwrap_or_else(Stage::new), refused))
    }

    /// Wait until every stage is written.
    fn drain(&mut self) -> io::Result<bool> {
        let mut refused = false;
        while self.out > 0 {
            let r = self
                .back
                .recv()
                .map_err(|_| io::Error::other("the writing thread ended"))?;
            refused |= self.took(r)?;
        }
        Ok(refused)
    }

    fn took(&mut self, (mut stage, r): (Stage, io::Result<bool>)) -> io::Result<bool> {
        self.out -= 1;
        stage.len = 0;
        self.free.push(stage);
        r
    }
}

impl Drop for Behind {
    fn drop(&mut self) {
        // The thread ends when the channel closes, after what it has.
        self.to = None;
        if let Some(t) = self.thread.take() {
            let _ = t.join();
        }
    }
}

/// Turn `O_DIRECT` on or off for an open file (its open file description,
/// shared by its duplicates); false if the file system refuses it.
fn set_direct(file: &File, on: bool) -> bool {
    let fd = std::os::fd::AsRawFd::as_raw_fd(file);
    // SAFETY: fcntl's flag calls on our own open descriptor.
    unsafe {
        let flags = libc::fcntl(fd, libc::F_GETFL);
        if flags < 0 {
            return false;
        }
        let flags = if on {
            flags | libc::O_DIRECT
        } else {
            flags & !libc::O_DIRECT
        };
        libc::fcntl(fd, libc::F_SETFL, flags) == 0
    }
}

/// Bytes on their way to an `O_DIRECT` file: a buffer whose address and
/// length are whole units, as the kernel requires of such writes.
struct Stage {
    ptr: std::ptr::NonNull<u8>,
    len: usize,
}

impl Stage {
    /// The unit of direct I/O (a page: every logical block size divides
    /// it).
    const UNIT: usize = 4096;
    const SIZE: usize = 1 << 20;

    fn layout() -> std::alloc::Layout {
        std::alloc::Layout::from_size_align(Self::SIZE, Self::UNIT).expect("a valid layout")
    }

    fn new() -> Stage {
        // SAFETY: the layout has a non-zero size.
        let p = unsafe { std::alloc::alloc(Self::layout()) };
        let Some(ptr) = std::ptr::NonNull::new(p) else {
            std::alloc::handle_alloc_error(Self::layout());
        };
        Stage { ptr, len: 0 }
    }

    /// Copy what fits of `buf` after the staged bytes; how much did.
    fn put(&mut self, buf: &[u8]) -> usize {
        let n = buf.len().min(Self::SIZE - self.len);
        // SAFETY: `len + n <= SIZE` bytes of the allocation; `buf` is not
        // in it (the stage is ours alone).
        unsafe {
            std::ptr::copy_nonoverlapping(buf.as_ptr(), self.ptr.as_ptr().add(self.len), n);
        }
        self.len += n;
        n
    }

    fn is_full(&self) -> bool {
        self.len == Self::SIZE
    }

    fn bytes(&self) -> &[u8] {
        // SAFETY: the first `len` bytes were written by `put`.
        unsafe { std::slice::from_raw_parts(self.ptr.as_ptr(), self.len) }
    }

    /// Drop the first `n` staged bytes (written), keeping the rest.
    fn consume(&mut self, n: usize) {
        let p = self.ptr.as_ptr();
        // SAFETY: `n <= len`; the ranges may overlap (`copy`).
        unsafe { std::ptr::copy(p.add(n), p, self.len - n) };
        self.len -= n;
    }
}

// SAFETY: a stage owns its allocation alone; it moves between the caller
// and the writing thread whole.
unsafe impl Send for Stage {}

impl Drop for Stage {
    fn drop(&mut self) {
        // SAFETY: allocated in `new` with this layout.
        unsafe { std::alloc::dealloc(self.ptr.as_ptr(), Self::layout()) };
    }
}

#[cfg(test)]
mod tests {
    use super::{Stage, WriteBehind};
    use std::io::{Read, Seek, SeekFrom, Write};
    use std::sync::atomic::Ordering;

    /// Under a `DeferDirSync`, files get their names and their directory
    /// waits in the set, once; its drop empties it, and then each commit
    /// syncs its own directory again (nothing waits).
    #[test]
    fn a_batch_syncs_each_directory_once_at_its_end() {
        use super::{DeferDirSync, Output, DEFERRED_DIRS};
        let dir = tempfile::tempdir().unwrap();
        let held = || {
            let d = DEFERRED_DIRS.lock().unwrap();
            d.as_ref().map(|s| {
                s.iter()
                    .filter(|p| p.ends_with(dir.path().file_name().unwrap()))
                    .count()
            })
        };
        let put = |name: &str| {
            let mut o = Output::file(&dir.path().join(name)).unwrap();
            o.writer().write_all(b"F\n").unwrap();
            o.commit().unwrap();
        };
        let guard = DeferDirSync::new();
        put("a.txt");
        put("b.txt");
        assert_eq!(held(), Some(1));
        drop(guard);
        assert_eq!(held(), None);
        put("c.txt");
        assert_eq!(held(), None);
        for n in ["a.txt", "b.txt", "c.txt"] {
            assert_eq!(std::fs::read(dir.path().join(n)).unwrap(), b"F\n");
        }
    }

    /// The file holds exactly what was written, in order, whatever the
    /// pieces and wherever the switch to writing around the page cache
    /// goes on and off (at unaligned offsets too, as frames written to
    /// one file before a split pass leave it); on a file system that
    /// refuses `O_DIRECT` the same, through the page cache.
    #[test]
    fn writing_around_the_page_cache_keeps_every_byte_in_order() {
        let mut expected = Vec::new();
        let mut wb = WriteBehind::new(tempfile::tempfile().unwrap());
        wb.direct_after = 0;
        let mut direct_seen = false;
        // Piece sizes and the switch, in a fixed pseudo-random pattern.
        let mut x: u64 = 12345;
        let mut next = |m: u64| {
            x = x
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            (x >> 33) % m
        };
        for round in 0..40u64 {
            // Off, written here, written by the thread, every change.
            let modes = [0u8, 1, 2, 1, 0, 2, 2, 0, 1];
            wb.want
                .store(modes[round as usize % modes.len()], Ordering::Relaxed);
            for _ in 0..next(12) {
                let len = match next(4) {
                    0 => next(10) as usize,
                    1 => next(5000) as usize,
                    2 => Stage::UNIT,
                    _ => next(3 * Stage::SIZE as u64) as usize,
                };
                let piece: Vec<u8> = (0..len).map(|i| (i as u64 * 31 + round) as u8).collect();
                wb.write_all(&piece).unwrap();
                expected.extend_from_slice(&piece);
                direct_seen |= wb.stage.is_some();
                if let Some(stage) = &wb.stage {
                    assert!(stage.len <= Stage::SIZE);
                    // Direct writes only ever start at a whole unit.
                    assert_eq!((wb.written - stage.len as u64) % Stage::UNIT as u64, 0);
                }
            }
            if round % 7 == 6 {
                wb.flush().unwrap();
                assert!(wb.stage.is_none());
            }
        }
        wb.flush().unwrap();
        assert!(direct_seen || wb.refused, "never wrote around the cache");
        // Full stages went to the writing thread.
        assert!(wb.refused || wb.behind.is_some(), "no writing thread");
        // Where the file system takes direct writes, none was refused (a
        // misaligned one would have been, and the rest gone through the
        // cache).
        assert!(
            !(takes_direct_writes() && wb.refused),
            "a direct write was refused"
        );
        let mut f = wb.file;
        f.seek(SeekFrom::Start(0)).unwrap();
        let mut got = Vec::new();
        f.read_to_end(&mut got).unwrap();
        assert_eq!(got.len(), expected.len());
        assert!(got == expected, "the file's bytes differ");
    }

    /// A write the writing thread fails (here: the file is open for
    /// reading only) is the caller's error, at a later write or the flush.
    #[test]
    fn an_error_of_the_writing_thread_reaches_the_caller() {
        let tmp = tempfile::NamedTempFile::new().unwrap();
        let file = std::fs::File::open(tmp.path()).unwrap();
        let mut wb = WriteBehind::new(file);
        wb.direct_after = 0;
        wb.want
            .store(super::around_cache::BEHIND, Ordering::Relaxed);
        let piece = vec![7u8; Stage::SIZE];
        let mut failed = false;
        for _ in 0..4 {
            failed |= wb.write_all(&piece).is_err();
        }
        failed |= wb.flush().is_err();
        assert!(failed, "a failed write went unreported");
    }

    /// Does the temporary directory's file system take an aligned direct
    /// write?
    fn takes_direct_writes() -> bool {
        let wb = WriteBehind::new(tempfile::tempfile().unwrap());
        let mut s = Stage::new();
        s.put(&[1u8; Stage::UNIT]);
        wb.set_direct(true) && (&wb.file).write_all(s.bytes()).is_ok()
    }

    /// Staged bytes: whole units go, the rest moves to the front.
    #[test]
    fn a_stage_keeps_what_is_not_written() {
        let mut s = Stage::new();
        let data: Vec<u8> = (0..Stage::UNIT + 10).map(|i| i as u8).collect();
        assert_eq!(s.put(&data), data.len());
        s.consume(Stage::UNIT);
        assert_eq!(s.bytes(), &data[Stage::UNIT..]);
        let big = vec![7u8; Stage::SIZE];
        assert_eq!(s.put(&big), Stage::SIZE - 10);
        assert!(s.is_full());
    }
}
