//! What a study directory (`<store>/studies/<name>-<id12>/`, see
//! [`crate::study::dir`]) holds, read without running anything: its files,
//! its stage directories, the run ids its CSV tables name and the time of
//! its last change; and which directory a `repose diff` or `repose studies`
//! argument names.
//!
//! A stage directory is any subdirectory but `slurm/` (the executor's
//! ledger, not a stage's output). A run id is any CSV cell of 64 lowercase
//! hex digits (`drum_id`, `experiment_id`, … : the tables name their runs
//! under several column names). Temp files of interrupted writers
//! ([`TEMP_PREFIX`]) are not the study's and are skipped.

use std::collections::BTreeSet;
use std::path::{Path, PathBuf};
use std::time::SystemTime;

use super::TrackingError;
use crate::manifest::ContentId;
use crate::report::table::Table;
use crate::store::seal::FileDigest;
use crate::store::{StoreError, TEMP_PREFIX};

/// The file a study directory keeps its study in.
pub const STUDY_FILE: &str = "study.json";

/// `<store>/studies`.
pub fn studies_dir(store_root: &Path) -> PathBuf {
    store_root.join("studies")
}

/// Every study directory of the store (those holding a [`STUDY_FILE`]),
/// sorted by name.
pub fn study_dirs(store_root: &Path) -> Result<Vec<PathBuf>, TrackingError> {
    let dir = studies_dir(store_root);
    if !dir.is_dir() {
        return Ok(Vec::new());
    }
    let mut out: Vec<PathBuf> = std::fs::read_dir(&dir)
        .map_err(StoreError::io(&dir))?
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| p.join(STUDY_FILE).is_file())
        .collect();
    out.sort();
    Ok(out)
}

/// The study id: sha256 of the directory's study.json (its canonical JSON).
pub fn study_id(dir: &Path) -> Result<ContentId, TrackingError> {
    let path = dir.join(STUDY_FILE);
    let digest = FileDigest::of_file(&path).map_err(StoreError::io(&path))?;
    Ok(ContentId::parse(&digest.sha256).expect("a sha256 in hex is an id"))
}

/// The study directory `given` names: a directory holding a study.json, or
/// the one study of the store whose directory name or id starts with it.
pub fn resolve_study(store_root: &Path, given: &str) -> Result<PathBuf, TrackingError> {
    let path = Path::new(given);
    if path.join(STUDY_FILE).is_file() {
        return Ok(path.to_path_buf());
    }
    let mut matches = Vec::new();
    for dir in study_dirs(store_root)? {
        let name = dir.file_name().map(|n| n.to_string_lossy().into_owned());
        let by_name = name.as_deref().is_some_and(|n| n.starts_with(given));
        if by_name || study_id(&dir)?.as_str().starts_with(given) {
            matches.push(dir);
        }
    }
    match matches.len() {
        1 => Ok(matches.remove(0)),
        0 => Err(TrackingError::NoStudy {
            given: given.to_string(),
            studies: studies_dir(store_root),
        }),
        _ => Err(TrackingError::AmbiguousStudy {
            given: given.to_string(),
            candidates: matches.iter().map(|d| d.display().to_string()).collect(),
        }),
    }
}

/// Every file below `dir`, as paths relative to it, sorted (temp files left
/// out).
pub fn files(dir: &Path) -> Result<Vec<PathBuf>, TrackingError> {
    let mut out = Vec::new();
    let mut stack = vec![dir.to_path_buf()];
    while let Some(d) = stack.pop() {
        for entry in std::fs::read_dir(&d).map_err(StoreError::io(&d))? {
            let path = entry.map_err(StoreError::io(&d))?.path();
            let temp = path
                .file_name()
                .is_some_and(|n| n.to_string_lossy().starts_with(TEMP_PREFIX));
            if path.is_dir() {
                stack.push(path);
            } else if !temp {
                out.push(path.strip_prefix(dir).unwrap_or(&path).to_path_buf());
            }
        }
    }
    out.sort();
    Ok(out)
}

/// The stage directories of a study directory (every subdirectory but
/// `slurm`), sorted.
pub fn stages(dir: &Path) -> Result<Vec<String>, TrackingError> {
    let mut out: Vec<String> = std::fs::read_dir(dir)
        .map_err(StoreError::io(dir))?
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| p.is_dir())
        .filter_map(|p| p.file_name().map(|n| n.to_string_lossy().into_owned()))
        .filter(|n| n != "slurm")
        .collect();
    out.sort();
    Ok(out)
}

/// The run ids named by the CSV tables below `dir` (`files` relative to it).
pub fn run_ids(dir: &Path, files: &[PathBuf]) -> Result<BTreeSet<ContentId>, TrackingError> {
    let mut ids = BTreeSet::new();
    for file in files
        .iter()
        .filter(|f| f.extension().is_some_and(|e| e == "csv"))
    {
        let text =
            std::fs::read_to_string(dir.join(file)).map_err(StoreError::io(&dir.join(file)))?;
        let Ok(table) = Table::parse(&text) else {
            continue; // not a table (an empty file): it names no run
        };
        let cells = table.rows.iter().flatten();
        ids.extend(
            cells
                .filter(|c| c.len() == 64)
                .filter_map(|c| ContentId::parse(c)),
        );
    }
    Ok(ids)
}

/// The newest modification time of any file below `dir` (the directory's
/// own when it holds none).
pub fn last_change(dir: &Path, files: &[PathBuf]) -> Result<SystemTime, TrackingError> {
    let mut newest = std::fs::metadata(dir)
        .and_then(|m| m.modified())
        .map_err(StoreError::io(dir))?;
    for file in files {
        let path = dir.join(file);
        let modified = std::fs::metadata(&path)
            .and_then(|m| m.modified())
            .map_err(StoreError::io(&path))?;
        newest = newest.max(modified);
    }
    Ok(newest)
}

/// `time` as ISO-8601 UTC to the second (`2026-11-28T06:53:31Z`).
pub fn iso8601(time: SystemTime) -> String {
    let secs = time
        .duration_since(SystemTime::UNIX_EPOCH)
        .map_or(0, |d| d.as_secs());
    let (days, rest) = (secs / 86_400, secs % 86_400);
    // Civil date from days since 1970-01-01 (Hinnant's days_from_civil, inverted).
    let z = days as i64 + 719_468;
    let era = z.div_euclid(146_097);
    let doe = z - era * 146_097;
    let yoe = (doe - doe / 1460 + doe / 36_524 - doe / 146_096) / 365;
    let doy = doe - (365 * yoe + yoe / 4 - yoe / 100);
    let mp = (5 * doy + 2) / 153;
    let day = doy - (153 * mp + 2) / 5 + 1;
    let month = if mp < 10 { mp + 3 } else { mp - 9 };
    let year = yoe + era * 400 + i64::from(month <= 2);
    format!(
        "{year:04}-{month:02}-{day:02}T{:02}:{:02}:{:02}Z",
        rest / 3600,
        rest % 3600 / 60,
        rest % 60
    )
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::time::Duration;

    #[test]
    fn iso8601_matches_known_dates() {
        let at = |s: u64| iso8601(SystemTime::UNIX_EPOCH + Duration::from_secs(s));
        assert_eq!(at(0), "1970-01-01T00:00:00Z");
        // date -u -d @1795849211
        assert_eq!(at(1_795_849_211), "2026-11-28T07:00:11Z");
        assert_eq!(at(951_782_400), "2000-02-29T00:00:00Z");
    }
}
