//! Collecting field errors: each names the JSON path, the value and what is allowed.

use std::fmt;

/// One rejected field: `path = value: rule`, e.g.
/// `contact.particle_particle.restitution = 1.3: must be in (0, 1]`.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct FieldError {
    /// Dotted JSON path of the field (map keys appear as path segments).
    pub path: String,
    /// The offending value as written in JSON.
    pub value: String,
    /// What is allowed.
    pub rule: String,
}

impl fmt::Display for FieldError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{} = {}: {}", self.path, self.value, self.rule)
    }
}

/// Formats a number as JSON would (shortest round-trip), or `NaN` / `inf`.
pub(crate) fn number(v: f64) -> String {
    match serde_json::Number::from_f64(v) {
        Some(n) => n.to_string(),
        None if v.is_nan() => "NaN".to_string(),
        None if v > 0.0 => "inf".to_string(),
        None => "-inf".to_string(),
    }
}

/// Formats a string as a JSON string literal.
pub(crate) fn string(s: &str) -> String {
    serde_json::Value::String(s.to_string()).to_string()
}

/// Joins a path prefix and a field name.
pub(crate) fn join(prefix: &str, field: &str) -> String {
    if prefix.is_empty() {
        field.to_string()
    } else {
        format!("{prefix}.{field}")
    }
}

/// Accumulates field errors so that several are reported together.
#[derive(Debug, Default)]
pub(crate) struct Checker {
    errors: Vec<FieldError>,
}

impl Checker {
    /// Records an error.
    pub(crate) fn fail(&mut self, path: &str, value: String, rule: impl Into<String>) {
        self.errors.push(FieldError {
            path: path.to_string(),
            value,
            rule: rule.into(),
        });
    }

    /// Requires a name that is safe as one path component
    /// ([`super::check_path_component`]).
    pub(crate) fn path_component(&mut self, path: &str, name: &str) {
        if let Err(rule) = super::check_path_component(name) {
            self.fail(path, string(name), rule);
        }
    }

    /// Requires a finite value > 0.
    pub(crate) fn positive(&mut self, path: &str, v: f64) {
        if !(v.is_finite() && v > 0.0) {
            self.fail(path, number(v), "must be a finite number > 0");
        }
    }

    /// Requires a finite value ≥ 0.
    pub(crate) fn non_negative(&mut self, path: &str, v: f64) {
        if !(v.is_finite() && v >= 0.0) {
            self.fail(path, number(v), "must be a finite number >= 0");
        }
    }

    /// Requires a finite value (any sign).
    pub(crate) fn finite(&mut self, path: &str, v: f64) {
        if !v.is_finite() {
            self.fail(path, number(v), "must be a finite number");
        }
    }

    /// Requires `v` in the interval `iv`.
    pub(crate) fn within(&mut self, path: &str, v: f64, iv: Interval) {
        if !iv.contains(v) {
            self.fail(path, number(v), format!("must be in {iv}"));
        }
    }

    /// The errors collected so far.
    pub(crate) fn into_errors(self) -> Vec<FieldError> {
        self.errors
    }

    /// Whether no error has been recorded.
    pub(crate) fn is_clean(&self) -> bool {
        self.errors.is_empty()
    }
}

/// An interval with open or closed ends, displayed in the usual notation `(0, 1]`.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Interval {
    pub(crate) lo: f64,
    pub(crate) lo_closed: bool,
    pub(crate) hi: f64,
    pub(crate) hi_closed: bool,
}

impl Interval {
    /// `(lo, hi]`.
    pub(crate) fn open_closed(lo: f64, hi: f64) -> Interval {
        Interval {
            lo,
            lo_closed: false,
            hi,
            hi_closed: true,
        }
    }

    /// `(lo, hi)`.
    pub(crate) fn open(lo: f64, hi: f64) -> Interval {
        Interval {
            lo,
            lo_closed: false,
            hi,
            hi_closed: false,
        }
    }

    /// `[lo, hi)`.
    pub(crate) fn closed_open(lo: f64, hi: f64) -> Interval {
        Interval {
            lo,
            lo_closed: true,
            hi,
            hi_closed: false,
        }
    }

    /// Whether `v` (finite) lies inside.
    pub(crate) fn contains(&self, v: f64) -> bool {
        let above = if self.lo_closed {
            v >= self.lo
        } else {
            v > self.lo
        };
        let below = if self.hi_closed {
            v <= self.hi
        } else {
            v < self.hi
        };
        v.is_finite() && above && below
    }
}

impl fmt::Display for Interval {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let open = if self.lo_closed { '[' } else { '(' };
        let close = if self.hi_closed { ']' } else { ')' };
        // Rust's f64 Display is shortest round-trip without a trailing `.0`: `(0, 1]`.
        write!(f, "{open}{}, {}{close}", self.lo, self.hi)
    }
}
