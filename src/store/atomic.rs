//! Atomic file writes: a reader sees either the old file or the complete new one,
//! never a partial write, even if the process dies midway.

use std::ffi::OsStr;
use std::fs::{self, File};
use std::io::{self, Seek, SeekFrom, Write};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicU64, Ordering};

/// Distinguishes temp files of concurrent writers in one process.
static TEMP_COUNTER: AtomicU64 = AtomicU64::new(0);

/// Prefix of temp files; they start with a dot so listings and status checks, which
/// look only at final names, never mistake one for a finished file.
pub const TEMP_PREFIX: &str = ".tmp-";

/// How many temp names [`create_temp`] tries before giving up. A name is taken
/// only by a file some other writer left (a killed process whose pid this one
/// now has: as PID 1 in a container, every process has the same pid), so a
/// handful of attempts always finds a free one; the bound only turns a
/// pathological directory into an error instead of a loop.
const TEMP_ATTEMPTS: u32 = 64;

/// Writes `bytes` to `path` atomically: a temp file in the same directory, fsync,
/// rename over `path`, fsync of the directory.
pub fn write_atomic(path: &Path, bytes: &[u8]) -> io::Result<()> {
    write_atomic_with(path, bytes, |_| Ok(()))
}

/// [`write_atomic`] with a hook called between the temp write and the rename, so
/// tests can inject a failure exactly there. On any error the temp file is removed.
pub(crate) fn write_atomic_with(
    path: &Path,
    bytes: &[u8],
    before_rename: impl FnOnce(&Path) -> io::Result<()>,
) -> io::Result<()> {
    let (dir, name) = split(path)?;
    let (mut file, temp) = create_temp(dir, name)?;
    let result = (|| {
        file.write_all(bytes)?;
        file.sync_all()?;
        drop(file);
        before_rename(&temp)?;
        fs::rename(&temp, path)?;
        sync_dir(dir)
    })();
    if result.is_err() {
        // Best effort: the temp name is never read as a result, so a leftover is
        // harmless; removing it only keeps the directory tidy.
        let _ = fs::remove_file(&temp);
    }
    result
}

/// The directory and file name of `path` (a bare name lives in `.`).
fn split(path: &Path) -> io::Result<(&Path, &OsStr)> {
    let dir = match path.parent() {
        Some(d) if !d.as_os_str().is_empty() => d,
        _ => Path::new("."),
    };
    let name = path.file_name().ok_or_else(|| {
        io::Error::new(
            io::ErrorKind::InvalidInput,
            "atomic write needs a file name",
        )
    })?;
    Ok((dir, name))
}

/// Creates a fresh temp file for `name` in `dir` and returns it with its path.
///
/// Names are `.tmp-<name>-<host>-<pid>-<counter>`, unique among this
/// process's writers; the host and pid let a later process on the same host
/// tell a leftover of an ended writer at once ([`writer_has_ended`]). The
/// pid alone does not make them unique across processes: a killed process's
/// leftovers carry a pid that a later process may get again (always, as
/// PID 1 in a container). So the file is created with create-new, and a name
/// some earlier process left behind is skipped for the next one.
fn create_temp(dir: &Path, name: &OsStr) -> io::Result<(File, PathBuf)> {
    let mut last = None;
    for _ in 0..TEMP_ATTEMPTS {
        let temp = dir.join(temp_name(
            name,
            TEMP_COUNTER.fetch_add(1, Ordering::Relaxed),
        ));
        match File::create_new(&temp) {
            Ok(file) => return Ok((file, temp)),
            Err(e) if e.kind() == io::ErrorKind::AlreadyExists => last = Some(e),
            Err(e) => return Err(e),
        }
    }
    Err(last.unwrap_or_else(|| io::Error::other("no temp name tried")))
}

/// The temp file name of this process's `counter`-th write of `name`.
fn temp_name(name: &OsStr, counter: u64) -> String {
    format!(
        "{TEMP_PREFIX}{}-{}-{}-{counter}",
        name.to_string_lossy(),
        host(),
        std::process::id()
    )
}

