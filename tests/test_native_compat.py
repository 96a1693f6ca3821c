"""The add-on with a `thicket_native` older than itself: output keys added since are
read with a default, never indexed (a KeyError would end every build of the kind)."""

import numpy as np
from conftest import add, positions

import thicket_native as tn
from thicket import api


def test_procedural_detail_without_the_shrunk_share(scene, monkeypatch):
    """`shrunk` (the share of visibly shrunk detail, for the panel's note) came with
    the fold guard's count: without it the detail is made as before, no note."""
    cube = add("cube")
    expected = positions(api.add_procedural_detail(cube, model="ROCK", levels=2, amplitude=0.03, seed=3)).copy()
    real = tn.procedural_detail

    def older(*args, **kwargs):
        out = real(*args, **kwargs)
        del out["shrunk"]
        return out

    monkeypatch.setattr(tn, "procedural_detail", older)
    api.regenerate(cube)
    assert cube.thicket.last_error == ""
    np.testing.assert_array_equal(positions(cube.thicket.result), expected)
