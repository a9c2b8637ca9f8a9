//! The wall clock as the log stamps it.

/// Wall-clock time, ns since the Unix epoch (0 if the clock is before it): a run's start.
pub fn unix_now_ns() -> u64 {
    std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map(|d| d.as_nanos() as u64)
        .unwrap_or(0)
}
