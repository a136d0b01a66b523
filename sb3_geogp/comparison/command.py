"""The ``sb3-geogp compare`` command (also ``examples/compare_critics.py``): options, checks.

:mod:`sb3_geogp.cli` builds the parser with :func:`add_arguments` and calls
:func:`run_from_args`.

Every mistake in the options ends, before any run starts, in a :class:`UsageError`:
``sb3-geogp`` prints it as one line on stderr and exits with status 2.
"""

from __future__ import annotations

import argparse
import ast
import dataclasses
import functools
import json
import math
import os
import warnings
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

import gymnasium as gym
from gymnasium.envs.registration import EnvSpec
from stable_baselines3.common.base_class import BaseAlgorithm

from sb3_geogp.callbacks import GPValueCallback
from sb3_geogp.comparison.evaluation import env_spec, max_episode_steps
from sb3_geogp.comparison.hyperparams import (
    ALGOS,
    ALL_CRITICS,
    CRITICS,
    ENVS,
    HyperparamsFile,
)
from sb3_geogp.comparison.results import VERDICT_TESTS, load_results
from sb3_geogp.comparison.run import build_model
from sb3_geogp.comparison.specs import ADAPT_PREFIX, RunSpec, SweepConfig, gp_kwargs_for
from sb3_geogp.comparison.sweep import pending_runs, run_sweep
from sb3_geogp.policies import build_gp_critic, check_gp_kwargs, resolved_gp_kwargs
from sb3_geogp.toolbox.scripts import count_arg

#: First line of ``--help``.
DESCRIPTION = (
    "Compare critics inside ordinary SB3 training: MLP vs GP critics (RBF, geodesic, Laplacian,"
    " Matérn)."
)
#: End of ``--help``.
EPILOG = """\
On your own environment, with rl-baselines3-zoo hyperparameters (ppo.yml: an entry MyEnv-v0
with the zoo's keys, e.g. n_envs, n_timesteps, n_steps, gamma, learning_rate, policy_kwargs):

  sb3-geogp compare --envs my_pkg.envs:MyEnv-v0 --hyperparams ppo=ppo.yml \\
      --critics mlp geodesic laplacian \\
      --threshold 200 --timesteps 50000 --seeds 5 --out results/my_env

'my_pkg.envs:' makes gymnasium import my_pkg.envs (which registers MyEnv-v0) in every worker.
The default GP critic is laplacian under PPO and rbf under A2C (geodesic up to 0.21); the
default --critics (the published sweep's) leave laplacian out.
See docs/usage.md, "Comparing critics on your environment".
"""


class UsageError(Exception):
    """A mistake in the command line, reported as one line on stderr with exit status 2.

    Shared by ``sb3-geogp train`` and ``sb3-geogp compare``. The message is kept on one line
    (it may quote the message of a library's exception).
    """

    def __init__(self, message: str) -> None:
        super().__init__(" ".join(message.split()))


