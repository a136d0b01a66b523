"""A sweep: every run of a :class:`~sb3_geogp.comparison.specs.SweepConfig`, resumable.

:func:`run_sweep` skips every run whose result file exists, so an interrupted sweep resumes
where it stopped and never redoes a finished run. Runs execute in parallel processes
(:func:`~sb3_geogp.toolbox.pools.worker_pool`, which Ctrl-C stops at once) or, with
``use_ray=True``, as Ray tasks wrapping the same :func:`~sb3_geogp.comparison.run.run_one`.
Each distinct warning of the runs is shown once per sweep, above the progress bar.
"""

from __future__ import annotations

import concurrent.futures as cf
import dataclasses
import json
import sys
from collections.abc import Callable, Iterable
from pathlib import Path
from typing import Any

from tqdm.auto import tqdm

from sb3_geogp.comparison.hyperparams import (
    DEVIATIONS,
    GP_KWARGS,
    THRESHOLDS,
    TIMESTEPS,
    ZOO_SOURCE,
)
from sb3_geogp.comparison.run import SCHEMA, load_result, result_path, run_one, write_json_atomic
from sb3_geogp.comparison.specs import RunSpec, SweepConfig, setting_differences
from sb3_geogp.toolbox.pools import worker_pool


def pending_runs(specs: Iterable[RunSpec], out_dir: str | Path) -> list[RunSpec]:
    """The specs without a finished result in ``out_dir``.

    Raises
    ------
    ValueError
        If a finished result of a spec's cell (algorithm, critic, environment), of its seed or
        another, was made with different settings than the spec asks for (a different budget,
        say), with other hyperparameters or another threshold: a folder holds one setting per
        cell, whose seeds its report pools; pick another ``out_dir`` rather than mix sweeps.
    """
    specs = list(specs)
    todo, refusals = [], []
    for spec in specs:
        done = load_result(result_path(out_dir, spec))
        if done is None:
            todo.append(spec)
        elif (difference := _difference(done, spec)) is not None:
            refusals.append((spec.critic == "mlp", spec, *difference))
    refusals += _other_seeds_refusals(specs, Path(out_dir))
    if refusals:
        # A GP run's file names the difference best: an MLP run also records the sweep's GP
        # options, which it does not use.
        _, spec, what, made, asked = min(refusals, key=lambda r: r[0])
        raise ValueError(
            f"{result_path(out_dir, spec)} was made with other {what} than requested "
            f"({setting_differences(made, asked)}); its cell's runs would be pooled with "
            "these: pass the options it was made with or use another --out"
        )
    return todo


def _difference(done: dict[str, Any], spec: RunSpec) -> tuple[str, Any, Any] | None:
    """What a finished result was made with where ``spec`` asks for something else:
    ``(what, made, asked)``, or ``None``."""
    for what, made, asked in (
        ("settings", done.get("spec"), spec.as_dict()),
        ("hyperparameters", done.get("hyperparams", {}).get("values"), spec.hyperparams),
        ("threshold", done.get("threshold"), spec.threshold),
    ):
        if made != (asked := _jsonable(asked)):
            return what, made, asked
    return None


def _other_seeds_refusals(
    specs: list[RunSpec], out_dir: Path
) -> list[tuple[bool, RunSpec, str, Any, Any]]:
    """The refusals (as :func:`pending_runs` makes them) of the finished results in
    ``out_dir`` of the cells of ``specs`` but of seeds they do not ask for."""
    # A run id is its cell's name and "__s<seed>": only the files of these cells are read (a
    # file whose contents are another cell's differs in its settings).
    cells = {s.run_id.rsplit("__s", 1)[0]: s for s in specs}
    asked = {s.run_id for s in specs}
    refusals = []
    for path in sorted((out_dir / "runs").glob("*.json")):
        spec = cells.get(path.stem.rsplit("__s", 1)[0])
        done = None if spec is None or path.stem in asked else load_result(path)
        seed = (done or {}).get("spec", {}).get("seed")
        if spec is None or done is None or not isinstance(seed, int):
            continue
        same_cell = dataclasses.replace(spec, seed=seed)
        if (difference := _difference(done, same_cell)) is not None:
            refusals.append((spec.critic == "mlp", same_cell, *difference))
    return refusals


