"""`make demo`: a headless batch run of Thicket on a bundled fixture.

    .venv/bin/python blend_fixtures/demo.py blend_fixtures/demo.blend out
    blender -b blend_fixtures/demo.blend --python blend_fixtures/demo.py -- blend_fixtures/demo.blend out

Every mesh gets a thick-surface stack (Offset Shell, solid, 3% of its size; the
sheet's thickness follows its "thickness" vertex group); writes out/demo_thicket.blend
and out/demo_thicket.glb.
"""

import os
import pathlib
import sys

HERE = pathlib.Path(__file__).resolve().parent
ROOT = HERE.parent
sys.path[:0] = [str(ROOT / "addon"), str(ROOT / "build" / "site")]

import bpy  # noqa: E402

import thicket  # noqa: E402
from thicket import api  # noqa: E402


def main(argv):
    source, out_dir = pathlib.Path(argv[0]), pathlib.Path(argv[1])
    if not hasattr(bpy.types.Object, "thicket"):
        thicket.register()
    out_blend, out_glb = out_dir / f"{source.stem}_thicket.blend", out_dir / f"{source.stem}_thicket.glb"
    done = api.process_file(str(source), thickness=0.03, output="SOLID")
    sheet = bpy.data.objects.get("Sheet")
    if sheet is not None:
        sheet.thicket.items[0].vertex_group = "thickness"
        api.regenerate(sheet)
    for name, result in done.items():
        obj = bpy.data.objects.get(result)
        detail = f"{len(obj.data.vertices)} vertices, {len(obj.data.polygons)} faces" if obj else ""
        print(f"  {name:10s} -> {result} {detail}")
    out_dir.mkdir(parents=True, exist_ok=True)
    bpy.ops.wm.save_as_mainfile(filepath=str(out_blend.resolve()), copy=True)
    api.export_glb([bpy.data.objects[r] for r in done.values() if r in bpy.data.objects], str(out_glb))
    print(f"wrote {out_blend}\nwrote {out_glb}")


if __name__ == "__main__":
    args = sys.argv[sys.argv.index("--") + 1:] if "--" in sys.argv else sys.argv[1:]
    main(args)
    if not bpy.app.binary_path:
        # Run as the bpy module (not Blender): its interpreter teardown is fragile (it
        # segfaults on 4.2 once any add-on class was registered, reproduced without
        # Thicket, and crashed once under load on 5.0.1). Everything is written: leave.
        sys.stdout.flush()
        sys.stderr.flush()
        os._exit(0)
