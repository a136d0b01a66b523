"""Aggregation of a critic-comparison sweep: per-cell statistics over seeds and verdicts.

Reads the result files written by :mod:`sb3_geogp.comparison.run` (``out/runs/*.json``):

* :func:`load_sweeps`: several sweeps' result files as one, a re-run replacing the cells it
  re-ran;
* :func:`summary_rows`: per environment, algorithm and critic the number of seeds, final
  return (mean [95 % CI], IQM), steps to threshold (and, where every run recorded it, since
  0.40, training seconds to it), final critic RMSE, wall clock and the GP's share of it;
* :func:`comparisons`: for each environment and algorithm the differences of the critic pairs
  of :data:`PAIRS` (RBF - MLP, geodesic - MLP and geodesic - RBF in the published sweep) of the
  means of three metrics (:data:`METRICS`), each with
  its 95 % bootstrap interval and a verdict ("better" / "worse" when the interval excludes 0,
  else "no difference"), and the same verdict at the family-wise level: a Bonferroni-widened
  interval over all comparisons of that metric, because among dozens of 95 % intervals a few
  exclude 0 by chance alone;
* :func:`estimate_sweep_seconds`: the duration of a planned sweep, from a calibration sweep.
"""

from __future__ import annotations

import json
import math
from collections import defaultdict
from collections.abc import Callable, Mapping, Sequence
from pathlib import Path
from typing import Any, Literal, NamedTuple

import numpy as np

from sb3_geogp.comparison.hyperparams import ALL_CRITICS
from sb3_geogp.toolbox.stats import bootstrap_ci, difference_ci, iqm, permutation_pvalue

Key = tuple[str, str, str]  # (env_id, algo, critic)
#: What decides a comparison's verdicts (:func:`comparisons`).
VerdictTest = Literal["bootstrap", "permutation"]
VERDICT_TESTS: tuple[VerdictTest, ...] = ("bootstrap", "permutation")
#: The critic pairs ``(a, b)`` compared where a sweep ran both: each GP critic against the MLP,
#: the geodesic against the RBF kernel (the published sweep's three), the Laplacian kernel
#: (the default critic since 0.6) against the MLP and both other kernels, and the Matérn
#: kernel against the MLP and the two default kernels (RBF under A2C, Laplacian under PPO).
PAIRS = (
    ("rbf", "mlp"),
    ("geodesic", "mlp"),
    ("geodesic", "rbf"),
    ("laplacian", "mlp"),
    ("laplacian", "rbf"),
    ("laplacian", "geodesic"),
    ("matern", "mlp"),
    ("matern", "rbf"),
    ("matern", "laplacian"),
)
#: Comparisons per metric of the published sweep (7 environments, 2 algorithms, 3 critic
#: pairs): the family its family-wise level corrects for, kept by re-runs of some cells.
PUBLISHED_FAMILY = 42
# Below this many seeds per critic a bootstrap interval is too coarse to support a verdict
# (with one seed it is a single point); the issue asks for at least 5 in published results.
MIN_SEEDS_FOR_VERDICT = 5
#: The verdict of a comparison with a NaN or infinite run on either side (a diverged run, a
#: metric that was not measured): its interval and p-value say nothing, so it is flagged
#: rather than read as "no difference".
NON_FINITE_VERDICT = "non-finite runs"


class Metric(NamedTuple):
    """A per-run number that comparisons are made on."""

    label: str
    of_run: Callable[[dict[str, Any]], float]
    higher_is_better: bool


METRICS: dict[str, Metric] = {
    "final_return": Metric("final evaluation return", lambda r: r["final_return"], True),
    # The mean over all checkpoints is the normalised area under the learning curve: it
    # rewards reaching good returns early, i.e. sample efficiency.
    "mean_return": Metric(
        "evaluation return averaged over all checkpoints (area under the learning curve)",
        lambda r: float(np.mean(r["eval"]["mean_return"])),
        True,
    ),
    "critic_rmse": Metric(
        "final critic RMSE against Monte Carlo returns (lower is better)",
        lambda r: r["critic_accuracy"]["rmse"][-1],
        False,
    ),
}


