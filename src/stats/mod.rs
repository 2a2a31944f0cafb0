//! Statistics as pure functions on slices: the one place for summary
//! statistics, distribution quantiles and p-values, least squares, response
//! surfaces and analysis of variance.
//!
//! - [`summary`]: mean and its Student-t 95 % confidence interval, the Welch
//!   interval of a difference of means, t quantiles and the p-values of t and
//!   F statistics (exact, from `statrs`, not a table).
//! - [`equivalence`]: the two one-sided t-tests of a mean against a band,
//!   the exact power of that test and the replicates that would decide it.
//! - [`metrics`]: fit metrics of paired values (R², mean squared error).
//! - [`regression`]: ordinary least squares by Householder QR, with standard
//!   errors, t statistics, two-sided p-values and leverages; a column that is
//!   a linear combination of earlier ones is refused, naming it.
//! - [`rsm`]: the quadratic response-surface analysis as Design-Expert prints
//!   it: coefficients in coded and actual units, the ANOVA with partial
//!   (Type III) sums of squares, lack of fit against pure error, R², adjusted
//!   and predicted R², coefficient of variation and adequate precision.
//! - [`oneway`]: one-way analysis of variance of groups of observations.
//! - [`homogeneity`]: Bartlett's test that groups share one variance (the
//!   noise-aware GP's choice between a pooled and a per-point seed
//!   variance).
//! - [`sensitivity`]: yan2015's parameter sensitivity matrix analysis: column
//!   norms (Eq. 17), normalised norms and the cross-correlation of parameters
//!   (Eq. 18), with the null vector when the parameters are collinear.
//! - [`nlls`]: nonlinear least squares by Levenberg–Marquardt with analytic
//!   gradients, the covariance s²·(JᵀJ)⁻¹ of the estimates (as
//!   `scipy.optimize.curve_fit` reports it), t confidence intervals and lack
//!   of fit against pure error; with the yan2015 power law (Eq. 19, started
//!   from its log-linear least-squares fit) and flow-rate decay (Eq. 20).
//! - [`pca`]: principal component analysis of the auto-scaled data matrix
//!   (yan2015 Eq. 13–16): eigenvalues, explained fractions and loadings.
//! - [`gp`]: Gaussian-process regression with a Matérn 5/2 ARD kernel, known
//!   per-point noise variances and an optional fitted nugget (he2019's
//!   noise-aware surrogate), hyperparameters by multi-start maximum likelihood; the
//!   probability of a band and the expected improvement on the distance to
//!   a target.
//! - [`gp_two_level`]: the two-level (multi-fidelity) process y_fine =
//!   ρ · y_coarse + β + δ of Kennedy & O'Hagan, recursive form: many coarse
//!   runs and a few fine ones predicting the fine level.
//! - [`trend`]: a weighted least-squares line and its value extrapolated
//!   with a confidence interval (a response against particle size, read at
//!   the real size).
//!
//! The fits and analyses of variance check their inputs before any
//! arithmetic: a non-finite value, slices of different lengths, too few
//! observations for the parameters and an aliased design are each a
//! [`StatsError`] rather than a NaN in the output.

pub mod equivalence;
pub mod gp;
pub mod gp_two_level;
pub mod homogeneity;
pub mod levenberg;
pub mod metrics;
pub mod nlls;
pub mod oneway;
pub mod pca;
pub mod regression;
pub mod rsm;
pub mod sensitivity;
pub mod summary;
pub mod trend;

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
    /// A group with too few observations for its statistic (a variance
    /// needs two).
    #[error("group {index} has {got} values; at least {needed} are needed")]
    GroupTooSmall {
        /// Index of the group.
        index: usize,
        /// Observations it has.
        got: usize,
        /// Observations needed.
        needed: usize,
    },
    /// Every group is constant: there is no variance to compare.
    #[error("every group is constant: there is no variance to compare")]
    NoVariance,
    /// A value that must be positive (it is logged, or raised to a fitted
    /// power) is zero or negative.
    #[error("non-positive value {value} in {what} at index {index} (it must be > 0)")]
    NonPositive {
        /// Which input: `y`, `factor `e` (column 0 of x)`, `t`.
        what: String,
        /// Index of the value within it (the observation).
        index: usize,
        /// The value.
        value: f64,
    },
    /// An iterative fit stopped at its iteration limit before meeting its
    /// convergence tolerances; a better start or a larger limit may help.
    #[error(
        "no convergence after {iterations} iterations \
         (last sum of squared residuals {sse})"
    )]
    NotConverged {
        /// Iterations (trial steps) taken.
        iterations: usize,
        /// Sum of squared residuals at the best point reached.
        sse: f64,
    },
    /// A column of a data matrix has zero variance, so it cannot be scaled
    /// to unit variance (and carries no information).
    #[error("column `{column}` is constant (zero variance)")]
    ConstantColumn {
        /// The column's name.
        column: String,
    },
    /// A matrix that must be inverted is singular (to rounding).
    #[error("singular matrix: {what}")]
    Singular {
        /// Which matrix, and why it is singular where known (for a nonlinear
        /// fit: the parameter not determined by the data at the solution).
        what: String,
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
    assert_rel_within(what, actual, expected, 1e-6);
}

/// Test helper: asserts |actual − expected| ≤ `tol` · |expected| for each
/// pair.
#[cfg(test)]
pub(crate) fn assert_rel_within(what: &str, actual: &[f64], expected: &[f64], tol: f64) {
    assert_eq!(actual.len(), expected.len(), "{what}: lengths");
    for (i, (a, e)) in actual.iter().zip(expected).enumerate() {
        assert!(
            (a - e).abs() <= tol * e.abs(),
            "{what}[{i}]: {a} vs reference {e}"
        );
    }
}
