"""Regenerates the .blend fixtures used by tests and `make demo`.

    .venv/bin/python blend_fixtures/make_fixtures.py      (or: make fixtures)

demo.blend: Suzanne (subdivided), a torus, an open wavy sheet with a vertex group
"thickness" (weights rising along x), the bunny scan from tests/data, plus a camera
and a light (non-mesh objects the tools must skip).
"""

import pathlib

import bpy
import numpy as np

HERE = pathlib.Path(__file__).resolve().parent
BUNNY = HERE.parent / "tests" / "data" / "bunny-3k.obj"


def make_demo():
    bpy.ops.wm.read_factory_settings(use_empty=True)
    bpy.ops.mesh.primitive_monkey_add(location=(0, 0, 0))
    suzanne = bpy.context.active_object
    modifier = suzanne.modifiers.new("subdivide", "SUBSURF")
    modifier.levels = 1
    bpy.ops.object.modifier_apply(modifier=modifier.name)

    bpy.ops.mesh.primitive_torus_add(location=(3, 0, 0))

    bpy.ops.mesh.primitive_grid_add(x_subdivisions=24, y_subdivisions=24, size=2, location=(-3, 0, 0))
    sheet = bpy.context.active_object
    sheet.name = "Sheet"
    co = np.empty(len(sheet.data.vertices) * 3, np.float32)
    sheet.data.vertices.foreach_get("co", co)
    co = co.reshape(-1, 3)
    co[:, 2] = 0.2 * np.sin(3 * co[:, 0]) * np.cos(2 * co[:, 1])
    sheet.data.vertices.foreach_set("co", co.ravel())
    sheet.data.update()
    group = sheet.vertex_groups.new(name="thickness")
    bands = np.clip(((co[:, 0] + 1) / 2 * 5).astype(int), 0, 4)
    for band in range(5):  # one call per weight band, not per vertex
        group.add(np.flatnonzero(bands == band).tolist(), (band + 1) / 5, "REPLACE")

    bpy.ops.wm.obj_import(filepath=str(BUNNY))
    bunny = bpy.context.selected_objects[0]
    bunny.name = "Bunny"
    bunny.location = (0, 3, 0)
    bunny.scale = (0.4, 0.4, 0.4)

    bpy.ops.object.camera_add(location=(0, -12, 5), rotation=(1.2, 0, 0))
    bpy.context.scene.camera = bpy.context.active_object
    bpy.ops.object.light_add(type="SUN", location=(0, 0, 8))
    bpy.ops.wm.save_as_mainfile(filepath=str(HERE / "demo.blend"), compress=True)


if __name__ == "__main__":
    make_demo()
    print(f"wrote {HERE / 'demo.blend'}")
