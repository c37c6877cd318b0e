"""One method's training run on one scene, as a small result record.

Shared by the compare command (halo_jax/cli/compare.py) and
experiments/bench/benchmark.py: the record
holds the held-out metrics (mean and per view), the held-out PSNR curve
against training seconds, each stage's steps and seconds, and provenance.
"""
import json
import os

from halo_jax import pipeline, protocol, provenance
from halo_jax.stages import collapse, metrics_log


def read_curve(workdir, heldout=True):
  """[[training seconds, PSNR], ...] from a run's metrics.jsonl (the last
  record of each stage and step, so a resumed run is not counted twice): the
  held-out evaluations, or with heldout=False the logged training batches of
  the stages that render. The seconds are the reference clock's (the same on
  any machine) where the log has them, else this machine's training seconds."""
  points = {}
  for r in metrics_log.read(workdir):
    if bool(r.get("heldout")) == heldout and "psnr" in r:
      points[(r.get("stage"), r.get("step"))] = [r.get("reference_s", r["wall_s"]), r["psnr"]]
  return sorted(points.values())


def run_method(config, workdir, dataset=None) -> dict:
  """Trains `config` in `workdir` (resuming what is there) and returns its record.

  A run whose stage collapsed (stages/collapse.py) is recorded too, flagged:
  its figures are the collapsed stage's held-out evaluation (the last images
  the method made), and record['collapsed'] names the stage and its verdict."""
  collapsed = None
  try:
    infos = pipeline.run(config, workdir, dataset)
    final = config.final_stage
  except collapse.Collapsed as e:
    infos, collapsed = e.infos, {"stage": e.stage, **e.verdict}
    # the last images the method made (a collapsed ray field renders none)
    final = [n for n, i in infos.items() if "eval" in i][-1]
  last = infos[final]["eval"]
  rounded = {n: {k: round(v, 5) for k, v in m.items()} for n, m in last["per_view"].items()}
  return {"psnr": last["psnr"], "ssim": last["ssim"], "lpips": last.get("lpips"),
          **({"flicker": last["flicker"]} if "flicker" in last else {}),
          "num_views": last["num_views"], "per_view": rounded,
          "wall_s": sum(i["wall_s"] for i in infos.values()),
          # the method's reference seconds at its end (halo_jax/protocol.py): under a
          # budget the same on any machine, beside this machine's wall_s
          "reference_s": max(i.get("reference_end_s", 0.0) for i in infos.values()),
          "protocol": protocol.summary(config),  # resolved: pipeline.run checks it
          "stages": {n: {"wall_s": i["wall_s"], "step": i["step"],
                         # what a time-budgeted run's step count rests on: a change of
                         # speed shows here, not in the code's fingerprint
                         "steps_per_s": round(i["step"] / i["wall_s"], 3) if i["wall_s"] else None,
                         "skipped": i.get("skipped", 0),
                         **{k: i[k] for k in ("past_time_cap", "target_s", "target_rays",
                                              "setup_s", "reference_end_s", "fixed_steps",
                                              "measured_step_s") if k in i},
                         **({"psnr": i["eval"]["psnr"]} if "eval" in i else {})}
                     for n, i in infos.items()},
          "learned": {n: i["learned"]["verdict"] for n, i in infos.items() if "learned" in i},
          "heldout_learned": {n: i["heldout_learned"]["verdict"] for n, i in infos.items()
                              if "heldout_learned" in i},
          **({"collapsed": collapsed} if collapsed else {}),
          "curve": read_curve(workdir),
          # training-batch PSNR against the same clock: whether a field still fits
          # its training views while its held-out figure has stopped rising
          "train_curve": read_curve(workdir, heldout=False),
          **_frequency_choice(workdir),
          "provenance": provenance.collect(),
          # every field the run read, as resolved: the record stands without its config file
          "resolved_config": json.loads(config.to_json_best_effort())}


def learned_cell(record: dict) -> str:
  """'yes', 'collapsed (<stage>)', 'constant on held-out views (<stage>)',
  'unjudged' or '-' (no verdict: a smoke run or an old record)."""
  if "collapsed" in record:
    return f"collapsed ({record['collapsed']['stage']})"
  flat = [n for n, v in (record.get("heldout_learned") or {}).items() if v == collapse.COLLAPSED]
  if flat:
    return f"constant on held-out views ({', '.join(flat)})"
  verdicts = set((record.get("learned") or {}).values())
  if collapse.LEARNED in verdicts:
    return "yes"
  return "unjudged" if collapse.UNJUDGED in verdicts else "-"


def _frequency_choice(workdir):
  """{'frequency_rule': {'chosen', 'note', 'grid'}} where the run searched Lo's
  frequency (lo.encoding.auto), else {}."""
  path = os.path.join(workdir, "tune", "results.json")
  if not os.path.exists(path):
    return {}
  with open(path) as f:
    r = json.load(f)
  return {"frequency_rule": {"chosen": r["chosen"], "note": r.get("note", ""),
                             "grid": [{k: g[k] for k in ("L", "scale", "criterion", "psnr")}
                                      for g in r["grid"]]}}


def seconds_to_reach(records, level):
  """Mean over `records` (seeds) of the first curve time at which held-out
  PSNR >= level; None if some record never reaches it."""
  times = []
  for r in records:
    hit = [t for t, p in r["curve"] if p >= level]
    if not hit:
      return None
    times.append(hit[0])
  return sum(times) / len(times)


def common_level(records, margin_db=0.5, of="min"):
  """The PSNR a 'seconds to reach' column uses: the lowest ('min': every record
  reaches it) or the median ('median': half do, so that a method that fails is
  not the yardstick) of the records' curve peaks, less margin_db; None
  without curves."""
  peaks = sorted(max(p for _, p in r["curve"]) for r in records if r["curve"])
  if not peaks:
    return None
  if of == "min":
    return peaks[0] - margin_db
  mid = len(peaks) // 2
  median = peaks[mid] if len(peaks) % 2 else 0.5 * (peaks[mid - 1] + peaks[mid])
  return median - margin_db
