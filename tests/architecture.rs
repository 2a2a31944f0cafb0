//! The crate's architecture, checked: who may import whom inside `src/`.
//!
//! Each `#[test]` below is one invariant of `docs/architecture.md`
//! ("Invariants"); the page says why each rule exists. The test reads the
//! sources as text (only `std`, no parser crate) and collects every path into
//! the crate:
//!
//! - `use` statements, including grouped (`use crate::{a::b, c}`), nested and
//!   multi-line ones, and `pub use` re-exports;
//! - paths written inline in code (`crate::x::y`, `$crate::x`, `super::x`,
//!   `self::x`, `std::fs::…`, and `child::x` where `child` is a module the
//!   file declares with `mod child;`);
//! - in `src/main.rs`, the binary, `repose::…` instead of `crate::…`.
//!
//! Comments, string and character literals are blanked out first, so a path
//! in prose or in a message is not an import. Test code is not checked (a test
//! may reach anywhere): inline `#[cfg(test)] mod name { … }` blocks are cut
//! (the block ends at the `}` line with the `mod` line's indentation, as
//! rustfmt writes it) and files declared `#[cfg(test)] mod name;` are skipped.
//!
//! Run it with `cargo test --release --test architecture`, or standalone:
//! `rustc --edition 2021 --test tests/architecture.rs -o /tmp/arch && /tmp/arch`
//! from the crate root.

use std::collections::{BTreeMap, BTreeSet};
use std::fmt::Write as _;
use std::fs;
use std::path::{Path, PathBuf};
use std::sync::OnceLock;

// ---------------------------------------------------------------------------
// The rules as data
// ---------------------------------------------------------------------------

/// What the engine must never import (invariant 1).
const ENGINE_MUST_NOT_IMPORT: &[&str] = &[
    "manifest", "store", "study", "scenes", "exec", "log", "report", "commands", "tracking",
    "audit",
];

/// The pure computation modules that do no I/O (invariant 2).
const PURE_MODULES: &[&str] = &["stats", "doe", "surrogate", "search"];

/// What a pure module must never import (invariant 2), besides `std::fs`.
const PURE_MUST_NOT_IMPORT: &[&str] = &["store", "report", "exec", "study", "commands"];

/// The layers, lowest first (invariant 4). A module may import modules of its
/// own layer or of lower layers, never of a higher one;
/// `top_level_modules_form_no_import_circle` keeps imports inside one layer
/// from going round in a circle (invariant 6).
/// `main` is the binary, `src/main.rs`.
const LAYERS: &[(&str, &[&str])] = &[
    ("foundations", &["errors", "huge_pages", "streams"]),
    ("maths", &["stats", "doe", "surrogate", "search"]),
    ("engine", &["dem", "packing", "measure"]),
    ("records", &["manifest", "store", "log", "report"]),
    ("running", &["scenes", "exec"]),
    ("studies", &["study"]),
    ("tools", &["tracking", "audit", "bench"]),
    ("cli", &["commands"]),
    ("binary", &["main"]),
];

// ---------------------------------------------------------------------------
// The invariants
// ---------------------------------------------------------------------------

/// Invariant 1: the engine knows nothing of manifests, files, studies or the CLI.
#[test]
fn engine_imports_nothing_of_the_pipeline() {
    let mut bad = Vec::new();
    for file in sources().iter().filter(|f| f.top == "dem") {
        for import in &file.imports {
            if let Some(top) = import.crate_top() {
                if ENGINE_MUST_NOT_IMPORT.contains(&top) {
                    bad.push(import.describe(file, &format!("dem must not import {top}")));
                }
            }
        }
    }
    assert_none("the engine (dem) imports the pipeline", &bad);
}

/// Invariant 2: statistics, designs, surrogates and searches are pure: no file
/// I/O, no store, reports, executor, studies or commands.
#[test]
fn maths_does_no_io() {
    let mut bad = Vec::new();
    for file in sources()
        .iter()
        .filter(|f| PURE_MODULES.contains(&f.top.as_str()))
    {
        for import in &file.imports {
            let why = match &import.target {
                Target::External(path)
                    if path.len() >= 2 && path[0] == "std" && path[1] == "fs" =>
                {
                    Some("std::fs (file I/O)".to_string())
                }
                Target::Crate(path) => path
                    .first()
                    .filter(|top| PURE_MUST_NOT_IMPORT.contains(&top.as_str()))
                    .map(|top| format!("crate::{top}")),
                Target::External(_) => None,
            };
            if let Some(why) = why {
                let rule = format!("{} is pure and must not use {why}", file.top);
                bad.push(import.describe(file, &rule));
            }
        }
    }
    assert_none(
        "a pure module (stats, doe, surrogate, search) does I/O",
        &bad,
    );
}

