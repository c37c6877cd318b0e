#!/usr/bin/env bash
# The throughput script on a lent GPU, with result files that come back.
#   experiments/gpu_throughput.sh OUT ["CONFIG [--flag=value ...]" ...]
# (default: lego_8view, its sin_cos=xla form, lego_8view_cpu)
# The device tool returns no file under a name with '+' (a config with
# overrides) or in a folder four levels down, which is where
# experiments/throughput.py writes (results/throughput/<config>/<machine>/).
# So each result is written under /tmp and copied to OUT/tp<k>.json, with
# OUT/paths.txt giving each one's place under results/throughput/:
#   paste -d' ' <(ls OUT/tp*.json) OUT/paths.txt   # then copy each into place
set -uo pipefail
out=$1
shift
configs=("$@")
[ ${#configs[@]} -gt 0 ] || configs=(configs/blender.py:lego_8view
    "configs/blender.py:lego_8view --config.sin_cos=xla" configs/blender.py:lego_8view_cpu)
py=${PYTHON:-python3}
# the checkout's package, whether or not it is installed
export PYTHONPATH="$PWD${PYTHONPATH:+:$PYTHONPATH}"
tmp=$(mktemp -d)
for run in "${configs[@]}"; do
  read -ra args <<< "$run"
  timeout 150 $py -m experiments.throughput --config="${args[0]}" --peak_n=8192 --results="$tmp" \
      "${args[@]:1}" \
      2>&1 | grep -v "^[IW][0-9]" | tail -n 8
done
k=0
: > "$out/paths.txt"
while IFS= read -r f; do
  k=$((k + 1))
  cp "$f" "$out/tp$(printf %02d $k).json"
  echo "${f#"$tmp"/}" >> "$out/paths.txt"
done < <(find "$tmp" -name '*.json' | sort)
echo "$k result files; their places: $out/paths.txt"
