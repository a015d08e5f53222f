//! What a load does when an input is absent (a material library, a texture, a material
//! named by `usemtl`) or was found only by looking beyond where it was written: a
//! warning naming it and what is used instead, and the render goes on; with `strict`,
//! the error ember gave before such scenes were tolerated.

use std::path::PathBuf;

use super::asset_paths::Found;
use super::SceneError;

/// How a scene is loaded.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct LoadOptions {
    /// Absent inputs, and files found only by their file name or by ignoring case, are
    /// errors instead of warnings (`ember render --strict`).
    pub strict: bool,
}

/// The warnings of one load so far.
pub(super) struct Warnings {
    strict: bool,
    pub lines: Vec<String>,
}

impl Warnings {
    pub fn new(options: &LoadOptions) -> Self {
        Warnings {
            strict: options.strict,
            lines: Vec::new(),
        }
    }

    pub fn push(&mut self, line: String) {
        self.lines.push(line);
    }

    /// An absent input: with `strict`, `error`; otherwise one warning, `error`'s
    /// message followed by what is used instead.
    pub fn absent(&mut self, error: SceneError, instead: &str) -> Result<(), SceneError> {
        if self.strict {
            return Err(error);
        }
        self.lines.push(format!("{error}; {instead}"));
        Ok(())
    }

    /// The file found for a name (by [`super::asset_paths::find`]), with a warning
    /// saying how when a later rule found it; `None` (warned) or an error
    /// (`strict`) when it is absent. `missing` makes the error of an absent file from
    /// its reason; `instead` says what is used in its place.
    pub fn located(
        &mut self,
        found: Option<Found>,
        missing: impl FnOnce(String) -> SceneError,
        instead: &str,
    ) -> Result<Option<PathBuf>, SceneError> {
        let Some(found) = found else {
            self.absent(missing("file not found".into()), instead)?;
            return Ok(None);
        };
        let Some(how) = found.how() else {
            return Ok(Some(found.path));
        };
        if self.strict && !found.rule.strict_accepts() {
            return Err(missing(format!(
                "file not found as written ({how}, which --strict does not accept)"
            )));
        }
        // Said as the error would say it, so that the warning names what refers to it.
        let reason = match found.rule.strict_accepts() {
            true => how,
            false => format!("not found as written; {how}"),
        };
        self.lines.push(missing(reason).to_string());
        Ok(Some(found.path))
    }
}