/// Invariant 3: `commands` is the CLI's library half; only the binary calls it.
#[test]
fn only_the_binary_uses_commands() {
    let mut bad = Vec::new();
    for file in sources()
        .iter()
        .filter(|f| f.top != "commands" && f.top != "main")
    {
        for import in &file.imports {
            if import.crate_top() == Some("commands") {
                let rule = format!("only src/main.rs may use commands, not {}", file.top);
                bad.push(import.describe(file, &rule));
            }
        }
    }
    assert_none("a library module imports commands", &bad);
}

/// Invariant 4: imports point down the layers of [`LAYERS`], never up.
#[test]
fn lower_layers_never_import_higher_ones() {
    let mut bad = Vec::new();
    for file in sources().iter().filter(|f| !f.top.is_empty()) {
        let Some(from) = layer_of(&file.top) else {
            bad.push(format!(
                "{}: top-level module `{}` has no layer: add it to LAYERS in \
                 tests/architecture.rs and to docs/architecture.md",
                file.rel, file.top
            ));
            continue;
        };
        for import in &file.imports {
            let Some(to_top) = import.crate_top() else {
                continue;
            };
            let Some(to) = layer_of(to_top) else { continue };
            if to > from {
                let rule = format!(
                    "{} ({}) must not import {to_top} ({}, a higher layer)",
                    file.top, LAYERS[from].0, LAYERS[to].0
                );
                bad.push(import.describe(file, &rule));
            }
        }
    }
    assert_none("an import points up the layers", &bad);
}

/// Invariant 5: the files of `src/study/` import each other without a circle.
#[test]
fn study_files_form_no_import_circle() {
    let in_study = |f: &SourceFile| f.module.first().map(String::as_str) == Some("study");
    let graph = FileGraph::build(in_study);
    let circles = graph.circles();
    if !circles.is_empty() {
        panic!("{}", graph.explain(&circles, "src/study"));
    }
}

/// Invariant 6: the top-level modules import each other without a circle
/// (the layers allow imports inside one layer; this keeps them one-way).
/// Stage files that still import another stage's file: each pair is a
/// reader reaching into its writer (a record, a predictor, a shared
/// helper) that belongs in the layout, the plan or a record module. None
/// is left, and the list only shrinks: a new pair fails the test below, and
/// so does a listed pair that is gone (delete it here).
const KNOWN_STAGE_TO_STAGE: &[(&str, &str)] = &[];

#[test]
fn stages_import_no_new_stage() {
    let stage_of = |module: &[String]| match module {
        [study, stages, name, ..] if study == "study" && stages == "stages" => Some(name.clone()),
        _ => None,
    };
    let mut found: BTreeMap<(String, String), String> = BTreeMap::new();
    for file in sources() {
        let Some(from) = stage_of(&file.module) else {
            continue;
        };
        for import in &file.imports {
            let Target::Crate(path) = &import.target else {
                continue;
            };
            if let Some(to) = stage_of(path).filter(|to| *to != from) {
                found
                    .entry((from.clone(), to))
                    .or_insert_with(|| import.describe(file, "a stage imports another stage"));
            }
        }
    }
    let known: BTreeSet<(String, String)> = KNOWN_STAGE_TO_STAGE
        .iter()
        .map(|(a, b)| (a.to_string(), b.to_string()))
        .collect();
    let new: Vec<String> = found
        .iter()
        .filter(|(pair, _)| !known.contains(*pair))
        .map(|(_, line)| line.clone())
        .collect();
    assert_none(
        "stages reach earlier outputs through the layout (study/dir.rs) and the plan, \
         never by importing another stage",
        &new,
    );
    let gone: Vec<String> = known
        .iter()
        .filter(|pair| !found.contains_key(*pair))
        .map(|(a, b)| {
            format!("({a:?}, {b:?}) no longer imports: delete it from KNOWN_STAGE_TO_STAGE")
        })
        .collect();
    assert_none("the known stage-to-stage imports", &gone);
}

#[test]
fn top_level_modules_form_no_import_circle() {
    let circles = top_level_circles();
    if !circles.is_empty() {
        panic!(
            "import circle(s) among the top-level modules of src/:\n{}",
            circles.join("\n")
        );
    }
}

