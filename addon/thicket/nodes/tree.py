"""The Thicket node editor's classes: the `ThicketFieldTree` node tree, its field
socket, the primitive / operation / texture nodes and the Output node. Every value
change and every link change asks the linked Field Mesh objects to regenerate
(`live.schedule_tree`, debounced)."""

import bpy
from bpy.props import BoolProperty, EnumProperty, FloatProperty, FloatVectorProperty, IntProperty, PointerProperty, StringProperty

from ..pure.field_nodes import TREE_IDNAME
from ..pure.field_tree import MAX_RESOLUTION, estimate_text

SOCKET_IDNAME = "ThicketFieldSocket"


def _changed(self, context):
    from . import live

    live.schedule_tree(self.id_data)


class ThicketFieldTree(bpy.types.NodeTree):
    """Implicit field trees (Akleman-Chen) meshed into Field Mesh objects"""

    bl_idname = TREE_IDNAME
    bl_label = "Thicket Field"
    bl_icon = "META_BALL"

    resolution: IntProperty(
        name="Resolution", description="Cells along the longest side of the tree's bounds", min=2, max=MAX_RESOLUTION, soft_max=512, default=64, update=_changed
    )
    adaptive: BoolProperty(
        name="Adaptive",
        description="Dual contouring on the cells that may hold the surface: quads, sharp creases and corners (off: marching prisms on the whole grid, triangles)",
        default=True,
        update=_changed,
    )
    auto_update: BoolProperty(name="Auto Update", description="Regenerate the Field Meshes when a node, a link or a handle changes", default=True)
    status: StringProperty(name="Status", description="The last regeneration's error, empty when it succeeded")

    def update(self):
        from . import live

        live.schedule_tree(self)


class ThicketFieldSocket(bpy.types.NodeSocket):
    """A field: value, gradient and colour at every point"""

    bl_idname = SOCKET_IDNAME
    bl_label = "Field"

    def draw(self, context, layout, node, text):
        layout.label(text=text)

    def draw_color(self, context, node):
        return (0.35, 0.75, 0.95, 1.0)


class ThicketFieldNode:
    """What every Thicket field node shares: the tree it lives in, a colour."""

    use_color: BoolProperty(
        name="Color", description="Give this node a colour (a primitive's diffuse colour; on an operation it replaces the blend)", update=_changed
    )
    color: FloatVectorProperty(name="Color", subtype="COLOR", size=4, min=0.0, max=1.0, default=(0.8, 0.8, 0.8, 1.0), update=_changed)

    @classmethod
    def poll(cls, ntree):
        return ntree.bl_idname == TREE_IDNAME

    def draw_color_option(self, layout):
        row = layout.row(align=True)
        row.prop(self, "use_color", text="")
        sub = row.row()
        sub.active = self.use_color
        sub.prop(self, "color", text="")


def _vector(name, default, size=3, **kw):
    return FloatVectorProperty(name=name, size=size, default=default, update=_changed, **kw)


def _float(name, default, **kw):
    return FloatProperty(name=name, default=default, update=_changed, **kw)


class _Primitive(ThicketFieldNode):
    handle: PointerProperty(
        name="Handle", type=bpy.types.Object, description="An object placing the skeleton (its world matrix); empty: the numbers below", update=_changed
    )
    radius: _float("Radius", 0.0, min=0.0)
    #: Properties drawn when no handle object is set.
    numeric = ()
    #: Properties drawn always.
    always = ("radius",)

    def init(self, context):
        self.outputs.new(SOCKET_IDNAME, "Field")

    def draw_buttons(self, context, layout):
        layout.prop(self, "handle")
        for name in self.extra_handles():
            layout.prop(self, name)
        if not self.uses_handles():
            for name in self.numeric:
                layout.prop(self, name)
        for name in self.always:
            layout.prop(self, name)
        self.draw_color_option(layout)

    def extra_handles(self):
        return ()

    def uses_handles(self):
        return self.handle is not None


