"""PropertyGroups of the stack, stored on each object (saved in the .blend)."""

import bpy
from bpy.props import (
    BoolProperty,
    BoolVectorProperty,
    CollectionProperty,
    EnumProperty,
    FloatProperty,
    FloatVectorProperty,
    IntProperty,
    PointerProperty,
    StringProperty,
)

from ..pure import settings as S
from ..pure.arrays import SELECTED_FACES
from .versioning import saved_value

PATTERNS = [
    ("chain_mail", "Chain Mail", "Interlocking metal rings"),
    ("weave", "Woven Fabric", "Warp and weft threads over and under each other"),
    ("rivets", "Rivets", "A plate with domed rivet heads"),
    ("grass", "Grass", "Bending blades that grow with time"),
    ("fur", "Fur", "Thin curling strands"),
    ("bubbles", "Bubbles", "Bubbles rising from a film and bursting (animated)"),
]

DETAIL_MODELS = [
    ("ROCK", "Rock", "A random value per control point at every level, halving per level: a 1/f fractal surface"),
    ("BERRY", "Berry", "Domes around seed points, with smaller clusters of domes at every finer level"),
    ("TENTACLE", "Tentacle", "Seeds pulled out further at each level, turning as they grow"),
    ("SPUR", "Spur", "Seeds pulled straight out along the normal, further at each level"),
    ("MUSHROOM", "Mushroom Cloud", "Around each seed a rising vortex ring lifts a stem and rolls a cap"),
    ("FUSE", "Fuse", "A surface of revolution about an axis, the fuse profile sin(sum 2^-i sin(t^(2^i))) one term per level"),
]


def _is_field_tree(self, tree):
    from ..pure.field_nodes import TREE_IDNAME

    return tree.bl_idname == TREE_IDNAME


