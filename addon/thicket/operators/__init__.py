"""One operator per module; `CLASSES` is what registration needs."""

from .add_thick_surface import THICKET_OT_add_thick_surface
from .apply_result import THICKET_OT_apply
from .export_texture import THICKET_OT_export_texture
from .field_mesh_add import THICKET_OT_field_mesh_add
from .field_mesh_regenerate import THICKET_OT_field_mesh_regenerate
from .field_nodes_add import THICKET_OT_field_nodes_add
from .fit_bake_budget import THICKET_OT_fit_bake_budget
from .item_add import THICKET_OT_item_add
from .item_move import THICKET_OT_item_move
from .item_remove import THICKET_OT_item_remove
from .live_preview import THICKET_OT_live_preview
from .procedural_detail_add import THICKET_OT_procedural_detail_add
from .regenerate import THICKET_OT_regenerate
from .remove_stack import THICKET_OT_remove
from .render_preview import THICKET_OT_render_preview
from .select_crossings import THICKET_OT_select_crossings

CLASSES = (
    THICKET_OT_add_thick_surface,
    THICKET_OT_regenerate,
    THICKET_OT_fit_bake_budget,
    THICKET_OT_apply,
    THICKET_OT_remove,
    THICKET_OT_item_add,
    THICKET_OT_item_remove,
    THICKET_OT_item_move,
    THICKET_OT_export_texture,
    THICKET_OT_render_preview,
    THICKET_OT_live_preview,
    THICKET_OT_select_crossings,
    THICKET_OT_field_mesh_add,
    THICKET_OT_field_nodes_add,
    THICKET_OT_field_mesh_regenerate,
    THICKET_OT_procedural_detail_add,
)
