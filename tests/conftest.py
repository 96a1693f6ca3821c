"""Tests run inside real Blender: the `bpy` module from PyPI (see Makefile).

The add-on is imported from addon/ and the native module from build/site (built by
`make wheel`), exactly the code the extension zip packs.
"""

import os
import pathlib
import sys

ROOT = pathlib.Path(__file__).resolve().parent.parent
sys.path[:0] = [str(ROOT / "addon"), str(ROOT / "build" / "site")]

import bpy  # noqa: E402
import numpy as np  # noqa: E402
import pytest  # noqa: E402
from blender_objects import mesh_object  # noqa: E402, F401  (tests import it from here)

import thicket  # noqa: E402

thicket.register()

FIXTURES = ROOT / "blend_fixtures"
DATA = ROOT / "tests" / "data"


@pytest.fixture
def scene():
    """An empty scene; Thicket stays registered across factory resets."""
    bpy.ops.wm.read_factory_settings(use_empty=True)
    return bpy.context.scene


def positions(obj_or_mesh):
    mesh = getattr(obj_or_mesh, "data", obj_or_mesh)
    co = np.empty(len(mesh.vertices) * 3, np.float32)
    mesh.vertices.foreach_get("co", co)
    return co.reshape(-1, 3)


def select_only(*objects):
    for o in bpy.context.view_layer.objects:
        o.select_set(False)
    for o in objects:
        o.select_set(True)
    bpy.context.view_layer.objects.active = objects[0] if objects else None


def add(primitive, **kw):
    getattr(bpy.ops.mesh, f"primitive_{primitive}_add")(**kw)
    return bpy.context.active_object


_exit_status = 0


def pytest_sessionfinish(session, exitstatus):
    global _exit_status
    _exit_status = int(exitstatus)


def pytest_unconfigure(config):
    # The bpy 4.2 module segfaults during interpreter teardown once any Python class
    # or handler was registered (reproduced without Thicket: registering one operator,
    # or a glTF export, is enough). Leave before teardown, with pytest's own status.
    if bpy.app.version < (4, 3, 0):
        sys.stdout.flush()
        sys.stderr.flush()
        os._exit(_exit_status)


def run_modal(watch, before_each_timer=None, limit=60.0):
    """Starts a watched operator's job and feeds it timer events until the modal
    ends (as Blender's event loop would); its status."""
    import time

    watch.job.start()
    status, end = {"RUNNING_MODAL"}, time.monotonic() + limit
    while status == {"RUNNING_MODAL"}:
        assert time.monotonic() < end, "the modal never ended"
        watch.job._thread.join(0.02)
        if before_each_timer is not None:
            before_each_timer()
        status = watch.event(bpy.context, "TIMER")
    return status
