//! When two paths name one file: `out.png`, `./out.png`, `sub/../out.png`, a symbolic
//! link to it or a hard link of it. Outputs are compared before any of them exists, so
//! a path that does not exist yet is known by its canonical folder and its name.

use std::path::{Component, Path, PathBuf};

/// What a path names, for comparing paths: the canonical path (of the file, or of the
/// nearest folder that exists, followed by the rest of the path), and the device and
/// inode of a file that exists.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct FileIdentity {
    canonical: PathBuf,
    inode: Option<(u64, u64)>,
}

impl FileIdentity {
    /// Whether both name the same file: one canonical path, or one inode.
    pub fn same(&self, other: &FileIdentity) -> bool {
        self.canonical == other.canonical || (self.inode.is_some() && self.inode == other.inode)
    }
}

/// The identity of `path`, which need not exist.
pub fn file_identity(path: &Path) -> FileIdentity {
    FileIdentity {
        canonical: canonical(path),
        inode: inode(path),
    }
}

/// Whether `a` and `b` name the same file (see [`FileIdentity`]).
pub fn same_file(a: &Path, b: &Path) -> bool {
    a == b || file_identity(a).same(&file_identity(b))
}

/// The canonical path of `path`, or of its nearest existing ancestor joined with the
/// rest, whose `.` and `..` are resolved by name (nothing below that ancestor exists
/// to be a link).
fn canonical(path: &Path) -> PathBuf {
    if let Ok(c) = path.canonicalize() {
        return c;
    }
    let absolute = std::path::absolute(path).unwrap_or_else(|_| path.to_owned());
    let components: Vec<Component> = absolute.components().collect();
    for existing in (0..components.len()).rev() {
        let ancestor: PathBuf = components[..existing].iter().collect();
        let Ok(mut out) = ancestor.canonicalize() else {
            continue;
        };
        for component in &components[existing..] {
            match component {
                Component::ParentDir => {
                    out.pop();
                }
                Component::Normal(name) => out.push(name),
                _ => {}
            }
        }
        return out;
    }
    absolute
}

#[cfg(unix)]
fn inode(path: &Path) -> Option<(u64, u64)> {
    use std::os::unix::fs::MetadataExt;
    std::fs::metadata(path).ok().map(|m| (m.dev(), m.ino()))
}

#[cfg(not(unix))]
fn inode(_: &Path) -> Option<(u64, u64)> {
    None
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn one_file_under_several_names() {
        let dir = tempfile::tempdir().unwrap();
        let d = dir.path();
        std::fs::create_dir(d.join("sub")).unwrap();
        // Paths of files that do not exist yet.
        assert!(same_file(&d.join("out.png"), &d.join("./out.png")));
        assert!(same_file(&d.join("out.png"), &d.join("sub/../out.png")));
        assert!(same_file(&d.join("a/b/../out.png"), &d.join("a/out.png")));
        assert!(!same_file(&d.join("out.png"), &d.join("sub/out.png")));
        // Existing files: links, symbolic and hard.
        std::fs::write(d.join("out.png"), b"x").unwrap();
        std::os::unix::fs::symlink(d.join("out.png"), d.join("sub/link.png")).unwrap();
        std::fs::hard_link(d.join("out.png"), d.join("hard.png")).unwrap();
        assert!(same_file(&d.join("out.png"), &d.join("sub/link.png")));
        assert!(same_file(&d.join("hard.png"), &d.join("sub/../out.png")));
        assert!(!same_file(&d.join("out.png"), &d.join("sub/none.png")));
    }
}
