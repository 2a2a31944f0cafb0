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
    let temp = temp_path(dir, name);
    let result = (|| {
        let mut file = File::create_new(&temp)?;
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

/// A fresh temp name for `name` in `dir`, unique within and across processes.
fn temp_path(dir: &Path, name: &OsStr) -> PathBuf {
    dir.join(format!(
        "{TEMP_PREFIX}{}-{}-{}",
        name.to_string_lossy(),
        std::process::id(),
        TEMP_COUNTER.fetch_add(1, Ordering::Relaxed)
    ))
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
        let temp = temp_path(dir, name);
        let file = File::create_new(&temp)?;
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
