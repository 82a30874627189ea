//! Output files that appear whole or not at all, and never through a planted link.
//!
//! Every write goes to a temporary file created *exclusively* in the target's folder, then is
//! moved into place:
//! - **Linux**: an anonymous `O_TMPFILE`; it has no name until it is committed (linked), so
//!   nothing is left behind even by `SIGKILL` or a power cut.
//! - **Elsewhere**, or where the filesystem lacks `O_TMPFILE`: a new file with an unpredictable
//!   name (`.NAME.<random>.tmp`) created with `O_EXCL`, which never follows a symbolic link
//!   planted at that name. Such names are listed in a process-wide registry; the handler of
//!   [`install_signal_cleanup`] unlinks them on SIGINT, SIGTERM, SIGHUP and SIGQUIT before the
//!   signal takes its default effect. (`ISOFORGE_TEMP=named` forces this mode, for tests.)
//!
//! [`Batch`] commits several outputs of one command together: each output is checked and its
//! temporary file created before any work ([`Batch::reserve`]), written, and all are renamed
//! into place only when all were written ([`Batch::commit`]); a dropped batch leaves nothing.
//!
//! **No fsync by default.** A reader, or a process killed at any point, sees the old file or the
//! whole new one: that needs only the rename. Surviving a *power cut* with the new data needs the
//! data on disk before the rename (`fsync`), which cost 27–112 ms on 70–155 MB meshes
//! (bench/peers/results-2026-11-24-e2e.md §4c), as much as extracting them; VTK, gzip and cp do
//! not pay it either. `ISOFORGE_SYNC=1` syncs each file before its rename and the folders after.
//! Nor is ext4's `auto_da_alloc` heuristic triggered (it writes a file back when it is closed
//! after a truncation to zero, or renamed over an existing file: 0.1 s and 0.05–0.09 s for a
//! 150 MB mesh, a sixth of a whole extraction): fresh temporary files are never truncated, and an
//! existing target is swapped out (`RENAME_EXCHANGE`) and unlinked rather than renamed over. So a
//! power cut soon after a commit may leave an empty or partial target where the heuristic would
//! often have kept the old or the new file; `ISOFORGE_SYNC=1` (plain rename after `fsync`) is the
//! setting for that.

use std::ffi::CString;
use std::fs::File;
use std::io::{self, BufWriter, Seek, SeekFrom, Write};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, AtomicPtr, AtomicU64, Ordering};
use std::sync::Mutex;

use crate::error::{Error, Result};

/// Writes `path` through `f`: all of it, or nothing (on any error `path` is untouched and no
/// temporary file remains).
///
/// # Errors
/// As [`Batch::reserve`] for the path; [`Error::Io`] naming `path` when writing or renaming
/// fails; whatever `f` returns.
pub fn write_atomic(path: &Path, f: impl FnOnce(&mut dyn Write) -> io::Result<()>) -> Result<()> {
    let batch = Batch::new();
    batch.reserve(path, "the output")?;
    batch.write(path, f)?;
    batch.commit()
}

// ---------------------------------------------------------------------------------------------
// The registry of named temporary files, read by the signal handler.

/// Named temporary files alive at once (an `extract` with many `--iso` values has one per value).
const REGISTRY_SLOTS: usize = 1024;

/// Paths (NUL-terminated, owned) of live named temporary files; null = free slot.
static REGISTRY: [AtomicPtr<libc::c_char>; REGISTRY_SLOTS] =
    [const { AtomicPtr::new(std::ptr::null_mut()) }; REGISTRY_SLOTS];

/// Set by the signal handler before it reads the registry: from then on nothing is freed.
static IN_HANDLER: AtomicBool = AtomicBool::new(false);

/// A registry entry; unregisters (and frees its path) when dropped.
struct Registered(usize);

impl Registered {
    fn new(path: &Path) -> io::Result<Self> {
        let c = CString::new(path.as_os_str().as_encoded_bytes())
            .map_err(|_| io::Error::new(io::ErrorKind::InvalidInput, "path contains a NUL byte"))?;
        let p = c.into_raw();
        for (i, slot) in REGISTRY.iter().enumerate() {
            if slot.compare_exchange(std::ptr::null_mut(), p, Ordering::SeqCst, Ordering::SeqCst).is_ok() {
                return Ok(Registered(i));
            }
        }
        // SAFETY: `p` came from `CString::into_raw` above and was not stored anywhere.
        drop(unsafe { CString::from_raw(p) });
        Err(io::Error::other(format!("more than {REGISTRY_SLOTS} temporary files at once")))
    }
}

