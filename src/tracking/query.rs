//! `--where` filters and `--sort` keys: parsing them and applying them to rows.
//!
//! A filter is `FIELD OP VALUE` with OP one of `= != < <= > >=` (spaces
//! around it optional). When both the field's value and VALUE parse as
//! numbers they compare as numbers (`static_friction>=0.4` keeps 0.5 and not
//! 0.35), otherwise as texts (`scene=drum`; `<` on texts is byte order). A
//! run without the field (a hopper field on a drum run, a response of a
//! failed run) matches no filter, not even `!=`: the question asked is
//! about a value it does not have. Several filters must all hold. A filter
//! that cannot mean what it says is refused: a word against a field of
//! numbers (`static_friction>abc`), an order of a number against a field of
//! words (`scene>5`), a doubled operator (`scene==drum`) or no value.
//!
//! A sort key is `FIELD` or `FIELD:desc` (`:asc` is the default); keys apply
//! in the order given, the sort is stable (rows equal on every key keep the
//! id order of the store), and rows without the field come last in either
//! direction.

use std::cmp::Ordering;

use super::fields::Value;
use super::TrackingError;

/// A comparison operator of a filter.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Op {
    /// `=`
    Eq,
    /// `!=`
    Ne,
    /// `<`
    Lt,
    /// `<=`
    Le,
    /// `>`
    Gt,
    /// `>=`
    Ge,
}

impl Op {
    /// Operators as written, the two-character ones first so `<=` is not
    /// read as `<`.
    const SPELLINGS: [(&'static str, Op); 6] = [
        ("!=", Op::Ne),
        ("<=", Op::Le),
        (">=", Op::Ge),
        ("=", Op::Eq),
        ("<", Op::Lt),
        (">", Op::Gt),
    ];

    /// The operator as written.
    fn spelling(self) -> &'static str {
        Op::SPELLINGS
            .iter()
            .find(|(_, op)| *op == self)
            .map_or("?", |(s, _)| s)
    }

    fn holds(self, order: Ordering) -> bool {
        match self {
            Op::Eq => order == Ordering::Equal,
            Op::Ne => order != Ordering::Equal,
            Op::Lt => order == Ordering::Less,
            Op::Le => order != Ordering::Greater,
            Op::Gt => order == Ordering::Greater,
            Op::Ge => order != Ordering::Less,
        }
    }
}

/// One `--where FIELD OP VALUE`.
#[derive(Debug, Clone, PartialEq)]
pub struct Filter {
    /// The field's name (see [`super::fields`]).
    pub field: String,
    /// The comparison.
    pub op: Op,
    /// The value compared with, as written.
    pub value: Value,
}

impl Filter {
    /// Parses `FIELD OP VALUE`; the error names the expression and the
    /// operators allowed.
    pub fn parse(text: &str) -> Result<Filter, TrackingError> {
        let bad = |message: &str| TrackingError::Expression {
            text: text.to_string(),
            message: message.to_string(),
        };
        let (at, len, op) = Op::SPELLINGS
            .iter()
            .filter_map(|(s, op)| text.find(s).map(|at| (at, s.len(), *op)))
            .min_by_key(|(at, len, _)| (*at, usize::MAX - len))
            .ok_or_else(|| bad("no operator; use one of = != < <= > >="))?;
        let field = text[..at].trim();
        let value = text[at + len..].trim();
        if field.is_empty() {
            return Err(bad("no field before the operator"));
        }
        if value.is_empty() {
            return Err(bad("no value after the operator"));
        }
        if value.starts_with(['=', '<', '>', '!']) {
            return Err(bad(&format!(
                "`{}{}` is not an operator; use one of = != < <= > >=",
                &text[at..at + len],
                &value[..1]
            )));
        }
        Ok(Filter {
            field: field.to_string(),
            op,
            value: Value::Text(value.to_string()),
        })
    }

