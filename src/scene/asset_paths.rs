//! Finding the files an OBJ or MTL names (material libraries, textures) when the scene
//! was written on another machine: `C:\Users\…\wood.jpg`, absolute paths of the
//! author's disk, backslashes, textures moved into a subfolder, names in another case.
//!
//! The rules, in order; the first that finds the file wins:
//! 1. as written, relative to each of the folders the name is looked up in (the folder
//!    of the file that names it first);
//! 2. the same with backslashes read as separators;
//! 3. by its file name alone, in each folder and its subfolders `textures/`, `maps/`
//!    and `tex/`;
//! 4. the paths of rules 2 and 3 matched without regard to case.
//!
//! A file found by rule 2 or later comes with a sentence saying how it was found, for a
//! warning; `--strict` accepts rules 1 and 2 only (what ember has always read).

use std::path::{Component, Path, PathBuf};

/// The subfolders rule 3 looks in besides the folder itself.
const SUBFOLDERS: [&str; 3] = ["textures", "maps", "tex"];

/// Which rule found a file.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) enum Rule {
    AsWritten,
    Backslashes,
    FileName,
    IgnoringCase,
}

impl Rule {
    /// Whether `--strict` accepts a file found by this rule.
    pub fn strict_accepts(self) -> bool {
        matches!(self, Rule::AsWritten | Rule::Backslashes)
    }
}

/// A file found for a written name.
#[derive(Clone, Debug, PartialEq, Eq)]
pub(super) struct Found {
    pub path: PathBuf,
    pub rule: Rule,
}

impl Found {
    /// How it was found, for a warning (`None` for a file found as written).
    pub fn how(&self) -> Option<String> {
        let at = self.path.display();
        match self.rule {
            Rule::AsWritten => None,
            Rule::Backslashes => Some(format!("found as {at}, reading backslashes as separators")),
            Rule::FileName => Some(format!("found by its file name alone, at {at}")),
            Rule::IgnoringCase => Some(format!("found at {at} by ignoring upper and lower case")),
        }
    }
}

/// Finds the file `written` names, looking in `folders` (the referring file's folder
/// first) by the rules of the module documentation; `None` when no rule finds it.
/// Rule 1 takes anything that exists (a directory named as a texture is then refused
/// by its reader, as damage, not absence); the later rules take regular files only.
pub(super) fn find(written: &str, folders: &[&Path]) -> Option<Found> {
    let found = |path: PathBuf, rule| Found { path, rule };
    for folder in folders {
        let path = folder.join(written);
        if path.exists() {
            return Some(found(path, Rule::AsWritten));
        }
    }
    let slashed = written.replace('\\', "/");
    if slashed != written {
        for folder in folders {
            let path = folder.join(&slashed);
            if path.exists() {
                return Some(found(path, Rule::Backslashes));
            }
        }
    }
    let name = file_name(&slashed)?;
    for candidate in by_file_name(name, folders) {
        if candidate.is_file() {
            return Some(found(candidate, Rule::FileName));
        }
    }
    let relative = is_relative(&slashed).then(|| Path::new(&slashed));
    let by_case = folders
        .iter()
        .filter_map(|folder| relative.and_then(|r| match_ignoring_case(folder, r)))
        .chain(
            folders
                .iter()
                .flat_map(|folder| by_file_name_relative(name, folder))
                .filter_map(|(folder, r)| match_ignoring_case(folder, &r)),
        )
        .next()?;
    Some(found(by_case, Rule::IgnoringCase))
}

/// The last component of a path written with `/` separators (after a Windows drive
/// letter too), if it names a file.
fn file_name(slashed: &str) -> Option<&str> {
    let name = slashed.rsplit('/').next()?;
    let name = name.rsplit_once(':').map_or(name, |(_, after)| after);
    (!name.is_empty() && name != "." && name != "..").then_some(name)
}

/// Whether a path written with `/` separators stays inside the folder it is joined
/// to: not absolute, no drive letter, no `..`.
fn is_relative(slashed: &str) -> bool {
    let path = Path::new(slashed);
    !slashed.contains(':')
        && path
            .components()
            .all(|c| matches!(c, Component::Normal(_) | Component::CurDir))
}

/// Where rule 3 looks for `name`: in each folder, then in its subfolders.
fn by_file_name<'a>(name: &'a str, folders: &'a [&'a Path]) -> impl Iterator<Item = PathBuf> + 'a {
    folders
        .iter()
        .flat_map(move |folder| by_file_name_relative(name, folder))
        .map(|(folder, relative)| folder.join(relative))
}

/// Rule 3's places for `name` in one folder, as (folder, path relative to it).
fn by_file_name_relative<'a>(
    name: &'a str,
    folder: &'a Path,
) -> impl Iterator<Item = (&'a Path, PathBuf)> + 'a {
    std::iter::once(PathBuf::from(name))
        .chain(SUBFOLDERS.iter().map(move |sub| Path::new(sub).join(name)))
        .map(move |relative| (folder, relative))
}

/// The regular file at `relative` under `folder`, each component matched without
/// regard to case (the first match in directory order where several differ only in
/// case).
fn match_ignoring_case(folder: &Path, relative: &Path) -> Option<PathBuf> {
    let mut at = folder.to_path_buf();
    for component in relative.components() {
        let Component::Normal(wanted) = component else {
            continue;
        };
        let wanted = wanted.to_string_lossy().to_lowercase();
        let dir = if at.as_os_str().is_empty() {
            Path::new(".")
        } else {
            &at
        };
        let entry = std::fs::read_dir(dir)
            .ok()?
            .filter_map(Result::ok)
            .find(|e| e.file_name().to_string_lossy().to_lowercase() == wanted)?;
        at.push(entry.file_name());
    }
    at.is_file().then_some(at)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn each_rule_in_turn() {
        let dir = tempfile::tempdir().unwrap();
        let d = dir.path();
        std::fs::create_dir_all(d.join("sub")).unwrap();
        std::fs::create_dir_all(d.join("Textures")).unwrap();
        for f in ["a.png", "sub/b.png", "Textures/Wood.PNG", "C.png"] {
            std::fs::write(d.join(f), b"x").unwrap();
        }
        let other = tempfile::tempdir().unwrap();
        let folders = [other.path(), d];
        let rule = |written: &str| find(written, &folders).map(|f| (f.path, f.rule));
        assert_eq!(rule("a.png"), Some((d.join("a.png"), Rule::AsWritten)));
        let absolute = d.join("a.png").display().to_string();
        assert_eq!(rule(&absolute), Some((d.join("a.png"), Rule::AsWritten)));
        assert_eq!(
            rule("sub\\b.png"),
            Some((d.join("sub/b.png"), Rule::Backslashes))
        );
        assert_eq!(
            rule("C:\\Users\\x\\a.png"),
            Some((d.join("a.png"), Rule::FileName))
        );
        // Rule 3 looks in the folders and their usual subfolders, not everywhere.
        assert_eq!(rule("/home/someone/scene/b.png"), None);
        assert_eq!(
            rule("textures\\wood.png"),
            Some((d.join("Textures/Wood.PNG"), Rule::IgnoringCase))
        );
        assert_eq!(
            rule("D:/art/WOOD.png"),
            Some((d.join("Textures/Wood.PNG"), Rule::IgnoringCase))
        );
        assert_eq!(rule("c.PNG"), Some((d.join("C.png"), Rule::IgnoringCase)));
        assert_eq!(rule("nowhere.png"), None);
        assert_eq!(rule("sub"), Some((d.join("sub"), Rule::AsWritten)));
        assert_eq!(rule("../x/"), None);
    }
}