/// The scanner itself: every form of import it claims to read is read, so a
/// rule cannot pass just because the scanner saw nothing.
#[test]
fn scanner_reads_every_import_form() {
    let text = "\
//! crate::doc::comment is prose, not an import
use crate::{a::b, c::{self, D}};
use super::sibling::Thing;
pub(crate) use crate::e
    ::f;
use child::Item;
mod child;
fn f() { let _ = crate::g::h(\"crate::in_string\"); let _ = '\"'; std::fs::read(x); }
#[cfg(test)]
mod tests {
    use crate::hidden;
}
";
    let module = vec!["study".to_string(), "fine".to_string()];
    let seen: Vec<String> = scan(text, &module, false)
        .iter()
        .map(|i| format!("{}:{}", i.line, i.target))
        .collect();
    let expected = [
        "2:crate::a::b",
        "2:crate::c",
        "2:crate::c::D",
        "3:crate::study::sibling::Thing",
        "4:crate::e::f",
        "6:crate::study::fine::child::Item",
        "8:crate::g::h",
        "8:std::fs::read",
    ];
    assert_eq!(seen, expected);
}

// ---------------------------------------------------------------------------
// Reporting
// ---------------------------------------------------------------------------

/// Panics with every offending import, one per line, if there is any.
fn assert_none(what: &str, bad: &[String]) {
    if !bad.is_empty() {
        panic!("{what} ({} found):\n  {}", bad.len(), bad.join("\n  "));
    }
}

/// The index in [`LAYERS`] of a top-level module, if it has one.
fn layer_of(top: &str) -> Option<usize> {
    LAYERS
        .iter()
        .position(|(_, modules)| modules.contains(&top))
}

// ---------------------------------------------------------------------------
// The sources: files, module paths, imports
// ---------------------------------------------------------------------------

/// One `.rs` file of `src/` and the crate paths it uses.
struct SourceFile {
    /// Path from the crate root, e.g. `src/study/fine.rs`.
    rel: String,
    /// Module path, e.g. `["study", "fine"]`; empty for `lib.rs` and `main.rs`.
    module: Vec<String>,
    /// Top-level module (`study`), `main` for the binary, empty for `lib.rs`.
    top: String,
    /// Every path the file uses, in source order.
    imports: Vec<Import>,
}

/// One path used in a file, where it is and what it resolves to.
struct Import {
    /// 1-based line of the path (of its `use` keyword for a `use`).
    line: usize,
    /// The path as written (for a grouped `use`, its full expanded path).
    written: String,
    /// What the path names.
    target: Target,
}

/// What a path names: something of this crate (path from the crate root) or
/// of another crate (`std`, `serde`, …).
#[derive(Clone, PartialEq)]
enum Target {
    Crate(Vec<String>),
    External(Vec<String>),
}

impl std::fmt::Display for Target {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Target::Crate(path) if path.is_empty() => write!(f, "crate"),
            Target::Crate(path) => write!(f, "crate::{}", path.join("::")),
            Target::External(path) => write!(f, "{}", path.join("::")),
        }
    }
}

impl Import {
    /// The top-level module of the crate this import reaches, if any.
    fn crate_top(&self) -> Option<&str> {
        match &self.target {
            Target::Crate(path) => path.first().map(String::as_str),
            Target::External(_) => None,
        }
    }

    /// `file:line: \`path\` (rule)`, the line of a failure message.
    fn describe(&self, file: &SourceFile, rule: &str) -> String {
        format!("{}:{}: `{}` ({rule})", file.rel, self.line, self.written)
    }
}

/// Every checked source file of `src/`, read once for all tests.
fn sources() -> &'static [SourceFile] {
    static SOURCES: OnceLock<Vec<SourceFile>> = OnceLock::new();
    SOURCES.get_or_init(read_sources)
}

/// The crate root: Cargo's manifest dir, or the current dir when the test is
/// built by plain `rustc`.
fn crate_root() -> PathBuf {
    PathBuf::from(option_env!("CARGO_MANIFEST_DIR").unwrap_or("."))
}

/// Reads and scans every `.rs` file under `src/` except test-only files.
fn read_sources() -> Vec<SourceFile> {
    let root = crate_root();
    let mut paths = Vec::new();
    collect_rs_files(&root.join("src"), &mut paths);
    assert!(
        !paths.is_empty(),
        "no .rs files under {}: run from the crate root",
        root.join("src").display()
    );
    let texts: Vec<(PathBuf, String)> = paths
        .into_iter()
        .map(|p| {
            let text = fs::read_to_string(&p).unwrap_or_else(|e| panic!("{}: {e}", p.display()));
            (p, text)
        })
        .collect();
    let test_only = test_only_modules(&root, &texts);
    let mut files = Vec::new();
    for (path, text) in &texts {
        let rel = path.strip_prefix(&root).unwrap_or(path);
        let rel_src = rel.strip_prefix("src").unwrap_or(rel);
        let binary = rel_src == Path::new("main.rs");
        let module = module_path(rel_src);
        if test_only.iter().any(|t| module.starts_with(t)) && !module.is_empty() {
            continue;
        }
        let top = if binary {
            "main".to_string()
        } else {
            module.first().cloned().unwrap_or_default()
        };
        files.push(SourceFile {
            rel: rel.to_string_lossy().replace('\\', "/"),
            imports: scan(text, &module, binary),
            module,
            top,
        });
    }
    files
}

