//! The study model: every study is a list of stages, as data. A study file
//! (he2019's calibration study, or a design study) is read once into a
//! [`StudyFile`] and lowered to a [`StudySpec`]: its method and the stages it
//! runs, in order, each with the kind it uses (which design, which
//! surrogates, which search, how many seeds). The commands pick what to run
//! from the spec's [`Method`] — the one place the method is decided — and
//! `repose stages FILE` prints the list, so a user sees what a study will do
//! before it spends an hour of CPU.
//!
//! | method | stages |
//! | --- | --- |
//! | he2019 | design (LHS) → simulate → fit (GA-BP) → search (tolerance) → verify |
//! | he2019, noise-aware | noise → design (LHS) → simulate (replicates) → fit (GP, GA-BP) → [adaptive] → search (probability) → verify |
//! | he2019, two-level (`noise_aware.fidelity`) | noise → design (LHS) → simulate (replicates) → fit (GP, GA-BP) → fine (points by the two-level GP, its fit) → search (probability, fine level) → verify (fine size) |
//! | response surface (cai2024) | [screen] → design (Box–Behnken, full factorial or LHS) → simulate → fit (quadratic, or a GP with `fit: "gp"`) → search (desirability) → [verify] |
//! | sensitivity (yan2015) | design (full factorial) → simulate → fit (power law) → sensitivity → [verify] |
//!
//! A design study runs as a response surface (`repose rsm`) or a
//! sensitivity analysis (`repose sensitivity`): the same document, two
//! stage lists. The noise floor of one experiment (`repose noise MANIFEST`)
//! the tradeoff sweep (`repose tradeoff`) and the particle-size sweep
//! (`repose convergence`) are one-stage studies of a manifest
//! ([`StudySpec::noise_floor`], [`StudySpec::tradeoff`],
//! [`StudySpec::convergence`]).

pub mod calibration;
pub mod design_study;

use std::path::Path;

use serde::Serialize;

use crate::manifest::{
    parse_study, ContentId, DesignKind, FieldError, ManifestError, Study, ValidationErrors,
};
use crate::study::plan::design_study::{
    is_design_study, parse_design_study, DesignSpec, DesignStudy, FitChoice,
};

/// A study file, read and validated once.
#[derive(Debug, Clone)]
pub enum StudyFile {
    /// he2019's calibration study (`parameters`, `calibration`, …).
    Calibration(Study),
    /// A design study (`factors`, `design`, `responses`, …).
    Design(DesignStudy),
}

impl StudyFile {
    /// Reads and validates the study file at `path` (a design study when it
    /// has a `factors` object), including the stages it spells out
    /// ([`StudyFile::spec`]).
    pub fn read(path: &Path) -> Result<StudyFile, ManifestError> {
        let text = std::fs::read_to_string(path).map_err(|source| ManifestError::Io {
            path: path.to_path_buf(),
            source,
        })?;
        StudyFile::parse(&text)
    }

    /// [`StudyFile::read`] of a study file's text.
    pub fn parse(text: &str) -> Result<StudyFile, ManifestError> {
        let file = if is_design_study(text) {
            parse_design_study(text).map(StudyFile::Design)
        } else {
            parse_study(text).map(StudyFile::Calibration)
        }?;
        file.spec(None, false)?;
        Ok(file)
    }

    /// The study's content id.
    pub fn id(&self) -> ContentId {
        match self {
            StudyFile::Calibration(s) => s.id(),
            StudyFile::Design(s) => s.id(),
        }
    }

    /// The stages the file spells out (empty: none).
    pub fn spelled(&self) -> &[String] {
        match self {
            StudyFile::Calibration(s) => &s.stages,
            StudyFile::Design(s) => &s.stages,
        }
    }

    /// The analysis a design study's spelled stages choose: `sensitivity`
    /// names yan2015's levels, any other list a response surface.
    pub fn spelled_analysis(&self) -> Option<Analysis> {
        let spelled = self.spelled();
        match self {
            StudyFile::Design(_) if !spelled.is_empty() => {
                Some(if spelled.iter().any(|s| s == "sensitivity") {
                    Analysis::Sensitivity
                } else {
                    Analysis::ResponseSurface
                })
            }
            _ => None,
        }
    }

    /// Whether the spelled stages name the adaptive rounds.
    pub fn spells_adaptive(&self) -> bool {
        names_adaptive(self.spelled())
    }

