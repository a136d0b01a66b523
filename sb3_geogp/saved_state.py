"""States saved by a sparse GP: what a state saved by an older version lacks, and the checks a
state passes before anything of it is loaded (a refused state leaves the GP as it was).

Each addition to the state since 0.1 has an entry here that fills it in as the older version
behaved, so that every saved model loads and predicts as it did.
"""

from __future__ import annotations

import copy
from collections.abc import Mapping
from typing import TYPE_CHECKING, Any

import torch
from torch import nn

from sb3_geogp.adaptation import as_adaptation
from sb3_geogp.rollback import in_use

if TYPE_CHECKING:
    from sb3_geogp.sparse_gp import SparseOnlineGP

#: Stored options that may differ on load (they only steer later updates).
UPDATE_RULES = (
    "novelty_tol",
    "forgetting",
    "forgetting_points",
    "adapt",
    "optimism",
    "optimism_cap",
    "drift_forgetting",
)
#: Options added to the state after 0.2, as the versions before them behaved: 0.8
#: (prior_mean, trend), 0.13 (forgetting_points), 0.18 (optimism), 0.19 (optimism_cap),
#: 0.36 (drift_forgetting), 0.44 (lengthscale_rule).
_OPTIONS_BEFORE = {
    "prior_mean": "constant",
    "trend": "none",
    "forgetting_points": None,
    "optimism": 0.0,
    "optimism_cap": None,
    "drift_forgetting": 0.0,
    "lengthscale_rule": "spread",
}


#: Buffers a state saved before the version named lacks, and what their zeros mean there.
_ZERO_BEFORE = {
    "block_moments": "0.6, drift refits: the open block's targets count from the next batch",
    "block_errors": "0.10, fit refits: the open block's errors count as none",
    "summary_batch": "0.11, snapshots: the summary holds only points that left the window",
    "last_batch_points": "0.12, lagged scores: the previous batch counts as its window points",
    "y_slope": "0.8, the linear prior mean: a constant one",
    "summary_input": "0.8, the linear prior mean: no input shifts in the summary",
    "trend_coef": "0.8, trends: none",
    "bonus_spreads": "0.19, the bonus cap: no spreads yet",
    "window.decay": "0.36, drift forgetting: no retained point has lost weight to drift",
    "refit_seen": "0.38, fit spacing: no refit since the first point",
    "ls_from_data": "0.42, spread-following lengthscales: none follows",
}


def state_to_restore(module: nn.Module, assign: bool) -> dict[str, Any]:
    """What puts ``module`` back as it was after a ``load_state_dict(..., assign=assign)``
    refused half-way, loaded back with the same ``assign``.

    Copies of its state, copied back into its tensors; with ``assign`` its own tensors, assigned
    back: the refused load put the caller's tensors in their place, which copying into would
    overwrite, and an optimizer keeps pointing at the parameters it holds.
    """
    if assign:
        return dict(module.state_dict(keep_vars=True))
    return {
        k: v.clone() if isinstance(v, torch.Tensor) else copy.deepcopy(v)
        for k, v in module.state_dict().items()
    }


def upgrade_options(options: Any) -> Any:
    """Stored options with those an older version did not store set as it behaved (anything
    but a dict is returned as it is, for the options check to refuse)."""
    return {**_OPTIONS_BEFORE, **options} if isinstance(options, dict) else options


def upgrade(state: dict[str, Any], prefix: str, gp: SparseOnlineGP) -> None:
    """Add to ``state``, in place, every buffer of ``gp`` that a state saved by an older
    version lacks (entries under ``prefix``), as that version behaved; and start the open block
    unscored where its scores score other forgetting candidates than ``gp``'s (``adapt`` may
    change on load)."""
    _upgrade_v01(state, prefix, gp)
    _upgrade_v02(state, prefix, gp)
    _upgrade_between_releases(state, prefix, gp)
    scores = state.get(prefix + "forgetting_scores")
    # Unscored scores (zeros) stay as given: with ``assign`` they are the tensors loaded.
    if (
        scores is None
        or scores.shape != gp.forgetting_scores.shape
        or (bool(scores.any()) and not _scored_alike(state.get(prefix + "_extra_state"), gp))
    ):
        state[prefix + "forgetting_scores"] = torch.zeros_like(gp.forgetting_scores)
    for name in _ZERO_BEFORE:
        state.setdefault(prefix + name, torch.zeros_like(gp.get_buffer(name)))


#: What a prediction reads of a state: none of it may be NaN or inf (over the BVs in use).
_PREDICTS = (
    "alpha", "P", "Q", "bv_x", "nugget", "noise_var", "y_mean", "y_scale", "y_slope",
    "trend_coef", "summary_prec", "summary_shift", "summary_unit", "summary_input",
    "kernel.variance",
)  # fmt: skip


def _scored_alike(options: Any, gp: SparseOnlineGP) -> bool:
    """Whether the open block's forgetting scores of a state saved with ``options`` score
    ``gp``'s candidates: the same candidates in the same order, by the same score, over the
    same points (scores are kept by position)."""
    options = upgrade_options(options)
    saved = options.get("adapt") if isinstance(options, dict) else None
    if not isinstance(saved, dict) or gp.adaptation is None:
        return False
    try:
        then = as_adaptation(saved)
    except (TypeError, ValueError):  # settings this version refuses: the options check says so
        return False
    rule = ("forgetting", "forgetting_score", "score_points")
    same = all(getattr(then, k) == getattr(gp.adaptation, k) for k in rule)
    return same and options.get("forgetting_points") == gp.forgetting_points