def env_file_name(env_id: str) -> str:
    """``env_id`` as part of a file name: without the module of a ``"module:EnvId"`` id
    (a colon is no file name's on Windows), ``/`` as ``-``."""
    return env_id.rpartition(":")[2].replace("/", "-")


def load_results(out_dir: str | Path) -> list[dict[str, Any]]:
    """All readable result files of a sweep, sorted by run id."""
    results = []
    for path in sorted((Path(out_dir) / "runs").glob("*.json")):
        try:
            results.append(json.loads(path.read_text()))
        except (OSError, ValueError):
            continue
    return results


def load_sweeps(out_dirs: Sequence[str | Path]) -> list[dict[str, Any]]:
    """The result files of several sweeps as one sweep.

    A cell (environment, algorithm, critic) found in more than one folder is taken whole from
    the last of them: a re-run of some cells, listed after the sweep it re-ran, replaces them
    rather than adding seeds to them.
    """
    cells: dict[Key, list[dict[str, Any]]] = {}
    for out_dir in out_dirs:
        cells.update(group_runs(load_results(out_dir)))
    return [r for runs in cells.values() for r in runs]


def pool_sweeps(out_dirs: Sequence[str | Path]) -> list[dict[str, Any]]:
    """The result files of sweeps of different seeds as one sweep, pooling their seeds.

    Unlike :func:`load_sweeps`, cells add up: a run is keyed by (environment, algorithm,
    critic, seed), and one found in more than one folder is taken from the last of them.
    """
    runs: dict[tuple[str, str, str, int], dict[str, Any]] = {}
    for out_dir in out_dirs:
        for r in load_results(out_dir):
            s = r["spec"]
            runs[(s["env_id"], s["algo"], s["critic"], s["seed"])] = r
    return list(runs.values())


#: What :func:`cpu_models` names a run that does not record its CPU (made before 0.24.1).
UNRECORDED_CPU = "unrecorded"


def cpu_models(results: Sequence[dict[str, Any]]) -> list[str]:
    """The CPU models the runs were made on (``provenance.machine.cpu_model``), sorted, each
    once; :data:`UNRECORDED_CPU` for runs that do not record one."""
    return sorted(
        {
            r.get("provenance", {}).get("machine", {}).get("cpu_model") or UNRECORDED_CPU
            for r in results
        }
    )


def machine_caution(results: Sequence[dict[str, Any]], baseline: Sequence[dict[str, Any]]) -> str:
    """One line naming the CPU models of a sweep's runs and of its baseline's, with a caution
    where they recorded different ones.

    The same code, versions and seed give another run on another CPU model, parting from its
    first evaluation where actions are continuous (docs/results.md, "The table's stored PPO
    MountainCarContinuous runs"); a difference against such a baseline mixes the change under
    test with the machine.
    """
    ours, theirs = cpu_models(results), cpu_models(baseline)
    line = f"CPU models: this sweep {', '.join(ours)}; baseline {', '.join(theirs)}."
    recorded = [m for m in (*ours, *theirs) if m != UNRECORDED_CPU]
    if len(set(recorded)) > 1:
        line += (
            " Caution: the runs come from different CPU models, on which the same code and seed "
            "give other runs; a difference here mixes the change with the machine. Re-run the "
            "baseline on this machine to compare code alone."
        )
    return line


def group_runs(results: list[dict[str, Any]]) -> dict[Key, list[dict[str, Any]]]:
    """Results by ``(env_id, algo, critic)``, each list sorted by seed."""
    groups: dict[Key, list[dict[str, Any]]] = defaultdict(list)
    for r in results:
        s = r["spec"]
        groups[(s["env_id"], s["algo"], s["critic"])].append(r)
    for runs in groups.values():
        runs.sort(key=lambda r: r["spec"]["seed"])
    return dict(groups)


