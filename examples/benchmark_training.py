"""Training wall clock of the critics inside SB3, and where the GP critic's time goes.

Two workloads with rl-baselines3-zoo's hyperparameters (as recorded for the critic
comparison): PPO on Pendulum-v1 and A2C on CartPole-v1 (a GP critic that does not adapt with
``forgetting=0.9``, as ``sb3-geogp train --no-adapt`` gives it; an adapting one starts from the
policy's default, as the drop-in's does: up to session 50 this benchmark started A2C's adapting
critics from 0.9 too). Two more run when named: ``--workloads "PPO Taxi-v4"``,
discrete observations, 500 one-hot columns for the GP, with SB3's PPO defaults in 4 envs; and
``"PPO CartPole-v1"`` (the zoo's 32-step rollouts in 8 envs, 30,000 steps as in the critic
comparison), where PPO feeds its critic most often. For every
seed the runs are interleaved (workload by workload, critic by critic), so a change in the
machine's load hits all critics alike; the table shows the median over seeds of the wall
clock, its ratio to the MLP critic's, and for the GP critics the seconds spent in GP updates,
in GP predictions, in measuring how far the actor moved (the policy's ``measure_drift``, which
a critic with ``drift_forgetting``, PPO's default since 0.37, runs at every rollout's end) and
in everything else; with ``--adapt``
also the GP critics with adaptation, and the seconds their updates spent on it (out-of-sample
statistics, summary of dropped points, adaptation proper) with its share of the GP critic's
time, the drift measurement counted in both.
``--critics`` picks the critics instead: a kernel, optionally followed by ``+adapt`` (the
policy's default adaptation for the workload's algorithm,
:func:`~sb3_geogp.policies.default_adaptation`: the default critic under PPO is
``laplacian+adapt``), ``+cheap`` (:data:`~sb3_geogp.CHEAP_ADAPTATION`) and, for the geodesic
kernel, ``+shared`` (0.3's one lengthscale factor, ``kernel_kwargs=dict(ard=False)``),
``+notrend`` (no trend: the critic before 0.9, whose PPO default moves a level), ``+f1``
(``forgetting=1.0``, per batch: the start before 0.14, whose PPO critic starts from 0.1 per
4,096 points, :data:`~sb3_geogp.policies.DEFAULT_FORGETTING`, wherever it adapts),
``+nodrift`` (``drift_forgetting=0``: PPO's critic before 0.37), and
after ``+adapt`` or ``+cheap`` by other adaptation settings (``+gapN``: ``max_gap=N``;
``+thinN``: ``score_points`` and ``fold_points`` N; ``+scoreN``, ``+foldN``: one of them;
``+stepsN``; ``+floorN``: ``fit_floor=N/100``; ``+priorN``: ``prior_sd=N/100``; ``+nosettle``:
``settle=False``; ``+snapshot``: ``summary="snapshot"``; ``+lagged``:
``forgetting_score="lagged"``; ``+whole``: ``whole_batch=True``; ``+follow``, ``+widen``:
``follow_spread=True``, ``"widen"``; and anywhere ``+returns``,
``GPValueCallback(target="returns")``,
SB3's returns as the GP's targets instead of the algorithm's default, and ``+everyN``,
``GPValueCallback(feed_every=N)``, the GP fed every N-th rollout, ``+basisN``,
``max_basis=N`` for this critic, and ``+actornorm``, the policy's
``normalize_actor_obs=True``); settings after
``+adapt`` start from :class:`~sb3_geogp.Adaptation`'s defaults, so ``laplacian+adapt+gap1+f1``
is PPO's critic before 0.10, a refit every block, ``+adapt+score256`` folds every point, and
``laplacian+adapt+gap16+nosettle+score256+fold256+floor80+snapshot+f1`` is 0.13's PPO critic,
without ``+f1`` 0.22's, with ``+prior10`` instead 0.23's with ``+returns``; the default critic
under PPO, ``laplacian+adapt``, is 0.25's),
so that the cost of an option is measured interleaved with the default's.

``--threads default`` leaves torch's thread count as a new user has it (the engine then runs
its own work single-threaded, see ``SparseOnlineGP(num_threads=...)``); ``--load N`` keeps N
busy processes running during the benchmark, to measure a loaded machine. Example::

    python examples/benchmark_training.py --seeds 0 1 --out runs/benchmark_training.json
    python examples/benchmark_training.py --seeds 0 1 --threads default --load 2
    python examples/benchmark_training.py --workloads "PPO Pendulum-v1" \\
        --critics geodesic+adapt geodesic+adapt+shared geodesic+adapt+thin512+gap4
    python examples/benchmark_training.py --workloads "PPO Pendulum-v1" \\
        --critics mlp laplacian+adapt laplacian+cheap
    python examples/benchmark_training.py --workloads "PPO Pendulum-v1" \\
        --critics mlp laplacian+adapt laplacian+adapt+notrend
"""

