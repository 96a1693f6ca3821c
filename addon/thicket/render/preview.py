"""Renders a source's thick surface (shell + texture, not baked) into a Blender image."""

import time

import bpy
import numpy as np

from ..pure.evaluate import cancelled_error, render_setup
from ..stack.guard import suspended
from ..stack.regenerate import read_source
from . import lights

PREVIEW_IMAGE = "Thicket Preview"


def render_arrays(obj, view, projection, width, height, depsgraph=None, method="auto", slices=16, mipmaps="double", light=None, progress=None):
    """The native render of the first item of `obj`'s stack that a renderer draws (a
    Volumetric Texture over its shell; `pure.evaluate.render_setup`): a dict
    with rgba (h, w, 4, row 0 at the top), depth, normal, renderer, fallback.
    `mipmaps`: "double", "linear" or "off" (see `thicket_native.render_shell`).
    `light`: direction toward the light in `obj`'s space; the scene's main light
    (`lights.scene_light`) unless given. `progress`: see `render_native`."""
    source, items, light = render_inputs(obj, depsgraph, light)
    return render_native(source, items, light, view, projection, width, height, method, slices, mipmaps, progress)


def render_inputs(obj, depsgraph=None, light=None):
    """What a render reads from Blender (main thread only): the source mesh and the
    enabled items' settings as a regeneration reads them (`read_source`: a Procedural
    Detail's sculpt included) and the light direction, all plain data."""
    with suspended():
        depsgraph = depsgraph or bpy.context.evaluated_depsgraph_get()
        source, items = read_source(obj, depsgraph)
        if light is None:
            light = lights.scene_light(depsgraph, obj)
    return source, items, light


#: Share of a render's progress that its shells take; the render takes the rest
#: (rows of the CPU reference; a GPU frame in one step).
SHELL_SHARE = 0.5


def render_native(source, items, light, view, projection, width, height, method="auto", slices=16, mipmaps="double", progress=None):
    """`render_arrays` on what `render_inputs` read, without bpy (any thread).
    `progress`: as in `evaluate_stack`, up to `SHELL_SHARE` over the shells, the rest
    over the render; False cancels either (a GPU frame once it is drawn)."""
    scaled = None if progress is None else (lambda f: progress(SHELL_SHARE * f))
    setup = render_setup(source, items, scaled)
    if progress is not None and progress(SHELL_SHARE) is False:
        raise cancelled_error()
    out = setup.handle().render(
        view,
        projection,
        int(width),
        int(height),
        method=method,
        slices=int(slices),
        mipmaps=mipmaps,
        light=tuple(float(v) for v in light),
        progress=None if progress is None else (lambda f: progress(SHELL_SHARE + (1.0 - SHELL_SHARE) * f)),
    )
    if progress is not None:
        progress(1.0)
    return out


#: Marks the images Thicket renders into (ID property), the only ones it overwrites.
RENDER_TAG = "thicket_render"


def to_image(rgba, name=PREVIEW_IMAGE):
    """Writes a rendered (h, w, 4) linear RGBA array (row 0 at the top) into the float
    image `name` that Thicket made, created or resized as needed (never a user's image
    of that name); returns the image."""
    height, width = rgba.shape[:2]
    image = bpy.data.images.get(name)
    # Only an image Thicket made is reused: a user's image of that name (a texture, a
    # file) is left alone and the render goes to a new one (Blender numbers its name).
    if image is None or not image.get(RENDER_TAG) or not image.is_float or image.source != "GENERATED":
        image = bpy.data.images.new(name, width, height, alpha=True, float_buffer=True)
        image[RENDER_TAG] = True
    elif tuple(image.size) != (width, height):
        image.scale(width, height)
    # Blender's pixel rows run bottom-up.
    image.pixels.foreach_set(np.ascontiguousarray(rgba[::-1], dtype=np.float32).ravel())
    image.update()
    return image


def render_to_image(obj, view, projection, width, height, name=PREVIEW_IMAGE, **options):
    """Renders and shows the result in image `name`; returns (image, seconds, renderer
    name, fallback message)."""
    start = time.perf_counter()
    out = render_arrays(obj, view, projection, width, height, **options)
    image = to_image(out["rgba"], name)
    return image, time.perf_counter() - start, out["renderer"], out["fallback"]
