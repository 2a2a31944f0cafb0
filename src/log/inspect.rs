//! `repose inspect`: reads a run log back, checks every byte of it and its
//! embedded manifest, and reports channels, counts and times.
//!
//! Integrity: both MCAP magics, the footer, the summary-section CRC, the
//! data-section CRC (the data section is every byte before the summary, so with
//! the summary CRC a flipped bit anywhere but the footer's own CRC field is
//! caught), chunk CRCs while decoding every message, and the decoded message
//! counts against the summary statistics. A truncated file fails the closing
//! magic. Provenance: the embedded manifest must hash to the embedded id, be
//! canonical, equal the attachment, and equal `<store>/<id>/manifest.json` when
//! that exists.

use std::collections::BTreeMap;
use std::io::{self, Write};
use std::path::{Path, PathBuf};

use mcap::read::{MessageStream, Options};
use mcap::records::Record;
use mcap::Summary;

use super::schema::{MANIFEST_ATTACHMENT, MANIFEST_METADATA};
use crate::manifest::{canonical_json, ContentId, Experiment};
use crate::store::MANIFEST_FILE;

/// The MCAP magic that opens and closes every file.
const MAGIC: &[u8; 8] = b"\x89MCAP0\r\n";
/// Opcodes used by the byte-level checks.
const OP_FOOTER: u8 = 0x02;
const OP_DATA_END: u8 = 0x0F;
/// Footer record: opcode, length, summary_start, summary_offset_start, summary_crc.
const FOOTER_LEN: usize = 1 + 8 + 8 + 8 + 4;
/// Data End record: opcode, length, data_section_crc.
const DATA_END_LEN: usize = 1 + 8 + 4;

/// Why `inspect` failed.
#[derive(Debug, thiserror::Error)]
pub enum InspectError {
    /// The file could not be read.
    #[error("cannot read {}: {source}", path.display())]
    Io {
        /// The file.
        path: PathBuf,
        /// The I/O error.
        source: io::Error,
    },
    /// The file is not a complete, intact MCAP file.
    #[error("{}: corrupt run log: {problem}", path.display())]
    Corrupt {
        /// The file.
        path: PathBuf,
        /// What is wrong.
        problem: String,
    },
    /// The file is intact but its provenance does not check out.
    #[error("{}: manifest check failed: {problem}", path.display())]
    Manifest {
        /// The file.
        path: PathBuf,
        /// What does not match.
        problem: String,
    },
    /// Writing the report failed.
    #[error("cannot write output: {0}")]
    Output(#[from] io::Error),
}

impl InspectError {
    /// True when the input is at fault: a corrupt or mismatched file, or one
    /// that cannot be read (missing, a directory), as for every command.
    pub fn is_invalid_input(&self) -> bool {
        matches!(
            self,
            InspectError::Corrupt { .. } | InspectError::Manifest { .. } | InspectError::Io { .. }
        )
    }
}

/// One channel of a log.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct ChannelReport {
    /// Channel id.
    pub id: u16,
    /// Topic.
    pub topic: String,
    /// Schema name (e.g. `foxglove.SceneUpdate`).
    pub schema: String,
    /// Schema encoding (`protobuf`, `jsonschema`).
    pub schema_encoding: String,
    /// Message encoding (`protobuf`, `json`).
    pub message_encoding: String,
    /// Messages decoded from the chunks.
    pub messages: u64,
}

/// The `repose.manifest` metadata record of a log.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct EmbeddedManifest {
    /// The experiment id as recorded.
    pub id: String,
    /// The canonical manifest JSON.
    pub manifest: String,
    /// The repose version that wrote the log.
    pub repose_version: String,
    /// The physics version that wrote the log.
    pub physics_version: String,
}

/// An attachment of a log.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct AttachmentReport {
    /// Name.
    pub name: String,
    /// Media type.
    pub media_type: String,
    /// Content.
    pub data: Vec<u8>,
}

