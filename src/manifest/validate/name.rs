//! The one rule for a name that becomes a file-system path component: a study's
//! name (its directory `studies/<name>-<id>`), a design study's scene, factor and
//! response names (output directories and files such as `rsm/<response>/` and
//! `screen/<response>.svg`), and a he2019 study's target scene names.
//!
//! Every such name is checked here and only here, when the document is
//! validated, so no stage can join a name that escapes the store: no path
//! separator, no `.` or `..`, no leading dot (a hidden or parent entry), no
//! control character (NUL, newline, ESC: they break listings and terminals), no
//! leading or trailing white space, and at most [`MAX_NAME_CHARS`] characters.

/// Longest name allowed (characters): the study directory adds a 13-character id
/// suffix and every stage a file name, and common file systems cap a component
/// at 255 bytes.
pub const MAX_NAME_CHARS: usize = 64;

/// `Ok` when `name` is safe as one path component, else what is allowed.
pub fn check_path_component(name: &str) -> Result<(), String> {
    const RULE: &str = "must be a non-empty name usable as one file name: at most 64 \
                        characters, no path separator (/ or \\), no control characters, not \
                        starting with '.' and without leading or trailing spaces";
    let chars = name.chars().count();
    let bad = chars == 0
        || chars > MAX_NAME_CHARS
        || name.starts_with('.')
        || name.trim() != name
        || name
            .chars()
            .any(|c| c == '/' || c == '\\' || c.is_control());
    if bad {
        Err(RULE.to_string())
    } else {
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names_that_escape_or_break_a_listing_are_refused() {
        for bad in [
            "",
            "/tmp/x",
            "../../../../../../tmp/x",
            "..",
            ".",
            ".hidden",
            "a/b",
            "a\\b",
            "nul\0byte",
            "new\nline",
            "esc\u{1b}[31m",
            " padded",
            "padded ",
            &"x".repeat(65),
        ] {
            assert!(check_path_component(bad).is_err(), "{bad:?} was accepted");
        }
    }

    #[test]
    fn ordinary_names_pass() {
        for good in [
            "he2019",
            "cai2024-smoke",
            "drum_angle_deg",
            "A",
            "μ_pw",
            "my study",
            "a..b",
            &"x".repeat(64),
        ] {
            assert!(check_path_component(good).is_ok(), "{good:?} was refused");
        }
    }
}
