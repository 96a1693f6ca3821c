"""A field tree as the source of a Volumetric Texture (issue 17): the binding
`Texture.from_field`, and a Shell + Volumetric Texture stack filled from a tree,
baked in real Blender: closed manifold, changed by the tree, kept by save/reload,
bad trees refused with the object left as it was."""

import json

import bmesh
import bpy
import numpy as np
import pytest
from conftest import add, positions
from mathutils.bvhtree import BVHTree
from test_bake_manifold import coplanar_and_apart

import thicket_native as tn
from thicket import api

BALL = {"op": "sphere", "center": [0.5, 0.5, 0.5], "radius": 0.3}
SMALL = {"op": "sphere", "center": [0.5, 0.5, 0.5], "radius": 0.2}
SETTINGS = dict(texture_size=16, resolution=4, depth_steps=6, follow_texture=False, triangle_budget=0)


def test_from_field_binding():
    t = tn.Texture.from_field(json.dumps(BALL), resolution=(32, 32, 33))
    assert t.size == (32, 32, 33)
    a = t.array()
    assert a.shape == (33, 32, 32) and a.dtype == np.float32
    assert a[16, 16, 16] == 1.0 and a[0, 0, 0] == 0.0
    # The mean occupancy over the cell is the ball's volume (a texel stands for 1/(32*32*32)).
    assert abs(a.sum() / (32 * 32 * 32) - 4 / 3 * np.pi * 0.3**3) < 0.01
    with pytest.raises(ValueError, match="radius"):
        tn.Texture.from_field('{"op": "sphere", "center": [0.5, 0.5, 0.5], "radius": -1}')
    with pytest.raises(ValueError):
        tn.Texture.from_field("{not json")
    with pytest.raises(ValueError, match="too large"):
        tn.Texture.from_field(json.dumps(BALL), resolution=(4096, 4096, 4096))
    with pytest.raises(ValueError, match="zero size"):
        tn.Texture.from_field(json.dumps(BALL), resolution=(0, 4, 4))


def defects(obj):
    """Non-manifold edges and crossing triangle pairs sharing no vertex (bmesh, BVHTree)."""
    bm = bmesh.new()
    bm.from_mesh(obj.data)
    bmesh.ops.triangulate(bm, faces=bm.faces[:])
    bm.faces.ensure_lookup_table()
    not_manifold = sum(not e.is_manifold for e in bm.edges)
    tris = np.array([[v.index for v in f.verts] for f in bm.faces], np.int64).reshape(-1, 3)
    pairs = BVHTree.FromBMesh(bm).overlap(BVHTree.FromBMesh(bm))
    bm.free()
    p = positions(obj).astype(np.float64)
    crossing = {
        tuple(sorted(q)) for q in pairs if q[0] != q[1] and not set(tris[q[0]]) & set(tris[q[1]]) and not coplanar_and_apart(p[tris[q[0]]], p[tris[q[1]]])
    }
    return not_manifold, len(crossing)


def test_shell_and_field_texture_bake_is_closed_manifold_and_follows_the_tree(scene, tmp_path):
    obj = add("cube", size=2.0)
    result = api.add_volumetric_texture(obj, shell_thickness=0.1, field_tree_json=json.dumps(BALL), **SETTINGS)
    item = obj.thicket.items[-1]
    assert item.source == "FIELD_JSON" and obj.thicket.last_error == ""
    assert len(result.data.polygons) > 0
    assert defects(result) == (0, 0)
    big = positions(result).copy()
    # Changing the tree changes the bake.
    item.tree = json.dumps(SMALL)
    api.regenerate(obj)
    assert obj.thicket.last_error == ""
    small = positions(result)
    assert len(small) != len(big) or not np.allclose(small, big)
    assert defects(result) == (0, 0)
    # Save and reload keep the source.
    path = str(tmp_path / "field_texture.blend")
    bpy.ops.wm.save_as_mainfile(filepath=path)
    bpy.ops.wm.open_mainfile(filepath=path)
    obj = bpy.data.objects["Cube"]
    item = obj.thicket.items[-1]
    assert item.source == "FIELD_JSON" and json.loads(item.tree) == SMALL
    assert item.to_settings().field_tree == item.tree


def test_bad_tree_is_refused_and_leaves_the_object_untouched(scene):
    obj = add("cube", size=2.0)
    with pytest.raises(ValueError, match="radius"):
        api.add_volumetric_texture(obj, field_tree_json='{"op": "sphere", "center": [0.5, 0.5, 0.5], "radius": -1}', **SETTINGS)
    assert len(obj.thicket.items) == 0 and obj.thicket.result is None
    with pytest.raises(ValueError):
        api.add_volumetric_texture(obj, field_tree_json="{not json", **SETTINGS)
    assert len(obj.thicket.items) == 0
    # A good stack whose tree turns bad keeps its result and reports.
    result = api.add_volumetric_texture(obj, shell_thickness=0.1, field_tree_json=BALL, **SETTINGS)
    good = positions(result).copy()
    obj.thicket.items[-1].tree = "{not json"
    with pytest.raises(ValueError):
        api.regenerate(obj)
    assert np.array_equal(positions(obj.thicket.result), good)


def test_node_tree_source_regenerates_on_edit(scene):
    tree = bpy.data.node_groups.new("Texture Field", "ThicketFieldTree")
    sphere = tree.nodes.new("ThicketNodeSphere")
    sphere.center, sphere.radius = (0.5, 0.5, 0.5), 0.3
    out = tree.nodes.new("ThicketNodeOutput")
    tree.links.new(sphere.outputs[0], out.inputs[0])
    obj = add("cube", size=2.0)
    result = api.add_volumetric_texture(obj, shell_thickness=0.1, field_tree_json=tree, **SETTINGS)
    assert obj.thicket.items[-1].source == "FIELD_NODES" and obj.thicket.items[-1].field_nodes == tree
    before = positions(result).copy()
    sphere.radius = 0.15  # the node's update schedules the stack (background: at once)
    after = positions(obj.thicket.result)
    assert len(after) != len(before) or not np.allclose(after, before)
    assert obj.thicket.last_error == ""