def add_arguments(parser: argparse.ArgumentParser) -> argparse.ArgumentParser:
    """Add the comparison's options to ``parser``."""
    parser.add_argument(
        "--out",
        type=Path,
        default=Path("runs/compare"),
        help="results dir (default: runs/compare; the published sweep is in results/compare)",
    )
    parser.add_argument("--quick", action="store_true", help="smoke sweep: 5%% budgets, 2 seeds")
    parser.add_argument("--workers", type=count_arg, default=2, help="parallel processes")
    parser.add_argument(
        "--seeds", type=count_arg, default=None, help="number of seeds (first-seed..first-seed+n-1)"
    )
    parser.add_argument(
        "--first-seed",
        type=int,
        default=0,
        metavar="S",
        help="seed of the first run (default 0); e.g. --seeds 10 --first-seed 10 runs fresh "
        "seeds 10-19 beside the published 0-9",
    )
    parser.add_argument(
        "--timesteps",
        type=count_arg,
        default=None,
        metavar="N",
        help="budget of every run (default: the built-in one per env, or n_timesteps of "
        "--hyperparams, times --timesteps-scale)",
    )
    parser.add_argument(
        "--timesteps-scale", type=float, default=None, help="multiply the default budgets"
    )
    parser.add_argument("--ray", action="store_true", help="run the runs as Ray tasks")
    parser.add_argument(
        "--mlp-normalize",
        action="store_true",
        help="SB3's MLP critic trains in VecNormalize where the zoo's entry has normalize, as "
        "rl-baselines3-zoo trains it (evaluated on observations normalised with its training "
        "statistics). Default: no VecNormalize for any critic",
    )
    parser.add_argument(
        "--gp-normalize",
        action="store_true",
        help="the same for the GP critics, whose basis vectors then keep observations in the "
        "units of their time (GPValueCallback warns)",
    )
    parser.add_argument(
        "--gp-actor-normalize",
        action="store_true",
        help="where the zoo's entry normalises observations, the GP critics' policies "
        "normalise their actors' observations alone (normalize_actor_obs=True): the critic's "
        "observations and the rewards stay raw. Not with --gp-normalize",
    )
    parser.add_argument(
        "--algos",
        nargs="+",
        choices=sorted(ALGOS),
        default=None,
        help="default: both, or those of --hyperparams",
    )
    parser.add_argument(
        "--critics",
        nargs="+",
        choices=ALL_CRITICS,
        default=None,
        help=f"default: {' '.join(CRITICS)} (the published sweep's); laplacian is the GP "
        "policy's default critic under PPO since 0.6",
    )
    parser.add_argument(
        "--envs",
        nargs="+",
        default=None,
        metavar="ENV",
        help=f"gymnasium ids; 'module:EnvId' imports module first (default: {' '.join(ENVS)})",
    )
    parser.add_argument(
        "--hyperparams",
        action="extend",
        nargs="+",
        default=None,
        metavar="ALGO=FILE",
        help="rl-baselines3-zoo yaml file of one algorithm, e.g. ppo=ppo.yml a2c=a2c.yml: "
        "its entries (keyed by env id) replace that algorithm's built-in hyperparameters; "
        "--algos defaults to the algorithms given",
    )
    parser.add_argument(
        "--threshold",
        nargs="+",
        type=float,
        default=None,
        metavar="X",
        help="return that counts as solved (steps to threshold), one per --envs (default: "
        "built in, else the env's reward_threshold)",
    )
    parser.add_argument(
        "--gp-option",
        action="append",
        default=None,
        metavar="KEY=VALUE",
        type=parse_gp_option,
        help="option of the GP critics, e.g. forgetting=0.9, or adapt.NAME=VALUE for one "
        "setting of each algorithm's adaptation, e.g. adapt.prior_sd=None (repeatable)",
    )
    add_target_arguments(parser)
    parser.add_argument(
        "--verdict-test",
        choices=VERDICT_TESTS,
        default="bootstrap",
        help="what decides the report's verdicts: the 95 %% percentile-bootstrap interval "
        "(every published table's rule) or a permutation test (exact level; the bootstrap "
        "errs more often than 5 %% at 10-50 seeds, docs/results.md)",
    )
    parser.add_argument(
        "--baseline",
        type=Path,
        nargs="+",
        default=None,
        metavar="DIR",
        help="also compare each critic with the same critic of the sweep in DIR (several: "
        "read as one sweep, a cell found in several taken from the last); the report and the "
        "command name both sweeps' CPU models, with a caution where they differ (the same "
        "seed gives other runs there)",
    )
    parser.add_argument("--no-plots", action="store_true", help="skip figures and the table")
    parser.add_argument(
        "--estimate-from",
        type=Path,
        default=None,
        metavar="DIR",
        help="only print the sweep's estimated duration, calibrated on the results in DIR",
    )
    parser.add_argument("--no-progress", action="store_true", help="hide the progress bar")
    return parser


def parse_gp_option(text: str) -> tuple[str, Any]:
    """``"KEY=VALUE"`` as ``(key, value)``, the value a Python literal where it is one
    (``forgetting=0.9``, ``adapt={"prior_sd": 0.1}``), else JSON where it is that
    (``kernel_kwargs={"ard": false}``), else the bare word (``dtype=float32``). ``KEY`` may
    be ``adapt.NAME``: one setting of the adaptation (:func:`~sb3_geogp.comparison.specs.
    gp_kwargs_for`, e.g. ``adapt.prior_sd=None``).

    Raises
    ------
    argparse.ArgumentTypeError
        If ``text`` has no ``=`` or its key is not an identifier (nor ``adapt.`` and one).
    """
    key, sep, value = text.partition("=")
    if not sep or not key.removeprefix(ADAPT_PREFIX).isidentifier():
        raise argparse.ArgumentTypeError(
            f"expected KEY=VALUE (e.g. forgetting=0.9 or adapt.prior_sd=None), got {text!r}"
        )
    try:
        return key, ast.literal_eval(value)
    except (ValueError, SyntaxError):
        pass
    try:
        return key, json.loads(value)
    except ValueError:
        return key, value  # a bare word, e.g. dtype=float32


