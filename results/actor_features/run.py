"""``PLAN.md``: exact GPs on the raw observations and on PPO's actor features, on the batches
the drop-in PPO default's GP critic is fed on Acrobot-v1 (one call per core; ``S64_STREAMS``
is where ``results/model_ceiling/laplacian.py`` recorded session 64's, optional)::

    python results/actor_features/run.py --seeds 0 2 4 6 8 --streams STREAMS \\
        --check S64_STREAMS --out results/actor_features/a
    python results/actor_features/run.py --seeds 1 3 5 7 9 --streams STREAMS \\
        --check S64_STREAMS --out results/actor_features/b
    python results/actor_features/run.py --extra --seeds 0 2 4 6 8 --streams STREAMS \\
        --out results/actor_features/c        # and seeds 1 3 5 7 9 into d
    python results/actor_features/read.py --plot results/actor_features/read.png \\
        --streams STREAMS > results/actor_features/read.md
"""

from __future__ import annotations

import argparse
import copy
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np
import torch as th
from tqdm.auto import tqdm

from sb3_geogp.comparison.run import write_json_atomic
from sb3_geogp.studies.exact_gp import exact_gp
from sb3_geogp.toolbox.provenance import provenance
from sb3_geogp.toolbox.scripts import load_script

HERE = Path(__file__).resolve().parent
SCHEDULE = load_script(HERE.parents[1] / "examples" / "adaptation_schedule.py", "schedule")
ENV = "Acrobot-v1"
STEPS = 30_000
#: The drop-in PPO default: the Laplacian critic fed as the policy is trained.
RECORDED = {"kernel": "laplacian", "target": None}
#: Points of each maximum-likelihood fit (``PLAN.md``).
FIT_POINTS = 512
Batch = tuple[th.Tensor, th.Tensor, "th.Tensor | None"]


def record(seed: int, streams: Path, steps: int = STEPS) -> tuple[list[Batch], list[th.nn.Module]]:
    """The batches of one run's GP critic (PPO, ``steps`` steps) and a copy of the actor's
    network at each feed, taken before the critic learns that batch (from ``streams`` if
    recorded before)."""
    path = SCHEDULE.stream_path(streams, ENV, seed, steps, RECORDED)
    actors_path = path.with_name(path.stem + "__actors.pt")
    if path.exists() and actors_path.exists():
        return th.load(path, weights_only=False), th.load(actors_path, weights_only=False)
    if path.exists():
        raise FileExistsError(f"{path} was recorded without its actors: remove it to re-record")
    actors: list[th.nn.Module] = []

    def watch(model: Any) -> Callable[[], None]:
        net = model.policy.mlp_extractor.policy_net
        return lambda: actors.append(copy.deepcopy(net).cpu().eval())

    batches = SCHEDULE.record(ENV, seed, steps, path, RECORDED, watch=watch)
    partial = actors_path.with_suffix(".partial")
    th.save(actors, partial)
    partial.replace(actors_path)
    return batches, actors


def same_batches(batches: list[Batch], other: list[Batch]) -> bool:
    """Whether two recordings hold the same batches bit for bit."""
    if len(batches) != len(other):
        return False
    for one, two in zip(batches, other, strict=True):
        for a, b in zip(one, two, strict=True):
            if (a is None) != (b is None) or (a is not None and not th.equal(a, b)):
                return False
    return True


def replay_mapped(
    batches: list[Batch], inputs: Callable[[int, th.Tensor], np.ndarray]
) -> dict[str, Any]:
    """An exact Laplacian GP on the newest batch, its inputs ``inputs(k, x)`` for batch ``k``'s
    actor (the batch learnt last); hyperparameters by maximum likelihood on
    :data:`FIT_POINTS` of its points. Scored as ``adaptation_schedule.py`` scores."""
    kept: list[tuple[th.Tensor, np.ndarray]] = []
    learnt = [0]  # batches learnt so far: the newest is batch learnt - 1
    noise: list[float] = []

    def predict(x: th.Tensor) -> th.Tensor:
        newest = learnt[0] - 1
        fit = exact_gp(
            inputs(newest, kept[-1][0]), kept[-1][1], "laplacian", FIT_POINTS, seed=newest
        )
        noise.append(fit.noise_var)
        return th.as_tensor(fit.predict(inputs(newest, x)))

    def learn(x: th.Tensor, y: th.Tensor, starts: th.Tensor | None) -> None:
        kept.append((x, y.double().numpy()))
        del kept[:-1]
        learnt[0] += 1

    return dict(noise_var=noise, **SCHEDULE._scored(batches, predict, learn))