/// What an intact log holds.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Inspection {
    /// File size, bytes.
    pub bytes: u64,
    /// Header library string.
    pub library: String,
    /// Channels by id.
    pub channels: Vec<ChannelReport>,
    /// Messages on every channel.
    pub messages: u64,
    /// Earliest and latest log time (ns), `None` without messages.
    pub time_range_ns: Option<(u64, u64)>,
    /// Chunks in the chunk index.
    pub chunks: usize,
    /// Chunks that have message indexes.
    pub indexed_chunks: usize,
    /// Distinct chunk compressions (`zstd`; empty string = none).
    pub compressions: Vec<String>,
    /// Attachments, in file order.
    pub attachments: Vec<AttachmentReport>,
    /// The manifest metadata, if present.
    pub manifest: Option<EmbeddedManifest>,
}

fn le_u64(b: &[u8]) -> u64 {
    u64::from_le_bytes(b[..8].try_into().expect("8 bytes"))
}

fn le_u32(b: &[u8]) -> u32 {
    u32::from_le_bytes(b[..4].try_into().expect("4 bytes"))
}

/// Checks the byte-level structure: magics, footer, summary and data CRCs.
fn check_bytes(b: &[u8]) -> Result<(), String> {
    let min = 2 * MAGIC.len() + DATA_END_LEN + FOOTER_LEN;
    if b.len() < MAGIC.len() || &b[..MAGIC.len()] != MAGIC {
        return Err("not an MCAP file (no MCAP magic at the start)".into());
    }
    if b.len() < min || &b[b.len() - MAGIC.len()..] != MAGIC {
        return Err(format!(
            "truncated: the file ({} bytes) does not end with the MCAP magic",
            b.len()
        ));
    }
    let footer = b.len() - MAGIC.len() - FOOTER_LEN;
    if b[footer] != OP_FOOTER || le_u64(&b[footer + 1..]) != (FOOTER_LEN - 9) as u64 {
        return Err("damaged: no footer record before the closing magic".into());
    }
    let summary_start = le_u64(&b[footer + 9..]);
    let summary_crc = le_u32(&b[footer + 25..]);
    if summary_start == 0 {
        return Err("no summary section (Foxglove needs one to seek)".into());
    }
    let summary_start = usize::try_from(summary_start)
        .ok()
        .filter(|&s| s >= MAGIC.len() + DATA_END_LEN && s <= footer)
        .ok_or_else(|| format!("damaged: summary offset {summary_start} is outside the file"))?;
    if summary_crc != 0 {
        let computed = crc32fast::hash(&b[summary_start..b.len() - MAGIC.len() - 4]);
        if computed != summary_crc {
            return Err(format!(
                "summary section CRC mismatch (stored {summary_crc:08x}, computed {computed:08x})"
            ));
        }
    }
    let data_end = summary_start - DATA_END_LEN;
    if b[data_end] != OP_DATA_END || le_u64(&b[data_end + 1..]) != 4 {
        return Err("damaged: no data-end record before the summary section".into());
    }
    let data_crc = le_u32(&b[data_end + 9..]);
    if data_crc != 0 {
        let computed = crc32fast::hash(&b[..data_end]);
        if computed != data_crc {
            return Err(format!(
                "data section CRC mismatch (stored {data_crc:08x}, computed {computed:08x}): \
                 bytes were changed"
            ));
        }
    }
    Ok(())
}

