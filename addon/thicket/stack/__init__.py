"""The thick-surface stack on Blender's side: Thicket's own non-destructive,
modifier-like item list stored on objects. The plain-data settings, the kinds and the
walk that evaluates a stack are in `pure/`.

- `properties`: the PropertyGroups stored on objects (saved in the .blend).
- `regenerate`: source object -> result object, the bpy side of `pure.evaluate`.
- `auto_update`: debounced regeneration when a source or a setting changes.
- `guard`: the re-entrancy guard of regeneration.
- `query`: which stack the user is acting on.
- `versioning`: settings of files saved by earlier versions under former names.
"""
