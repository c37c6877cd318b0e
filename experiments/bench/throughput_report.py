"""Throughput result files (experiments/throughput.py) -> docs/results/throughput.md.

  python -m experiments.throughput_report [--results=results/throughput] [--docs=docs/results]
  python -m experiments.throughput_report --check   # exit 1 when the page is out of date

One file per measurement, results/throughput/<config>/<machine>/<UTC time>_<commit>.json,
committed. For each config and machine the page shows the newest measurement,
the change of every step against the measurement committed before it with the
commits between the two that touched the code (which change moved it), and
the history of all measurements. A step whose time moved by less than
NOISE of the older figure is called unchanged: best-of-rounds timings on the
2-core CPU repeat within a few per cent.
"""
import glob
import hashlib
import json
import os
import re
import subprocess
import sys

from absl import flags

from experiments.bench import tool
from experiments.bench.paths import REPO

FLAGS = flags.FLAGS
NOISE = 0.05
STEP_ORDER = ("lo", "ray", "hi", "nerf", "render")
# The code whose change can move a step's time: the commits the page names.
# experiments/throughput.py held the measurement before experiments/bench/ did
CODE_PATHS = ("halo_jax", "configs", "experiments/throughput.py")


def _slug(text: str) -> str:
  return re.sub(r"[^a-z0-9]+", "-", text.lower()).strip("-")


def config_slug(config: str, overrides: dict) -> str:
  """'configs/blender.py:lego_8view_cpu' (+ overrides) -> 'blender-lego_8view_cpu'
  (+ '+' and a hash of the overrides: each set of overrides is its own series)."""
  path, _, variant = config.partition(":")
  name = os.path.splitext(os.path.basename(path))[0] + (f"-{variant}" if variant else "")
  if overrides:
    text = json.dumps(overrides, sort_keys=True)
    name += "+" + hashlib.sha1(text.encode()).hexdigest()[:6]
  return name


def machine_slug(prov: dict) -> str:
  """'cpu-amd-epyc-9b14-2c' on a CPU (the cores the run used), the device
  kind on an accelerator ('gpu-nvidia-h100-80gb-hbm3')."""
  dev = prov["device"]
  if dev["backend"] == "cpu":
    return f"cpu-{_slug(prov['cpu']['model'])}-{prov['cpu']['cores_used']}c"
  return f"{dev['backend']}-{_slug(dev['kind'])}"


def result_path(root: str, record: dict) -> str:
  """Where throughput.py writes `record`: one new file per measurement."""
  prov = record["provenance"]
  stamp = prov["time_utc"].replace("-", "").replace(":", "")
  commit = (prov["git"]["commit"] or "nogit")[:7] + ("-dirty" if prov["git"]["dirty"] else "")
  return os.path.join(root, config_slug(record["config"], record.get("overrides", {})),
                      machine_slug(prov), f"{stamp}_{commit}.json")


def load(root: str) -> dict:
  """{(config series, machine): [record, ...] oldest first}."""
  out = {}
  for path in sorted(glob.glob(os.path.join(root, "*", "*", "*.json"))):
    series, machine = path.split(os.sep)[-3:-1]
    with open(path) as f:
      out.setdefault((series, machine), []).append(json.load(f))
  for records in out.values():
    records.sort(key=lambda r: r["provenance"]["time_utc"])
  return out


def _steps(record):
  return [s for s in STEP_ORDER if s in record["steps"]] + sorted(
      s for s in record["steps"] if s not in STEP_ORDER)


def compare(old: dict, new: dict) -> dict:
  """{step: {'old_ms', 'new_ms', 'ratio' (new/old time), 'old_share',
  'new_share', 'moved' ('faster', 'slower' or '')}} for the steps both have."""
  out = {}
  for s in _steps(new):
    if s not in old["steps"]:
      continue
    a, b = old["steps"][s], new["steps"][s]
    ratio = b["s_per_step"] / a["s_per_step"]
    moved = "" if abs(ratio - 1.0) < NOISE else ("faster" if ratio < 1.0 else "slower")
    out[s] = {"old_ms": 1e3 * a["s_per_step"], "new_ms": 1e3 * b["s_per_step"], "ratio": ratio,
              "old_share": a["share_of_peak"], "new_share": b["share_of_peak"], "moved": moved}
  return out


def commits_between(old: dict, new: dict, repo: str = REPO) -> list:
  """['<sha7> <subject>', ...]: the commits after `old`'s up to `new`'s that
  touched the code (CODE_PATHS); [] where git or either commit is missing."""
  a, b = old["provenance"]["git"]["commit"], new["provenance"]["git"]["commit"]
  if not a or not b or a == b:
    return []
  try:
    text = subprocess.run(["git", "-C", repo, "log", "--format=%h %s", f"{a}..{b}", "--",
                           *CODE_PATHS], capture_output=True, text=True, timeout=20,
                          check=True).stdout
  except (OSError, subprocess.SubprocessError):
    return []
  return [line for line in text.splitlines() if line.strip()]


def _commit(record):
  git = record["provenance"]["git"]
  return (git["commit"] or "no git")[:7] + (" (modified tree)" if git["dirty"] else "")


