"""The thick-surface stack: Thicket's own non-destructive, modifier-like item list.

- `settings`: plain-data item settings (no bpy), one dataclass per item kind.
- `evaluate`: runs a list of settings over mesh arrays (no bpy).
- `properties`: the PropertyGroups stored on objects (saved in the .blend).
- `regenerate`: source object -> result object, the bpy side of `evaluate`.
- `auto_update`: debounced regeneration when a source or a setting changes.
"""
