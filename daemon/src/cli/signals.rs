//! SIGINT and SIGTERM for the long-running commands (`run`, `record`): blocked before any
//! thread starts, so that they are received synchronously by the main thread, never by a
//! real-time or worker thread.

/// SIGINT and SIGTERM, blocked in this thread and the threads started after, and waited for.
pub(super) struct TerminationSignals {
    set: libc::sigset_t,
}

impl TerminationSignals {
    pub(super) fn block() -> Self {
        // SAFETY: sigset manipulation on a local set; pthread_sigmask on the calling thread.
        unsafe {
            let mut set: libc::sigset_t = std::mem::zeroed();
            libc::sigemptyset(&mut set);
            libc::sigaddset(&mut set, libc::SIGINT);
            libc::sigaddset(&mut set, libc::SIGTERM);
            libc::pthread_sigmask(libc::SIG_BLOCK, &set, std::ptr::null_mut());
            TerminationSignals { set }
        }
    }

    /// Waits for a signal (its name) or until `timeout_s` passed (`None`).
    pub(super) fn wait(&self, timeout_s: Option<f64>) -> Option<&'static str> {
        let deadline = timeout_s.map(|s| std::time::Instant::now() + std::time::Duration::from_secs_f64(s));
        loop {
            let left = deadline.map(|d| d.saturating_duration_since(std::time::Instant::now()));
            if left.is_some_and(|l| l.is_zero()) {
                return None;
            }
            // Wake at least once a second so the deadline is checked without a timed wait
            // API of its own.
            let step = left.map_or(std::time::Duration::from_secs(1), |l| l.min(std::time::Duration::from_secs(1)));
            let ts =
                libc::timespec { tv_sec: step.as_secs() as libc::time_t, tv_nsec: step.subsec_nanos() as libc::c_long };
            // SAFETY: valid set and timespec; a null siginfo is allowed.
            let sig = unsafe { libc::sigtimedwait(&self.set, std::ptr::null_mut(), &ts) };
            if sig == libc::SIGINT {
                return Some("SIGINT");
            }
            if sig == libc::SIGTERM {
                return Some("SIGTERM");
            }
        }
    }
}