def latest_table(record: dict) -> str:
  lines = ["| step | ms | rays/s | samples/s | GFLOP/step | GFLOP/s | share of peak |",
           "|---|---|---|---|---|---|---|"]
  for s in _steps(record):
    r = record["steps"][s]
    lines.append(f"| {s} | {1e3 * r['s_per_step']:.2f} | {r['rays_per_s']:,.0f} | "
                 f"{r['samples_per_s']:,.0f} | {r['gflops']:.2f} | {r['gflops_per_s']:.1f} | "
                 f"{100 * r['share_of_peak']:.0f}% |")
  return "\n".join(lines)


def compare_table(old: dict, new: dict) -> str:
  lines = [f"| step | ms at {_commit(old)} | ms at {_commit(new)} | time ratio | share of peak "
           "| moved |", "|---|---|---|---|---|---|"]
  for s, c in compare(old, new).items():
    lines.append(f"| {s} | {c['old_ms']:.2f} | {c['new_ms']:.2f} | {c['ratio']:.2f} | "
                 f"{100 * c['old_share']:.0f}% -> {100 * c['new_share']:.0f}% | "
                 f"{c['moved'] or 'within noise'} |")
  return "\n".join(lines)


def history_table(records: list) -> str:
  steps = _steps(records[-1])
  lines = ["| measured (UTC) | commit | peak GFLOP/s | " + " | ".join(f"{s} ms" for s in steps)
           + " |", "|---|---|---|" + "---|" * len(steps)]
  for r in records:
    cells = [f"{1e3 * r['steps'][s]['s_per_step']:.2f}" if s in r["steps"] else "-"
             for s in steps]
    lines.append(f"| {r['provenance']['time_utc']} | {_commit(r)} | {r['peak_gflops']:.0f} | "
                 + " | ".join(cells) + " |")
  return "\n".join(lines)


def page(by_series: dict, repo: str = REPO) -> str:
  out = ["# Throughput, measured", "",
         "Generated by `python -m experiments.throughput_report` from "
         "`results/throughput/`; do not edit by hand. Each file is one run of "
         "`python -m experiments.throughput --config=...`: whole jitted training steps "
         "and a held-out render chunk, FLOPs from XLA's cost analysis, shares against an "
         "fp32 matmul on random operands measured at the start and end of the same run "
         "(the larger counts), each time the fastest of its rounds. "
         f"A step is 'within noise' when its time moved by less than {NOISE:.0%}. "
         "Notes on what the figures mean: [throughput.md](../throughput.md).", ""]
  if not by_series:
    out += ["No measurement yet.", ""]
  for (series, machine), records in sorted(by_series.items()):
    new = records[-1]
    prov = new["provenance"]
    over = new.get("overrides") or {}
    over = (" with " + " ".join(f"`--config.{k}={v}`" for k, v in sorted(over.items()))
            if over else "")
    out += [f"## `{new['config']}` on {machine}", "",
            f"{prov['cpu']['model']}, {prov['cpu']['cores_used']} cores used, "
            f"{prov['device']['kind']}; jax {prov['versions']['jax']}; matmul peak "
            f"{new['peak_gflops']:.0f} GFLOP/s (n={new['flags']['peak_n']})"
            + (f", bfloat16 operands {new['peak_bf16_gflops']:.0f}" if "peak_bf16_gflops" in new
               else "") + "; "
            f"{new['flags']['rounds']} rounds of {new['flags']['repeats']} steps{over}. "
            f"Newest: {prov['time_utc']}, commit {_commit(new)}.", "", latest_table(new), ""]
    if len(records) > 1:
      old = records[-2]
      moved = commits_between(old, new, repo)
      out += [f"Against the measurement committed before it ({old['provenance']['time_utc']}):",
              "", compare_table(old, new), ""]
      if moved:
        out += ["Code changes between the two (commits touching "
                + ", ".join(f"`{p}`" for p in CODE_PATHS) + "):", ""]
        out += [f"- {c}" for c in moved] + [""]
      else:
        out += ["No commit touching the code lies between the two: a change is the "
                "machine's, not the code's.", ""]
      out += ["History:", "", history_table(records), ""]
  return "\n".join(out)


def define_flags():
  flags.DEFINE_string("results", os.path.join(REPO, "results", "throughput"),
                      "Throughput result files' root.")
  flags.DEFINE_string("docs", os.path.join(REPO, "docs", "results"), "Output folder.")
  flags.DEFINE_bool("check", False, "Write nothing; exit 1 when the page is out of date.")


def main(argv):
  del argv
  text = page(load(FLAGS.results))
  path = os.path.join(FLAGS.docs, "throughput.md")
  if FLAGS.check:
    current = open(path).read() if os.path.exists(path) else ""
    if current != text:
      print(f"{path} is out of date: run python -m experiments.throughput_report")
      sys.exit(1)
    print(f"{path} is up to date")
    return
  os.makedirs(FLAGS.docs, exist_ok=True)
  with open(path, "w") as f:
    f.write(text)
  print("wrote", path)


def cli():
  """The tool's entry point (python -m experiments.<tool>)."""
  define_flags()
  tool.run(sys.modules[__name__], main)


if __name__ == "__main__":
  cli()