    /// Refuses a comparison that could only match nothing or everything by
    /// accident: a word against a field whose `values` (every run's) are
    /// numbers, or an order (`< <= > >=`) of a number against a field of
    /// words. `numeric` says the field is known to hold numbers even when no
    /// run has it (a catalogue response).
    pub fn check_kind(
        &self,
        values: impl IntoIterator<Item = Value>,
        numeric: bool,
    ) -> Result<(), TrackingError> {
        let (mut numbers, mut words) = (numeric, false);
        for v in values {
            match v.number() {
                Some(_) => numbers = true,
                None => words = true,
            }
        }
        let bad = |message: String| TrackingError::Expression {
            text: format!("{}{}{}", self.field, self.op.spelling(), self.value),
            message,
        };
        let ordering = !matches!(self.op, Op::Eq | Op::Ne);
        match self.value.number() {
            None if numbers && !words => Err(bad(format!(
                "`{}` holds numbers and `{}` is not one",
                self.field, self.value
            ))),
            Some(_) if ordering && words && !numbers => Err(bad(format!(
                "`{}` holds words; order it against a word, or compare with = or !=",
                self.field
            ))),
            _ => Ok(()),
        }
    }

    /// Whether `value` (the row's value of the field) passes; a missing one
    /// never does.
    pub fn accepts(&self, value: Option<&Value>) -> bool {
        value.is_some_and(|v| self.op.holds(v.compare(&self.value)))
    }
}

/// One `--sort FIELD[:desc]` key.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct SortKey {
    /// The field's name.
    pub field: String,
    /// Largest first.
    pub descending: bool,
}

impl SortKey {
    /// Every key of `--sort` arguments, each a comma-separated list of
    /// `FIELD`, `FIELD:asc` or `FIELD:desc`.
    pub fn parse_all(args: &[String]) -> Result<Vec<SortKey>, TrackingError> {
        let mut keys = Vec::new();
        for part in args.iter().flat_map(|a| a.split(',')) {
            let (field, direction) = part.rsplit_once(':').unwrap_or((part, "asc"));
            let descending = match direction {
                "asc" => false,
                "desc" => true,
                other => {
                    return Err(TrackingError::Expression {
                        text: part.to_string(),
                        message: format!("sort direction `{other}`; use asc or desc"),
                    })
                }
            };
            if field.trim().is_empty() {
                return Err(TrackingError::Expression {
                    text: part.to_string(),
                    message: "no field to sort by".to_string(),
                });
            }
            keys.push(SortKey {
                field: field.trim().to_string(),
                descending,
            });
        }
        Ok(keys)
    }
}

/// The order of two rows' values of one key: missing values last.
pub fn order_by(key: &SortKey, a: Option<&Value>, b: Option<&Value>) -> Ordering {
    match (a, b) {
        (Some(a), Some(b)) if key.descending => b.compare(a),
        (Some(a), Some(b)) => a.compare(b),
        (Some(_), None) => Ordering::Less,
        (None, Some(_)) => Ordering::Greater,
        (None, None) => Ordering::Equal,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn two_character_operators_are_not_read_as_one() {
        let f = Filter::parse("contact.particle_particle.static_friction <= 0.4").unwrap();
        assert_eq!(f.field, "contact.particle_particle.static_friction");
        assert_eq!(f.op, Op::Le);
        assert_eq!(f.value, Value::Text("0.4".into()));
        assert_eq!(Filter::parse("scene!=drum").unwrap().op, Op::Ne);
        assert!(Filter::parse("scene drum").is_err());
        assert!(Filter::parse("=drum").is_err());
    }

    #[test]
    fn a_missing_value_passes_no_filter() {
        let f = Filter::parse("angle_deg!=3").unwrap();
        assert!(!f.accepts(None));
        assert!(f.accepts(Some(&Value::Number(2.0))));
    }

    #[test]
    fn sort_keys_split_on_commas_and_name_a_bad_direction() {
        let keys = SortKey::parse_all(&["scene,angle_deg:desc".into()]).unwrap();
        assert_eq!(keys.len(), 2);
        assert!(keys[1].descending && !keys[0].descending);
        assert!(SortKey::parse_all(&["a:down".into()]).is_err());
    }
}