/// This machine's host name as temp names carry it (Linux's
/// `/proc/sys/kernel/hostname`, every character outside `[A-Za-z0-9._-]`
/// replaced by `_`), or empty where it cannot be read.
fn host() -> &'static str {
    static HOST: std::sync::OnceLock<String> = std::sync::OnceLock::new();
    HOST.get_or_init(|| {
        fs::read_to_string("/proc/sys/kernel/hostname")
            .map(|h| {
                h.trim()
                    .chars()
                    .map(|c| {
                        if c.is_ascii_alphanumeric() || "._-".contains(c) {
                            c
                        } else {
                            '_'
                        }
                    })
                    .collect()
            })
            .unwrap_or_default()
    })
}

/// Whether the temp file `file_name` was written by another process of this
/// host that has ended (its pid is not in `/proc`): a killed writer's
/// leftover, whatever its age. Names without this host's name (another
/// machine on a shared file system, or an older repose) never are.
fn writer_has_ended(file_name: &str) -> bool {
    let host = host();
    let mut parts = file_name.rsplitn(3, '-');
    let (Some(counter), Some(pid), Some(rest)) = (parts.next(), parts.next(), parts.next()) else {
        return false;
    };
    let Ok(pid) = pid.parse::<u32>() else {
        return false;
    };
    !host.is_empty()
        && counter.parse::<u64>().is_ok()
        && rest.ends_with(&format!("-{host}"))
        && pid != std::process::id()
        && !Path::new("/proc").join(pid.to_string()).exists()
}

/// Removes every temp file ([`TEMP_PREFIX`]) directly inside `dir` and returns
/// how many it removed. Only call it while holding the directory's claim (see
/// [`super::claim`]): then no live writer owns any of them, and they are the
/// leftovers of killed processes (one can be a whole run log).
pub fn remove_stale_temps(dir: &Path) -> io::Result<usize> {
    let mut removed = 0;
    for entry in fs::read_dir(dir)? {
        removed += usize::from(remove_if_temp(&entry?, |_| Ok(true))?);
    }
    Ok(removed)
}

/// Removes `entry` when it is a temp file ([`TEMP_PREFIX`]) that `remove`
/// accepts; whether it did (one another process removed first counts).
fn remove_if_temp(
    entry: &fs::DirEntry,
    remove: impl FnOnce(&fs::DirEntry) -> io::Result<bool>,
) -> io::Result<bool> {
    let is_temp = entry
        .file_name()
        .to_str()
        .is_some_and(|n| n.starts_with(TEMP_PREFIX));
    if !(is_temp && entry.file_type()?.is_file() && remove(entry)?) {
        return Ok(false);
    }
    match fs::remove_file(entry.path()) {
        Err(e) if e.kind() != io::ErrorKind::NotFound => Err(e),
        _ => Ok(true),
    }
}

/// How old a temp file must be before [`remove_old_temps`] takes it for a
/// killed writer's leftover: an atomic write of a stage output lives for
/// milliseconds (write, fsync, rename), so ten minutes is far beyond any
/// live one, on this machine or another sharing the file system.
pub const STALE_TEMP_AGE: std::time::Duration = std::time::Duration::from_secs(600);

/// Removes every temp file ([`TEMP_PREFIX`]) in the tree under `dir` last
/// modified at least `min_age` ago, or left by an ended writer of this host
/// ([`writer_has_ended`]: a stage killed and re-run at once), and returns
/// how many it removed. For directories without a claim (a study's stage
/// outputs), where a fresh temp may be another client's write in progress;
/// a missing `dir` removes nothing.
pub fn remove_old_temps(dir: &Path, min_age: std::time::Duration) -> io::Result<usize> {
    let mut removed = 0;
    let mut stack = vec![dir.to_path_buf()];
    while let Some(d) = stack.pop() {
        let entries = match fs::read_dir(&d) {
            Ok(e) => e,
            Err(e) if e.kind() == io::ErrorKind::NotFound => continue,
            Err(e) => return Err(e),
        };
        for entry in entries {
            let entry = entry?;
            if entry.file_type()?.is_dir() {
                stack.push(entry.path());
                continue;
            }
            let old = |e: &fs::DirEntry| -> io::Result<bool> {
                if e.file_name().to_str().is_some_and(writer_has_ended) {
                    return Ok(true);
                }
                let age = e.metadata()?.modified()?.elapsed().unwrap_or_default();
                Ok(age >= min_age)
            };
            removed += usize::from(remove_if_temp(&entry, old)?);
        }
    }
    Ok(removed)
}

