"""Draws one stack item's settings (shared by the Properties and sidebar panels)."""


def draw_item_settings(layout, obj, item):
    col = layout.column()
    col.use_property_split = True
    col.use_property_decorate = False
    if item.kind == "SHELL":
        col.prop(item, "side")
    col.prop(item, "thickness_mode")
    col.prop(item, "thickness")
    col.prop_search(item, "vertex_group", obj, "vertex_groups")
    col.prop(item, "output")
    if item.output == "LAYERS":
        col.prop(item, "layers")


def draw_status(layout, obj):
    stack = obj.thicket
    if stack.last_error:
        box = layout.box()
        box.alert = True
        box.label(text=stack.last_error, icon="ERROR")
    if stack.result is not None:
        layout.label(text=f"Result: {stack.result.name}", icon="OUTLINER_OB_MESH")
