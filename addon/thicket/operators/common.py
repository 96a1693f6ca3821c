"""What every Thicket operator shares: error reporting, progress, stack polls, and
long work on a worker thread that a modal operator watches and Esc cancels."""

import threading
from contextlib import contextmanager

from ..pure import native
from ..pure.native import error_text  # noqa: F401 (the operators' shared name for it)
from ..stack.query import active_stack_source

#: Exceptions that mean bad input or settings; reported, never raised into Blender.
USER_ERRORS = (TypeError, KeyError, ValueError, RuntimeError)


def user_errors():
    return USER_ERRORS + native.error_types()


def cancel_errors():
    """Exceptions that mean the user stopped the work: the core's `Cancelled` (a
    progress callback answered False) and Ctrl-C."""
    return (native.get().Cancelled, KeyboardInterrupt)


@contextmanager
def progress(context, total=1.0):
    """Blender's progress cursor from 0 to `total`; yields an `update(value)` function."""
    wm = context.window_manager
    wm.progress_begin(0.0, max(float(total), 1e-9))
    try:
        yield wm.progress_update
    finally:
        wm.progress_end()


class Job:
    """`work(job)` on a worker thread: plain data in and out, no bpy (Blender's data
    may only be touched from the main thread). The work reports through
    `job.progress(fraction)`, the callback the native calls take, which answers False
    once `cancel()` was asked for, so the core stops at its next check."""

    def __init__(self, work):
        self.fraction = 0.0
        self.cancelled = False
        #: What the work is at ("'Cube' (2 of 3)"), for the status line; set by the work.
        self.stage = ""
        #: Called with each fraction from the thread that runs the work (set by `run_here`).
        self.on_progress = None
        self._work = work
        self._result = self._error = None
        self._thread = threading.Thread(target=self._run, name="thicket-job", daemon=True)

    def progress(self, fraction) -> bool:
        self.fraction = max(self.fraction, min(float(fraction), 1.0))
        if self.on_progress is not None:
            self.on_progress(self.fraction)
        return not self.cancelled

    def cancel(self):
        self.cancelled = True

    def start(self):
        self._thread.start()
        return self

    def run_here(self, update=None):
        """Runs the work on the calling thread instead (headless scripts: no events
        to cancel from, but Ctrl-C still cancels); `update(fraction)` follows it."""
        self.on_progress = update
        self._run()
        return self

    @property
    def done(self) -> bool:
        return not self._thread.is_alive()

    def join(self, timeout=None):
        """Waits for the work to end (at most `timeout` seconds)."""
        self._thread.join(timeout)

    def _run(self):
        try:
            self._result = self._work(self)
        except BaseException as exc:  # handed to the main thread by outcome()
            self._error = exc

    def outcome(self):
        """The work's result, or its exception raised here; `Cancelled` whenever
        cancelling was asked for, even if the work got to its end first."""
        if self._thread.is_alive():
            self._thread.join()
        if self._error is not None:
            raise self._error
        if self.cancelled:
            raise native.get().Cancelled("cancelled")
        return self._result


#: While a job runs, these cancel it...
CANCEL_EVENTS = {"ESC", "RIGHTMOUSE"}
#: ... and these reach Blender (viewport navigation, nothing that edits); the rest waits.
PASS_EVENTS = {
    "MOUSEMOVE",
    "INBETWEEN_MOUSEMOVE",
    "MIDDLEMOUSE",
    "WHEELUPMOUSE",
    "WHEELDOWNMOUSE",
    "TRACKPADPAN",
    "TRACKPADZOOM",
    "MOUSEROTATE",
    "MOUSESMARTZOOM",
    "NDOF_MOTION",
}


class JobWatch:
    """A `Job` seen through an operator: Blender's progress indicator and a status
    line while it runs, Esc or right-click to cancel, and the end turned into the
    operator's result. `finish(result)` writes the result (main thread) and returns
    the operator's status; `fail(exc)` does the same for an error the user should
    see (default: an ERROR report), `on_cancel()` for a cancel (default: reported,
    nothing changed; work in parts may keep the parts it finished)."""

    def __init__(self, job, label, report, finish, fail=None, on_cancel=None):
        self.job, self.label, self.report, self.finish = job, label, report, finish
        self.fail = fail or (lambda exc: self.report({"ERROR"}, f"{label}: {error_text(exc)}") or {"CANCELLED"})
        self.on_cancel = on_cancel or (lambda: self.report({"WARNING"}, f"{label}: cancelled; nothing was changed") or {"CANCELLED"})
        self._timer = None

    def start_modal(self, context, operator):
        """Starts the job and makes `operator` modal; its `modal` calls `event`."""
        wm = context.window_manager
        wm.progress_begin(0.0, 1.0)
        self._status(context, f"{self.label}: starting (Esc to cancel)")
        self.job.start()
        self._timer = wm.event_timer_add(0.1, window=context.window)
        wm.modal_handler_add(operator)
        return {"RUNNING_MODAL"}

    def event(self, context, kind, value="NOTHING"):
        """One event for the modal operator: returns its status."""
        if kind in CANCEL_EVENTS and value == "PRESS" and not self.job.cancelled:
            self.job.cancel()
            self._status(context, f"{self.label}: cancelling...")
        elif kind != "TIMER":
            return {"PASS_THROUGH"} if kind in PASS_EVENTS else {"RUNNING_MODAL"}
        if not self.job.done:
            context.window_manager.progress_update(self.job.fraction)
            if not self.job.cancelled:
                stage = f"{self.job.stage}, " if self.job.stage else ""
                self._status(context, f"{self.label}: {stage}{self.job.fraction:.0%} (Esc to cancel)")
            return {"RUNNING_MODAL"}
        self.stop(context)
        return self.conclude()

    def run_blocking(self, context):
        """The job on this thread with the progress indicator (operators' `execute`)."""
        with progress(context) as update:
            self.job.run_here(update)
        return self.conclude()

    def conclude(self):
        try:
            result = self.job.outcome()
        except cancel_errors():
            return self.on_cancel()
        except Exception as exc:  # user errors and the unexpected alike: reported, never raised into Blender
            return self.fail(exc)
        return self.finish(result)

    def stop(self, context):
        wm = context.window_manager
        if self._timer is not None:
            wm.event_timer_remove(self._timer)
            self._timer = None
        wm.progress_end()
        self._status(context, None)

    @staticmethod
    def _status(context, text):
        if context.workspace is not None:
            context.workspace.status_text_set(text)


class WatchedOperator:
    """Mixin for operators whose work runs as a `JobWatch`: modal where there is a
    window (progress, Esc cancels), blocking from `execute` otherwise."""

    def run_watched(self, context, watch):
        if watch is None:
            return {"CANCELLED"}
        if context.window is None:
            return watch.run_blocking(context)
        self._running = watch
        return watch.start_modal(context, self)

    def modal(self, context, event):
        return self._running.event(context, event.type, event.value)

    def cancel(self, context):
        """Blender ended the modal itself (a file loaded, the window closed): stop the
        work and clear the progress bar and status."""
        self._running.job.cancel()
        self._running.stop(context)


class StackOperator:
    """Mixin for operators on the active object's existing stack: undoable, and
    available only when the active object (or the source of an active result) has one."""

    bl_options = {"REGISTER", "UNDO"}

    @classmethod
    def poll(cls, context):
        return active_stack_source(context) is not None
