"""thicket_native called directly with numpy arrays (as scripts and the add-on do)."""

import numpy as np
import pytest

import thicket_native as tn

CUBE_V = np.array([[x, y, z] for z in (-1, 1) for y in (-1, 1) for x in (-1, 1)], np.float32)
CUBE_F = np.array([[0, 2, 3, 1], [4, 5, 7, 6], [0, 1, 5, 4], [1, 3, 7, 5], [3, 2, 6, 7], [2, 0, 4, 6]], np.int32)


def test_offset_moves_cube_corners_along_diagonals():
    out = tn.offset_shell(CUBE_V, np.full(6, 4, np.int32), CUBE_F.ravel(), 0.5)
    moved = out["vertices"] - CUBE_V[out["source_vertex"]]
    expected = CUBE_V[out["source_vertex"]] / np.sqrt(3) * 0.5
    np.testing.assert_allclose(moved, expected, atol=1e-6)
    assert out["vertices"].dtype == np.float32 and out["corners"].dtype == np.int32
    assert out["directors"].shape == (8, 3)


def test_relative_thickness_and_factors():
    factors = np.linspace(0, 1, 8, dtype=np.float32)
    out = tn.offset_shell(CUBE_V, np.full(6, 4, np.uint32), CUBE_F.astype(np.uint32).ravel(), 0.1, relative=True, factors=factors)
    lengths = np.linalg.norm(out["directors"], axis=1)
    np.testing.assert_allclose(lengths, factors * 0.1 * np.sqrt(12), rtol=1e-5, atol=1e-7)


def test_solid_output_is_closed():
    out = tn.offset_shell(CUBE_V, np.full(6, 4, np.int32), CUBE_F.ravel(), 0.2, output="solid")
    report = tn.mesh_report(out["vertices"], out["face_sizes"], out["corners"])
    assert report["closed_manifold"] and report["faces"] == 12


@pytest.mark.parametrize(
    "vertices, sizes, corners, message",
    [
        (CUBE_V, np.full(6, 4, np.int32), np.arange(24, dtype=np.int32), "refers to vertex"),
        (CUBE_V, np.full(6, 4, np.int32), -np.ones(24, np.int32), "negative index"),
        (CUBE_V, np.array([2], np.int32), np.array([0, 1], np.int32), "at least 3"),
        (CUBE_V[:, :2].copy(), np.array([3], np.int32), np.array([0, 1, 2], np.int32), "shape"),
        (np.zeros((0, 3), np.float32), np.zeros(0, np.int32), np.zeros(0, np.int32), "empty"),
    ],
)
def test_structural_errors_are_thicket_errors(vertices, sizes, corners, message):
    with pytest.raises(tn.ThicketError, match=message):
        tn.offset_shell(vertices, sizes, corners, 0.1)


def test_nan_coordinates_named():
    v = CUBE_V.copy()
    v[3, 1] = np.nan
    with pytest.raises(tn.ThicketError, match="vertex 3 has a non-finite"):
        tn.offset_shell(v, np.full(6, 4, np.int32), CUBE_F.ravel(), 0.1)


@pytest.mark.parametrize("thickness", [0.0, float("nan"), float("inf"), 1e9])
def test_absurd_thickness_refused(thickness):
    with pytest.raises(tn.ThicketError, match="thickness"):
        tn.offset_shell(CUBE_V, np.full(6, 4, np.int32), CUBE_F.ravel(), thickness)


def test_non_contiguous_input_refused_not_crashing():
    strided = np.zeros((8, 6), np.float32)[:, ::2]
    with pytest.raises(tn.ThicketError, match="contiguous"):
        tn.offset_shell(strided, np.full(6, 4, np.int32), CUBE_F.ravel(), 0.1)


def test_thicket_error_is_a_value_error():
    assert issubclass(tn.ThicketError, ValueError)


