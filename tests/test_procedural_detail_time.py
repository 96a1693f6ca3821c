"""Time in procedural detail (Velho et al. section 3: "an animation time parameter can
feed into (i) any synthesized shape definition, (ii) the synthesized alpha, and (iii)
the post-processing shader"), through `thicket_native.procedural_detail(..., time=)`
and the stack item's Animate With Frame. Each animated result is compared with the
static result of the settings that time should give, computed independently."""

import numpy as np
import pytest
from conftest import add, positions

import thicket_native as tn
from thicket import api, mesh_io
from thicket.pure.field_tree import COLOR_ATTRIBUTE
from thicket.pure.kinds.procedural_detail import BLEND_ATTRIBUTE


def sphere_arrays(subdivisions=2):
    obj = add("ico_sphere", subdivisions=subdivisions)
    return obj, mesh_io.read_mesh(obj.data)


def detail(a, model, levels, params, **kw):
    return tn.procedural_detail(a.vertices, a.face_sizes, a.corners, model, levels, 4, params, **kw)


@pytest.mark.parametrize("model, size", [("rock", "amplitude"), ("spur", "length"), ("mushroom", "length"), ("fuse", "amplitude")])
def test_a_growing_model_has_its_share_of_the_size_at_each_time(scene, model, size):
    _, a = sphere_arrays()

    def grown(t):
        return detail(a, model, 2, {size: 0.04, "grow": 2.0}, time=t)["vertices"]

    def static(s):
        return detail(a, model, 2, {size: s})["vertices"]

    np.testing.assert_allclose(grown(0.5), static(0.01), atol=1e-6)
    np.testing.assert_allclose(grown(7.0), static(0.04), atol=1e-6)
    np.testing.assert_allclose(grown(0.0), static(0.0), atol=1e-6)
    assert np.abs(grown(0.5) - grown(1.5)).max() > 1e-3, "it grows between times"


def test_a_spinning_tentacle_turns_by_spin_times_time(scene):
    _, a = sphere_arrays()
    spun = detail(a, "tentacle", 3, {"length": 0.02, "theta": 0.3, "spin": 0.4}, time=2.5)["vertices"]
    turned = detail(a, "tentacle", 3, {"length": 0.02, "theta": 1.3})["vertices"]
    still = detail(a, "tentacle", 3, {"length": 0.02, "theta": 0.3})["vertices"]
    np.testing.assert_allclose(spun, turned, atol=1e-6)
    assert np.abs(spun - still).max() > 1e-3
    # Without spin (the default), time does not turn it.
    np.testing.assert_array_equal(detail(a, "tentacle", 3, {"length": 0.02, "theta": 0.3}, time=2.5)["vertices"], still)


def test_a_sweeping_blend_is_the_plane_moved_back_by_sweep_times_time(scene):
    _, a = sphere_arrays()
    diag = float(np.linalg.norm(a.vertices.max(0) - a.vertices.min(0)))
    direction = np.array([1.0, 2.0, 0.0]) / np.sqrt(5.0)
    blend = lambda point, sweep: dict(model="berry", params={"radius": 0.1}, seed=2, plane=(tuple(point), tuple(direction)), width=0.2, sweep=sweep)  # noqa: E731
    swept = detail(a, "rock", 3, {"amplitude": 0.02}, blend=blend((0.0, 0.0, 0.0), 0.05), time=3.0)
    moved = detail(a, "rock", 3, {"amplitude": 0.02}, blend=blend(-0.15 * diag * direction, 0.0))
    np.testing.assert_allclose(swept["blend"], moved["blend"], atol=1e-5)
    np.testing.assert_allclose(swept["vertices"], moved["vertices"], atol=1e-5)
    before = detail(a, "rock", 3, {"amplitude": 0.02}, blend=blend((0.0, 0.0, 0.0), 0.05), time=0.0)
    assert swept["blend"].mean() > before["blend"].mean() + 0.05, "the second model's side grew"


