"""Settings of each stack item kind as plain data, independent of Blender."""

from dataclasses import dataclass


@dataclass(frozen=True)
class OffsetShell:
    """Offset Shell (normal displacement): the baseline shell.

    thickness: a length, or a fraction of the bounding-box diagonal when `relative`;
    negative offsets inward. vertex_group scales it per vertex (0 = no offset).
    output: "outer" (offset surface), "solid" (closed with the base and rims) or
    "layers" (`layers` evenly spaced copies).
    """

    thickness: float = 0.05
    relative: bool = True
    vertex_group: str = ""
    output: str = "outer"
    layers: int = 4

    kind = "OFFSET_SHELL"
    label = "Offset Shell"


KINDS = {cls.kind: cls for cls in (OffsetShell,)}
