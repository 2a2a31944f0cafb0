//! Seals: the record that makes a run complete and lets a reader check it.
//!
//! `seal.json` is the last file a successful run writes. It lists the size and
//! sha256 of every deterministic file of the run (manifest.json, result.json
//! and, when the runner wrote one, run.mcap; never timing.json, which differs
//! between identical runs). A run is complete exactly when its seal exists and
//! every file still matches it, so a one-byte edit, a truncated or deleted
//! file, or a manifest whose hash no longer equals the run id is *damaged*,
//! never a silent cache hit. The seal itself is deterministic: identical
//! manifests give byte-identical seals.
//!
//! Checking costs one read and hash of each sealed file, far below the cost
//! of the simulation that wrote them (measured: `docs/performance.md`). A
//! listing of many runs ([`Depth::Sizes`]) hashes the
//! small JSON files and only compares the log's length, so it stays quick for
//! stores of large logs; a cache hit, `runs show` and `audit` hash everything
//! ([`Depth::Full`]).

use std::collections::BTreeMap;
use std::fs::File;
use std::io::{self, Read};
use std::path::Path;

use serde::{Deserialize, Serialize};
use sha2::{Digest, Sha256};

use super::{RunDir, RunResult, MANIFEST_FILE, MCAP_FILE, RESULT_FILE};
use crate::manifest::ContentId;

/// File name of the seal inside a run directory.
pub const SEAL_FILE: &str = "seal.json";

/// The files a seal covers, in the order they are checked.
const SEALED_FILES: [&str; 3] = [MANIFEST_FILE, RESULT_FILE, MCAP_FILE];

/// What `seal.json` holds.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Seal {
    /// The run id (sha256 of manifest.json).
    pub id: ContentId,
    /// Every sealed file present when the run finished, by name.
    pub files: BTreeMap<String, FileDigest>,
}

/// Size and hash of one sealed file.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct FileDigest {
    /// Length, bytes.
    pub bytes: u64,
    /// sha256 of the bytes, lowercase hex.
    pub sha256: String,
}

/// How thoroughly [`check`] reads the sealed files.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Depth {
    /// Hash manifest.json and result.json; compare the log's length only.
    Sizes,
    /// Hash every sealed file.
    Full,
}

impl FileDigest {
    /// The size and sha256 of the file at `path`, read in pieces.
    pub fn of_file(path: &Path) -> io::Result<FileDigest> {
        let mut file = File::open(path)?;
        let mut hasher = Sha256::new();
        // No larger than the file: a 1 MiB buffer is a huge-page mapping
        // (`crate::huge_pages`) whose 2 MiB the kernel zeroes for every small
        // file (measured: docs/performance.md, src/store/seal.rs).
        let len = file.metadata()?.len();
        let mut buf = vec![0u8; len.clamp(1, 1 << 20) as usize];
        let mut bytes = 0u64;
        loop {
            let n = file.read(&mut buf)?;
            if n == 0 {
                break;
            }
            hasher.update(&buf[..n]);
            bytes += n as u64;
        }
        Ok(FileDigest {
            bytes,
            sha256: hex::encode(hasher.finalize()),
        })
    }

    /// The size and sha256 of `bytes`.
    pub fn of_bytes(bytes: &[u8]) -> FileDigest {
        FileDigest {
            bytes: bytes.len() as u64,
            sha256: hex::encode(Sha256::digest(bytes)),
        }
    }
}

/// The seal of the run in `dir` as its files are now (each of
/// [`SEALED_FILES`] that exists).
pub fn seal_of(dir: &RunDir) -> io::Result<Seal> {
    let mut files = BTreeMap::new();
    for name in SEALED_FILES {
        let path = dir.path().join(name);
        match FileDigest::of_file(&path) {
            Ok(digest) => {
                files.insert(name.to_string(), digest);
            }
            Err(e) if e.kind() == io::ErrorKind::NotFound && name == MCAP_FILE => {}
            Err(e) => return Err(e),
        }
    }
    Ok(Seal {
        id: dir.id().clone(),
        files,
    })
}

/// Checks the run in `dir` against `seal` and returns its result, or what is
/// wrong (naming the file) when it is damaged.
pub fn check(dir: &RunDir, seal: &Seal, depth: Depth) -> Result<RunResult, String> {
    if &seal.id != dir.id() {
        return Err(format!("{SEAL_FILE} names run {}", seal.id));
    }
    for name in [MANIFEST_FILE, RESULT_FILE] {
        if !seal.files.contains_key(name) {
            return Err(format!("{SEAL_FILE} does not cover {name}"));
        }
    }
    let mut result_bytes = Vec::new();
    for (name, sealed) in &seal.files {
        if !SEALED_FILES.contains(&name.as_str()) {
            return Err(format!("{SEAL_FILE} covers an unknown file {name}"));
        }
        let path = dir.path().join(name);
        let size = match std::fs::metadata(&path) {
            Ok(m) => m.len(),
            Err(e) if e.kind() == io::ErrorKind::NotFound => {
                return Err(format!("{name} is missing"))
            }
            Err(e) => return Err(format!("{name}: {e}")),
        };
        if size != sealed.bytes {
            return Err(format!(
                "{name} has {size} bytes, {} when the run finished",
                sealed.bytes
            ));
        }
        if depth == Depth::Sizes && name == MCAP_FILE {
            continue;
        }
        let digest = if name == RESULT_FILE {
            result_bytes = std::fs::read(&path).map_err(|e| format!("{name}: {e}"))?;
            FileDigest::of_bytes(&result_bytes)
        } else {
            FileDigest::of_file(&path).map_err(|e| format!("{name}: {e}"))?
        };
        if digest.sha256 != sealed.sha256 {
            return Err(format!(
                "{name} changed since the run finished (sha256 {} sealed, {} now)",
                sealed.sha256, digest.sha256
            ));
        }
        if name == MANIFEST_FILE && digest.sha256 != dir.id().as_str() {
            return Err(format!(
                "{name} hashes to {}, not to the run id",
                digest.sha256
            ));
        }
    }
    let result: RunResult = serde_json::from_slice(&result_bytes)
        .map_err(|e| format!("{RESULT_FILE} does not parse: {e}"))?;
    if &result.id != dir.id() {
        return Err(format!("{RESULT_FILE} names run {}", result.id));
    }
    Ok(result)
}