impl Drop for Registered {
    fn drop(&mut self) {
        let p = REGISTRY[self.0].swap(std::ptr::null_mut(), Ordering::SeqCst);
        // A handler that started before the swap may still read `p`; it sets IN_HANDLER first
        // (SeqCst on both sides), so seeing it unset here means no handler holds `p`. The process
        // ends with the handler anyway, so not freeing is harmless.
        if !p.is_null() && !IN_HANDLER.load(Ordering::SeqCst) {
            // SAFETY: `p` came from `CString::into_raw` in `Registered::new` and is no longer shared.
            drop(unsafe { CString::from_raw(p) });
        }
    }
}

/// Installs (once per process) handlers for SIGINT, SIGTERM, SIGHUP and SIGQUIT that unlink the
/// named temporary files of unfinished writes, then let the signal take its default effect
/// (the process ends with that signal, as without the handler). Signals set to be ignored (e.g.
/// SIGHUP under `nohup`) or already handled by the program are left alone. Call it at start-up,
/// before threads are spawned; on platforms other than Unix it does nothing.
pub fn install_signal_cleanup() {
    #[cfg(unix)]
    {
        static ONCE: std::sync::Once = std::sync::Once::new();
        ONCE.call_once(|| {
            for sig in [libc::SIGINT, libc::SIGTERM, libc::SIGHUP, libc::SIGQUIT] {
                // SAFETY: plain sigaction calls with zero-initialised (valid) structures; the
                // handler only calls async-signal-safe functions (unlink, signal, raise).
                unsafe {
                    let mut old: libc::sigaction = std::mem::zeroed();
                    if libc::sigaction(sig, std::ptr::null(), &mut old) != 0 || old.sa_sigaction != libc::SIG_DFL {
                        continue;
                    }
                    let mut sa: libc::sigaction = std::mem::zeroed();
                    sa.sa_sigaction = on_signal as extern "C" fn(libc::c_int) as libc::sighandler_t;
                    libc::sigemptyset(&mut sa.sa_mask);
                    libc::sigaction(sig, &sa, std::ptr::null_mut());
                }
            }
        });
    }
}

#[cfg(unix)]
extern "C" fn on_signal(sig: libc::c_int) {
    IN_HANDLER.store(true, Ordering::SeqCst);
    for slot in &REGISTRY {
        let p = slot.load(Ordering::SeqCst);
        if !p.is_null() {
            // SAFETY: `p` is a NUL-terminated path owned by the registry and never freed once
            // IN_HANDLER is set; unlink is async-signal-safe.
            unsafe { libc::unlink(p) };
        }
    }
    // SAFETY: restoring the default action and re-raising are async-signal-safe; the signal is
    // blocked while this handler runs, so it is delivered (and ends the process) on return.
    unsafe {
        libc::signal(sig, libc::SIG_DFL);
        libc::raise(sig);
    }
}

// ---------------------------------------------------------------------------------------------
// Temporary files.

/// A hard-to-guess 64-bit number: SipHash with per-process random keys over the time, the
/// process id and a counter.
fn random_u64() -> u64 {
    use std::hash::{BuildHasher, Hasher};
    static COUNTER: AtomicU64 = AtomicU64::new(0);
    let mut h = std::collections::hash_map::RandomState::new().build_hasher();
    let now = std::time::SystemTime::now().duration_since(std::time::UNIX_EPOCH).unwrap_or_default();
    h.write_u128(now.as_nanos());
    h.write_u32(std::process::id());
    h.write_u64(COUNTER.fetch_add(1, Ordering::Relaxed));
    h.finish()
}

/// The folder a file named `path` lives in.
fn folder_of(path: &Path) -> &Path {
    match path.parent() {
        Some(p) if !p.as_os_str().is_empty() => p,
        _ => Path::new("."),
    }
}

/// Candidate names for a named temporary file beside `target`.
fn temp_names(target: &Path) -> impl Iterator<Item = PathBuf> + '_ {
    let name = target.file_name().map(|n| n.to_string_lossy().into_owned()).unwrap_or_default();
    let dir = folder_of(target).to_path_buf();
    (0..64).map(move |_| dir.join(format!(".{name}.{:016x}.tmp", random_u64())))
}

/// Whether commits sync files and folders to disk (`ISOFORGE_SYNC=1`; see the module doc).
fn durable() -> bool {
    std::env::var_os("ISOFORGE_SYNC").is_some_and(|v| v == "1")
}

