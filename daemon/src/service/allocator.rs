//! The C library's allocator settings for a daemon whose memory is locked.
//!
//! `mlockall` (for the real-time thread, `rt::sched`) makes every page the process maps
//! resident, so memory the allocator keeps after a `free` stays resident too. By default glibc
//! raises its mmap threshold after freeing a large block (up to 32 MiB), after which large
//! blocks come from heaps it rarely trims, and it opens up to 8 arenas per CPU: a soak of
//! random overrides, holds and reloads grew the daemon by steps of megabytes that never came
//! back. Fixed thresholds and two arenas give large blocks back at once and keep the rest
//! trimmed; the real-time thread never allocates, so none of this reaches the cycle.

/// Blocks from this size are mapped on their own and unmapped when freed. Setting it also
/// turns off glibc's dynamic raise of the threshold.
const MMAP_THRESHOLD_BYTES: i32 = 128 * 1024;
/// Free memory at the top of a heap beyond this is given back to the system.
const TRIM_THRESHOLD_BYTES: i32 = 256 * 1024;
/// Arenas: the connection, planner, supervisor and recorder threads allocate, never the
/// real-time thread; two keep contention low without a heap per thread.
const ARENA_MAX: i32 = 2;

/// Applies the settings above; best effort (a C library without `mallopt` keeps its own).
pub(crate) fn keep_memory_returnable() {
    #[cfg(all(target_os = "linux", target_env = "gnu"))]
    {
        for (param, value, name) in [
            (libc::M_MMAP_THRESHOLD, MMAP_THRESHOLD_BYTES, "M_MMAP_THRESHOLD"),
            (libc::M_TRIM_THRESHOLD, TRIM_THRESHOLD_BYTES, "M_TRIM_THRESHOLD"),
            (libc::M_ARENA_MAX, ARENA_MAX, "M_ARENA_MAX"),
        ] {
            // SAFETY: mallopt(3) only changes allocator parameters; it is safe to call at any
            // time from any thread.
            if unsafe { libc::mallopt(param, value) } != 1 {
                tracing::warn!("mallopt({name}, {value}) refused; the allocator keeps its default");
            }
        }
    }
}
