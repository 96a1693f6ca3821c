"""`blender -c thicket ...`: batch thick surfaces from the command line (Blender 4.2+).

    blender -c thicket input.blend [more.blend ...] --out-dir out/ [--thickness 0.05]
            [--absolute] [--output outer|solid|layers] [--glb]

For each input, every mesh gets a thick-surface stack; `<name>_thicket.blend` (and
`.glb` with --glb) are written into --out-dir. Exit status 0 when every file worked.
"""

import argparse
import os
import sys


def parser():
    p = argparse.ArgumentParser(prog="blender -c thicket", description="Add Thicket thick surfaces to every mesh of .blend files.")
    p.add_argument("inputs", nargs="+", help=".blend files to process")
    p.add_argument("--out-dir", default="out", help="folder for the results (default: out)")
    p.add_argument("--thickness", type=float, default=0.05, help="fraction of the bounding-box diagonal, or a length with --absolute")
    p.add_argument("--absolute", action="store_true", help="thickness is a length, not a fraction of the object's size")
    p.add_argument("--output", choices=["outer", "solid", "layers"], default="outer")
    p.add_argument("--glb", action="store_true", help="also write a .glb of the results")
    return p


def run(argv) -> int:
    from . import api

    args = parser().parse_args(argv)
    status = 0
    for path in args.inputs:
        stem = os.path.splitext(os.path.basename(path))[0]
        out_blend = os.path.join(args.out_dir, f"{stem}_thicket.blend")
        out_glb = os.path.join(args.out_dir, f"{stem}_thicket.glb") if args.glb else None
        try:
            done = api.process_file(
                path,
                out_blend=out_blend,
                out_glb=out_glb,
                thickness=args.thickness,
                thickness_mode="ABSOLUTE" if args.absolute else "RELATIVE",
                output=args.output.upper(),
            )
        except (OSError, RuntimeError) as exc:
            print(f"thicket: {path}: {exc}", file=sys.stderr)
            status = 1
            continue
        for source, result in done.items():
            print(f"thicket: {path}: {source} -> {result}")
            status |= result.startswith("error:")
        print(f"thicket: wrote {out_blend}" + (f" and {out_glb}" if out_glb else ""))
    return status


def register():
    import bpy

    if hasattr(bpy.utils, "register_cli_command"):
        return bpy.utils.register_cli_command("thicket", run)
    return None


def unregister(handle):
    import bpy

    if handle is not None:
        bpy.utils.unregister_cli_command(handle)