def _is_mesh(self, obj):
    return obj.type == "MESH" and obj != self.id_data


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
            ("LAYERS", "Stacked Surfaces", "Evenly spaced surfaces from the base to the offset surface (as many as Surfaces)"),
        ],
        default="OUTER",
        update=_changed,
    )
    surfaces: IntProperty(
        name="Surfaces",
        description="How many evenly spaced surfaces Stacked Surfaces makes; the last one is the offset surface",
        min=1,
        max=256,
        soft_max=32,
        default=S.OffsetShell.surfaces,
        update=_changed,
    )
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

    # Volumetric Texture
    pattern: EnumProperty(
        name="Pattern",
        items=PATTERNS,
        default="chain_mail",
        update=_changed,
    )
    combine: EnumProperty(
        name="Combine With",
        description="A second pattern united with the first (chapter 7.3)",
        items=[("NONE", "Nothing", "")] + PATTERNS,
        default="NONE",
        update=_changed,
    )
    offset: FloatVectorProperty(name="Offset", description="Shift of the combined pattern in texture space (s, t)", size=2, default=(0.0, 0.0), update=_changed)
    seed: IntProperty(name="Seed", min=0, default=0, update=_changed)
    feature_thickness: FloatProperty(
        name="Feature Thickness", description="Scales rings, threads, blades and bubbles", min=0.1, max=4.0, default=1.0, update=_changed
    )
    texture_size: IntProperty(
        name="Texture Size", description="Texels along s and t (half as many across the shell)", min=8, max=256, default=64, update=_changed
    )
    tiling: FloatProperty(
        name="Tiling", description="Texture tiles per UV unit (per face, or per Tile Size, without UVs)", min=0.01, soft_max=64.0, default=1.0, update=_changed
    )
    no_uv_tiles: EnumProperty(
        name="Without UV Map",
        description="Where the texture's tiles go on a mesh without a UV map",
        items=[
            ("FACE", "One Tile per Face", "Each face is one whole tile: the pattern's size follows the faces (dense meshes make very many tiles)"),
            ("WORLD", "World-Size Tiles", "Generated coordinates: the surface cut into charts laid flat, one tile every Tile Size along the surface"),
        ],
        default="FACE",
        update=_changed,
    )
    tile_size: FloatProperty(
        name="Tile Size",
        description="Length of one texture tile along the surface with World-Size Tiles, in the object's own units like Thickness (the object's scale is not applied; 0: automatic, 1/32 of the base's bounding-box diagonal)",
        min=0.0,
        default=0.0,
        subtype="DISTANCE",
        precision=4,
        update=_changed,
    )
    resolution: IntProperty(name="Resolution", description="Samples along each base edge of a cell", min=1, max=64, default=8, update=_changed)
    depth_steps: IntProperty(
        name="Depth Steps",
        description="Bake samples across the shell, from the base to the outer surface",
        min=2,
        max=256,
        default=S.VolumetricTexture.depth_steps,
        update=_changed,
    )
    time: FloatProperty(name="Time", description="Time of animated patterns", default=1.0, update=_changed)
    follow_frame: BoolProperty(name="Follow Frame", description="Time follows the scene frame (seconds times Speed)", default=False, update=_changed)
    speed: FloatProperty(name="Speed", description="Texture time per second of scene time", default=1.0, update=_changed)
    source: EnumProperty(
        name="Source",
        items=[
            ("PATTERN", "Pattern", "A procedural pattern from Thicket's library"),
            ("FILE", "File", "A texture file: a folder of PNG slices (base first) or an OpenEXR volume"),
            ("FIELD_NODES", "Field Nodes", "A Thicket field node tree, authored in the unit texture cell (x, y, z = s, t, depth)"),
            ("FIELD_JSON", "Field JSON", "A field tree's JSON (Field Tree, or its Text), authored in the unit texture cell (x, y, z = s, t, depth)"),
        ],
        default="PATTERN",
        update=_changed,
    )
    filepath: StringProperty(name="Texture File", description="A PNG slice (its folder is the stack) or an .exr volume", subtype="FILE_PATH", update=_changed)
    field_nodes: PointerProperty(
        name="Field Nodes",
        description="A Thicket field node tree filling the texture's unit cell (x, y, z = s, t, depth from the base)",
        type=bpy.types.NodeTree,
        poll=_is_field_tree,
        update=_changed,
    )
    hole_group: StringProperty(name="Holes", description="Vertex group where the texture is cut away (by weight)", update=_changed)
    cutter: PointerProperty(
        name="Cutter", description="A closed mesh object: the texture is cut away inside it", type=bpy.types.Object, poll=_is_mesh, update=_changed
    )
    move_group: StringProperty(
        name="Move Region", description="Vertex group of the piece of texture to move along the surface (needs a UV map)", update=_changed
    )
    move_offset: FloatVectorProperty(
        name="Move By",
        description="How far the piece moves, in UV units; its trace shows the base surface",
        size=2,
        default=(0.0, 0.0),
        step=1,
        update=_changed,
    )
    face_selection: EnumProperty(
        name="Selected Faces",
        description="Use the source's selected faces (instead of a vertex group) for",
        items=[
            ("NONE", "Not Used", "Vertex groups only"),
            ("REGION", "Region", "The texture exists on the selected faces"),
            ("HOLES", "Holes", "The texture is cut away on the selected faces"),
            ("MOVE", "Move Region", "The texture on the selected faces moves"),
        ],
        default="NONE",
        update=_changed,
    )
    follow_texture: BoolProperty(
        name="Follow Texture",
        description="Sample the bake at the texture's own texel spacing (at least Resolution and Depth Steps), so thin strands and wires survive; off: exactly Resolution and Depth Steps (quick, coarse)",
        default=True,
        update=_changed,
    )
    triangle_budget: IntProperty(
        name="Triangle Budget",
        description="Simplify the bake toward this many triangles, never moving its surface by more than a quarter of a sample step (0: keep every triangle)",
        min=0,
        default=1_000_000,
        update=_changed,
    )
    confirm_above: IntProperty(
        name="Ask Above",
        description="In the interface, ask before baking (or subdividing into) more than this many (estimated) triangles",
        min=1000,
        default=3_000_000,
        update=_changed,
    )
    max_triangles: IntProperty(
        name="Sample Limit",
        description="The most triangles the bake may sample before simplifying: a finer lattice is coarsened to fit, and bakes over it even at Resolution are refused",
        min=1000,
        default=20_000_000,
        update=_changed,
    )

    # Solid Texture
    tree: StringProperty(
        name="Field Tree", description="The field tree's JSON (see the README's Implicit shapes); a Text, when set, is used instead", update=_changed
    )
    tree_text: PointerProperty(name="Tree Text", description="A Text datablock holding the field tree's JSON", type=bpy.types.Text, update=_changed)
    mode: EnumProperty(
        name="Mode",
        items=[
            ("COLOR", "Color", "Write the tree's colour into a colour attribute"),
            ("DISPLACE", "Displace", "Move vertices along their normals by Amplitude times the tree's texture value"),
        ],
        default="COLOR",
        update=_changed,
    )
    domain: EnumProperty(
        name="Domain",
        items=[("POINT", "Vertex", "One colour per vertex"), ("CORNER", "Face Corner", "One colour per face corner")],
        default="POINT",
        update=_changed,
    )
    amplitude: FloatProperty(
        name="Amplitude", description="Displacement at texture value 1", default=0.1, soft_min=-1.0, soft_max=1.0, step=1, precision=4, update=_changed
    )
    color_attribute: StringProperty(name="Attribute", description="The colour attribute written", default="thicket_color", update=_changed)

    # Procedural Detail
    detail_model: EnumProperty(name="Model", items=DETAIL_MODELS, default="ROCK", update=_changed)
    levels: IntProperty(
        name="Levels",
        description="Catmull-Clark levels, each with its own detail (each level has four times the faces of the last)",
        min=1,
        max=6,
        default=S.ProceduralDetail.levels,
        update=_changed,
    )
    detail_amplitude: FloatProperty(
        name="Amplitude",
        description="The rock's largest displacement at the first level (halved at each finer level), or the fuse's, as a fraction of the bounding-box diagonal",
        default=S.ProceduralDetail.amplitude,
        soft_min=-0.2,
        soft_max=0.2,
        step=0.1,
        precision=4,
        update=_changed,
    )
    detail_radius: FloatProperty(
        name="Radius",
        description="The berry's dome radius at the first level (halved at each finer level), or the mushroom cloud's vortex ring's, as a fraction of the bounding-box diagonal",
        default=S.ProceduralDetail.radius,
        min=0.001,
        soft_max=0.5,
        step=0.1,
        precision=4,
        update=_changed,
    )
    detail_length: FloatProperty(
        name="Length",
        description="The pull at level 1 (tentacle, spur; times the level at finer ones) or the flow per level (mushroom cloud), a fraction of the bounding-box diagonal",
        default=S.ProceduralDetail.length,
        soft_min=-0.1,
        soft_max=0.1,
        step=0.1,
        precision=4,
        update=_changed,
    )
    detail_theta: FloatProperty(name="Turn", description="The tentacle's rotation angle (animatable)", default=0.0, subtype="ANGLE", update=_changed)
    detail_spin: FloatProperty(
        name="Spin",
        description="With Animate With Frame: the tentacle's turn per unit of time (radians per second times Speed)",
        default=S.ProceduralDetail.spin,
        subtype="ANGLE",
        update=_changed,
    )
    detail_grow: FloatProperty(
        name="Grow Time",
        description="With Animate With Frame: the time the detail takes to grow from nothing to its full size (0: full size at once; the berry does not grow)",
        default=S.ProceduralDetail.grow,
        min=0.0,
        soft_max=20.0,
        update=_changed,
    )
    detail_spacing: FloatProperty(
        name="Spacing",
        description="Random seeds' spacing, a fraction of the bounding-box diagonal",
        default=S.ProceduralDetail.spacing,
        min=0.001,
        soft_max=1.0,
        precision=3,
        update=_changed,
    )
    fuse_span: FloatProperty(
        name="Span",
        description="The fuse profile's argument at the vertex farthest along the axis (more: more waves)",
        default=1.5,
        min=0.01,
        max=4.0,
        update=_changed,
    )
    fuse_axis: FloatVectorProperty(
        name="Axis", description="The fuse's axis of revolution (through the bounding-box centre)", size=3, default=(0.0, 0.0, 1.0), update=_changed
    )
    detail_children: IntProperty(
        name="Children", description="Seeds each dome's seed grows at the next level", min=0, max=64, default=S.ProceduralDetail.children, update=_changed
    )
    detail_seeds: EnumProperty(
        name="Seeds",
        description="Where the berries, tentacles, spurs or mushroom clouds grow",
        items=[
            ("RANDOM", "Random", "Poisson-disk points (two radii or Spacing apart), from Seed"),
            ("GROUP", "Vertex Group", "The vertices of the vertex group with weight 0.5 or more"),
            ("SELECTED", "Selected Vertices", "The source's selected vertices"),
        ],
        default="RANDOM",
        update=_changed,
    )

    detail_at: BoolVectorProperty(
        name="Detail At Levels",
        description="The levels the model adds detail at (5: features at one level or several)",
        size=6,
        default=(True,) * 6,
        update=_changed,
    )
    blend_model: EnumProperty(
        name="Blend With",
        description="A second model blended in level by level (Burt-Adelson): its detail where the alpha is 1",
        items=[("NONE", "Nothing", "No blend")] + DETAIL_MODELS,
        default="NONE",
        update=_changed,
    )
    blend_seed: IntProperty(name="Blend Seed", description="The second model's random values", min=0, default=1, update=_changed)
    blend_gain: FloatProperty(
        name="Blend Gain",
        description="The second model's lengths (amplitude, radius) as a multiple of the first's",
        default=1.0,
        soft_min=0.0,
        soft_max=4.0,
        update=_changed,
    )
    blend_alpha: EnumProperty(
        name="Alpha",
        items=[
            ("PLANE", "Plane", "The second model beyond a plane (through Point, facing Direction, in the object's space)"),
            ("GROUP", "Vertex Group", "The second model where the vertex group's weight is 1"),
        ],
        default="PLANE",
        update=_changed,
    )
    blend_point: FloatVectorProperty(
        name="Point", description="A point of the blend plane, in the object's space", size=3, default=(0.0, 0.0, 0.0), subtype="TRANSLATION", update=_changed
    )
    blend_direction: FloatVectorProperty(
        name="Direction", description="The blend plane's normal: the second model lies on its side", size=3, default=(1.0, 2.0, 0.0), update=_changed
    )
    blend_width: FloatProperty(
        name="Transition",
        description="The transition's width at the first level, halving at each finer one: a fraction of the bounding-box diagonal (plane) or of the weights (group)",
        default=0.2,
        min=0.0,
        soft_max=1.0,
        update=_changed,
    )
    blend_sweep: FloatProperty(
        name="Sweep",
        description="With Animate With Frame: how far the second model's side grows per unit of time (a fraction of the bounding-box diagonal for a plane, of the weights for a group)",
        default=S.ProceduralDetail.blend_sweep,
        soft_min=-1.0,
        soft_max=1.0,
        step=0.1,
        precision=3,
        update=_changed,
    )
    blend_group: StringProperty(name="Blend Group", description="Vertex group whose weight is the blend's alpha", update=_changed)
    local_object: PointerProperty(
        name="Local Center",
        description="An object (an Empty) whose location centres a local modification of the detail (section 5); none: no modification",
        type=bpy.types.Object,
        update=_changed,
    )
    local_radius: FloatProperty(
        name="Local Radius", description="The modification's reach, in edges of the base mesh", default=2.0, min=0.01, soft_max=20.0, update=_changed
    )
    local_gain: FloatProperty(
        name="Local Gain",
        description="The detail's factor at the center (0 removes it, 2 doubles it), easing to 1 at the radius",
        default=0.0,
        soft_min=0.0,
        soft_max=4.0,
        update=_changed,
    )
    local_at: BoolVectorProperty(name="Local At Levels", description="The levels the modification acts at", size=6, default=(True,) * 6, update=_changed)
    use_sculpt: BoolProperty(
        name="Use Sculpt",
        description=(
            "Start from the source's Multires sculpt: its base mesh with the sculpt's details at their levels, the procedural detail"
            " added on top (the sculpt follows it); Levels must reach the sculpt's. Only for the first item; the source's other"
            " modifiers are not applied"
        ),
        default=False,
        update=_changed,
    )
    detail_shader: EnumProperty(
        name="Shader",
        items=[("NONE", "None", "No colours"), ("PLANET", "Planet", "Oceans, lowlands, mountains and snow caps from the detail's height and the blend (6.2)")],
        default="NONE",
        update=_changed,
    )
    shader_sea: FloatProperty(
        name="Sea Level", description="Height of the sea, a fraction of the bounding-box diagonal", default=0.0, step=0.1, precision=4, update=_changed
    )
    shader_snow: FloatProperty(
        name="Snow Line", description="Height of the snow line, a fraction of the bounding-box diagonal", default=0.025, step=0.1, precision=4, update=_changed
    )

    shader_sea_rate: FloatProperty(
        name="Sea Rise",
        description="With Animate With Frame: how fast the sea level rises per unit of time (negative: falls), a fraction of the bounding-box diagonal; once the sea reaches the snow line the frame is refused with a message",
        default=S.ProceduralDetail.sea_rate,
        step=0.01,
        precision=4,
        update=_changed,
    )
    shader_snow_rate: FloatProperty(
        name="Snow Rise",
        description="With Animate With Frame: how fast the snow line rises per unit of time (negative: the caps grow), a fraction of the bounding-box diagonal; once it reaches the sea the frame is refused with a message",
        default=S.ProceduralDetail.snow_rate,
        step=0.01,
        precision=4,
        update=_changed,
    )

    def tree_json(self):
        """The Solid Texture's tree: its Text's content when set, else its JSON text."""
        return self.tree_text.as_string() if self.tree_text is not None else self.tree

    def texture_field_tree(self):
        """The Volumetric Texture's field tree JSON for the Field sources ("" for the
        others); a missing node tree or empty JSON is refused naming the item."""
        from ..pure.field_tree import invalid

        if self.source == "FIELD_NODES":
            if self.field_nodes is None:
                raise invalid(f"'{self.name}' has no field node tree: pick a Thicket field node tree as its source")
            from ..nodes.graph import tree_json

            return tree_json(self.field_nodes)
        if self.source == "FIELD_JSON":
            text = self.tree_json()
            if not text.strip():
                raise invalid(f"'{self.name}' has no field tree: give it the tree's JSON or a Text holding it")
            return text
        return ""

    def texture_time(self, scene=None):
        """The time the pattern is baked at: the scene's (seconds x speed) when following frames."""
        scene = scene or bpy.context.scene
        if self.follow_frame and scene is not None:
            return scene.frame_current / (scene.render.fps / scene.render.fps_base) * self.speed
        return self.time

    def to_settings(self, depsgraph=None):
        """The plain-data settings `pure.evaluate` runs on (a cutter's mesh is read
        from `depsgraph`, in the source's object space)."""
        if self.kind == S.VolumetricTexture.kind:
            return S.VolumetricTexture(
                pattern=self.pattern,
                seed=self.seed,
                time=self.texture_time(),
                feature_thickness=self.feature_thickness,
                texture_size=self.texture_size,
                tiling=self.tiling,
                no_uv_tiles=self.no_uv_tiles.lower(),
                tile_size=self.tile_size,
                resolution=self.resolution,
                depth_steps=saved_value(self, "depth_steps"),
                vertex_group=SELECTED_FACES if self.face_selection == "REGION" else self.vertex_group,
                combine="" if self.combine == "NONE" else self.combine,
                offset=tuple(self.offset),
                follow_texture=self.follow_texture,
                triangle_budget=self.triangle_budget,
                max_triangles=self.max_triangles,
                confirm_above=self.confirm_above,
                filepath=bpy.path.abspath(self.filepath) if self.source == "FILE" else "",
                field_tree=self.texture_field_tree(),
                hole_group=SELECTED_FACES if self.face_selection == "HOLES" else self.hole_group,
                move_group=SELECTED_FACES if self.face_selection == "MOVE" else self.move_group,
                move_offset=tuple(self.move_offset),
                cutter=self._cutter_arrays(depsgraph),
            )
        if self.kind == S.ProceduralDetail.kind:
            return S.ProceduralDetail(
                model=self.detail_model.lower(),
                levels=self.levels,
                seed=self.seed,
                amplitude=self.detail_amplitude,
                radius=self.detail_radius,
                children=self.detail_children,
                length=self.detail_length,
                theta=self.detail_theta,
                spacing=self.detail_spacing,
                span=self.fuse_span,
                axis=tuple(self.fuse_axis),
                time=self.texture_time() if self.follows_frame() else 0.0,
                spin=self.detail_spin,
                # Not following the frame, the time is 0: the detail is shown full grown.
                grow=self.detail_grow if self.follows_frame() else 0.0,
                seeds=self.detail_seeds.lower(),
                vertex_group=self.vertex_group,
                confirm_above=self.confirm_above,
                at=_chosen_levels(self.detail_at),
                blend_model="" if self.blend_model == "NONE" else self.blend_model.lower(),
                blend_seed=self.blend_seed,
                blend_gain=self.blend_gain,
                blend_alpha=self.blend_alpha.lower(),
                blend_point=tuple(self.blend_point),
                blend_direction=tuple(self.blend_direction),
                blend_width=self.blend_width,
                blend_sweep=self.blend_sweep,
                blend_group=self.blend_group,
                local_center=self._local_center(),
                local_radius=self.local_radius,
                local_gain=self.local_gain,
                local_at=_chosen_levels(self.local_at),
                shader="" if self.detail_shader == "NONE" else self.detail_shader.lower(),
                sea=self.shader_sea,
                snow=self.shader_snow,
                sea_rate=self.shader_sea_rate,
                snow_rate=self.shader_snow_rate,
                use_sculpt=self.use_sculpt,
            )
        if self.kind == S.SolidTexture.kind:
            return S.SolidTexture(
                tree=self.tree_json(), mode=self.mode.lower(), domain=self.domain.lower(), amplitude=self.amplitude, attribute=self.color_attribute
            )
        return S.shell_settings(self.kind, self.thickness, self.thickness_mode, self.vertex_group, self.output, saved_value(self, "surfaces"), self.side)

    def _local_center(self):
        """The local modification's center in the source's object space, or None."""
        if self.local_object is None:
            return None
        return tuple(self.id_data.matrix_world.inverted_safe() @ self.local_object.matrix_world.translation)

    def follows_frame(self):
        """Whether the scene frame changes this item's result (a texture's time; a
        procedural detail's models, blend or shader that time moves)."""
        if self.kind == "PROCEDURAL_DETAIL":
            return self.follow_frame and self._detail_animates()
        return self.follow_frame and self.kind == "VOLUMETRIC_TEXTURE"

    def _detail_animates(self):
        """Whether time moves this Procedural Detail (section 3: the models, the alpha,
        the shader), so following the frame is worth a regeneration per frame."""
        models = [m for m in (self.detail_model, self.blend_model) if m != "NONE"]
        spins = "TENTACLE" in models and self.detail_spin != 0.0
        grows = self.detail_grow > 0.0 and any(m != "BERRY" for m in models)
        sweeps = self.blend_model != "NONE" and self.blend_sweep != 0.0
        tides = self.detail_shader == "PLANET" and (self.shader_sea_rate != 0.0 or self.shader_snow_rate != 0.0)
        return spins or grows or sweeps or tides

    def watched_objects(self):
        """Other objects whose change changes this item's result: a cutter, a local center."""
        if self.kind == "PROCEDURAL_DETAIL" and self.local_object is not None:
            # The center is read in the source's space: moving either moves it.
            return [self.local_object, self.id_data]
        found = self.cutter if self.kind == "VOLUMETRIC_TEXTURE" else None
        # The cutter is read in the source's space too: moving either moves the cut.
        return [found, self.id_data] if found is not None and found != self.id_data else []

    def _cutter_arrays(self, depsgraph):
        if self.cutter is None:
            return None
        from ..mesh_io import read_solid

        return read_solid(self.cutter, self.id_data, depsgraph or bpy.context.evaluated_depsgraph_get())


