"""Settings renamed apart (issue 16): "layers" meant the shell output's count of
surfaces, the bake's lattice steps across the shell and the placed textures. Files
saved with the former property names open with their values under the new ones;
scripts with the former names work for one release, with a DeprecationWarning."""

import warnings

import bpy
import pytest
from conftest import add

from thicket import api
from thicket.stack import versioning
from thicket.stack.properties import ThicketItem


def saved_by_the_former_add_on(item, **values):
    """What the add-on before the rename saved: the values as ID properties under
    their former names, and nothing under the new ones."""
    for name, value in values.items():
        item[name] = value
    for new in versioning.RENAMED_ITEM_PROPERTIES.values():
        if new in item.keys():
            del item[new]


def test_a_file_saved_with_the_former_names_opens_with_their_values(scene, tmp_path):
    cube = add("cube")
    shell = api.add_item(cube, "OFFSET_SHELL", thickness=0.1, thickness_mode="ABSOLUTE", output="LAYERS")
    saved_by_the_former_add_on(shell, layers=7)
    sphere = add("uv_sphere")
    api.add_item(sphere, "SHELL")
    saved_by_the_former_add_on(api.add_item(sphere, "VOLUMETRIC_TEXTURE", resolution=3), texture_layers=24)
    api.add_item(sphere, "VOLUMETRIC_TEXTURE")  # never set: keeps the default
    path = str(tmp_path / "former.blend")
    bpy.ops.wm.save_as_mainfile(filepath=path)
    bpy.ops.wm.read_factory_settings(use_empty=True)

    bpy.ops.wm.open_mainfile(filepath=path)
    cube, sphere = bpy.data.objects["Cube"], bpy.data.objects["Sphere"]
    assert cube.thicket.items[0].surfaces == 7
    assert [i.depth_steps for i in sphere.thicket.items[1:]] == [24, 16] and sphere.thicket.items[1].resolution == 3
    for item in (*cube.thicket.items, *sphere.thicket.items):
        assert not set(item.keys()) & set(versioning.RENAMED_ITEM_PROPERTIES), item.keys()
    # And the stack evaluates with them: seven surfaces of the cube's eight vertices.
    assert len(api.regenerate(cube).data.vertices) == 7 * 8


def test_enabling_the_add_on_upgrades_the_open_file(scene):
    """Enabled (or updated) with a file open, the add-on upgrades it once (a timer in
    the interface: bpy.data cannot be read while it registers)."""
    cube = add("cube")
    item = api.add_item(cube, "OFFSET_SHELL", output="LAYERS")
    saved_by_the_former_add_on(item, layers=5)
    assert item.surfaces == 4  # not read under the former name
    assert versioning.upgrade_file() == 1 and item.surfaces == 5
    assert versioning.upgrade_file() == 0  # once
    assert versioning.on_load in bpy.app.handlers.load_post


def test_scripts_with_the_former_names_work_with_a_warning(scene):
    cube = add("cube")
    with pytest.warns(DeprecationWarning, match="'layers' is now called 'surfaces'"):
        item = api.add_item(cube, "OFFSET_SHELL", output="LAYERS", layers=3)
    assert item.surfaces == 3
    with pytest.warns(DeprecationWarning, match="'texture_layers' is now called 'depth_steps'"):
        assert api.add_item(cube, "VOLUMETRIC_TEXTURE", texture_layers=12).depth_steps == 12
    with pytest.raises(TypeError, match="former name"):
        api.add_item(cube, "OFFSET_SHELL", layers=3, surfaces=2)
    sphere = add("ico_sphere", subdivisions=1)
    with pytest.warns(DeprecationWarning, match="surfaces"):
        result = api.add_thick_surface(sphere, thickness=0.1, output="LAYERS", layers=2)
    assert sphere.thicket.items[0].surfaces == 2 and len(result.data.vertices) == 2 * len(sphere.data.vertices)
    with pytest.raises(TypeError, match="unexpected keyword argument 'layer'"):
        api.add_thick_surface(sphere, layer=2)
    # Both names at once are refused, whatever the values; a name of another item is
    # refused as given, without a warning about it.
    for surfaces in (3, 4):
        with pytest.raises(TypeError, match="former name 'layers'"):
            api.add_thick_surface(add("cube"), surfaces=surfaces, layers=5)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        with pytest.raises(TypeError, match="unexpected keyword argument 'texture_layers'"):
            api.add_thick_surface(add("cube"), texture_layers=5)
    # The warning names the script's line, also through add_volumetric_texture.
    with pytest.warns(DeprecationWarning, match="'texture_layers'") as caught:
        api.add_volumetric_texture(add("cube"), texture_layers=8)
    assert caught[0].filename == __file__
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        api.add_item(cube, "OFFSET_SHELL", surfaces=2)  # the new names warn about nothing


