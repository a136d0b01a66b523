"""Command line: ``sb3-geogp train --algo ppo --env Pendulum-v1 --critic laplacian ...``.

``sb3-geogp compare ...`` runs the critic comparison (:mod:`sb3_geogp.comparison`).

Trains PPO or A2C with the GP critic (or SB3's MLP critic for comparison), with SB3's progress
bar, and writes to ``--out``: the model (``model.zip``), SB3's logs of every rollout
(``progress.csv``, plus a TensorBoard log when ``tensorboard`` is installed; the terminal gets
a table at SB3's usual pace), the Monitor episode logs (``monitor/``) and a learning curve
(``learning_curve.png``, when ``matplotlib`` is installed: episode returns with the
environment's threshold, and below them the critic's out-of-sample explained variance per
rollout and, for a GP critic, its number of basis vectors). Interrupted by Ctrl-C or SIGTERM,
it saves ``checkpoint.zip`` there (also every ``--save-every`` steps), and the same command
resumes from it.
"""

from __future__ import annotations

import argparse
import contextlib
import copy
import csv
import importlib.util
import inspect
import json
import os
import shutil
import signal
import sys
import threading
import time
import zipfile
from collections.abc import Iterator, Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any, NamedTuple, NoReturn

import gymnasium as gym
import numpy as np
import torch as th
from stable_baselines3.common.callbacks import BaseCallback
from stable_baselines3.common.env_util import make_vec_env
from stable_baselines3.common.logger import (
    HumanOutputFormat,
    KVWriter,
    Logger,
    SeqWriter,
    configure,
)
from stable_baselines3.common.on_policy_algorithm import OnPolicyAlgorithm
from stable_baselines3.common.vec_env import VecEnv

import sb3_geogp.envs  # noqa: F401  (registers the package's environments for --env)
from sb3_geogp import __version__
from sb3_geogp.callbacks import GPValueCallback
from sb3_geogp.comparison.command import (
    DESCRIPTION,
    EPILOG,
    UsageError,
    add_arguments,
    add_target_arguments,
    check_builds,
    check_env,
    check_not_a_file,
    check_out,
    check_target_arguments,
    parse_gp_option,
    run_from_args,
)
from sb3_geogp.comparison.hyperparams import ALGOS, ALL_CRITICS
from sb3_geogp.comparison.hyperparams import threshold as comparison_threshold
from sb3_geogp.comparison.report import pyplot
from sb3_geogp.comparison.run import write_json_atomic
from sb3_geogp.comparison.specs import fed, setting_differences, with_gp_options
from sb3_geogp.defaults import LENGTHSCALE_RULES
from sb3_geogp.policies import GPActorCriticPolicy, check_supported_spaces, default_kernel
from sb3_geogp.toolbox.scripts import DefaultsHelpFormatter, count_arg

if TYPE_CHECKING:
    from matplotlib.axes import Axes
    from matplotlib.figure import Figure


#: ``train``'s default ``--max-basis``.
_MAX_BASIS = 256


class _OneLineParser(argparse.ArgumentParser):
    """An ``ArgumentParser`` whose mistakes end in one line, as the checks after parsing do
    (:class:`UsageError`), instead of argparse's usage block; ``--help`` still shows it."""

    def error(self, message: str) -> NoReturn:
        self.exit(2, f"{self.prog}: error: {message}; see {self.prog} --help\n")


