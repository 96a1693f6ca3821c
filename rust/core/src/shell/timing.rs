//! Per-stage wall-clock times of shell builds, for benchmarks and profiling
//! (`examples/shell_stages.rs`), with the process's CPU time over each stage
//! (steadier than wall time on a loaded machine; stages that run beside others, the
//! tracing and the checker, share theirs) and work counters. Off by default: a
//! disabled [`Stage`] costs one atomic load. Times are recorded process-wide;
//! [`take`] and [`take_cpu`] hand them over.

use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Mutex;
use std::time::Instant;

static ON: AtomicBool = AtomicBool::new(false);
static TIMES: Mutex<Vec<(&'static str, f64)>> = Mutex::new(Vec::new());
static CPU: Mutex<Vec<(&'static str, f64)>> = Mutex::new(Vec::new());

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

/// This process's CPU seconds so far (Linux `/proc/self/stat`, in clock ticks of
/// 10 ms; 0 elsewhere).
pub fn cpu_seconds() -> f64 {
    let Ok(stat) = std::fs::read_to_string("/proc/self/stat") else { return 0.0 };
    // After the command's closing parenthesis, utime and stime are the 12th and 13th fields.
    let fields: Vec<&str> = stat.rsplit(')').next().unwrap_or("").split_whitespace().collect();
    let ticks = |k: usize| fields.get(k).and_then(|f| f.parse::<f64>().ok()).unwrap_or(0.0);
    (ticks(11) + ticks(12)) / 100.0
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
    start: Option<(Instant, f64)>,
}

impl Stage {
    /// Starts timing `name` (a no-op unless recording is on).
    pub fn start(name: &'static str) -> Self {
        Stage { name, start: ON.load(Ordering::Relaxed).then(|| (Instant::now(), cpu_seconds())) }
    }
}

impl Drop for Stage {
    fn drop(&mut self) {
        if let Some((wall, cpu)) = self.start {
            add(self.name, wall.elapsed().as_secs_f64());
            CPU.lock().unwrap_or_else(|e| e.into_inner()).push((self.name, cpu_seconds() - cpu));
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

    /// The CPU clock advances with work done on this thread (Linux: /proc).
    #[test]
    fn cpu_seconds_follow_work() {
        if !std::path::Path::new("/proc/self/stat").exists() {
            return;
        }
        let (start, wall) = (cpu_seconds(), Instant::now());
        let mut x = 1u64;
        while cpu_seconds() - start < 0.05 {
            x = std::hint::black_box(x.wrapping_mul(6364136223846793005).wrapping_add(1));
            assert!(wall.elapsed().as_secs() < 60, "no CPU time recorded for a minute of work");
        }
        assert!(cpu_seconds() >= start + 0.05);
    }
}
