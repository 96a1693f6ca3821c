//! Progress and cancellation of long work (bakes, shells), shared between the worker
//! threads and whoever watches them: counters the work advances, a flag it checks.

use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};

/// Steps done of a total, and a request to stop. Work that sees the request stops at
/// its next step and returns [`crate::Error::Cancelled`].
#[derive(Debug, Default)]
pub struct Progress {
    done: AtomicUsize,
    total: AtomicUsize,
    cancel: AtomicBool,
}

impl Progress {
    /// Starts a stage of `total` steps.
    pub fn start(&self, total: usize) {
        self.done.store(0, Ordering::Relaxed);
        self.total.store(total, Ordering::Relaxed);
    }

    pub fn step(&self) {
        self.advance(1);
    }

    /// `n` more steps done.
    pub fn advance(&self, n: usize) {
        self.done.fetch_add(n, Ordering::Relaxed);
    }

    /// The share done, in `[0, 1]` (0 before a stage starts).
    pub fn fraction(&self) -> f64 {
        let total = self.total.load(Ordering::Relaxed);
        if total == 0 {
            0.0
        } else {
            (self.done.load(Ordering::Relaxed) as f64 / total as f64).min(1.0)
        }
    }

    /// Asks the work to stop.
    pub fn cancel(&self) {
        self.cancel.store(true, Ordering::Relaxed);
    }

    pub fn is_cancelled(&self) -> bool {
        self.cancel.load(Ordering::Relaxed)
    }

    /// `Err(Cancelled)` once cancelling was asked for.
    pub fn check(&self) -> crate::Result<()> {
        if self.is_cancelled() {
            Err(crate::Error::Cancelled)
        } else {
            Ok(())
        }
    }
}

#[cfg(test)]
mod tests {
    use super::Progress;
    use crate::shell::incremental::IncrementalShell;
    use crate::shell::{build_shell, build_shell_watched, ShellParams, Side, Thickness};
    use crate::testmeshes as tm;
    use crate::Error;

    #[test]
    fn a_shell_counts_its_vertices_up_to_one_and_matches_the_unwatched_build() {
        let mesh = tm::icosphere(4);
        let t = Thickness::relative(0.1).per_vertex(&mesh, None).unwrap();
        let progress = Progress::default();
        let seen = std::sync::Mutex::new(Vec::new());
        let finished = std::sync::atomic::AtomicBool::new(false);
        let shell = std::thread::scope(|s| {
            let watcher = s.spawn(|| loop {
                seen.lock().unwrap().push(progress.fraction());
                std::thread::sleep(std::time::Duration::from_micros(200));
                if progress.fraction() >= 1.0 || finished.load(std::sync::atomic::Ordering::Acquire) {
                    break;
                }
            });
            let shell = build_shell_watched(&mesh, &t, Side::Envelope, &ShellParams::default(), Some(&progress));
            finished.store(true, std::sync::atomic::Ordering::Release); // a failed build ends the watch too
            watcher.join().unwrap();
            shell.unwrap()
        });
        assert_eq!(progress.fraction(), 1.0);
        let seen = seen.into_inner().unwrap();
        assert!(seen.windows(2).all(|w| w[0] <= w[1]), "not monotone: {seen:?}");
        assert!(seen.iter().any(|&f| f > 0.0 && f < 1.0), "no fraction between 0 and 1 seen: {seen:?}");
        assert!(shell == build_shell(&mesh, &t, Side::Envelope, &ShellParams::default()).unwrap());
    }

    #[test]
    fn cancelling_from_another_thread_stops_a_big_shell_early() {
        let mesh = tm::icosphere(6); // 40,962 vertices
        let t = Thickness::relative(0.1).per_vertex(&mesh, None).unwrap();
        let progress = Progress::default();
        let (result, at_cancel) = std::thread::scope(|s| {
            let canceller = s.spawn(|| {
                while progress.fraction() < 0.05 {
                    std::thread::yield_now();
                }
                progress.cancel();
                progress.fraction()
            });
            let result = build_shell_watched(&mesh, &t, Side::Exterior, &ShellParams::default(), Some(&progress));
            (result, canceller.join().unwrap())
        });
        assert_eq!(result.unwrap_err(), Error::Cancelled);
        // Each thread finishes at most the vertex it was tracing.
        let stopped = progress.fraction();
        let threads = rayon::current_num_threads() as f64;
        assert!(stopped < at_cancel + (threads + 1.0) / (mesh.vertex_count() as f64), "stopped at {stopped}, cancelled at {at_cancel}");
        assert!(stopped < 0.5);
    }

    #[test]
    fn a_cancelled_watch_stops_shells_before_tracing() {
        let mesh = tm::icosphere(2);
        let t = Thickness::relative(0.1).per_vertex(&mesh, None).unwrap();
        let progress = Progress::default();
        progress.cancel();
        let err = build_shell_watched(&mesh, &t, Side::Exterior, &ShellParams::default(), Some(&progress)).unwrap_err();
        assert_eq!(err, Error::Cancelled);
        assert_eq!(progress.fraction(), 0.0);
        let kept = IncrementalShell::new_watched(mesh.clone(), t.clone(), Side::Exterior, ShellParams::default(), Some(&progress));
        assert_eq!(kept.err(), Some(Error::Cancelled));
        // Watched but not cancelled: the kept shell is the unwatched one's, and the count is full.
        let fresh = Progress::default();
        let kept = IncrementalShell::new_watched(mesh.clone(), t.clone(), Side::Exterior, ShellParams::default(), Some(&fresh)).unwrap();
        assert_eq!(fresh.fraction(), 1.0);
        let plain = IncrementalShell::new(mesh, t, Side::Exterior, ShellParams::default()).unwrap();
        assert!(kept.shell() == plain.shell());
    }
}
