//! Finding runs: listing the store and resolving an id prefix.

use super::{Depth, RunState, RunStatus, Store, StoreError};
use crate::manifest::{ContentId, Experiment};
use crate::store::RunResult;

/// One run as shown by `repose runs list`. Manifest and result are `None` when
/// absent or unreadable (the status still says what the directory holds).
#[derive(Debug, Clone)]
pub struct RunSummary {
    /// The run id.
    pub id: ContentId,
    /// Its state.
    pub status: RunStatus,
    /// What is wrong with a damaged run, naming the file.
    pub problem: Option<String>,
    /// Its manifest.
    pub experiment: Option<Experiment>,
    /// Its result, when complete.
    pub result: Option<RunResult>,
}

impl RunSummary {
    /// The summary of run `id` found in `state`, with its manifest.
    pub fn new(id: ContentId, state: RunState, experiment: Option<Experiment>) -> RunSummary {
        let status = state.status();
        let (result, problem) = match state {
            RunState::Complete(r) => (Some(*r), None),
            RunState::Damaged(p) => (None, Some(p)),
            _ => (None, None),
        };
        RunSummary {
            id,
            status,
            problem,
            experiment,
            result,
        }
    }

    /// The header of [`RunSummary::row`]'s table (`repose runs list`).
    pub const HEADER: [&'static str; 8] = [
        "ID",
        "SCENE",
        "PROFILE",
        "e_pp",
        "mu_pp",
        "Γ_pp J/m²",
        "STATUS",
        "ANGLE deg",
    ];

    /// One line of `repose runs list`: id prefix, scene, profile, the
    /// particle–particle restitution, friction and surface energy (J/m²), the
    /// status and the headline angle (degrees); `-` where unknown.
    pub fn row(&self) -> [String; 8] {
        let cell = |v: Option<f64>| v.map_or_else(|| "-".to_string(), |v| format!("{v:.4}"));
        let pp = self
            .experiment
            .as_ref()
            .map(|e| e.contact.particle_particle);
        [
            self.id.short(12).to_string(),
            self.experiment
                .as_ref()
                .map_or("?", |e| e.scene.kind())
                .to_string(),
            self.experiment
                .as_ref()
                .map_or("?", |e| e.profile.as_str())
                .to_string(),
            cell(pp.map(|p| p.restitution)),
            cell(pp.map(|p| p.static_friction)),
            cell(pp.map(|p| p.surface_energy_j_m2)),
            self.status.to_string(),
            self.result
                .as_ref()
                .and_then(|r| r.headline_angle_deg)
                .map_or_else(|| "-".to_string(), |a| format!("{a:.2}")),
        ]
    }
}

/// `cells` aligned as `repose runs list` prints them (widths 12, 11, 7, 7,
/// 7, 9, 10, 9; the numbers right-aligned).
pub fn runs_line(cells: &[impl AsRef<str>; 8]) -> String {
    let c: Vec<&str> = cells.iter().map(AsRef::as_ref).collect();
    format!(
        "{:<12}  {:<11}  {:<7}  {:>7}  {:>7}  {:>9}  {:<10}  {:>9}",
        c[0], c[1], c[2], c[3], c[4], c[5], c[6], c[7]
    )
}

impl Store {
    /// The ids of every run directory, sorted (other entries are ignored).
    pub fn ids(&self) -> Result<Vec<ContentId>, StoreError> {
        let entries = std::fs::read_dir(self.root()).map_err(StoreError::io(self.root()))?;
        let mut ids = Vec::new();
        for entry in entries {
            let entry = entry.map_err(StoreError::io(self.root()))?;
            if !entry.path().is_dir() {
                continue;
            }
            if let Some(id) = entry.file_name().to_str().and_then(ContentId::parse) {
                ids.push(id);
            }
        }
        ids.sort();
        Ok(ids)
    }

    /// A summary of every run, sorted by id. Each run is checked against its
    /// seal to [`Depth::Sizes`] (the logs' lengths, not their hashes), so a
    /// listing of large logs stays quick; `runs show` checks fully.
    pub fn list(&self) -> Result<Vec<RunSummary>, StoreError> {
        Ok(self
            .ids()?
            .into_iter()
            .map(|id| {
                let state = self.check(&id, Depth::Sizes);
                RunSummary::new(id.clone(), state, self.load_manifest(&id).ok())
            })
            .collect())
    }

    /// The one run id starting with `prefix`; an error names every candidate when
    /// the prefix is ambiguous.
    pub fn resolve_prefix(&self, prefix: &str) -> Result<ContentId, StoreError> {
        let hex = !prefix.is_empty()
            && prefix
                .bytes()
                .all(|b| b.is_ascii_digit() || (b'a'..=b'f').contains(&b));
        if !hex || prefix.len() > 64 {
            return Err(StoreError::BadPrefix {
                prefix: prefix.to_string(),
            });
        }
        let mut matches: Vec<ContentId> = self
            .ids()?
            .into_iter()
            .filter(|id| id.as_str().starts_with(prefix))
            .collect();
        match matches.len() {
            0 => Err(StoreError::NoMatch {
                prefix: prefix.to_string(),
                root: self.root().to_path_buf(),
            }),
            1 => Ok(matches.remove(0)),
            _ => Err(StoreError::Ambiguous {
                prefix: prefix.to_string(),
                candidates: matches,
            }),
        }
    }
}
