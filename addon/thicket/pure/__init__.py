"""Thicket's modules that import without Blender: plain Python and numpy over the
native core, for the add-on, scripts and tools alike.

The rule (`tests/test_pure_modules.py`, `tests/test_import_graph.py`): every module in
this folder imports in a Python that has no Blender module, and imports nothing of
the add-on outside this folder; the Blender side (`stack/` PropertyGroups,
regeneration and auto-update, `mesh_io`, `operators/`, `render/`, `ui/`, `api`)
imports from here, never the other way. As glTF-Blender-IO keeps its
Blender-independent code in `io/` beside `blender/`.

- `arrays`: meshes as flat numpy arrays, the form `thicket_native` takes and returns.
- `native`: the compiled core, imported once, with a message users can act on.
- `settings`: each stack item kind's settings as plain data.
- `kinds`: one module per item kind with its step, and the registry of what each
  consumes and produces.
- `state`: what the stack's walk carries from item to item.
- `evaluate`: the walk over a stack of settings, mesh arrays in, mesh arrays out.
- `live_shells`: field shells kept between evaluations for incremental edits.
"""
