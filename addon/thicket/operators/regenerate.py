import bpy

from .. import api
from ..stack.evaluate import BakeNeedsConfirmation
from .common import StackOperator, active_stack_source, error_text, progress, user_errors


class THICKET_OT_regenerate(StackOperator, bpy.types.Operator):
    """Recompute the Thicket result of the active object from its mesh and stack"""

    bl_idname = "thicket.regenerate"
    bl_label = "Regenerate"

    estimate: bpy.props.IntProperty(options={"HIDDEN", "SKIP_SAVE"})

    def invoke(self, context, event):
        # Interactive: bakes over an item's "Ask Above" wait for the user's OK.
        status = self._run(context, ask=True)
        if self.estimate:
            return context.window_manager.invoke_props_dialog(self, title="Large bake", confirm_text="Bake")
        return status

    def draw(self, context):
        self.layout.label(text=f"This bake makes about {self.estimate:,} triangles.", icon="ERROR")
        self.layout.label(text="It may take a while and a lot of memory. Bake it?")

    def execute(self, context):
        return self._run(context, ask=False)

    def _run(self, context, ask):
        obj = active_stack_source(context)
        self.estimate = 0
        try:
            with progress(context, len(obj.thicket.items)) as update:
                api.regenerate(obj, progress=update, ask=ask, fresh=True)
        except BakeNeedsConfirmation as exc:
            self.estimate = exc.estimate
            return {"CANCELLED"}
        except user_errors() as exc:
            obj.thicket.last_error = error_text(exc)
            self.report({"ERROR"}, f"{obj.name}: {error_text(exc)}")
            return {"CANCELLED"}
        return {"FINISHED"}