def test_errors_are_typed_by_kind(tmp_path):
    """Each kind of failure has its own ThicketError subclass, so scripts can tell bad
    input from a missing file, a GPU problem, a cancel or a bug."""
    kinds = (tn.InvalidInput, tn.FileError, tn.DeviceError, tn.Cancelled, tn.InternalError)
    assert all(issubclass(k, tn.ThicketError) for k in kinds)
    assert len(set(kinds)) == 5 and not any(issubclass(a, b) for a in kinds for b in kinds if a is not b)
    # Bad input, from the binding's own checks and from the core's.
    with pytest.raises(tn.InvalidInput, match="contiguous"):
        tn.offset_shell(np.zeros((8, 6), np.float32)[:, ::2], np.full(6, 4, np.int32), CUBE_F.ravel(), 0.1)
    with pytest.raises(tn.InvalidInput, match="thickness"):
        tn.offset_shell(CUBE_V, np.full(6, 4, np.int32), CUBE_F.ravel(), float("nan"))
    # A missing texture folder.
    with pytest.raises(tn.FileError):
        tn.load_texture(str(tmp_path / "missing"))
    # A cancel from the progress callback.
    with pytest.raises(tn.Cancelled):
        tn.shell(CUBE_V, np.full(6, 4, np.int32), CUBE_F.ravel(), 0.1, relative=True, progress=lambda fraction: False)


def _stub():
    """The module's stub (rust/py/thicket_native.pyi, shipped in the wheel), parsed."""
    import ast
    import pathlib

    path = pathlib.Path(__file__).parents[1] / "rust" / "py" / "thicket_native.pyi"
    return ast.parse(path.read_text())


def _stub_parameters(function):
    """(name, has a default, kind) of a stubbed function's parameters, `self` left out."""
    import inspect

    P = inspect.Parameter
    args = function.args
    positional = [(a, P.POSITIONAL_ONLY) for a in args.posonlyargs] + [(a, P.POSITIONAL_OR_KEYWORD) for a in args.args]
    defaults = [False] * (len(positional) - len(args.defaults)) + [True] * len(args.defaults)
    out = [(a.arg, d, kind) for (a, kind), d in zip(positional, defaults) if a.arg != "self"]
    out += [(args.vararg.arg, False, P.VAR_POSITIONAL)] if args.vararg else []
    out += [(a.arg, d is not None, P.KEYWORD_ONLY) for a, d in zip(args.kwonlyargs, args.kw_defaults)]
    return out + ([(args.kwarg.arg, False, P.VAR_KEYWORD)] if args.kwarg else [])


def _real_parameters(callable_):
    import inspect

    parameters = inspect.signature(callable_).parameters.values()
    return [(p.name, p.default is not inspect.Parameter.empty, p.kind) for p in parameters if p.name != "self"]


def _stub_only(name):
    """The stub's own typing helpers (the keyword settings' TypedDicts): not in the module."""
    return name.startswith("_")


def test_the_stub_matches_the_module():
    """Every public function, class and exception of thicket_native is in the stub,
    with the module's own parameter names, order, kinds and defaults; and nothing else."""
    import ast

    tree = _stub()
    functions = {n.name: n for n in tree.body if isinstance(n, ast.FunctionDef) and not _stub_only(n.name)}
    classes = {n.name: n for n in tree.body if isinstance(n, ast.ClassDef) and not _stub_only(n.name)}
    public = {name for name in dir(tn) if not name.startswith("_") and name != "thicket_native"}
    assert public == set(functions) | set(classes), public ^ (set(functions) | set(classes))
    for name, node in functions.items():
        assert _stub_parameters(node) == _real_parameters(getattr(tn, name)), name
    for name, node in classes.items():
        real = getattr(tn, name)
        if issubclass(real, BaseException):
            base = node.bases[0].id
            assert real.__mro__[1].__name__ == base, (name, base)
            continue
        methods = {m.name: m for m in node.body if isinstance(m, ast.FunctionDef)}
        assert _stub_parameters(methods["__init__"]) == _real_parameters(real), name
        members = {m for m in vars(real) if not m.startswith("_")}
        assert members == {m for m in methods if not m.startswith("_")}, (name, members)
        for member in members:
            if callable(getattr(real, member)):
                assert _stub_parameters(methods[member]) == _real_parameters(getattr(real, member)), (name, member)


