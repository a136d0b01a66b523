"""Command line: ``sb3-geogp train --algo ppo --env Pendulum-v1 --critic geodesic ...``.

``sb3-geogp compare ...`` runs the critic comparison (:mod:`sb3_geogp.comparison`).

Trains PPO or A2C with the GP critic (or SB3's MLP critic for comparison), with SB3's progress
bar, and writes to ``--out``: the model (``model.zip``), SB3's logs (``progress.csv``, plus a
TensorBoard log when ``tensorboard`` is installed), the Monitor episode logs (``monitor/``) and
a learning curve (``learning_curve.png``, when ``matplotlib`` is installed).
"""

from __future__ import annotations

import argparse
import csv
import importlib.util
import json
import sys
import time
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import gymnasium as gym
import numpy as np
import torch as th
from stable_baselines3.common.env_util import make_vec_env
from stable_baselines3.common.logger import configure

import sb3_geogp.envs  # noqa: F401  (registers the package's environments for --env)
from sb3_geogp import __version__
from sb3_geogp.callbacks import GPValueCallback
from sb3_geogp.comparison.command import add_arguments, run_from_args
from sb3_geogp.comparison.hyperparams import ALGOS, CRITICS
from sb3_geogp.policies import GPActorCriticPolicy


def build_parser() -> argparse.ArgumentParser:
    """The ``sb3-geogp`` argument parser (sub-commands ``train`` and ``compare``)."""
    parser = argparse.ArgumentParser(
        prog="sb3-geogp", description="Sparse on-line (geodesic) GP critics for SB3."
    )
    parser.add_argument("--version", action="version", version=f"%(prog)s {__version__}")
    commands = parser.add_subparsers(dest="command", required=True)
    add_arguments(
        commands.add_parser(
            "compare", help="compare MLP / RBF-GP / geodesic-GP critics in PPO and A2C"
        )
    )
    train = commands.add_parser(
        "train",
        help="train PPO or A2C with a GP or MLP critic",
        formatter_class=argparse.ArgumentDefaultsHelpFormatter,
    )
    train.add_argument("--algo", choices=sorted(ALGOS), default="ppo")
    train.add_argument("--env", default="Pendulum-v1", help="gymnasium environment id")
    train.add_argument("--critic", choices=CRITICS, default="geodesic")
    train.add_argument("--timesteps", type=int, default=100_000)
    train.add_argument("--seed", type=int, default=0)
    train.add_argument("--out", type=Path, default=None, help="output directory")
    train.add_argument("--n-envs", type=int, default=4)
    train.add_argument("--n-steps", type=int, default=None, help="rollout length per env")
    train.add_argument("--max-basis", type=int, default=256, help="GP basis capacity")
    train.add_argument(
        "--forgetting",
        type=float,
        default=None,
        help="GP forgetting factor in (0, 1] (default: 0.9 with a2c, 1.0 with ppo; "
        "see docs/results.md)",
    )
    train.add_argument(
        "--target", choices=("returns", "monte_carlo"), default="returns", help="GP targets"
    )
    train.add_argument(
        "--threads", type=int, default=1, help="torch CPU threads (1 is fastest for small nets)"
    )
    train.add_argument("--no-progress", action="store_true", help="hide the progress bar")
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point of ``sb3-geogp``; returns the exit status."""
    args = build_parser().parse_args(argv)
    if args.command == "compare":
        return run_from_args(args)
    try:
        train(args)
    except UsageError as err:
        print(f"sb3-geogp train: error: {err}", file=sys.stderr)
        return 2
    return 0


class UsageError(Exception):
    """A mistake in the command line, reported as one line on stderr with exit status 2."""


def check_train_args(args: argparse.Namespace, out: Path) -> None:
    """Raise :class:`UsageError` naming the first bad ``train`` argument, before any work."""
    for name in ("timesteps", "n_envs", "max_basis", "threads", "n_steps"):
        value = getattr(args, name)
        if value is not None and value < 1:
            raise UsageError(f"--{name.replace('_', '-')} must be at least 1, got {value}")
    if args.forgetting is not None and not 0 < args.forgetting <= 1:
        raise UsageError(f"--forgetting must be in (0, 1], got {args.forgetting}")
    try:
        gym.spec(args.env)
    except gym.error.Error as err:
        raise UsageError(
            f"unknown environment {args.env!r} ({err}); pass a registered gymnasium id, or "
            "'module:EnvId' to import the module that registers it"
        ) from None
    saved = out / _SETTINGS
    if saved.is_file() and json.loads(saved.read_text()) != _settings(args):
        raise UsageError(
            f"{out} holds a run made with other settings ({saved}); pass another --out or "
            "delete that directory"
        )


#: The ``train`` settings a run directory was made with.
_SETTINGS = "train_settings.json"


def _settings(args: argparse.Namespace) -> dict[str, Any]:
    return {k: v for k, v in vars(args).items() if k not in ("command", "out", "no_progress")}


def train(args: argparse.Namespace) -> Path:
    """Train one model as described by the parsed ``train`` arguments; return the output dir."""
    out: Path = args.out or Path("runs") / f"{args.algo}_{args.critic}_{args.env}_s{args.seed}"
    check_train_args(args, out)
    th.set_num_threads(args.threads)
    out.mkdir(parents=True, exist_ok=True)
    (out / _SETTINGS).write_text(json.dumps(_settings(args), indent=1))
    env = make_vec_env(
        args.env, n_envs=args.n_envs, seed=args.seed, monitor_dir=str(out / "monitor")
    )
    algo_kwargs: dict[str, Any] = {}
    if args.n_steps is not None:
        algo_kwargs["n_steps"] = args.n_steps
        if args.algo == "ppo":
            algo_kwargs["batch_size"] = min(64, args.n_steps * args.n_envs)
    callback = None
    if args.critic == "mlp":
        model = ALGOS[args.algo]("MlpPolicy", env, seed=args.seed, **algo_kwargs)
    else:
        gp_kwargs = dict(kernel=args.critic, max_basis=args.max_basis, forgetting=_forgetting(args))
        model = ALGOS[args.algo](
            GPActorCriticPolicy,
            env,
            seed=args.seed,
            policy_kwargs=dict(gp_kwargs=gp_kwargs),
            **algo_kwargs,
        )
        callback = GPValueCallback(target=args.target)
    formats = ["stdout", "csv"]
    if importlib.util.find_spec("tensorboard") is not None:
        formats.append("tensorboard")
    model.set_logger(configure(str(out), formats))
    progress = not args.no_progress and _progress_bar_available()
    start = time.perf_counter()
    model.learn(args.timesteps, callback=callback, progress_bar=progress)
    seconds = time.perf_counter() - start
    model.save(out / "model.zip")
    env.close()
    title = f"{args.algo.upper()} on {args.env}, {args.critic} critic, seed {args.seed}"
    curve = plot_learning_curve(out / "monitor", out / "learning_curve.png", title=title)
    print(f"trained {model.num_timesteps} steps in {seconds:.1f} s; saved {out / 'model.zip'}")
    if curve is not None:
        print(f"learning curve: {curve}")
    return out


def plot_learning_curve(monitor_dir: Path, path: Path, title: str = "") -> Path | None:
    """Episode return against timesteps from SB3 Monitor logs, as a PNG.

    Parameters
    ----------
    monitor_dir : Path
        Folder of ``*.monitor.csv`` files.
    path : Path
        PNG to write.
    title : str
        Figure title.

    Returns
    -------
    Path or None
        ``path``, or ``None`` when matplotlib is missing or no episode has finished.
    """
    if importlib.util.find_spec("matplotlib") is None:
        print("matplotlib not installed: no learning curve (pip install sb3_geogp[plot])")
        return None
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    steps, returns = read_monitor_logs(monitor_dir)
    if len(returns) == 0:
        return None
    window = max(1, min(20, len(returns) // 5))
    smooth = np.convolve(returns, np.ones(window) / window, mode="valid")
    fig, ax = plt.subplots(figsize=(6, 4))
    ax.plot(steps, returns, ".", alpha=0.3, label="episode return")
    ax.plot(steps[window - 1 :], smooth, label=f"mean of {window}")
    ax.set_xlabel("timesteps")
    ax.set_ylabel("episode return")
    ax.set_title(title)
    ax.legend()
    fig.tight_layout()
    fig.savefig(path, dpi=100)
    plt.close(fig)
    return path


def read_monitor_logs(monitor_dir: Path) -> tuple[np.ndarray, np.ndarray]:
    """Episodes of all SB3 ``*.monitor.csv`` files in a folder, in order of completion.

    Returns
    -------
    timesteps : ndarray, shape (n_episodes,)
        Total steps of all environments when each episode ended (approximately, by wall
        time order).
    returns : ndarray, shape (n_episodes,)
        Undiscounted episode returns.
    """
    rows: list[tuple[float, float, float]] = []
    for file in sorted(Path(monitor_dir).glob("*monitor.csv")):
        with file.open(newline="") as handle:
            next(handle, None)  # "#{json header}"
            rows += [(float(r["t"]), float(r["l"]), float(r["r"])) for r in csv.DictReader(handle)]
    rows.sort()
    lengths = np.array([r[1] for r in rows])
    return np.cumsum(lengths), np.array([r[2] for r in rows])


def _progress_bar_available() -> bool:
    return all(importlib.util.find_spec(name) is not None for name in ("tqdm", "rich"))


def _forgetting(args: argparse.Namespace) -> float:
    if args.forgetting is not None:
        return float(args.forgetting)
    return 0.9 if args.algo == "a2c" else 1.0  # measured: docs/results.md, A2C control


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