class ThicketNodeSphere(_Primitive, bpy.types.Node):
    """Sphere: |x - center| - radius (the handle's location is the centre)"""

    bl_idname = "ThicketNodeSphere"
    bl_label = "Sphere"
    op = "sphere"
    center: _vector("Center", (0.0, 0.0, 0.0), subtype="TRANSLATION")
    radius: _float("Radius", 1.0, min=0.0)
    numeric = ("center",)


class ThicketNodePoint(_Primitive, bpy.types.Node):
    """Point skeleton: h over the world axes' planes through the centre, minus the radius"""

    bl_idname = "ThicketNodePoint"
    bl_label = "Point"
    op = "point"
    center: _vector("Center", (0.0, 0.0, 0.0), subtype="TRANSLATION")
    radius: _float("Radius", 0.5, min=0.0)
    numeric = ("center",)


class ThicketNodePlane(_Primitive, bpy.types.Node):
    """Plane: n . (x - point) (a handle gives the point and its local Z as the normal)"""

    bl_idname = "ThicketNodePlane"
    bl_label = "Plane"
    op = "plane"
    point: _vector("Point", (0.0, 0.0, 0.0), subtype="TRANSLATION")
    normal: _vector("Normal", (0.0, 0.0, 1.0), subtype="DIRECTION")
    numeric = ("point", "normal")
    always = ()


class ThicketNodeSegment(_Primitive, bpy.types.Node):
    """Segment skeleton from a to b (two handle objects, or a curve's first spline's ends)"""

    bl_idname = "ThicketNodeSegment"
    bl_label = "Segment"
    op = "segment"
    handle_b: PointerProperty(
        name="Handle B", type=bpy.types.Object, description="The object at the segment's end b (not needed when Handle is a curve)", update=_changed
    )
    a: _vector("A", (-1.0, 0.0, 0.0), subtype="TRANSLATION")
    b: _vector("B", (1.0, 0.0, 0.0), subtype="TRANSLATION")
    radius: _float("Radius", 0.3, min=0.0)
    numeric = ("a", "b")

    def extra_handles(self):
        return () if self.handle is not None and self.handle.type == "CURVE" else ("handle_b",)

    def uses_handles(self):
        return self.handle is not None or self.handle_b is not None


class ThicketNodeRectangle(_Primitive, bpy.types.Node):
    """Rectangle skeleton in the rotated x-y plane (a handle gives centre, rotation and, from its scale, half sizes)"""

    bl_idname = "ThicketNodeRectangle"
    bl_label = "Rectangle"
    op = "rectangle"
    center: _vector("Center", (0.0, 0.0, 0.0), subtype="TRANSLATION")
    half_size: _vector("Half Size", (1.0, 0.5), size=2, min=0.0)
    radius: _float("Radius", 0.1, min=0.0)
    numeric = ("center", "half_size")


class ThicketNodeBox(_Primitive, bpy.types.Node):
    """Box skeleton (a handle empty gives centre, rotation and, from its scale times its display size, half sizes)"""

    bl_idname = "ThicketNodeBox"
    bl_label = "Box"
    op = "box"
    center: _vector("Center", (0.0, 0.0, 0.0), subtype="TRANSLATION")
    half_size: _vector("Half Size", (0.5, 0.5, 0.5), min=0.0)
    numeric = ("center", "half_size")


class ThicketNodeTorus(_Primitive, bpy.types.Node):
    """Toroid around an axis (a handle gives the centre and its local Z as the axis)"""

    bl_idname = "ThicketNodeTorus"
    bl_label = "Torus"
    op = "torus"
    center: _vector("Center", (0.0, 0.0, 0.0), subtype="TRANSLATION")
    axis: _vector("Axis", (0.0, 0.0, 1.0), subtype="DIRECTION")
    major: _float("Major Radius", 1.0, min=0.0)
    minor: _float("Minor Radius", 0.25, min=0.0)
    numeric = ("center", "axis")
    always = ("major", "minor")


OPERATIONS = (
    ("union_wp", "Union (w_p)", "-w_p(-f1, ..., -fn): soft union"),
    ("intersection_wp", "Intersection (w_p)", "w_p(f1, ..., fn): soft intersection"),
    ("difference_wp", "Difference (w_p)", "w_p(A, -B): soft difference"),
    ("min", "Min", "Exact union"),
    ("max", "Max", "Exact intersection"),
    ("h", "h", "The h operation (section 3): |(f1+, ..., fn+)|"),
)


