"""The Procedural Detail item on an artist's Multires sculpt (Use Sculpt; issue 18,
Velho, Perlin, Ying and Biermann section 2), in real Blender.

The sculpt is made as in test_multires.py: `object.multires_subdivide`, then the finest
level set from a displaced copy of its own evaluated mesh with `object.multires_reshape`.
With zero procedural amplitude the item's result is Blender's own evaluated Multires
mesh, vertex for vertex through the matched numbering; detail lands on top of it; the
analysis is cached (counted by `thicket.sculpt.analyses`) and re-run only when the sculpt
or its base changes; it runs in the stack's evaluation (a worker in the interface), with
progress and cancel, not while Blender is read; bad input is refused with the source
untouched.
"""

import bmesh
import bpy
import numpy as np
import pytest
from conftest import add, positions, run_modal, select_only
from test_multires import diagonal, evaluated, quads, reshape_to, sculpted

import thicket_native as tn
from thicket import api, mesh_io, sculpt
from thicket.operators.regenerate import watched_regeneration
from thicket.pure.evaluate import evaluate_stack
from thicket.pure.kinds.procedural_detail import ANALYSIS_SHARE
from thicket.pure.kinds.procedural_detail_sculpt import MATCH_SHARE
from thicket.stack.guard import suspended
from thicket.stack.regenerate import read_source


def wavy(p):
    return p * (0.06 * np.sin(7.0 * p[:, 0]) * np.cos(5.0 * p[:, 1]) + 0.04 * np.sin(9.0 * p[:, 2]))[:, None]


def bumpy(p):
    return p * (0.08 * np.cos(6.0 * p[:, 1] + p[:, 2]))[:, None]


def up(p):
    return np.outer(0.05 * np.sin(5.0 * p[:, 0]) * np.cos(4.0 * p[:, 1]), [0.0, 0.0, 1.0])


def reshaped(obj, offset):
    """Sets the sculpt's finest level (the modifier's own levels, no new ones) to the
    plain subdivision of the base moved by `offset`, as `sculpted` does."""
    modifier = mesh_io.multires_modifier(obj)
    levels = modifier.total_levels
    with suspended():
        plain = bpy.data.objects.new("plain", obj.data)
        bpy.context.scene.collection.objects.link(plain)
        surface = plain.modifiers.new("s", "SUBSURF")
        surface.levels, surface.quality = levels, max(levels, 3)
        p = evaluated(plain)
        bpy.data.objects.remove(plain)
        target = p.vertices + offset(p.vertices)
        reshape_to(obj, modifier, target, p)
    out = evaluated(obj).vertices
    assert np.abs(out - target).max() < 1e-4 * diagonal(target), "the reshape took"
    return out


def in_thicket_order(obj, result):
    """Blender's evaluated Multires positions of `obj` in the result's numbering, after
    checking that the numbering carries Blender's faces onto the result's."""
    blender = evaluated(obj)
    order = api.analyze_multires(obj)["order"]
    inverse = np.empty_like(order)
    inverse[order] = np.arange(len(order), dtype=order.dtype)
    sizes, corners = np.empty(len(result.data.polygons), np.int32), np.empty(len(result.data.loops), np.int32)
    result.data.polygons.foreach_get("loop_total", sizes)
    result.data.loops.foreach_get("vertex_index", corners)
    assert (sizes == 4).all()
    np.testing.assert_array_equal(quads(inverse[blender.corners]), quads(corners))
    return blender.vertices[order]


def snapshot(obj):
    """What must not change: the base mesh, the evaluated sculpt, the modifiers."""
    return mesh_io.read_mesh(obj.data).vertices.copy(), evaluated(obj).vertices.copy(), [(m.type, m.total_levels) for m in obj.modifiers]


def assert_untouched(obj, before):
    base, sculpt_positions, modifiers = snapshot(obj)
    np.testing.assert_array_equal(base, before[0])
    np.testing.assert_array_equal(sculpt_positions, before[1])
    assert modifiers == before[2]
    assert not any(o.name.startswith(".thicket") for o in bpy.data.objects)


CASES = {
    "cube": (dict(size=2), 3, wavy),
    "grid": (dict(x_subdivisions=4, y_subdivisions=3, size=2), 2, up),
    # Triangle fans at the poles.
    "uv_sphere": (dict(segments=12, ring_count=6, radius=1), 2, wavy),
}


