"""The stack is open: the evaluator walks items by what each kind declares it
consumes and produces (`pure.kinds.KINDS`), and the renderers draw what a drawn
kind's own `draw_setup` gives, so a new kind is its settings, its step (and setup)
and one registration line; nothing else in the evaluator changes."""

from dataclasses import dataclass

import numpy as np
import pytest

from thicket.pure import evaluate as E
from thicket.pure import kinds as K
from thicket.pure import settings as S
from thicket.pure.arrays import MeshArrays


@dataclass(frozen=True)
class Lift:
    """A made-up kind: moves the current mesh up, keeping its vertices (and so their
    provenance), like a deformer would."""

    label: str = "Lift"
    vertex_group: str = ""
    height: float = 1.0


def lift_step(state, item, ask, progress):
    mesh = state.current
    state.current = MeshArrays(mesh.vertices + np.float32([0.0, 0.0, item.height]), mesh.face_sizes, mesh.corners)


def quad():
    v = np.float32([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0]])
    return MeshArrays(v, np.int32([4]), np.int32([0, 1, 2, 3]))


@pytest.fixture
def with_lift():
    K.KINDS[Lift] = K.Kind("mesh", "mesh", 0.1, lift_step)
    try:
        yield
    finally:
        del K.KINDS[Lift]


def test_a_registered_kind_runs_in_a_stack_with_the_others(with_lift):
    shell = S.OffsetShell(thickness=0.1, relative=False)
    out = E.evaluate_stack(quad(), [Lift(height=2.0), shell])
    # The shell's outer layer is built on the lifted quad, 0.1 above it.
    assert out.vertex_count == 4 and np.allclose(out.vertices[:, 2], 2.1), out.vertices
    # And a kind's progress share is its declared weight.
    spans = E.progress_spans([Lift(), shell])
    assert spans[0] == pytest.approx((0.0, 0.5)) and spans[1] == pytest.approx((0.5, 1.0))


def test_declarations_are_checked_before_a_step_runs(with_lift):
    texture = S.VolumetricTexture()
    with pytest.raises(E.StackError, match="needs a Shell"):
        E.evaluate_stack(quad(), [Lift(), texture])
    # A texture's result has no provenance: a kind that consumes a mesh cannot follow.
    shell = S.OffsetShell(thickness=0.1, relative=False)
    with pytest.raises(E.StackError, match="cannot follow a Volumetric Texture"):
        E.evaluate_stack(quad(), [shell, S.VolumetricTexture(texture_size=8, resolution=2, depth_steps=2), Lift()])


def test_the_renderers_stop_before_the_first_drawn_kind_without_running_it(with_lift, monkeypatch):
    def must_not_run(*args):
        raise AssertionError("render_setup ran the texture's step")

    monkeypatch.setitem(K.KINDS, S.VolumetricTexture, K.KINDS[S.VolumetricTexture]._replace(step=must_not_run))
    shell = S.OffsetShell(thickness=0.1, relative=False)
    setup = E.render_setup(quad(), [Lift(height=1.0), shell, S.VolumetricTexture(texture_size=8)])
    assert setup.item.kind == S.VolumetricTexture.kind
    assert setup.shell.base.vertices[:, 2].min() == pytest.approx(1.0)
    with pytest.raises(E.StackError, match="no enabled Volumetric Texture item"):
        E.render_setup(quad(), [shell])
    # The same stack evaluated runs it.
    with pytest.raises(AssertionError, match="ran the texture's step"):
        E.evaluate_stack(quad(), [shell, S.VolumetricTexture(texture_size=8)])


@dataclass(frozen=True)
class Glow:
    """A made-up drawn kind (as a Solid Texture will be): a renderer draws it from the
    shell with its own setup; evaluated, it makes geometry."""

    label: str = "Glow"
    vertex_group: str = ""
    brightness: float = 2.0


class GlowSetup:
    """What a renderer draws of a Glow item: anything with a handle() to render from."""

    def __init__(self, state, item):
        self.shell, self.item, self.notes = state.shell, item, list(state.notes)

    def handle(self):
        return ("glow handle", self.item.brightness)


@dataclass(frozen=True)
class Fringe:
    """A made-up kind that consumes the shell but is only evaluated (no draw_setup)."""

    label: str = "Fringe"
    vertex_group: str = ""


def fringe_step(state, item, ask, progress):
    state.notes.append("fringe ran")


@pytest.fixture
def with_drawn_kinds():
    K.KINDS[Glow] = K.Kind("shell", "geometry", 2.0, lambda *args: None, GlowSetup)
    K.KINDS[Fringe] = K.Kind("shell", "mesh", 1.0, fringe_step)
    try:
        yield
    finally:
        del K.KINDS[Glow], K.KINDS[Fringe]


def test_a_drawn_kind_declares_its_own_setup(with_drawn_kinds):
    """A new drawn kind is its module and its registration line: the renderers get its
    own setup, not a Volumetric Texture's."""
    shell = S.OffsetShell(thickness=0.1, relative=False)
    setup = E.render_setup(quad(), [shell, Glow(brightness=3.0)])
    assert isinstance(setup, GlowSetup) and setup.handle() == ("glow handle", 3.0)
    assert np.allclose(setup.shell.directors[:, 2], 0.1)
    # The first drawn item is the one drawn, whichever kind it is.
    assert isinstance(E.render_setup(quad(), [shell, Glow(), S.VolumetricTexture()]), GlowSetup)
    assert E.render_setup(quad(), [shell, S.VolumetricTexture(texture_size=8), Glow()]).item.kind == S.VolumetricTexture.kind
    # Drawn items take no share of a render's progress; a kind with no draw_setup does.
    spans = E.progress_spans([shell, Glow()], bakes=False)
    assert spans[1][1] - spans[1][0] == 0.0
    spans = E.progress_spans([shell, Fringe(), Glow()], bakes=False)
    assert spans[1][1] - spans[1][0] > 0.0
    with pytest.raises(E.StackError, match="no enabled Glow or Volumetric Texture item"):
        E.render_setup(quad(), [shell])


def test_consuming_the_shell_does_not_make_a_kind_drawn(with_drawn_kinds):
    """Only a declared draw_setup does: a kind that consumes the shell without one is
    run before the drawn item, like any other."""
    shell = S.OffsetShell(thickness=0.1, relative=False)
    assert not K.KINDS[Fringe].drawn and K.KINDS[Glow].drawn and K.KINDS[S.VolumetricTexture].drawn
    assert not K.KINDS[S.OffsetShell].drawn and not K.KINDS[S.FieldShell].drawn
    setup = E.render_setup(quad(), [shell, Fringe(), Glow()])
    assert isinstance(setup, GlowSetup) and setup.notes == ["fringe ran"]


def test_the_walk_knows_no_kind():
    """The evaluator imports the registry, not a kind's module: what is drawn and how
    is each kind's own declaration."""
    from test_import_graph import import_graph

    assert not [m for m in import_graph()["thicket.pure.evaluate"] if m.startswith("thicket.pure.kinds.")]
