import bpy

from ..pure import live_shells
from ..pure.evaluate import evaluate_stack
from ..pure.kinds.volumetric_texture import BakeNeedsConfirmation
from ..stack import auto_update
from ..stack.query import active_stack_source
from ..stack.regenerate import read_source, write_result
from .common import Job, JobWatch, StackOperator, WatchedOperator, error_text


class THICKET_OT_regenerate(StackOperator, WatchedOperator, bpy.types.Operator):
    """Recompute the Thicket result of the active object from its mesh and stack
    (Esc cancels and keeps the previous result)"""

    bl_idname = "thicket.regenerate"
    bl_label = "Regenerate"

    estimate: bpy.props.IntProperty(options={"HIDDEN", "SKIP_SAVE"})
    budget: bpy.props.IntProperty(options={"HIDDEN", "SKIP_SAVE"})
    making: bpy.props.StringProperty(default="bake", options={"HIDDEN", "SKIP_SAVE"})
    label: bpy.props.StringProperty(options={"HIDDEN", "SKIP_SAVE"})
    fit_budget: bpy.props.BoolProperty(
        name="Fit Tiles to Budget First",
        description="Grow the texture's tiles to the smallest size at which its bake is estimated within its Triangle Budget, then bake",
        options={"SKIP_SAVE"},
    )
    confirmed: bpy.props.BoolProperty(options={"HIDDEN", "SKIP_SAVE"})

    def invoke(self, context, event):
        if self.estimate:
            # A run found a bake (or a subdivision) over its item's "Ask Above": the user decides.
            confirm = {"bake": "Bake", "subdivision": "Subdivide"}.get(self.making, "Continue")
            return context.window_manager.invoke_props_dialog(self, title=f"Large {self.making}", confirm_text=confirm)
        if context.window is None:
            return self.execute(context)
        # Interactive: the stack evaluates on a worker thread while Blender shows the
        # progress; Esc cancels. Bakes over "Ask Above" wait for the user's OK.
        return self.run_watched(context, self._watch(context, ask=not self.confirmed, fresh=not self.confirmed))

    def draw(self, context):
        self.layout.label(text=f"This {self.making} makes about {self.estimate:,} triangles.", icon="ERROR")
        over = self.making == "bake" and self.budget and self.estimate > self.budget
        if self.budget and self.estimate > self.budget:
            self.layout.label(text=f"That is {self.estimate / self.budget:.1f} times its Triangle Budget of {self.budget:,}.")
        self.layout.label(text="It may take a while and a lot of memory. Make it?")
        if over:
            self.layout.prop(self, "fit_budget")

    def execute(self, context):
        if self.estimate and context.window is not None:
            # "Bake" in the dialog: run it watched, with progress and Esc (the tiles
            # fitted to the budget first where asked, watched alike).
            if self.fit_budget:
                bpy.ops.thicket.fit_bake_budget("INVOKE_DEFAULT", label=self.label, regenerate=True)
            else:
                bpy.ops.thicket.regenerate("INVOKE_DEFAULT", confirmed=True)
            return {"CANCELLED"}  # the run it started makes the undo step
        watch = self._watch(context, ask=False)
        return {"CANCELLED"} if watch is None else watch.run_blocking(context)

    def _watch(self, context, ask, fresh=True):
        return watched_regeneration(context, active_stack_source(context), ask, self.report, fresh)


def watched_regeneration(context, obj, ask, report, fresh=True):
    """The regeneration of `obj` as a watched job (None when its source cannot be
    read, reported): the source is read here (main thread), the stack evaluates in the
    job, the result is written only when it succeeded and was not cancelled. `fresh`:
    shells are built anew (not after a large-bake confirmation: the run that asked
    has just built them)."""
    name = obj.name
    auto_update.cancel(obj)  # a live build in flight read an older state than this run
    try:
        arrays, items = read_source(obj, context.evaluated_depsgraph_get())
    except (KeyError, TypeError, ValueError) as exc:
        _failed(obj, exc, report)
        return None
    if fresh:
        live_shells.clear()  # built from scratch, as asked for
    job = Job(lambda job: evaluate_stack(arrays, items, job.progress, ask))

    def finish(result_arrays):
        source = bpy.data.objects.get(name)
        if source is None:
            report({"WARNING"}, f"'{name}' was deleted while it regenerated")
            return {"CANCELLED"}
        write_result(source, result_arrays)
        return {"FINISHED"}

    def fail(exc):
        if isinstance(exc, BakeNeedsConfirmation):
            if bpy.context.window is not None:  # ask, then bake watched (see invoke)
                bpy.ops.thicket.regenerate("INVOKE_DEFAULT", estimate=exc.estimate, budget=exc.budget, making=exc.making, label=str(exc.label))
            return {"CANCELLED"}
        return _failed(bpy.data.objects.get(name), exc, report)

    return JobWatch(job, f"Regenerating '{name}'", report, finish, fail)


def _failed(obj, exc, report):
    """Reported, and kept on the stack for the panel; the previous result stays."""
    if obj is not None:
        obj.thicket.last_error = error_text(exc)
    report({"ERROR"}, f"{getattr(obj, 'name', '?')}: {error_text(exc)}")
    return {"CANCELLED"}