@pytest.mark.parametrize("primitive", list(CASES))
def test_zero_amplitude_is_blenders_multires_vertex_for_vertex(scene, primitive):
    kw, levels, offset = CASES[primitive]
    obj = add(primitive, **kw)
    sculpt_positions = sculpted(obj, levels, offset)
    before = snapshot(obj)
    result = api.add_procedural_detail(obj, model="ROCK", amplitude=0.0, levels=levels)
    item = obj.thicket.items[0]
    assert item.use_sculpt, "on by default where the item comes first on a sculpt"
    assert obj.thicket.last_error == "" and obj.thicket.last_note == ""
    ours = positions(result)
    assert len(ours) == len(sculpt_positions)
    blender = in_thicket_order(obj, result)
    error = np.linalg.norm(ours - blender, axis=1).max() / diagonal(blender)
    assert error < 1e-5, error
    # The sculpt is real: the same item without it (plain levels on the fitted base) is far off.
    m = api.analyze_multires(obj)
    plain = tn.synthesize_multires(m["vertices"], m["face_sizes"], m["corners"], [np.zeros_like(d) for d in m["details"]])["vertices"]
    assert np.linalg.norm(plain - blender, axis=1).max() > 0.01 * diagonal(blender)
    # UV maps come through the levels from the base mesh.
    assert len(result.data.uv_layers) == len(obj.data.uv_layers) == 1
    assert_untouched(obj, before)


def test_a_lower_viewport_level_reads_the_same_sculpt_from_the_cache(scene):
    obj = add("cube", size=2)
    sculpted(obj, 3, wavy)
    flat = positions(api.add_procedural_detail(obj, model="ROCK", amplitude=0.0)).copy()
    analysed = sculpt.analyses
    # The object now shows level 1: the sculpt is read from a copy at all its levels,
    # the very positions the object's own evaluated mesh gave, so nothing is analysed.
    mesh_io.multires_modifier(obj).levels = 1
    assert len(evaluated(obj).vertices) == 26
    np.testing.assert_array_equal(positions(api.regenerate(obj)), flat)
    assert sculpt.analyses == analysed
    # In Edit Mode the mesh is flushed and read the same way.
    select_only(obj)
    with bpy.context.temp_override(object=obj, active_object=obj):
        assert bpy.ops.object.mode_set(mode="EDIT") == {"FINISHED"}
    try:
        np.testing.assert_array_equal(positions(api.regenerate(obj)), flat)
    finally:
        with bpy.context.temp_override(object=obj, active_object=obj):
            bpy.ops.object.mode_set(mode="OBJECT")
    assert sculpt.analyses == analysed


def test_seeds_from_a_vertex_group_of_the_base(scene):
    obj = add("cube", size=2)
    sculpted(obj, 2, wavy)
    group = obj.vertex_groups.new(name="tips")
    group.add([0, 6], 1.0, "REPLACE")
    result = api.add_procedural_detail(obj, model="BERRY", radius=0.1, children=0, seeds="GROUP", vertex_group="tips", levels=2)
    assert obj.thicket.items[0].use_sculpt and obj.thicket.last_error == ""
    m = api.analyze_multires(obj)
    native = tn.procedural_detail(
        m["vertices"].astype(np.float32),
        m["face_sizes"],
        m["corners"],
        "berry",
        2,
        0,
        {"radius": float(np.float32(0.1)), "children": 0, "seeds": [0, 6]},
        sculpt=m,
    )
    np.testing.assert_allclose(positions(result), native["vertices"], atol=1e-6)
    flat = tn.procedural_detail(m["vertices"].astype(np.float32), m["face_sizes"], m["corners"], "rock", 2, 0, {"amplitude": 0.0}, sculpt=m)
    moved = np.linalg.norm(positions(result) - flat["vertices"], axis=1) > 1e-4
    assert moved[[0, 6]].all() and not moved[[1, 7]].any(), "domes at the group's vertices only"


