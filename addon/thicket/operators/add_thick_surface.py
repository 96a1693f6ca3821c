import bpy
from bpy.props import EnumProperty, FloatProperty

from .. import api
from ..pure import settings as S
from ..pure.evaluate import evaluate_each
from ..stack.guard import suspended
from ..stack.properties import ThicketItem
from ..stack.regenerate import read_source, write_result
from .common import Job, JobWatch, WatchedOperator, error_text, user_errors


class THICKET_OT_add_thick_surface(WatchedOperator, bpy.types.Operator):
    """Give every selected mesh a thick-surface stack (Offset Shell) and generate its result
    (Esc cancels the objects not finished yet)"""

    bl_idname = "thicket.add_thick_surface"
    bl_label = "Add Thick Surface"
    bl_options = {"REGISTER", "UNDO"}

    thickness: FloatProperty(
        name="Thickness", default=0.05, precision=4, step=0.1, description=ThicketItem.__annotations__["thickness"].keywords["description"]
    )
    thickness_mode: EnumProperty(name="Mode", items=ThicketItem.__annotations__["thickness_mode"].keywords["items"], default="RELATIVE")
    output: EnumProperty(name="Output", items=ThicketItem.__annotations__["output"].keywords["items"], default="OUTER")
    kind: EnumProperty(name="Kind", items=ThicketItem.__annotations__["kind"].keywords["items"], default="OFFSET_SHELL")
    side: EnumProperty(name="Side", items=ThicketItem.__annotations__["side"].keywords["items"], default="EXTERIOR")

    @classmethod
    def poll(cls, context):
        return any(o.type == "MESH" for o in context.selected_objects)

    def invoke(self, context, event):
        # Interactive: the shells are built on a worker thread while Blender shows the
        # progress; Esc cancels the objects not finished yet.
        return self.run_watched(context, self._watch(context))

    def execute(self, context):
        # Scripts and the redo panel: blocking (Ctrl-C cancels as Esc does).
        watch = self._watch(context)
        return {"CANCELLED"} if watch is None else watch.run_blocking(context)

    def _watch(self, context):
        selected = list(context.selected_objects)
        meshes = [o for o in selected if o.type == "MESH" and o.thicket.source is None]
        if len(selected) > len(meshes):
            self.report({"INFO"}, f"Skipped {len(selected) - len(meshes)} selected object(s) that are not source meshes")
        if not meshes:
            return None
        item = dict(thickness=self.thickness, thickness_mode=self.thickness_mode, output=self.output)
        if self.kind == S.FieldShell.kind:
            item["side"] = self.side
        return watched_thick_surfaces(meshes, self.kind, item, self.report)


def watched_thick_surfaces(objects, kind, item, report):
    """Thick surfaces for `objects` (source meshes) as one watched job, as
    `api.add_thick_surface` makes them one by one: each source is read here (main
    thread) with its stack, or with a new `kind` item of the properties `item` where
    it has none; the job evaluates them in turn; the stacks and results of the objects
    it finished are written here once it ended (all of them, or those before a cancel
    or an unexpected error: the others are left as they were)."""
    # (A lone Volumetric Texture item fails in the evaluation, as it does from the API.)
    new_stack = [S.shell_settings(kind, **item) if kind in (S.OffsetShell.kind, S.FieldShell.kind) else S.KINDS[kind]()]
    names, sources = [], []
    for obj in objects:
        names.append(obj.name)
        try:
            sources.append(read_source(obj, items=None if obj.thicket.items else new_stack))
        except user_errors() as exc:  # reported with the object's turn
            sources.append(exc)
    label = "Adding thick surfaces"
    done = []  # each finished object's result or error, in order

    def work(job):
        outcomes = evaluate_each(sources, job.progress, user_errors())
        for i, name in enumerate(names):
            job.stage = f"'{name}' ({i + 1} of {len(names)})"
            done.append(next(outcomes))
        return done

    def conclude(stopped=None):
        made, failed = [], []
        with suspended():
            for name, outcome in zip(names, done):
                obj = bpy.data.objects.get(name)
                if obj is None:
                    failed.append(f"'{name}' was deleted meanwhile")
                    continue
                if not obj.thicket.items:
                    api.add_item(obj, kind, **item)
                if isinstance(outcome, BaseException):
                    obj.thicket.last_error = error_text(outcome)
                    failed.append(f"{name}: {error_text(outcome)}")
                else:
                    write_result(obj, outcome)
                    made.append(name)
        left = names[len(done) :]
        if stopped is not None and left:
            why = "cancelled" if stopped == "cancel" else error_text(stopped)
            report({"WARNING"} if stopped == "cancel" else {"ERROR"}, f"{label}: {why}; {len(done)} of {len(names)} done, left as they were: {', '.join(left)}")
        if failed and not made:
            report({"ERROR"}, "; ".join(failed))
        for message in failed if made else ():  # some objects worked: keep them, warn about the rest
            report({"WARNING"}, message)
        return {"FINISHED"} if made else {"CANCELLED"}

    return JobWatch(Job(work), label, report, lambda _: conclude(), fail=conclude, on_cancel=lambda: conclude("cancel"))
