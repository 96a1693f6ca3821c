import bpy
from bpy.props import BoolProperty, IntProperty, StringProperty

from ..fields import field_mesh
from ..pure.field_tree import CONFIRM_ABOVE, MAX_RESOLUTION, needs_confirmation
from .common import Job, JobWatch, WatchedOperator, error_text, user_errors


def _text(context, name):
    """The Text named `name`, else the Text editor's, else the only one."""
    if name:
        return bpy.data.texts.get(name)
    space = context.space_data
    if space is not None and space.type == "TEXT_EDITOR" and space.text is not None:
        return space.text
    return bpy.data.texts[0] if len(bpy.data.texts) == 1 else None


def watched_field_build(prepared, label, report, write, max_bytes=None):
    """A field mesh build as a watched job: the core meshes `prepared`
    (`fields.field_mesh.prepare`) on the worker thread with its progress, Esc
    cancels in the core; `write(arrays)` (main thread) makes or updates the object
    only when the build succeeded, so a cancel or an error leaves everything as it
    was (reported "Cancelled")."""
    job = Job(lambda job: field_mesh.mesh_arrays(prepared, job.progress, max_bytes))

    def finish(arrays):
        try:
            obj = write(arrays)
        except user_errors() as exc:
            report({"ERROR"}, f"{label}: {error_text(exc)}")
            return {"CANCELLED"}
        layer = bpy.context.view_layer
        if obj is not None and layer is not None:
            for other in layer.objects:
                other.select_set(False)
            try:
                obj.select_set(True)
                layer.objects.active = obj
            except RuntimeError:  # linked outside this view layer: made, not selected
                pass
        return {"FINISHED"}

    def cancelled():
        report({"WARNING"}, f"{label}: Cancelled; nothing was changed")
        return {"CANCELLED"}

    return JobWatch(job, label, report, finish, on_cancel=cancelled)


class FieldBuildOperator(WatchedOperator):
    """Mixin for operators that build a field mesh: modal with progress and Esc where
    there is a window, blocking otherwise; an interactive build estimated above
    `confirm_above` triangles asks first. Subclasses give `_build(context)`: the
    `prepare`d settings, a label, `write(arrays)` and `on_error(exc)`."""

    confirm_above: IntProperty(
        name="Ask Above",
        description="Ask before an interactive build estimated to make more triangles than this",
        min=0,
        default=CONFIRM_ABOVE,
    )
    estimate: IntProperty(options={"HIDDEN", "SKIP_SAVE"})
    estimate_bytes: IntProperty(options={"HIDDEN", "SKIP_SAVE"})
    confirmed: BoolProperty(options={"HIDDEN", "SKIP_SAVE"})

    def invoke(self, context, event):
        build = self._checked(context)
        if build is None:
            return {"CANCELLED"}
        prepared = build[0]
        if not self.confirmed:
            try:
                guess = field_mesh.estimate(prepared)
            except user_errors() as exc:
                return self._error(build, exc)
            if needs_confirmation(guess, self.confirm_above) and context.window is not None:
                self.estimate = min(int(guess["triangles"]), 2**31 - 1)
                self.estimate_bytes = min(int(guess["peak_bytes"] // 1_000_000), 2**31 - 1)
                return context.window_manager.invoke_props_dialog(self, title="Large field mesh", confirm_text="Build")
        return self.run_watched(context, watched_field_build(prepared, build[1], self.report, build[2]))

    def draw(self, context):
        if self.estimate:
            self.layout.label(text=f"This field mesh makes about {self.estimate:,} triangles ({self.estimate_bytes:,} MB).", icon="ERROR")
            self.layout.label(text="It may take a while and a lot of memory. Build it?")
            return
        for name in self._draw_properties:
            self.layout.prop(self, name)
        self.layout.prop(self, "confirm_above")

    def execute(self, context):
        if self.estimate and not self.confirmed and context.window is not None:
            # "Build" in the dialog: run it watched, with progress and Esc.
            again = getattr(bpy.ops.thicket, self.bl_idname.split(".", 1)[1])
            again("INVOKE_DEFAULT", confirmed=True, confirm_above=self.confirm_above, **{n: getattr(self, n) for n in self._draw_properties})
            return {"CANCELLED"}  # the run it started makes the undo step
        build = self._checked(context)
        if build is None:
            return {"CANCELLED"}
        return watched_field_build(build[0], build[1], self.report, build[2]).run_blocking(context)

    def _checked(self, context):
        try:
            return self._build(context)
        except user_errors() as exc:
            self.report({"ERROR"}, f"{self.bl_label}: {error_text(exc)}")
            return None

    def _error(self, build, exc):
        self.report({"ERROR"}, f"{build[1]}: {error_text(exc)}")
        return {"CANCELLED"}


class THICKET_OT_field_mesh_add(FieldBuildOperator, bpy.types.Operator):
    """Add a mesh of an implicit field tree read from a Text holding its JSON (the
    tree and settings are kept on the object, so it can be regenerated; Esc cancels
    the build)"""

    bl_idname = "thicket.field_mesh_add"
    bl_label = "Add Field Mesh"
    bl_options = {"REGISTER", "UNDO"}

    text: StringProperty(name="Text", description="The Text holding the field tree's JSON (default: the Text editor's, or the only Text)")
    resolution: IntProperty(
        name="Resolution", description="Cells along the longest side of the tree's bounds", min=2, max=MAX_RESOLUTION, soft_max=512, default=128
    )
    adaptive: BoolProperty(
        name="Adaptive",
        description="Dual contouring on the cells that may hold the surface: quads, sharp creases and corners (off: marching prisms on the whole grid, triangles)",
        default=True,
    )
    _draw_properties = ("text", "resolution", "adaptive")

    @classmethod
    def poll(cls, context):
        return len(bpy.data.texts) > 0

    def _build(self, context):
        text = _text(context, self.text)
        if text is None:
            which = f"no Text named '{self.text}'" if self.text else "several Texts: name the one holding the field tree"
            raise KeyError(which)
        prepared = field_mesh.prepare(text.as_string(), self.resolution, None, self.adaptive)
        name, collection, text_name = text.name.rsplit(".", 1)[0] or "Field Mesh", context.collection, text.name

        def write(arrays):
            return field_mesh.write_new(prepared, arrays, name, collection, bpy.data.texts.get(text_name))

        return prepared, "Add Field Mesh", write


__all__ = ["THICKET_OT_field_mesh_add", "FieldBuildOperator", "watched_field_build"]