def test_detail_lands_on_the_sculpt(scene):
    obj = add("cube", size=2)
    sculpted(obj, 3, wavy)
    flat = positions(api.add_procedural_detail(obj, model="ROCK", amplitude=0.0, seed=4)).copy()
    assert obj.thicket.items[0].levels == 3, "a preset's or the default's levels are raised to the sculpt's"
    with suspended():
        obj.thicket.items[0].detail_amplitude = 0.03
    rocky = positions(api.regenerate(obj)).copy()
    d = diagonal(flat)
    assert np.linalg.norm(rocky - flat, axis=1).max() > 0.005 * d, "the detail shows"
    # Plain detail on the same base (no sculpt): same rock, without the sculpt's features.
    m = api.analyze_multires(obj)
    plain = tn.procedural_detail(m["vertices"].astype(np.float32), m["face_sizes"], m["corners"], "rock", 3, 4, {"amplitude": float(np.float32(0.03))})
    zero = tn.synthesize_multires(m["vertices"], m["face_sizes"], m["corners"], [np.zeros_like(x) for x in m["details"]])["vertices"]
    assert np.linalg.norm(rocky - plain["vertices"], axis=1).max() > 0.01 * d, "the sculpt shows"
    # Each is the other's plus roughly its own features: the sculpt rides on the rock.
    feature = np.linalg.norm(flat - zero, axis=1)
    carried = np.linalg.norm(rocky - plain["vertices"], axis=1)
    assert np.sqrt(np.mean((carried - feature) ** 2)) < 0.25 * np.sqrt(np.mean(feature**2))
    # More levels than the sculpt's: finer levels on top, the sculpt still there.
    with suspended():
        obj.thicket.items[0].levels = 4
    finer = api.regenerate(obj)
    assert len(finer.data.polygons) == 6 * 4**4


def test_only_a_change_of_the_sculpt_runs_the_analysis_again(scene):
    obj = add("cube", size=2)
    sculpted(obj, 2, wavy)
    start = sculpt.analyses
    first = positions(api.add_procedural_detail(obj, model="ROCK", amplitude=0.01, seed=1)).copy()
    assert sculpt.analyses == start + 1
    numberings = sculpt.numberings
    item = obj.thicket.items[0]
    seen = [first]
    # The item's own settings (live edits: regenerated at once headless): no analysis.
    item.detail_amplitude = 0.02
    item.seed = 5
    assert item.levels == 3
    item.levels = 4
    assert obj.thicket.last_error == ""
    seen.append(positions(api.regenerate(obj)).copy())
    assert sculpt.analyses == start + 1 and sculpt.numberings == numberings
    assert len(seen[-1]) != len(first)
    # A new sculpt: analysed again (the numbering kept), and the result follows it.
    item.levels = 2
    item.detail_amplitude = 0.0
    new = reshaped(obj, bumpy)
    result = api.regenerate(obj)
    assert sculpt.analyses == start + 2 and sculpt.numberings == numberings
    error = np.linalg.norm(positions(result) - in_thicket_order(obj, result), axis=1).max() / diagonal(new)
    assert error < 1e-5, error
    # A moved base vertex: numbered and analysed again.
    analysed = sculpt.analyses
    with suspended():
        obj.data.vertices[0].co.x -= 0.2
    result = api.regenerate(obj)
    assert sculpt.analyses == analysed + 1 and sculpt.numberings == numberings + 1
    error = np.linalg.norm(positions(result) - in_thicket_order(obj, result), axis=1).max() / diagonal(new)
    assert error < 1e-5, error
    # One entry per object, dropped when the object goes away or a file is loaded.
    assert set(sculpt._cache) == {obj.session_uid}
    other = add("cube", size=2, location=(4, 0, 0))
    sculpted(other, 1, wavy)
    api.add_procedural_detail(other, model="ROCK", amplitude=0.0)
    assert set(sculpt._cache) == {obj.session_uid, other.session_uid}
    bpy.data.objects.remove(obj)
    api.regenerate(other)
    assert set(sculpt._cache) == {other.session_uid}
    # Turning Use Sculpt off forgets it.
    other.thicket.items[0].use_sculpt = False
    api.regenerate(other)
    assert sculpt._cache == {}
    other.thicket.items[0].use_sculpt = True
    assert sculpt._cache
    bpy.ops.wm.read_factory_settings(use_empty=True)
    assert sculpt._cache == {}


