//! Where `program.load {"path"}` may read from: the programs directory (`[programs] dir`,
//! default the daemon's working directory). Whoever can reach the control socket can name a
//! path, so a path resolves inside that directory only: relative to it, without `..`, and
//! with symbolic links resolved before the check, so that no link leads out of it. An error
//! names the rule and the path as given, never anything read from a file.

use crate::control::errors::ProgramPathError;
use interpd_config::ProgramsConfig;
use std::path::{Component, Path, PathBuf};

/// The programs directory, canonical (absolute, symbolic links resolved).
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct ProgramsDir {
    dir: PathBuf,
}

/// The programs directory cannot be used.
#[derive(Debug, thiserror::Error)]
#[error("programs.dir {dir}: {source} (the directory program.load reads programs from; see docs/configuration.md)")]
pub struct ProgramsDirError {
    dir: String,
    #[source]
    source: std::io::Error,
}

impl ProgramsDir {
    /// `[programs] dir`, or the working directory when it is unset; it must exist.
    pub fn from_config(c: &ProgramsConfig) -> Result<Self, ProgramsDirError> {
        let given = c.dir.clone().map_or_else(|| PathBuf::from("."), PathBuf::from);
        let fail = |source| ProgramsDirError { dir: given.display().to_string(), source };
        let dir = given.canonicalize().map_err(fail)?;
        if !dir.is_dir() {
            return Err(fail(std::io::Error::new(std::io::ErrorKind::NotADirectory, "not a directory")));
        }
        Ok(Self { dir })
    }

    pub fn path(&self) -> &Path {
        &self.dir
    }

    /// The file `requested` names: relative paths are taken relative to the directory,
    /// absolute ones must lie in it. A file that does not exist resolves (reading it then
    /// fails with the usual "cannot read"), as long as its place lies in the directory.
    pub fn resolve(&self, requested: &Path) -> Result<PathBuf, ProgramPathError> {
        let dir = self.dir.display().to_string();
        let path = requested.display().to_string();
        if requested.components().any(|c| c == Component::ParentDir) {
            return Err(ProgramPathError::ParentComponent { path, dir });
        }
        let joined = self.dir.join(requested);
        let resolved = match joined.canonicalize() {
            Ok(p) => p,
            // Not there (yet): its parent decides where it would be.
            Err(_) => match (joined.parent().map(Path::canonicalize), joined.file_name()) {
                (Some(Ok(parent)), Some(name)) => parent.join(name),
                _ => joined.clone(),
            },
        };
        if resolved.starts_with(&self.dir) { Ok(resolved) } else { Err(ProgramPathError::Outside { path, dir }) }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn temp_dir(tag: &str) -> PathBuf {
        let d = std::env::temp_dir().join(format!("interpd-programs-{tag}-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&d);
        std::fs::create_dir_all(d.join("sub")).expect("temp dir");
        d
    }

    #[test]
    fn paths_resolve_inside_the_directory_only() {
        let root = temp_dir("resolve");
        std::fs::write(root.join("sub/part.ngc"), "G1 X1 F100\n").expect("write");
        std::fs::write(root.join("../interpd-programs-outside.ngc"), "G1 X1 F100\n").expect("write");
        #[cfg(unix)]
        std::os::unix::fs::symlink("/etc", root.join("etc")).expect("symlink");
        let dir = ProgramsDir::from_config(&ProgramsConfig {
            dir: Some(root.display().to_string()),
            ..ProgramsConfig::default()
        })
        .expect("dir");
        let canon = root.canonicalize().expect("canonical");
        assert_eq!(dir.resolve(Path::new("sub/part.ngc")), Ok(canon.join("sub/part.ngc")));
        assert_eq!(dir.resolve(&canon.join("sub/part.ngc")), Ok(canon.join("sub/part.ngc")));
        assert_eq!(dir.resolve(Path::new("new.ngc")), Ok(canon.join("new.ngc")), "not there yet: resolves");
        for bad in ["../interpd-programs-outside.ngc", "sub/../../x.ngc"] {
            assert!(matches!(dir.resolve(Path::new(bad)), Err(ProgramPathError::ParentComponent { .. })), "{bad}");
        }
        for bad in ["/etc/shadow", "etc/passwd", "/tmp/x.ngc"] {
            let e = dir.resolve(Path::new(bad)).expect_err(bad);
            assert!(matches!(e, ProgramPathError::Outside { .. }), "{bad}: {e}");
            assert!(e.to_string().contains("[programs] dir"), "{e}");
        }
        let _ = std::fs::remove_file(root.join("../interpd-programs-outside.ngc"));
        let _ = std::fs::remove_dir_all(&root);
    }

    #[test]
    fn a_missing_directory_is_an_error_naming_the_key() {
        let e = ProgramsDir::from_config(&ProgramsConfig {
            dir: Some("/nonexistent/interpd".into()),
            ..ProgramsConfig::default()
        })
        .expect_err("missing");
        assert!(e.to_string().starts_with("programs.dir /nonexistent/interpd: "), "{e}");
    }
}
