"""The add-on's pure modules live in one folder, `thicket/pure/`: every module there
(none of its imports, read with `ast`, reaches a Blender module) imports and runs in
plain Python with every Blender module refused (the stack's settings, kinds and walk,
arrays and the native loader serve scripts and tools that run without Blender), and
no module outside it claims to need no Blender. The Blender side is imported when the
add-on registers."""

import ast
import json
import pathlib
import subprocess
import sys

from test_import_graph import module_name, relative_target

ROOT = pathlib.Path(__file__).resolve().parent.parent
ADDON = ROOT / "addon" / "thicket"  # the modules test_import_graph names
PURE = ADDON / "pure"
BLENDER_MODULES = {"bpy", "bmesh", "mathutils", "gpu", "gpu_extras", "bpy_extras", "blf", "aud", "freestyle", "bl_math", "idprop", "imbuf", "_bpy"}


def top_level_imports(path, package):
    """The modules `path` imports when it is imported: its statements outside
    functions (lazy imports inside functions do not count; class bodies run too)."""
    names = set()
    todo = list(ast.parse(path.read_text(), str(path)).body)
    while todo:
        node = todo.pop()
        if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)):
            continue
        if isinstance(node, ast.Import):
            names.update(a.name for a in node.names)
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                target = relative_target(package, node)
                names.update(f"{target}.{a.name}" for a in node.names)
                names.add(target)
            else:
                names.add(node.module or "")
        else:
            todo.extend(ast.iter_child_nodes(node))
    return names


def pure_modules():
    """Add-on modules that import no Blender module when imported, directly or through
    the add-on modules they import."""
    paths = {module_name(p): p for p in ADDON.rglob("*.py")}
    imports = {}
    for name, path in paths.items():
        package = name if path.name == "__init__.py" else name.rpartition(".")[0]
        # Importing a module imports its packages first.
        parents = {".".join(name.split(".")[:k]) for k in range(1, name.count(".") + 1)}
        imports[name] = top_level_imports(path, package) | parents
    pure = set(paths)
    changed = True
    while changed:
        changed = False
        for name in sorted(pure):
            own = imports[name]
            blender = any(m.split(".")[0] in BLENDER_MODULES for m in own)
            impure_dependency = any(m in paths and m not in pure for m in own)
            if blender or impure_dependency:
                pure.discard(name)
                changed = True
    return sorted(pure)


# Run in a fresh interpreter: Blender's modules refused, the add-on and the native
# module on the path; imports every pure module, then evaluates a stack.
CHILD = """
import importlib, importlib.abc, json, sys
blocked = set(json.loads(sys.argv[1]))
class NoBlender(importlib.abc.MetaPathFinder):
    def find_spec(self, name, path, target=None):
        if name.split(".")[0] in blocked:
            raise ImportError(f"{name}: no Blender here")
sys.meta_path.insert(0, NoBlender())
sys.path[:0] = json.loads(sys.argv[2])
for name in json.loads(sys.argv[3]):
    importlib.import_module(name)
import numpy as np
from thicket.pure.arrays import MeshArrays
from thicket.pure import settings as S
from thicket.pure.evaluate import evaluate_stack
quad = MeshArrays(np.float32([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0]]), np.int32([4]), np.int32([0, 1, 2, 3]))
out = evaluate_stack(quad, [S.FieldShell(thickness=0.1, relative=False)])
print(json.dumps({"z": out.vertices[:, 2].tolist(), "blender": sorted(m for m in sys.modules if m.split(".")[0] in blocked)}))
"""


def pure_folder():
    """The modules in the pure folder, packages included."""
    return sorted(module_name(p) for p in PURE.rglob("*.py"))


def test_every_module_in_the_pure_folder_is_pure():
    pure, folder = set(pure_modules()), pure_folder()
    assert not [name for name in folder if name not in pure], "these import Blender; move them out of pure/"
    # The package itself is imported first, so it needs no Blender either.
    assert "thicket" in pure
    # The stack's logic is there.
    assert {"thicket.pure.arrays", "thicket.pure.native", "thicket.pure.settings", "thicket.pure.state", "thicket.pure.evaluate"} <= set(folder)
    assert {"thicket.pure.kinds", "thicket.pure.kinds.shell", "thicket.pure.kinds.volumetric_texture", "thicket.pure.live_shells"} <= set(folder)
    # And the Blender side is recognised as such (the test can fail).
    assert "thicket.mesh_io" not in pure and "thicket.stack.properties" not in pure