from __future__ import annotations

import argparse
import json
import multiprocessing as mp
import os
import statistics
import time
from collections.abc import Iterator, Sequence
from contextlib import contextmanager
from pathlib import Path
from typing import Any

import torch as th
from stable_baselines3 import A2C, PPO
from stable_baselines3.common.env_util import make_vec_env

from sb3_geogp import CHEAP_ADAPTATION, GPActorCriticPolicy, GPValueCallback
from sb3_geogp.comparison.hyperparams import ALL_CRITICS, CRITICS, algo_kwargs, hyperparams
from sb3_geogp.kernels import kernel_names, kernels_taking
from sb3_geogp.toolbox.benchmarks import GPClock
from sb3_geogp.toolbox.provenance import provenance
from sb3_geogp.toolbox.scripts import DefaultsHelpFormatter, count_arg

#: Workload -> (algorithm, its name, environment, steps, options of a GP critic that does not
#: adapt).
WORKLOADS = {
    "PPO Pendulum-v1": (PPO, "ppo", "Pendulum-v1", 102_400, {}),
    "A2C CartPole-v1": (A2C, "a2c", "CartPole-v1", 30_000, {"forgetting": 0.9}),
    "PPO Taxi-v4": (PPO, "ppo", "Taxi-v4", 20_480, {}),
    "PPO CartPole-v1": (PPO, "ppo", "CartPole-v1", 30_000, {}),
}
#: The workloads run without ``--workloads`` (those of every published run of the benchmark).
DEFAULT_WORKLOADS = ("PPO Pendulum-v1", "A2C CartPole-v1")
#: Hyperparameters of the workloads with no built-in entry (rl-baselines3-zoo has none for
#: Taxi-v4): SB3's PPO defaults with 4 envs of 512 steps, as results/discrete_obs/ppo.yml.
OWN_ENTRIES: dict[str, dict[str, Any]] = {"Taxi-v4": {"n_envs": 4, "n_steps": 512}}
#: GP critics with adaptation (``gp_kwargs=dict(adapt=True)``), measured with ``--adapt``; the
#: Laplacian one with the policy's options for it (``novelty_tol=0.1``) is the default critic
#: under PPO.
ADAPTIVE = ("rbf+adapt", "geodesic+adapt", "laplacian+adapt")
#: What a suffix of a critic's name adds to its ``gp_kwargs``.
SUFFIXES: dict[str, dict[str, Any]] = {
    "adapt": {"adapt": True},
    "cheap": {"adapt": CHEAP_ADAPTATION.as_dict()},
    "shared": {"kernel_kwargs": {"ard": False}},
    "notrend": {"trend": "none"},
    "f1": {"forgetting": 1.0},
    "nodrift": {"drift_forgetting": 0.0},
}
#: Suffixes with a count (after ``+adapt``): the :class:`~sb3_geogp.adaptation.Adaptation`
#: settings they give it and what the count is divided by, e.g. ``+gap4`` (``max_gap=4``),
#: ``+thin512`` (``score_points`` and ``fold_points`` 512), ``+fold1024``, ``+steps2``, ``+floor80``
#: (``fit_floor=0.8``), ``+prior10`` (``prior_sd=0.1``), ``+spacing4096`` (``fit_spacing=4096``).
SETTING_SUFFIXES: dict[str, tuple[tuple[str, ...], int]] = {
    "gap": (("max_gap",), 1),
    "thin": (("score_points", "fold_points"), 1),
    "score": (("score_points",), 1),
    "fold": (("fold_points",), 1),
    "steps": (("steps",), 1),
    "floor": (("fit_floor",), 100),
    "prior": (("prior_sd",), 100),
    "spacing": (("fit_spacing",), 1),
}
#: Suffixes with a count anywhere after the kernel, and the GP option the count sets:
#: ``+basis128`` (``max_basis=128``, for this critic instead of ``--max-basis``).
GP_COUNTS: dict[str, str] = {"basis": "max_basis"}
#: Suffixes that configure ``GPValueCallback`` instead of the GP, and its options they set.
CALLBACK_SUFFIXES: dict[str, dict[str, Any]] = {"returns": {"target": "returns"}}
#: Suffixes with a count that configure ``GPValueCallback``, and the option the count sets:
#: ``+every4`` (``feed_every=4``).
CALLBACK_COUNTS: dict[str, str] = {"every": "feed_every"}
#: Suffixes that configure the policy instead of the GP, and its options they set.
POLICY_SUFFIXES: dict[str, dict[str, Any]] = {"actornorm": {"normalize_actor_obs": True}}
#: Suffixes without a count (after ``+adapt``) and the settings they give it.
SETTING_FLAGS: dict[str, dict[str, Any]] = {
    "nosettle": {"settle": False},
    "snapshot": {"summary": "snapshot"},
    "lagged": {"forgetting_score": "lagged"},
    "whole": {"whole_batch": True},
    "follow": {"follow_spread": True},
    "widen": {"follow_spread": "widen"},
}


