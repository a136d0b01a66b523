"""Shared pieces of the benchmark scripts: kernel variants, pendulum batches, text tables."""

from __future__ import annotations

import contextlib
import hashlib
from collections.abc import Iterator, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import torch

from sb3_geogp.experiments.data import pendulum_rollouts
from sb3_geogp.sparse_gp import SparseOnlineGP, make_kernel


@dataclass(frozen=True)
class Variant:
    """A named configuration of :class:`SparseOnlineGP`.

    Attributes
    ----------
    label : str
        Name printed in tables.
    kernel : str
        ``"rbf"`` or ``"geodesic"``.
    kernel_options : dict
        Keyword arguments of the kernel (defaults otherwise).
    gp_options : dict
        Keyword arguments of :class:`SparseOnlineGP` besides ``max_basis`` (e.g. ``forgetting``).
    """

    label: str
    kernel: str
    kernel_options: dict[str, Any] = field(default_factory=dict)
    gp_options: dict[str, Any] = field(default_factory=dict)

    def build(self, input_dim: int, max_basis: int) -> SparseOnlineGP:
        """An empty model of this variant with capacity ``max_basis``."""
        kernel = make_kernel(self.kernel, **self.kernel_options)  # type: ignore[arg-type]
        return SparseOnlineGP(input_dim, kernel, max_basis=max_basis, **self.gp_options)


@dataclass(frozen=True)
class Rollout:
    """States ``x`` (n, d), discounted returns ``y`` (n,) and episode ``starts`` (n,), float64."""

    x: torch.Tensor
    y: torch.Tensor
    starts: torch.Tensor

    @classmethod
    def pendulum(cls, n_points: int, seed: int) -> Rollout:
        """``pendulum_rollouts(n_points, seed)`` as tensors."""
        x, y, starts = pendulum_rollouts(n_points, seed=seed)
        return cls(torch.as_tensor(x), torch.as_tensor(y), torch.as_tensor(starts))

    def __len__(self) -> int:
        return int(self.y.shape[0])

    def slice(self, start: int, stop: int) -> Rollout:
        """Rows ``start:stop``."""
        return Rollout(self.x[start:stop], self.y[start:stop], self.starts[start:stop])

    def feed(self, gp: SparseOnlineGP) -> None:
        """``gp.update`` with the whole rollout (in order, with its episode starts)."""
        gp.update(self.x, self.y, self.starts)


def pendulum_stream(
    n_points: int, batch_size: int, chunk_batches: int = 16, first_seed: int = 1
) -> Iterator[Rollout]:
    """Pendulum transitions in batches of ``batch_size``, ``n_points`` in total.

    Rollouts are generated in chunks of ``chunk_batches`` batches with seeds ``first_seed``,
    ``first_seed + 1``, ...; a batch may end inside an episode (as a PPO rollout buffer does),
    a chunk starts a new one.
    """
    seed, remaining = first_seed, n_points
    while remaining > 0:
        chunk = Rollout.pendulum(min(remaining, chunk_batches * batch_size), seed)
        for start in range(0, len(chunk), batch_size):
            yield chunk.slice(start, start + batch_size)
        remaining -= len(chunk)
        seed += 1


def format_cell(value: Any) -> str:
    """Render one table cell: floats with 4 significant digits, ``None`` as ``-``."""
    if value is None:
        return "-"
    if isinstance(value, bool):
        return "yes" if value else "NO"
    if isinstance(value, float):
        return f"{value:.4g}"
    return str(value)


def format_table(rows: Sequence[Mapping[str, Any]], columns: Sequence[str]) -> str:
    """Left-aligned text table of ``rows`` restricted to ``columns``.

    Parameters
    ----------
    rows : sequence of mappings
        One mapping per row; missing keys print as ``-``.
    columns : sequence of str
        Column keys, also used as headers.

    Returns
    -------
    str
        Header, rule and one line per row.
    """
    cells = [[format_cell(row.get(col)) for col in columns] for row in rows]
    widths = [max([len(col)] + [len(r[i]) for r in cells]) for i, col in enumerate(columns)]
    lines = ["  ".join(col.ljust(w) for col, w in zip(columns, widths, strict=True))]
    lines.append("  ".join("-" * w for w in widths))
    lines += ["  ".join(c.ljust(w) for c, w in zip(r, widths, strict=True)) for r in cells]
    return "\n".join(lines)


@contextlib.contextmanager
def torch_threads(threads: int | None) -> Iterator[None]:
    """Run with ``threads`` torch (and, with threadpoolctl, BLAS) threads; ``None`` = as is.

    torch's thread count is restored afterwards.
    """
    before = torch.get_num_threads()
    if threads is not None:
        torch.set_num_threads(threads)
    try:
        with _blas_threads(threads):
            yield
    finally:
        torch.set_num_threads(before)


def _blas_threads(threads: int | None) -> contextlib.AbstractContextManager[Any]:
    """Limit NumPy's BLAS threads too (threadpoolctl ships with scikit-learn), if installed."""
    if threads is None:
        return contextlib.nullcontext()
    try:
        from threadpoolctl import threadpool_limits
    except ImportError:
        return contextlib.nullcontext()
    return threadpool_limits(limits=threads)


def engine_fingerprint() -> dict[str, str]:
    """Short SHA-256 of the engine's source files, to tie results to the code they measured."""
    package = Path(__file__).resolve().parents[1]
    return {
        name: hashlib.sha256((package / name).read_bytes()).hexdigest()[:12]
        for name in ("sparse_gp.py", "kernels.py", "graph.py")
    }