#: How a module's docstring says that it needs no Blender.
CLAIMS = ("no bpy", "without blender", "no blender")


def claims_to_be_pure(path):
    doc = (ast.get_docstring(ast.parse(path.read_text(), str(path))) or "").lower()
    return any(claim in doc for claim in CLAIMS)


#: Modules outside pure/ that import no Blender module when imported, and why they
#: are Blender code all the same. A new module like them is a decision: pure/ if it
#: runs without Blender, here if it only works on what Blender hands it.
BLENDER_SIDE_WITHOUT_BPY_IMPORT = {
    "thicket": "registration: imports the Blender side when register() is called",
    "thicket.nodes": "package docstring only",
    "thicket.nodes.graph": "reads the Blender node trees and handle objects handed to it",
    "thicket.cli": "Blender's command-line command: imports bpy and the api when run",
    "thicket.render": "package docstring only",
    "thicket.render.camera": "reads Blender cameras, scenes and 3D views handed to it",
    "thicket.stack": "package docstring only",
    "thicket.stack.guard": "holds back Blender's update handlers while Thicket writes",
    "thicket.stack.query": "reads Blender's context",
}


def test_the_modules_outside_the_pure_folder_that_import_no_blender_are_known():
    outside = set(pure_modules()) - set(pure_folder())
    assert outside == set(BLENDER_SIDE_WITHOUT_BPY_IMPORT), outside ^ set(BLENDER_SIDE_WITHOUT_BPY_IMPORT)


def test_nothing_outside_the_pure_folder_claims_to_be_pure():
    """A module that says it needs no Blender belongs in pure/, where the tests hold it
    to that; outside, the package's own __init__ (registration, which imports Blender
    when called) is the one that says why it imports without it."""
    outside = [p for p in ADDON.rglob("*.py") if not p.is_relative_to(PURE) and p != ADDON / "__init__.py"]
    assert len(outside) > 20
    claiming = [module_name(p) for p in outside if claims_to_be_pure(p)]
    assert not claiming, f"{claiming} say they need no Blender but are outside pure/"
    # The check reads what the pure modules say of themselves.
    assert claims_to_be_pure(PURE / "__init__.py")


def test_pure_modules_import_and_evaluate_a_stack_without_blender():
    paths = [str(ROOT / "addon"), str(ROOT / "build" / "site")]
    args = [sys.executable, "-c", CHILD, json.dumps(sorted(BLENDER_MODULES)), json.dumps(paths), json.dumps(pure_folder())]
    done = subprocess.run(args, capture_output=True, text=True, timeout=120)
    assert done.returncode == 0, done.stderr[-3000:]
    result = json.loads(done.stdout.strip().splitlines()[-1])
    # The shell's outer layer: the quad's four vertices, 0.1 above it (a little less
    # at an open mesh's rim, where the field shell compresses).
    assert len(result["z"]) == 4 and all(0.05 < z <= 0.1 + 1e-5 for z in result["z"]), result
    assert result["blender"] == []


def test_unregister_removes_what_was_registered_even_after_a_reload():
    """Reloading a module while the add-on is registered makes new classes; unregister
    removes the registered ones (not the new ones, which Blender never saw), and
    registering again works."""
    import importlib

    import bpy

    import thicket
    import thicket.operators
    from thicket.operators import remove_stack

    importlib.reload(remove_stack)
    importlib.reload(thicket.operators)  # its CLASSES now names the new, unregistered class
    thicket.unregister()
    assert not hasattr(bpy.types, "THICKET_OT_remove")
    thicket.register()
    assert hasattr(bpy.types, "THICKET_OT_remove") and bpy.ops.thicket.remove.poll() in (True, False)