def stack_curves(
    runs: list[dict[str, Any]], section: str = "eval", value: str = "mean_return"
) -> tuple[np.ndarray, np.ndarray]:
    """Curves of several runs on the first run's timesteps.

    Parameters
    ----------
    runs : list of dict
    section, value : str
        ``r[section]["timesteps"]`` and ``r[section][value]`` of every run, e.g.
        ``("eval", "mean_return")`` or ``("critic_accuracy", "rmse")``.

    Returns
    -------
    timesteps : ndarray, shape (T,)
    values : ndarray, shape (n_runs, T)
        Runs with other timesteps (a different rollout size) are linearly interpolated.
    """
    grid = np.asarray(runs[0][section]["timesteps"], dtype=np.float64)
    rows = []
    for r in runs:
        t = np.asarray(r[section]["timesteps"], dtype=np.float64)
        y = np.asarray(r[section][value], dtype=np.float64)
        rows.append(y if np.array_equal(t, grid) else np.interp(grid, t, y))
    return grid, np.stack(rows)


def verdict(low: float, high: float, higher_is_better: bool = True) -> str:
    """``"better"`` / ``"worse"`` if the interval of a difference ``a - b`` excludes 0 on the
    side where ``a`` is better / worse, else ``"no difference"``."""
    if low > 0 or high < 0:
        return "better" if (low > 0) == higher_is_better else "worse"
    return "no difference"


def summary_rows(results: list[dict[str, Any]], seed: int = 0) -> list[dict[str, Any]]:
    """One row per ``(env, algo, critic)`` with the statistics of the module docstring.

    Parameters
    ----------
    results : list of dict
        Result files' contents.
    seed : int
        Seed of every bootstrap.

    Returns
    -------
    list of dict
        JSON-compatible rows (non-finite numbers as ``None``).
    """
    groups = group_runs(results)
    rows = []
    for key in sorted(groups, key=lambda k: (k[0], k[1], ALL_CRITICS.index(k[2]))):
        env_id, algo, critic = key
        runs = groups[key]
        final = np.array([r["final_return"] for r in runs])
        est, low, high = (float(x) for x in bootstrap_ci(final, seed=seed))
        stt = _to_threshold(runs, "steps_to_threshold")
        rmse = np.array([r["critic_accuracy"]["rmse"][-1] for r in runs])
        r_est, r_low, r_high = (float(x) for x in bootstrap_ci(rmse, seed=seed))
        shares = [r["critic_share"] for r in runs if r.get("critic_share") is not None]
        row: dict[str, Any] = dict(
            env=env_id,
            algo=algo,
            critic=critic,
            n_seeds=len(runs),
            timesteps=int(runs[0]["spec"]["total_timesteps"]),
            final_mean=est,
            final_low=low,
            final_high=high,
            final_iqm=float(iqm(final)),
            threshold=float(runs[0]["threshold"]),
            steps_to_threshold_median=float(np.median(stt)),
            reached=int(np.isfinite(stt).sum()),
            critic_rmse_mean=r_est,
            critic_rmse_low=r_low,
            critic_rmse_high=r_high,
            train_seconds_mean=float(np.mean([r["train_seconds"] for r in runs])),
            critic_share_mean=float(np.mean(shares)) if shares else None,
        )
        # Runs made before 0.40 did not record their training clock: then no such column.
        if all("seconds_to_threshold" in r for r in runs):
            seconds = _to_threshold(runs, "seconds_to_threshold")
            row["seconds_to_threshold_median"] = float(np.median(seconds))
        rows.append(row)
    return [_json_safe(r) for r in rows]


def _to_threshold(runs: list[dict[str, Any]], key: str) -> np.ndarray:
    """Each run's steps or seconds to its threshold, ``inf`` where it never reached it."""
    return np.array([np.inf if r[key] is None else r[key] for r in runs], dtype=np.float64)