/// Every `.rs` file under `dir`, recursively, in sorted order.
fn collect_rs_files(dir: &Path, out: &mut Vec<PathBuf>) {
    let mut entries: Vec<PathBuf> = fs::read_dir(dir)
        .unwrap_or_else(|e| panic!("{}: {e}", dir.display()))
        .map(|entry| entry.expect("directory entry").path())
        .collect();
    entries.sort();
    for path in entries {
        if path.is_dir() {
            collect_rs_files(&path, out);
        } else if path.extension().is_some_and(|ext| ext == "rs") {
            out.push(path);
        }
    }
}

/// The module path of a file given relative to `src/`:
/// `study/fine.rs` → `study::fine`, `study/convergence/mod.rs` →
/// `study::convergence`, `lib.rs` and `main.rs` → the crate root (empty).
fn module_path(rel_src: &Path) -> Vec<String> {
    let mut parts: Vec<String> = rel_src
        .iter()
        .map(|part| part.to_string_lossy().into_owned())
        .collect();
    let last = parts.pop().unwrap_or_default();
    let stem = last.strip_suffix(".rs").unwrap_or(&last);
    if parts.is_empty() && (stem == "lib" || stem == "main") {
        return Vec::new();
    }
    if stem != "mod" {
        parts.push(stem.to_string());
    }
    parts
}

/// Module paths declared test-only (`#[cfg(test)] mod name;`), whose files
/// are test code and not checked.
fn test_only_modules(root: &Path, texts: &[(PathBuf, String)]) -> Vec<Vec<String>> {
    let mut found = Vec::new();
    for (path, text) in texts {
        let rel = path.strip_prefix(root.join("src")).unwrap_or(path);
        let module = module_path(rel);
        let lines: Vec<&str> = text.lines().collect();
        for (i, line) in lines.iter().enumerate() {
            if line.trim() != "#[cfg(test)]" {
                continue;
            }
            if let Some((name, false)) = lines.get(i + 1).and_then(|l| mod_declaration(l)) {
                let mut child = module.clone();
                child.push(name);
                found.push(child);
            }
        }
    }
    found
}

/// A `mod name;` or `mod name {` line (any visibility): the name and whether
/// the module is inline (`{`).
fn mod_declaration(line: &str) -> Option<(String, bool)> {
    let rest = strip_visibility(line.trim());
    let rest = rest.strip_prefix("mod ")?.trim_start();
    let name: String = rest.chars().take_while(|c| is_ident_char(*c)).collect();
    let after = rest[name.len()..].trim();
    match after {
        ";" if !name.is_empty() => Some((name, false)),
        "{" if !name.is_empty() => Some((name, true)),
        _ => None,
    }
}

/// `line` without a leading `pub`, `pub(crate)`, `pub(super)`, … .
fn strip_visibility(line: &str) -> &str {
    let Some(rest) = line.strip_prefix("pub") else {
        return line;
    };
    let rest = if rest.starts_with('(') {
        match rest.find(')') {
            Some(close) => &rest[close + 1..],
            None => return line,
        }
    } else {
        rest
    };
    if rest.starts_with(char::is_whitespace) {
        rest.trim_start()
    } else {
        line
    }
}

/// Whether `c` may appear in an identifier.
fn is_ident_char(c: char) -> bool {
    c.is_alphanumeric() || c == '_'
}

// ---------------------------------------------------------------------------
// Scanning one file
// ---------------------------------------------------------------------------

/// Every path a file's text uses outside comments, literals and test modules.
/// `module` is the file's module path; `binary` says `repose::` means `crate::`.
fn scan(text: &str, module: &[String], binary: bool) -> Vec<Import> {
    let code = without_test_modules(&blank_comments_and_literals(text));
    let lines: Vec<&str> = code.lines().collect();
    let children = child_modules(&lines);
    let resolver = Resolver {
        module,
        children: &children,
        binary,
    };
    let mut imports = Vec::new();
    let mut i = 0;
    while i < lines.len() {
        if is_use_start(lines[i]) {
            let (statement, last) = use_statement(&lines, i);
            for path in expand_use_tree(&statement) {
                imports.extend(resolver.import(i + 1, &path));
            }
            i = last + 1;
        } else {
            for path in inline_paths(lines[i], &resolver) {
                imports.extend(resolver.import(i + 1, &path));
            }
            i += 1;
        }
    }
    imports
}

