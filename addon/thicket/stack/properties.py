"""PropertyGroups of the stack, stored on each object (saved in the .blend)."""

import bpy
from bpy.props import BoolProperty, CollectionProperty, EnumProperty, FloatProperty, IntProperty, PointerProperty, StringProperty

from . import settings as S


def _changed(self, context):
    from . import auto_update

    auto_update.schedule(self.id_data)


class ThicketItem(bpy.types.PropertyGroup):
    """One item of the stack; the settings shown depend on `kind`."""

    kind: EnumProperty(
        name="Kind",
        items=[(k, cls.label, cls.__doc__.splitlines()[0]) for k, cls in S.KINDS.items()],
        update=_changed,
    )
    name: StringProperty(name="Name", default="Offset Shell")
    show_viewport: BoolProperty(name="Enabled", description="Use this item when generating the result", default=True, update=_changed)
    show_expanded: BoolProperty(name="Expanded", default=True)
    thickness: FloatProperty(
        name="Thickness",
        description="Offset distance (negative: inward). In Relative mode, a fraction of the bounding-box diagonal",
        default=S.OffsetShell.thickness,
        soft_min=-1.0,
        soft_max=1.0,
        precision=4,
        step=0.1,
        update=_changed,
    )
    thickness_mode: EnumProperty(
        name="Thickness Mode",
        items=[
            ("RELATIVE", "Relative", "Thickness is a fraction of the bounding-box diagonal"),
            ("ABSOLUTE", "Absolute", "Thickness is a length in object space"),
        ],
        default="RELATIVE",
        update=_changed,
    )
    vertex_group: StringProperty(name="Vertex Group", description="Scales the thickness per vertex by its weight", update=_changed)
    output: EnumProperty(
        name="Output",
        items=[
            ("OUTER", "Outer Surface", "The offset surface only"),
            ("SOLID", "Solid", "Offset surface closed with the base surface and rims"),
            ("LAYERS", "Layers", "Evenly spaced layers between base and offset surface"),
        ],
        default="OUTER",
        update=_changed,
    )
    layers: IntProperty(name="Layers", min=1, max=256, soft_max=32, default=S.OffsetShell.layers, update=_changed)
    side: EnumProperty(
        name="Side",
        items=[
            ("EXTERIOR", "Exterior", "The shell lies outside the surface"),
            ("INTERIOR", "Interior", "The shell lies inside the surface"),
            ("ENVELOPE", "Envelope", "The shell lies on both sides, half the thickness each"),
        ],
        default="EXTERIOR",
        update=_changed,
    )

    def to_settings(self):
        """The plain-data settings `stack.evaluate` runs on."""
        common = dict(
            thickness=self.thickness,
            relative=self.thickness_mode == "RELATIVE",
            vertex_group=self.vertex_group,
            output=self.output.lower(),
            layers=self.layers,
        )
        if self.kind == S.FieldShell.kind:
            return S.FieldShell(side=self.side.lower(), **common)
        return S.OffsetShell(**common)


class ThicketStack(bpy.types.PropertyGroup):
    items: CollectionProperty(type=ThicketItem)
    active_index: IntProperty(name="Active Item", min=0)
    result: PointerProperty(type=bpy.types.Object, name="Result", description="Generated geometry of this stack")
    source: PointerProperty(type=bpy.types.Object, name="Source", description="Set on a result object: the object it was generated from")
    auto_update: BoolProperty(name="Auto Update", description="Regenerate when the source or a setting changes", default=True)
    last_error: StringProperty(name="Last Error", description="Why the last regeneration failed (empty when it worked)")

    @property
    def has_stack(self):
        return len(self.items) > 0


CLASSES = (ThicketItem, ThicketStack)


def register_properties():
    bpy.types.Object.thicket = PointerProperty(type=ThicketStack)


def unregister_properties():
    del bpy.types.Object.thicket
