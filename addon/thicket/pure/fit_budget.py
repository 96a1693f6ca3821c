"""A Volumetric Texture's tiles grown to its Triangle Budget, without Blender: the
items above it run as the stack runs them (`evaluate.state_before`), then the
kind's search (`kinds.volumetric_texture.fit_budget`). Kept out of `evaluate`, which
knows no kind."""

from . import settings as S
from .arrays import MeshArrays
from .evaluate import scaled_progress, state_before
from .kinds.volumetric_texture import BudgetFit, fit_budget, texture_weights
from .state import StackError

#: The share of `fit_texture_budget`'s progress the items before the texture take.
FIT_SHELL_SHARE = 0.2


def fit_texture_budget(source: MeshArrays, items, index, progress=None) -> BudgetFit:
    """Tiles grown to the Triangle Budget of the Volumetric Texture `items[index]`
    (`volumetric_texture.fit_budget`: the item settings that give them, and the
    search's result): the items before it run as `evaluate_stack` runs them (its
    shell), then the search, nothing baked. `progress`: as `evaluate_stack`'s."""
    item = items[index]
    if not isinstance(item, S.VolumetricTexture):
        raise StackError(f"'{item.label}' is no Volumetric Texture: only a bake has a Triangle Budget")
    state = state_before(source, items, index, scaled_progress(progress, 0.0, FIT_SHELL_SHARE))
    if state.shell is None:
        raise StackError(f"'{item.label}' needs a Shell or Offset Shell above it in the stack")
    fit = fit_budget(state.shell, item, texture_weights(state, item), scaled_progress(progress, FIT_SHELL_SHARE, 1.0))
    if progress is not None:
        progress(1.0)
    return fit