/// The text with comments replaced by spaces and the contents of string and
/// character literals blanked, newlines kept so line numbers stay right.
fn blank_comments_and_literals(text: &str) -> String {
    let chars: Vec<char> = text.chars().collect();
    let mut out = String::with_capacity(text.len());
    let blank = |c: char| if c == '\n' { '\n' } else { ' ' };
    let mut i = 0;
    while i < chars.len() {
        let c = chars[i];
        let next = chars.get(i + 1).copied();
        if c == '/' && next == Some('/') {
            while i < chars.len() && chars[i] != '\n' {
                out.push(' ');
                i += 1;
            }
        } else if c == '/' && next == Some('*') {
            let mut depth = 0;
            while i < chars.len() {
                if chars[i] == '/' && chars.get(i + 1) == Some(&'*') {
                    depth += 1;
                    out.push_str("  ");
                    i += 2;
                } else if chars[i] == '*' && chars.get(i + 1) == Some(&'/') {
                    depth -= 1;
                    out.push_str("  ");
                    i += 2;
                    if depth == 0 {
                        break;
                    }
                } else {
                    out.push(blank(chars[i]));
                    i += 1;
                }
            }
        } else if let Some(hashes) = raw_string_start(&chars, i) {
            // r"…", r#"…"#, br"…": no escapes; ends at '"' and as many '#'.
            let open = i + chars[i..].iter().position(|&c| c == '"').unwrap_or(0);
            out.extend(std::iter::repeat_n(' ', open - i));
            out.push('"');
            i = open + 1;
            while i < chars.len() {
                let closes =
                    chars[i] == '"' && (0..hashes).all(|k| chars.get(i + 1 + k) == Some(&'#'));
                if closes {
                    out.push('"');
                    out.extend(std::iter::repeat_n(' ', hashes));
                    i += 1 + hashes;
                    break;
                }
                out.push(blank(chars[i]));
                i += 1;
            }
        } else if c == '"' {
            out.push('"');
            i += 1;
            while i < chars.len() && chars[i] != '"' {
                if chars[i] == '\\' {
                    out.push(' ');
                    i += 1;
                }
                if i < chars.len() {
                    out.push(blank(chars[i]));
                    i += 1;
                }
            }
            out.push('"');
            i += 1;
        } else if let Some(len) = char_literal_len(&chars, i) {
            out.push('\'');
            out.extend(std::iter::repeat_n(' ', len - 2));
            out.push('\'');
            i += len;
        } else {
            out.push(c);
            i += 1;
        }
    }
    out
}

/// If a raw string literal (`r"`, `r#"`, `br#"`, …) starts at `i`, its number
/// of `#`.
fn raw_string_start(chars: &[char], i: usize) -> Option<usize> {
    if i > 0 && is_ident_char(chars[i - 1]) {
        return None;
    }
    let mut j = i;
    if chars.get(j) == Some(&'b') {
        j += 1;
    }
    if chars.get(j) != Some(&'r') {
        return None;
    }
    j += 1;
    let hashes = chars[j..].iter().take_while(|&&c| c == '#').count();
    (chars.get(j + hashes) == Some(&'"')).then_some(hashes)
}

/// If a character literal (`'x'`, `'\n'`, `'\u{1F600}'`) starts at `i`, its
/// length in chars; `None` for a lifetime (`'a`) or anything else.
fn char_literal_len(chars: &[char], i: usize) -> Option<usize> {
    if chars[i] != '\'' {
        return None;
    }
    if chars.get(i + 1) == Some(&'\\') {
        let close = chars[i + 2..].iter().position(|&c| c == '\'')?;
        return Some(close + 3);
    }
    (chars.get(i + 2) == Some(&'\'')).then_some(3)
}

/// The text with every `#[cfg(test)] mod name { … }` block blanked (the block
/// ends at the line `}` with the indentation of its `mod` line).
fn without_test_modules(code: &str) -> String {
    let lines: Vec<&str> = code.lines().collect();
    let mut out = String::with_capacity(code.len());
    let mut closing: Option<String> = None;
    for (i, line) in lines.iter().enumerate() {
        if let Some(end) = &closing {
            if line.trim_end() == end {
                closing = None;
            }
            out.push('\n');
            continue;
        }
        let next = lines.get(i + 1).copied().unwrap_or("");
        if line.trim() == "#[cfg(test)]" && matches!(mod_declaration(next), Some((_, true))) {
            let indent = next.len() - next.trim_start().len();
            closing = Some(format!("{}}}", &next[..indent]));
            out.push('\n');
            continue;
        }
        out.push_str(line);
        out.push('\n');
    }
    out
}

