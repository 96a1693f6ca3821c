"""Stack item kinds: what each consumes and produces, and its step. The walk
(`pure.evaluate`) reads only these declarations, so a new kind is one module here
with its step, and one line in `KINDS`; Blender also needs its settings in
`settings.KINDS`, the item PropertyGroup and its panel."""

from typing import NamedTuple

from .. import settings as S
from .shell import field_shell, offset_shell, shell_step
from .volumetric_texture import texture_step


class Kind(NamedTuple):
    """How a stack item kind evaluates. `consumes`: "mesh" (the current mesh, whose
    vertices must come from the source's, so vertex groups follow them) or "shell"
    (the latest shell, which the renderers draw instead of running the step);
    `produces`: "shell" (a shell and its mesh), "mesh" (a mesh whose vertices are
    traced to the source's) or "geometry" (new geometry, from no single source
    vertex: vertex groups end there). `weight`: its share of the progress bar relative to the others
    (not from the papers: a bake usually takes longest, an offset shell is
    instantaneous). `step(state, item, ask, progress)` updates the state."""

    consumes: str
    produces: str
    weight: float
    step: object


#: Every item kind by its settings class. For the evaluator a new kind is its settings,
#: its step and one line here; Blender also needs it in `settings.KINDS`, the item
#: PropertyGroup and its panel.
KINDS = {
    S.OffsetShell: Kind("mesh", "shell", 0.1, shell_step(offset_shell)),
    S.FieldShell: Kind("mesh", "shell", 1.0, shell_step(field_shell)),
    S.VolumetricTexture: Kind("shell", "geometry", 3.0, texture_step),
}
