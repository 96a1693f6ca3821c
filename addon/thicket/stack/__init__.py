"""The thick-surface stack: Thicket's own non-destructive, modifier-like item list.

- `settings`: plain-data item settings (no bpy), one dataclass per item kind.
- `kinds`: one module per item kind with its step, and the registry of what each
  consumes and produces (no bpy).
- `state`: what the walk carries from item to item (no bpy).
- `evaluate`: walks a list of settings over mesh arrays by those declarations (no bpy).
- `properties`: the PropertyGroups stored on objects (saved in the .blend).
- `regenerate`: source object -> result object, the bpy side of `evaluate`.
- `auto_update`: debounced regeneration when a source or a setting changes.
"""