def _operation_changed(self, context):
    self.update_sockets()
    _changed(self, context)


class ThicketNodeOperation(ThicketFieldNode, bpy.types.Node):
    """Set operations and h over the linked fields"""

    bl_idname = "ThicketNodeOperation"
    bl_label = "Operation"
    operation: EnumProperty(name="Operation", items=OPERATIONS, default="union_wp", update=_operation_changed)
    p: _float("p", 8.0, soft_min=0.1, soft_max=100.0, description="Sharpness of the w_p operations (> 0; large: near min / max)")
    inputs_count: IntProperty(name="Inputs", min=2, max=16, default=2, update=_operation_changed)

    def init(self, context):
        self.outputs.new(SOCKET_IDNAME, "Field")
        self.update_sockets()

    def update_sockets(self):
        count = 2 if self.operation == "difference_wp" else self.inputs_count
        names = ["A", "B"] if self.operation == "difference_wp" else [f"Field {i + 1}" for i in range(count)]
        while len(self.inputs) > count:
            self.inputs.remove(self.inputs[-1])
        while len(self.inputs) < count:
            self.inputs.new(SOCKET_IDNAME, names[len(self.inputs)])
        for socket, name in zip(self.inputs, names, strict=True):
            socket.name = name

    def draw_buttons(self, context, layout):
        layout.prop(self, "operation", text="")
        if self.operation.endswith("_wp"):
            layout.prop(self, "p")
        if self.operation != "difference_wp":
            layout.prop(self, "inputs_count")
        self.draw_color_option(layout)


class ThicketNodeOffset(ThicketFieldNode, bpy.types.Node):
    """f - amount: grows the solid by amount"""

    bl_idname = "ThicketNodeOffset"
    bl_label = "Offset"
    amount: _float("Amount", 0.1)

    def init(self, context):
        self.inputs.new(SOCKET_IDNAME, "Field")
        self.outputs.new(SOCKET_IDNAME, "Field")

    def draw_buttons(self, context, layout):
        layout.prop(self, "amount")
        self.draw_color_option(layout)


class ThicketNodeNegate(ThicketFieldNode, bpy.types.Node):
    """-f: the complement"""

    bl_idname = "ThicketNodeNegate"
    bl_label = "Negate"

    def init(self, context):
        self.inputs.new(SOCKET_IDNAME, "Field")
        self.outputs.new(SOCKET_IDNAME, "Field")

    def draw_buttons(self, context, layout):
        self.draw_color_option(layout)


class _Textured(ThicketFieldNode):
    tau: _float("Phase", 0.0, description="tau, the texture function's phase (animatable)")
    use_ramp: BoolProperty(name="Ramp", description="Colour from a two-stop ramp at the texture value", update=_changed)
    ramp_low: FloatVectorProperty(name="Low", subtype="COLOR", size=4, min=0.0, max=1.0, default=(0.1, 0.1, 0.1, 1.0), update=_changed)
    ramp_high: FloatVectorProperty(name="High", subtype="COLOR", size=4, min=0.0, max=1.0, default=(0.9, 0.9, 0.9, 1.0), update=_changed)

    def init(self, context):
        self.inputs.new(SOCKET_IDNAME, "Shape")
        self.inputs.new(SOCKET_IDNAME, "Texture")
        self.outputs.new(SOCKET_IDNAME, "Field")

    def draw_ramp(self, layout):
        layout.prop(self, "tau")
        layout.prop(self, "use_ramp")
        if self.use_ramp:
            row = layout.row(align=True)
            row.prop(self, "ramp_low", text="")
            row.prop(self, "ramp_high", text="")
        self.draw_color_option(layout)


