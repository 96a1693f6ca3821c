"""The shell kinds, Offset Shell (normal displacement) and Shell (the L_p field,
thick surfaces chapter 4): each builds a shell on the current mesh and reports what
its final check found."""

import hashlib

import numpy as np

from .. import live_shells, native
from .. import settings as S
from ..arrays import MeshArrays
from ..state import ShellContext, State, group_weights

DIRECTOR_ATTRIBUTE = "thicket_director"
LAYER_ATTRIBUTE = "thicket_layer"
THICKNESS_ATTRIBUTE = "thicket_thickness"
RATIO_ATTRIBUTE = "thicket_ratio"

#: Below this share of its target a vertex counts as compressed.
COMPRESSED_BELOW = 0.95


def _shell_result(out, base: MeshArrays):
    """Mesh arrays of a native shell result, with per-vertex shell attributes and the
    base's UV maps and material indices (outer, inner and rim faces alike)."""
    result = base.carried_to(MeshArrays.from_native(out), out["source_corner"], out["source_face"])
    source = out["source_vertex"]
    result.point_attributes = {
        DIRECTOR_ATTRIBUTE: out["directors"][source],
        LAYER_ATTRIBUTE: out["layer"],
    }
    if "achieved" in out:
        result.point_attributes[THICKNESS_ATTRIBUTE] = out["achieved"][source]
        result.point_attributes[RATIO_ATTRIBUTE] = thickness_ratio(out)[source]
    return result, source


def thickness_ratio(out):
    """Achieved / target thickness per base vertex (1 where the target is zero)."""
    target = out["target"]
    ratio = np.ones_like(target)
    np.divide(out["achieved"], target, out=ratio, where=target > 0)
    return ratio


def shell_summary(label, out):
    """What a field shell's final check found and how much it compressed, for the panel."""
    ratio = thickness_ratio(out)[out["target"] > 0]
    check = out["check"]
    return {
        "label": label,
        "min_ratio": float(ratio.min()) if ratio.size else 1.0,
        "mean_ratio": float(ratio.mean()) if ratio.size else 1.0,
        "compressed": int((ratio < COMPRESSED_BELOW).sum()),
        "vertices": int(ratio.size),
        **check,
    }


def summary_text(s) -> str:
    """One panel line for a `shell_summary`."""
    verdict = "no folds or crossings" if s["clean"] else "defects left"
    text = (
        f"{s['label']}: thickness min {s['min_ratio']:.0%}, mean {s['mean_ratio']:.0%} of target; "
        f"{s['compressed']:,} of {s['vertices']:,} vertices compressed; final check: {verdict}"
    )
    if s["check_shortened"]:
        text += f" ({s['check_shortened']:,} shortened by it)"
    return text


def _common_args(mesh: MeshArrays, item, factors):
    args = (mesh.vertices, mesh.face_sizes, mesh.corners, float(item.thickness))
    kwargs = dict(relative=item.relative, factors=factors, output=item.output, surfaces=int(item.surfaces))
    return args, kwargs


def offset_shell(mesh: MeshArrays, item: S.OffsetShell, factors, progress=None):
    args, kwargs = _common_args(mesh, item, factors)
    out = native.get().offset_shell(*args, **kwargs)
    return (*_shell_result(out, mesh), out)


def field_shell(mesh: MeshArrays, item: S.FieldShell, factors, progress=None):
    args, kwargs = _common_args(mesh, item, factors)
    out = live_shells.field_shell(args, dict(kwargs, side=item.side), progress)
    return (*_shell_result(out, mesh), out)


#: Non-manifold edge counts of the last few base topologies (digest -> count): a
#: live edit moves vertices, not faces, and counting anew cost 24-59 ms a step on a
#: 44k-vertex mesh against under 1 ms for the digest.
_non_manifold_counts: dict = {}
_REMEMBERED_TOPOLOGIES = 8


def non_manifold_edges(mesh: MeshArrays) -> int:
    """Edges of `mesh` used by more than two faces (they depend on its faces alone)."""
    digest = hashlib.blake2b(np.ascontiguousarray(mesh.face_sizes).tobytes(), digest_size=16)
    digest.update(np.ascontiguousarray(mesh.corners).tobytes())
    key = (len(mesh.vertices), digest.digest())
    if key not in _non_manifold_counts:
        if len(_non_manifold_counts) >= _REMEMBERED_TOPOLOGIES:
            del _non_manifold_counts[next(iter(_non_manifold_counts))]
        _non_manifold_counts[key] = native.get().mesh_report(mesh.vertices, mesh.face_sizes, mesh.corners)["non_manifold_edges"]
    return _non_manifold_counts[key]


def non_manifold_note(label, mesh: MeshArrays):
    """A note when edges of the shell's base are used by more than two faces: along
    them no shell (nor a bake in it) can be a closed 2-manifold; "" otherwise."""
    count = non_manifold_edges(mesh)
    if not count:
        return ""
    return (
        f"'{label}': {count:,} {'edge' if count == 1 else 'edges'} of the mesh used by more than two faces, so the result is not a closed 2-manifold there "
        "(Select > Select All by Trait > Non Manifold shows them)"
    )


def shell_step(build):
    """A shell kind's step: `build(mesh, item, factors, progress)` on the current mesh
    gives the shell's mesh, each vertex's provenance and the native output."""

    def step(state: State, item, ask, progress):
        factors = group_weights(state.source, item.vertex_group, state.origin)
        base, base_origin = state.current, state.origin
        state.current, provenance, out = build(base, item, factors, progress)
        state.shell = ShellContext(base, out, base_origin)
        note = non_manifold_note(item.label, base)
        if note:
            state.notes.append(note)
        if "check" in out:
            state.summaries.append(shell_summary(item.label, out))
        state.origin = base_origin[provenance]

    return step
