"""field_mesh's size safety (issue 17's bad input: "resolutions whose output would not
fit in memory: a clear message, nothing changed"): field_mesh_estimate against the
meshes it estimates, the memory limit refusing a huge resolution at once, progress and
cancel through the callback, and the GIL released while meshing."""

import json
import resource
import threading
import time

import pytest

import thicket_native as tn

SPHERE = {"op": "sphere", "center": [0.03, -0.02, 0.01], "radius": 0.7}
TORUS = {"op": "torus", "center": [0, 0, 0], "axis": [0.2, 1, 0.3], "major": 0.6, "minor": 0.22}
UNION = {
    "op": "union_wp",
    "p": 8,
    "children": [
        {"op": "sphere", "center": [0, 0, 0], "radius": 0.45},
        {"op": "box", "center": [0.5, 0.2, -0.1], "half_size": [0.2, 0.15, 0.3]},
        {"op": "segment", "a": [-0.8, -0.2, -0.6], "b": [0.8, 0.2, 0.6], "radius": 0.06},
    ],
}
#: A sphere rippled by equation 1 along a plane: about three times a sphere's area.
RIPPLED = {
    "op": "displace",
    "shape": {"op": "sphere", "center": [0, 0, 0], "radius": 0.6},
    "texture": {"op": "plane", "point": [0, 0, 0], "normal": [1, 0.3, 0.2]},
    "amplitude": 0.05,
    "omega": 40,
}


@pytest.mark.parametrize("node", [SPHERE, TORUS, UNION, RIPPLED], ids=["sphere", "torus", "union", "rippled"])
@pytest.mark.parametrize("resolution, adaptive", [(48, True), (150, True), (260, True), (48, False), (120, False)])
def test_the_estimate_is_within_one_and_a_half_times_the_mesh(node, resolution, adaptive):
    text = json.dumps(node)
    e = tn.field_mesh_estimate(text, resolution=resolution, adaptive=adaptive)
    out = tn.field_mesh(text, resolution=resolution, adaptive=adaptive)
    faces, vertices = len(out["face_sizes"]), len(out["vertices"])
    assert 1 / 1.5 < e["faces"] / faces < 1.5, (e, faces)
    assert 1 / 1.5 < e["vertices"] / vertices < 1.5, (e, vertices)
    assert e["triangles"] == (2 * e["faces"] if adaptive else e["faces"])
    assert tuple(e["cells"]) == tuple(out["cells"])
    assert e["fits"] and e["max_bytes"] == 4e9 and 0 < e["peak_bytes"] < 4e9
    if resolution <= 64 and adaptive:
        assert e["faces"] == faces, "counted on the lattice meshed, the estimate is exact"


def max_rss_mb():
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024


def test_a_huge_resolution_is_refused_at_once_with_the_estimate_and_the_limit():
    text = json.dumps(RIPPLED)
    e = tn.field_mesh_estimate(text, resolution=2048)
    assert not e["fits"] and e["peak_bytes"] > 4e9 and 256 < e["resolution_within"] < 2048
    before = max_rss_mb()
    start = time.perf_counter()
    with pytest.raises(
        tn.OverLimit,
        match=r"resolution 2048 \(.* cells\) would make about .* vertices and .* quads and need about .* GB at its peak, over the memory limit of 4.00 GB: use about \d+ cells or fewer",
    ):
        tn.field_mesh(text, resolution=2048)
    elapsed = time.perf_counter() - start
    assert elapsed < 2.0, f"refusing took {elapsed:.2f} s"
    assert max_rss_mb() - before < 100, "the refusal allocated"
    # The marching prisms' planes alone pass a small limit; the resolution it proposes fits.
    with pytest.raises(tn.OverLimit, match="over the memory limit of 0.05 GB"):
        tn.field_mesh(json.dumps(SPHERE), resolution=512, adaptive=False, max_bytes=50e6)
    small = tn.field_mesh_estimate(json.dumps(SPHERE), resolution=512, max_bytes=50e6)
    fit = small["resolution_within"]
    assert tn.field_mesh_estimate(json.dumps(SPHERE), resolution=fit, max_bytes=50e6)["fits"]
    assert len(tn.field_mesh(json.dumps(SPHERE), resolution=fit, max_bytes=50e6)["vertices"]) > 0
    with pytest.raises(tn.InvalidInput, match="max_bytes must be a positive number"):
        tn.field_mesh(json.dumps(SPHERE), resolution=16, max_bytes=0)


def test_progress_rises_to_one_and_a_cancel_from_the_callback_raises_cancelled():
    text = json.dumps(RIPPLED)
    for adaptive in (True, False):
        seen = []
        out = tn.field_mesh(text, resolution=160, adaptive=adaptive, progress=seen.append)
        assert seen[0] == 0.0 and seen[-1] == 1.0 and seen == sorted(seen), seen
        assert len(out["vertices"]) > 0
        calls = []

        def cancel(fraction, calls=calls):
            calls.append(fraction)
            return fraction < 0.05

        start = time.perf_counter()
        with pytest.raises(tn.Cancelled):
            tn.field_mesh(text, resolution=400, adaptive=adaptive, progress=cancel)
        assert time.perf_counter() - start < 5.0 and calls[-1] < 0.5, calls
    with pytest.raises(tn.Cancelled):
        tn.field_mesh(text, resolution=64, progress=lambda fraction: False)


def test_the_gil_is_released_while_meshing():
    text = json.dumps(RIPPLED)
    done = threading.Event()
    ticks = 0

    def work():
        tn.field_mesh(text, resolution=256)
        done.set()

    worker = threading.Thread(target=work)
    start = time.perf_counter()
    worker.start()
    while not done.is_set():
        ticks += 1
        time.sleep(0.001)
    worker.join()
    elapsed = time.perf_counter() - start
    # Held, the main thread would wait for the whole mesh: a tick or two.
    assert elapsed > 0.1 and ticks > 0.3 * elapsed / 0.0011, (ticks, elapsed)
