"""The light a preview is lit by, from the Blender scene, as the direction toward it in
a source object's own space (the space the native renderers shade in)."""

import numpy as np
from mathutils import Vector

# Toward the light when the scene has none: from the front-left, above.
DEFAULT_LIGHT = (0.3, -0.5, 0.8)


def _object_centre(obj):
    corners = np.array([obj.matrix_world @ Vector(c) for c in obj.bound_box], dtype=np.float64)
    return corners.mean(axis=0)


def scene_light(depsgraph, obj):
    """Direction toward the scene's main light, in `obj`'s space: the strongest
    visible sun (its rays run along its local -Z), else the point, spot or area light
    giving `obj`'s centre the most power (energy over squared distance), else
    `DEFAULT_LIGHT`. The renderers take one directional light."""
    centre = _object_centre(obj)
    suns, others = [], []
    for instance in depsgraph.object_instances:
        light_object = instance.object
        if light_object.type != "LIGHT":
            continue
        light = light_object.data
        matrix = instance.matrix_world
        if light.type == "SUN":
            toward = np.array(matrix.to_3x3() @ Vector((0.0, 0.0, 1.0)), dtype=np.float64)
            suns.append((float(light.energy), toward))
        else:
            toward = np.array(matrix.translation, dtype=np.float64) - centre
            distance2 = float(toward @ toward)
            if distance2 > 1e-12:
                others.append((float(light.energy) / distance2, toward))
    candidates = suns or others
    if not candidates:
        return DEFAULT_LIGHT
    _, toward = max(candidates, key=lambda c: c[0])
    # World vectors to the object's space by the inverse of its matrix (exact for
    # rotations and uniform scale; an approximation under non-uniform scale, where
    # the renderers' object-space shading differs from world space anyway).
    local = np.array(obj.matrix_world.inverted_safe().to_3x3() @ Vector(toward), dtype=np.float64)
    length = float(np.linalg.norm(local))
    if not np.isfinite(length) or length < 1e-12:
        return DEFAULT_LIGHT
    return tuple(float(v) for v in local / length)
