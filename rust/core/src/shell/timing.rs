//! Per-stage wall-clock times of shell builds, for benchmarks and profiling
//! (`examples/shell_stages.rs`). Off by default: a disabled [`Stage`] costs one
//! atomic load. Times are recorded process-wide; [`take`] hands them over.

use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Mutex;
use std::time::Instant;

static ON: AtomicBool = AtomicBool::new(false);
static TIMES: Mutex<Vec<(&'static str, f64)>> = Mutex::new(Vec::new());

/// Starts (or stops) recording stage times.
pub fn enable(on: bool) {
    ON.store(on, Ordering::Relaxed);
}

/// The recorded (stage, seconds) in the order the stages ended, cleared.
pub fn take() -> Vec<(&'static str, f64)> {
    std::mem::take(&mut *TIMES.lock().unwrap_or_else(|e| e.into_inner()))
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
    start: Option<Instant>,
}

impl Stage {
    /// Starts timing `name` (a no-op unless recording is on).
    pub fn start(name: &'static str) -> Self {
        Stage { name, start: ON.load(Ordering::Relaxed).then(Instant::now) }
    }
}

impl Drop for Stage {
    fn drop(&mut self) {
        if let Some(s) = self.start {
            add(self.name, s.elapsed().as_secs_f64());
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