/// Reads and checks a log held in memory.
pub fn inspect_bytes(b: &[u8]) -> Result<Inspection, String> {
    check_bytes(b)?;
    let decode = |e: mcap::McapError| format!("cannot decode: {e}");
    let library = match mcap::read::LinearReader::new(b).map_err(decode)?.next() {
        Some(Ok(Record::Header(h))) => h.library,
        _ => return Err("the first record is not a header".into()),
    };
    let summary = Summary::read(b)
        .map_err(decode)?
        .ok_or("no summary section (Foxglove needs one to seek)")?;
    let stats = summary
        .stats
        .as_ref()
        .ok_or("the summary has no statistics record")?;

    let mut counts: BTreeMap<u16, u64> = BTreeMap::new();
    let mut range: Option<(u64, u64)> = None;
    for message in
        MessageStream::new_with_options(b, Options::ValidateChunkCrcs.into()).map_err(decode)?
    {
        let message = message.map_err(decode)?;
        *counts.entry(message.channel.id).or_default() += 1;
        let t = message.log_time;
        range = Some(range.map_or((t, t), |(lo, hi)| (lo.min(t), hi.max(t))));
    }
    let messages: u64 = counts.values().sum();
    if messages != stats.message_count || counts != stats.channel_message_counts {
        return Err(format!(
            "the chunks hold {messages} messages, the summary statistics say {}",
            stats.message_count
        ));
    }

    let mut channels: Vec<ChannelReport> = summary
        .channels
        .values()
        .map(|c| ChannelReport {
            id: c.id,
            topic: c.topic.clone(),
            schema: c.schema.as_ref().map_or(String::new(), |s| s.name.clone()),
            schema_encoding: c
                .schema
                .as_ref()
                .map_or(String::new(), |s| s.encoding.clone()),
            message_encoding: c.message_encoding.clone(),
            messages: counts.get(&c.id).copied().unwrap_or(0),
        })
        .collect();
    channels.sort_by_key(|c| c.id);

    let mut compressions: Vec<String> = summary
        .chunk_indexes
        .iter()
        .map(|c| c.compression.clone())
        .collect();
    compressions.sort();
    compressions.dedup();

    let mut attachments = Vec::new();
    for index in &summary.attachment_indexes {
        let a = mcap::read::attachment(b, index).map_err(decode)?;
        attachments.push(AttachmentReport {
            name: a.name,
            media_type: a.media_type,
            data: a.data.into_owned(),
        });
    }

    let mut manifest = None;
    for index in summary
        .metadata_indexes
        .iter()
        .filter(|m| m.name == MANIFEST_METADATA)
    {
        let m = mcap::read::metadata(b, index).map_err(decode)?;
        let field = |k: &str| m.metadata.get(k).cloned().unwrap_or_default();
        manifest = Some(EmbeddedManifest {
            id: field("id"),
            manifest: field("manifest"),
            repose_version: field("repose_version"),
            physics_version: field("physics_version"),
        });
    }

    Ok(Inspection {
        bytes: b.len() as u64,
        library,
        channels,
        messages,
        time_range_ns: range,
        chunks: summary.chunk_indexes.len(),
        indexed_chunks: summary
            .chunk_indexes
            .iter()
            .filter(|c| !c.message_index_offsets.is_empty())
            .count(),
        compressions,
        attachments,
        manifest,
    })
}

/// Reads and checks a log file.
pub fn inspect_file(path: &Path) -> Result<Inspection, InspectError> {
    let bytes = std::fs::read(path).map_err(|source| InspectError::Io {
        path: path.to_path_buf(),
        source,
    })?;
    inspect_bytes(&bytes).map_err(|problem| InspectError::Corrupt {
        path: path.to_path_buf(),
        problem,
    })
}

/// Where the embedded manifest was found to match.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum StoreCheck {
    /// `<store>/<id>/manifest.json` exists and is byte-identical.
    Matches(PathBuf),
    /// No `<store>/<id>/manifest.json` to compare with.
    Absent(PathBuf),
}

