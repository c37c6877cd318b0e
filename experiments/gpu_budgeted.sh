#!/usr/bin/env bash
# A budgeted comparison of HALO and nerf_tuned on one GPU, in the paper's
# config, with each method's step cap set from its own measured step time so
# that its learning-rate (and window) schedule ends near the budget
# (docs/gpu.md). For configs whose methods train one stage, 'hi' (the light
# fields, configs/stanford_lf.py). Usage:
#   experiments/gpu_budgeted.sh CONFIG BUDGET_S WORKDIR OUT [extra --config flags...]
# Each method: a 200-step calibration run, then the budgeted run;
# WORKDIR/results.json collects both methods; a tarball of the workdir
# (without checkpoints) is written to OUT after each method.
set -euo pipefail
cfg=$1 budget=$2 work=$3 out=$4
shift 4
py=${PYTHON:-python3}
common=(--config="$cfg" --config.eval.lpips=False --config.eval.chunk=16384 "$@")
for m in halo nerf_tuned; do
  cal=$work.cal_$m
  $py -m halo_jax.cli.compare "${common[@]}" --workdir="$cal" --methods="$m" \
      --config.hi.steps=200 --config.hi.log_every=50 --curve_points=0 > "$out/cal_$m.log" 2>&1
  read -r steps alpha <<<"$($py - "$cal/$m/metrics.jsonl" "$budget" <<'PY'
import json, sys
rows = [json.loads(l) for l in open(sys.argv[1]) if '"hi"' in l]
w = {r["step"]: r["wall_s"] for r in rows}
step_s = (w[200] - w[50]) / 150
offset_s = w[50] - 50 * step_s  # wall_s excludes compilation: about 0
steps = int((float(sys.argv[2]) - offset_s) / step_s)
print(steps, steps // 4)  # the paper's window: alpha at its floor after 20k of 80k steps
print(f"step {step_s*1e3:.2f} ms, offset {offset_s:.1f} s -> cap {steps}", file=sys.stderr)
PY
)"
  echo "$m: hi.steps=$steps hi.joint.alpha_steps=$alpha"
  $py -m halo_jax.cli.compare "${common[@]}" --workdir="$work" --methods="$m" \
      --config.budget_s="$budget" --config.hi.steps="$steps" \
      --config.hi.joint.alpha_steps="$alpha" 2>&1 | grep -v "step/s" | tail -n 30
  tar czf "$out/$(basename "$work").tgz" --exclude=checkpoints --exclude=params \
      -C "$(dirname "$work")" "$(basename "$work")"
done
