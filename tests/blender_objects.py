"""Objects made from plain vertex and face lists, for the tests and the benchmarks."""

import bpy


def mesh_object(name, vertices, faces):
    """A new mesh object `name`, linked to the scene's collection."""
    mesh = bpy.data.meshes.new(name)
    mesh.from_pydata(vertices, [], faces)
    obj = bpy.data.objects.new(name, mesh)
    bpy.context.scene.collection.objects.link(obj)
    return obj
