//! Helpers for the end-to-end tests in `tests/tests/`: locating the real binaries and the
//! repository's example programs.

use std::path::PathBuf;

/// Root of the repository (the workspace directory).
pub fn repo_root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).parent().expect("tests/ has a parent").to_path_buf()
}

/// Path of a workspace binary built next to the running test executable
/// (`target/<profile>/<name>`). `cargo test --workspace` builds every package's binaries
/// because each binary's package has integration tests. `INTERPD_BIN_DIR`, when set, is
/// searched instead (scripts/vcan-vm.sh puts the binaries in the VM's /bin).
pub fn binary(name: &str) -> PathBuf {
    if let Some(dir) = std::env::var_os("INTERPD_BIN_DIR") {
        return PathBuf::from(dir).join(name);
    }
    let exe = std::env::current_exe().expect("test executable path");
    // target/<profile>/deps/<test> (a test) or target/<profile>/<tool> (a tool of this crate)
    // -> target/<profile>/<name>
    let mut dir = exe.parent().expect("the executable's directory");
    if dir.file_name().is_some_and(|n| n == "deps") {
        dir = dir.parent().expect("target/<profile> directory");
    }
    let path = dir.join(name);
    assert!(
        path.exists(),
        "binary {} not found; build it with `cargo build --workspace` (cargo test --workspace does)",
        path.display()
    );
    path
}

/// Path of a file under examples/.
pub fn example(name: &str) -> PathBuf {
    repo_root().join("examples").join(name)
}

pub mod daemon;
pub mod fuzz;
pub mod process;
pub mod rng;
pub mod soak;
pub mod stream;
pub mod vcan;
