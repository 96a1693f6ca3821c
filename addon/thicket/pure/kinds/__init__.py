"""Stack item kinds: what each consumes and produces, its step, and how a renderer
draws it if one does. The walk
(`pure.evaluate`) reads only these declarations, so a new kind is one module here
with its step, and one line in `KINDS`; Blender also needs its settings in
`settings.KINDS`, the item PropertyGroup and its panel."""

from typing import NamedTuple

from .. import settings as S
from .procedural_detail import procedural_detail_step
from .shell import field_shell, offset_shell, shell_step
from .solid_texture import solid_texture_step
from .volumetric_texture import texture_draw_setup, texture_step


class Kind(NamedTuple):
    """How a stack item kind evaluates. `consumes`: "mesh" (the current mesh, whose
    vertices must come from the source's, so vertex groups follow them), "shell"
    (the latest shell) or "any" (the current mesh, wherever it came from); `produces`: "shell" (a shell and its mesh), "mesh" (a mesh whose vertices are
    traced to the source's) or "geometry" (new geometry, from no single source
    vertex: vertex groups end there). `weight`: its share of the progress bar relative to the others
    (not from the papers: a bake usually takes longest, an offset shell is
    instantaneous). `step(state, item, ask, progress)` updates the state.

    `draw_setup(state, item)`: for a kind the renderers draw from the state before it
    instead of running its step (a Volumetric Texture, a Solid Texture), what they
    draw: an object whose `handle()` is the native handle that renders frames
    (`render(view, projection, width, height, progress=..., **frame settings)`, as
    `thicket_native.TexturedShell.render`). None for kinds that are only evaluated."""

    consumes: str
    produces: str
    weight: float
    step: object
    draw_setup: object = None

    @property
    def drawn(self) -> bool:
        """Whether a renderer draws this kind directly (`draw_setup`)."""
        return self.draw_setup is not None


#: Every item kind by its settings class. For the evaluator a new kind is its settings,
#: its step and one line here; Blender also needs it in `settings.KINDS`, the item
#: PropertyGroup and its panel.
KINDS = {
    S.OffsetShell: Kind("mesh", "shell", 0.1, shell_step(offset_shell)),
    S.FieldShell: Kind("mesh", "shell", 1.0, shell_step(field_shell)),
    S.VolumetricTexture: Kind("shell", "geometry", 3.0, texture_step, texture_draw_setup),
    S.SolidTexture: Kind("any", "mesh", 0.2, solid_texture_step),
    S.ProceduralDetail: Kind("mesh", "mesh", 1.0, procedural_detail_step),
}