    /// The study's stage list, run with `analysis` (a command's, or the
    /// file's own when `None`; a response surface when neither says) and
    /// `adaptive` rounds (or the file's own `adaptive` stage). A file that
    /// spells its stages must spell exactly this list, and a command's
    /// analysis must be the one it spells; each error names `stages`, what
    /// it holds and the list the study's blocks give.
    pub fn spec(
        &self,
        analysis: Option<Analysis>,
        adaptive: bool,
    ) -> Result<StudySpec, ManifestError> {
        let invalid = |rule: String| {
            ManifestError::Invalid(ValidationErrors(vec![FieldError {
                path: "stages".into(),
                value: format!("[{}]", self.spelled().join(", ")),
                rule,
            }]))
        };
        let analysis = match (analysis, self.spelled_analysis()) {
            (Some(asked), Some(spelled)) if asked != spelled => {
                return Err(invalid(format!(
                    "spells a {} study; run it with `repose {}`",
                    word(&spelled).replace('_', " "),
                    command_of(spelled)
                )))
            }
            (asked, spelled) => asked.or(spelled).unwrap_or(Analysis::ResponseSurface),
        };
        if let StudyFile::Calibration(s) = self {
            if s.fidelity().is_some() && (adaptive || self.spells_adaptive()) {
                let (path, value) = if self.spells_adaptive() {
                    (
                        "stages".to_string(),
                        format!("[{}]", self.spelled().join(", ")),
                    )
                } else {
                    ("--adaptive".to_string(), "(given)".to_string())
                };
                let own = StudySpec::of(self, analysis, false);
                let names: Vec<&str> = own.stages.iter().map(Stage::name).collect();
                return Err(ManifestError::Invalid(ValidationErrors(vec![FieldError {
                    path,
                    value,
                    rule: format!(
                        "asks for the adaptive rounds, which a two-level study \
                         (noise_aware.fidelity) does not run: its fine stage chooses the fine \
                         points by the two-level model instead; the stages the study's blocks \
                         give: [{}]",
                        names.join(", ")
                    ),
                }])));
            }
        }
        let spec = StudySpec::of(self, analysis, adaptive || self.spells_adaptive());
        let names: Vec<&str> = spec.stages.iter().map(Stage::name).collect();
        if self.spelled().is_empty() || self.spelled() == names.as_slice() {
            return Ok(spec);
        }
        let mut allowed = format!(
            "must be the stages the study's blocks give: [{}]",
            names.join(", ")
        );
        match self {
            StudyFile::Calibration(s) if s.noise_aware.is_some() && s.fidelity().is_none() => {
                allowed.push_str(", with `adaptive` after `fit` for the adaptive rounds")
            }
            StudyFile::Design(_) if analysis == Analysis::Sensitivity => allowed.push_str(
                " for yan2015's sensitivity levels, or with `search` in place of \
                 `sensitivity` (and `screen` first when the study screens) for a response \
                 surface",
            ),
            StudyFile::Design(_) => allowed.push_str(
                " for a response surface, or with `sensitivity` in place of `search` (and no \
                 `screen`) for yan2015's sensitivity levels",
            ),
            StudyFile::Calibration(_) => {}
        }
        Err(invalid(allowed))
    }
}

/// Whether a spelled stage list names the adaptive rounds (they then run
/// as with `--adaptive`).
pub fn names_adaptive(stages: &[String]) -> bool {
    stages.iter().any(|s| s == "adaptive")
}

/// The subcommand that runs a design study's analysis.
fn command_of(analysis: Analysis) -> &'static str {
    match analysis {
        Analysis::ResponseSurface => "rsm",
        Analysis::Sensitivity => "sensitivity",
    }
}

/// Which analysis a design study runs.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Analysis {
    /// Quadratic response surfaces, desirability, verification (`repose rsm`).
    ResponseSurface,
    /// yan2015's power laws and sensitivity levels (`repose sensitivity`).
    Sensitivity,
}

/// A study's method: which driver runs its stages.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Method {
    /// he2019 as published: one packing per sample, the GA-BP network.
    He2019,
    /// he2019 with a noise floor, replicates, a GP and seeds in verification.
    He2019NoiseAware,
    /// A design study analysed by response surfaces (cai2024 and others).
    ResponseSurface,
    /// A design study analysed by yan2015's sensitivity levels.
    Sensitivity,
    /// One experiment over packing seeds (`repose noise MANIFEST`).
    NoiseFloor,
    /// Fidelity knobs around one experiment (`repose tradeoff`).
    Tradeoff,
    /// One experiment over particle sizes (`repose convergence`).
    Convergence,
}