def _stub_settings():
    """The keys of each keyword-settings TypedDict in the stub (its bases' included),
    and which TypedDict each function's `**settings` is."""
    import ast

    tree = _stub()
    dicts = {n.name: n for n in tree.body if isinstance(n, ast.ClassDef) and _stub_only(n.name)}

    def keys(name):
        node = dicts[name]
        inherited = {k for b in node.bases if isinstance(b, ast.Name) and b.id in dicts for k in keys(b.id)}
        return inherited | {s.target.id for s in node.body if isinstance(s, ast.AnnAssign)}

    def settings_of(function):
        return keys(function.args.kwarg.annotation.slice.id)

    functions = {n.name: settings_of(n) for n in tree.body if isinstance(n, ast.FunctionDef) and n.args.kwarg}
    for node in (n for n in tree.body if isinstance(n, ast.ClassDef) and not _stub_only(n.name)):
        for method in (m for m in node.body if isinstance(m, ast.FunctionDef) and m.args.kwarg):
            functions[f"{node.name}.{method.name}"] = settings_of(method)
    return functions, set().union(*map(keys, dicts))


def test_each_function_takes_exactly_the_keyword_settings_its_stub_names():
    """`**settings` is read by name in the binding (one list for the four textured-shell
    entry points): each function reads every key of its stub's TypedDict (a value of
    the wrong kind is refused as that argument) and refuses any other, as Python
    refuses an unexpected keyword argument; `render_shell` takes no triangle budget."""
    sizes, corners = np.full(6, 4, np.int32), CUBE_F.ravel()
    shell = tn.offset_shell(CUBE_V, sizes, corners, 0.3)
    args = (CUBE_V, sizes, corners, np.zeros_like(shell["directors"]), shell["directors"], [tn.texture("rivets", size=(8, 8, 4))])
    camera = (np.eye(4, dtype=np.float32), np.eye(4, dtype=np.float32), 8, 8)
    handle = tn.TexturedShell(*args, resolution=2, depth_steps=4)
    calls = {
        "bake_texture": lambda **kw: tn.bake_texture(*args, **kw),
        "estimate_bake": lambda **kw: tn.estimate_bake(*args, **kw),
        "fit_bake_tiles": lambda **kw: tn.fit_bake_tiles(*args, tile_size=0.5, **kw),
        "render_shell": lambda **kw: tn.render_shell(*args, *camera, **kw),
        "TexturedShell.__init__": lambda **kw: tn.TexturedShell(*args, **kw),
        "TexturedShell.render": lambda **kw: handle.render(*camera, **kw),
        "Shell.textured": lambda **kw: tn.Mesh(*args[:3]).shell(0.3).textured(args[5], **kw),
    }
    functions, every_key = _stub_settings()
    assert set(functions) == set(calls)
    assert "triangle_budget" in functions["bake_texture"] and "triangle_budget" not in functions["render_shell"]
    for name, call in calls.items():
        for key in sorted(every_key | {"resolutoin", "progres"}):
            with pytest.raises(Exception) as raised:
                call(**{key: object()})
            unexpected = isinstance(raised.value, TypeError) and "unexpected keyword argument" in str(raised.value)
            assert unexpected == (key not in functions[name]), (name, key, raised.value)
            if unexpected:
                assert f"'{key}'" in str(raised.value)
            elif isinstance(raised.value, TypeError):
                assert str(raised.value).startswith(f"argument '{key}':"), (name, key, raised.value)


