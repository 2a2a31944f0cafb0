//! The one report writer: every table and plot repose writes goes through here.
//!
//! - [`table`]: CSV tables, read and written with the `csv` crate (so quoting
//!   and embedded commas are handled by one well-tested parser), while number
//!   formatting stays ours (shortest round-trip `f64`), so identical inputs
//!   give identical bytes and the golden files keep matching.
//! - [`markdown`]: a small Markdown table builder (header, alignment, rows of
//!   strings) for the reports meant to be read by people.
//! - [`svg`]: the hand-written SVG plots of the calibration stages (parity
//!   plot, scatter matrix, learning curve). Kept as they are because golden
//!   files pin their bytes.
//! - [`plots`]: newer plots drawn with `plotters` (SVG backend only, no system
//!   fonts: text is written as SVG `<text>` elements): predicted vs actual,
//!   contour maps and per-factor level means. Each returns the SVG as a
//!   `String`, deterministic and without timestamps; the caller writes it
//!   atomically ([`crate::store::write_atomic`]).
//!
//! - [`page`]: the study report page (`repose report`), one static HTML file
//!   per study rendered with askama from the study's outputs, lineage
//!   records and runs.
//!
//! Except [`page`], nothing here touches the run store or knows about
//! studies: the functions are pure (data in, text out), which keeps the
//! outputs reproducible and testable byte for byte. [`page`] sits above the
//! stages: it reads what they wrote (files and lineage records, through
//! [`crate::store`]) and never calls a stage.

pub mod markdown;
pub mod page;
pub mod plots;
pub mod svg;
pub mod table;
