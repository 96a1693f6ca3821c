"""Source object -> result object: the bpy side of `pure.evaluate`."""

import dataclasses

import bpy

from .. import mesh_io, sculpt
from ..pure import settings as S
from ..pure.evaluate import evaluate_stack
from ..pure.kinds.shell import summary_text
from ..pure.state import StackError
from .guard import suspended
from .versioning import ensure_upgraded


def result_name(source: bpy.types.Object) -> str:
    return f"{source.name}_thicket"


def enabled_settings(source, depsgraph=None):
    return [item.to_settings(depsgraph) for item in source.thicket.items if item.show_viewport]


def ensure_result(source: bpy.types.Object) -> bpy.types.Object:
    """The companion result object, created next to the source when missing.

    It is parented to the source with an identity parent inverse, so it follows the
    source's transform; its mesh lives in the source's object space.
    """
    stack = source.thicket
    result = stack.result
    if result is not None and result.name in bpy.data.objects:
        return result
    mesh = bpy.data.meshes.new(result_name(source))
    result = bpy.data.objects.new(result_name(source), mesh)
    for collection in source.users_collection or (bpy.context.scene.collection,):
        collection.objects.link(result)
    result.parent = source
    result.matrix_parent_inverse.identity()
    for material in source.data.materials:
        mesh.materials.append(material)
    result.thicket.source = source
    stack.result = result
    return result


def regenerate(source: bpy.types.Object, depsgraph=None, progress=None, ask=False) -> bpy.types.Object:
    """Evaluates the source's stack and writes the result object's mesh.

    The result is written only after the whole stack succeeded: on error or cancel the
    previous result stays, the source is never modified, and the exception
    propagates. `progress`: see `evaluate_stack` (a float in [0, 1]; False cancels).
    `ask`: stop with `BakeNeedsConfirmation` before a bake over its item's
    `confirm_above`.
    """
    ensure_upgraded()
    with suspended():
        arrays, items = read_source(source, depsgraph)
        return write_result(source, evaluate_stack(arrays, items, progress, ask))


def read_source(source: bpy.types.Object, depsgraph=None, items=None):
    """What evaluating the stack needs, read on the main thread: the evaluated source
    mesh (with the vertex groups its items use) and the enabled items' settings, or
    `items` (settings of a stack not added yet). Both are plain data, so
    `evaluate_stack` may run on another thread.

    When the first item is a Procedural Detail with Use Sculpt and the source has a
    Multires modifier, the source read is the modifiers' cage instead (other modifiers
    not applied: the item notes it) and the item's settings carry the sculpt as Blender
    gives it (`sculpt.read`): its analysis, cached, runs in the evaluation, which puts
    the sculpt's fitted coarse positions in the cage's. A later item with Use Sculpt is
    refused: only the first item starts from the source."""
    if source.type != "MESH":
        raise TypeError(f"'{source.name}' is a {source.type.lower()}, not a mesh")
    with suspended():
        depsgraph = depsgraph or bpy.context.evaluated_depsgraph_get()
        if items is None:
            items = enabled_settings(source, depsgraph)
        groups = sorted({g for item in items for g in item.vertex_groups()})
        takes = [i for i, item in enumerate(items) if isinstance(item, S.ProceduralDetail) and item.use_sculpt]
        if not takes or mesh_io.multires_modifier(source) is None:
            sculpt.forget(source)
            return mesh_io.read_evaluated(source, depsgraph, groups), items
        if takes[-1] > 0:
            raise StackError(
                f"'{items[takes[-1]].label}' uses the Multires sculpt (Use Sculpt) but is item {takes[-1] + 1} of the enabled stack:"
                " only the first item starts from the source; move it to the top or turn its Use Sculpt off"
            )
        base, read, notes = sculpt.read(source, depsgraph, groups, items[0].label)
        items = [dataclasses.replace(items[0], sculpt=read, sculpt_notes=tuple(notes)), *items[1:]]
        return base, items


def write_result(source: bpy.types.Object, result_arrays) -> bpy.types.Object:
    """Writes an evaluated stack into the source's result object (created when
    missing) and its notes and shell reports into the stack; returns the result."""
    with suspended():
        result = ensure_result(source)
        mesh_io.write_mesh(result.data, result_arrays)
        if source.thicket.last_error:
            source.thicket.last_error = ""
        note = "; ".join(result_arrays.notes)
        if source.thicket.last_note != note:
            source.thicket.last_note = note
        _store_summaries(source.thicket, result_arrays.shell_summaries)
    return result


def _store_summaries(stack, summaries):
    """The field shells' final-check lines, and how many source faces cross the
    source itself, for the panel (written only when they change: no extra updates)."""
    report = "\n".join(summary_text(s) for s in summaries)
    crossing = max((s["base_crossing_faces"] for s in summaries), default=0)
    if stack.last_report != report:
        stack.last_report = report
    if stack.source_crossings != crossing:
        stack.source_crossings = crossing
