//! A run as named fields: the values `--where`, `--sort`, `--columns` and
//! `repose diff` address, and the closest known names for a misspelt one.
//!
//! A run's fields are, looked up in this order:
//! - the built-ins [`BUILTINS`]: `id` (the full hex id), `scene` (the scene
//!   kind), `profile`, `status` (complete, failed, incomplete, damaged) and
//!   `physics_version`;
//! - every leaf of its manifest by dotted path, as the canonical JSON holds
//!   it (`contact.particle_particle.static_friction`, `scene.kind`,
//!   `seeds.packing_seed`; array items by index, `a.0.b`);
//! - its responses: every key of the result's `measurements`,
//!   [`HEADLINE_KEY`] (the headline angle, degrees) and every named response
//!   of its scene kind's catalogue (`repose responses`), for a complete run.
//!
//! Every catalogue name is a known field even in a store with no run of that
//! kind (it then matches nothing); an unknown name is refused with the
//! closest known ones.
//!
//! A response whose key equals a manifest path is shadowed by the manifest
//! field (no scene names one so). Values keep their kind: numbers compare as
//! numbers, words as words ([`Value::compare`]).

use std::cmp::Ordering;
use std::collections::{BTreeMap, BTreeSet};

use crate::manifest::Experiment;
use crate::scenes::responses::{catalogue, kinds, response};
use crate::store::{RunSummary, HEADLINE_KEY};

/// The fields every run has, whatever its manifest and result hold.
pub const BUILTINS: [&str; 5] = ["id", "scene", "profile", "status", "physics_version"];

/// One field's value.
#[derive(Debug, Clone, PartialEq)]
pub enum Value {
    /// A number (a JSON number of the manifest, a measurement in its unit).
    Number(f64),
    /// A word, id or other text (a JSON boolean is `true` or `false`).
    Text(String),
}

impl Value {
    /// The value as a number: a number, or a text that parses as one.
    pub fn number(&self) -> Option<f64> {
        match self {
            Value::Number(v) => Some(*v),
            Value::Text(t) => t.trim().parse().ok(),
        }
    }

    /// Numeric order when both sides are numbers ([`Value::number`]), else
    /// the order of their texts (byte order).
    pub fn compare(&self, other: &Value) -> Ordering {
        match (self.number(), other.number()) {
            (Some(a), Some(b)) => a.total_cmp(&b),
            _ => self.to_string().cmp(&other.to_string()),
        }
    }
}

impl serde::Serialize for Value {
    /// A number as a JSON number (a whole one below 2⁵³ without a fraction,
    /// as the text shows it), a text as a string.
    fn serialize<S: serde::Serializer>(&self, serializer: S) -> Result<S::Ok, S::Error> {
        const EXACT: f64 = 9_007_199_254_740_992.0;
        match self {
            Value::Number(v) if v.fract() == 0.0 && v.abs() < EXACT => {
                serializer.serialize_i64(*v as i64)
            }
            Value::Number(v) => serializer.serialize_f64(*v),
            Value::Text(t) => serializer.serialize_str(t),
        }
    }
}

impl std::fmt::Display for Value {
    /// Numbers in shortest round-trip form, texts as they are.
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Value::Number(v) => write!(f, "{v}"),
            Value::Text(t) => f.write_str(t),
        }
    }
}

/// One run's summary with its fields (module docs).
#[derive(Debug, Clone)]
pub struct Record {
    /// The run as the store lists it.
    pub summary: RunSummary,
    /// Every manifest leaf by dotted path (empty when the manifest is unreadable).
    pub manifest: BTreeMap<String, Value>,
    /// Every response of a complete run, in its unit.
    pub responses: BTreeMap<String, f64>,
}

impl Record {
    /// The fields of `summary`'s run.
    pub fn new(summary: RunSummary) -> Record {
        let manifest = summary
            .experiment
            .as_ref()
            .map(manifest_fields)
            .unwrap_or_default();
        let mut responses = BTreeMap::new();
        if let Some(result) = &summary.result {
            responses.extend(result.measurements.iter().map(|(k, v)| (k.clone(), *v)));
            if let Some(angle) = result.headline_angle_deg {
                responses.insert(HEADLINE_KEY.to_string(), angle);
            }
            // The named responses of the scene's catalogue (what `repose
            // responses` prints), derived from the measurements.
            if let Some(kind) = summary.experiment.as_ref().map(|e| e.scene.kind()) {
                for spec in catalogue(kind).unwrap_or(&[]) {
                    if let Ok(v) = response(result, kind, spec.name) {
                        responses.entry(spec.name.to_string()).or_insert(v);
                    }
                }
            }
        }
        Record {
            summary,
            manifest,
            responses,
        }
    }

    /// The value of `field`, if this run has it.
    pub fn get(&self, field: &str) -> Option<Value> {
        let experiment = self.summary.experiment.as_ref();
        match field {
            "id" => Some(Value::Text(self.summary.id.to_string())),
            "scene" => experiment.map(|e| Value::Text(e.scene.kind().to_string())),
            "profile" => experiment.map(|e| Value::Text(e.profile.as_str().to_string())),
            "status" => Some(Value::Text(self.summary.status.to_string())),
            "physics_version" => experiment.map(|e| Value::Number(e.physics_version.into())),
            _ => self
                .manifest
                .get(field)
                .cloned()
                .or_else(|| self.responses.get(field).map(|v| Value::Number(*v))),
        }
    }