def _jsonable(x: Any) -> Any:
    """``x`` as it reads back from JSON (tuples become lists)."""
    return json.loads(json.dumps(x))


def run_sweep(
    config: SweepConfig,
    out_dir: str | Path,
    workers: int = 1,
    use_ray: bool = False,
    progress: bool = True,
) -> list[str]:
    """Run every unfinished run of ``config``; return the ids of the runs executed now.

    Parameters
    ----------
    config : SweepConfig
    out_dir : str or Path
        Results go to ``out_dir/runs/*.json``; ``out_dir/sweep.json`` records the config of
        every sweep run into the folder (``sweeps``, once each, in order).
    workers : int
        Parallel processes (``1``: in this process). With Ray, the number of CPUs requested
        from a local Ray instance if none is running.
    use_ray : bool
        Run each :func:`run_one` as a Ray task (needs ``ray``).
    progress : bool
        Show a tqdm progress bar.

    Returns
    -------
    list of str
        Run ids executed (finished ones are skipped, never redone).
    """
    out = Path(out_dir)
    specs = config.specs()
    todo = pending_runs(specs, out)
    _record_sweep(out, config)
    bar = _progress_bar(len(specs), len(specs) - len(todo), progress)
    executed: list[str] = []
    shown: set[str] = set()

    def finished(spec: RunSpec, result: dict[str, Any]) -> None:
        executed.append(spec.run_id)
        for text in result["warnings"]:
            if text not in shown:
                shown.add(text)
                # tqdm.write prints above a running bar instead of through it.
                tqdm.write(f"{text} (first in {spec.run_id}; shown once)", file=sys.stderr)
        if bar is not None:
            bar.set_postfix_str(f"{spec.run_id}: {result['final_return']:.1f}")
            bar.update(1)

    try:
        if use_ray:
            _run_ray(todo, out, workers, finished)
        elif workers <= 1:
            for spec in todo:
                finished(spec, run_one(spec, out))
        else:
            with worker_pool(workers) as pool:
                futures = {pool.submit(run_one, spec, str(out)): spec for spec in todo}
                for future in cf.as_completed(futures):
                    finished(futures[future], future.result())
    finally:
        if bar is not None:
            bar.close()
    return executed


def _run_ray(
    todo: list[RunSpec],
    out: Path,
    workers: int,
    finished: Callable[[RunSpec, dict[str, Any]], None],
) -> None:
    try:
        import ray
    except ImportError as err:
        raise ImportError(
            "--ray needs Ray, which is not installed: pip install 'ray[default]' (or run "
            "without --ray to use local processes)"
        ) from err
    if not ray.is_initialized():
        ray.init(num_cpus=max(1, workers) if workers else None, ignore_reinit_error=True)
    remote = ray.remote(num_cpus=1)(run_one)
    refs = {remote.remote(spec, str(out)): spec for spec in todo}
    while refs:
        ready, _ = ray.wait(list(refs), num_returns=1)
        for ref in ready:
            finished(refs.pop(ref), ray.get(ref))


def _record_sweep(out: Path, config: SweepConfig) -> None:
    """Add ``config`` to ``out/sweep.json``'s list of the sweeps run into the folder, unless
    it is there already (a resumed sweep); a file of 0.31.3 or older holds one sweep."""
    path = out / "sweep.json"
    try:
        earlier = json.loads(path.read_text())
    except (OSError, ValueError):
        earlier = None
    sweeps = earlier.get("sweeps", [earlier]) if isinstance(earlier, dict) else []
    record = _jsonable(_sweep_record(config))
    if record not in sweeps:
        sweeps.append(record)
    write_json_atomic(path, dict(schema=SCHEMA, sweeps=sweeps))


def _sweep_record(config: SweepConfig) -> dict[str, Any]:
    return dict(
        schema=SCHEMA,
        config=dataclasses.asdict(config),
        timesteps=TIMESTEPS,
        thresholds=THRESHOLDS,
        gp_kwargs=GP_KWARGS,
        hyperparams_source=ZOO_SOURCE,
        deviations=list(DEVIATIONS),
    )


def _progress_bar(total: int, done: int, enabled: bool) -> Any:
    if not enabled:
        return None
    return tqdm(total=total, initial=done, desc="runs", unit="run", dynamic_ncols=True)
