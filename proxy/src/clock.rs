//! The host's monotonic clock as plain nanoseconds.
//!
//! Routed ops are stamped with it in one process and compared with it in another, so it must be
//! one clock for every process of the host: `CLOCK_MONOTONIC`. (`std::time::Instant` reads the
//! same clock but does not expose its value.) Stamps from different hosts cannot be compared.

/// Nanoseconds of `CLOCK_MONOTONIC`.
pub fn monotonic_ns() -> u64 {
    let now = rustix::time::clock_gettime(rustix::time::ClockId::Monotonic);
    now.tv_sec as u64 * 1_000_000_000 + now.tv_nsec as u64
}

/// CPU time this thread has used, ns (`CLOCK_THREAD_CPUTIME_ID`).
pub fn thread_cpu_ns() -> u64 {
    let t = rustix::time::clock_gettime(rustix::time::ClockId::ThreadCPUTime);
    t.tv_sec as u64 * 1_000_000_000 + t.tv_nsec as u64
}