def test_the_shader_moves_its_sea_and_snow_by_their_rates(scene):
    _, a = sphere_arrays()
    shader = lambda **k: dict(name="planet", sea=0.0, snow=0.02, **k)  # noqa: E731
    later = detail(a, "rock", 3, {"amplitude": 0.03}, shader=shader(sea_rate=0.002, snow_rate=-0.001), time=4.0)
    static = detail(a, "rock", 3, {"amplitude": 0.03}, shader=dict(name="planet", sea=0.008, snow=0.016))
    np.testing.assert_array_equal(later["vertices"], static["vertices"])
    np.testing.assert_allclose(later["colors"], static["colors"], atol=1e-5)
    now = detail(a, "rock", 3, {"amplitude": 0.03}, shader=shader(sea_rate=0.002, snow_rate=-0.001))
    # The rising sea floods land: more vertices are blue-dominant later.
    sea = lambda c: int(np.sum(c[:, 2] > c[:, 1]))  # noqa: E731
    assert sea(later["colors"]) > sea(now["colors"])
    # A sea risen past the snow line (0.03 against 0.02 at time 3) carries the snow line
    # up to a tenth of the land band (0.002) above it: the frame renders as that static
    # shader, not refused.
    flooded = detail(a, "rock", 3, {"amplitude": 0.03}, shader=shader(sea_rate=0.01), time=3.0)
    static = detail(a, "rock", 3, {"amplitude": 0.03}, shader=dict(name="planet", sea=0.03, snow=0.032))
    np.testing.assert_allclose(flooded["colors"], static["colors"], atol=1e-5)
    assert np.isfinite(flooded["colors"]).all() and sea(flooded["colors"]) > sea(later["colors"])


def test_bad_times_and_motions_are_refused(scene):
    _, a = sphere_arrays(1)
    with pytest.raises(tn.InvalidInput, match="time"):
        detail(a, "rock", 1, {"amplitude": 0.02}, time=float("nan"))
    with pytest.raises(tn.InvalidInput, match="grow"):
        detail(a, "rock", 1, {"amplitude": 0.02, "grow": -1.0}, time=1.0)
    with pytest.raises(tn.InvalidInput, match="snow above sea"):
        detail(a, "rock", 1, {"amplitude": 0.02}, shader=dict(name="planet", sea=0.02, snow=0.0, sea_rate=0.01), time=3.0)
    with pytest.raises(TypeError, match="spin"):
        detail(a, "berry", 1, {"radius": 0.1, "spin": 1.0})


def test_the_planet_item_animates_its_sea_blend_and_growth_with_the_frame(scene):
    obj = add("ico_sphere", subdivisions=2)
    before = positions(obj).copy()
    api.add_procedural_detail(obj, preset="PLANET", levels=3, follow_frame=True, grow=2.0, sweep=0.05, sea_rate=0.002)
    item = obj.thicket.items[0]
    assert item.follows_frame()
    scene.render.fps, scene.render.fps_base = 24, 1.0
    a = mesh_io.read_mesh(obj.data)

    def native_at(t):
        f = lambda x: float(np.float32(x))  # noqa: E731  (single-precision properties)
        params = {"amplitude": f(item.detail_amplitude), "grow": 2.0}
        partner = {"amplitude": f(item.detail_amplitude) * f(item.blend_gain), "grow": 2.0}
        blend = dict(model="rock", params=partner, seed=2, width=f(item.blend_width), sweep=f(0.05), plane=((0.0, 0.0, 0.0), (1.0, 2.0, 0.0)))
        shader = dict(name="planet", sea=0.0, snow=f(item.shader_snow), sea_rate=f(0.002), snow_rate=0.0)
        return tn.procedural_detail(a.vertices, a.face_sizes, a.corners, "rock", 3, 0, params, blend=blend, shader=shader, time=t)

    results = {}
    for frame in (12, 36, 60):
        scene.frame_set(frame)  # regenerated at once, headless
        out = obj.thicket.result.data
        want = native_at(frame / 24.0)
        np.testing.assert_allclose(positions(obj.thicket.result), want["vertices"], atol=1e-6, err_msg=f"frame {frame}")
        colors = np.empty((len(out.vertices), 4), np.float32)
        out.attributes[COLOR_ATTRIBUTE].data.foreach_get("color", colors.ravel())
        np.testing.assert_allclose(colors, want["colors"], atol=1e-5)
        blend = np.empty(len(out.vertices), np.float32)
        out.attributes[BLEND_ATTRIBUTE].data.foreach_get("value", blend)
        results[frame] = (positions(obj.thicket.result).copy(), colors, blend)
    assert np.abs(results[12][0] - results[36][0]).max() > 1e-3, "still growing at 1.5 s"
    assert results[60][2].mean() > results[12][2].mean(), "the blend swept on"
    np.testing.assert_array_equal(positions(obj), before)


def test_a_still_item_does_not_follow_the_frame(scene):
    obj = add("ico_sphere", subdivisions=1)
    api.add_procedural_detail(obj, preset="ROCK", levels=2, follow_frame=True)
    item = obj.thicket.items[0]
    assert not item.follows_frame(), "nothing moves with time: no regeneration per frame"
    item.detail_grow = 1.0
    assert item.follows_frame()
    item.detail_model = "BERRY"
    assert not item.follows_frame(), "the berry does not grow"
    item.follow_frame = False
    item.detail_model = "ROCK"
    assert not item.follows_frame()
    # Not following the frame, the detail is full grown (time 0 would be nothing).
    assert obj.thicket.items[0].to_settings().grow == 0.0
