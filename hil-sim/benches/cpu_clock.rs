//! CPU time of the calling thread, shared by the speed benchmarks and examples.

/// CPU time this thread has run (ns), from /proc/thread-self/schedstat (Linux); the
/// machine may be shared, so CPU time is what "on one core" means.
pub fn thread_cpu_ns() -> Option<u64> {
    let s = std::fs::read_to_string("/proc/thread-self/schedstat").ok()?;
    s.split_whitespace().next()?.parse().ok()
}