def callback_option(suffix: str) -> dict[str, Any] | None:
    """The ``GPValueCallback`` options one suffix sets (``None``: it sets none)."""
    name = suffix.rstrip("0123456789")
    count = int(suffix[len(name) :] or 0)
    if name in CALLBACK_COUNTS and count >= 1:
        return {CALLBACK_COUNTS[name]: count}
    return CALLBACK_SUFFIXES.get(suffix)


def callback_kwargs_of(suffixes: Sequence[str]) -> dict[str, Any]:
    """The ``GPValueCallback`` options the suffixes of a GP critic's name set."""
    return {k: v for s in suffixes for k, v in (callback_option(s) or {}).items()}


def gp_kwargs_of(suffixes: Sequence[str]) -> dict[str, Any] | None:
    """What the suffixes of a GP critic's name add to its ``gp_kwargs`` (``None``: a suffix
    is unknown, or a setting suffix comes without ``+adapt``); :data:`CALLBACK_SUFFIXES` add
    nothing."""
    options: dict[str, Any] = {}
    settings: dict[str, Any] = {}
    for suffix in suffixes:
        if callback_option(suffix) is not None or suffix in POLICY_SUFFIXES:
            continue
        name = suffix.rstrip("0123456789")
        count = suffix[len(name) :]
        if suffix in SUFFIXES:
            options.update(SUFFIXES[suffix])
        elif name in GP_COUNTS and count:
            options[GP_COUNTS[name]] = int(count)
        elif suffix in SETTING_FLAGS:
            settings.update(SETTING_FLAGS[suffix])
        elif name in SETTING_SUFFIXES and count:
            names, divisor = SETTING_SUFFIXES[name]
            value = int(count) if divisor == 1 else int(count) / divisor
            settings.update(dict.fromkeys(names, value))
        else:
            return None
    adapt = options.get("adapt")
    if settings and adapt is None:
        return None
    if settings:
        options["adapt"] = {**(adapt if isinstance(adapt, dict) else {}), **settings}
    return options