def comparisons(
    results: list[dict[str, Any]],
    seed: int = 0,
    level: float = 0.95,
    baseline: list[dict[str, Any]] | None = None,
    family_size: int | None = None,
    test: VerdictTest = "bootstrap",
) -> list[dict[str, Any]]:
    """Differences of means between critics, per environment, algorithm and metric.

    For every metric of :data:`METRICS` and every pair ``(a, b)`` of :data:`PAIRS` present in
    an ``(env, algo)`` cell: ``mean(a) - mean(b)`` over seeds with its percentile-bootstrap
    interval at ``level`` and at the family-wise level ``1 - (1 - level) / m`` (Bonferroni),
    ``m`` being the number of comparisons made on that metric. With fewer than
    :data:`MIN_SEEDS_FOR_VERDICT` seeds on either side the verdicts are ``"too few seeds"``,
    and with a NaN or infinite value on either side :data:`NON_FINITE_VERDICT`. The verdicts
    are the intervals' (``test="bootstrap"``, every published table's rule), or a permutation
    test's at the same two levels (``test="permutation"``, exact level; its two-sided
    ``p_value`` is then kept too; :func:`~sb3_geogp.toolbox.stats.permutation_pvalue`).

    Parameters
    ----------
    results : list of dict
        Result files' contents.
    seed : int
        Seed of every bootstrap.
    level : float
        Per-comparison confidence level.
    baseline : list of dict, optional
        Results of another sweep (e.g. the same critics with default GP options). Then each
        critic of ``results`` is compared with the same critic of ``baseline`` (``a - b`` with
        ``a == b`` and ``b_sweep == "baseline"``) instead of with the other critics.
    family_size : int, optional
        Number of comparisons per metric the family-wise level corrects for; by default the
        number made here. A re-run of some cells keeps the published sweep's family this way.
    test : {"bootstrap", "permutation"}
        What decides the verdicts.

    Returns
    -------
    list of dict
        Keys ``env, algo, metric, a, b, b_sweep, n_a, n_b, diff, low, high, verdict,
        family_size, fw_level, fw_low, fw_high, fw_verdict``, and ``p_value`` with the
        permutation test.
    """
    groups = group_runs(results)
    ref = groups if baseline is None else group_runs(baseline)
    pairs = [(e, al, a, b) for e, al in sorted({(k[0], k[1]) for k in groups})
             for a, b in critic_pairs(baseline is not None)
             if (e, al, a) in groups and (e, al, b) in ref]  # fmt: skip
    family = max(family_size or len(pairs), 1)
    out = []
    for name, metric in METRICS.items():
        for env_id, algo, a, b in pairs:
            xa = np.array([metric.of_run(r) for r in groups[(env_id, algo, a)]], dtype=float)
            xb = np.array([metric.of_run(r) for r in ref[(env_id, algo, b)]], dtype=float)
            row = dict(env=env_id, algo=algo, metric=name, a=a, b=b,
                       b_sweep="same" if baseline is None else "baseline",
                       n_a=len(xa), n_b=len(xb))  # fmt: skip
            row.update(_difference(xa, xb, level, family, metric.higher_is_better, test, seed))
            out.append(row)
    return out


