//! Statistics as pure functions on slices: the one place for summary
//! statistics, distribution quantiles and p-values, least squares, response
//! surfaces and analysis of variance.
//!
//! - [`summary`]: mean and its Student-t 95 % confidence interval, the Welch
//!   interval of a difference of means, t quantiles and the p-values of t and
//!   F statistics (exact, from `statrs`, not a table).
//! - [`metrics`]: fit metrics of paired values (R², mean squared error).
//! - [`regression`]: ordinary least squares by Householder QR, with standard
//!   errors, t statistics, two-sided p-values and leverages; a column that is
//!   a linear combination of earlier ones is refused, naming it.
//! - [`rsm`]: the quadratic response-surface analysis as Design-Expert prints
//!   it: coefficients in coded and actual units, the ANOVA with partial
//!   (Type III) sums of squares, lack of fit against pure error, R², adjusted
//!   and predicted R², coefficient of variation and adequate precision.
//! - [`oneway`]: one-way analysis of variance of groups of observations.
//! - [`sensitivity`]: yan2015's parameter sensitivity matrix analysis: column
//!   norms (Eq. 17), normalised norms and the cross-correlation of parameters
//!   (Eq. 18), with the null vector when the parameters are collinear.
//!
//! The fits and analyses of variance check their inputs before any
//! arithmetic: a non-finite value, slices of different lengths, too few
//! observations for the parameters and an aliased design are each a
//! [`StatsError`] rather than a NaN in the output.
//!
//! Nonlinear least squares and principal component analysis (for the yan2015
//! calibration) belong here too and are a later addition.

pub mod metrics;
pub mod oneway;
pub mod regression;
pub mod rsm;
pub mod sensitivity;
pub mod summary;

/// Why a statistic could not be computed from the data given.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum StatsError {
    /// The residual has no degree of freedom left: a fit of `parameters`
    /// coefficients needs more than that many observations (and one-way
    /// ANOVA more observations than groups).
    #[error(
        "{observations} observations are too few for {parameters} parameters \
         (at least {} are needed for a residual degree of freedom)",
        parameters + 1
    )]
    TooFewObservations {
        /// Observations given.
        observations: usize,
        /// Parameters (coefficients, or group means) to estimate.
        parameters: usize,
    },
    /// The design matrix is singular: the named term's column is (to
    /// rounding) a linear combination of the columns before it, so its
    /// coefficient is not estimable.
    #[error(
        "the design is singular: term `{term}` is aliased with the terms \
         before it (its column is a linear combination of theirs)"
    )]
    Aliased {
        /// The aliased term (a term name, or `xj` for column j of an unnamed
        /// design).
        term: String,
    },
    /// Two inputs that must pair up have different lengths.
    #[error("lengths differ: {what} has {got} values where {expected} are needed")]
    LengthMismatch {
        /// What has the wrong length.
        what: String,
        /// The length it must have.
        expected: usize,
        /// The length it has.
        got: usize,
    },
    /// An input value is NaN or infinite.
    #[error("non-finite value {value} in {what} at index {index}")]
    NonFinite {
        /// Which input: `y`, `group 2`, `coded run 4`, or the term of a design
        /// column.
        what: String,
        /// Index of the value within it (the run, for design columns).
        index: usize,
        /// The value.
        value: f64,
    },
    /// Fewer groups than the analysis compares (one-way ANOVA needs two).
    #[error("{got} groups given; at least {needed} are needed")]
    TooFewGroups {
        /// Groups given.
        got: usize,
        /// Groups needed.
        needed: usize,
    },
    /// A group with no observations.
    #[error("group {index} is empty")]
    EmptyGroup {
        /// Index of the empty group.
        index: usize,
    },
}

/// Checks that every value of `values` is finite, naming `what` and the index
/// of the first that is not.
pub(crate) fn check_finite(what: &str, values: &[f64]) -> Result<(), StatsError> {
    match values.iter().position(|v| !v.is_finite()) {
        Some(index) => Err(StatsError::NonFinite {
            what: what.to_string(),
            index,
            value: values[index],
        }),
        None => Ok(()),
    }
}

/// Test helper: asserts |actual − expected| ≤ 1e-6 · |expected| for each pair.
#[cfg(test)]
pub(crate) fn assert_rel(what: &str, actual: &[f64], expected: &[f64]) {
    assert_eq!(actual.len(), expected.len(), "{what}: lengths");
    for (i, (a, e)) in actual.iter().zip(expected).enumerate() {
        assert!(
            (a - e).abs() <= 1e-6 * e.abs(),
            "{what}[{i}]: {a} vs reference {e}"
        );
    }
}
