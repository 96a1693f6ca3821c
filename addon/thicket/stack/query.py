"""Which stack the user is acting on: read by operators, panels and the renderers
alike, so none of them imports another's module to find it."""


def active_source(context):
    """The active object if it is a mesh that can carry a stack (not a result)."""
    obj = context.active_object
    if obj is None or obj.type != "MESH":
        return None
    if obj.thicket.source is not None:  # a result: act on its source
        return obj.thicket.source
    return obj


def active_stack_source(context):
    """[`active_source`], when it has a stack."""
    obj = active_source(context)
    return obj if obj is not None and len(obj.thicket.items) > 0 else None