/// Names of the modules a file declares (`mod name;`, `pub mod name;`).
fn child_modules(lines: &[&str]) -> BTreeSet<String> {
    lines
        .iter()
        .filter_map(|line| mod_declaration(line))
        .filter(|(_, inline)| !inline)
        .map(|(name, _)| name)
        .collect()
}

/// Whether a line starts a `use` statement (any visibility).
fn is_use_start(line: &str) -> bool {
    strip_visibility(line.trim_start()).starts_with("use ")
}

/// The `use` statement starting at line `first` (without `use` and `;`), and
/// the index of its last line.
fn use_statement(lines: &[&str], first: usize) -> (String, usize) {
    let mut text = String::new();
    for (i, line) in lines.iter().enumerate().skip(first) {
        text.push_str(line);
        text.push(' ');
        if line.contains(';') {
            let start = text.find("use ").map_or(0, |p| p + 4);
            let end = text.find(';').unwrap_or(text.len());
            return (text[start..end].to_string(), i);
        }
    }
    (text, lines.len() - 1)
}

/// The tokens of a use tree: identifiers (and `*`), `::`, `{`, `}`, `,`.
fn use_tokens(tree: &str) -> Vec<String> {
    let chars: Vec<char> = tree.chars().collect();
    let mut tokens = Vec::new();
    let mut i = 0;
    while i < chars.len() {
        let c = chars[i];
        if c == ':' && chars.get(i + 1) == Some(&':') {
            tokens.push("::".to_string());
            i += 2;
        } else if "{},*".contains(c) {
            tokens.push(c.to_string());
            i += 1;
        } else if is_ident_char(c) || c == '$' {
            let word: String = chars[i..]
                .iter()
                .take_while(|&&c| is_ident_char(c) || c == '$')
                .collect();
            i += word.chars().count();
            tokens.push(word);
        } else {
            i += 1;
        }
    }
    tokens
}

/// The full paths a use tree names: `crate::{a::b, c::{self, D}}` →
/// `crate::a::b`, `crate::c`, `crate::c::D` (a rename `as x` is dropped, a
/// glob `*` names its module).
fn expand_use_tree(tree: &str) -> Vec<Vec<String>> {
    let tokens = use_tokens(tree);
    let mut out = Vec::new();
    let mut pos = 0;
    expand_subtree(&tokens, &mut pos, &[], &mut out);
    out
}

/// Expands one use tree starting at `tokens[*pos]` under `prefix`.
fn expand_subtree(
    tokens: &[String],
    pos: &mut usize,
    prefix: &[String],
    out: &mut Vec<Vec<String>>,
) {
    let mut path = prefix.to_vec();
    loop {
        match tokens.get(*pos).map(String::as_str) {
            Some("{") => {
                *pos += 1;
                while !matches!(tokens.get(*pos).map(String::as_str), Some("}") | None) {
                    expand_subtree(tokens, pos, &path, out);
                    if tokens.get(*pos).map(String::as_str) == Some(",") {
                        *pos += 1;
                    }
                }
                *pos += 1; // the closing '}'
                return;
            }
            Some("*") => {
                *pos += 1;
                break;
            }
            Some("self") if !path.is_empty() => *pos += 1,
            Some(word) if word != "," && word != "}" && word != "::" => {
                path.push(word.to_string());
                *pos += 1;
            }
            _ => break,
        }
        match tokens.get(*pos).map(String::as_str) {
            Some("::") => *pos += 1,
            Some("as") => {
                *pos += 2; // `as name`
                break;
            }
            _ => break,
        }
    }
    // A rename may follow a path word without `::` in between.
    if tokens.get(*pos).map(String::as_str) == Some("as") {
        *pos += 2;
    }
    if !path.is_empty() {
        out.push(path);
    }
}

/// Paths written inline on one code line that start at a root the resolver
/// knows (`crate`, `$crate`, `super`, `self`, `std`, a declared child module;
/// `repose` in the binary), e.g. `crate::report::table::TableError`.
fn inline_paths(line: &str, resolver: &Resolver) -> Vec<Vec<String>> {
    let chars: Vec<char> = line.chars().collect();
    let mut paths = Vec::new();
    let mut i = 0;
    while i < chars.len() {
        let starts_word = (is_ident_char(chars[i]) || chars[i] == '$')
            && (i == 0 || !(is_ident_char(chars[i - 1]) || chars[i - 1] == '$'))
            && !(i >= 2 && chars[i - 1] == ':' && chars[i - 2] == ':');
        if !starts_word {
            i += 1;
            continue;
        }
        let (path, end) = path_at(&chars, i);
        if path.len() >= 2 && resolver.knows_root(&path[0]) {
            paths.push(path);
        }
        i = end.max(i + 1);
    }
    paths
}

