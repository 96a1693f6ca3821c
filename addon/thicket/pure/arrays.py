"""Meshes as flat numpy arrays: the form thicket_native takes and returns."""

from dataclasses import dataclass, field

import numpy as np

#: The pseudo vertex group of the source's selected faces (weight 1 on their vertices).
SELECTED_FACES = "<selected faces>"
#: The pseudo vertex group of the source's selected vertices (weight 1 on them).
SELECTED_VERTICES = "<selected vertices>"


def weight_attribute(vertex_group: str) -> str:
    """Name of the point attribute that carries a vertex group's weights."""
    return f"thicket_weight:{vertex_group}"


@dataclass
class MeshArrays:
    vertices: np.ndarray  # (n, 3) float32
    face_sizes: np.ndarray  # (f,) int32, Blender's loop_total
    corners: np.ndarray  # (c,) int32, Blender's loop vertex_index
    point_attributes: dict = field(default_factory=dict)  # name -> (n,) or (n, 3) float32
    uvs: np.ndarray | None = None  # (c, 2) float32: the active UV map per corner, or None
    normals: np.ndarray | None = None  # (n, 3) float32 custom vertex normals to write, or None
    notes: list = field(default_factory=list)  # things the user should be told about the result
    uv_maps: dict = field(default_factory=dict)  # UV map name -> (c, 2) float32, every map
    material_index: np.ndarray | None = None  # (f,) int32 per face, or None
    uv_name: str = "UVMap"  # the active UV map's name (what `uvs` holds)
    attributes: dict = field(default_factory=dict)  # name -> (domain, data type, values): colours, ints, corner data
    active_color: str = ""  # the colour attribute (in `attributes`) to make active and rendered, or ""

    def carried_to(self, result: "MeshArrays", source_corner, source_face) -> "MeshArrays":
        """`result` given this mesh's UV maps and material indices through provenance
        (the corner and face of this mesh each corner and face of `result` comes from)."""
        result.uv_maps = {name: uv[source_corner] for name, uv in self.uv_maps.items()}
        result.uvs = None if self.uvs is None else self.uvs[source_corner]
        result.material_index = None if self.material_index is None else self.material_index[source_face]
        result.uv_name = self.uv_name
        return result

    @property
    def vertex_count(self) -> int:
        return len(self.vertices)

    @property
    def face_count(self) -> int:
        return len(self.face_sizes)

    @classmethod
    def from_native(cls, result: dict) -> "MeshArrays":
        """A mesh from a thicket_native result dict (vertices, face_sizes, corners)."""
        return cls(result["vertices"], result["face_sizes"], result["corners"])
