# Session 53's GPU check, run from the repository root on the device machine; .whl/ held the
# wheels that machine lacks (stable_baselines3 2.9.2, gymnasium 1.4.0, farama_notifications,
# sb3_contrib 2.9.2) and this package's own. $OUT is the folder whose files came back.
set -o pipefail
python3 -m pip install -q --no-index --no-deps --no-compile --no-cache-dir --upgrade --target /tmp/site .whl/*.whl && export PYTHONPATH=/tmp/site || exit 1
export PYTHONUNBUFFERED=1 MPLBACKEND=Agg
{ nvidia-smi --query-gpu=name,driver_version,memory.total --format=csv; nproc
  python3 -c "import torch,numpy,scipy,stable_baselines3 as s,gymnasium as g,sb3_geogp as p;print('torch',torch.__version__,'cuda',torch.cuda.is_available(),'numpy',numpy.__version__,'scipy',scipy.__version__,'sb3',s.__version__,'gym',g.__version__,'sb3_geogp',p.__version__,p.__file__)"; } 2>&1 | tee $OUT/env.log
python3 examples/device_check.py --device cuda --out $OUT/device.json 2>&1 | tee $OUT/device_check.log
for d in cpu cuda; do /usr/bin/time -f "wall %e s" python3 -m sb3_geogp.cli train --algo ppo --env Pendulum-v1 --timesteps 20000 --device $d --no-progress --out /tmp/run_$d 2>&1 | tail -15; python3 -c "import json,sys;print(open('/tmp/run_$d/train_settings.json').read()[:600])"; done 2>&1 | tee $OUT/train.log
timeout 330 python3 -m pytest -q -p no:cacheprovider tests 2>&1 | tail -40 > $OUT/pytest_tail.log; echo "pytest rc=$?" >> $OUT/pytest_tail.log; cat $OUT/pytest_tail.log
