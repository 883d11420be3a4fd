//! Scheduling of the real-time thread: SCHED_FIFO, locked memory and a pinned CPU when the
//! system permits, and a plain statement of what it did not permit.

use interpd_config::RtConfig;
use std::fmt;

/// What the real-time set-up achieved; each part is `Err(reason)` where it was refused.
#[derive(Debug, Clone, PartialEq)]
pub struct SchedReport {
    pub fifo_priority: Result<i32, String>,
    pub memory_locked: Result<(), String>,
    pub pinned_cpu: Result<usize, String>,
}

impl SchedReport {
    /// Everything asked for was granted.
    pub fn all_granted(&self) -> bool {
        self.fifo_priority.is_ok() && self.memory_locked.is_ok() && self.pinned_cpu.is_ok()
    }
}

impl fmt::Display for SchedReport {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match &self.fifo_priority {
            Ok(p) => write!(f, "SCHED_FIFO priority {p}")?,
            Err(e) => write!(f, "normal scheduling ({e})")?,
        }
        match &self.memory_locked {
            Ok(()) => write!(f, ", memory locked")?,
            Err(e) => write!(f, ", memory not locked ({e})")?,
        }
        match &self.pinned_cpu {
            Ok(c) => write!(f, ", pinned to CPU {c}"),
            Err(e) => write!(f, ", not pinned ({e})"),
        }
    }
}

/// Applies `cfg` to the calling thread (and, for mlockall, the process).
pub fn apply(cfg: &RtConfig) -> SchedReport {
    SchedReport {
        fifo_priority: set_fifo(cfg.priority),
        memory_locked: lock_memory(cfg.lock_memory),
        pinned_cpu: pin(cfg.cpu),
    }
}

fn os_error() -> String {
    std::io::Error::last_os_error().to_string()
}

fn set_fifo(priority: i32) -> Result<i32, String> {
    if priority == 0 {
        return Err("rt.priority = 0".into());
    }
    let param = libc::sched_param { sched_priority: priority };
    // SAFETY: plain syscall on the calling thread with a valid parameter struct.
    let rc = unsafe { libc::pthread_setschedparam(libc::pthread_self(), libc::SCHED_FIFO, &param) };
    if rc == 0 { Ok(priority) } else { Err(format!("SCHED_FIFO refused: {}", std::io::Error::from_raw_os_error(rc))) }
}

fn lock_memory(wanted: bool) -> Result<(), String> {
    if !wanted {
        return Err("rt.lock_memory = false".into());
    }
    // SAFETY: plain syscall.
    let rc = unsafe { libc::mlockall(libc::MCL_CURRENT | libc::MCL_FUTURE) };
    if rc == 0 { Ok(()) } else { Err(format!("mlockall refused: {}", os_error())) }
}

/// The CPU the real-time thread is pinned to (`rt.cpu`, else the last online CPU) and the
/// number of online CPUs.
fn rt_cpu(cpu: Option<usize>) -> Result<(usize, usize), String> {
    // SAFETY: plain syscall.
    let online = unsafe { libc::sysconf(libc::_SC_NPROCESSORS_ONLN) };
    if online < 1 {
        return Err(format!("cannot count CPUs: {}", os_error()));
    }
    let online = online as usize;
    let cpu = cpu.unwrap_or(online - 1);
    if cpu >= online {
        return Err(format!("rt.cpu = {cpu} but only {online} CPUs are online"));
    }
    Ok((cpu, online))
}

/// Keeps the calling thread, and every thread it starts from now on, off the real-time CPU
/// (when there is another one): the planner, publisher, supervisor and control threads would
/// otherwise share it with the cycle, and a non-preemptible kernel section of theirs (a page
/// fault, an munmap's TLB shoot-down) delays the cycle's wake-up by milliseconds. Returns the
/// CPU kept free.
pub fn keep_off_rt_cpu(cfg: &RtConfig) -> Result<usize, String> {
    let (cpu, online) = rt_cpu(cfg.cpu)?;
    if online < 2 {
        return Err("one CPU online: nothing to keep off it".into());
    }
    // SAFETY: cpu_set_t is plain data; CPU_SET writes inside it; the call affects this thread.
    let rc = unsafe {
        let mut set: libc::cpu_set_t = std::mem::zeroed();
        for other in (0..online).filter(|&c| c != cpu) {
            libc::CPU_SET(other, &mut set);
        }
        libc::sched_setaffinity(0, std::mem::size_of::<libc::cpu_set_t>(), &set)
    };
    if rc == 0 { Ok(cpu) } else { Err(format!("sched_setaffinity refused: {}", os_error())) }
}

/// Sets the calling thread's nice value (Linux applies `setpriority` to a thread id alone).
/// A value below 0 needs CAP_SYS_NICE or `LimitNICE`/`RLIMIT_NICE`.
pub fn set_thread_nice(nice: i32) -> Result<(), String> {
    // SAFETY: gettid has no arguments; setpriority changes this thread's nice value only.
    let rc = unsafe {
        let tid = libc::syscall(libc::SYS_gettid) as libc::id_t;
        libc::setpriority(libc::PRIO_PROCESS, tid, nice)
    };
    if rc == 0 { Ok(()) } else { Err(format!("setpriority(nice {nice}) refused: {}", os_error())) }
}

fn pin(cpu: Option<usize>) -> Result<usize, String> {
    let (cpu, _) = rt_cpu(cpu)?;
    // SAFETY: cpu_set_t is plain data; CPU_SET writes inside it; the call affects this thread.
    let rc = unsafe {
        let mut set: libc::cpu_set_t = std::mem::zeroed();
        libc::CPU_SET(cpu, &mut set);
        libc::sched_setaffinity(0, std::mem::size_of::<libc::cpu_set_t>(), &set)
    };
    if rc == 0 { Ok(cpu) } else { Err(format!("sched_setaffinity refused: {}", os_error())) }
}