def _difference(
    xa: np.ndarray,
    xb: np.ndarray,
    level: float,
    family: int,
    higher: bool,
    test: VerdictTest,
    seed: int,
) -> dict[str, Any]:
    """One row of :func:`comparisons` past its names: the difference of means, its intervals
    at ``level`` and at the family-wise level of ``family`` comparisons, and their verdicts."""
    fw_level = 1 - (1 - level) / family
    finite = bool(np.isfinite(xa).all() and np.isfinite(xb).all())
    # A non-finite run makes the intervals NaN; its verdict is flagged below instead.
    with np.errstate(invalid="ignore"):
        d, low, high = (float(x) for x in difference_ci(xa, xb, level=level, seed=seed))
        _, fw_low, fw_high = (float(x) for x in difference_ci(xa, xb, level=fw_level, seed=seed))
    row: dict[str, Any] = dict(
        diff=d, low=low, high=high, verdict=verdict(low, high, higher),
        family_size=family, fw_level=fw_level, fw_low=fw_low, fw_high=fw_high,
        fw_verdict=verdict(fw_low, fw_high, higher),
    )  # fmt: skip
    if test == "permutation":
        p = permutation_pvalue(xa, xb, seed=seed) if finite else math.nan
        row.update(p_value=p, **_tested(d, p, 1 - level, 1 - fw_level, higher))
    if min(len(xa), len(xb)) < MIN_SEEDS_FOR_VERDICT:
        row.update(verdict="too few seeds", fw_verdict="too few seeds")
    elif not finite:
        row.update(verdict=NON_FINITE_VERDICT, fw_verdict=NON_FINITE_VERDICT)
    return row


def _tested(diff: float, p: float, alpha: float, fw_alpha: float, higher: bool) -> dict[str, str]:
    """The verdicts of a test's p-value ``p`` for a difference ``diff``, at both levels: the
    side of ``diff`` (:func:`verdict` of the point ``diff``) where ``p`` is below the level."""

    def at(level: float) -> str:
        return verdict(diff, diff, higher) if p < level else "no difference"

    return dict(verdict=at(alpha), fw_verdict=at(fw_alpha))


def rerun_comparisons(
    published: list[dict[str, Any]],
    rerun: list[dict[str, Any]],
    seed: int = 0,
    replaces: Mapping[str, str] | None = None,
) -> tuple[list[dict[str, Any]], list[dict[str, Any]]]:
    """The published comparisons of the critics re-run in some cells, and the re-run's.

    The re-run replaces the published runs of its critics in its ``(env, algo)`` cells; the
    other critics of those cells (e.g. the MLP) keep their published runs, and the family-wise
    level stays the published sweep's (``family_size``), so both sides follow the same rule.

    Parameters
    ----------
    published, rerun : list of dict
        Result files' contents.
    seed : int
        Seed of every bootstrap.
    replaces : mapping of str to str, optional
        Re-run critic to the published critic it takes the place of, when a new default
        critic is compared with the old one under another name (``{"laplacian": "geodesic"}``):
        the published critic is then the "before" of the re-run one and is left out of the
        re-run's comparisons.

    Returns
    -------
    before, after : list of dict
        :func:`comparisons` rows of the re-run critics (before: the critics they replace)
        against the critics not re-run, in the re-run cells: from the published sweep, and
        with the re-run.
    """
    renamed = dict(replaces or {})
    cells = {(r["spec"]["env_id"], r["spec"]["algo"]) for r in rerun}
    critics = {r["spec"]["critic"] for r in rerun}
    previous = {renamed.get(c, c) for c in critics}
    involved = critics | previous

    def wanted(row: dict[str, Any], side: set[str]) -> bool:
        in_cell = (row["env"], row["algo"]) in cells
        return in_cell and row["a"] in side and row["b"] not in involved

    before = comparisons(published, seed=seed)
    family = before[0]["family_size"] if before else None
    kept = [
        r for r in published
        if (r["spec"]["env_id"], r["spec"]["algo"]) in cells and r["spec"]["critic"] not in involved
    ]  # fmt: skip
    after = comparisons(kept + rerun, seed=seed, family_size=family)
    return [r for r in before if wanted(r, previous)], [r for r in after if wanted(r, critics)]


def critic_pairs(against_baseline: bool) -> tuple[tuple[str, str], ...]:
    """The ``(a, b)`` critic pairs a report compares: each critic with itself where ``b`` is a
    baseline sweep's run of the same critic (``against_baseline``), else :data:`PAIRS`."""
    return tuple((c, c) for c in ALL_CRITICS) if against_baseline else PAIRS


