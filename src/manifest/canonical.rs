//! Canonical JSON and content ids.
//!
//! The canonical form of a typed manifest is its serialisation with object keys
//! sorted, no whitespace, and numbers as the typed value prints them: every float
//! field is an `f64` written as the shortest string that round-trips (ryu), so `1`,
//! `1.0` and `1e0` in a float field all become `1.0` (and `-0.0` becomes `0.0`);
//! integer fields (seeds, versions) stay integers. Canonicalising the *typed* value also fills defaults and
//! drops absent optionals, so omitted-default and spelled-out manifests hash alike.
//! The id is the lowercase hex sha256 of the canonical bytes.

use std::fmt;

use serde::{Deserialize, Serialize};
use serde_json::Value;
use sha2::{Digest, Sha256};

/// A content id: lowercase hex sha256 (64 characters) of canonical JSON.
#[derive(Debug, Clone, PartialEq, Eq, PartialOrd, Ord, Hash, Serialize, Deserialize)]
#[serde(transparent)]
pub struct ContentId(String);

impl ContentId {
    /// The id of the given canonical bytes.
    pub fn of_bytes(bytes: &[u8]) -> ContentId {
        ContentId(hex::encode(Sha256::digest(bytes)))
    }

    /// Accepts a full 64-character lowercase hex id (e.g. a run directory name).
    pub fn parse(s: &str) -> Option<ContentId> {
        let ok = s.len() == 64
            && s.bytes()
                .all(|b| b.is_ascii_digit() || (b'a'..=b'f').contains(&b));
        ok.then(|| ContentId(s.to_string()))
    }

    /// The hex string.
    pub fn as_str(&self) -> &str {
        &self.0
    }

    /// The first `n` characters, for tables.
    pub fn short(&self, n: usize) -> &str {
        &self.0[..n.min(self.0.len())]
    }
}

impl fmt::Display for ContentId {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(&self.0)
    }
}

/// The canonical JSON of a typed value (sorted keys, compact, shortest floats).
///
/// Non-finite floats have no JSON form and print as `null`; validated manifests
/// never contain them.
pub fn canonical_json<T: Serialize>(value: &T) -> String {
    // Our manifest types have string keys only and no fallible Serialize impls, so
    // conversion to a JSON value cannot fail.
    let v = serde_json::to_value(value).expect("manifest types serialise to JSON");
    let mut out = String::new();
    write_canonical(&v, &mut out);
    out
}

/// The content id of a typed value: sha256 of its canonical JSON.
pub fn content_id<T: Serialize>(value: &T) -> ContentId {
    ContentId::of_bytes(canonical_json(value).as_bytes())
}

/// Writes `v` with keys sorted explicitly (independent of serde_json's map order
/// feature, which another crate in the build could switch on).
fn write_canonical(v: &Value, out: &mut String) {
    match v {
        Value::Object(map) => {
            let mut entries: Vec<(&String, &Value)> = map.iter().collect();
            entries.sort_by(|a, b| a.0.cmp(b.0));
            out.push('{');
            for (i, (k, val)) in entries.into_iter().enumerate() {
                if i > 0 {
                    out.push(',');
                }
                out.push_str(&Value::String(k.clone()).to_string());
                out.push(':');
                write_canonical(val, out);
            }
            out.push('}');
        }
        Value::Array(items) => {
            out.push('[');
            for (i, item) in items.iter().enumerate() {
                if i > 0 {
                    out.push(',');
                }
                write_canonical(item, out);
            }
            out.push(']');
        }
        // -0.0 and 0.0 are the same physical value: one spelling, one id.
        Value::Number(n) if n.is_f64() && n.as_f64() == Some(0.0) => out.push_str("0.0"),
        scalar => out.push_str(&scalar.to_string()),
    }
}