def check_env(env_id: str) -> EnvSpec:
    """The spec of ``env_id``; a :class:`UsageError` naming the fix if gymnasium has none."""
    try:
        return env_spec(env_id)
    except ImportError as err:
        raise UsageError(
            f"environment {env_id!r}: cannot import its module ({err}); install it or add its "
            "folder to PYTHONPATH"
        ) from None
    except gym.error.Error as err:
        raise UsageError(
            f"unknown environment {env_id!r} ({err}); pass a registered gymnasium id, or "
            "'module:EnvId' to import the module that registers it"
        ) from None


def _check_gp_options(
    options: list[tuple[str, Any]], critics: Sequence[str], algos: Sequence[str]
) -> tuple[tuple[str, Any], ...]:
    """``options`` if every GP critic of ``critics`` accepts them under each of ``algos`` (a
    bad option would otherwise fail in every worker); kernel options, e.g.
    ``kernel_kwargs={"nu": 1.5}``, are checked against the kernels named only."""
    if "kernel" in dict(options):
        raise UsageError(
            "--gp-option kernel=...: the kernel is the critic, choose it with --critics"
        )
    kernels = [critic for critic in critics if critic != "mlp"]
    if not kernels:
        raise UsageError("--gp-option sets the GP critics' options, and --critics names none")
    try:
        for algo in algos:
            # the policy's own checks and construction
            checked = check_gp_kwargs(dict(gp_kwargs_for(options, algo)))
            for kernel in kernels:
                build_gp_critic(resolved_gp_kwargs({**checked, "kernel": kernel}), input_dim=1)
    except (TypeError, ValueError) as e:
        raise UsageError(f"--gp-option: the GP critic rejects {dict(options)}: {e}") from None
    return tuple(options)


def _hyperparams_files(items: list[str]) -> tuple[tuple[str, HyperparamsFile], ...]:
    """The files of ``--hyperparams ALGO=FILE ...``, read."""
    files: dict[str, HyperparamsFile] = {}
    for item in items:
        algo, sep, path = item.partition("=")
        if not sep or algo not in ALGOS or not path:
            raise UsageError(
                f"--hyperparams takes ALGO=FILE with ALGO one of {', '.join(sorted(ALGOS))} "
                f"(e.g. ppo=ppo.yml), got {item!r}"
            )
        if algo in files:
            raise UsageError(f"--hyperparams: {algo} is given twice")
        try:
            files[algo] = HyperparamsFile.read(path)
        except ValueError as err:
            raise UsageError(f"--hyperparams {item}: {err}") from None
    return tuple(files.items())


def add_target_arguments(parser: argparse.ArgumentParser) -> None:
    """Add ``--target``, ``--horizon`` and ``--feed-every``, what and when
    :class:`GPValueCallback` feeds the GP critics (shared by ``sb3-geogp compare`` and
    ``sb3-geogp train``)."""
    parser.add_argument(
        "--target",
        choices=("returns", "monte_carlo"),
        default=None,
        help="value targets GPValueCallback feeds the GP critics: returns (SB3's TD(lambda) "
        "returns, which the MLP critic learns too) or monte_carlo (returns of completed "
        "episodes); default: GPValueCallback's per algorithm, monte_carlo for PPO (cut after 200 "
        "steps where gamma**200 >= 0.5), returns for A2C",
    )
    parser.add_argument(
        "--horizon",
        type=int,
        default=None,
        metavar="N",
        help="with --target monte_carlo: cut each return after N steps with the critic's value "
        "(GPValueCallback's horizon); unset: no cut there, and without --target each algorithm's "
        "default (under PPO cut after 200 steps where gamma**200 >= 0.5)",
    )
    parser.add_argument(
        "--feed-every",
        type=int,
        default=1,
        metavar="K",
        help="feed the GP critics every K-th rollout, with the K rollouts since the last feed "
        "(GPValueCallback's feed_every; default 1: every rollout)",
    )