/// Whether temporary files should be named (no `O_TMPFILE`): forced by `ISOFORGE_TEMP=named`.
#[cfg(target_os = "linux")]
fn force_named() -> bool {
    std::env::var_os("ISOFORGE_TEMP").is_some_and(|v| v == "named")
}

/// A temporary file beside its target: anonymous (Linux `O_TMPFILE`) or named and registered.
pub(crate) struct TempFile {
    file: File,
    /// The registered name of a named temporary file; `None` for an anonymous one.
    named: Option<(PathBuf, Registered)>,
}

impl TempFile {
    /// Creates a temporary file for `target` in its folder, readable and writable.
    pub fn create(target: &Path) -> io::Result<Self> {
        #[cfg(target_os = "linux")]
        if !force_named() && proc_fd_available() {
            match open_tmpfile(folder_of(target)) {
                Ok(file) => return Ok(TempFile { file, named: None }),
                // Filesystems without O_TMPFILE (and old kernels) answer these: fall back.
                Err(e) if matches!(e.raw_os_error(), Some(libc::EOPNOTSUPP | libc::EISDIR | libc::EINVAL)) => {}
                Err(e) => return Err(e),
            }
        }
        Self::create_named(temp_names(target))
    }

    /// Creates the first of `names` that does not exist yet (`O_EXCL`: an existing name, even a
    /// dangling symbolic link, is skipped, never followed).
    fn create_named(names: impl Iterator<Item = PathBuf>) -> io::Result<Self> {
        for path in names {
            // Registered before it exists: a signal in between unlinks nothing, harmlessly.
            let reg = Registered::new(&path)?;
            match std::fs::OpenOptions::new().read(true).write(true).create_new(true).open(&path) {
                Ok(file) => return Ok(TempFile { file, named: Some((path, reg)) }),
                Err(e) if e.kind() == io::ErrorKind::AlreadyExists => continue,
                Err(e) => return Err(e),
            }
        }
        Err(io::Error::new(io::ErrorKind::AlreadyExists, "no free temporary file name"))
    }

    /// The file itself (for `std::io::copy` between files, which the kernel does for `File`s).
    pub fn file_mut(&mut self) -> &mut File {
        &mut self.file
    }

    /// Empties the file and rewinds it. A file that is already empty (every fresh one) is not
    /// truncated: on ext4 (`auto_da_alloc`) a truncation to zero makes the later `close` write
    /// the whole new content back before returning (0.1 s for a 150 MB mesh).
    pub fn reset(&mut self) -> io::Result<()> {
        if self.file.metadata()?.len() > 0 {
            self.file.set_len(0)?;
        }
        self.file.seek(SeekFrom::Start(0)).map(|_| ())
    }

    /// Gives the file (synced if [`durable`]) a name of its own in `target`'s folder, without
    /// replacing anything: the first step of a commit, which can fail without touching the target.
    fn prepare(mut self, target: &Path) -> io::Result<Prepared> {
        if durable() {
            self.file.sync_all()?;
        }
        if let Some((path, reg)) = self.named.take() {
            return Ok(Prepared { path, _reg: reg, renamed: false });
        }
        #[cfg(target_os = "linux")]
        {
            use std::os::fd::AsRawFd;
            let proc = CString::new(format!("/proc/self/fd/{}", self.file.as_raw_fd()))
                .map_err(|_| io::Error::other("fd path"))?;
            for path in temp_names(target) {
                let reg = Registered::new(&path)?;
                let c = CString::new(path.as_os_str().as_encoded_bytes())
                    .map_err(|_| io::Error::new(io::ErrorKind::InvalidInput, "path contains a NUL byte"))?;
                // SAFETY: both paths are valid NUL-terminated strings. linkat never replaces an
                // existing name (EEXIST), so a planted link is not followed.
                let r = unsafe {
                    libc::linkat(libc::AT_FDCWD, proc.as_ptr(), libc::AT_FDCWD, c.as_ptr(), libc::AT_SYMLINK_FOLLOW)
                };
                if r == 0 {
                    return Ok(Prepared { path, _reg: reg, renamed: false });
                }
                let e = io::Error::last_os_error();
                if e.kind() != io::ErrorKind::AlreadyExists {
                    return Err(e);
                }
            }
            Err(io::Error::new(io::ErrorKind::AlreadyExists, "no free temporary file name"))
        }
        #[cfg(not(target_os = "linux"))]
        {
            let _ = target;
            Err(io::Error::other("anonymous temporary files exist only on Linux"))
        }
    }
}