def test_a_topology_edit_under_the_modifier_is_followed_or_refused(scene):
    obj = add("cube", size=2)
    sculpted(obj, 2, wavy)
    api.add_procedural_detail(obj, model="ROCK", amplitude=0.0, levels=2)
    # A face deleted under the Multires (Blender keeps the other faces' displacements):
    # the base changed, so the cache does not answer; the result is the new sculpt.
    with suspended():
        bm = bmesh.new()
        bm.from_mesh(obj.data)
        bm.faces.ensure_lookup_table()
        bmesh.ops.delete(bm, geom=[bm.faces[0]], context="FACES_ONLY")
        bm.to_mesh(obj.data)
        bm.free()
        obj.data.update()
    result = api.regenerate(obj)
    assert len(result.data.polygons) == 5 * 16
    blender = in_thicket_order(obj, result)
    assert np.linalg.norm(positions(result) - blender, axis=1).max() < 1e-5 * diagonal(blender)
    # A loose vertex under it: refused, naming the item and the cause; the last result stays.
    kept = positions(result).copy()
    with suspended():
        obj.data.vertices.add(1)
        obj.data.update()
    before = snapshot(obj)
    with pytest.raises(api.ThicketError, match="Use Sculpt.*no face"):
        api.regenerate(obj)
    np.testing.assert_array_equal(positions(obj.thicket.result), kept)
    assert_untouched(obj, before)


def test_bad_input_is_refused_with_the_reason_and_the_source_untouched(scene):
    obj = add("cube", size=2)
    sculpted(obj, 3, wavy)
    before = snapshot(obj)
    # Explicit levels below the sculpt's are not raised: refused at once, saying what to do.
    with pytest.raises(api.ThicketError, match="sculpt has 3 levels.*set Levels to 3"):
        api.add_procedural_detail(obj, model="ROCK", levels=2, use_sculpt=True)
    assert obj.thicket.result is None
    assert_untouched(obj, before)
    obj.thicket.items[0].levels = 3  # a live edit: regenerated at once headless
    assert obj.thicket.last_error == "" and obj.thicket.result is not None
    kept = positions(obj.thicket.result).copy()
    # Sculpt Mode: the latest strokes are not in the mesh yet.
    select_only(obj)
    with bpy.context.temp_override(object=obj, active_object=obj):
        assert bpy.ops.object.mode_set(mode="SCULPT") == {"FINISHED"}
    with pytest.raises(ValueError, match="Use Sculpt.*Sculpt Mode"):
        api.regenerate(obj)
    with bpy.context.temp_override(object=obj, active_object=obj):
        assert bpy.ops.object.mode_set(mode="OBJECT") == {"FINISHED"}
    np.testing.assert_array_equal(positions(obj.thicket.result), kept)
    assert_untouched(obj, before)
    # Use Sculpt on an item that is not the first one.
    kept = positions(api.add_procedural_detail(obj, model="ROCK", amplitude=0.0, levels=1)).copy()
    assert len(kept) == 1538
    assert not obj.thicket.items[1].use_sculpt, "off by default after another item"
    obj.thicket.items[1].use_sculpt = True
    assert "item 2" in obj.thicket.last_error and "move it to the top" in obj.thicket.last_error
    np.testing.assert_array_equal(positions(obj.thicket.result), kept)
    # A Multires with no levels.
    cube = add("cube", size=2, location=(4, 0, 0))
    cube.modifiers.new("Multires", "MULTIRES")
    with pytest.raises(ValueError, match="Use Sculpt.*no levels: subdivide it first"):
        api.add_procedural_detail(cube, model="ROCK", use_sculpt=True)
    assert cube.thicket.items[0].use_sculpt and cube.thicket.result is None
    # No Multires at all.
    plain = add("cube", size=2, location=(8, 0, 0))
    with pytest.raises(ValueError, match="no Multires"):
        api.add_procedural_detail(plain, model="ROCK", use_sculpt=True)
    assert len(plain.thicket.items) == 0


def test_other_modifiers_are_left_out_with_a_note(scene):
    obj = add("cube", size=2)
    sculpted(obj, 2, wavy)
    flat = positions(api.add_procedural_detail(obj, model="ROCK", amplitude=0.0)).copy()
    displace = obj.modifiers.new("Push", "DISPLACE")
    displace.strength = 0.3
    result = api.regenerate(obj)
    assert "Push on the source not applied" in obj.thicket.last_note
    np.testing.assert_array_equal(positions(result), flat)


