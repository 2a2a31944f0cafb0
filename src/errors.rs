//! Error reports for people: an error and its causes on one line, each cause
//! said once.
//!
//! Many errors print their cause inside their own message *and* return it as
//! their source (`"{path}: {source}"`), so printing the chain naively says
//! the root cause twice (`No space left on device (os error 28): No space
//! left on device (os error 28)`), while printing only the top message can
//! hide it (`I/O error from writing, or reading a compression stream`). A
//! report here walks the whole chain and skips a cause whose text the report
//! already contains.

use std::error::Error;
use std::io;

/// `error` and every cause not already said, joined with `": "`.
pub fn chain(error: &dyn Error) -> String {
    let mut report = error.to_string();
    let mut source = error.source();
    while let Some(cause) = source {
        let text = cause.to_string();
        if !report.contains(&text) {
            report.push_str(": ");
            report.push_str(&text);
        }
        source = cause.source();
    }
    report
}

/// True when `error` or one of its causes is a write to a closed pipe (the
/// reader of our output went away, as `repose inspect F | head` does): not a
/// failure to report.
pub fn is_broken_pipe(error: &(dyn Error + 'static)) -> bool {
    let mut current = Some(error);
    while let Some(e) = current {
        if e.downcast_ref::<io::Error>()
            .is_some_and(|e| e.kind() == io::ErrorKind::BrokenPipe)
        {
            return true;
        }
        current = e.source();
    }
    false
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::log::LogError;

    fn no_space() -> io::Error {
        io::Error::from_raw_os_error(28)
    }

    /// A full disk while the log is written: the MCAP writer's own message
    /// says only "I/O error"; the report must name the root cause, once.
    #[test]
    fn a_full_disk_under_the_log_writer_is_named_once() {
        let error = LogError::Mcap(mcap::McapError::Io(no_space()));
        let report = chain(&error);
        assert_eq!(
            report.matches("No space left on device").count(),
            1,
            "{report}"
        );
        assert!(report.starts_with("run log: "), "{report}");
        let store = crate::store::StoreError::Io {
            path: "runs/x/result.json".into(),
            source: no_space(),
        };
        let report = chain(&store);
        assert_eq!(report.matches("os error 28").count(), 1, "{report}");
    }

    #[test]
    fn a_closed_pipe_is_recognised_through_wrappers() {
        let pipe = crate::store::StoreError::Io {
            path: "-".into(),
            source: io::Error::from(io::ErrorKind::BrokenPipe),
        };
        assert!(is_broken_pipe(&pipe));
        assert!(!is_broken_pipe(&LogError::Mcap(mcap::McapError::Io(
            no_space()
        ))));
    }
}