impl Write for TempFile {
    fn write(&mut self, buf: &[u8]) -> io::Result<usize> {
        self.file.write(buf)
    }
    fn flush(&mut self) -> io::Result<()> {
        self.file.flush()
    }
}

impl io::Read for TempFile {
    fn read(&mut self, buf: &mut [u8]) -> io::Result<usize> {
        self.file.read(buf)
    }
}

impl Seek for TempFile {
    fn seek(&mut self, to: SeekFrom) -> io::Result<u64> {
        self.file.seek(to)
    }
}

impl Drop for TempFile {
    fn drop(&mut self) {
        if let Some((path, _reg)) = &self.named {
            let _ = std::fs::remove_file(path);
        }
    }
}

/// A temporary file with a name in the target's folder, about to be renamed over the target.
struct Prepared {
    path: PathBuf,
    _reg: Registered,
    renamed: bool,
}

impl Prepared {
    /// Moves into place, atomically replacing `target`; on failure the file is removed.
    ///
    /// On Linux an existing regular `target` is swapped with the new file (`RENAME_EXCHANGE`),
    /// then the old content, now under the temporary name, is unlinked: a rename over an
    /// existing file makes ext4 (`auto_da_alloc`) write the new file back before the rename
    /// returns (0.05–0.09 s for a 150 MB mesh). Either way a reader sees the old file or the
    /// whole new one; what a power cut leaves is the module doc's subject.
    fn finish(mut self, target: &Path) -> io::Result<()> {
        #[cfg(target_os = "linux")]
        if !durable() && std::fs::symlink_metadata(target).is_ok_and(|m| m.is_file()) && self.exchange(target)? {
            return Ok(());
        }
        std::fs::rename(&self.path, target)?;
        self.renamed = true;
        Ok(())
    }

    /// Swaps the new file with the old `target` and unlinks the old one; false (nothing done)
    /// where the filesystem cannot swap or `target` is gone.
    #[cfg(target_os = "linux")]
    fn exchange(&mut self, target: &Path) -> io::Result<bool> {
        let c = |p: &Path| {
            CString::new(p.as_os_str().as_encoded_bytes())
                .map_err(|_| io::Error::new(io::ErrorKind::InvalidInput, "path contains a NUL byte"))
        };
        let (ours, theirs) = (c(&self.path)?, c(target)?);
        let swap = || {
            // SAFETY: both paths are valid NUL-terminated strings.
            let r = unsafe {
                libc::renameat2(libc::AT_FDCWD, ours.as_ptr(), libc::AT_FDCWD, theirs.as_ptr(), libc::RENAME_EXCHANGE)
            };
            if r == 0 {
                Ok(())
            } else {
                Err(io::Error::last_os_error())
            }
        };
        if let Err(e) = swap() {
            return match e.raw_os_error() {
                Some(libc::EINVAL | libc::ENOSYS | libc::EOPNOTSUPP | libc::ENOENT) => Ok(false),
                _ => Err(e),
            };
        }
        // The temporary name now holds the old file (a folder, had one replaced the target
        // since it was checked: then swap back and fail rather than leave it renamed).
        if let Err(e) = std::fs::remove_file(&self.path) {
            if swap().is_err() {
                // The new file is in place; leave both names alone.
                self.renamed = true;
            }
            return Err(e);
        }
        self.renamed = true;
        Ok(true)
    }
}

impl Drop for Prepared {
    fn drop(&mut self) {
        if !self.renamed {
            let _ = std::fs::remove_file(&self.path);
        }
    }
}

#[cfg(target_os = "linux")]
fn open_tmpfile(dir: &Path) -> io::Result<File> {
    use std::os::unix::fs::OpenOptionsExt;
    // O_TMPFILE is a flag of open(2) on the folder; the mode is the one File::create uses.
    std::fs::OpenOptions::new().read(true).write(true).mode(0o666).custom_flags(libc::O_TMPFILE).open(dir)
}

/// Anonymous files are committed by linking `/proc/self/fd/N`; without /proc, use names.
#[cfg(target_os = "linux")]
fn proc_fd_available() -> bool {
    static AVAILABLE: std::sync::OnceLock<bool> = std::sync::OnceLock::new();
    *AVAILABLE.get_or_init(|| Path::new("/proc/self/fd").is_dir())
}

// ---------------------------------------------------------------------------------------------
// Identity of files.