impl Method {
    /// The driver of a calibration study: noise-aware when it has a
    /// `noise_aware` block.
    pub fn of_calibration(study: &Study) -> Method {
        if study.noise_aware.is_some() {
            Method::He2019NoiseAware
        } else {
            Method::He2019
        }
    }
}

/// The design of experiments.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum DesignOf {
    /// Latin hypercube.
    Lhs,
    /// Latin hypercube optimised for space filling.
    OptimisedLhs,
    /// Every combination of levels.
    FullFactorial,
    /// Box–Behnken.
    BoxBehnken,
    /// One factor at a time (screening).
    OneFactor,
}

/// A surrogate the fit stage trains ([`crate::surrogate`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum FitKind {
    /// he2019's GA-BP network.
    GaBp,
    /// Gaussian process.
    Gp,
    /// Quadratic response surface with ANOVA.
    Quadratic,
    /// yan2015's power law.
    PowerLaw,
}

/// How the search stage picks parameter sets ([`crate::search`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum SearchKind {
    /// Predicted mean within the tolerance of the target.
    Tolerance,
    /// Probability of the target band under the GP.
    Probability,
    /// Derringer–Suich desirability of every response.
    Desirability,
}

/// One stage of a study, with what it uses.
#[derive(Debug, Clone, PartialEq, Serialize)]
#[serde(tag = "stage", rename_all = "snake_case")]
pub enum Stage {
    /// The noise floor: one point over packing seeds.
    Noise {
        /// Packing seeds.
        seeds: u64,
    },
    /// One-factor screening with a one-way ANOVA.
    Screen {
        /// Screened factors.
        factors: usize,
        /// Levels over every screened factor.
        levels: u64,
        /// Seeds per level.
        replicates: u32,
        /// Scenes each level runs in.
        scenes: Vec<String>,
    },
    /// The design of experiments.
    Design {
        /// Which design.
        design: DesignOf,
        /// Factors (calibrated parameters).
        factors: usize,
    },
    /// The design's runs through the executor.
    Simulate {
        /// Scenes each point runs in.
        scenes: Vec<String>,
        /// Design points.
        points: u64,
        /// Packing seeds per point.
        replicates: u32,
    },
    /// Surrogates fitted on the response table.
    Fit {
        /// The surrogates, in the order they are fitted.
        models: Vec<FitKind>,
    },
    /// Design points again at a finer particle size, chosen by the
    /// two-level Gaussian process, which is fitted to both levels.
    Fine {
        /// Fine points (design points).
        points: u64,
        /// Packing seeds per fine point.
        replicates: u32,
        /// Fine particle radius / the study's.
        size: f64,
    },
    /// Rounds of points chosen by the GP until a candidate passes.
    Adaptive {
        /// Most runs the rounds may add.
        max_runs: u32,
    },
    /// Parameter sets that reproduce the targets.
    Search {
        /// How they are picked.
        search: SearchKind,
        /// Parameters whose main effect is below the noise are fixed at
        /// their centre first (noise-aware he2019 with `screen`).
        #[serde(skip_serializing_if = "std::ops::Not::not")]
        screen: bool,
    },
    /// yan2015's sensitivity levels.
    Sensitivity,
    /// Candidates re-simulated in every scene.
    Verify {
        /// Scenes each candidate runs in.
        scenes: Vec<String>,
        /// Candidates verified, at most (he2019: `--candidates`; a design
        /// study: its optimum and named points).
        points: u64,
        /// Packing seeds per candidate and scene (the fewest, when a power
        /// calculation may raise them).
        seeds: u32,
        /// Most seeds the calibration scene's power calculation may ask
        /// for (noise-aware he2019 with `max_verification_seeds`).
        #[serde(skip_serializing_if = "Option::is_none")]
        max_seeds: Option<u32>,
        /// Particle size of the verification runs / the study's (a
        /// two-level study verifies at its fine size).
        #[serde(skip_serializing_if = "Option::is_none")]
        size: Option<f64>,
    },
    /// The verified candidates at finer particle sizes, in every scene,
    /// with the verification's seeds.
    Transfer {
        /// Scenes each candidate runs in.
        scenes: Vec<String>,
        /// Candidates, at most (as verified).
        points: u64,
        /// Packing seeds per candidate and scene (the fewest, as verified).
        seeds: u32,
        /// Most seeds the verification's power calculation may have given
        /// the calibration scene.
        #[serde(skip_serializing_if = "Option::is_none")]
        max_seeds: Option<u32>,
        /// Particle radius / the verified one, each size.
        sizes: Vec<f64>,
    },
    /// Fidelity knobs swept with replicates.
    Tradeoff {
        /// Knobs swept.
        knobs: Vec<String>,
        /// Points: the reference and every coarser value of each knob.
        points: u64,
        /// Packing seeds per point.
        replicates: u64,
    },
    /// Particle sizes swept with replicates, each response's trend read at
    /// the real size.
    Convergence {
        /// Size levels.
        levels: u64,
        /// Packing seeds per level.
        replicates: u64,
    },
}

