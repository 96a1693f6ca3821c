"""The built extension zip installs into a fresh Blender user directory and works
from the installed copy, with the thicket_native wheel the zip carries."""

import json
import os
import pathlib
import subprocess
import sys

ROOT = pathlib.Path(__file__).resolve().parent.parent

SCRIPT = r"""
import json, sys, bpy
zip_path = sys.argv[1]
bpy.ops.extensions.package_install_files(filepath=zip_path, repo="user_default", enable_on_install=True)
import thicket_native
from bl_ext.user_default.thicket import api
for obj in list(bpy.data.objects):
    bpy.data.objects.remove(obj)
bpy.ops.mesh.primitive_cube_add()
cube = bpy.context.active_object
ret = bpy.ops.thicket.add_thick_surface(thickness=0.1, output="SOLID")
print("RESULT", json.dumps({
    "ret": sorted(ret),
    "native": thicket_native.__file__,
    "api": api.__file__,
    "faces": len(cube.thicket.result.data.polygons),
    "cli": hasattr(bpy.utils, "register_cli_command"),
}))
"""


def test_install_zip_and_run_operator(tmp_path):
    zips = sorted((ROOT / "dist").glob("thicket-*.zip"))
    assert zips, "run `make extension` first (make test does)"
    env = dict(os.environ, BLENDER_USER_RESOURCES=str(tmp_path / "user"))
    # No build/site or addon/ on the path: everything must come from the installed zip.
    proc = subprocess.run(
        [sys.executable, "-c", SCRIPT, str(zips[-1])],
        env=env,
        capture_output=True,
        text=True,
        timeout=300,
        cwd=tmp_path,
    )
    line = next((text for text in proc.stdout.splitlines() if text.startswith("RESULT ")), None)
    assert line, proc.stdout[-3000:] + proc.stderr[-3000:]
    result = json.loads(line[len("RESULT ") :])
    assert result["ret"] == ["FINISHED"]
    assert result["faces"] == 12
    assert result["native"].startswith(str(tmp_path)), result["native"]
    assert result["api"].startswith(str(tmp_path)), result["api"]
