"""Undoing a sparse GP's failed update: a :class:`Rollback` holds what an update may change,
so that an update (or a hyperparameter fit) that raises leaves the state exactly as it was.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

from torch import Tensor

if TYPE_CHECKING:
    from sb3_geogp.sparse_gp import SparseOnlineGP

#: GP buffers with one row per BV slot, and (m, m) ones.
_PER_SLOT = frozenset(
    {"bv_x", "bv_y", "nugget", "alpha", "summary_shift", "summary_unit", "summary_input"}
)
_SLOT_BY_SLOT = frozenset({"P", "Q", "summary_prec"})


class Rollback:
    """What an update needs to undo itself, copied as little and as late as possible.

    The GP's own buffers are copied up front, those indexed by BV slot only over the slots in
    use (the rest is zero by construction: a deletion zeroes the freed slot); the kernel's own
    buffers (hyperparameters, trajectory bookkeeping) are small and copied up front too; its
    state over the basis (the geodesic kernel's graph) only changes when the basis does, and
    is checkpointed (over the node slots in use) just before the first such change.
    """

    def __init__(self, gp: SparseOnlineGP) -> None:
        self._gp = gp
        self._m = gp.n_basis
        self._own = {
            name: in_use(name, b, self._m).clone() for name, b in gp.named_buffers(recurse=False)
        }
        self._kernel = {name: b.clone() for name, b in gp.kernel.named_buffers(recurse=False)}
        self._window = {name: b.clone() for name, b in gp.window.named_buffers()}
        self._basis_saved = False
        self._basis: Any = None

    def before_basis_change(self) -> None:
        """Checkpoint the kernel's state over the basis, once, before the basis first changes."""
        if not self._basis_saved:
            self._basis = self._gp.kernel.basis_checkpoint()
            self._basis_saved = True

    def restore(self) -> None:
        """Put the GP's buffers, its kernel's and its window's back as they were when the
        rollback was made (the GP's matrix cache is its own to drop)."""
        gp = self._gp
        for name, b in gp.named_buffers(recurse=False):
            if name in _PER_SLOT or name in _SLOT_BY_SLOT:
                b.zero_()
            in_use(name, b, self._m).copy_(self._own[name])
        for name, b in gp.kernel.named_buffers(recurse=False):
            b.copy_(self._kernel[name])
        for name, b in gp.window.named_buffers():
            b.copy_(self._window[name])
        if self._basis_saved:
            gp.kernel.restore_basis(self._basis)


def in_use(name: str, buffer: Tensor, m: int) -> Tensor:
    """The part of the GP buffer ``name`` that holds the ``m`` BVs in use (a view)."""
    if name in _SLOT_BY_SLOT:
        return buffer[:m, :m]
    if name in _PER_SLOT:
        return buffer[:m]
    return buffer
