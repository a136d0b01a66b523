# Session 56's GPU check of 0.31.1, run from the repository root on the device machine; .whl/
# held the wheels that machine lacks (stable_baselines3 2.9.2, gymnasium 1.4.0,
# farama_notifications, sb3_contrib 2.9.2) and this package's own. $OUT is the folder whose
# files came back. First the maze-ceiling test corrected after session 54's check
# (device_0_30_1), then device_check.py, then a 100,000-step PPO run with the GP on the GPU
# (long_training_run.py), then the whole suite.
set -o pipefail
python3 -m pip install -q --no-index --no-deps --no-compile --no-cache-dir --upgrade --target /tmp/site .whl/*.whl && export PYTHONPATH=/tmp/site || exit 1
export PYTHONUNBUFFERED=1 MPLBACKEND=Agg
{ nvidia-smi --query-gpu=name,driver_version,memory.total --format=csv; nproc
  python3 -c "import torch,numpy,scipy,stable_baselines3 as s,gymnasium as g,sb3_geogp as p;print('torch',torch.__version__,'cuda',torch.cuda.is_available(),'numpy',numpy.__version__,'scipy',scipy.__version__,'sb3',s.__version__,'gym',g.__version__,'sb3_geogp',p.__version__,p.__file__)"; } 2>&1 | tee $OUT/env.log
python3 -m pytest -q -p no:cacheprovider \
  tests/studies/test_value_ceiling.py::test_the_maze_ceiling_leaves_ppo_as_it_was_and_its_returns_agree \
  2>&1 | tail -4 | tee $OUT/pytest_maze_ceiling.log
python3 examples/device_check.py --device cuda --out $OUT/device.json 2>&1 | tee $OUT/device_check.log
timeout 120 python3 examples/long_training_run.py --algo ppo --env Pendulum-v1 --timesteps 100000 \
  --device cuda --no-progress --out $OUT 2>&1 | tee $OUT/long_training_run.log
timeout ${SUITE_S:-340} python3 -m pytest -q -p no:cacheprovider tests 2>&1 | tail -40 > $OUT/pytest_tail.log; echo "pytest rc=$?" >> $OUT/pytest_tail.log; cat $OUT/pytest_tail.log