    /// Whether `field` is one of this run's responses (and not a manifest field).
    pub fn is_response(&self, field: &str) -> bool {
        !self.manifest.contains_key(field) && self.responses.contains_key(field)
    }
}

/// Every leaf of `experiment`'s manifest by dotted path.
pub fn manifest_fields(experiment: &Experiment) -> BTreeMap<String, Value> {
    let mut out = BTreeMap::new();
    if let Ok(json) = serde_json::to_value(experiment) {
        flatten(&json, String::new(), &mut out);
    }
    out
}

/// Every leaf of `json` by dotted path below `prefix` (array items by index).
pub fn flatten(json: &serde_json::Value, prefix: String, out: &mut BTreeMap<String, Value>) {
    let child = |key: &str| {
        if prefix.is_empty() {
            key.to_string()
        } else {
            format!("{prefix}.{key}")
        }
    };
    match json {
        serde_json::Value::Object(map) => {
            for (k, v) in map {
                flatten(v, child(k), out);
            }
        }
        serde_json::Value::Array(items) => {
            for (i, v) in items.iter().enumerate() {
                flatten(v, child(&i.to_string()), out);
            }
        }
        serde_json::Value::Number(n) => {
            out.insert(
                prefix,
                n.as_f64().map_or(Value::Text(n.to_string()), Value::Number),
            );
        }
        serde_json::Value::String(s) => {
            out.insert(prefix, Value::Text(s.clone()));
        }
        other => {
            out.insert(prefix, Value::Text(other.to_string()));
        }
    }
}

/// Every field name any of `records` has, with the built-ins and every
/// response name of every scene kind's catalogue (a name `repose responses`
/// prints is a field even when no run of the store has it).
pub fn known_fields(records: &[Record]) -> BTreeSet<String> {
    let mut known: BTreeSet<String> = BUILTINS.iter().map(|s| s.to_string()).collect();
    for kind in kinds() {
        known.extend(
            catalogue(kind)
                .unwrap_or(&[])
                .iter()
                .map(|s| s.name.to_string()),
        );
    }
    for r in records {
        known.extend(r.manifest.keys().cloned());
        known.extend(r.responses.keys().cloned());
    }
    known
}

/// Whether `field` is a response name of some scene kind's catalogue (a
/// number wherever a run has it).
pub fn is_catalogue_response(field: &str) -> bool {
    kinds()
        .iter()
        .any(|k| catalogue(k).unwrap_or(&[]).iter().any(|s| s.name == field))
}

/// The (at most) five names of `known` closest to `field`: those containing
/// it first (`angle_deg` finds `dynamic_angle_deg`), then by Levenshtein
/// distance to the whole dotted path or to its last segment, whichever is
/// smaller (`static_frction` finds `contact.particle_particle.static_friction`).
pub fn closest<'a>(field: &str, known: impl IntoIterator<Item = &'a String>) -> Vec<String> {
    let mut scored: Vec<(bool, usize, &String)> = known
        .into_iter()
        .map(|k| {
            let tail = k.rsplit('.').next().unwrap_or(k);
            let distance = levenshtein(field, k).min(levenshtein(field, tail));
            (!k.contains(field), distance, k)
        })
        .collect();
    scored.sort();
    scored
        .into_iter()
        .take(5)
        .map(|(_, _, k)| k.clone())
        .collect()
}

/// The Levenshtein distance between `a` and `b` (insertions, deletions and
/// substitutions of characters).
fn levenshtein(a: &str, b: &str) -> usize {
    let b: Vec<char> = b.chars().collect();
    let mut row: Vec<usize> = (0..=b.len()).collect();
    for (i, ca) in a.chars().enumerate() {
        let mut diagonal = row[0];
        row[0] = i + 1;
        for (j, cb) in b.iter().enumerate() {
            let substituted = diagonal + usize::from(ca != *cb);
            diagonal = row[j + 1];
            row[j + 1] = substituted.min(row[j] + 1).min(row[j + 1] + 1);
        }
    }
    row[b.len()]
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn levenshtein_counts_edits() {
        assert_eq!(levenshtein("kitten", "sitting"), 3);
        assert_eq!(levenshtein("", "abc"), 3);
        assert_eq!(levenshtein("same", "same"), 0);
    }

    #[test]
    fn a_tail_finds_its_dotted_path() {
        let known: Vec<String> = [
            "contact.particle_particle.static_friction",
            "scene.kind",
            "id",
        ]
        .iter()
        .map(|s| s.to_string())
        .collect();
        assert_eq!(
            closest("static_frction", &known)[0],
            "contact.particle_particle.static_friction"
        );
        let known = [
            "seeds.sample_index".to_string(),
            "dynamic_angle_deg".to_string(),
        ];
        assert_eq!(closest("angle_deg", &known)[0], "dynamic_angle_deg");
    }

    #[test]
    fn numbers_compare_as_numbers_and_words_as_words() {
        let n = |v: f64| Value::Number(v);
        assert_eq!(n(9.0).compare(&Value::Text("10".into())), Ordering::Less);
        assert_eq!(
            Value::Text("drum".into()).compare(&Value::Text("hopper".into())),
            Ordering::Less
        );
    }
}
