//! Where a verb may read files it finds (not files the user names on the command line):
//! inside one folder, after resolving `..` and symbolic links, and never in a hidden file or
//! folder. `sweep claims` reads its sources so, and `sweep index` every document, plan and
//! experiment copy of the folder it indexes — a `REPRODUCTION.md` or `experiment.toml` that
//! is a link to a file outside the repository would otherwise be rendered into a page that
//! gets committed and published.

use std::path::{Component, Path, PathBuf};

/// Why a path was refused.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub(crate) enum Refused {
    /// Nothing is there (or a link points nowhere).
    #[error("{} does not exist", .0.display())]
    Missing(PathBuf),
    /// It resolves outside the folder.
    #[error("{} leads outside {} (after resolving `..` and links)", .path.display(), .root.display())]
    Outside {
        /// The path as asked for.
        path: PathBuf,
        /// The folder it must stay in.
        root: PathBuf,
    },
    /// It is a hidden file or inside a hidden folder (below the root).
    #[error("{} is a hidden file or inside a hidden folder", .0.display())]
    Hidden(PathBuf),
}

/// `path` resolved (links and `..`), when it exists inside `root` — which must itself be
/// resolved ([`std::fs::canonicalize`]) — and is neither hidden nor inside a hidden folder
/// below it.
pub(crate) fn inside(path: &Path, root: &Path) -> Result<PathBuf, Refused> {
    let real = std::fs::canonicalize(path).map_err(|_| Refused::Missing(path.to_path_buf()))?;
    let Ok(within) = real.strip_prefix(root) else {
        return Err(Refused::Outside {
            path: path.to_path_buf(),
            root: root.to_path_buf(),
        });
    };
    if within
        .components()
        .any(|c| matches!(c, Component::Normal(n) if n.to_string_lossy().starts_with('.')))
    {
        return Err(Refused::Hidden(path.to_path_buf()));
    }
    Ok(real)
}

/// The folder reads below `folder` stay in: the git repository that holds it (the nearest
/// ancestor with a `.git`), else `folder` itself; resolved.
pub(crate) fn repository_of(folder: &Path) -> std::io::Result<PathBuf> {
    let real = std::fs::canonicalize(folder)?;
    Ok(real
        .ancestors()
        .find(|a| a.join(".git").exists())
        .map_or(real.clone(), Path::to_path_buf))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn links_out_hidden_files_and_missing_files_are_refused() {
        let dir = tempfile::tempdir().unwrap();
        let root = dir.path().join("repo");
        std::fs::create_dir_all(root.join(".hidden")).unwrap();
        std::fs::write(dir.path().join("secret.md"), "secret").unwrap();
        std::fs::write(root.join("paper.md"), "paper").unwrap();
        std::fs::write(root.join(".hidden/x.md"), "x").unwrap();
        std::os::unix::fs::symlink(dir.path().join("secret.md"), root.join("link.md")).unwrap();
        std::os::unix::fs::symlink(root.join("paper.md"), root.join("inner.md")).unwrap();
        let root = std::fs::canonicalize(&root).unwrap();
        assert!(inside(&root.join("paper.md"), &root).is_ok());
        assert_eq!(
            inside(&root.join("inner.md"), &root).unwrap(),
            root.join("paper.md")
        );
        assert!(matches!(
            inside(&root.join("link.md"), &root),
            Err(Refused::Outside { .. })
        ));
        assert!(matches!(
            inside(&root.join("../secret.md"), &root),
            Err(Refused::Outside { .. })
        ));
        assert!(matches!(
            inside(&root.join(".hidden/x.md"), &root),
            Err(Refused::Hidden(_))
        ));
        assert!(matches!(
            inside(&root.join("gone.md"), &root),
            Err(Refused::Missing(_))
        ));
    }
}
