//! Per-stage wall-clock times of shell builds, for benchmarks and profiling
//! (`examples/shell_stages.rs`), with the process's CPU time over each stage
//! (steadier than wall time on a loaded machine; stages that run beside others, the
//! tracing and the checker, share theirs), the exact triangle tests run during each
//! stage, and work counters. Off by default: a disabled [`Stage`] or
//! [`exact_test`] costs one atomic load. Times are recorded process-wide; [`take`],
//! [`take_cpu`] and [`take_exact`] hand them over.

use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::{Arc, Mutex};
use std::time::Instant;

static ON: AtomicBool = AtomicBool::new(false);
static TIMES: Mutex<Vec<(&'static str, f64)>> = Mutex::new(Vec::new());
static CPU: Mutex<Vec<(&'static str, f64)>> = Mutex::new(Vec::new());
static EXACT: Mutex<Vec<(&'static str, f64)>> = Mutex::new(Vec::new());

/// The exact-test count: one counter per thread, on its own cache line, written by
/// that thread alone (a plain load and store, no locked add: tens of millions of
/// tests a build), read by [`exact_tests`] through the list of every thread's.
#[repr(align(64))]
#[derive(Default)]
struct Counter(AtomicU64);
static COUNTERS: Mutex<Vec<Arc<Counter>>> = Mutex::new(Vec::new());
thread_local! {
    static MINE: Arc<Counter> = {
        let c = Arc::new(Counter::default());
        COUNTERS.lock().unwrap_or_else(|e| e.into_inner()).push(c.clone());
        c
    };
}

/// Held by tests that switch recording on and off (it is process-wide), so that one
/// does not switch it off under another.
#[cfg(test)]
pub(crate) static SERIAL: Mutex<()> = Mutex::new(());

/// Starts (or stops) recording stage times.
pub fn enable(on: bool) {
    ON.store(on, Ordering::Relaxed);
}

/// The recorded (stage, seconds) in the order the stages ended, cleared.
pub fn take() -> Vec<(&'static str, f64)> {
    std::mem::take(&mut *TIMES.lock().unwrap_or_else(|e| e.into_inner()))
}

/// The CPU seconds (user and system, every thread) of each recorded stage, in the
/// order [`take`] gives their wall times, cleared.
pub fn take_cpu() -> Vec<(&'static str, f64)> {
    std::mem::take(&mut *CPU.lock().unwrap_or_else(|e| e.into_inner()))
}

/// The exact triangle tests ([`exact_test`], every thread) run during each recorded
/// stage, in the order [`take`] gives their wall times, cleared.
pub fn take_exact() -> Vec<(&'static str, f64)> {
    std::mem::take(&mut *EXACT.lock().unwrap_or_else(|e| e.into_inner()))
}

/// This process's CPU seconds so far, every thread (`clock_gettime` with
/// `CLOCK_PROCESS_CPUTIME_ID`: a system call, no file read, nanoseconds; 0 where
/// that clock is missing).
pub fn cpu_seconds() -> f64 {
    #[cfg(unix)]
    {
        let mut t = libc::timespec { tv_sec: 0, tv_nsec: 0 };
        // SAFETY: `t` is a valid, writable timespec; the call writes only it.
        if unsafe { libc::clock_gettime(libc::CLOCK_PROCESS_CPUTIME_ID, &mut t) } == 0 {
            return t.tv_sec as f64 + t.tv_nsec as f64 * 1e-9;
        }
    }
    0.0
}

/// Counts one exact triangle-triangle test (when on; `shell::intersect` calls it).
#[inline]
pub fn exact_test() {
    if ON.load(Ordering::Relaxed) {
        MINE.with(|c| c.0.store(c.0.load(Ordering::Relaxed) + 1, Ordering::Relaxed));
    }
}

/// The exact tests counted so far (while on), every thread.
pub fn exact_tests() -> u64 {
    COUNTERS.lock().unwrap_or_else(|e| e.into_inner()).iter().map(|c| c.0.load(Ordering::Relaxed)).sum()
}

/// Adds `n` to counter `name` (recorded, when on): how much work a stage did
/// (elements checked, exact tests), summed per name by [`summed`] as its "seconds".
/// Counters are named apart from stages (`#` first, by convention).
pub fn count(name: &'static str, n: usize) {
    add(name, n as f64);
}

/// Adds `seconds` to stage `name` (recorded, when on).
pub fn add(name: &'static str, seconds: f64) {
    if ON.load(Ordering::Relaxed) {
        TIMES.lock().unwrap_or_else(|e| e.into_inner()).push((name, seconds));
    }
}

/// A stage being timed: recorded when dropped.
pub struct Stage {
    name: &'static str,
    start: Option<(Instant, f64, u64)>,
}

impl Stage {
    /// Starts timing `name` (a no-op unless recording is on).
    pub fn start(name: &'static str) -> Self {
        Stage { name, start: ON.load(Ordering::Relaxed).then(|| (Instant::now(), cpu_seconds(), exact_tests())) }
    }
}

impl Drop for Stage {
    fn drop(&mut self) {
        if let Some((wall, cpu, tests)) = self.start {
            add(self.name, wall.elapsed().as_secs_f64());
            CPU.lock().unwrap_or_else(|e| e.into_inner()).push((self.name, cpu_seconds() - cpu));
            EXACT.lock().unwrap_or_else(|e| e.into_inner()).push((self.name, (exact_tests() - tests) as f64));
        }
    }
}

/// Sums the recorded times per stage, in order of first appearance, with counts.
pub fn summed(times: &[(&'static str, f64)]) -> Vec<(&'static str, f64, usize)> {
    let mut out: Vec<(&'static str, f64, usize)> = Vec::new();
    for &(name, s) in times {
        match out.iter_mut().find(|o| o.0 == name) {
            Some(o) => {
                o.1 += s;
                o.2 += 1;
            }
            None => out.push((name, s, 1)),
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The CPU clock advances with work done, finely: spinning, its first change is
    /// far below the 10 ms ticks of `/proc/self/stat` (the process's other threads,
    /// other tests, can only add what they ran in that moment), and 50 ms of it pass
    /// within a minute of spinning. Process-wide, so other tests' work may make it
    /// pass faster: no upper bound on it is asserted.
    #[test]
    fn cpu_seconds_follow_work_finely() {
        let start = cpu_seconds();
        assert!(start > 0.0, "no CPU clock");
        let wall = Instant::now();
        let mut x = 1u64;
        let mut next = cpu_seconds();
        while next == start {
            x = std::hint::black_box(x.wrapping_mul(6364136223846793005).wrapping_add(1));
            next = cpu_seconds();
        }
        assert!(next > start && next - start < 1e-3, "the clock stepped by {} s", next - start);
        while cpu_seconds() - start < 0.05 {
            x = std::hint::black_box(x.wrapping_mul(6364136223846793005).wrapping_add(1));
            assert!(wall.elapsed().as_secs() < 60, "no CPU time recorded for a minute of work");
        }
        assert!(cpu_seconds() >= start + 0.05);
    }

    /// A stage records the exact tests run inside it (at least those: recording is
    /// process-wide and other tests may run some at the same time), an enclosing
    /// stage at least as many as the stages inside it.
    #[test]
    fn stages_count_the_exact_tests_inside_them() {
        use crate::shell::intersect::triangles_intersect;
        use glam::DVec3;
        let _serial = SERIAL.lock().unwrap_or_else(|e| e.into_inner());
        enable(true);
        let a = [DVec3::ZERO, DVec3::X, DVec3::Y];
        let b = [DVec3::new(0.2, 0.2, -1.0), DVec3::new(0.2, 0.2, 1.0), DVec3::new(2.0, 2.0, 0.5)];
        {
            let _outer = Stage::start("timing test: outer");
            for _ in 0..7 {
                assert!(std::hint::black_box(triangles_intersect(&a, &b)));
            }
            let _inner = Stage::start("timing test: inner");
            for _ in 0..5 {
                assert!(std::hint::black_box(triangles_intersect(&b, &a)));
            }
        }
        enable(false);
        let exact = take_exact();
        let of = |name: &str| exact.iter().filter(|e| e.0 == name).map(|e| e.1).sum::<f64>();
        let (outer, inner) = (of("timing test: outer"), of("timing test: inner"));
        assert!(inner >= 5.0 && outer >= inner + 7.0, "outer {outer}, inner {inner}");
    }
}
