"""Field trees rendered into Blender images by the core's sphere tracer
(`thicket_native.field_render`), from a camera object or a default view framing the
tree."""

import math

import bpy
import numpy as np
from mathutils import Matrix, Vector

from ..pure import native
from ..pure.field_tree import check_tree, invalid

#: Where the default view looks from (towards the tree's centre): front right, above.
DEFAULT_DIRECTION = (1.0, -1.4, 0.9)
#: The default view's field of view across the larger side of the image (radians;
#: Blender's 50 mm lens on its 36 mm sensor).
DEFAULT_FOV = 2.0 * math.atan(18.0 / 50.0)
#: Cells of the coarse mesh whose vertices give a tree's extent for the default view.
FRAMING_RESOLUTION = 24


def tree_extent(text):
    """(min corner, max corner) of the tree's zero set, from a coarse mesh: the core's
    own bound grown by two cells is the grid, its vertices lie on the surface."""
    out = native.get().field_mesh(text, resolution=FRAMING_RESOLUTION)
    vertices = out["vertices"]
    if len(vertices) == 0:
        raise invalid("field tree: its surface is empty, nothing to frame: pass a camera")
    return vertices.min(axis=0).astype(np.float64), vertices.max(axis=0).astype(np.float64)


def default_camera(text, width, height):
    """(view, projection) framing the tree's extent from `DEFAULT_DIRECTION`
    (perspective, `DEFAULT_FOV` across the larger side; OpenGL conventions, as
    `calc_matrix_camera` gives)."""
    lo, hi = tree_extent(text)
    center = Vector(((lo + hi) / 2.0).tolist())
    radius = max(float(np.linalg.norm(hi - lo)) / 2.0, 1e-6)
    distance = radius / math.sin(DEFAULT_FOV / 2.0) * 1.05
    direction = Vector(DEFAULT_DIRECTION).normalized()
    eye = center + direction * distance
    rotation = (-direction).to_track_quat("-Z", "Y").to_matrix().to_4x4()
    view = (Matrix.Translation(eye) @ rotation).inverted()
    near, far = max(distance - 2.0 * radius, distance * 1e-3), distance + 2.0 * radius
    f = 1.0 / math.tan(DEFAULT_FOV / 2.0)
    fx, fy = (f, f * width / height) if width >= height else (f * height / width, f)
    projection = np.array(
        [[fx, 0, 0, 0], [0, fy, 0, 0], [0, 0, (far + near) / (near - far), 2 * far * near / (near - far)], [0, 0, -1, 0]],
        dtype=np.float32,
    )
    return np.array(view, dtype=np.float32), projection


def camera_matrices(camera, width, height):
    """(view, projection) of a Blender camera object for a width x height image."""
    if not isinstance(camera, bpy.types.Object) or camera.type != "CAMERA":
        raise TypeError(f"camera must be a camera object, got {getattr(camera, 'name', camera)!r}")
    depsgraph = bpy.context.evaluated_depsgraph_get()
    projection = camera.calc_matrix_camera(depsgraph, x=width, y=height)
    return np.array(camera.matrix_world.inverted(), dtype=np.float32), np.array(projection, dtype=np.float32)


def render_field(tree_json, camera=None, width=512, height=512, image="Thicket Field"):
    """The tree rendered into the float image `image` (created or resized), returned."""
    from ..render.preview import to_image

    if isinstance(tree_json, bpy.types.Text):
        tree_json = tree_json.as_string()
    text = check_tree(tree_json)
    for side in (width, height):
        if isinstance(side, bool) or not isinstance(side, (int, np.integer)) or side < 1:
            raise invalid(f"width and height must be whole numbers of pixels >= 1, got {width} x {height}")
    width, height = int(width), int(height)
    view, projection = default_camera(text, width, height) if camera is None else camera_matrices(camera, width, height)
    rgba = native.get().field_render(text, view, projection, width=width, height=height)
    return to_image(np.asarray(rgba, dtype=np.float32), image)
