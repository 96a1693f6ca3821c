"""Headless batch use: the API on many files, the demo script, `blender -c thicket`."""

import re
import subprocess
import sys

import bpy
import numpy as np
from conftest import FIXTURES, ROOT

import thicket
from thicket import api, cli

DEMO = FIXTURES / "demo.blend"
MESHES = {"Suzanne", "Torus", "Sheet", "Bunny"}


def test_process_file_writes_blend_and_glb(scene, tmp_path):
    done = api.process_file(str(DEMO), out_blend=str(tmp_path / "a.blend"), out_glb=str(tmp_path / "a.glb"), thickness=0.02)
    assert set(done) == MESHES and all(not r.startswith("error") for r in done.values())
    bpy.ops.wm.open_mainfile(filepath=str(tmp_path / "a.blend"))
    for name in MESHES:
        assert bpy.data.objects[name].thicket.result.name == f"{name}_thicket"
    bpy.ops.wm.read_factory_settings(use_empty=True)
    bpy.ops.import_scene.gltf(filepath=str(tmp_path / "a.glb"))
    imported = {o.name for o in bpy.context.scene.objects if o.type == "MESH"}
    assert imported == {f"{n}_thicket" for n in MESHES}


def test_cli_command_is_registered_and_runs(scene, tmp_path, capsys):
    if hasattr(bpy.utils, "register_cli_command"):
        assert thicket._cli_handle is not None
    status = cli.run([str(DEMO), "--out-dir", str(tmp_path), "--output", "solid", "--glb"])
    out = capsys.readouterr().out
    assert status == 0, out
    assert (tmp_path / "demo_thicket.blend").exists() and (tmp_path / "demo_thicket.glb").exists()
    assert "Suzanne -> Suzanne_thicket" in out


def test_cli_reports_missing_file(tmp_path, capsys):
    assert cli.run([str(tmp_path / "missing.blend"), "--out-dir", str(tmp_path)]) == 1
    assert "missing.blend" in capsys.readouterr().err


def test_demo_script_in_plain_python(tmp_path):
    """`make demo`'s script, run the way a technical artist's batch job runs it."""
    proc = subprocess.run([sys.executable, str(FIXTURES / "demo.py"), str(DEMO), str(tmp_path)], capture_output=True, text=True, timeout=300, cwd=ROOT)
    assert proc.returncode == 0, proc.stderr[-2000:]
    assert (tmp_path / "demo_thicket.blend").stat().st_size > 0
    assert (tmp_path / "demo_thicket.glb").stat().st_size > 0
    # Each fixture mesh baked with a texture and previewed; the previews show it (the
    # side-by-side picture is not the flat background alone).
    for name in ("Bunny", "Sheet", "Suzanne", "Torus"):
        assert re.search(rf"{name} +(chain_mail|grass) +-> {name}_thicket: [\d,]+ triangles", proc.stdout), proc.stdout
        assert (tmp_path / f"{name}_preview.png").stat().st_size > 0
    image = bpy.data.images.load(str(tmp_path / "demo_previews.png"))
    try:
        px = np.empty(image.size[0] * image.size[1] * 4, np.float32)
        image.pixels.foreach_get(px)
        grey = px.reshape(-1, 4)[:, :3]
        assert image.size[0] == 4 * image.size[1]
        assert (np.abs(grey - grey[0]).max(axis=1) > 0.1).mean() > 0.02
    finally:
        bpy.data.images.remove(image)
