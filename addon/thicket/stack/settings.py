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


@dataclass(frozen=True)
class FieldShell:
    """Shell: directors integrated along the L_p-averaged distance field (chapter 4).

    Unlike the Offset Shell it does not fold over itself in concavities: where the
    surface is close to itself the thickness is reduced locally instead. side:
    "exterior", "interior" or "envelope" (both, half each). thickness as for
    OffsetShell but its magnitude only (the side gives the direction).
    """

    thickness: float = 0.05
    relative: bool = True
    vertex_group: str = ""
    output: str = "outer"
    layers: int = 4
    side: str = "exterior"

    kind = "SHELL"
    label = "Shell"


KINDS = {cls.kind: cls for cls in (OffsetShell, FieldShell)}