def test_use_sculpt_off_details_the_evaluated_mesh_as_before(scene):
    obj = add("cube", size=2)
    sculpted(obj, 1, wavy)
    result = api.add_procedural_detail(obj, model="ROCK", amplitude=0.02, seed=2, levels=1, use_sculpt=False)
    assert not obj.thicket.items[0].use_sculpt
    dense = evaluated(obj)
    native = tn.procedural_detail(dense.vertices, dense.face_sizes, dense.corners, "rock", 1, 2, {"amplitude": float(np.float32(0.02))})
    np.testing.assert_array_equal(positions(result), native["vertices"])
    assert len(result.data.polygons) == 6 * 4 * 4
    # Without a Multires the option stays off and the item is as it always was.
    cube = add("cube", size=2, location=(4, 0, 0))
    api.add_procedural_detail(cube, model="ROCK")
    assert not cube.thicket.items[0].use_sculpt


def test_the_operator_starts_from_the_sculpt_and_undoes(scene):
    obj = add("cube", size=2)
    sculpt_positions = sculpted(obj, 3, wavy)
    select_only(obj)
    bpy.ops.ed.undo_push(message="before")
    assert bpy.ops.thicket.procedural_detail_add(preset="ROCK") == {"FINISHED"}
    bpy.ops.ed.undo_push(message="Add Procedural Detail")
    obj = bpy.data.objects["Cube"]
    item = obj.thicket.items[0]
    assert item.use_sculpt and item.levels == 4
    assert obj.thicket.last_error == "" and len(obj.thicket.result.data.polygons) == 6 * 4**4
    bpy.ops.ed.undo()
    obj = bpy.data.objects["Cube"]
    assert len(obj.thicket.items) == 0
    np.testing.assert_array_equal(evaluated(obj).vertices, sculpt_positions)


def test_the_panel_shows_use_sculpt_only_with_a_multires(scene):
    from test_field_blender import Layout

    from thicket.ui.item_settings import draw_item_settings

    cube = add("cube")
    api.add_item(cube, "PROCEDURAL_DETAIL")
    drawn = []
    draw_item_settings(Layout(drawn), cube, cube.thicket.items[0])
    assert "use_sculpt" not in drawn
    cube.modifiers.new("Multires", "MULTIRES")
    drawn.clear()
    draw_item_settings(Layout(drawn), cube, cube.thicket.items[0])
    assert drawn[:3] == ["detail_model", "levels", "use_sculpt"]


def test_a_saved_sculpt_item_reloads_and_the_renderers_read_the_sculpt(scene, tmp_path):
    from thicket.render import preview

    obj = add("cube", size=2)
    sculpted(obj, 2, wavy)
    flat = positions(api.add_procedural_detail(obj, model="ROCK", amplitude=0.0, levels=2)).copy()
    # The renderers read the source as a regeneration does: the coarse mesh and the sculpt.
    source, items, _ = preview.render_inputs(obj)
    assert source.vertex_count == 8 and items[0].sculpt is not None and items[0].sculpt.levels == 2
    path = str(tmp_path / "sculpt.blend")
    bpy.ops.wm.save_as_mainfile(filepath=path)
    bpy.ops.wm.open_mainfile(filepath=path)
    assert sculpt._cache == {}, "dropped on load"
    obj = bpy.data.objects["Cube"]
    assert obj.thicket.items[0].use_sculpt
    analysed = sculpt.analyses
    np.testing.assert_array_equal(positions(api.regenerate(obj)), flat)
    assert sculpt.analyses == analysed + 1


def test_the_default_levels_rise_to_a_deeper_sculpt_and_chosen_levels_keep_it_off(scene):
    obj = add("cube", size=2)
    sculpted(obj, 4, wavy)  # deeper than the default's 3 levels
    result = api.add_procedural_detail(obj, model="ROCK", amplitude=0.0)
    item = obj.thicket.items[0]
    assert item.use_sculpt and item.levels == 4, "the default's levels are raised to the sculpt's"
    assert len(result.data.polygons) == 6 * 4**4
    api.remove(obj)
    # Levels the caller chose below the sculpt's: detail on the evaluated mesh, as before.
    result = api.add_procedural_detail(obj, model="ROCK", amplitude=0.0, levels=1)
    assert not obj.thicket.items[0].use_sculpt
    assert len(result.data.polygons) == 4 * 6 * 4**4, "one level over the dense sculpt"
    api.remove(obj)
    # Asked for explicitly, they are refused.
    with pytest.raises(api.ThicketError, match="more than the item's 1"):
        api.add_procedural_detail(obj, model="ROCK", amplitude=0.0, levels=1, use_sculpt=True)