impl Stage {
    /// The stage's name (its directory and, where it has one, subcommand).
    pub fn name(&self) -> &'static str {
        match self {
            Stage::Noise { .. } => "noise",
            Stage::Screen { .. } => "screen",
            Stage::Design { .. } => "design",
            Stage::Simulate { .. } => "simulate",
            Stage::Fit { .. } => "fit",
            Stage::Fine { .. } => "fine",
            Stage::Adaptive { .. } => "adaptive",
            Stage::Search { .. } => "search",
            Stage::Sensitivity => "sensitivity",
            Stage::Verify { .. } => "verify",
            Stage::Transfer { .. } => "transfer",
            Stage::Tradeoff { .. } => "tradeoff",
            Stage::Convergence { .. } => "convergence",
        }
    }

    /// The most runs the stage may start (saturating: a count past
    /// `u64::MAX` reads as `u64::MAX`); 0 for a stage that runs nothing.
    pub fn runs(&self) -> u64 {
        match self {
            Stage::Noise { seeds } => *seeds,
            Stage::Screen {
                levels,
                replicates,
                scenes,
                ..
            } => levels
                .saturating_mul(u64::from(*replicates))
                .saturating_mul(scenes.len() as u64),
            Stage::Simulate {
                scenes,
                points,
                replicates,
            } => points
                .saturating_mul(scenes.len() as u64)
                .saturating_mul(u64::from(*replicates)),
            Stage::Fine {
                points, replicates, ..
            } => points.saturating_mul(u64::from(*replicates)),
            Stage::Adaptive { max_runs } => u64::from(*max_runs),
            Stage::Verify {
                scenes,
                points,
                seeds,
                max_seeds,
                ..
            } => points
                .saturating_mul(scenes.len() as u64)
                .saturating_mul(u64::from((*seeds).max(max_seeds.unwrap_or(0)))),
            Stage::Transfer {
                scenes,
                points,
                seeds,
                max_seeds,
                sizes,
            } => points
                .saturating_mul(scenes.len() as u64)
                .saturating_mul(u64::from((*seeds).max(max_seeds.unwrap_or(0))))
                .saturating_mul(sizes.len() as u64),
            Stage::Tradeoff {
                points, replicates, ..
            } => points.saturating_mul(*replicates),
            Stage::Convergence { levels, replicates } => levels.saturating_mul(*replicates),
            Stage::Design { .. }
            | Stage::Fit { .. }
            | Stage::Search { .. }
            | Stage::Sensitivity => 0,
        }
    }
}

/// A study as its method and stage list (module docs).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct StudySpec {
    /// The study's (or experiment's) name.
    pub name: String,
    /// Its id.
    pub id: ContentId,
    /// The driver.
    pub method: Method,
    /// The stages, in the order they run.
    pub stages: Vec<Stage>,
}

impl StudySpec {
    /// The stage list of a document; `analysis` says how a design study is
    /// analysed (ignored for a calibration study); `adaptive` adds the
    /// adaptive rounds of a noise-aware calibration, whose verification runs
    /// [`default_candidates`] candidates.
    pub fn of(document: &StudyFile, analysis: Analysis, adaptive: bool) -> StudySpec {
        match document {
            StudyFile::Calibration(study) => {
                StudySpec::calibration(study, adaptive, default_candidates(study))
            }
            StudyFile::Design(study) => StudySpec::design(study, analysis),
        }
    }