def check_target_arguments(args: argparse.Namespace) -> None:
    """Raise :class:`UsageError` unless :class:`GPValueCallback` takes ``--target``,
    ``--horizon`` and ``--feed-every`` (its own check, before any work)."""
    try:
        GPValueCallback(target=args.target, horizon=args.horizon, feed_every=args.feed_every)
    except ValueError as err:
        target = args.target or "(default)"
        raise UsageError(
            f"--target {target} --horizon {args.horizon} --feed-every {args.feed_every}: {err}"
        ) from None


def config_from_args(args: argparse.Namespace) -> SweepConfig:
    """The :class:`SweepConfig` described by parsed :func:`add_arguments` options.

    Raises
    ------
    UsageError
        Naming the first mistake: an unknown environment, an unreadable or
        unusable hyperparameter file, an environment without hyperparameters, budget or
        threshold, or hyperparameters that do not build a model.
    """
    config = SweepConfig.quick() if args.quick else SweepConfig()
    if args.first_seed < 0:
        raise UsageError(f"--first-seed must be at least 0, got {args.first_seed}")
    changes: dict[str, Any] = {}
    n_seeds = len(config.seeds) if args.seeds is None else args.seeds
    if args.first_seed + n_seeds > 2**32:
        raise UsageError(
            f"--first-seed {args.first_seed} with {n_seeds} seeds goes past SB3's largest seed, "
            "2**32 - 1: pass a smaller --first-seed"
        )
    if args.seeds is not None or args.first_seed:
        changes["seeds"] = tuple(range(args.first_seed, args.first_seed + n_seeds))
    if args.timesteps_scale is not None:
        if not args.timesteps_scale > 0:
            raise UsageError(f"--timesteps-scale must be positive, got {args.timesteps_scale}")
        if args.timesteps is not None:
            raise UsageError("--timesteps sets every budget: drop --timesteps-scale")
        changes["timesteps_scale"] = args.timesteps_scale
    if args.timesteps is not None:
        changes["timesteps"] = args.timesteps
    if args.hyperparams:
        files = _hyperparams_files(args.hyperparams)
        changes["hyperparams_files"] = files
        changes["algos"] = tuple(algo for algo, _ in files)
        unused = [algo for algo, _ in files if args.algos and algo not in args.algos]
        if unused:
            raise UsageError(f"--hyperparams {unused[0]}=...: {unused[0]} is not among --algos")
    for name in ("algos", "critics", "envs"):
        if (values := getattr(args, name)) is not None:
            twice = next((v for i, v in enumerate(values) if v in values[:i]), None)
            if twice is not None:
                raise UsageError(f"--{name} names {twice} twice: name each once")
            changes[name] = tuple(values)
    envs = changes.get("envs", config.envs)
    for env_id in envs:
        check_env(env_id)
    if args.threshold is not None:
        if not all(math.isfinite(t) for t in args.threshold):
            raise UsageError(f"--threshold takes finite returns, got {args.threshold}")
        if len(args.threshold) != len(envs):
            raise UsageError(
                f"--threshold takes one value per environment ({len(envs)}: {' '.join(envs)}), "
                f"got {len(args.threshold)}"
            )
        changes["thresholds"] = tuple(zip(envs, args.threshold, strict=True))
    if args.gp_option:
        critics = changes.get("critics", config.critics)
        algos = changes.get("algos", config.algos)
        changes["gp_options"] = _check_gp_options(args.gp_option, critics, algos)
    changes["target"] = args.target
    check_target_arguments(args)
    changes["horizon"] = args.horizon
    changes["feed_every"] = args.feed_every
    changes["mlp_normalize"] = args.mlp_normalize
    changes["gp_normalize"] = args.gp_normalize
    changes["gp_actor_normalize"] = args.gp_actor_normalize
    config = dataclasses.replace(config, **changes)
    try:
        for env_id in envs:
            max_episode_steps(env_id)
        specs = config.specs()
    except ValueError as err:
        raise UsageError(str(err)) from None
    _check_models([spec for spec in specs if spec.algo in dict(config.hyperparams_files)])
    for folder in args.baseline or ():
        if not any((folder / "runs").glob("*.json")):
            raise UsageError(
                f"--baseline {folder}: no run files in its runs/ folder; pass a sweep's --out"
            )
    return config


