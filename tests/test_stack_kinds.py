"""The stack is open: the evaluator walks items by what each kind declares it
consumes and produces (`pure.kinds.KINDS`), so a new kind is its settings, its
step and one registration line; nothing else in the evaluator changes."""

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
        raise AssertionError("texture_setup ran the texture's step")

    monkeypatch.setitem(K.KINDS, S.VolumetricTexture, K.KINDS[S.VolumetricTexture]._replace(step=must_not_run))
    shell = S.OffsetShell(thickness=0.1, relative=False)
    setup = E.texture_setup(quad(), [Lift(height=1.0), shell, S.VolumetricTexture(texture_size=8)])
    assert setup.item.kind == S.VolumetricTexture.kind
    assert setup.shell.base.vertices[:, 2].min() == pytest.approx(1.0)
    with pytest.raises(E.StackError, match="no enabled Volumetric Texture"):
        E.texture_setup(quad(), [shell])
    # The same stack evaluated runs it.
    with pytest.raises(AssertionError, match="ran the texture's step"):
        E.evaluate_stack(quad(), [shell, S.VolumetricTexture(texture_size=8)])