/// Checks the embedded manifest: present, hashes to its recorded id, canonical,
/// equal to the `manifest.json` attachment, and equal to
/// `<store_root>/<id>/manifest.json` if that exists.
pub fn check_manifest(
    inspection: &Inspection,
    store_root: &Path,
) -> Result<(ContentId, StoreCheck), String> {
    let m = inspection
        .manifest
        .as_ref()
        .ok_or_else(|| format!("no `{MANIFEST_METADATA}` metadata record"))?;
    let id = ContentId::of_bytes(m.manifest.as_bytes());
    if id.as_str() != m.id {
        return Err(format!(
            "the embedded manifest hashes to {id}, but the log records id {}",
            m.id
        ));
    }
    let parsed: Experiment = serde_json::from_str(&m.manifest)
        .map_err(|e| format!("the embedded manifest is not an experiment: {e}"))?;
    if canonical_json(&parsed) != m.manifest {
        return Err("the embedded manifest is not in canonical form".into());
    }
    match inspection
        .attachments
        .iter()
        .find(|a| a.name == MANIFEST_ATTACHMENT)
    {
        Some(a) if a.data == m.manifest.as_bytes() => {}
        Some(_) => {
            return Err(format!(
                "the `{MANIFEST_ATTACHMENT}` attachment differs from the metadata manifest"
            ))
        }
        None => return Err(format!("no `{MANIFEST_ATTACHMENT}` attachment")),
    }
    let stored = store_root.join(id.as_str()).join(MANIFEST_FILE);
    match std::fs::read(&stored) {
        Ok(bytes) if bytes == m.manifest.as_bytes() => Ok((id, StoreCheck::Matches(stored))),
        Ok(_) => Err(format!(
            "{} differs from the embedded manifest",
            stored.display()
        )),
        Err(e) if e.kind() == io::ErrorKind::NotFound => Ok((id, StoreCheck::Absent(stored))),
        Err(e) => Err(format!("cannot read {}: {e}", stored.display())),
    }
}

fn seconds(ns: u64) -> String {
    format!("{}.{:09}", ns / 1_000_000_000, ns % 1_000_000_000)
}

/// `repose inspect`: checks `path` (integrity and manifest, see the module
/// docs) and writes the report to `out`. The report is written before a
/// manifest mismatch is returned, so what was found stays visible.
pub fn report(path: &Path, store_root: &Path, out: &mut dyn Write) -> Result<(), InspectError> {
    let i = inspect_file(path)?;
    writeln!(out, "file:     {} ({} bytes)", path.display(), i.bytes)?;
    writeln!(out, "library:  {}", i.library)?;
    writeln!(
        out,
        "chunks:   {} ({}), {} with message indexes; summary present",
        i.chunks,
        i.compressions
            .iter()
            .map(|c| if c.is_empty() { "uncompressed" } else { c })
            .collect::<Vec<_>>()
            .join(", "),
        i.indexed_chunks
    )?;
    match i.time_range_ns {
        Some((lo, hi)) => writeln!(
            out,
            "time:     {} s .. {} s, {} messages",
            seconds(lo),
            seconds(hi),
            i.messages
        )?,
        None => writeln!(out, "time:     no messages")?,
    }
    writeln!(out, "channels:")?;
    let width = i.channels.iter().map(|c| c.topic.len()).max().unwrap_or(0);
    for c in &i.channels {
        writeln!(
            out,
            "  {:<width$}  {:<22} {:<8} {:>7} messages",
            c.topic, c.schema, c.message_encoding, c.messages
        )?;
    }
    for a in &i.attachments {
        writeln!(
            out,
            "attachment: {} ({}, {} bytes)",
            a.name,
            a.media_type,
            a.data.len()
        )?;
    }
    if let Some(m) = &i.manifest {
        writeln!(
            out,
            "manifest: id {} (repose {}, physics version {})",
            m.id, m.repose_version, m.physics_version
        )?;
    }
    let (_, store) = check_manifest(&i, store_root).map_err(|problem| InspectError::Manifest {
        path: path.to_path_buf(),
        problem,
    })?;
    writeln!(
        out,
        "  hash:   ok (sha256 of the embedded canonical manifest)"
    )?;
    match store {
        StoreCheck::Matches(p) => writeln!(out, "  store:  matches {}", p.display())?,
        StoreCheck::Absent(p) => writeln!(out, "  store:  no {} to compare", p.display())?,
    }
    Ok(())
}