def critic_name(text: str) -> str:
    """``text`` if it names a critic (``mlp``, or a kernel with known suffixes), else an
    argparse error listing them."""
    kernel, *suffixes = text.split("+")
    known = kernel in ALL_CRITICS and (kernel != "mlp" or not suffixes)
    if not known or gp_kwargs_of(suffixes) is None:
        counted = " +".join([*(f"{k}N" for k in SETTING_SUFFIXES), *SETTING_FLAGS])
        counts = (f"{k}N" for k in (*GP_COUNTS, *CALLBACK_COUNTS))
        anywhere = [*SUFFIXES, *CALLBACK_SUFFIXES, *POLICY_SUFFIXES, *counts]
        raise argparse.ArgumentTypeError(
            f"unknown critic {text!r}: use one of {ALL_CRITICS}, a GP kernel optionally followed "
            f"by +{' +'.join(anywhere)}"
            ", and after +adapt or +cheap by "
            f"+{counted} (e.g. "
            "geodesic+adapt+shared, geodesic+adapt+thin512+gap4)"
        )
    for option in (gp_kwargs_of(suffixes) or {}).get("kernel_kwargs", {}):
        takers = kernels_taking(option)  # +shared: the geodesic kernel's ard
        if kernel not in takers:
            raise argparse.ArgumentTypeError(
                f"critic {text!r}: {option!r} is an option of {kernel_names(takers)}, not of "
                f"the {kernel} kernel"
            )
    return text


def critic_gp_kwargs(workload: str, critic: str, max_basis: int) -> dict[str, Any]:
    """A GP critic's ``gp_kwargs``: its kernel and what its suffixes add, and the workload's
    options where it does not adapt (an adapting one gets the policy's defaults)."""
    kernel, *suffixes = critic.split("+")
    gp_kwargs: dict[str, Any] = dict(kernel=kernel, max_basis=max_basis, adapt=False)
    gp_kwargs.update(gp_kwargs_of(suffixes) or {})
    fixed = WORKLOADS[workload][4]
    return {**fixed, **gp_kwargs} if gp_kwargs["adapt"] is False else gp_kwargs


def run(workload: str, critic: str, seed: int, max_basis: int, scale: float) -> dict[str, Any]:
    """Train once; wall clock, and for a GP critic the seconds in its updates and predictions."""
    algo_cls, algo, env_id, steps, _ = WORKLOADS[workload]
    entry = OWN_ENTRIES.get(env_id) or hyperparams(algo, env_id).values
    n_envs, kwargs, policy_kwargs = algo_kwargs(algo, entry)
    env = make_vec_env(env_id, n_envs=n_envs, seed=seed)
    seconds = {"update": 0.0, "predict": 0.0, "adaptation": 0.0, "drift": 0.0}
    if critic == "mlp":
        model = algo_cls("MlpPolicy", env, seed=seed, policy_kwargs=policy_kwargs, **kwargs)
        callback = None
    else:
        suffixes = critic.split("+")[1:]
        gp_kwargs = critic_gp_kwargs(workload, critic, max_basis)
        policy_kwargs = {**policy_kwargs, "gp_kwargs": gp_kwargs}
        for suffix in suffixes:
            policy_kwargs.update(POLICY_SUFFIXES.get(suffix, {}))
        model = algo_cls(GPActorCriticPolicy, env, seed=seed, policy_kwargs=policy_kwargs, **kwargs)
        clock = GPClock(model.policy.gp)
        clock.time(model.policy, "measure_drift", "drift")
        seconds = clock.seconds
        callback = GPValueCallback(**callback_kwargs_of(suffixes))
    start = time.perf_counter()
    model.learn(int(steps * scale), callback=callback)
    wall = time.perf_counter() - start
    env.close()
    return {"wall": wall, **seconds}


def _spin() -> None:
    while True:
        pass


@contextmanager
def background_load(n: int) -> Iterator[None]:
    """``n`` busy processes for the duration of the block (a loaded machine)."""
    procs = [mp.get_context("spawn").Process(target=_spin, daemon=True) for _ in range(n)]
    for p in procs:
        p.start()
    try:
        yield
    finally:
        for p in procs:
            p.terminate()
            p.join()


def adaptation_share(run: dict[str, float]) -> float:
    """The share of one run's GP critic time (updates, predictions, drift measurement) spent
    on adaptation, the drift measurement included (runs recorded before 0.37 have none)."""
    drift = run.get("drift", 0.0)
    return (run.get("adaptation", 0.0) + drift) / (run["update"] + run["predict"] + drift)