def check_not_a_file(out: Path) -> None:
    """Raise :class:`UsageError` if the output folder ``out`` is a file."""
    if out.exists() and not out.is_dir():
        raise UsageError(f"--out {out} is a file, not a directory: pass a directory")


def check_out(out: Path) -> None:
    """Create the output folder ``out`` (and its parents) unless it exists.

    Raises
    ------
    UsageError
        If ``out`` is a file or cannot be created or written to.
    """
    check_not_a_file(out)
    try:
        out.mkdir(parents=True, exist_ok=True)
    except OSError as err:
        raise UsageError(f"--out {out} cannot be created ({err.strerror}): pass another") from None
    if not os.access(out, os.W_OK | os.X_OK):
        raise UsageError(f"--out {out} is not writable: pass another")


def _check_models(specs: list[RunSpec]) -> None:
    """Build the model of every algorithm, environment and kind of critic (MLP or GP) of
    ``specs``, so that SB3's, the policy's and the environment's own checks run before any run.
    """
    cells: dict[tuple[str, str, bool], RunSpec] = {}
    for spec in specs:
        cells.setdefault((spec.algo, spec.env_id, spec.critic == "mlp"), spec)
    for spec in cells.values():
        check_builds(
            functools.partial(build_model, spec),
            f"{spec.hyperparams_source}: {spec.algo} with the {spec.critic} critic on "
            f"{spec.env_id}",
        )


def check_builds(build: Callable[[], BaseAlgorithm], what: str) -> None:
    """Build a model and close its environment, so that SB3's, the policy's and the
    environment's own checks run before any work.

    Parameters
    ----------
    build : callable
        Builds the model.
    what : str
        How the error names the model, e.g. ``"ppo with the rbf critic on CartPole-v1"``.

    Raises
    ------
    UsageError
        Naming ``what`` and the error, if the model cannot be built.
    """
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")  # the run shows them
            model = build()
    except Exception as err:  # anything SB3, the policy or the environment reject
        raise UsageError(f"{what} fails to build: {type(err).__name__}: {err}") from None
    env = model.get_env()
    if env is not None:
        env.close()


def run_from_args(args: argparse.Namespace) -> int:
    """Run (or resume) the sweep of parsed ``compare`` arguments, then aggregate it; returns the
    exit status.

    Raises
    ------
    UsageError
        See :func:`config_from_args`; also if ``--out`` holds runs made with other settings.
    """
    config = config_from_args(args)
    specs = config.specs()
    n_total = len(specs)
    if args.estimate_from is not None:
        from sb3_geogp.comparison.results import estimate_sweep_seconds

        calibration = load_results(args.estimate_from)
        if not calibration:
            raise UsageError(
                f"--estimate-from {args.estimate_from}: no run files in its runs/ folder; pass "
                "a sweep's --out"
            )
        est = estimate_sweep_seconds(calibration, specs, workers=args.workers)
        counted = n_total - est["uncounted_runs"]
        print(
            f"estimate (an upper bound) for {counted} of {n_total} runs: "
            f"{est['total_seconds'] / 3600:.2f} CPU hours, {est['wall_seconds'] / 3600:.2f} h "
            f"with {args.workers} workers on idle cores"
        )
        if est["missing"]:
            print(
                f"not counted, {len(est['missing'])} cells without calibration data in "
                f"{args.estimate_from} (runs of their env, algorithm and critic): "
                f"{', '.join(est['missing'])}"
            )
        return 0
    check_out(args.out)
    try:
        pending_runs(specs, args.out)  # refuses the folder of another sweep
    except ValueError as err:
        raise UsageError(str(err)) from None
    print(f"sweep: {n_total} runs -> {args.out} ({args.workers} workers)")
    executed = run_sweep(
        config, args.out, workers=args.workers, use_ray=args.ray, progress=not args.no_progress
    )
    print(f"ran {len(executed)} runs, {n_total - len(executed)} were already done")
    if not args.no_plots:
        from sb3_geogp.comparison.report import matplotlib_available, write_report

        paths = write_report(
            args.out, baseline_dir=args.baseline, test=args.verdict_test, echo=print
        )
        for path in paths:
            print(f"wrote {path}")
        if not matplotlib_available():
            print("figures skipped: matplotlib is not installed (pip install matplotlib)")
    return 0
