import time

import bpy
from bpy.props import BoolProperty, EnumProperty, IntProperty

from ..render import camera, preview
from ..stack.query import active_stack_source
from .common import Job, JobWatch, WatchedOperator, error_text, user_errors


class THICKET_OT_render_preview(WatchedOperator, bpy.types.Operator):
    """Render the active object's thick surface (shell and texture, not baked) into the
    'Thicket Preview' image, from the scene camera or the 3D view (Esc cancels)"""

    bl_idname = "thicket.render_preview"
    bl_label = "Render Preview"
    bl_options = {"REGISTER", "UNDO"}

    use_view: BoolProperty(name="From 3D View", description="Render the 3D view's angle instead of the scene camera", default=False)
    method: EnumProperty(
        name="Renderer",
        items=[
            ("auto", "Automatic", "The GPU slice renderer, or the CPU reference when no GPU adapter exists"),
            ("interpolating", "Slices (Interpolating)", "GPU slices with the surface found between slices (chapter 5)"),
            ("plain", "Slices (Plain)", "GPU slices without interpolation, for comparison"),
            ("reference", "Reference (CPU)", "Ray marching with exact root bracketing: slow, exact"),
        ],
        default="auto",
    )
    slices: IntProperty(name="Slices", description="Slices per cell", min=1, max=256, default=16)
    mipmaps: EnumProperty(
        name="Mipmaps",
        description="How textures finer than the pixels are filtered (slice renderers)",
        items=[
            ("double", "Double", "Geometry up close, a semi-transparent medium far away, so fine detail never vanishes (chapter 6)"),
            ("linear", "Averaged", "Plain averaged mipmaps: fine detail thins out and vanishes far away"),
            ("off", "Off", "The full texture everywhere: far views alias"),
        ],
        default="double",
    )

    @classmethod
    def poll(cls, context):
        return active_stack_source(context) is not None

    def invoke(self, context, event):
        self.use_view = context.region_data is not None and context.space_data is not None and context.space_data.type == "VIEW_3D"
        # The shells and the render run on a worker thread while Blender shows the
        # progress; Esc cancels them (a GPU frame once it is drawn).
        return self.run_watched(context, self._watch(context))

    def execute(self, context):
        watch = self._watch(context)
        return {"CANCELLED"} if watch is None else watch.run_blocking(context)

    def _watch(self, context):
        """The render as a watched job: camera and source read here (main thread), the
        shells and the render in the job, the image written when it succeeded."""
        obj = active_stack_source(context)
        depsgraph = context.evaluated_depsgraph_get()
        try:
            if self.use_view and context.region_data is not None:
                width, height = context.region.width, context.region.height
                view, projection = camera.viewport_camera(context.region_data, obj)
            else:
                width, height = camera.render_size(context.scene)
                view, projection = camera.scene_camera(context.scene, depsgraph, obj, width, height)
            source, items, light = preview.render_inputs(obj, depsgraph)
        except user_errors() as exc:
            self.report({"ERROR"}, f"{obj.name}: {error_text(exc)}")
            return None
        method, slices, mipmaps = self.method, self.slices, self.mipmaps
        start = time.perf_counter()

        def work(job):
            return preview.render_native(source, items, light, view, projection, width, height, method, slices, mipmaps, job.progress)

        def finish(out):
            image = preview.to_image(out["rgba"])
            if out["fallback"]:
                self.report({"WARNING"}, out["fallback"])
            self.report({"INFO"}, f"'{image.name}': {width}x{height} in {time.perf_counter() - start:.2f} s ({out['renderer']})")
            screen = bpy.context.screen
            for area in screen.areas if screen else ():
                if area.type == "IMAGE_EDITOR":
                    area.spaces.active.image = image
                    break
            return {"FINISHED"}

        return JobWatch(Job(work), f"Rendering '{obj.name}'", self.report, finish)