def check_posterior(state: Mapping[str, Any], prefix: str, max_basis: int) -> None:
    """Refuse a saved basis count that a GP of ``max_basis`` cannot hold, or a state with NaN
    or inf in what predictions read (its used part), or a fitted GP's lengthscales (current or
    starting) not finite and positive (a corrupted save)."""
    count = state.get(prefix + "count")
    if count is None:
        return
    m = int(count)
    if not 0 <= m <= max_basis + 1:
        raise ValueError(
            f"the saved state has {m} basis vectors, which a GP with max_basis="
            f"{max_basis} cannot hold: it is corrupted or from another GP"
        )
    for name in _PREDICTS:
        saved = state.get(prefix + name)
        if saved is not None and not bool(torch.isfinite(in_use(name, saved, m)).all()):
            raise ValueError(
                f"the saved state's {name} holds NaN or inf: the GP it came from was "
                "corrupted; load an earlier save"
            )
    # Before its first batch a GP's lengthscales may hold NaN: chosen from that batch.
    initialized = state.get(prefix + "initialized")
    if not (bool(initialized) if initialized is not None else m > 0):
        return
    for name in ("kernel.lengthscale", "ls_start"):  # the adaptation starts from ls_start
        saved = state.get(prefix + name)
        if saved is not None and not bool(((saved > 0) & torch.isfinite(saved)).all()):
            raise ValueError(
                f"the saved state's {name} holds NaN, inf or values not above 0: the GP it "
                "came from was corrupted; load an earlier save"
            )


def _upgrade_v02(state: dict[str, Any], prefix: str, gp: SparseOnlineGP) -> None:
    """Add, in place, what a state saved before the retained window (sb3_geogp 0.1, 0.2) lacks:
    an empty window, no closed block, and the saved lengthscale as the starting one; and what
    one saved by 0.2 lacks: an empty summary of the points that left the window, and batch
    indices for the window (from 0.2's block indices, so that a point's age in batches is its
    age in blocks: its weight is that of 0.2)."""
    for name in ("summary_prec", "summary_shift", "summary_unit", "summary_input"):
        if prefix + name not in state:
            state[prefix + name] = torch.zeros_like(getattr(gp, name))
    if prefix + "window.block" in state:
        # 0.2 counted ages in blocks, not batches: a retained point keeps its age, in batches.
        offset = state[prefix + "n_batches"] - state[prefix + "n_blocks"]
        state[prefix + "window.batch"] = state.pop(prefix + "window.block") + offset
    # Counters that start at 0: a state without the window lacks them all, code with the
    # window but before the pruning counter (between 0.1.0 and 0.2.0) lacks n_pruned.
    for name in ("n_blocks", "block_new", "n_pruned"):
        state.setdefault(prefix + name, torch.zeros((), dtype=torch.long))
    if prefix + "window.count" in state:
        return
    extra = state.get(prefix + "_extra_state")
    if isinstance(extra, dict):
        state[prefix + "_extra_state"] = {**extra, "window": gp.window.size, "adapt": None}
    for name, value in gp.window.state_dict().items():
        state[prefix + "window." + name] = value
    state[prefix + "block_forgetting"] = torch.tensor(gp.forgetting, dtype=gp.noise_var.dtype)
    saved = state.get(prefix + "kernel.lengthscale")
    state[prefix + "ls_start"] = gp.ls_start.clone() if saved is None else saved.clone()


def _upgrade_between_releases(state: dict[str, Any], prefix: str, gp: SparseOnlineGP) -> None:
    """Fill in, in place, what states saved by the repository's code between the 0.1.0 and
    0.2.0 releases lack or hold beyond any release: the first 0.1.0 code had no novelty floor
    (its threshold was ``novelty_tol``), code with the window but before the pruning counter
    saved no ``n_pruned`` (:func:`_upgrade_v02` fills it in), and some 0.2.0 code saved a
    ``block_start`` that nothing reads now (loaded, each predicts as its code did)."""
    state.setdefault(prefix + "novelty_floor", torch.tensor(gp.novelty_tol, dtype=torch.float64))
    state.pop(prefix + "block_start", None)


def _upgrade_v01(state: dict[str, Any], prefix: str, gp: SparseOnlineGP) -> None:
    """Rename, in place, the entries of a state saved by sb3_geogp 0.1 (SB3 models included).

    0.1 kept the BV graph, each BV's graph node and the trajectory's last node in the GP; they
    now belong to the kernel (the BV nodes as the graph's ``basis_nodes``). 0.1 stored no
    options: they are taken as this GP's (they cannot be checked).
    """
    if prefix + "bv_node" not in state:
        return
    state[prefix + "_extra_state"] = gp.get_extra_state()
    state[prefix + "kernel._extra_state"] = gp.kernel.get_extra_state()
    bv_node = state.pop(prefix + "bv_node")
    traj_node = state.pop(prefix + "traj_node")
    graph = gp.kernel.graph
    if graph is None:
        return
    for key in [k for k in state if k.startswith(prefix + "graph.")]:
        state[prefix + "kernel.tree." + key[len(prefix + "graph.") :]] = state.pop(key)
    basis_nodes = torch.full((graph.capacity,), -1, dtype=torch.long)
    basis_nodes[: bv_node.shape[0]] = bv_node
    state[prefix + "kernel.tree.basis_nodes"] = basis_nodes
    state[prefix + "kernel.traj_node"] = traj_node