def _json_safe(x: Any) -> Any:
    if isinstance(x, dict):
        return {k: _json_safe(v) for k, v in x.items()}
    if isinstance(x, float) and not math.isfinite(x):
        return None
    return x


def estimate_sweep_seconds(
    results: list[dict[str, Any]], specs: list[Any], workers: int = 2
) -> dict[str, Any]:
    """Rough wall-clock estimate of a sweep from the results of a (smaller) calibration sweep.

    Per ``(env, algo, critic)`` cell: training time ``total_timesteps / rate``, ``rate`` the
    calibration runs' mean ``num_timesteps / train_cpu_seconds`` (CPU time, so that a busy
    calibration machine does not inflate it; ``train_seconds`` for files without it), plus
    measurement time: CPU seconds per environment step of the calibration's evaluations and
    Monte Carlo rollouts (from ``checkpoint_cost``; without it the whole
    ``checkpoint_seconds`` over an upper bound of the steps) times the planned steps, every
    episode counted at full length (an upper bound). Per-rollout costs that do not scale with
    the budget make small calibration runs pessimistic about the rate.

    Parameters
    ----------
    results : list of dict
        Calibration results.
    specs : list of RunSpec
        The planned runs.
    workers : int
        Parallel processes on as many otherwise idle cores; the estimate is the total divided
        by ``workers``.

    Returns
    -------
    dict
        ``total_seconds``, ``wall_seconds`` (total / workers) and ``per_cell`` seconds per run;
        cells without calibration data are listed in ``missing``, and ``uncounted_runs`` is
        how many planned runs they hold (not in the totals).
    """
    groups = group_runs(results)
    per_cell: dict[str, float] = {}
    missing = []
    uncounted = 0
    total = 0.0
    for spec in specs:
        key = (spec.env_id, spec.algo, spec.critic)
        runs = groups.get(key)
        if not runs:
            missing.append("/".join(key))
            uncounted += 1
            continue
        rate = float(
            np.mean(
                [r["num_timesteps"] / r.get("train_cpu_seconds", r["train_seconds"]) for r in runs]
            )
        )
        step_cost = float(np.mean([_checkpoint_step_cost(r) for r in runs]))
        horizon = runs[0]["critic_accuracy"]["horizon"]
        episode = runs[0].get("max_episode_steps", horizon)
        n_evals = spec.n_checkpoints + 2
        n_critic = n_evals // spec.critic_every + 1
        planned = episode * n_evals * spec.n_eval_episodes
        planned += horizon * n_critic * spec.n_probe_states * spec.n_mc_rollouts
        seconds = spec.total_timesteps / rate + step_cost * planned
        per_cell["/".join(key)] = seconds
        total += seconds
    return dict(
        total_seconds=total,
        wall_seconds=total / max(1, workers),
        per_cell=per_cell,
        missing=sorted(set(missing)),
        uncounted_runs=uncounted,
    )


def _checkpoint_step_cost(result: dict[str, Any]) -> float:
    """Seconds per environment step of a run's checkpoint measurements."""
    cost = result.get("checkpoint_cost")
    if cost and cost["eval_env_steps"] + cost["mc_env_steps"] > 0:
        seconds = cost.get("eval_cpu_seconds", cost["eval_seconds"]) + cost.get(
            "mc_cpu_seconds", cost["mc_seconds"]
        )
        return seconds / (cost["eval_env_steps"] + cost["mc_env_steps"])
    spec = result["spec"]
    acc = result["critic_accuracy"]
    n_evals = len(result["eval"]["timesteps"])
    episode = result.get("max_episode_steps", acc["horizon"])
    upper = episode * n_evals * spec["n_eval_episodes"]
    upper += acc["horizon"] * len(acc["timesteps"]) * acc["n_states"] * acc["n_rollouts"]
    return float(result["checkpoint_seconds"]) / upper