def big_sculpt():
    """A sculpt whose analysis (131k vertices) outlasts several progress ticks (0.1 s),
    its item added (zero amplitude) but not evaluated, auto-update off."""
    obj = add("uv_sphere", segments=32, ring_count=16, radius=1)
    sculpted(obj, 4, wavy)
    obj.thicket.auto_update = False
    api.add_detail_item(obj, detail_model="ROCK", detail_amplitude=0.0)
    assert obj.thicket.items[0].use_sculpt and obj.thicket.result is None
    return obj


def rising(seen):
    return all(a <= b for a, b in zip(seen, seen[1:]))


def test_the_analysis_runs_in_the_evaluation_with_progress_and_cancel(scene):
    obj = big_sculpt()
    analysed, numbered = sculpt.analyses, sculpt.numberings
    source, items = read_source(obj)
    # Blender is read (the cage, the sculpt, the numbering's positions), nothing analysed.
    assert sculpt.analyses == analysed and sculpt.numberings == numbered
    assert items[0].sculpt.numbering is not None
    np.testing.assert_array_equal(source.vertices, mesh_io.read_mesh(obj.data).vertices)
    assert obj.session_uid not in sculpt._cache
    # The match has its share of the progress and a cancel lands after it, before the
    # analysis: Cancelled, the matched numbering kept (no analysis).
    seen = []

    def cancel_inside(fraction):
        seen.append(fraction)
        return fraction == 0.0

    with pytest.raises(tn.Cancelled):
        evaluate_stack(source, items, cancel_inside)
    assert seen[-1] == pytest.approx(MATCH_SHARE * ANALYSIS_SHARE) and rising(seen), seen
    assert sculpt.analyses == analysed and sculpt.numberings == numbered + 1
    entry = sculpt._cache[obj.session_uid]
    assert entry.analysis is None and entry.fine_key is None
    np.testing.assert_array_equal(entry.order, items[0].sculpt.order)
    # Read again: the numbering comes from the cache (Blender's is not read, nothing
    # matched) and the analysis has the whole share. Cancelled inside the analysis:
    # nothing stored, the numbering stays.
    source, items = read_source(obj)
    assert items[0].sculpt.numbering is None and items[0].sculpt.order is entry.order
    seen = []
    with pytest.raises(tn.Cancelled):
        evaluate_stack(source, items, cancel_inside)
    assert rising(seen) and 0.0 < seen[-1] < ANALYSIS_SHARE, seen
    assert sculpt.analyses == analysed + 1 and sculpt.numberings == numbered + 1
    assert sculpt._cache[obj.session_uid] is entry
    # Evaluated again (the same read): analysed again, the progress rising through it to 1.
    seen = []
    result = evaluate_stack(source, items, seen.append)
    assert sculpt.analyses == analysed + 2 and sculpt.numberings == numbered + 1
    assert rising(seen) and seen[-1] == 1.0 and any(0.0 < f < ANALYSIS_SHARE for f in seen), seen
    assert sculpt._cache[obj.session_uid].analysis is not None
    written = api.regenerate(obj)  # from the cache: nothing analysed
    assert sculpt.analyses == analysed + 2
    np.testing.assert_array_equal(positions(written), result.vertices)
    blender = in_thicket_order(obj, written)
    assert np.linalg.norm(result.vertices - blender, axis=1).max() < 1e-5 * diagonal(blender)


