"""Blender cameras and 3D views as the view and projection matrices the native
renderers take, in a source object's own space (the shell lives there)."""

import numpy as np


def _local_view(view_world, obj):
    return np.array(view_world @ obj.matrix_world, dtype=np.float32)


def render_size(scene):
    """The scene's output size in pixels (resolution times its percentage)."""
    r = scene.render
    scale = r.resolution_percentage / 100.0
    return max(1, int(r.resolution_x * scale)), max(1, int(r.resolution_y * scale))


def scene_camera(scene, depsgraph, obj, width, height):
    """(view, projection) of the scene camera for an image of width x height pixels:
    Blender's own projection (lens, sensor fit, shift, orthographic scale) from
    `calc_matrix_camera`, the view in `obj`'s space."""
    camera = scene.camera
    if camera is None:
        raise ValueError("the scene has no camera: add one or render from the 3D view")
    r = scene.render
    projection = camera.calc_matrix_camera(depsgraph, x=width, y=height, scale_x=r.pixel_aspect_x, scale_y=r.pixel_aspect_y)
    view = camera.matrix_world.inverted()
    return _local_view(view, obj), np.array(projection, dtype=np.float32)


def viewport_camera(region_3d, obj):
    """(view, projection) of a 3D view (its `RegionView3D`)."""
    return _local_view(region_3d.view_matrix, obj), np.array(region_3d.window_matrix, dtype=np.float32)
