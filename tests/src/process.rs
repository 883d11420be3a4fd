//! Resources of a running process from /proc (resident memory, file descriptors, threads) and
//! the simulated plant as a child process that a test may kill and start again.

use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};

/// Resident memory of process `pid` (VmRSS), KiB; `None` once it has exited.
pub fn rss_kib(pid: u32) -> Option<u64> {
    status_field(pid, "VmRSS:")
}

/// Peak resident memory of process `pid` (VmHWM), KiB.
pub fn peak_rss_kib(pid: u32) -> Option<u64> {
    status_field(pid, "VmHWM:")
}

fn status_field(pid: u32, name: &str) -> Option<u64> {
    let status = std::fs::read_to_string(format!("/proc/{pid}/status")).ok()?;
    status.lines().find_map(|l| l.strip_prefix(name)).and_then(|v| v.trim().trim_end_matches("kB").trim().parse().ok())
}

/// Open file descriptors of process `pid`.
pub fn fd_count(pid: u32) -> usize {
    std::fs::read_dir(format!("/proc/{pid}/fd")).map_or(0, |d| d.count())
}

/// What the file descriptors of process `pid` refer to (for messages).
pub fn fd_targets(pid: u32) -> Vec<String> {
    let Ok(dir) = std::fs::read_dir(format!("/proc/{pid}/fd")) else { return Vec::new() };
    let mut out: Vec<String> = dir
        .flatten()
        .map(|e| {
            format!(
                "{}: {}",
                e.file_name().to_string_lossy(),
                std::fs::read_link(e.path()).unwrap_or_default().display()
            )
        })
        .collect();
    out.sort();
    out
}

/// Threads of process `pid`.
pub fn thread_count(pid: u32) -> usize {
    std::fs::read_dir(format!("/proc/{pid}/task")).map_or(0, |d| d.count())
}

/// Open sockets of process `pid` (the control connections and the listener; iceoryx2 uses
/// files, which come and go with its subscribers).
pub fn socket_count(pid: u32) -> usize {
    std::fs::read_dir(format!("/proc/{pid}/fd")).map_or(0, |d| {
        d.flatten()
            .filter(|e| std::fs::read_link(e.path()).is_ok_and(|t| t.to_string_lossy().starts_with("socket:")))
            .count()
    })
}

/// The resources of a process at one moment.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Resources {
    pub fds: usize,
    pub sockets: usize,
    pub threads: usize,
    pub rss_kib: u64,
}

impl Resources {
    pub fn of(pid: u32) -> Resources {
        Resources {
            fds: fd_count(pid),
            sockets: socket_count(pid),
            threads: thread_count(pid),
            rss_kib: rss_kib(pid).unwrap_or(0),
        }
    }
}

/// `sim-plant` on a service prefix, its stderr in a file; SIGTERM and wait on drop.
pub struct Plant {
    child: Option<Child>,
    log: PathBuf,
}

impl Plant {
    /// Starts `sim-plant --service-prefix PREFIX` with `extra` arguments; stderr goes to `log`.
    pub fn start(prefix: &str, extra: &[&str], log: &Path) -> Plant {
        let child = Command::new(crate::binary("sim-plant"))
            .args(["--service-prefix", prefix])
            .args(extra)
            .stdout(Stdio::null())
            .stderr(Stdio::from(std::fs::File::create(log).expect("plant log file")))
            .spawn()
            .expect("start sim-plant");
        Plant { child: Some(child), log: log.to_path_buf() }
    }

    pub fn pid(&self) -> Option<u32> {
        self.child.as_ref().map(Child::id)
    }

    /// Whether the process still runs.
    pub fn running(&mut self) -> bool {
        self.child.as_mut().is_some_and(|c| matches!(c.try_wait(), Ok(None)))
    }

    pub fn stderr(&self) -> String {
        std::fs::read_to_string(&self.log).unwrap_or_default()
    }

    /// SIGKILL, as a crash ends it.
    pub fn kill(mut self) {
        if let Some(mut c) = self.child.take() {
            let _ = c.kill();
            let _ = c.wait();
        }
    }

    /// SIGTERM and wait; the exit code.
    pub fn terminate(mut self) -> Option<i32> {
        let c = self.child.take()?;
        // SAFETY: kill(2) on our own child's pid.
        unsafe { libc::kill(c.id() as i32, libc::SIGTERM) };
        c.wait_with_output().ok().and_then(|o| o.status.code())
    }
}

impl Drop for Plant {
    fn drop(&mut self) {
        if let Some(mut c) = self.child.take() {
            // SAFETY: as above.
            unsafe { libc::kill(c.id() as i32, libc::SIGTERM) };
            let _ = c.wait();
        }
    }
}