    /// he2019's stage list, classic or noise-aware, verifying `candidates`
    /// clusters.
    pub fn calibration(study: &Study, adaptive: bool, candidates: usize) -> StudySpec {
        let design = match study.design.kind {
            DesignKind::Lhs => DesignOf::Lhs,
            DesignKind::LhsOptimised => DesignOf::OptimisedLhs,
            DesignKind::FullFactorial => DesignOf::FullFactorial,
            DesignKind::BoxBehnken => DesignOf::BoxBehnken,
        };
        let factors = study.parameters.len();
        let points = design_points(design, study.design.size, factors);
        let calibration_scene = vec![study.calibration.name.clone()];
        let scenes: Vec<String> = std::iter::once(&study.calibration)
            .chain(&study.verification)
            .map(|t| t.name.clone())
            .collect();
        let candidates = candidates as u64;
        let method = Method::of_calibration(study);
        let stages = match &study.noise_aware {
            None => vec![
                Stage::Design { design, factors },
                Stage::Simulate {
                    scenes: calibration_scene,
                    points,
                    replicates: 1,
                },
                Stage::Fit {
                    models: vec![FitKind::GaBp],
                },
                Stage::Search {
                    search: SearchKind::Tolerance,
                    screen: false,
                },
                Stage::Verify {
                    scenes,
                    points: candidates,
                    seeds: 1,
                    max_seeds: None,
                    size: None,
                },
            ],
            Some(n) => {
                let mut stages = vec![
                    Stage::Noise {
                        seeds: u64::from(n.noise_seeds),
                    },
                    Stage::Design { design, factors },
                    Stage::Simulate {
                        scenes: calibration_scene,
                        points,
                        replicates: n.replicates,
                    },
                    Stage::Fit {
                        models: vec![FitKind::Gp, FitKind::GaBp],
                    },
                ];
                if let Some(f) = n.fidelity {
                    stages.push(Stage::Fine {
                        points: u64::from(f.fine_points),
                        replicates: f.fine_replicates,
                        size: f.fine_size,
                    });
                } else if adaptive {
                    stages.push(Stage::Adaptive {
                        max_runs: n.adaptive.max_runs,
                    });
                }
                stages.push(Stage::Search {
                    search: SearchKind::Probability,
                    screen: n.screen,
                });
                let fine = n.fidelity.map(|f| f.fine_size);
                stages.push(Stage::Verify {
                    scenes,
                    points: candidates,
                    seeds: n.verification_seeds,
                    // The noise floor is the coarse level's: no power
                    // calculation raises the fine seeds.
                    max_seeds: n.max_verification_seeds.filter(|_| fine.is_none()),
                    size: fine,
                });
                stages
            }
        };
        StudySpec {
            name: study.name.clone(),
            id: study.id(),
            method,
            stages,
        }
        .with_transfer(study.transfer.as_ref().map(|t| t.sizes.as_slice()))
    }

    /// The list with its transfer stage at `sizes` (after verification, with
    /// the verification's scenes, candidates and seeds), or without one.
    pub fn with_transfer(mut self, sizes: Option<&[f64]>) -> StudySpec {
        self.stages.retain(|s| !matches!(s, Stage::Transfer { .. }));
        let verify = self.stages.iter().find_map(|s| match s {
            Stage::Verify {
                scenes,
                points,
                seeds,
                max_seeds,
                ..
            } => Some((scenes.clone(), *points, *seeds, *max_seeds)),
            _ => None,
        });
        if let (Some(sizes), Some((scenes, points, seeds, max_seeds))) = (sizes, verify) {
            let mut sizes = sizes.to_vec();
            sizes.sort_by(|a, b| b.total_cmp(a));
            self.stages.push(Stage::Transfer {
                scenes,
                points,
                seeds,
                max_seeds,
                sizes,
            });
        }
        self
    }

