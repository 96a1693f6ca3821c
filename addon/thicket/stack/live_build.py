"""Builds off Blender's main thread, shared by the stack's auto-update and the node
editor's live Field Meshes: what a build needs is read on the main thread, the work
runs in a `operators.common.Job` (the core releases the GIL), and a timer on the main
thread hands each finished build to its owner's `write`.

Builds are keyed by their owner's `session_uid` (an object or a node tree: renaming
it mid-build changes nothing). A result is written only while the owner still reads
as it did when its build started (`Build.read` against `Build.state(owner)`): an
undo, or a change nothing scheduled, drops it (and its error). Errors go to the owner's `fail`,
cancels are dropped, and nothing is ever raised into Blender's event loop."""

import atexit
import time
import weakref

import bpy

from ..operators.common import Job, cancel_errors

#: How often the main thread looks for finished builds (seconds).
POLL_SECONDS = 0.05

#: A build's progress alone redraws the views at most this often (seconds); a build
#: that starts, lands or ends redraws them at the next look.
PROGRESS_SECONDS = 0.25

#: The clock of the redraw throttle and of `_end_all`'s deadline (tests replace it).
_clock = time.monotonic


class Build:
    """One build in flight: `work(job)` on a worker thread (plain data, no bpy), and
    `read`, the owner's `state(owner)` when it started: the result is written only
    while the owner still reads the same. `extra` is whatever the owner's `write`
    needs besides the work's result."""

    def __init__(self, owner, state, work, extra=None):
        self.state, self.read, self.extra = state, state(owner), extra
        self.job = Job(work)


