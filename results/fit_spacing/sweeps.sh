# Sourced by the run.sh of results/fit_spacing, fit_spacing_2048 and fit_spacing_tradeoff.

# spaced_adapt S: PPO's default adaptation with fit_spacing S, as the JSON --gp-option takes.
spaced_adapt() {
    python -c "from stable_baselines3 import PPO; from sb3_geogp.policies import default_adaptation; import json; d = default_adaptation(PPO).as_dict(); d['fit_spacing'] = $1; print(json.dumps(d))"
}

# table_sweep ADAPT ENV...: PPO's laplacian critic with --gp-option adapt=ADAPT on issue 13's
# table's 50 seeds (0-19, 150-169, 570-579) in each ENV, in order, into $OUT/table/ENV_sFIRST.
table_sweep() {
    local adapt=$1 env block
    shift
    for env in "$@"; do
      for block in 0:20 150:20 570:10; do
        sb3-geogp compare --algos ppo --critics laplacian --envs "$env" \
            --gp-option "adapt=$adapt" --seeds "${block#*:}" --first-seed "${block%%:*}" \
            --workers 2 --no-progress --no-plots --out "$OUT/table/${env#sb3_geogp/}_s${block%%:*}"
      done
    done
}
