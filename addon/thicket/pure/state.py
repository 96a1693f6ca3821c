"""What a stack's walk carries from item to item: the current mesh, where its
vertices came from, the latest shell, and the notes for the user. Every item kind's
step reads and updates it (`pure.kinds`); the walk itself is `pure.evaluate`."""

import numpy as np

from . import native
from .arrays import MeshArrays, weight_attribute


class ShellContext:
    """The shell a later Volumetric Texture maps into: the mesh it was built on, its
    base offsets and directors (depth r over vertex v at v + base_offset + r * director)
    and `handle`, the same shell as a `thicket_native.Shell` (its `mesh` the base with
    its UVs), read and checked once by the shell's kind and passed on without numpy."""

    def __init__(self, base: MeshArrays, out, origin):
        self.base = base
        self.directors = np.ascontiguousarray(out["directors"], dtype=np.float32)
        offset = out.get("base_offset")
        self.base_offset = np.zeros_like(self.directors) if offset is None else np.ascontiguousarray(offset, dtype=np.float32)
        self.origin = origin  # source vertex of each base vertex
        tn = native.get()
        uvs = None if base.uvs is None else np.ascontiguousarray(base.uvs, dtype=np.float32)
        mesh = tn.Mesh(np.ascontiguousarray(base.vertices, dtype=np.float32), base.face_sizes, base.corners, uvs)
        self.handle = tn.Shell(mesh, self.base_offset, self.directors)
        self.generated = {}  # tile size -> (Shell handle over the base with world-size UVs, the UVs)

    def world_size(self, tile_size):
        """The same shell over its base with generated world-size UVs (`Mesh.with_world_size_uvs`:
        one tile every `tile_size` units along the surface), and those UVs: made once per
        tile size, so the bake, its estimate and the previews share one handle."""
        found = self.generated.get(tile_size)
        if found is None:
            mesh = self.handle.mesh.with_world_size_uvs(tile_size)
            found = self.generated[tile_size] = (native.get().Shell(mesh, self.base_offset, self.directors), mesh.uvs)
        return found


class NeedsConfirmation(Exception):
    """A result estimated above its item's `confirm_above` triangles (a bake, a
    Procedural Detail's finest level): the UI asks before making it. `making` names
    the work for the question ("bake", "subdivision")."""

    def __init__(self, label, estimate, limit, budget=0, making="bake"):
        over = f", {estimate / budget:.1f} times the Triangle Budget of {budget:,}" if budget and estimate > budget else ""
        super().__init__(f"'{label}' would make about {estimate:,} triangles (over {limit:,}{over}): click Regenerate to confirm")
        self.label, self.estimate, self.budget, self.making = label, estimate, budget, making


class StackError(ValueError):
    """A stack that cannot be evaluated as ordered (e.g. a texture without a shell)."""


def group_weights(source: MeshArrays, name, at):
    """Vertex group `name`'s weights at the vertices `at` (source indices: the walk
    never reaches a kind that reads groups once they are gone); None without a name."""
    if not name:
        return None
    weights = source.point_attributes.get(weight_attribute(name))
    if weights is None:
        raise KeyError(f"vertex group '{name}' was not read from the source")
    return np.ascontiguousarray(weights[at], dtype=np.float32)


class State:
    """What the items so far have made: the current mesh, the source vertex of each of
    its vertices (None once geometry comes from no single source vertex), the latest
    shell, notes for the user and the field shells' final checks."""

    def __init__(self, source: MeshArrays):
        self.source = source
        self.current = source
        self.origin = np.arange(source.vertex_count)
        self.shell = None
        self.made_by = ""  # the label of the kind that made geometry without provenance
        self.notes = []
        self.summaries = []
