"""Field trees on Blender's side (issue 17): Field Mesh objects built from a tree's
JSON and kept regenerable (`field_mesh`), and field renders into Blender images."""

from .field_mesh import build_field_mesh, field_settings, regenerate_field_mesh

__all__ = ["build_field_mesh", "regenerate_field_mesh", "field_settings"]
