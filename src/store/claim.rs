//! Claims: at most one process computes a run at a time.
//!
//! Before computing run `<id>`, a process takes an exclusive lock on
//! `<id>/.claim` (an advisory `flock`, through [`File::lock`]). A second
//! process that wants the same run blocks on the lock, and once it has it,
//! finds the first one's sealed result and reuses it instead of simulating
//! again. The operating system drops a lock when its holder exits, however it
//! exits, so a killed owner never leaves a run claimed forever — unlike a
//! lock *file* whose existence is the lock. The empty `.claim` file stays
//! behind; it is a dot-file, so nothing mistakes it for an output.
//!
//! Holding the claim also means no live process writes into the run
//! directory, so whatever temp files it holds are leftovers of killed writers
//! and are removed ([`super::atomic::remove_stale_temps`]).
//!
//! On a shared file system the lock is only as good as the file system's
//! locking: Linux maps `flock` on NFS to NFS byte-range locks (NFSv4, or v3
//! with the lock manager running), which is what cluster stores use.

use std::fs::{File, OpenOptions, TryLockError};
use std::io;
use std::path::Path;

/// File name of the lock inside a run directory.
pub const CLAIM_FILE: &str = ".claim";

/// A held claim on one run directory; dropping it releases the lock.
#[derive(Debug)]
pub struct Claim {
    // Kept open for the lock's lifetime; closing releases it.
    _file: File,
}

/// Claims the run directory `dir` (which must exist), waiting for another
/// holder to finish. `on_wait` is called once, before blocking, when the run is
/// already claimed, so a caller can say why it waits.
pub fn claim(dir: &Path, on_wait: impl FnOnce()) -> io::Result<Claim> {
    let file = OpenOptions::new()
        .create(true)
        .truncate(false)
        .write(true)
        .open(dir.join(CLAIM_FILE))?;
    match file.try_lock() {
        Ok(()) => {}
        Err(TryLockError::WouldBlock) => {
            on_wait();
            file.lock()?;
        }
        Err(TryLockError::Error(e)) => return Err(e),
    }
    Ok(Claim { _file: file })
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::sync::mpsc;
    use std::time::Duration;

    #[test]
    fn a_second_claim_waits_until_the_first_is_dropped() {
        let dir = tempfile::tempdir().unwrap();
        let first = claim(dir.path(), || panic!("nobody holds it yet")).unwrap();
        let (waiting, waited) = mpsc::channel();
        let (done, finished) = mpsc::channel();
        let path = dir.path().to_path_buf();
        let second = std::thread::spawn(move || {
            let c = claim(&path, || waiting.send(()).unwrap()).unwrap();
            done.send(()).unwrap();
            drop(c);
        });
        waited.recv_timeout(Duration::from_secs(10)).unwrap();
        assert!(
            finished.recv_timeout(Duration::from_millis(200)).is_err(),
            "the second claim must block while the first is held"
        );
        drop(first);
        finished.recv_timeout(Duration::from_secs(10)).unwrap();
        second.join().unwrap();
    }
}
