import bpy

from ..api import texture_item_index
from ..pure.fit_budget import fit_texture_budget
from ..stack.query import active_stack_source
from ..stack.regenerate import read_source
from .common import Job, JobWatch, StackOperator, WatchedOperator, error_text


class THICKET_OT_fit_bake_budget(StackOperator, WatchedOperator, bpy.types.Operator):
    """Grow the Volumetric Texture's tiles to the smallest size at which its bake is
    estimated within its Triangle Budget (a UV map's Tiling shrinks; without one,
    World-Size Tiles grow); Esc cancels and changes nothing"""

    bl_idname = "thicket.fit_bake_budget"
    bl_label = "Fit Tiles to Budget"

    index: bpy.props.IntProperty(default=-1, options={"HIDDEN", "SKIP_SAVE"})
    label: bpy.props.StringProperty(options={"HIDDEN", "SKIP_SAVE"})
    regenerate: bpy.props.BoolProperty(
        name="Then Regenerate", description="Regenerate the result once the tiles are fitted", default=False, options={"SKIP_SAVE"}
    )

    def invoke(self, context, event):
        return self.run_watched(context, self._watch(context))

    def execute(self, context):
        watch = self._watch(context)
        return {"CANCELLED"} if watch is None else watch.run_blocking(context)

    def _watch(self, context):
        obj = active_stack_source(context)
        at = texture_item_index(obj, self.index, self.label)
        if at is None:
            self.report({"ERROR"}, f"'{obj.name}' has no enabled Volumetric Texture item")
            return None
        try:
            arrays, items = read_source(obj, context.evaluated_depsgraph_get())
        except (KeyError, TypeError, ValueError) as exc:
            self.report({"ERROR"}, f"{obj.name}: {error_text(exc)}")
            return None
        enabled = sum(item.show_viewport for item in obj.thicket.items[:at])
        name, item_name, regenerate = obj.name, obj.thicket.items[at].name, self.regenerate
        job = Job(lambda job: fit_texture_budget(arrays, items, enabled, job.progress))

        def finish(fit):
            source = bpy.data.objects.get(name)
            if source is None or at >= len(source.thicket.items):
                self.report({"WARNING"}, f"'{name}' changed while its tiles were fitted")
                return {"CANCELLED"}
            item = source.thicket.items[at]
            for key, value in fit.settings.items():
                setattr(item, key, value)  # auto-update regenerates, asking above Ask Above
            found, budget = fit.found, item.triangle_budget
            what = f"Tiling {item.tiling:.4g}" if "tiling" in fit.settings else f"Tile Size {item.tile_size:.4g}"
            verdict = "within" if found["fits"] else "still over"
            self.report(
                {"INFO"},
                f"'{item_name}': {what} ({found['scale']:.2f} times larger tiles): about {found['triangles']:,} triangles, {verdict} its Triangle Budget of {budget:,}",
            )
            if regenerate:
                bpy.ops.thicket.regenerate("INVOKE_DEFAULT" if bpy.context.window is not None else "EXEC_DEFAULT", confirmed=True)
            return {"FINISHED"}

        return JobWatch(job, f"Fitting '{item_name}' to its budget", self.report, finish)