def test_a_numbering_that_does_not_carry_the_faces_is_refused_naming_the_object(scene, monkeypatch):
    # Positions can match two close vertices the wrong way round: the core's check of the
    # renumbered faces refuses it, with the message the user saw before, not an analysis
    # of noise.
    obj = add("cube", size=2)
    sculpted(obj, 2, wavy)
    obj.thicket.auto_update = False
    api.add_detail_item(obj, detail_model="ROCK", detail_amplitude=0.0, levels=2)
    before = snapshot(obj)
    real = tn.match_subdivision

    def swapped(*args, **kw):
        order = real(*args, **kw)
        order[[0, 1]] = order[[1, 0]]  # two vertices of the base's first face
        return order

    monkeypatch.setattr(tn, "match_subdivision", swapped)
    analysed = sculpt.analyses
    message = f"'{obj.name}' could not be matched face for face to Thicket's subdivision"
    with pytest.raises(ValueError, match=f"Use Sculpt.*{message}"):
        api.regenerate(obj)
    assert obj.session_uid not in sculpt._cache and sculpt.analyses == analysed + 1
    with pytest.raises(ValueError, match=message):
        api.analyze_multires(obj)
    assert_untouched(obj, before)
    monkeypatch.setattr(tn, "match_subdivision", real)
    result = api.regenerate(obj)
    blender = in_thicket_order(obj, result)
    assert np.linalg.norm(positions(result) - blender, axis=1).max() < 1e-5 * diagonal(blender)


def test_the_regenerate_job_analyses_on_its_worker_and_esc_keeps_the_previous_result(scene):
    obj = big_sculpt()
    kept = positions(api.regenerate(obj)).copy()  # headless: the same code, synchronously
    entry = sculpt._cache[obj.session_uid]
    analysed = sculpt.analyses
    new = reshaped(obj, bumpy)
    reports = []
    watch = watched_regeneration(bpy.context, obj, False, lambda kind, text: reports.append((kind, text)))
    assert sculpt.analyses == analysed, "the main thread only read Blender"
    watch.job.start()
    while watch.job.fraction == 0.0 and not watch.job.done:
        watch.job._thread.join(0.01)
    assert sculpt.analyses == analysed + 1 and not watch.job.done, "analysing on the worker"
    status = watch.event(bpy.context, "ESC", "PRESS")
    while status == {"RUNNING_MODAL"}:
        watch.job._thread.join(0.05)
        status = watch.event(bpy.context, "TIMER")
    assert status == {"CANCELLED"} and watch.job.fraction < ANALYSIS_SHARE
    assert any(kind == {"WARNING"} and "cancelled" in text for kind, text in reports), reports
    np.testing.assert_array_equal(positions(obj.thicket.result), kept)
    assert sculpt._cache[obj.session_uid] is entry, "the entry before the cancel stays"
    # The next regeneration analyses again, as an uncancelled one does.
    watch = watched_regeneration(bpy.context, obj, False, lambda kind, text: reports.append((kind, text)))
    assert run_modal(watch) == {"FINISHED"} and sculpt.analyses == analysed + 2
    after = positions(obj.thicket.result).copy()
    assert np.linalg.norm(after - in_thicket_order(obj, obj.thicket.result), axis=1).max() < 1e-5 * diagonal(new)
    sculpt.clear()
    np.testing.assert_array_equal(positions(api.regenerate(obj)), after)
    assert sculpt.analyses == analysed + 3
    # A cache hit does no analysis.
    np.testing.assert_array_equal(positions(api.regenerate(obj)), after)
    assert sculpt.analyses == analysed + 3


def test_only_the_latest_read_of_a_sculpt_is_cached(scene):
    obj = add("cube", size=2)
    sculpted(obj, 2, wavy)
    obj.thicket.auto_update = False
    api.add_detail_item(obj, detail_model="ROCK", detail_amplitude=0.0)
    older = read_source(obj)
    reshaped(obj, bumpy)
    newer = read_source(obj)
    # The older read's analysis (a job that finished late) is used but not stored.
    analysed = sculpt.analyses
    first = evaluate_stack(*older)
    assert sculpt.analyses == analysed + 1 and obj.session_uid not in sculpt._cache
    second = evaluate_stack(*newer)
    assert sculpt.analyses == analysed + 2 and sculpt._cache[obj.session_uid].fine_key == newer[1][0].sculpt.fine_key
    assert np.abs(first.vertices - second.vertices).max() > 1e-3
    np.testing.assert_array_equal(evaluate_stack(*newer).vertices, second.vertices)
    assert sculpt.analyses == analysed + 2, "a hit"
    # Forgotten while it was analysed (Use Sculpt turned off, a file loaded): not stored.
    reshaped(obj, up)
    pending = read_source(obj)
    sculpt.forget(obj)
    evaluate_stack(*pending)
    assert sculpt.analyses == analysed + 3 and obj.session_uid not in sculpt._cache