def actor_inputs(actors: list[th.nn.Module]) -> Callable[[int, th.Tensor], np.ndarray]:
    """The features of actor ``k`` (the one copied when batch ``k`` was fed)."""

    def inputs(k: int, x: th.Tensor) -> np.ndarray:
        with th.no_grad():
            return actors[k](x.float()).double().numpy()

    return inputs


def initial_inputs(actors: list[th.nn.Module]) -> Callable[[int, th.Tensor], np.ndarray]:
    """The features of the actor copied at the first feed, for every batch (``PLAN.md``'s
    addendum)."""
    return actor_inputs(actors[:1] * len(actors))


def raw_inputs(k: int, x: th.Tensor) -> np.ndarray:
    return x.double().numpy()


def run_replays(
    doc: str,
    replays: dict[str, Callable[..., dict[str, Any]]],
    settings: dict[str, Any],
    seeded: bool = False,
) -> None:
    """The command line of a study on these streams (``results/return_noise``,
    ``results/additive_kernel``): ``--seeds``, ``--streams``, ``--out``, ``--steps`` (the
    runs' length, :data:`STEPS` unless given); each seed's batches
    (:func:`record`) replayed by every predictor of ``replays`` (called with the batches, and
    with the seed too where ``seeded``), and ``OUT/results.json``
    written after every seed with ``settings``, the results by env, seed and predictor, and the
    provenance (an interrupted call keeps the seeds it finished)."""
    parser = argparse.ArgumentParser(description=doc.split("\n\n")[0])
    parser.add_argument("--seeds", nargs="+", type=int, required=True)
    parser.add_argument("--streams", type=Path, required=True)
    parser.add_argument("--out", type=Path, required=True)
    parser.add_argument("--steps", type=int, default=STEPS)
    args = parser.parse_args()
    th.set_num_threads(1)
    results: dict[int, Any] = {}
    bar = tqdm(total=len(args.seeds) * len(replays), unit="replay")
    for seed in args.seeds:
        batches, _ = record(seed, args.streams, args.steps)
        results[seed] = {}
        for name, replay in replays.items():
            results[seed][name] = replay(batches, seed) if seeded else replay(batches)
            bar.update()
        args.out.mkdir(parents=True, exist_ok=True)
        write_json_atomic(
            args.out / "results.json",
            {
                **settings,
                "steps": args.steps,
                "results": {ENV: results},
                "provenance": provenance(),
            },
        )


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--seeds", nargs="+", type=int, required=True)
    parser.add_argument("--streams", type=Path, required=True)
    parser.add_argument("--out", type=Path, required=True)
    parser.add_argument("--check", type=Path, default=None, help="session 64's streams")
    parser.add_argument("--extra", action="store_true", help="score the addendum's row only")
    args = parser.parse_args()
    th.set_num_threads(1)
    results: dict[int, Any] = {}
    same: dict[int, bool | None] = {}
    bar = tqdm(total=len(args.seeds) * (2 if args.extra else 4), unit="step")
    for seed in args.seeds:
        batches, actors = record(seed, args.streams)
        bar.update()
        if args.extra:
            results[seed] = {"initial": replay_mapped(batches, initial_inputs(actors))}
            bar.update()
            continue
        old = (
            None
            if args.check is None
            else SCHEDULE.stream_path(args.check, ENV, seed, STEPS, RECORDED)
        )
        same[seed] = (
            None
            if old is None or not old.exists()
            else same_batches(batches, th.load(old, weights_only=False))
        )
        results[seed] = {"default": SCHEDULE.replay(ENV, seed, batches, RECORDED)}
        bar.update()
        results[seed]["raw"] = replay_mapped(batches, raw_inputs)
        bar.update()
        results[seed]["actor"] = replay_mapped(batches, actor_inputs(actors))
        bar.update()
    args.out.mkdir(parents=True, exist_ok=True)
    write_json_atomic(
        args.out / "results.json",
        {
            "recorded": RECORDED,
            "fit_points": FIT_POINTS,
            "same_as_check": same,
            "results": {ENV: results},
            "provenance": provenance(),
        },
    )


if __name__ == "__main__":
    main()