def table(results: dict[str, dict[str, list[dict[str, Any]]]]) -> str:
    """Medians per workload and critic; wall clocks relative to the MLP critic's, or to the
    first critic's where the MLP was not run."""
    critics = list(next(iter(results.values())))
    reference = "mlp" if "mlp" in critics else critics[0]
    lines = [
        f"| workload | critic | wall s | x {reference} | GP update s | GP predict s | drift s "
        "| rest s | adaptation s | adaptation / GP |",
        "|---|---|---|---|---|---|---|---|---|---|",
    ]
    for workload, by_critic in results.items():
        ref = statistics.median(r["wall"] for r in by_critic[reference])
        for critic, runs in by_critic.items():
            wall = statistics.median(r["wall"] for r in runs)
            cells = [f"{wall:.1f}", f"{wall / ref:.2f}"]
            if critic == "mlp":
                cells += ["–"] * 6
            else:
                upd = statistics.median(r["update"] for r in runs)
                pred = statistics.median(r["predict"] for r in runs)
                drift = statistics.median(r.get("drift", 0.0) for r in runs)
                adapt = statistics.median(r.get("adaptation", 0.0) for r in runs)
                share = statistics.median(adaptation_share(r) for r in runs)
                cells += [f"{upd:.2f}", f"{pred:.2f}", f"{drift:.2f}"]
                cells += [f"{wall - upd - pred - drift:.1f}"]
                adaptive = "adapt" in (gp_kwargs_of(critic.split("+")[1:]) or {})
                cells += [f"{adapt:.2f}", f"{share:.0%}"] if adaptive else ["–", "–"]
            lines.append(f"| {workload} | {critic} | " + " | ".join(cells) + " |")
    return "\n".join(lines)


def main(argv: Sequence[str] | None = None) -> None:
    parser = argparse.ArgumentParser(
        description=__doc__.split("\n\n")[0], formatter_class=DefaultsHelpFormatter
    )
    parser.add_argument("--seeds", type=int, nargs="+", default=[0, 1])
    parser.add_argument("--max-basis", type=count_arg, default=256)
    parser.add_argument(
        "--threads", default="1", help="torch threads for the whole run, or 'default'"
    )
    parser.add_argument("--load", type=int, default=0, help="busy background processes")
    parser.add_argument("--scale", type=float, default=1.0, help="multiply the step budgets")
    parser.add_argument(
        "--workloads", nargs="+", default=list(DEFAULT_WORKLOADS), choices=WORKLOADS
    )
    parser.add_argument(
        "--adapt", action="store_true", help="also the GP critics with adapt=True, interleaved"
    )
    parser.add_argument(
        "--critics",
        nargs="+",
        type=critic_name,
        default=None,
        help="critics to run instead, e.g. geodesic+adapt geodesic+adapt+shared",
    )
    parser.add_argument("--out", type=Path, default=None, help="write the figures as JSON")
    args = parser.parse_args(argv)
    critics = tuple(args.critics or CRITICS + (ADAPTIVE if args.adapt else ()))
    if args.threads != "default":
        th.set_num_threads(int(args.threads))
    record = provenance()  # at the start: the code the runs import
    results: dict[str, dict[str, list[dict[str, Any]]]] = {
        w: {c: [] for c in critics} for w in args.workloads
    }
    with background_load(args.load):
        for seed in args.seeds:
            for workload in args.workloads:
                for critic in critics:
                    r = run(workload, critic, seed, args.max_basis, args.scale)
                    results[workload][critic].append(r)
                    print(
                        f"seed {seed} {workload} {critic:9s} {r['wall']:7.1f} s "
                        f"(update {r['update']:.2f} s, predict {r['predict']:.2f} s, "
                        f"of which adaptation {r['adaptation']:.2f} s; drift {r['drift']:.2f} s)",
                        flush=True,
                    )
    header = (
        f"seeds {args.seeds}, max_basis={args.max_basis}, torch threads "
        f"{th.get_num_threads()} ({args.threads}), {args.load} busy background processes, "
        f"load average {os.getloadavg()[0]:.1f}, medians over seeds"
    )
    print("\n" + header + "\n\n" + table(results))
    if args.out is not None:
        args.out.parent.mkdir(parents=True, exist_ok=True)
        out = {"args": vars(args) | {"out": str(args.out)}, "header": header}
        out |= {"results": results, "provenance": record}
        args.out.write_text(json.dumps(out, indent=1))


if __name__ == "__main__":
    main()