/// True when `a` and `b` name the same file: the same device and inode when both exist, else
/// the same canonical path (folder resolved, name compared).
pub fn same_file(a: &Path, b: &Path) -> bool {
    #[cfg(unix)]
    if let (Ok(ma), Ok(mb)) = (std::fs::metadata(a), std::fs::metadata(b)) {
        use std::os::unix::fs::MetadataExt;
        return ma.dev() == mb.dev() && ma.ino() == mb.ino();
    }
    match (canonical(a), canonical(b)) {
        (Some(x), Some(y)) => x == y,
        _ => a == b,
    }
}

/// The canonical form of a path whose last component may not exist yet.
fn canonical(p: &Path) -> Option<PathBuf> {
    if let Ok(c) = p.canonicalize() {
        return Some(c);
    }
    Some(folder_of(p).canonicalize().ok()?.join(p.file_name()?))
}

/// Refuses `outputs` that name the same file as one of `inputs` (both `(path, role)` pairs,
/// an empty input role for a positional argument), before anything is created.
///
/// # Errors
/// [`Error::InvalidInput`] naming the output, its role, the input and its role.
pub fn refuse_overwrite(outputs: &[(PathBuf, String)], inputs: &[(PathBuf, String)]) -> Result<()> {
    for (path, out_role) in outputs {
        if let Some((input, role)) = inputs.iter().find(|(i, _)| same_file(path, i)) {
            let what = if input == path { String::new() } else { format!(" {}", input.display()) };
            let role = if role.is_empty() { String::new() } else { format!(" ({role})") };
            return Err(output_error(path, format!("{out_role} would overwrite the input{what}{role}")));
        }
    }
    Ok(())
}

// ---------------------------------------------------------------------------------------------
// Batches.

struct Entry {
    path: PathBuf,
    /// How the command line named this output ("-o", "--time-json"), for messages.
    role: String,
    /// `None` while a streaming writer holds it ([`Batch::take`]).
    temp: Option<TempFile>,
    written: bool,
}

/// The outputs of one command, committed together: all appear, or none does.
///
/// ```no_run
/// # fn main() -> isoforge_io::Result<()> {
/// use std::io::Write;
/// let batch = isoforge_io::Batch::new();
/// batch.reserve("mesh.ply".as_ref(), "-o")?;        // checked and created before any work
/// batch.reserve("time.json".as_ref(), "--time-json")?;
/// batch.write("mesh.ply".as_ref(), |w| w.write_all(b"ply\n"))?;
/// batch.write("time.json".as_ref(), |w| w.write_all(b"{}"))?;
/// batch.commit()?;                                   // both renamed into place
/// # Ok(()) }
/// ```
#[derive(Default)]
pub struct Batch {
    entries: Mutex<Vec<Entry>>,
}

impl std::fmt::Debug for Batch {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let paths: Vec<PathBuf> = self.lock().iter().map(|e| e.path.clone()).collect();
        f.debug_struct("Batch").field("outputs", &paths).finish()
    }
}

/// `path: detail` as an error about an output.
fn output_error(path: &Path, detail: impl std::fmt::Display) -> Error {
    Error::InvalidInput(format!("{}: {detail}", path.display()))
}

impl Batch {
    /// The most files one batch writes (its temporary files are registered for the signal
    /// handler's cleanup, in a fixed table).
    pub const MAX_FILES: usize = REGISTRY_SLOTS;

    /// An empty batch.
    pub fn new() -> Self {
        Self::default()
    }

