"""Does fit_spacing=4096 change the fixed-policy check's adaptive on-line GP? Both arms over the
check's own streams (10 seeds, 20/50/100/200 BVs, laplacian, level trend, forgetting 0.1 per
4096 points, PPO's adaptation as the 0.35 check ran it); per case: refits in each arm and
whether the final GP states (refit_seen excepted) and their predictions on the check's 60 x 60
grid are equal bit for bit. Where every case is, the check's batch GP (fitted from the
adaptive GP's basis and hyperparameters) and its ratio are the same too.

    python results/fit_spacing/fixed_policy.py > results/fit_spacing/fixed_policy.txt
"""

import dataclasses
import json

import torch

from sb3_geogp.policies import DEFAULT_ADAPTATION
from sb3_geogp.studies.pendulum.batch_check import (
    CheckConfig,
    episode_batches,
    new_online_gp,
    stream,
)
from sb3_geogp.studies.pendulum.task import Task

torch.set_num_threads(1)
# "default": PPO's adaptation as the 0.35 check ran it (0.35-0.38's); "spaced": 0.39's.
arms = {
    "default": dataclasses.replace(DEFAULT_ADAPTATION, fit_spacing=None),
    "spaced": DEFAULT_ADAPTATION,
}
task = Task()
rows = []
for seed in range(10):
    for m in (200, 100, 50, 20):
        cfg = {
            k: CheckConfig(
                kernels=("laplacian",),
                max_basis=(m,),
                seeds=(seed,),
                adaptation=a,
                trend="level",
                forgetting=0.1,
                forgetting_points=4096,
            )
            for k, a in arms.items()
        }
        data = stream(task, cfg["default"], seed)
        gps, refits = {}, {}
        for k, c in cfg.items():
            gp = new_online_gp(task, "laplacian", data.states.shape[1], m, c, adapt=True)
            n, last = 0, 0  # refit_seen before the first feed
            for r in episode_batches(data.episode_starts, c.episodes_per_batch):
                gp.update(data.states[r], data.returns[r], episode_starts=data.episode_starts[r])
                if int(gp.refit_seen) != last:
                    n, last = n + 1, int(gp.refit_seen)
            gps[k], refits[k] = gp, n
        a, b = gps["default"].state_dict(), gps["spaced"].state_dict()
        same = all(
            torch.equal(a[x], b[x])
            for x in a
            if torch.is_tensor(a[x]) and not x.endswith("refit_seen")
        )
        states, _, _ = task.grid(60)
        same = same and torch.equal(
            gps["default"].predict(states)[0], gps["spaced"].predict(states)[0]
        )
        row = dict(
            seed=seed,
            max_basis=m,
            refits_default=refits["default"],
            refits_spaced=refits["spaced"],
            identical=same,
        )
        print(json.dumps(row), flush=True)
        rows.append(row)
print("identical in", sum(r["identical"] for r in rows), "of", len(rows))