/// The `a::b::c` chain of identifiers starting at `i`, and where it ends.
fn path_at(chars: &[char], mut i: usize) -> (Vec<String>, usize) {
    let mut path = Vec::new();
    loop {
        let word: String = chars[i..]
            .iter()
            .take_while(|&&c| is_ident_char(c) || c == '$')
            .collect();
        if word.is_empty() {
            break;
        }
        i += word.chars().count();
        path.push(word);
        let more = chars.get(i) == Some(&':')
            && chars.get(i + 1) == Some(&':')
            && chars.get(i + 2).is_some_and(|&c| is_ident_char(c));
        if !more {
            break;
        }
        i += 2;
    }
    (path, i)
}

/// Turns paths written in one file into crate-absolute targets.
struct Resolver<'a> {
    /// The file's module path.
    module: &'a [String],
    /// Modules the file declares, usable as `child::…`.
    children: &'a BTreeSet<String>,
    /// `src/main.rs`: the library is `repose::`.
    binary: bool,
}

impl Resolver<'_> {
    /// Whether an inline path starting with `root` is one this test follows.
    fn knows_root(&self, root: &str) -> bool {
        matches!(root, "crate" | "$crate" | "super" | "self" | "std")
            || (self.binary && root == "repose")
            || self.children.contains(root)
    }

    /// The import for a path written at `line`; `None` for a path that names
    /// nothing this test cares about (e.g. a bare `serde`).
    fn import(&self, line: usize, path: &[String]) -> Option<Import> {
        let target = self.resolve(path)?;
        Some(Import {
            line,
            written: path.join("::"),
            target,
        })
    }

    /// A written path as a crate-absolute path, or an external one.
    fn resolve(&self, path: &[String]) -> Option<Target> {
        let (first, rest) = path.split_first()?;
        let rest: Vec<String> = rest.to_vec();
        let within = |base: &[String], rest: Vec<String>| {
            let mut abs = base.to_vec();
            abs.extend(rest);
            Target::Crate(abs)
        };
        match first.as_str() {
            "crate" | "$crate" => Some(Target::Crate(rest)),
            "repose" if self.binary => Some(Target::Crate(rest)),
            "self" => Some(within(self.module, rest)),
            "super" => {
                let mut base = self.module.to_vec();
                base.pop();
                let mut rest = rest.as_slice();
                while rest.first().map(String::as_str) == Some("super") {
                    base.pop();
                    rest = &rest[1..];
                }
                Some(within(&base, rest.to_vec()))
            }
            name if self.children.contains(name) => Some(within(self.module, path.to_vec())),
            _ => Some(Target::External(path.to_vec())),
        }
    }
}

// ---------------------------------------------------------------------------
// Import graphs and their circles
// ---------------------------------------------------------------------------

/// A file-level import graph among some of the source files.
struct FileGraph {
    /// The files (indices into [`sources`]) that are nodes.
    nodes: Vec<usize>,
    /// For each node, the nodes it imports, with the first import that does.
    edges: Vec<BTreeMap<usize, (usize, String)>>,
}

impl FileGraph {
    /// The graph among the files `keep` selects: an import of a path depends
    /// on the file of the longest module prefix of that path
    /// (`crate::study::x::Y` → the file of `study::x`, its `mod.rs` for a
    /// directory module). An import of an enclosing module's own items
    /// (`super::StudyError` from `study/mod.rs`) is not an edge: a module's
    /// root holding what its children share, and calling them, is Rust's
    /// usual shape, not a circle between siblings.
    fn build(keep: impl Fn(&SourceFile) -> bool) -> FileGraph {
        let all = sources();
        let nodes: Vec<usize> = (0..all.len()).filter(|&i| keep(&all[i])).collect();
        let by_module: BTreeMap<&[String], usize> = nodes
            .iter()
            .enumerate()
            .map(|(node, &i)| (all[i].module.as_slice(), node))
            .collect();
        let mut edges = vec![BTreeMap::new(); nodes.len()];
        for (from, &i) in nodes.iter().enumerate() {
            let file = &all[i];
            for import in &file.imports {
                let Target::Crate(path) = &import.target else {
                    continue;
                };
                let Some(to) = (1..=path.len())
                    .rev()
                    .find_map(|n| by_module.get(&path[..n]).copied())
                else {
                    continue;
                };
                let target_module = &all[nodes[to]].module;
                let encloses = file.module.starts_with(target_module);
                if to != from && !encloses {
                    edges[from]
                        .entry(to)
                        .or_insert((import.line, import.written.clone()));
                }
            }
        }
        FileGraph { nodes, edges }
    }