/// A file written in place of `path` through a temp file in the same directory,
/// for outputs streamed in pieces (the run log). [`AtomicFile::commit`] fsyncs
/// it and renames it over `path`; dropping it uncommitted removes the temp file,
/// so `path` only ever appears complete.
#[derive(Debug)]
pub struct AtomicFile {
    file: Option<File>,
    temp: PathBuf,
    path: PathBuf,
}

impl AtomicFile {
    /// Creates the temp file for `path` (which must name a file in an existing
    /// directory).
    pub fn create(path: &Path) -> io::Result<AtomicFile> {
        let (dir, name) = split(path)?;
        let (file, temp) = create_temp(dir, name)?;
        Ok(AtomicFile {
            file: Some(file),
            temp,
            path: path.to_path_buf(),
        })
    }

    fn file(&mut self) -> &mut File {
        self.file.as_mut().expect("present until commit or drop")
    }

    /// Bytes written so far (the temp file's length).
    pub fn size(&self) -> io::Result<u64> {
        let file = self.file.as_ref().expect("present until commit or drop");
        Ok(file.metadata()?.len())
    }

    /// The final path.
    pub fn path(&self) -> &Path {
        &self.path
    }

    /// Fsyncs the temp file, renames it over the final path and fsyncs the
    /// directory. On error the temp file is removed.
    pub fn commit(mut self) -> io::Result<()> {
        let file = self.file.take().expect("present until commit or drop");
        let result = (|| {
            file.sync_all()?;
            drop(file);
            fs::rename(&self.temp, &self.path)?;
            sync_dir(split(&self.path)?.0)
        })();
        if result.is_err() {
            let _ = fs::remove_file(&self.temp);
        }
        // Renamed (or removed): nothing is left for drop to clean up.
        self.temp = PathBuf::new();
        result
    }
}

impl Write for AtomicFile {
    fn write(&mut self, buf: &[u8]) -> io::Result<usize> {
        self.file().write(buf)
    }

    fn flush(&mut self) -> io::Result<()> {
        self.file().flush()
    }
}

impl Seek for AtomicFile {
    fn seek(&mut self, pos: SeekFrom) -> io::Result<u64> {
        self.file().seek(pos)
    }
}

impl Drop for AtomicFile {
    fn drop(&mut self) {
        if !self.temp.as_os_str().is_empty() {
            // Best effort, as in `write_atomic_with`.
            let _ = fs::remove_file(&self.temp);
        }
    }
}

/// Makes a rename durable by syncing the directory entry (Unix only; elsewhere the
/// platform offers no portable way and the rename itself is the commit point).
fn sync_dir(dir: &Path) -> io::Result<()> {
    #[cfg(unix)]
    File::open(dir)?.sync_all()?;
    #[cfg(not(unix))]
    let _ = dir;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A killed process with this process's pid left temp files under the
    /// names this process is about to use (the container case: every process
    /// is PID 1). Writes must still succeed, and leave those files alone.
    #[test]
    fn temp_names_left_by_an_earlier_process_with_our_pid_are_skipped() {
        let dir = tempfile::tempdir().unwrap();
        let next = TEMP_COUNTER.load(Ordering::Relaxed);
        // Other tests in this process may take counters meanwhile; leave more
        // leftovers than they can plausibly use, but fewer than the attempts.
        let planted: Vec<PathBuf> = (next..next + 40)
            .map(|c| {
                let p = dir.path().join(temp_name(OsStr::new("run.mcap"), c));
                fs::write(&p, b"leftover").unwrap();
                p
            })
            .collect();
        let target = dir.path().join("run.mcap");
        write_atomic(&target, b"fresh").unwrap();
        assert_eq!(fs::read(&target).unwrap(), b"fresh");
        let mut streamed = AtomicFile::create(&dir.path().join("other")).unwrap();
        streamed.write_all(b"x").unwrap();
        streamed.commit().unwrap();
        assert!(planted.iter().all(|p| p.is_file()));
        assert_eq!(remove_stale_temps(dir.path()).unwrap(), planted.len());
        assert!(dir.path().join("run.mcap").is_file() && dir.path().join("other").is_file());
    }
}
