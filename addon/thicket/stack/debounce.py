"""Debounced regeneration shared by the stack and the node editor: names collected
and flushed once things are quiet (a timer in UI sessions; at once in background
mode, where timers never run), never while a regeneration is writing (the guard)."""

import bpy

from .guard import busy

DEBOUNCE_SECONDS = 0.15


class Debounced:
    """Calls `run(name)` for every name added, once no other arrived for
    `DEBOUNCE_SECONDS`."""

    def __init__(self, run):
        self.pending: set[str] = set()
        self._run = run
        self._tick = self._timer  # one object, so the timer is found registered

    def add(self, name: str) -> None:
        self.pending.add(name)
        if bpy.app.background:
            self.flush()
        elif not bpy.app.timers.is_registered(self._tick):
            bpy.app.timers.register(self._tick, first_interval=DEBOUNCE_SECONDS)

    def _timer(self):
        self.flush()
        return None

    def flush(self) -> None:
        if busy():
            return
        while self.pending:
            self._run(self.pending.pop())
