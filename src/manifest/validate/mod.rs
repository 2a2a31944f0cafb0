//! Validation of typed manifests: every physical field is checked for finiteness,
//! range and consistency, and all violations are reported together, each naming the
//! JSON path, the value and what is allowed.

mod checker;
mod experiment;
mod name;
mod scene;
mod study;

use std::fmt;

pub use checker::FieldError;
pub(crate) use checker::{number, string};
pub use name::{check_path_component, MAX_NAME_CHARS};
pub use scene::PACKING_LIMIT;

use super::experiment::Experiment;
use super::study::Study;
use checker::Checker;

/// Every field error found in one document (never empty).
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct ValidationErrors(pub Vec<FieldError>);

impl fmt::Display for ValidationErrors {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        for (i, e) in self.0.iter().enumerate() {
            if i > 0 {
                writeln!(f)?;
            }
            write!(f, "{e}")?;
        }
        Ok(())
    }
}

impl std::error::Error for ValidationErrors {}

fn finish(c: Checker) -> Result<(), ValidationErrors> {
    if c.is_clean() {
        Ok(())
    } else {
        Err(ValidationErrors(c.into_errors()))
    }
}

/// Checks an experiment; `Err` lists every violated rule.
pub fn validate_experiment(e: &Experiment) -> Result<(), ValidationErrors> {
    let mut c = Checker::default();
    experiment::check_experiment(&mut c, e);
    finish(c)
}

/// Checks a study; `Err` lists every violated rule.
pub fn validate_study(s: &Study) -> Result<(), ValidationErrors> {
    let mut c = Checker::default();
    study::check_study(&mut c, s);
    finish(c)
}