def build_parser() -> argparse.ArgumentParser:
    """The ``sb3-geogp`` argument parser (sub-commands ``train`` and ``compare``)."""
    parser = _OneLineParser(
        prog="sb3-geogp", description="Sparse on-line (geodesic) GP critics for SB3."
    )
    parser.add_argument("--version", action="version", version=f"%(prog)s {__version__}")
    commands = parser.add_subparsers(dest="command", required=True)
    add_arguments(
        commands.add_parser(
            "compare",
            help="compare the MLP critic with GP critics (RBF, geodesic, Laplacian) in PPO and A2C",
            description=DESCRIPTION,
            epilog=EPILOG,
            formatter_class=argparse.RawDescriptionHelpFormatter,
        )
    )
    train = commands.add_parser(
        "train",
        help="train PPO or A2C with a GP or MLP critic",
        formatter_class=DefaultsHelpFormatter,
    )
    train.add_argument("--algo", choices=sorted(ALGOS), default="ppo", help="the algorithm")
    train.add_argument("--env", default="Pendulum-v1", help="gymnasium environment id")
    train.add_argument(
        "--critic",
        choices=ALL_CRITICS,
        default=None,
        help="mlp (SB3's) or the GP critic's kernel (default: GPActorCriticPolicy's for --algo, "
        "laplacian with ppo, rbf with a2c)",
    )
    train.add_argument(
        "--timesteps",
        type=count_arg,
        default=100_000,
        help="environment steps, rounded up to whole rollouts",
    )
    train.add_argument("--seed", type=int, default=0, help="seed of the model and environments")
    train.add_argument(
        "--out",
        type=Path,
        default=None,
        help="output directory (default: runs/ALGO_CRITIC_ENV_sSEED)",
    )
    train.add_argument("--n-envs", type=count_arg, default=4, help="parallel environments")
    train.add_argument(
        "--n-steps",
        type=count_arg,
        default=None,
        help="rollout length per env (default: the algorithm's, 2048 with ppo, 5 with a2c)",
    )
    train.add_argument("--max-basis", type=count_arg, default=_MAX_BASIS, help="GP basis capacity")
    train.add_argument(
        "--forgetting",
        type=float,
        default=None,
        help="GP forgetting factor in (0, 1]: fixed with --no-adapt, else the starting value "
        "(default: the policy's, as in the drop-in; with --no-adapt 0.9 with a2c, 1.0 with "
        "ppo; see docs/usage.md)",
    )
    train.add_argument(
        "--adapt",
        action=argparse.BooleanOptionalAction,
        default=True,
        help="the GP learns hyperparameters, target scale and forgetting from the data "
        "(--no-adapt: fixed, as in 0.2)",
    )
    train.add_argument(
        "--lengthscale-rule",
        choices=LENGTHSCALE_RULES,
        default=None,
        help="the GP's lengthscales start at each observation's spread (spread, the policy's "
        "default), or at that times sqrt(observation size) (distance), for many observations "
        "(SparseOnlineGP's lengthscale_rule; docs/method.md, 'Many inputs')",
    )
    train.add_argument(
        "--gp-option",
        type=parse_gp_option,
        action="append",
        default=None,
        metavar="KEY=VALUE",
        help="any other option of the GP critic (GPActorCriticPolicy's gp_kwargs; repeatable), "
        "e.g. trend=linear, or adapt.NAME=VALUE for one setting of the default adaptation, "
        "e.g. adapt.prior_sd=None; options that have a flag of their own take the flag",
    )
    train.add_argument(
        "--normalize-actor-obs",
        action="store_true",
        help="normalise the actor's observations by running statistics, as VecNormalize does, "
        "while the GP critic keeps raw ones (GPActorCriticPolicy's normalize_actor_obs)",
    )
    add_target_arguments(train)
    train.add_argument(
        "--threads",
        type=count_arg,
        default=1,
        help="torch CPU threads (1 is fastest for small nets)",
    )
    train.add_argument(
        "--device",
        default="cpu",
        help="torch device of the policy and the GP critic, e.g. cuda (SB3 runs MLP policies "
        "fastest on the CPU)",
    )
    train.add_argument(
        "--save-every",
        type=int,
        default=50_000,
        metavar="N",
        help="save checkpoint.zip every N steps (at the next rollout's start), from which the "
        "same command resumes after a hard kill; 0: only when interrupted by Ctrl-C or SIGTERM",
    )
    train.add_argument("--no-progress", action="store_true", help="hide the progress bar")
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point of ``sb3-geogp``; returns the exit status."""
    args = build_parser().parse_args(argv)
    try:
        if args.command == "compare":
            with _sigterm_interrupts():
                return run_from_args(args)
        train(args)
    except UsageError as err:
        print(f"sb3-geogp {args.command}: error: {err}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        if args.command == "compare":
            print(
                f"sb3-geogp compare: interrupted; the finished runs are in {args.out / 'runs'}, "
                "and the same command resumes the sweep",
                file=sys.stderr,
            )
        return 130  # the shell's status for an interrupt (train has saved its checkpoint)
    return 0


def check_train_args(args: argparse.Namespace, out: Path) -> None:
    """Raise :class:`UsageError` naming the first bad ``train`` argument, before any work."""
    if args.save_every < 0:
        raise UsageError(
            f"--save-every must be at least 0 (0: no periodic saves), got {args.save_every}"
        )
    if args.forgetting is not None and not 0 < args.forgetting <= 1:
        raise UsageError(f"--forgetting must be in (0, 1], got {args.forgetting}")
    if not 0 <= args.seed < 2**32:
        raise UsageError(f"--seed must be in [0, 2**32), got {args.seed}")
    if args.algo == "ppo" and args.n_steps is not None and args.n_steps * args.n_envs < 2:
        raise UsageError(
            "PPO needs rollouts of at least 2 steps (--n-steps x --n-envs) for its minibatches, "
            f"got {args.n_steps * args.n_envs}"
        )
    check_not_a_file(out)
    check_targets(args)
    check_gp_options(args)
    check_env_spaces(args.env, args.critic)
    check_device(args.device)
    check_builds(
        lambda: _new_model(args, make_vec_env(args.env, n_envs=args.n_envs)),
        f"{args.algo} with the {args.critic} critic on {args.env}",
    )
    saved = out / _SETTINGS
    if (out / "model.zip").is_file() and not saved.is_file():
        raise UsageError(
            f"{out} holds a model.zip that sb3-geogp train did not write (no {_SETTINGS}); "
            "pass another --out"
        )
    try:
        made = json.loads(saved.read_text()) if saved.is_file() else None
    except ValueError as err:
        raise UsageError(f"{saved} cannot be read ({err}); pass another --out") from err
    if made is not None and made != (asked := _settings(args)):
        raise UsageError(
            f"{out} holds a run made with other settings ({saved}: "
            f"{setting_differences(made, asked)}); pass the options it was made with, another "
            "--out, or delete that directory"
        )


def check_targets(args: argparse.Namespace) -> None:
    """Raise :class:`UsageError` unless ``--target``, ``--horizon`` and ``--feed-every`` can
    reach the critic."""
    gp_only = args.target == "monte_carlo" or args.horizon is not None or args.feed_every != 1
    if args.critic == "mlp" and gp_only:
        raise UsageError(
            "--target, --horizon and --feed-every choose what and when the GP critic learns; "
            "SB3's MLP critic learns SB3's returns every rollout. Drop them, or pass a GP --critic"
        )
    check_target_arguments(args)


#: The GP options ``train`` sets by flags of their own, which ``--gp-option`` may not name.
_FLAGGED = {
    "kernel": "--critic",
    "max_basis": "--max-basis",
    "forgetting": "--forgetting",
    "adapt": "--adapt / --no-adapt (or adapt.NAME=VALUE for one setting)",
    "lengthscale_rule": "--lengthscale-rule",
}


def check_gp_options(args: argparse.Namespace) -> None:
    """Raise :class:`UsageError` if GP options are given with SB3's MLP critic (they would be
    ignored), or ``--gp-option`` names an option that has a flag of its own."""
    given = [
        flag
        for flag, value, default in (
            ("--max-basis", args.max_basis, _MAX_BASIS),
            ("--forgetting", args.forgetting, None),
            ("--no-adapt", args.adapt, True),
            ("--lengthscale-rule", args.lengthscale_rule, None),
            ("--gp-option", args.gp_option, None),
            ("--normalize-actor-obs", args.normalize_actor_obs, False),
        )
        if value != default
    ]
    if args.critic == "mlp" and given:
        raise UsageError(
            f"{', '.join(given)} {'configures' if len(given) == 1 else 'configure'} the GP "
            "critic, and --critic mlp trains SB3's MLP critic; drop them, or pass a GP --critic"
        )
    for key, _ in args.gp_option or []:
        if key in _FLAGGED:
            raise UsageError(f"--gp-option {key}=...: pass {_FLAGGED[key]} instead")


def check_env_spaces(env_id: str, critic: str) -> None:
    """Raise :class:`UsageError` unless ``env_id`` is registered, can be made here and, for a
    GP critic, has spaces the GP critic supports: before anything is written."""
    check_env(env_id)
    try:
        env = gym.make(env_id)
    except gym.error.Error as err:  # e.g. a missing dependency (Box2D)
        raise UsageError(f"environment {env_id!r} cannot be made here: {err}") from None
    try:
        if critic != "mlp":
            check_supported_spaces(env.observation_space, env.action_space)
    except ValueError as err:
        raise UsageError(f"{env_id}: {err}; or pass --critic mlp") from None
    finally:
        env.close()


def check_device(name: str) -> None:
    """Raise :class:`UsageError` unless ``name`` is a torch device this machine has."""
    try:
        device = th.device(name)
    except RuntimeError as err:
        raise UsageError(f"--device {name!r} is not a torch device ({err})") from None
    if device.type == "cuda" and not th.cuda.is_available():
        raise UsageError(f"--device {name}: torch sees no CUDA device here; use --device cpu")


#: The ``train`` settings a run directory was made with.
_SETTINGS = "train_settings.json"
#: The model of an interrupted ``train``, from which the same command resumes.
_CHECKPOINT = "checkpoint.zip"
#: ``progress.csv``'s rows from before a resumed part, until that part ends.
_EARLIER_PROGRESS = "progress_earlier.csv"
_STEPS_KEY = "time/total_timesteps"


def _settings(args: argparse.Namespace) -> dict[str, Any]:
    settings = {k: v for k, v in vars(args).items() if k not in _NOT_SETTINGS}
    # What the critic is fed, as run directories made before its default moved record it.
    settings["target"], settings["horizon"] = fed(args.target, args.horizon, args.algo, args.critic)
    if args.gp_option is not None:
        # As the directory's JSON holds them (tuples read back as lists): resuming matches.
        settings["gp_option"] = json.loads(json.dumps(args.gp_option, default=repr))
    # At its default, an option added after 0.20 is left out, so that older run directories
    # still match.
    return {k: v for k, v in settings.items() if not (k in _ADDED and v == _ADDED[k])}


#: ``train`` options that do not change the run, so a directory does not record them.
_NOT_SETTINGS = ("command", "out", "no_progress", "save_every")
#: ``train`` options added after 0.20 and their defaults, recorded only when set otherwise.
_ADDED: dict[str, Any] = {
    "horizon": None,
    "feed_every": 1,
    "normalize_actor_obs": False,
    "lengthscale_rule": None,
    "gp_option": None,
}


def train(args: argparse.Namespace) -> Path:
    """Train one model as described by the parsed ``train`` arguments; return the output dir.

    Interrupted (Ctrl-C or SIGTERM), it saves the model as it stands to ``checkpoint.zip``,
    draws the learning curve so far and re-raises :class:`KeyboardInterrupt`; it also saves
    there every ``--save-every`` steps. The same command then resumes from the checkpoint
    (:func:`_resume_from`). A directory that holds the finished run is left as it is.
    """
    if args.critic is None:
        args.critic = default_kernel(ALGOS[args.algo])
    out: Path = args.out or Path("runs") / f"{args.algo}_{args.critic}_{args.env}_s{args.seed}"
    check_train_args(args, out)
    if (out / "model.zip").is_file() and not (out / _CHECKPOINT).is_file():
        print(
            f"{out / 'model.zip'} is this run, trained already; pass another --out to train again"
        )
        return out
    th.set_num_threads(args.threads)
    check_out(out)
    start = _resume_from(out)
    env = make_vec_env(
        args.env, n_envs=args.n_envs, seed=args.seed + start, monitor_dir=str(_monitor(out, start))
    )
    model = _load_checkpoint(args, out, env) if start else _new_model(args, env)
    # Written once the model is built: a run that could not start does not bind the directory.
    write_json_atomic(out / _SETTINGS, _settings(args))
    # SB3 collects whole rollouts; asking for them makes the progress bar's total the steps run.
    rollout = model.n_steps * model.n_envs
    total = -(-args.timesteps // rollout) * rollout
    callbacks: list[BaseCallback] = (
        []
        if args.critic == "mlp"
        else [GPValueCallback(target=args.target, horizon=args.horizon, feed_every=args.feed_every)]
    )
    if args.save_every:
        callbacks.append(_Checkpoints(out / _CHECKPOINT, args.save_every))
    last_update = _LastUpdate()
    callbacks.append(last_update)  # last: it sees the rollout after the GP has learnt it
    model.set_logger(_logger(out, model))
    progress = not args.no_progress and _progress_bar_available()
    started = time.perf_counter()
    try:
        with _sigterm_interrupts():
            model.learn(
                total - start,
                callback=callbacks,
                log_interval=1,
                progress_bar=progress,
                reset_num_timesteps=not start,
            )
    except KeyboardInterrupt:
        last_update.undo_unfinished(model)
        _save(model, out / _CHECKPOINT)
        _finish_logs(args, out)
        print(
            f"interrupted after {model.num_timesteps} of {total} steps; saved "
            f"{out / _CHECKPOINT}: run the same command to resume",
            file=sys.stderr,
        )
        raise
    finally:
        env.close()
    seconds = time.perf_counter() - started
    _save(model, out / "model.zip")
    for done in (out / _CHECKPOINT, _partial(out / _CHECKPOINT)):
        done.unlink(missing_ok=True)  # the partial one a kill during a save may have left
    curve = _finish_logs(args, out)
    resumed = f" (resumed at {start})" if start else ""
    print(
        f"trained {model.num_timesteps} steps{resumed} in {seconds:.1f} s; "
        f"saved {out / 'model.zip'}"
    )
    if curve is not None:
        print(f"learning curve: {curve}")
    return out


def _new_model(args: argparse.Namespace, env: VecEnv) -> OnPolicyAlgorithm:
    algo_kwargs: dict[str, Any] = {}
    if args.n_steps is not None:
        algo_kwargs["n_steps"] = args.n_steps
        if args.algo == "ppo":
            algo_kwargs["batch_size"] = min(64, args.n_steps * args.n_envs)
    if args.critic == "mlp":
        return ALGOS[args.algo]("MlpPolicy", env, seed=args.seed, device=args.device, **algo_kwargs)
    gp_kwargs = dict(
        kernel=args.critic, max_basis=args.max_basis, adapt=args.adapt, **_forgetting(args)
    )
    if args.lengthscale_rule is not None:  # else the policy's, as the drop-in saves it
        gp_kwargs["lengthscale_rule"] = args.lengthscale_rule
    gp_kwargs = with_gp_options(gp_kwargs, args.gp_option or [], args.algo)
    return ALGOS[args.algo](
        GPActorCriticPolicy,
        env,
        seed=args.seed,
        policy_kwargs=dict(gp_kwargs=gp_kwargs, normalize_actor_obs=args.normalize_actor_obs),
        device=args.device,
        **algo_kwargs,
    )


def _load_checkpoint(args: argparse.Namespace, out: Path, env: VecEnv) -> OnPolicyAlgorithm:
    model = ALGOS[args.algo].load(out / _CHECKPOINT, env=env, device=args.device)
    # A resumed run is determined by its seed and the step it resumes at, as the
    # environments' seeds are.
    model.set_random_seed((args.seed + model.num_timesteps) % 2**32)  # where SB3's seeds stop
    return model


def _save(model: OnPolicyAlgorithm, path: Path) -> None:
    """``model.save`` through a temporary file, so that an interrupt or a kill cannot leave half
    a checkpoint behind; the file's modification time is the moment of the save, which tells a
    resumed run which Monitor episodes came after it (:func:`_resume_from`)."""
    partial = _partial(path)
    now = time.time()
    model.save(partial)
    os.utime(partial, (now, now))
    partial.replace(path)


def _partial(path: Path) -> Path:
    return path.with_name(f"partial_{path.name}")


class _LastUpdate(BaseCallback):
    """What an interrupt must undo to leave the model as its last completed update left it.

    Interrupted while a rollout is collected or the GP learns it (its own update rolls back),
    the rollout is dropped: SB3 has already counted its steps, so the step count goes back to
    the rollout's start. Interrupted in the algorithm's update that follows (PPO's epochs), the
    actor and its optimiser go back to their state before it; the GP keeps what it learnt from
    that rollout, whose steps then count, as the logs that SB3 wrote before its update say.
    """

    def __init__(self) -> None:
        super().__init__()
        self.rollout_start: int | None = None  # None: interrupted before the first rollout
        self.before_update: tuple[dict[str, th.Tensor], dict[str, Any]] | None = None

    def _on_rollout_start(self) -> None:
        self.rollout_start = self.num_timesteps
        self.before_update = None

    def _on_step(self) -> bool:
        return True

    def _on_rollout_end(self) -> None:
        policy = self.model.policy
        parameters = {k: v.detach().clone() for k, v in policy.named_parameters()}
        self.before_update = parameters, copy.deepcopy(policy.optimizer.state_dict())

    def undo_unfinished(self, model: OnPolicyAlgorithm) -> None:
        """Put ``model`` back to its last completed update (see the class docstring)."""
        if self.before_update is None:
            if self.rollout_start is not None:
                model.num_timesteps = self.rollout_start
            return
        parameters, optimizer = self.before_update
        with th.no_grad():
            for name, value in model.policy.named_parameters():
                value.copy_(parameters[name])
        model.policy.optimizer.load_state_dict(optimizer)


class _Checkpoints(BaseCallback):
    """Save the model to ``path`` every ``every`` steps, as a rollout starts: the previous one
    is then learnt from by both the actor and the critic."""

    def __init__(self, path: Path, every: int) -> None:
        super().__init__()
        self.path, self.every = path, every
        self.saved_at = -1

    def _on_training_start(self) -> None:
        self.saved_at = self.num_timesteps

    def _on_rollout_start(self) -> None:
        if self.num_timesteps - self.saved_at >= self.every:
            _save(self.model, self.path)  # type: ignore[arg-type]
            self.saved_at = self.num_timesteps

    def _on_step(self) -> bool:
        return True


def _resume_from(out: Path) -> int:
    """The step an interrupted run resumes at (0: none to resume). The rows ``progress.csv``
    holds up to it move to ``progress_earlier.csv`` (SB3's logger starts the file anew),
    where rows of a part that was killed after it are dropped; without a checkpoint the files
    of earlier parts are removed, as the run starts afresh."""
    earlier = out / _EARLIER_PROGRESS
    if not (out / _CHECKPOINT).is_file():
        earlier.unlink(missing_ok=True)
        for part in (out / "monitor").glob(f"{_PART}*"):
            shutil.rmtree(part)
        return 0
    with zipfile.ZipFile(out / _CHECKPOINT) as archive:
        start = int(json.loads(archive.read("data"))["num_timesteps"])
    _merge_progress([earlier, out / "progress.csv"], earlier, until=start)
    saved = (out / _CHECKPOINT).stat().st_mtime
    for file in (out / "monitor").rglob("*monitor.csv"):
        _drop_episodes_after(file, saved)
    return start


def _drop_episodes_after(file: Path, moment: float) -> None:
    """Remove from a Monitor log the episodes that ended after ``moment`` (a killed part's,
    played after its last checkpoint)."""
    log = _MonitorLog.read(file)
    kept = [r for r in log.rows if log.t_start + float(r["t"]) <= moment]
    if len(kept) == len(log.rows):
        return
    with file.open("w", newline="") as handle:
        handle.write(log.header)
        writer = csv.DictWriter(handle, log.columns)
        writer.writeheader()
        writer.writerows(kept)


class _MonitorLog(NamedTuple):
    """An SB3 Monitor file: its ``#{json}`` header line, whose ``t_start`` its episodes' times
    ``t`` count from, its columns and its rows (as strings)."""

    header: str
    t_start: float
    columns: list[str]
    rows: list[dict[str, str]]

    @classmethod
    def read(cls, file: Path) -> _MonitorLog:
        with file.open(newline="") as handle:
            header = handle.readline()
            reader = csv.DictReader(handle)
            rows = list(reader)
        t_start = float(json.loads(header.lstrip("#") or "{}").get("t_start", 0))
        return cls(header, t_start, list(reader.fieldnames or ["r", "l", "t"]), rows)


#: Prefix of the Monitor folder of a resumed part, followed by the step it resumed at.
_PART = "from_"


def _monitor(out: Path, start: int) -> Path:
    """Where the Monitor logs of the part starting at ``start`` go (one folder per part, as
    each environment's file is named by its index)."""
    return out / "monitor" if start == 0 else out / "monitor" / f"{_PART}{start}"


def _merge_progress(parts: Sequence[Path], path: Path, until: int | None = None) -> None:
    """Write the rows of the CSV ``parts`` that exist, in order, to ``path`` with the union of
    their columns (``until``: only rows logged at or before that step)."""
    columns: dict[str, None] = {}
    rows: list[dict[str, str]] = []
    for part in (p for p in parts if p.is_file()):
        with part.open(newline="") as handle:
            reader = csv.DictReader(handle)
            columns.update(dict.fromkeys(reader.fieldnames or ()))
            rows += [r for r in reader if until is None or float(r.get(_STEPS_KEY) or 0) <= until]
    if not columns:
        return
    with path.open("w", newline="") as handle:
        writer = csv.DictWriter(handle, list(columns), restval="", lineterminator="\n")
        writer.writeheader()
        writer.writerows(rows)


def _logger(out: Path, model: OnPolicyAlgorithm) -> Logger:
    formats = ["stdout", "csv"]
    if importlib.util.find_spec("tensorboard") is not None:
        formats.append("tensorboard")
    logger = configure(str(out), formats)
    # Every rollout is logged (log_interval=1) for the learning curve's critic panel; the
    # terminal keeps the algorithm's own pace, as A2C's 5-step rollouts would flood it.
    stdout_every = inspect.signature(model.learn).parameters["log_interval"].default
    logger.output_formats = [
        _EveryNth(f, stdout_every) if isinstance(f, HumanOutputFormat) else f
        for f in logger.output_formats
    ]
    return logger


def _finish_logs(args: argparse.Namespace, out: Path) -> Path | None:
    """One ``progress.csv`` over every part of the run, and the learning curve from it."""
    earlier = out / _EARLIER_PROGRESS
    if earlier.is_file():
        _merge_progress([earlier, out / "progress.csv"], out / "progress.csv")
        earlier.unlink()
    return plot_learning_curve(
        out / "monitor",
        out / "learning_curve.png",
        title=f"{args.algo.upper()} on {args.env}, {args.critic} critic, seed {args.seed}",
        progress=out / "progress.csv",
        threshold=reward_threshold(args.env),
    )


@contextlib.contextmanager
def _sigterm_interrupts() -> Iterator[None]:
    """SIGTERM (a batch system's stop, ``kill``) interrupts as Ctrl-C does, so that a training
    run saves its checkpoint and a sweep stops its workers and says what it kept; only the main
    thread can handle signals."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return

    def interrupt(signum: int, frame: Any) -> None:
        raise KeyboardInterrupt

    previous = signal.signal(signal.SIGTERM, interrupt)
    try:
        yield
    finally:
        signal.signal(signal.SIGTERM, previous)


class _EveryNth(KVWriter, SeqWriter):
    """A log writer passing on only every ``n``-th table of values (and every message)."""

    def __init__(self, writer: HumanOutputFormat, n: int) -> None:
        self.writer = writer
        self.n = n
        self.count = 0

    def write(
        self, key_values: dict[str, Any], key_excluded: dict[str, tuple[str, ...]], step: int = 0
    ) -> None:
        self.count += 1
        if self.count % self.n == 0:
            self.writer.write(key_values, key_excluded, step)

    def write_sequence(self, sequence: list[str]) -> None:
        self.writer.write_sequence(sequence)

    def close(self) -> None:
        self.writer.close()


def reward_threshold(env_id: str) -> float | None:
    """The return at which ``env_id`` counts as solved, for the learning curve.

    The level the critic comparison uses (:func:`~sb3_geogp.comparison.hyperparams.threshold`:
    its own, e.g. -200 for Pendulum-v1, else gymnasium's ``reward_threshold``), or ``None``
    where there is none.
    """
    try:
        return comparison_threshold(env_id)
    except ValueError:
        return None


class CriticLog(NamedTuple):
    """The critic's per-rollout statistics from SB3's ``progress.csv`` (:func:`read_critic_log`).

    Attributes
    ----------
    timesteps : ndarray, shape (n,)
        Total environment steps at the end of each rollout.
    explained_variance : ndarray, shape (n,)
        Out-of-sample explained variance of the rollout's value targets by the critic's values
        from before it was trained on them (NaN where a rollout has none).
    n_basis : ndarray, shape (n,), or None
        The GP's number of basis vectors after the rollout; ``None`` for an MLP critic.
    """

    timesteps: np.ndarray
    explained_variance: np.ndarray
    n_basis: np.ndarray | None


def read_critic_log(progress_csv: Path) -> CriticLog | None:
    """The critic's statistics per rollout, from the ``progress.csv`` that ``train`` writes.

    A GP critic's are ``gp/explained_variance`` and ``gp/n_basis``
    (:class:`~sb3_geogp.GPValueCallback`: the GP's prediction of the targets it is about to
    absorb). An MLP critic's is SB3's ``train/explained_variance``: the rollout's values,
    predicted while collecting it, against its returns.

    Parameters
    ----------
    progress_csv : Path
        SB3's CSV log with one row per rollout (``log_interval=1``).

    Returns
    -------
    CriticLog or None
        ``None`` when the file is missing or has no rollout yet.
    """
    if not Path(progress_csv).is_file():
        return None
    with Path(progress_csv).open(newline="") as handle:
        rows = list(csv.DictReader(handle))
    if not rows:
        return None

    def column(key: str) -> np.ndarray:
        return np.array([float(r[key]) if r.get(key) else np.nan for r in rows])

    steps = column("time/total_timesteps")
    if "gp/n_basis" in rows[0]:
        return CriticLog(steps, column("gp/explained_variance"), column("gp/n_basis"))
    # SB3 dumps an iteration's log before its train(), which records that rollout's
    # explained variance: the value in a row belongs to the rollout of the row before.
    return CriticLog(steps[:-1], column("train/explained_variance")[1:], None)


def plot_learning_curve(
    monitor_dir: Path,
    path: Path,
    title: str = "",
    *,
    progress: Path | None = None,
    threshold: float | None = None,
) -> Path | None:
    """Learning curve of a run as a PNG (:func:`learning_curve_figure` of its logs).

    Parameters
    ----------
    monitor_dir : Path
        Folder of SB3 ``*.monitor.csv`` files.
    path : Path
        PNG to write.
    title : str
        Figure title.
    progress : Path, optional
        SB3's ``progress.csv`` logged every rollout: adds the critic panel.
    threshold : float, optional
        Return at which the task counts as solved (:func:`reward_threshold`), drawn dashed.

    Returns
    -------
    Path or None
        ``path``, or ``None`` when matplotlib is missing or there is nothing to draw yet.
    """
    if importlib.util.find_spec("matplotlib") is None:
        print("matplotlib not installed: no learning curve (pip install sb3_geogp[plot])")
        return None
    steps, returns = read_monitor_logs(monitor_dir)
    critic = None if progress is None else read_critic_log(progress)
    if len(returns) == 0 and critic is None:
        return None
    # A resumed part's Monitor logs are in monitor/from_<step> (train's _monitor).
    parts = Path(monitor_dir).glob(f"{_PART}*")
    resumed = sorted(int(p.name.removeprefix(_PART)) for p in parts)
    fig = learning_curve_figure(steps, returns, critic, threshold, title, resumed_at=resumed)
    fig.savefig(path, dpi=100)
    pyplot().close(fig)
    return path


def learning_curve_figure(
    steps: np.ndarray,
    returns: np.ndarray,
    critic: CriticLog | None = None,
    threshold: float | None = None,
    title: str = "",
    *,
    resumed_at: Sequence[int] = (),
) -> Figure:
    """Episode returns against timesteps and, with ``critic``, a critic panel below.

    Parameters
    ----------
    steps, returns : ndarray, shape (n_episodes,)
        :func:`read_monitor_logs`.
    critic : CriticLog, optional
        :func:`read_critic_log`: explained variance per rollout (left axis) and, for a GP
        critic, the number of basis vectors (right axis).
    threshold : float, optional
        Drawn as a dashed line labelled "threshold".
    title : str
        Figure title.
    resumed_at : sequence of int
        Steps at which an interrupted run was resumed, drawn as dotted lines in each panel.

    Returns
    -------
    matplotlib.figure.Figure
        Axes: the returns panel, then the explained-variance panel, then its basis-vector
        twin (the last two with ``critic`` only).
    """
    plt = pyplot()
    n_panels = 1 if critic is None else 2
    fig, axes = plt.subplots(
        n_panels,
        1,
        sharex=True,
        squeeze=False,
        figsize=(7, 2.2 + 2.6 * n_panels),
        height_ratios=[3, 2][:n_panels],
    )
    ax = axes[0, 0]
    if len(returns):
        _raw_and_mean(ax, steps, returns, "tab:blue", "episode return", "episodes")
    else:
        ax.text(0.5, 0.5, "no episode finished yet", ha="center", transform=ax.transAxes)
    if threshold is not None:
        ax.axhline(threshold, color="k", lw=1, ls="--", label=f"threshold ({threshold:g})")
    for i, step in enumerate(resumed_at):
        for panel in axes[:, 0]:
            label = "resumed" if panel is ax and i == 0 else None
            panel.axvline(step, color="0.4", lw=1, ls=":", label=label)
    ax.set_ylabel("episode return")
    _legend_above(ax, *ax.get_legend_handles_labels())
    fig.suptitle(title)
    if critic is not None:
        _critic_panel(axes[1, 0], critic)
    axes[-1, 0].set_xlabel("timesteps")
    fig.tight_layout()
    return fig


def _critic_panel(ax: Axes, critic: CriticLog) -> None:
    """Explained variance per rollout and, on a twin axis, the GP's basis vectors."""
    keep = np.isfinite(critic.explained_variance)
    t, ev = critic.timesteps[keep], critic.explained_variance[keep]
    # Early rollouts can be far below -1 and would squash everything else; they are counted
    # in the legend instead.
    off_scale = int((ev < -1).sum())
    label = "explained variance per rollout"
    if off_scale:
        label += f" ({off_scale} below −1, off scale)"
    ax.axhline(0, color="0.6", lw=0.8)
    if len(ev):
        _raw_and_mean(ax, t, ev, "tab:purple", label, "rollouts")
    ax.set_ylim(max(-1.0, float(ev.min(initial=0.0))) - 0.05, 1.05)
    ax.set_ylabel("explained variance\n(out of sample)")
    handles, labels = ax.get_legend_handles_labels()
    if critic.n_basis is not None:
        twin = ax.twinx()
        # Rollouts the GP was not fed (feed_every > 1) log no n_basis.
        fed = np.isfinite(critic.n_basis)
        twin.step(
            critic.timesteps[fed],
            critic.n_basis[fed],
            where="post",
            color="tab:green",
            # a lone rollout is a step of no length: its marker is all that shows
            marker="." if int(fed.sum()) == 1 else None,
            label="basis vectors (right axis)",
        )
        twin.set_ylim(bottom=0)
        twin.set_ylabel("basis vectors (GP)")
        more = twin.get_legend_handles_labels()
        handles, labels = handles + more[0], labels + more[1]
    _legend_above(ax, handles, labels)


def _legend_above(ax: Axes, handles: list[Any], labels: list[str]) -> None:
    """The legend in a strip above the panel, where it cannot hide any data."""
    ax.legend(handles, labels, loc="lower left", bbox_to_anchor=(0, 1), ncol=2, fontsize=8)


def _raw_and_mean(
    ax: Axes, x: np.ndarray, y: np.ndarray, color: str, label: str, unit: str
) -> None:
    """``y`` as faint points and its moving mean over up to 20 ``unit`` as a line."""
    window = max(1, min(20, len(y) // 5))
    ax.plot(x, y, ".", color=color, alpha=0.3, label=label)
    if window > 1:
        smooth = np.convolve(y, np.ones(window) / window, mode="valid")
        ax.plot(x[window - 1 :], smooth, color=color, label=f"mean of last {window} {unit}")


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
    # A resumed run's parts are in subfolders; each file's times count from its own start.
    for file in sorted(Path(monitor_dir).rglob("*monitor.csv")):
        log = _MonitorLog.read(file)
        rows += [(log.t_start + float(r["t"]), float(r["l"]), float(r["r"])) for r in log.rows]
    rows.sort()
    lengths = np.array([r[1] for r in rows])
    return np.cumsum(lengths), np.array([r[2] for r in rows])


def _progress_bar_available() -> bool:
    return all(importlib.util.find_spec(name) is not None for name in ("tqdm", "rich"))


def _forgetting(args: argparse.Namespace) -> dict[str, float]:
    """The GP's forgetting options: ``--forgetting`` where given; else, for an adaptive critic,
    none, so that it starts from the policy's defaults as the drop-in does; for a fixed one
    0.9 with A2C (which without adaptation needs forgetting: docs/results.md, "Control: A2C
    with GP forgetting 0.9") and 1.0 with PPO."""
    if args.forgetting is not None:
        return {"forgetting": float(args.forgetting)}
    if args.adapt:
        return {}
    return {"forgetting": 0.9 if args.algo == "a2c" else 1.0}


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