def _chosen_levels(flags):
    """The levels (1-based) whose flag is on; None when all are (every level)."""
    return None if all(flags) else tuple(i + 1 for i, on in enumerate(flags) if on)


class ThicketStack(bpy.types.PropertyGroup):
    items: CollectionProperty(type=ThicketItem)
    active_index: IntProperty(name="Active Item", min=0)
    result: PointerProperty(type=bpy.types.Object, name="Result", description="Generated geometry of this stack")
    source: PointerProperty(type=bpy.types.Object, name="Source", description="Set on a result object: the object it was generated from")
    auto_update: BoolProperty(name="Auto Update", description="Regenerate when the source or a setting changes", default=True)
    last_error: StringProperty(name="Last Error", description="Why the last regeneration failed (empty when it worked)")
    last_note: StringProperty(name="Note", description="What the user should know about the last result")
    last_report: StringProperty(name="Shell Report", description="Per field shell: thickness kept and what the final check found")
    source_crossings: IntProperty(name="Crossing Faces", description="Faces of the source that cross another part of the source", min=0)

    @property
    def has_stack(self):
        return len(self.items) > 0


CLASSES = (ThicketItem, ThicketStack)


def register_properties():
    bpy.types.Object.thicket = PointerProperty(type=ThicketStack)


def unregister_properties():
    del bpy.types.Object.thicket
