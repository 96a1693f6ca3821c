"""Runs a stack of item settings over a mesh (numpy arrays in, numpy arrays out): the
walk over the items by what each kind declares (`pure.kinds`).

Without Blender: the same function serves operators, the headless API and tests.
"""

import numpy as np

from . import native
from .arrays import MeshArrays
from .kinds import KINDS
from .state import StackError, State


def _drawn(kind) -> bool:
    """Whether a renderer draws the kind instead of running its step (`Kind.draw_setup`)."""
    return kind.drawn


def render_setup(source: MeshArrays, items, progress=None):
    """Runs the items before the first one a renderer draws (its kind declares a
    `draw_setup`) and returns that kind's setup of it, what the renderer draws without
    baking (its `handle()` renders frames). `progress`: as in `evaluate_stack`, over
    the items run."""
    state, stopped = _run(source, items, progress, stop=_drawn)
    if stopped is None:
        labels = sorted({cls.label for cls, kind in KINDS.items() if kind.drawn})
        raise StackError(f"the stack has no enabled {' or '.join(labels)} item to render")
    return KINDS[type(stopped)].draw_setup(state, stopped)


def progress_spans(items, bakes=True):
    """The (start, end) share of the whole that each item covers; items a renderer
    draws take none when nothing is baked (`bakes` False)."""
    weights = [KINDS[type(item)].weight if bakes or not _drawn(KINDS[type(item)]) else 0.0 for item in items]
    total = sum(weights) or 1.0
    ends = np.cumsum(weights) / total
    return [(float(end - w / total), float(end)) for w, end in zip(weights, ends)]


def cancelled_error():
    """The core's `Cancelled` error (a ThicketError), raised where Python stops work."""
    return native.get().Cancelled("cancelled")


def _scaled(progress, start, end):
    """`progress` seen by one item: its fractions mapped into [start, end]."""
    if progress is None:
        return None
    return lambda fraction: progress(start + (end - start) * min(max(float(fraction), 0.0), 1.0))


def evaluate_stack(source: MeshArrays, items, progress=None, ask=False) -> MeshArrays:
    """Applies `items` in order; each item's input is the previous item's output.

    Vertex-group weights are looked up on the source mesh and followed through the
    items by provenance (`source_vertex`), so a group keeps meaning after the first
    item. An empty list returns the source. `ask`: raise `BakeNeedsConfirmation`
    before a bake estimated over its item's `confirm_above` (the interface then asks
    the user).

    `progress`: a callable given the share of the whole stack done, a float in [0, 1]
    that never decreases: at once, during field shells and bakes (about ten times a
    second, from the calling thread), after each item, and 1.0 at the end (when the
    answer no longer matters). Returning False cancels: the work stops at its next
    check and `thicket_native.Cancelled` (a `ThicketError`) is raised, or the
    callback's own exception if it raised one. Nothing is returned, and a field shell
    whose build was cancelled is not kept for later edits.
    """
    state, _ = _run(source, items, progress, ask)
    current = state.current
    if current is source:
        current = MeshArrays(source.vertices, source.face_sizes, source.corners)
    current.notes = state.notes
    current.shell_summaries = state.summaries
    return current


def _run(source: MeshArrays, items, progress=None, ask=False, stop=None):
    """Walks the stack by each kind's declarations (`KINDS`): the state after the last
    item and None, or, where `stop(kind)` holds, the state before that item and the
    item (the progress spans then leave drawn items out)."""
    spans = progress_spans(items, bakes=stop is None)
    if progress is not None and progress(0.0) is False:
        raise cancelled_error()
    state = State(source)
    for i, item in enumerate(items):
        kind = KINDS[type(item)]
        if kind.consumes == "shell" and state.shell is None:
            raise StackError(f"'{item.label}' needs a Shell or Offset Shell above it in the stack")
        if kind.consumes == "mesh" and state.origin is None:
            raise StackError(f"'{item.label}' cannot follow a {state.made_by}")
        if stop is not None and stop(kind):
            return state, item
        kind.step(state, item, ask, _scaled(progress, *spans[i]))
        if kind.produces == "geometry":
            state.origin, state.made_by = None, type(item).label
        if progress is not None and progress(spans[i][1]) is False and i + 1 < len(items):
            raise cancelled_error()
    if progress is not None:
        progress(1.0)
    return state, None


def state_before(source: MeshArrays, items, index, progress=None) -> State:
    """The stack's state just before `items[index]`: the items above it run as
    `evaluate_stack` runs them (what a tool working on that one item reads, as
    `pure.fit_budget` does). `progress`: as `evaluate_stack`'s."""
    state, _ = _run(source, items[:index], progress)
    return state


def scaled_progress(progress, start, end):
    """`progress` seen by one part of a longer piece of work: its fractions mapped into
    [start, end]."""
    return _scaled(progress, start, end)


def evaluate_each(sources, progress=None, errors=(ValueError,)):
    """`evaluate_stack` over several `(source, items)` pairs, one after the other,
    yielding each one's result, or its error when it is one of `errors` (an entry may
    be such an error already: a source that could not be read). `progress` covers
    them all in equal parts, ending at 1.0; a cancel (see `evaluate_stack`) ends the
    iteration with its exception, the results yielded before it standing."""
    n = len(sources)
    for i, entry in enumerate(sources):
        part = _scaled(progress, i / n, (i + 1) / n)
        if isinstance(entry, BaseException):  # nothing to evaluate: passed at once
            if part is not None and part(0.0) is False:
                raise cancelled_error()
            outcome = entry
            if part is not None:
                part(1.0)
        else:
            try:
                outcome = evaluate_stack(*entry, part)
            except native.get().Cancelled:
                raise
            except errors as exc:
                outcome = exc
        yield outcome
