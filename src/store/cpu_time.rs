//! The CPU time of the calling thread, for `timing.json`: a run's cost in
//! CPU-seconds, which (unlike its wall time) does not grow when other work
//! shares the machine. Linux's per-thread clock (`getrusage(RUSAGE_THREAD)`);
//! elsewhere none.

/// User + system CPU time the calling thread has used so far, s; `None`
/// where the platform has no per-thread clock or the call fails.
#[cfg(target_os = "linux")]
pub fn thread_cpu_s() -> Option<f64> {
    // SAFETY: getrusage writes one rusage struct into the zeroed value we
    // own; RUSAGE_THREAD is valid on Linux ≥ 2.6.26.
    let mut usage: libc::rusage = unsafe { std::mem::zeroed() };
    let status = unsafe { libc::getrusage(libc::RUSAGE_THREAD, &mut usage) };
    if status != 0 {
        return None;
    }
    let seconds = |t: libc::timeval| t.tv_sec as f64 + t.tv_usec as f64 * 1e-6;
    Some(seconds(usage.ru_utime) + seconds(usage.ru_stime))
}

/// User + system CPU time the calling thread has used so far, s; `None`
/// where the platform has no per-thread clock.
#[cfg(not(target_os = "linux"))]
pub fn thread_cpu_s() -> Option<f64> {
    None
}

#[cfg(test)]
mod tests {
    /// Spinning for a while on this thread advances its clock by about as
    /// much as the wall clock (and not by more, up to the clock's tick).
    #[test]
    #[cfg(target_os = "linux")]
    fn counts_this_threads_work() {
        let start = super::thread_cpu_s().unwrap();
        let wall = std::time::Instant::now();
        let mut x = 0u64;
        while wall.elapsed().as_secs_f64() < 0.2 {
            x = x.wrapping_mul(6364136223846793005).wrapping_add(1);
        }
        std::hint::black_box(x);
        let used = super::thread_cpu_s().unwrap() - start;
        let elapsed = wall.elapsed().as_secs_f64();
        assert!(
            used > 0.0 && used <= elapsed + 0.02,
            "{used} s of {elapsed} s"
        );
    }
}