def test_no_setting_is_called_layers_any_more():
    """The interface says Surfaces (the Stacked Surfaces output's count) and Depth
    Steps (the bake's samples across the shell), never the ambiguous Layers."""
    props = ThicketItem.bl_rna.properties
    labels = {p.identifier: p.name for p in props}
    assert labels["surfaces"] == "Surfaces" and labels["depth_steps"] == "Depth Steps"
    assert not [name for name in labels.values() if "layer" in name.lower()]
    assert not {"layers", "texture_layers"} & set(labels)
    output = {e.identifier: e.name for e in props["output"].enum_items}
    assert output["LAYERS"] == "Stacked Surfaces"
    for p in props:
        assert "Layers" not in p.description, (p.identifier, p.description)


def test_a_headless_script_enabling_the_add_on_after_opening_a_file_upgrades_it(scene, tmp_path):
    """Background mode runs no timers: enabling the add-on after opening an old file
    upgrades it at once (it was left with the former names)."""
    import thicket

    cube = add("cube")
    saved_by_the_former_add_on(api.add_item(cube, "OFFSET_SHELL", output="LAYERS"), layers=6)
    path = str(tmp_path / "former.blend")
    bpy.ops.wm.save_as_mainfile(filepath=path)
    thicket.unregister()
    try:
        bpy.ops.wm.open_mainfile(filepath=path)  # no handler of Thicket's runs
    finally:
        thicket.register()
    item = bpy.data.objects["Cube"].thicket.items[0]
    assert item.surfaces == 6 and "layers" not in item.keys()


def test_enabled_while_blender_restricts_its_data_the_next_regeneration_upgrades(scene, monkeypatch):
    """Blender's add-on enabling (Preferences, --addons) runs register() with bpy.data
    restricted; headless, no timer runs then, so the next regeneration upgrades."""
    cube = add("cube")
    item = api.add_item(cube, "OFFSET_SHELL", output="LAYERS")
    saved_by_the_former_add_on(item, layers=3)
    data = bpy.data
    monkeypatch.setattr(bpy, "data", object())  # what RestrictBlend puts in its place
    versioning.register()
    monkeypatch.setattr(bpy, "data", data)
    assert item.surfaces != 3 and "layers" in item.keys()
    api.regenerate(cube)
    assert item.surfaces == 3 and "layers" not in item.keys()


def test_values_left_under_the_former_names_are_read(scene):
    """Linked objects cannot be upgraded (read-only): what their file saved under the
    former names is still what the stack evaluates."""
    cube = add("cube")
    shell = api.add_item(cube, "OFFSET_SHELL", output="LAYERS")
    texture = api.add_item(cube, "VOLUMETRIC_TEXTURE")
    saved_by_the_former_add_on(shell, layers=6)
    saved_by_the_former_add_on(texture, texture_layers=20)
    assert shell.to_settings().surfaces == 6 and texture.to_settings().depth_steps == 20
    shell.surfaces, texture.depth_steps = 3, 9  # a value under the current name wins
    assert shell.to_settings().surfaces == 3 and texture.to_settings().depth_steps == 9