    fn lock(&self) -> std::sync::MutexGuard<'_, Vec<Entry>> {
        self.entries.lock().unwrap_or_else(|p| p.into_inner())
    }

    /// Checks `path` as an output and creates its temporary file now, so a missing or
    /// unwritable folder fails before any work. `role` names the output in messages (`-o`).
    ///
    /// # Errors
    /// [`Error::InvalidInput`] when `path` has no file name, is a folder or not a regular file,
    /// names the same file as an output already reserved, or its folder does not exist;
    /// [`Error::Io`] when the temporary file cannot be created (permissions, read-only
    /// filesystem).
    pub fn reserve(&self, path: &Path, role: &str) -> Result<()> {
        if path.file_name().is_none() {
            return Err(output_error(path, format!("{role} must name a file")));
        }
        if let Ok(meta) = std::fs::metadata(path) {
            let t = meta.file_type();
            if t.is_dir() {
                return Err(output_error(path, format!("{role} is a folder; give a file name")));
            }
            if !t.is_file() {
                return Err(output_error(
                    path,
                    format!(
                        "{role} is {}, not a regular file (outputs are written beside and renamed into place)",
                        crate::file::kind_name(&t)
                    ),
                ));
            }
        }
        let dir = folder_of(path);
        match std::fs::metadata(dir) {
            Ok(m) if m.is_dir() => {}
            Ok(_) => return Err(output_error(path, format!("{} is not a folder", dir.display()))),
            Err(_) => return Err(output_error(path, format!("the folder {} does not exist", dir.display()))),
        }
        let mut entries = self.lock();
        if let Some(other) = entries.iter().find(|e| same_file(&e.path, path)) {
            return Err(output_error(path, format!("{role} names the same file as {}", other.role)));
        }
        let temp = TempFile::create(path).map_err(|source| Error::Io { path: path.to_path_buf(), source })?;
        entries.push(Entry { path: path.to_path_buf(), role: role.to_string(), temp: Some(temp), written: false });
        Ok(())
    }

    /// Refuses outputs that would overwrite an input: `inputs` are `(path, role)` pairs
    /// (`("ct.nrrd", "-i")`, or an empty role for a positional argument); see
    /// [`crate::input_files`] for the files a volume reads.
    ///
    /// # Errors
    /// [`Error::InvalidInput`] naming the output, its role, the input and its role.
    pub fn refuse_inputs(&self, inputs: &[(PathBuf, String)]) -> Result<()> {
        let outputs: Vec<(PathBuf, String)> = self.lock().iter().map(|e| (e.path.clone(), e.role.clone())).collect();
        refuse_overwrite(&outputs, inputs)
    }

    /// The paths reserved so far, in order.
    pub fn paths(&self) -> Vec<PathBuf> {
        self.lock().iter().map(|e| e.path.clone()).collect()
    }

    /// Writes the content of `path` (reserving it first if needed) through `f`; writing it
    /// again replaces the content. Nothing appears at `path` before [`Batch::commit`].
    ///
    /// # Errors
    /// As [`Batch::reserve`]; [`Error::Io`] naming `path` when writing fails; whatever `f`
    /// returns, as [`Error::Io`].
    pub fn write(&self, path: &Path, f: impl FnOnce(&mut dyn Write) -> io::Result<()>) -> Result<()> {
        self.with_file(path, |file| {
            file.reset()?;
            let mut w = BufWriter::with_capacity(1 << 20, file);
            f(&mut w)?;
            w.flush()
        })
    }

    /// Runs `f` on the temporary file of `path` (reserved first if needed) and marks it written.
    fn with_file<R>(&self, path: &Path, f: impl FnOnce(&mut TempFile) -> io::Result<R>) -> Result<R> {
        let mut temp = self.take(path)?;
        let r = f(&mut temp).map_err(|source| Error::Io { path: path.to_path_buf(), source });
        self.put(path, temp);
        r
    }

    /// Takes the temporary file of `path` (reserved first if needed) out of the batch, for a
    /// writer that fills it over many calls; give it back with [`Batch::put`].
    pub(crate) fn take(&self, path: &Path) -> Result<TempFile> {
        if !self.lock().iter().any(|e| e.path == path) {
            self.reserve(path, "the output")?;
        }
        let internal = || Error::InvalidInput(format!("internal: {} is not available (this is a bug)", path.display()));
        let mut entries = self.lock();
        let e = entries.iter_mut().find(|e| e.path == path).ok_or_else(internal)?;
        e.temp.take().ok_or_else(internal)
    }

    /// [`Batch::take`], emptied (a stream starts from its first byte).
    pub(crate) fn take_empty(&self, path: &Path) -> Result<TempFile> {
        let mut file = self.take(path)?;
        file.reset().map_err(|source| crate::Error::Io { path: path.to_path_buf(), source })?;
        Ok(file)
    }

    /// Gives back a written temporary file taken with [`Batch::take`].
    pub(crate) fn put(&self, path: &Path, temp: TempFile) {
        if let Some(e) = self.lock().iter_mut().find(|e| e.path == path) {
            e.temp = Some(temp);
            e.written = true;
        }
    }

    /// Moves every output into place: first each is synced (if `durable`) and given a temporary name in its
    /// folder (nothing replaced yet; any failure here leaves every target untouched), then all
    /// are renamed over their targets.
    ///
    /// # Errors
    /// [`Error::InvalidInput`] when a reserved output was never written (a bug in the caller);
    /// [`Error::Io`] naming the output that could not be moved.
    pub fn commit(self) -> Result<()> {
        let entries = std::mem::take(&mut *self.lock());
        let mut prepared = Vec::with_capacity(entries.len());
        for e in entries {
            let (true, Some(temp)) = (e.written, e.temp) else {
                return Err(output_error(
                    &e.path,
                    format!("internal: {} was reserved but not written (this is a bug)", e.role),
                ));
            };
            let p = temp.prepare(&e.path).map_err(|source| Error::Io { path: e.path.clone(), source })?;
            prepared.push((e.path, p));
        }
        let mut folders: Vec<PathBuf> = Vec::new();
        for (path, p) in prepared {
            p.finish(&path).map_err(|source| Error::Io { path: path.clone(), source })?;
            let dir = folder_of(&path).to_path_buf();
            if !folders.contains(&dir) {
                folders.push(dir);
            }
        }
        // The renames themselves reach the disk with the folders.
        for dir in folders.into_iter().filter(|_| durable()) {
            if let Ok(d) = File::open(&dir) {
                let _ = d.sync_all();
            }
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn names_in(dir: &Path) -> Vec<String> {
        let mut v: Vec<String> =
            std::fs::read_dir(dir).unwrap().map(|e| e.unwrap().file_name().to_string_lossy().into_owned()).collect();
        v.sort();
        v
    }

    #[test]
    fn failure_leaves_nothing() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("out.txt");
        let r = write_atomic(&p, |w| {
            w.write_all(b"partial")?;
            Err(io::Error::other("boom"))
        });
        assert!(r.is_err());
        assert!(!p.exists());
        assert!(names_in(dir.path()).is_empty(), "temporary file left behind");
        write_atomic(&p, |w| w.write_all(b"ok")).unwrap();
        assert_eq!(std::fs::read(&p).unwrap(), b"ok");
        write_atomic(&p, |w| w.write_all(b"replaced")).unwrap();
        assert_eq!(std::fs::read(&p).unwrap(), b"replaced");
        assert_eq!(names_in(dir.path()), ["out.txt"]);
    }

    #[test]
    #[cfg(unix)]
    fn issue_10_named_temporaries_skip_planted_links() {
        let dir = tempfile::tempdir().unwrap();
        let victim = dir.path().join("victim.txt");
        std::fs::write(&victim, b"precious").unwrap();
        let target = dir.path().join("out.txt");
        // Every candidate but the last is taken by a link to the victim (or a dangling link).
        let names: Vec<PathBuf> = (0..5).map(|i| dir.path().join(format!(".out.txt.{i}.tmp"))).collect();
        for (i, n) in names[..4].iter().enumerate() {
            let to = if i % 2 == 0 { victim.clone() } else { dir.path().join("nowhere") };
            std::os::unix::fs::symlink(&to, n).unwrap();
        }
        let mut t = TempFile::create_named(names.clone().into_iter()).unwrap();
        assert_eq!(t.named.as_ref().unwrap().0, names[4]);
        t.write_all(b"new").unwrap();
        t.prepare(&target).unwrap().finish(&target).unwrap();
        assert_eq!(std::fs::read(&victim).unwrap(), b"precious");
        assert_eq!(std::fs::read(&target).unwrap(), b"new");
        assert!(!dir.path().join("nowhere").exists(), "a dangling link was followed");
        // All names taken: an error, the links untouched.
        assert!(TempFile::create_named(names[..4].iter().cloned()).is_err());
        assert_eq!(std::fs::read(&victim).unwrap(), b"precious");
    }

    #[test]
    #[cfg(unix)]
    fn issue_10_a_link_at_the_target_is_replaced_not_followed() {
        let dir = tempfile::tempdir().unwrap();
        let victim = dir.path().join("victim.txt");
        std::fs::write(&victim, b"precious").unwrap();
        let target = dir.path().join("out.txt");
        std::os::unix::fs::symlink(&victim, &target).unwrap();
        write_atomic(&target, |w| w.write_all(b"new")).unwrap();
        assert_eq!(std::fs::read(&victim).unwrap(), b"precious");
        assert!(!std::fs::symlink_metadata(&target).unwrap().file_type().is_symlink());
        assert_eq!(std::fs::read(&target).unwrap(), b"new");
    }

    #[test]
    fn replacing_a_file_swaps_it_out_whole() {
        let dir = tempfile::tempdir().unwrap();
        let target = dir.path().join("out.ply");
        std::fs::write(&target, b"old mesh").unwrap();
        // Another name of the old file keeps the old content, as with a rename over it.
        let alias = dir.path().join("alias.ply");
        std::fs::hard_link(&target, &alias).unwrap();
        write_atomic(&target, |w| w.write_all(b"new")).unwrap();
        assert_eq!(std::fs::read(&target).unwrap(), b"new");
        assert_eq!(std::fs::read(&alias).unwrap(), b"old mesh");
        assert_eq!(names_in(dir.path()), ["alias.ply", "out.ply"], "the old file left under a temporary name");
        // Written twice in one batch: the second content, from the start of the file.
        let batch = Batch::new();
        batch.write(&target, |w| w.write_all(b"first, longer")).unwrap();
        batch.write(&target, |w| w.write_all(b"second")).unwrap();
        batch.commit().unwrap();
        assert_eq!(std::fs::read(&target).unwrap(), b"second");
        assert_eq!(names_in(dir.path()), ["alias.ply", "out.ply"]);
    }

    #[test]
    fn registry_tracks_named_temporaries() {
        let dir = tempfile::tempdir().unwrap();
        let t = TempFile::create_named(temp_names(&dir.path().join("x"))).unwrap();
        let (path, reg) = t.named.as_ref().unwrap();
        let c = REGISTRY[reg.0].load(Ordering::SeqCst);
        // SAFETY: this test's own entry, alive until `t` is dropped below.
        assert_eq!(unsafe { std::ffi::CStr::from_ptr(c) }.to_bytes(), path.as_os_str().as_encoded_bytes());
        let path = path.clone();
        assert!(path.exists());
        drop(t);
        assert!(!path.exists());
    }

    #[test]
    fn issue_10_batches_commit_all_or_nothing() {
        let dir = tempfile::tempdir().unwrap();
        let (a, b) = (dir.path().join("a.ply"), dir.path().join("b.json"));
        {
            let batch = Batch::new();
            batch.reserve(&a, "-o").unwrap();
            batch.reserve(&b, "--time-json").unwrap();
            batch.write(&a, |w| w.write_all(b"mesh")).unwrap();
            // b fails: the batch is dropped, nothing appears.
            assert!(batch.write(&b, |_| Err(io::Error::other("disk full"))).is_err());
        }
        assert!(names_in(dir.path()).is_empty(), "{:?}", names_in(dir.path()));
        let batch = Batch::new();
        batch.reserve(&a, "-o").unwrap();
        batch.reserve(&b, "--time-json").unwrap();
        batch.write(&a, |w| w.write_all(b"mesh")).unwrap();
        assert!(names_in(dir.path()).is_empty(), "visible before commit");
        batch.write(&b, |w| w.write_all(b"{}")).unwrap();
        batch.commit().unwrap();
        assert_eq!(names_in(dir.path()), ["a.ply", "b.json"]);
        assert_eq!(std::fs::read(&a).unwrap(), b"mesh");
    }

    #[test]
    fn issue_10_outputs_are_checked_before_any_work() {
        let dir = tempfile::tempdir().unwrap();
        let batch = Batch::new();
        let msg = |r: Result<()>| r.unwrap_err().to_string();
        let missing = dir.path().join("no/such/x.ply");
        assert!(msg(batch.reserve(&missing, "-o")).ends_with("does not exist"));
        assert!(msg(batch.reserve(dir.path(), "-o")).contains("-o is a folder"));
        assert!(msg(batch.reserve(Path::new("/dev/null"), "-o")).contains("a character device"));
        let out = dir.path().join("o.ply");
        batch.reserve(&out, "-o").unwrap();
        let again = dir.path().join(".").join("o.ply");
        assert_eq!(
            msg(batch.reserve(&again, "--time-json")),
            format!("{}: --time-json names the same file as -o", again.display())
        );
        let input = dir.path().join("in.nrrd");
        std::fs::write(&input, b"x").unwrap();
        let b2 = Batch::new();
        b2.reserve(&input, "-o").unwrap();
        let e = msg(b2.refuse_inputs(&[(input.clone(), "-i".into())]));
        assert_eq!(e, format!("{}: -o would overwrite the input (-i)", input.display()));
        // A hard link to the input is the same file too.
        let link = dir.path().join("alias.nrrd");
        std::fs::hard_link(&input, &link).unwrap();
        let b3 = Batch::new();
        b3.reserve(&link, "-o").unwrap();
        assert!(msg(b3.refuse_inputs(&[(input.clone(), "-i".into())])).contains("would overwrite the input"));
        drop((batch, b2, b3));
        assert_eq!(names_in(dir.path()), ["alias.nrrd", "in.nrrd"]);
    }
}
