//! The socket file: bound with mode 0660 without a moment of wider permissions, a stale file
//! left by a crashed daemon replaced, a live daemon's socket or any other file refused. Its
//! (device, inode) goes to the server, which at shutdown removes only the file it created.

use super::errors::ServerError;
use std::fs;
use std::io;
use std::os::unix::fs::{DirBuilderExt, FileTypeExt, MetadataExt, PermissionsExt};
use std::os::unix::net::{UnixListener, UnixStream};
use std::path::Path;
use std::sync::atomic::{AtomicU64, Ordering};

/// Permissions of the socket file: owner and group may connect (docs/control-api.md).
pub const SOCKET_MODE: u32 = 0o660;

/// Binds the socket at `path` with mode 0660 and returns it with the file's (dev, ino).
pub(super) fn create_socket(path: &Path) -> Result<(UnixListener, (u64, u64)), ServerError> {
    let socket_err = |source| ServerError::Socket { path: path.to_path_buf(), source };
    clear_stale(path)?;
    let listener = match bind_private(path) {
        Ok(l) => l,
        Err(PrivateBind::Exists) => return Err(ServerError::AlreadyRunning(path.to_path_buf())),
        Err(PrivateBind::Unavailable(e)) => {
            tracing::debug!(error = %e, "cannot bind in a private directory; binding in place");
            bind_in_place(path).map_err(socket_err)?
        }
    };
    let md = fs::symlink_metadata(path).map_err(socket_err)?;
    Ok((listener, (md.dev(), md.ino())))
}

/// A socket file at `path` is either a live daemon's (error) or left by one that crashed
/// (removed). Anything else at the path is not ours to delete.
fn clear_stale(path: &Path) -> Result<(), ServerError> {
    let socket_err = |source| ServerError::Socket { path: path.to_path_buf(), source };
    let md = match fs::symlink_metadata(path) {
        Ok(md) => md,
        Err(e) if e.kind() == io::ErrorKind::NotFound => return Ok(()),
        Err(e) => return Err(socket_err(e)),
    };
    if !md.file_type().is_socket() {
        return Err(ServerError::NotASocket(path.to_path_buf()));
    }
    match UnixStream::connect(path) {
        Ok(_) => Err(ServerError::AlreadyRunning(path.to_path_buf())),
        Err(e) if e.kind() == io::ErrorKind::ConnectionRefused => {
            match fs::remove_file(path) {
                Ok(()) => {}
                Err(e) if e.kind() == io::ErrorKind::NotFound => {}
                Err(e) => return Err(socket_err(e)),
            }
            tracing::warn!(socket = %path.display(), "removed a stale control socket left by a daemon that did not shut down");
            Ok(())
        }
        Err(e) => Err(socket_err(e)),
    }
}

enum PrivateBind {
    /// Something appeared at the path meanwhile (another daemon starting).
    Exists,
    Unavailable(io::Error),
}

/// Binds in a fresh mode-0700 directory next to `path`, sets 0660, then links the socket to
/// `path`. Binding directly at `path` would leave the socket reachable with umask permissions
/// (possibly 0777) until the chmod; and `link(2)` fails rather than replace a file that
/// another daemon created at `path` in the meantime.
fn bind_private(path: &Path) -> Result<UnixListener, PrivateBind> {
    static SEQ: AtomicU64 = AtomicU64::new(0);
    let parent = match path.parent() {
        Some(p) if !p.as_os_str().is_empty() => p,
        _ => Path::new("."),
    };
    let dir = parent.join(format!(".interpd-{}-{}", std::process::id(), SEQ.fetch_add(1, Ordering::Relaxed)));
    fs::DirBuilder::new().mode(0o700).create(&dir).map_err(PrivateBind::Unavailable)?;
    let tmp = dir.join("s");
    let result = (|| {
        let listener = UnixListener::bind(&tmp).map_err(PrivateBind::Unavailable)?;
        fs::set_permissions(&tmp, fs::Permissions::from_mode(SOCKET_MODE)).map_err(PrivateBind::Unavailable)?;
        match fs::hard_link(&tmp, path) {
            Ok(()) => Ok(listener),
            Err(e) if e.kind() == io::ErrorKind::AlreadyExists => Err(PrivateBind::Exists),
            Err(e) => Err(PrivateBind::Unavailable(e)),
        }
    })();
    let _ = fs::remove_file(&tmp);
    let _ = fs::remove_dir(&dir);
    result
}

/// Fallback where the private directory cannot be used (no hard links on the file system, a
/// temporary path over the 108-byte socket path limit).
fn bind_in_place(path: &Path) -> io::Result<UnixListener> {
    let listener = UnixListener::bind(path)?;
    if let Err(e) = fs::set_permissions(path, fs::Permissions::from_mode(SOCKET_MODE)) {
        let _ = fs::remove_file(path);
        return Err(e);
    }
    Ok(listener)
}
