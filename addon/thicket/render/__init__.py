"""Rendering thick surfaces without baking them (thick surfaces, chapters 5-6):
cameras from Blender, the native renderers, and the image they make."""