def test_a_textured_shell_handle_gives_what_the_functions_give():
    """Read and checked once, the handle bakes, estimates and renders as bake_texture,
    estimate_bake and render_shell do with the same arguments; bad input raises when
    it is made."""
    sizes, corners = np.full(6, 4, np.int32), CUBE_F.ravel()
    shell = tn.offset_shell(CUBE_V, sizes, corners, 0.3)
    args = (CUBE_V, sizes, corners, np.zeros_like(shell["directors"]), shell["directors"], [tn.texture("rivets", size=(16, 16, 8))])
    settings = dict(resolution=4, depth_steps=8, holes=(CUBE_V[:, 0] > 0).astype(np.float32))
    handle = tn.TexturedShell(*args, **settings)
    assert handle.vertex_count == 8
    baked, direct = handle.bake(), tn.bake_texture(*args, **settings)
    assert len(direct["corners"]) > 0
    for key in ("vertices", "corners", "normals", "texcoords", "source_face"):
        np.testing.assert_array_equal(baked[key], direct[key], err_msg=key)
    assert handle.estimate() == tn.estimate_bake(*args, **settings)
    fractions = []
    handle.bake(progress=fractions.append)
    assert fractions and fractions[-1] == 1.0
    view = np.array([[1, 0, 0, 0], [0, 0, 1, 0], [0, -1, 0, -6], [0, 0, 0, 1]], np.float32)
    projection = np.array([[2, 0, 0, 0], [0, 2, 0, 0], [0, 0, -1.02, -0.2], [0, 0, -1, 0]], np.float32)
    for _ in range(2):  # the second frame from the kept scene
        frame = handle.render(view, projection, 24, 24, method="reference")
        want = tn.render_shell(*args, view, projection, 24, 24, method="reference", **{k: v for k, v in settings.items()})
        np.testing.assert_array_equal(frame["rgba"], want["rgba"])
    assert frame["rgba"][..., 3].max() > 0.5, "the cube is in view"
    with pytest.raises(tn.InvalidInput, match="resolution"):
        tn.TexturedShell(*args, resolution=0)
    with pytest.raises(tn.ThicketError, match="render method"):
        handle.render(view, projection, 24, 24, method="raytrace")


def test_the_former_layers_keyword_works_for_one_release_with_a_warning():
    """ "layers" meant two settings here: the shell functions' count of surfaces (now
    `surfaces`) and the textured shell's lattice steps across the shell (now
    `depth_steps`). The old keyword gives the same result with a DeprecationWarning;
    both names at once are refused, whatever the values."""
    import warnings

    sizes, corners = np.full(6, 4, np.int32), CUBE_F.ravel()
    want = tn.offset_shell(CUBE_V, sizes, corners, 0.3, output="layers", surfaces=3)
    assert len(want["vertices"]) == 3 * 8
    shells = {
        "offset_shell": lambda **kw: tn.offset_shell(CUBE_V, sizes, corners, 0.3, output="layers", **kw)["vertices"],
        "shell": lambda **kw: tn.shell(CUBE_V, sizes, corners, 0.3, output="layers", **kw)["vertices"],
        "IncrementalShell": lambda **kw: tn.IncrementalShell(CUBE_V, sizes, corners, 0.3, output="layers", **kw).result()["vertices"],
    }
    for name, call in shells.items():
        with pytest.warns(DeprecationWarning, match=rf"{name}\(\): keyword 'layers' is deprecated .* use 'surfaces'"):
            old = call(layers=3)
        np.testing.assert_array_equal(old, call(surfaces=3), err_msg=name)
        for surfaces in (2, 1):  # also the default: both names given is ambiguous whatever the values
            with pytest.raises(TypeError, match="former name 'layers'"):
                call(surfaces=surfaces, layers=3)

    args = (CUBE_V, sizes, corners, np.zeros_like(want["directors"]), want["directors"], [tn.texture("rivets", size=(8, 8, 4))])
    calls = {
        "estimate_bake": lambda **kw: tn.estimate_bake(*args, resolution=2, **kw),
        "bake_texture": lambda **kw: len(tn.bake_texture(*args, resolution=2, **kw)["vertices"]),
        "TexturedShell": lambda **kw: tn.TexturedShell(*args, resolution=2, **kw).estimate(),
    }
    for name, call in calls.items():
        with pytest.warns(DeprecationWarning, match=rf"{name}\(\): keyword 'layers' is deprecated .* use 'depth_steps'"):
            old = call(layers=5)
        assert old == call(depth_steps=5) != call(depth_steps=12), name
        with pytest.raises(TypeError, match="former name 'layers'"):
            call(depth_steps=5, layers=5)
        with pytest.raises(TypeError, match="argument 'layers'"):
            call(layers="five")
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        tn.estimate_bake(*args, resolution=2, depth_steps=4)  # the new names warn about nothing
