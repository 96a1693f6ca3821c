"""Renders each procedural texture baked on a plane with Cycles (CPU) and writes a
contact sheet to blend_fixtures/textures.png: `.venv/bin/python blend_fixtures/render_textures.py`."""

import math
import os
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
OUT = ROOT / "build" / "renders"
sys.path[:0] = [str(ROOT / "addon"), str(ROOT / "build" / "site")]
import bpy

bpy.ops.wm.read_factory_settings(use_empty=True)
import thicket

thicket.register()
from thicket import api

scene = bpy.context.scene
scene.render.engine = "CYCLES"
scene.cycles.samples = 8
scene.cycles.device = "CPU"
scene.render.resolution_x = scene.render.resolution_y = 240
bpy.ops.object.light_add(type="SUN", location=(2, -2, 4))
bpy.context.object.data.energy = 4
bpy.ops.object.camera_add(location=(0, -2.6, 2.0), rotation=(math.radians(52), 0, 0))
scene.camera = bpy.context.object
world = bpy.data.worlds.new("w")
world.color = (0.3, 0.3, 0.35)
scene.world = world
for pattern, tiling in (("chain_mail", 3), ("weave", 2), ("rivets", 2), ("grass", 2), ("fur", 2), ("bubbles", 2)):
    bpy.ops.mesh.primitive_grid_add(x_subdivisions=4, y_subdivisions=4, size=2)
    plane = bpy.context.object
    # Patterns are modelled for a shell half a tile deep (tile = 2 / tiling; the grid's
    # diagonal is 2 * sqrt(2)); grass and fur stand taller.
    half_tile = 0.5 * (2.0 / tiling) / (2.0 * math.sqrt(2.0))
    shell = 0.12 if pattern in ("grass", "fur") else half_tile
    res = api.add_volumetric_texture(plane, pattern, shell_thickness=shell, tiling=tiling, resolution=24, depth_steps=24, texture_size=96)
    plane.hide_render = True
    scene.render.filepath = str(OUT / f"{pattern}.png")
    bpy.ops.render.render(write_still=True)
    print(pattern, len(res.data.polygons), flush=True)
    api.remove(plane)
    bpy.data.objects.remove(plane)

import numpy as np

names = ["chain_mail", "weave", "rivets", "grass", "fur", "bubbles"]
images = [bpy.data.images.load(str(OUT / f"{n}.png")) for n in names]
w, h = images[0].size
canvas = np.zeros((h * 2, w * 3, 4), np.float32)
for k, im in enumerate(images):
    px = np.empty(w * h * 4, np.float32)
    im.pixels.foreach_get(px)
    r, c = divmod(k, 3)
    canvas[(1 - r) * h : (2 - r) * h, c * w : (c + 1) * w] = px.reshape(h, w, 4)
sheet = bpy.data.images.new("sheet", w * 3, h * 2, alpha=True)
sheet.pixels.foreach_set(canvas.ravel())
sheet.filepath_raw = str(ROOT / "blend_fixtures" / "textures.png")
sheet.file_format = "PNG"
sheet.save()
os._exit(0)  # bpy 4.2 segfaults at teardown once classes are registered