class Builds:
    """The builds in flight of one kind of owner, found again by `find(uid)` (None
    once it is gone). `write(owner, build, result)` and `fail(owner, exc)` run on the main thread.

    `on_poll()`: called after a look that saw something change (the panel's and the
    views' redraw): a build started, landed or was dropped, or, at most every
    `PROGRESS_SECONDS`, a build's progress moved. Nothing changed, nothing is redrawn
    (the timer looks every `POLL_SECONDS`).

    `exclusive`: a newer build of an owner never runs beside the older one (work that
    keeps state between builds, such as the incremental shells): the older is
    cancelled and the newer waits for that cancel to land, `starter()` making it then
    (so it reads the owner as it is by then)."""

    def __init__(self, find, write, fail, exclusive=False, on_poll=None):
        self.find, self.write, self.fail, self.exclusive, self.on_poll = find, write, fail, exclusive, on_poll
        self.builds: dict = {}
        #: Cancelled builds still running (exclusive), and what starts the next one once they end.
        self._ending: dict = {}
        self._next: dict = {}
        #: Cancelled builds of the others, still running until their work sees the cancel.
        self._cancelled: list = []
        #: The builds' progress as last redrawn (by job), and when.
        self._shown: dict = {}
        self._redrawn = float("-inf")
        self._tick = self.poll  # one object, so the timer is found registered
        _every.add(self)

    def start(self, owner, starter) -> None:
        """Cancels `owner`'s build in flight and starts `starter()`'s `Build` (None:
        nothing to build), or, when `exclusive` and the cancelled one is still running,
        once it ended."""
        uid = owner.session_uid
        self.cancel(owner)
        if uid in self._ending:
            self._next[uid] = starter
        else:
            self._launch(uid, starter)
        self._watch()

    def _launch(self, uid, starter) -> None:
        build = starter()
        if build is not None:
            self.builds[uid] = build
            build.job.start()

    def _watch(self) -> None:
        if (self.builds or self._ending or self._cancelled) and not bpy.app.timers.is_registered(self._tick):
            bpy.app.timers.register(self._tick, first_interval=POLL_SECONDS)

    def cancel(self, owner=None) -> None:
        """Cancels `owner`'s build in flight (every build for None) and any waiting to
        start; their results are never written. One still running is kept until its
        work ends, for `wait` and for the exit (`_end_all`)."""
        for uid in list(self.builds) if owner is None else [owner.session_uid]:
            build = self.builds.pop(uid, None)
            if build is not None:
                build.job.cancel()
                if not build.job.done:
                    if self.exclusive:
                        self._ending[uid] = build
                    else:
                        self._cancelled.append(build)
            self._next.pop(uid, None)

    def cancel_others(self, owner) -> None:
        """Cancels the builds of every owner but `owner` (the one a view shows now)."""
        for uid in [uid for uid in (*self.builds, *self._next) if uid != owner.session_uid]:
            self.cancel(_Named(uid))

    def running(self, owner) -> bool:
        """Whether `owner` has a build in flight or waiting to start."""
        uid = owner.session_uid
        return uid in self.builds or uid in self._next

    def fraction(self, owner) -> float | None:
        """How far `owner`'s build in flight is (0 to 1), None when none runs."""
        build = self.builds.get(owner.session_uid)
        return None if build is None else build.job.fraction

    def poll(self):
        """Writes the builds that are done and starts those that waited (main thread);
        the timer's next interval, or None once nothing is in flight. One build's
        failure never strands the others."""
        self._cancelled = [build for build in self._cancelled if not build.job.done]
        for uid, build in list(self._ending.items()):
            if build.job.done:
                del self._ending[uid]
                starter = self._next.pop(uid, None)
                if starter is not None:
                    self._launch(uid, starter)
        for uid, build in list(self.builds.items()):
            if not build.job.done:
                continue
            del self.builds[uid]
            owner = self.find(uid)
            if owner is None:
                continue  # it went (deleted, or another file loaded)
            try:
                result, error = build.job.outcome(), None
            except cancel_errors():
                continue
            except Exception as exc:  # noqa: BLE001 - the work's error, the owner's to show
                result, error = None, exc
            try:
                if build.state(owner) != build.read:
                    continue  # it changed since (an undo): what it shows stays as it is
                if error is None:
                    self.write(owner, build, result)
                else:
                    self.fail(owner, error)
            except Exception as exc:  # noqa: BLE001 - a timer that raises is unregistered by Blender
                self.fail(owner, exc)
        if self.on_poll is not None and self._changed():
            self.on_poll()
        return POLL_SECONDS if self.builds or self._ending or self._cancelled else None

    def _changed(self) -> bool:
        """Whether the views show something else than at the last redraw: another set
        of builds in flight (one started, landed or was dropped), or, `PROGRESS_SECONDS`
        after the last redraw, a build's progress (in whole percent) moved. Remembers
        what it said changed as shown."""
        now = _clock()
        shown = {id(build.job): round(build.job.fraction, 2) for build in self.builds.values()}
        if shown.keys() == self._shown.keys() and (shown == self._shown or now - self._redrawn < PROGRESS_SECONDS):
            return False
        self._shown, self._redrawn = shown, now
        return True

    def wait(self, timeout=60.0) -> None:
        """Waits for every build in flight (and those waiting to start) and writes
        them (renders, tests and scripts), within one `timeout` for all of them."""
        deadline = time.monotonic() + timeout
        while self.builds or self._ending or self._cancelled:
            builds = [*self.builds.values(), *self._ending.values(), *self._cancelled]
            for build in builds:
                build.job.join(max(0.0, deadline - time.monotonic()))
            self.poll()
            if not all(build.job.done for build in builds):
                return  # timed out


def by_uid(collection, uid):
    return next((item for item in collection if item.session_uid == uid), None)


class _Named:
    """An owner known by its `session_uid` only (one gone, or another's)."""

    def __init__(self, uid):
        self.session_uid = uid


#: Every `Builds`, for `_end_all`.
_every: "weakref.WeakSet[Builds]" = weakref.WeakSet()


def redraw_panels() -> None:
    """Redraws the views that show builds' progress and results (Properties editor,
    3D views: the stack panels, the sidebar, the live preview)."""
    for window in getattr(bpy.context.window_manager, "windows", ()):
        for area in window.screen.areas:
            if area.type in {"PROPERTIES", "VIEW_3D"}:
                area.tag_redraw()


@atexit.register
def _end_all(timeout=10.0) -> None:
    """At exit, cancels every build and waits for its worker: a native call still
    running would call back into Python (its progress) after Python ended, which aborts
    the process. Every build is told first, so all of them wind down together, then
    joined within one `timeout` in all (not each in turn)."""
    every = list(_every)
    for builds in every:
        builds.cancel()
    deadline = _clock() + timeout
    for builds in every:
        for build in [*builds._ending.values(), *builds._cancelled]:
            build.job.join(max(0.0, deadline - _clock()))