    /// A design study's stage list for `analysis`.
    pub fn design(study: &DesignStudy, analysis: Analysis) -> StudySpec {
        let design = match study.design {
            DesignSpec::BoxBehnken { .. } => DesignOf::BoxBehnken,
            DesignSpec::FullFactorial { .. } => DesignOf::FullFactorial,
            DesignSpec::Lhs { .. } => DesignOf::Lhs,
        };
        let points = study.points();
        let scenes: Vec<String> = study.scenes.keys().cloned().collect();
        let mut stages = Vec::new();
        if let (Analysis::ResponseSurface, Some(s)) = (analysis, &study.screening) {
            stages.push(Stage::Screen {
                factors: s.factors.len(),
                levels: s.factors.values().map(|f| f.levels.len() as u64).sum(),
                replicates: s.replicates,
                scenes: scenes.clone(),
            });
        }
        stages.push(Stage::Design {
            design,
            factors: study.factors.len(),
        });
        stages.push(Stage::Simulate {
            scenes: scenes.clone(),
            points,
            replicates: study.replicates,
        });
        let method = match analysis {
            Analysis::ResponseSurface => {
                stages.push(Stage::Fit {
                    models: vec![match study.fit {
                        FitChoice::Quadratic => FitKind::Quadratic,
                        FitChoice::Gp => FitKind::Gp,
                    }],
                });
                stages.push(Stage::Search {
                    search: SearchKind::Desirability,
                    screen: false,
                });
                Method::ResponseSurface
            }
            Analysis::Sensitivity => {
                stages.push(Stage::Fit {
                    models: vec![FitKind::PowerLaw],
                });
                stages.push(Stage::Sensitivity);
                Method::Sensitivity
            }
        };
        if let Some(v) = &study.verification {
            stages.push(Stage::Verify {
                scenes,
                // The desirability optimum and every named point.
                points: 1 + v.points.len() as u64,
                seeds: v.replicates,
                max_seeds: None,
                size: None,
            });
        }
        StudySpec {
            name: study.name.clone(),
            id: study.id(),
            method,
            stages,
        }
    }

    /// The noise floor of one experiment over `seeds` packing seeds.
    pub fn noise_floor(name: &str, id: ContentId, seeds: u64) -> StudySpec {
        StudySpec {
            name: name.to_string(),
            id,
            method: Method::NoiseFloor,
            stages: vec![Stage::Noise { seeds }],
        }
    }

    /// The tradeoff sweep of `knobs` around one experiment: `points` (the
    /// reference and each coarser knob value) × `replicates` runs.
    pub fn tradeoff(
        name: &str,
        id: ContentId,
        knobs: Vec<String>,
        points: u64,
        replicates: u64,
    ) -> StudySpec {
        StudySpec {
            name: name.to_string(),
            id,
            method: Method::Tradeoff,
            stages: vec![Stage::Tradeoff {
                knobs,
                points,
                replicates,
            }],
        }
    }

    /// The particle-size sweep of one experiment: `levels` sizes ×
    /// `replicates` runs.
    pub fn convergence(name: &str, id: ContentId, levels: u64, replicates: u64) -> StudySpec {
        StudySpec {
            name: name.to_string(),
            id,
            method: Method::Convergence,
            stages: vec![Stage::Convergence { levels, replicates }],
        }
    }

    /// The most runs the study may start: every stage's [`Stage::runs`]
    /// (saturating).
    pub fn runs(&self) -> u64 {
        self.stages
            .iter()
            .fold(0u64, |n, s| n.saturating_add(s.runs()))
    }

    /// Refuses a study that may start more than `max_runs` runs, before
    /// anything is built (issue 40: a million replicates or a billion centre
    /// points once spun or ran out of memory); the message gives the count,
    /// each stage's share and the flag that raises the limit.
    pub fn check_runs(&self, max_runs: u64) -> Result<(), String> {
        let total = self.runs();
        if total <= max_runs {
            return Ok(());
        }
        let shares: Vec<String> = self
            .stages
            .iter()
            .filter(|s| s.runs() > 0)
            .map(|s| format!("{} {}", s.name(), count(s.runs())))
            .collect();
        Err(format!(
            "{}: up to {} runs ({}), more than --max-runs {}; make the study smaller or \
             raise --max-runs",
            self.name,
            count(total),
            shares.join(", "),
            count(max_runs)
        ))
    }