class ThicketNodeDisplace(_Textured, bpy.types.Node):
    """Shape + amplitude (cos(omega texture + tau) + 1) (equation 1)"""

    bl_idname = "ThicketNodeDisplace"
    bl_label = "Displace"
    amplitude: _float("Amplitude", 0.05)
    omega: _float("Omega", 10.0, min=1e-6)

    def draw_buttons(self, context, layout):
        layout.prop(self, "amplitude")
        layout.prop(self, "omega")
        self.draw_ramp(layout)


class ThicketNodeFractal(_Textured, bpy.types.Node):
    """Shape + sum of a_j (cos(omega_j texture + tau) + 1) (equation 2), a_j = amplitude gain^j, omega_j = omega lacunarity^j"""

    bl_idname = "ThicketNodeFractal"
    bl_label = "Fractal"
    octaves: IntProperty(name="Octaves", min=1, max=12, default=3, update=_changed)
    amplitude: _float("Amplitude", 0.05)
    omega: _float("Omega", 10.0, min=1e-6)
    gain: _float("Gain", 0.5)
    lacunarity: _float("Lacunarity", 2.0, min=1e-6)

    def draw_buttons(self, context, layout):
        for name in ("octaves", "amplitude", "omega", "gain", "lacunarity"):
            layout.prop(self, name)
        self.draw_ramp(layout)


class ThicketNodeOutput(ThicketFieldNode, bpy.types.Node):
    """The field the tree's Field Meshes show"""

    bl_idname = "ThicketNodeOutput"
    bl_label = "Field Output"

    def init(self, context):
        self.inputs.new(SOCKET_IDNAME, "Field")

    def draw_buttons(self, context, layout):
        pass


NODE_CLASSES = (
    ThicketNodeSphere,
    ThicketNodePoint,
    ThicketNodePlane,
    ThicketNodeSegment,
    ThicketNodeRectangle,
    ThicketNodeBox,
    ThicketNodeTorus,
    ThicketNodeOperation,
    ThicketNodeOffset,
    ThicketNodeNegate,
    ThicketNodeDisplace,
    ThicketNodeFractal,
    ThicketNodeOutput,
)


class THICKET_MT_field_nodes_add(bpy.types.Menu):
    bl_idname = "THICKET_MT_field_nodes_add"
    bl_label = "Thicket Field"

    def draw(self, context):
        for cls in NODE_CLASSES:
            op = self.layout.operator("node.add_node", text=cls.bl_label)
            op.type = cls.bl_idname
            op.use_transform = True


def draw_add_menu(self, context):
    """Node editor's Add menu: the Thicket nodes, in a Thicket field tree."""
    space = context.space_data
    if space is not None and getattr(space, "tree_type", "") == TREE_IDNAME:
        self.layout.menu(THICKET_MT_field_nodes_add.bl_idname)


class THICKET_PT_field_nodes(bpy.types.Panel):
    bl_space_type = "NODE_EDITOR"
    bl_region_type = "UI"
    bl_category = "Thicket"
    bl_label = "Field Mesh"

    @classmethod
    def poll(cls, context):
        tree = getattr(context.space_data, "edit_tree", None)
        return tree is not None and tree.bl_idname == TREE_IDNAME

    def draw(self, context):
        tree = context.space_data.edit_tree
        layout = self.layout
        layout.prop(tree, "resolution")
        layout.prop(tree, "adaptive")
        layout.prop(tree, "auto_update")
        from . import live

        estimate = live.tree_estimate(tree)
        if estimate is not None:
            text = estimate_text(estimate)
            layout.label(text=text[:1].upper() + text[1:], icon="INFO" if estimate["fits"] else "ERROR")
        layout.operator("thicket.field_nodes_add", text="Add Field Mesh", icon="META_BALL")
        layout.operator("thicket.field_mesh_regenerate", text="Regenerate", icon="FILE_REFRESH")
        if tree.status:
            layout.label(text=tree.status, icon="INFO" if tree.status.startswith(live.NOT_LIVE) else "ERROR")


CLASSES = (ThicketFieldTree, ThicketFieldSocket, *NODE_CLASSES, THICKET_MT_field_nodes_add, THICKET_PT_field_nodes)
MENU_ENTRIES = (("NODE_MT_add", draw_add_menu),)
