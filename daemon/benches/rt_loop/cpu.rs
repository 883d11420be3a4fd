//! CPU placement of the benchmark's helper threads (the real-time thread itself is placed by
//! `interpd::rt::sched`, with the daemon's `[rt]` settings).

use interpd::config::RtConfig;

/// CPUs online.
pub fn online() -> usize {
    // SAFETY: plain syscall.
    let n = unsafe { libc::sysconf(libc::_SC_NPROCESSORS_ONLN) };
    usize::try_from(n).unwrap_or(1).max(1)
}

/// The CPU the daemon pins its real-time thread to with `rt` (as `rt::sched` chooses it).
pub fn rt_cpu(rt: &RtConfig) -> usize {
    rt.cpu.unwrap_or(online() - 1)
}

/// "The other core": the CPU next below the real-time one (wrapping), or the same on a
/// single-CPU machine.
pub fn other_cpu(rt: &RtConfig) -> usize {
    let n = online();
    (rt_cpu(rt) + n - 1) % n
}

/// Pins the calling thread to `cpu`.
pub fn pin_current_thread(cpu: usize) -> Result<usize, String> {
    // SAFETY: cpu_set_t is plain data; CPU_SET writes inside it; the call affects this thread.
    let rc = unsafe {
        let mut set: libc::cpu_set_t = std::mem::zeroed();
        libc::CPU_SET(cpu, &mut set);
        libc::sched_setaffinity(0, std::mem::size_of::<libc::cpu_set_t>(), &set)
    };
    if rc == 0 { Ok(cpu) } else { Err(std::io::Error::last_os_error().to_string()) }
}

/// SCHED_FIFO at `priority` for the calling thread; `Err` says why not.
pub fn set_fifo(priority: i32) -> Result<i32, String> {
    let param = libc::sched_param { sched_priority: priority };
    // SAFETY: plain syscall on the calling thread with a valid parameter struct.
    let rc = unsafe { libc::pthread_setschedparam(libc::pthread_self(), libc::SCHED_FIFO, &param) };
    if rc == 0 { Ok(priority) } else { Err(std::io::Error::from_raw_os_error(rc).to_string()) }
}
