//! Scheduling of the real-time thread: SCHED_FIFO, locked memory and a pinned CPU when the
//! system permits, and a plain statement of what it did not permit.

use interpd_config::RtConfig;
use std::fmt;

/// What the real-time set-up achieved; each part is `Err` where it was refused.
#[derive(Debug, Clone, PartialEq)]
pub struct SchedReport {
    pub fifo_priority: Result<i32, SchedError>,
    pub memory_locked: Result<(), SchedError>,
    pub pinned_cpu: Result<usize, SchedError>,
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

/// Why a scheduling request was not carried out.
#[derive(Debug, Clone, Copy, PartialEq, Eq, thiserror::Error)]
pub enum SchedError {
    /// The configuration does not ask for it (`rt.priority = 0`, `rt.lock_memory = false`).
    #[error("{0}")]
    NotRequested(&'static str),
    /// The system refused `call` with `errno`.
    #[error("{call} refused: {}", std::io::Error::from_raw_os_error(*errno))]
    Refused { call: Call, errno: i32 },
    /// The number of online CPUs could not be read.
    #[error("cannot count CPUs: {}", std::io::Error::from_raw_os_error(*errno))]
    CpuCount { errno: i32 },
    /// `rt.cpu` names a CPU that is not online.
    #[error("rt.cpu = {cpu} but only {online} CPUs are online")]
    NoSuchCpu { cpu: usize, online: usize },
    /// There is no other CPU to keep the other threads on.
    #[error("one CPU online: nothing to keep off it")]
    OneCpu,
}

/// The system call a [`SchedError::Refused`] names.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Call {
    SchedFifo,
    Mlockall,
    SetAffinity,
    SetPriority { nice: i32 },
}

impl fmt::Display for Call {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Call::SchedFifo => f.write_str("SCHED_FIFO"),
            Call::Mlockall => f.write_str("mlockall"),
            Call::SetAffinity => f.write_str("sched_setaffinity"),
            Call::SetPriority { nice } => write!(f, "setpriority(nice {nice})"),
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

/// The errno of the last failed call on this thread.
fn errno() -> i32 {
    std::io::Error::last_os_error().raw_os_error().unwrap_or(0)
}

fn set_fifo(priority: i32) -> Result<i32, SchedError> {
    if priority == 0 {
        return Err(SchedError::NotRequested("rt.priority = 0"));
    }
    let param = libc::sched_param { sched_priority: priority };
    // SAFETY: plain syscall on the calling thread with a valid parameter struct.
    let rc = unsafe { libc::pthread_setschedparam(libc::pthread_self(), libc::SCHED_FIFO, &param) };
    if rc == 0 { Ok(priority) } else { Err(SchedError::Refused { call: Call::SchedFifo, errno: rc }) }
}

fn lock_memory(wanted: bool) -> Result<(), SchedError> {
    if !wanted {
        return Err(SchedError::NotRequested("rt.lock_memory = false"));
    }
    // SAFETY: plain syscall.
    let rc = unsafe { libc::mlockall(libc::MCL_CURRENT | libc::MCL_FUTURE) };
    if rc == 0 { Ok(()) } else { Err(SchedError::Refused { call: Call::Mlockall, errno: errno() }) }
}

/// The CPU the real-time thread is pinned to (`rt.cpu`, else the last online CPU) and the
/// number of online CPUs.
fn rt_cpu(cpu: Option<usize>) -> Result<(usize, usize), SchedError> {
    // SAFETY: plain syscall.
    let online = unsafe { libc::sysconf(libc::_SC_NPROCESSORS_ONLN) };
    if online < 1 {
        return Err(SchedError::CpuCount { errno: errno() });
    }
    let online = online as usize;
    let cpu = cpu.unwrap_or(online - 1);
    if cpu >= online {
        return Err(SchedError::NoSuchCpu { cpu, online });
    }
    Ok((cpu, online))
}

/// Keeps the calling thread, and every thread it starts from now on, off the real-time CPU
/// (when there is another one): the planner, publisher, supervisor and control threads would
/// otherwise share it with the cycle, and a non-preemptible kernel section of theirs (a page
/// fault, an munmap's TLB shoot-down) delays the cycle's wake-up by milliseconds. Returns the
/// CPU kept free.
pub fn keep_off_rt_cpu(cfg: &RtConfig) -> Result<usize, SchedError> {
    let (cpu, online) = rt_cpu(cfg.cpu)?;
    if online < 2 {
        return Err(SchedError::OneCpu);
    }
    // SAFETY: cpu_set_t is plain data; CPU_SET writes inside it; the call affects this thread.
    let rc = unsafe {
        let mut set: libc::cpu_set_t = std::mem::zeroed();
        for other in (0..online).filter(|&c| c != cpu) {
            libc::CPU_SET(other, &mut set);
        }
        libc::sched_setaffinity(0, std::mem::size_of::<libc::cpu_set_t>(), &set)
    };
    if rc == 0 { Ok(cpu) } else { Err(SchedError::Refused { call: Call::SetAffinity, errno: errno() }) }
}

/// Sets the calling thread's nice value (Linux applies `setpriority` to a thread id alone).
/// A value below 0 needs CAP_SYS_NICE or `LimitNICE`/`RLIMIT_NICE`.
pub fn set_thread_nice(nice: i32) -> Result<(), SchedError> {
    // SAFETY: gettid has no arguments; setpriority changes this thread's nice value only.
    let rc = unsafe {
        let tid = libc::syscall(libc::SYS_gettid) as libc::id_t;
        libc::setpriority(libc::PRIO_PROCESS, tid, nice)
    };
    if rc == 0 { Ok(()) } else { Err(SchedError::Refused { call: Call::SetPriority { nice }, errno: errno() }) }
}

/// The calling thread's nice value.
pub fn thread_nice() -> i32 {
    // SAFETY: gettid has no arguments; getpriority reads this thread's nice value. errno is
    // cleared first because -1 is a valid nice value.
    unsafe {
        *libc::__errno_location() = 0;
        let tid = libc::syscall(libc::SYS_gettid) as libc::id_t;
        libc::getpriority(libc::PRIO_PROCESS, tid)
    }
}

fn pin(cpu: Option<usize>) -> Result<usize, SchedError> {
    let (cpu, _) = rt_cpu(cpu)?;
    // SAFETY: cpu_set_t is plain data; CPU_SET writes inside it; the call affects this thread.
    let rc = unsafe {
        let mut set: libc::cpu_set_t = std::mem::zeroed();
        libc::CPU_SET(cpu, &mut set);
        libc::sched_setaffinity(0, std::mem::size_of::<libc::cpu_set_t>(), &set)
    };
    if rc == 0 { Ok(cpu) } else { Err(SchedError::Refused { call: Call::SetAffinity, errno: errno() }) }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn refusals_read_as_before() {
        let e = SchedError::Refused { call: Call::SchedFifo, errno: libc::EPERM };
        assert_eq!(e.to_string(), format!("SCHED_FIFO refused: {}", std::io::Error::from_raw_os_error(libc::EPERM)));
        let e = SchedError::Refused { call: Call::SetPriority { nice: -5 }, errno: libc::EACCES };
        assert!(e.to_string().starts_with("setpriority(nice -5) refused: "), "{e}");
        assert_eq!(SchedError::NoSuchCpu { cpu: 4, online: 2 }.to_string(), "rt.cpu = 4 but only 2 CPUs are online");
        let report = SchedReport {
            fifo_priority: Err(SchedError::NotRequested("rt.priority = 0")),
            memory_locked: Ok(()),
            pinned_cpu: Err(SchedError::OneCpu),
        };
        assert_eq!(
            report.to_string(),
            "normal scheduling (rt.priority = 0), memory locked, not pinned (one CPU online: nothing to keep off it)"
        );
    }
}
