#!/usr/bin/env bash
# A budgeted comparison of HALO and nerf_tuned on one GPU, in the paper's
# config, with step caps given up front (measured step times, docs/gpu.md) so
# that each stage's learning-rate schedule ends near its share of the budget.
# For the three-stage configs; the one-stage light fields calibrate their own
# caps (experiments/gpu_budgeted.sh). Usage:
#   experiments/gpu_capped.sh CONFIG BUDGET_S WORKDIR OUT SEED "HALO_CAPS" "NERF_CAPS"
# where each *_CAPS is a space-separated list of --config.* flags. After each
# method a tarball of the workdir (without checkpoints) is written to OUT.
# HALO_METHOD (default halo) names the HALO method, e.g. halo_authors.
set -euo pipefail
cfg=$1 budget=$2 work=$3 out=$4 seed=$5 halo_caps=$6 nerf_caps=$7
py=${PYTHON:-python3}
common=(--config="$cfg" --config.eval.lpips=False --config.eval.chunk=16384
        --config.budget_s="$budget" --config.seed="$seed" --workdir="$work")
halo=${HALO_METHOD:-halo}
for m in "$halo" nerf_tuned; do
  if [ "$m" = "$halo" ]; then caps=$halo_caps; else caps=$nerf_caps; fi
  # shellcheck disable=SC2086  # the caps are one flag per word
  $py -m halo_jax.cli.compare "${common[@]}" --methods="$m" $caps 2>&1 \
      | grep -v "step/s" | tail -n 30
  tar czf "$out/$(basename "$work")_seed$seed.tgz" --exclude=checkpoints --exclude=params \
      -C "$(dirname "$work")" "$(basename "$work")"
done