    /// Every strongly connected component of more than one file.
    fn circles(&self) -> Vec<Vec<usize>> {
        let successors: Vec<Vec<usize>> = self
            .edges
            .iter()
            .map(|e| e.keys().copied().collect())
            .collect();
        strongly_connected(&successors)
            .into_iter()
            .filter(|component| component.len() > 1)
            .collect()
    }

    /// The failure message: each circle's files, and the import lines that
    /// close it.
    fn explain(&self, circles: &[Vec<usize>], place: &str) -> String {
        let all = sources();
        let name = |node: usize| all[self.nodes[node]].rel.clone();
        let mut msg = format!(
            "{} import circle(s) among the files of {place}:\n",
            circles.len()
        );
        for circle in circles {
            let mut files: Vec<String> = circle.iter().map(|&n| name(n)).collect();
            files.sort();
            let _ = writeln!(
                msg,
                "\n  circle of {} files: {}",
                files.len(),
                files.join(", ")
            );
            let members: BTreeSet<usize> = circle.iter().copied().collect();
            let mut sorted: Vec<usize> = circle.clone();
            sorted.sort_by_key(|&n| name(n));
            for from in sorted {
                for (to, (line, written)) in &self.edges[from] {
                    if members.contains(to) {
                        let _ = writeln!(
                            msg,
                            "    {}:{}: `{written}` → {}",
                            name(from),
                            line,
                            name(*to)
                        );
                    }
                }
            }
        }
        msg
    }
}

/// Circles among the top-level modules, each described by its modules and,
/// per import edge inside it, the first line that makes it.
fn top_level_circles() -> Vec<String> {
    let names: Vec<&str> = LAYERS
        .iter()
        .flat_map(|(_, modules)| modules.iter().copied())
        .collect();
    let index = |top: &str| names.iter().position(|n| *n == top);
    let mut edges: Vec<BTreeMap<usize, String>> = vec![BTreeMap::new(); names.len()];
    for file in sources() {
        let Some(from) = index(&file.top) else {
            continue;
        };
        for import in &file.imports {
            let Some(to) = import.crate_top().and_then(index) else {
                continue;
            };
            if to != from {
                edges[from].entry(to).or_insert_with(|| {
                    format!("{}:{}: `{}`", file.rel, import.line, import.written)
                });
            }
        }
    }
    let successors: Vec<Vec<usize>> = edges.iter().map(|e| e.keys().copied().collect()).collect();
    let mut circles = Vec::new();
    for component in strongly_connected(&successors) {
        if component.len() < 2 {
            continue;
        }
        let mut members: Vec<usize> = component.clone();
        members.sort_by_key(|&m| names[m]);
        let listed: Vec<&str> = members.iter().map(|&m| names[m]).collect();
        let mut text = format!("  circle: {}", listed.join(", "));
        for &from in &members {
            for (to, first) in &edges[from] {
                if component.contains(to) {
                    let _ = write!(text, "\n    {} → {}: {first}", names[from], names[*to]);
                }
            }
        }
        circles.push(text);
    }
    circles
}

/// The strongly connected components of a graph given as successor lists
/// (Tarjan's algorithm, iterative so deep graphs cannot overflow the stack).
fn strongly_connected(successors: &[Vec<usize>]) -> Vec<Vec<usize>> {
    const UNSEEN: usize = usize::MAX;
    let n = successors.len();
    let mut index = vec![UNSEEN; n];
    let mut low = vec![0; n];
    let mut on_stack = vec![false; n];
    let mut stack = Vec::new();
    let mut components = Vec::new();
    let mut counter = 0;
    for start in 0..n {
        if index[start] != UNSEEN {
            continue;
        }
        // Each frame: a node and how many of its successors were visited.
        let mut frames = vec![(start, 0)];
        index[start] = counter;
        low[start] = counter;
        counter += 1;
        stack.push(start);
        on_stack[start] = true;
        while let Some(frame) = frames.last_mut() {
            let node = frame.0;
            if let Some(&succ) = successors[node].get(frame.1) {
                frame.1 += 1;
                if index[succ] == UNSEEN {
                    index[succ] = counter;
                    low[succ] = counter;
                    counter += 1;
                    stack.push(succ);
                    on_stack[succ] = true;
                    frames.push((succ, 0));
                } else if on_stack[succ] {
                    low[node] = low[node].min(index[succ]);
                }
                continue;
            }
            frames.pop();
            if let Some(&(parent, _)) = frames.last() {
                low[parent] = low[parent].min(low[node]);
            }
            if low[node] == index[node] {
                let mut component = Vec::new();
                while let Some(member) = stack.pop() {
                    on_stack[member] = false;
                    component.push(member);
                    if member == node {
                        break;
                    }
                }
                components.push(component);
            }
        }
    }
    components
}