    /// The stage list as text: one numbered line per stage with what it uses.
    pub fn describe(&self) -> String {
        let mut s = format!(
            "{} ({}), method {}:\n",
            self.name,
            &self.id.to_string()[..12],
            word(&self.method)
        );
        for (i, stage) in self.stages.iter().enumerate() {
            let detail = match stage {
                Stage::Noise { seeds } => format!("{seeds} packing seeds at one point"),
                Stage::Screen {
                    factors,
                    levels,
                    replicates,
                    scenes,
                } => format!(
                    "{factors} factor(s) one at a time, {levels} level(s) x scenes {} x \
                     {replicates} seed(s) per level",
                    scenes.join(", ")
                ),
                Stage::Design { design, factors } => {
                    format!("{} over {factors} factor(s)", word(design))
                }
                Stage::Simulate {
                    scenes,
                    points,
                    replicates,
                } => format!(
                    "{points} point(s) x scenes {} x {replicates} seed(s) per point",
                    scenes.join(", ")
                ),
                Stage::Fit { models } => models.iter().map(word).collect::<Vec<_>>().join(", "),
                Stage::Fine {
                    points,
                    replicates,
                    size,
                } => format!(
                    "{points} design point(s) at particle size x {size} x {replicates} seed(s), \
                     chosen by the two-level GP's fine sd; the two-level GP fitted"
                ),
                Stage::Adaptive { max_runs } => format!("up to {max_runs} runs"),
                Stage::Search { search, screen } => {
                    let mut w = word(search);
                    if self.stages.iter().any(|s| matches!(s, Stage::Fine { .. })) {
                        w.push_str(" of the fine level");
                    }
                    if *screen {
                        w.push_str(", parameters below the noise fixed at their centre");
                    }
                    w
                }
                Stage::Sensitivity => "levels 1-3".to_string(),
                Stage::Verify {
                    scenes,
                    points,
                    seeds,
                    max_seeds,
                    size,
                } => {
                    let at = size.map_or(String::new(), |f| format!(" at particle size x {f}"));
                    let per = match max_seeds {
                        Some(max) => format!(
                            "{seeds} seed(s) per candidate and scene; the calibration scene's \
                             by power on the noise floor, up to {max}"
                        ),
                        None => format!("{seeds} seed(s) per candidate and scene"),
                    };
                    format!(
                        "up to {points} candidate(s) x scenes {}{at}, {per}",
                        scenes.join(", ")
                    )
                }
                Stage::Transfer {
                    scenes,
                    points,
                    seeds,
                    sizes,
                    ..
                } => format!(
                    "up to {points} verified candidate(s) x scenes {} at particle size(s) {} of \
                     the verified, the verification's seeds ({seeds} or more per candidate and \
                     scene) and rule",
                    scenes.join(", "),
                    sizes
                        .iter()
                        .map(|s| format!("x {s}"))
                        .collect::<Vec<_>>()
                        .join(", ")
                ),
                Stage::Tradeoff {
                    knobs,
                    points,
                    replicates,
                } => format!(
                    "{points} point(s) over knobs {} x {replicates} seed(s)",
                    knobs.join(", ")
                ),
                Stage::Convergence { levels, replicates } => {
                    format!("{levels} particle size(s) x {replicates} seed(s)")
                }
            };
            let runs = stage.runs();
            let runs = if runs > 0 {
                format!(" [up to {} runs]", count(runs))
            } else {
                String::new()
            };
            s.push_str(&format!("  {}. {}: {detail}{runs}\n", i + 1, stage.name()));
        }
        s.push_str(&format!("  at most {} runs in all\n", count(self.runs())));
        s
    }
}

/// The candidates `repose calibrate` verifies by default: 1 for a
/// noise-aware study (its candidate runs every scene with several seeds), 3
/// for he2019's classic method.
pub fn default_candidates(study: &Study) -> usize {
    if study.noise_aware.is_some() {
        1
    } else {
        3
    }
}

/// Design points of a calibration study's design without building it: an
/// LHS has `size` points, a full factorial `size` levels per factor, a
/// Box–Behnken 2k(k − 1) edge midpoints and `size` centre points
/// (saturating).
fn design_points(design: DesignOf, size: u64, factors: usize) -> u64 {
    let k = factors as u64;
    match design {
        DesignOf::Lhs | DesignOf::OptimisedLhs | DesignOf::OneFactor => size,
        DesignOf::FullFactorial => (0..factors).fold(1u64, |n, _| n.saturating_mul(size)),
        DesignOf::BoxBehnken => (2 * k * k.saturating_sub(1)).saturating_add(size),
    }
}

/// A count with thousands separated by commas (1,000,000).
fn count(n: u64) -> String {
    let digits = n.to_string();
    let mut s = String::new();
    for (i, c) in digits.chars().enumerate() {
        if i > 0 && (digits.len() - i).is_multiple_of(3) {
            s.push(',');
        }
        s.push(c);
    }
    s
}

/// A unit enum variant as serde names it (`optimised_lhs`, `ga_bp`, …).
fn word<T: Serialize>(value: &T) -> String {
    match serde_json::to_value(value) {
        Ok(serde_json::Value::String(s)) => s,
        other => format!("{other:?}"),
    }
}
