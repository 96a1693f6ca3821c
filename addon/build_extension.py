"""Packs addon/thicket plus the built thicket_native wheel into an installable
Blender extension zip: python addon/build_extension.py WHEEL_DIR DIST_DIR."""

import pathlib
import re
import sys
import zipfile

ADDON = pathlib.Path(__file__).resolve().parent / "thicket"


def build(wheel_dir: pathlib.Path, dist: pathlib.Path) -> pathlib.Path:
    wheels = sorted(wheel_dir.glob("thicket_native-*.whl"))
    if not wheels:
        sys.exit(f"no thicket_native wheel in {wheel_dir}: run `make wheel` first")
    wheel = wheels[-1]
    manifest = (ADDON / "blender_manifest.toml").read_text()
    version = re.search(r'^version = "([^"]+)"', manifest, re.M).group(1)
    manifest = re.sub(r"^wheels = \[\]", f'wheels = ["./wheels/{wheel.name}"]', manifest, flags=re.M)
    dist.mkdir(parents=True, exist_ok=True)
    target = dist / f"thicket-{version}.zip"
    with zipfile.ZipFile(target, "w", zipfile.ZIP_DEFLATED) as z:
        for path in sorted(ADDON.rglob("*")):
            rel = path.relative_to(ADDON)
            if path.is_dir() or "__pycache__" in rel.parts or rel.parts[0] == "wheels" or path.suffix == ".pyc":
                continue
            if rel.name == "blender_manifest.toml":
                z.writestr(str(rel), manifest)
            else:
                z.write(path, str(rel))
        z.write(wheel, f"wheels/{wheel.name}")
    return target


if __name__ == "__main__":
    print(build(pathlib.Path(sys.argv[1]), pathlib.Path(sys.argv[2])))
