"""Calibrates the frequency rule's threshold: full grids on every scene, then
leave-one-scene-out.

  python -m experiments.calibrate_frequency                 # run what is missing, then report
  python -m experiments.calibrate_frequency --only=lego     # some scenes (regex on the name)
  python -m experiments.calibrate_frequency --report_only   # tables and figures from the files
  python -m experiments.calibrate_frequency --views=validation  # the grid scored on validation views

For each scene (the CPU suite's scenes that have a Lo-NeRF: experiments/bench/suites.py)
every point of `tune.grid` trains a short Lo-NeRF (`--lo_steps`), scores rho on
the scene's view pairs and Lo-NeRF's held-out PSNR (halo_jax/frequency/tuning.py). One
small JSON per scene goes to results/frequency/<scene>.json (committed: a scene
whose file exists is not rerun; a killed scene resumes its grid from
--scratch). The report (halo_jax/frequency/calibration.py) chooses the threshold on all
scenes but one and evaluates it on the one left out, for each scene, and the
threshold on all scenes (the value to freeze in defaults.py). It writes
docs/results/frequency_calibration.md and a figure per scene.
"""
import json
import os
import re
import sys
import time

from absl import flags, logging

from experiments.bench import run_file, suites, tool
from experiments.bench.paths import REPO
from halo_jax import defaults
from experiments.bench import git_state
from experiments.bench import frequency_calibration as calibration
from halo_jax.configure import compose

FLAGS = flags.FLAGS


def define_flags():
  """Defined on launch, not on import (tests import several experiments)."""
  flags.DEFINE_enum("views", "test", ["test", "validation"],
                    "held-out views the grid's PSNR is scored on: the suite's test views (the "
                    "calibration as first made) or each scene's validation views")
  flags.DEFINE_string("results", "", "Result files ('': results/frequency, or "
                      "results/frequency_val for --views=validation).")
  flags.DEFINE_string("scratch", "/tmp/halo_calibrate", "Grid points' workdirs.")
  flags.DEFINE_string("docs", os.path.join(REPO, "docs", "results"), "Report folder.")
  flags.DEFINE_string("only", "", "Scenes whose name matches this regex.")
  flags.DEFINE_integer("lo_steps", 300, "Training steps of each grid point's Lo-NeRF.")
  flags.DEFINE_bool("report_only", False, "Write the report from the result files; train nothing.")

# Scenes with a Lo-NeRF stage (the light field's HALO has none: the rule
# does not apply to it, and `auto` refuses it).
SCENES = tuple(s for s in suites.CPU.scenes if "halo" in s.methods and s.name != "knights")
# The same kinds on the validation suite, each scene's validation views in
# the test slot (docs/validation.md): where the threshold is to be chosen.
VALIDATION_SCENES = tuple(s for s in suites.VALIDATION_SCENES
                          if "halo" in s.methods and s.name != "knights")

# --views: (scenes, result folder under results/, page name)
VIEWS = {"test": (SCENES, "frequency", "frequency_calibration"),
         "validation": (VALIDATION_SCENES, "frequency_val", "frequency_calibration_val")}


def configure(scene, lo_steps, scratch, validation=False):
  fields = dict(suites.VALIDATION_VIEWS + tuple(scene.overrides)) if validation else {}
  fields.update({"tune.lo_steps": lo_steps, "tune.lo_seconds": 0.0})
  first = compose(scene.config, "halo", fields, protocol="steps")
  if first.data.kind == "procedural" and not first.data.root:
    fields["data.root"] = os.path.join(
        scratch, "scenes", f"{first.data.procedural_scene}_{first.data.procedural_size}")
  return compose(scene.config, "halo", fields, protocol="steps")


def run_scene(scene, lo_steps, scratch, results, validation=False):
  from halo_jax import datasets, pipeline
  from halo_jax.frequency import tuning
  c = configure(scene, lo_steps, scratch, validation)
  workdir = os.path.join(scratch, scene.name)
  os.makedirs(workdir, exist_ok=True)
  start = time.time()
  dataset = datasets.load(c.data, workdir)
  res = tuning.tune(c, workdir, dataset, pipeline.run, full_grid=True)
  hi = c.hi.encoding
  record = {
      "scene": scene.name, "config": scene.config, "lo_steps": lo_steps,
      "held_out": {"split": c.data.test_split, "views": c.data.test_views},
      "hi_freq": 2.0 ** (hi.L - 1) / hi.scale,
      "hand_set": {"L": c.lo.encoding.L, "scale": c.lo.encoding.scale},
      "tune": {k: c.tune[k] for k in ("grid", "num_pairs", "size", "shift_px",
                                      "mask_fraction", "seed", "warp")},
      "grid": [{k: g[k] for k in ("L", "scale", "max_freq", "criterion", "criterion_plain",
                                  "criterion_warped", "per_pair",
                                  "shift_px", "pair_kind", "psnr", "ssim", "wall_s", "steps",
                                  "collapsed")}
               for g in res["grid"]],
      "run_seconds": round(time.time() - start, 1),
      "provenance": git_state.collect()}
  path = os.path.join(results, f"{scene.name}.json")
  run_file.write_json(path, record)
  return record


def load_results(results):
  out = {}
  for name in sorted(os.listdir(results)) if os.path.isdir(results) else []:
    if name.endswith(".json"):
      with open(os.path.join(results, name)) as f:
        r = json.load(f)
      out[r["scene"]] = r
  return out


def made_by(scenes) -> list:
  """The page's line naming the commit and code tree each scene's grid was
  run at, and whether that tree had uncommitted changes."""
  groups = {}
  for name, r in scenes.items():
    git = r.get("provenance", {}).get("git") or {}
    state = "modified" if git.get("dirty") or git.get("code_dirty") else "clean"
    key = ((git.get("commit") or "?")[:7], git.get("code_tree") or "not recorded", state)
    groups.setdefault(key, []).append(name)
  return ["Made by: " + "; ".join(
      f"commit {c} (code tree {t}, {state}): {', '.join(sorted(names))}"
      for (c, t, state), names in sorted(groups.items())) + ".", ""]


def auto_section(runs_root):
  """Markdown lines: halo_auto (suite 'auto') against the CPU suite's hand-set
  halo, per scene and seed, from the benchmark's result files."""
  import glob
  rows = []
  for path in sorted(glob.glob(os.path.join(runs_root, "auto", "time", "*", "halo_auto",
                                            "seed*.json"))):
    scene, seed = path.split(os.sep)[-3], os.path.basename(path)[:-5]
    with open(path) as f:
      auto = json.load(f)
    hand_path = os.path.join(runs_root, "cpu", "time", scene, "halo", f"{seed}.json")
    hand = json.load(open(hand_path)) if os.path.exists(hand_path) else None
    ch = auto.get("frequency_rule", {}).get("chosen", {})
    rows.append(f"| {scene} | {seed} | {ch.get('L')}:{ch.get('scale', 0):g} | "
                f"{auto['psnr']:.2f} | " + (f"{hand['psnr']:.2f} | {auto['psnr'] - hand['psnr']:+.2f} |"
                                            if hand else "not run | |"))
  if not rows:
    return []
  return ["## `auto` against the hand-set CPU config", "",
          "HALO with the rule's choice (`halo_auto`, `results/auto/time/`) and with the hand-set "
          "Lo frequency (`halo`, `results/cpu/time/`), the same budget, core and seed; the "
          "search's own training is outside the budget.", "",
          "| scene | seed | chosen L:s | auto PSNR | hand-set PSNR | auto - hand-set |",
          "|---|---|---|---|---|---|"] + rows + [""]


# (name, tune.warp, tune.relative): the rule's forms the calibration compares.
FORMS = (("rho", False, False), ("rho / rho at Hi's frequency", False, True),
         ("warped rho", True, False), ("warped rho / warped rho at Hi's frequency", True, True))


def calibrate(scenes):
  """Every form of the rule, each by leave-one-out: {form: {'warp',
  'relative', 'loo', 'frozen', 'mean_regret'}}, and the form with the least
  mean leave-one-out distance (the simplest on a tie: FORMS order)."""
  out = {}
  for form, warp, relative in FORMS:
    key = "criterion_warped" if warp else "criterion_plain"
    if not all(key in r for s in scenes.values() for r in s["grid"]):
      if warp:
        continue
      key = "criterion"  # files from before the warped form: rho is the plain one
    s = calibration.scored(scenes, relative, key)
    loo = calibration.leave_one_out(s)
    out[form] = {"warp": warp, "relative": relative, "key": key, "loo": loo,
                 "frozen": calibration.choose(s),
                 "mean_regret": sum(r["regret"] for r in loo.values()) / len(loo)}
  best = min(out, key=lambda f: round(out[f]["mean_regret"], 6))
  return out, best


def reference_rows(scenes):
  """Choices that need no rule, as table rows: the grid point just below
  Hi-NeRF's frequency everywhere, and the hand-set configs' points."""
  def mean_distance(choose_row):
    d = [max(r["psnr"] for r in s["grid"]) - choose_row(s)["psnr"] for s in scenes.values()]
    return sum(d) / len(d)
  on_grid = lambda s: next((r for r in s["grid"] if (r["L"], r["scale"]) == (
      s["hand_set"]["L"], s["hand_set"]["scale"])), None)
  rows = [f"| (no rule) always the grid's second point, one below Hi-NeRF's frequency | "
          f"{mean_distance(lambda s: s['grid'][1]):.2f} | |"]
  if all(on_grid(s) for s in scenes.values()):
    rows.append(f"| (no rule) the hand-set CPU configs | {mean_distance(on_grid):.2f} | |")
  return rows


def _loo_table(scenes, loo):
  lines = ["| scene | threshold (chosen on the others) | pick L:s | pick PSNR | best L:s | "
           "best PSNR | distance dB | hand-set L:s |", "|---|---|---|---|---|---|---|---|"]
  for name, r in loo.items():
    hs = scenes[name]["hand_set"]
    lines.append(f"| {name} | {r['threshold']:.4g} | {r['pick'][0]}:{r['pick'][1]:g} | "
                 f"{r['pick_psnr']:.2f} | {r['best'][0]}:{r['best'][1]:g} | {r['best_psnr']:.2f} "
                 f"| {r['regret']:.2f} | {hs['L']}:{hs['scale']:g} |")
  regrets = [r["regret"] for r in loo.values()]
  within = sum(x <= 1.0 for x in regrets)
  return lines + ["", f"Leave-one-out: {within} of {len(regrets)} picks within 1 dB of their "
                  f"scene's best grid point; mean distance {sum(regrets) / len(regrets):.2f} dB, "
                  f"largest {max(regrets):.2f} dB.", ""]


def _scene_section(name, s, frozen, relative, docs, prefix="frequency"):
  from halo_jax import plots
  from halo_jax.frequency import tuning
  first = s["grid"][0]["criterion"]
  lines = [f"## {name}", "",
           f"`{s['config']}`, Lo-NeRF {s['lo_steps']} steps per point, pairs "
           f"'{s['grid'][0]['pair_kind']}', Hi-NeRF's frequency {s['hi_freq']:g}.", "",
           "| L | s | max freq | rho | warped rho | score (frozen form) | Lo held-out PSNR | "
           "SSIM | median shift px | learned |",
           "|---|---|---|---|---|---|---|---|---|---|"]
  for g in s["grid"]:
    shift = sorted(g["shift_px"])[len(g["shift_px"]) // 2]
    lines.append(f"| {g['L']} | {g['scale']:g} | {g['max_freq']:g} | "
                 f"{g.get('criterion_plain', float('nan')):.4f} | "
                 f"{g.get('criterion_warped', float('nan')):.4f} | "
                 f"{tuning.score(g['criterion'], first, relative):.4f} | {g['psnr']:.2f} | "
                 f"{g['ssim']:.3f} | {shift:.2f} | "
                 # files from before the collapse check carry no verdict
                 f"{ {True: 'collapsed', False: 'yes'}.get(g.get('collapsed'), '-')} |")
  png = f"{prefix}_{name}.png"
  plots.criterion_and_psnr([f"{g['L']}:{g['scale']:g}" for g in s["grid"]],
                           [tuning.score(g["criterion"], first, relative) for g in s["grid"]],
                           [g["psnr"] for g in s["grid"]], os.path.join(docs, png),
                           threshold=frozen, xlabel="Lo-NeRF P.E. L:s (high to low frequency)",
                           psnr_label="Lo-NeRF held-out PSNR (dB)", title=name)
  return lines + ["", f"![{name}]({png})", ""]


def report(scenes, docs, runs_root=None, views="test"):
  """Writes the calibration page of `views` (VIEWS: frequency_calibration.md
  for the test views, frequency_calibration_val.md for the validation views;
  + PNGs); returns (markdown, {'relative', 'threshold'}: the settings to
  freeze)."""
  _, folder, page = VIEWS[views]
  forms, best = calibrate(scenes)
  chosen = forms[best]
  frozen = chosen["frozen"]["threshold"]
  os.makedirs(docs, exist_ok=True)
  lines = [
      "# Frequency rule: calibration by leave-one-scene-out"
      + (", on validation views" if views == "validation" else ""), "",
      f"Generated by `experiments/calibrate_frequency.py --views={views} --report_only` from "
      f"`results/{folder}/*.json`; do not edit. Protocol: docs/frequency.md. The PSNR is "
      "Lo-NeRF's on the scene's "
      + ("validation views (docs/validation.md)" if views == "validation" else "held-out views")
      + "; for each scene the threshold is chosen on the other scenes only.", "",
      *made_by(scenes),
      "| form of the rule | mean leave-one-out distance dB | threshold on all scenes |",
      "|---|---|---|"]
  for form, f in forms.items():
    lines.append(f"| {form}{' (chosen)' if form == best else ''} | {f['mean_regret']:.2f} | "
                 f"{f['frozen']['threshold']:.4g} |")
  lines += reference_rows(scenes)
  lines += ["", f"Frozen: `tune.warp={chosen['warp']}`, `tune.relative={chosen['relative']}`, "
            f"`tune.threshold={frozen:.4g}` "
            f"(chosen on all {len(scenes)} scenes; mean distance to each scene's best grid "
            f"point {chosen['frozen']['mean_regret']:.2f} dB).", "",
            f"### Leave-one-out, {best}", ""]
  lines += _loo_table(scenes, chosen["loo"])
  for other in (f for f in forms if f != best):
    lines += [f"### Leave-one-out, {other}", ""] + _loo_table(scenes, forms[other]["loo"])
  if runs_root:
    lines += auto_section(runs_root)
  for name, s in calibration.scored(scenes, False, chosen["key"]).items():
    lines += _scene_section(name, s, frozen, chosen["relative"], docs,
                            "frequency" if views == "test" else "frequency_val")
  text = "\n".join(lines) + "\n"
  with open(os.path.join(docs, f"{page}.md"), "w") as f:
    f.write(text)
  return text, {"warp": chosen["warp"], "relative": chosen["relative"], "threshold": frozen}


def main(argv):
  del argv
  logging.set_verbosity(logging.WARNING)
  scene_list, folder, _ = VIEWS[FLAGS.views]
  validation = FLAGS.views == "validation"
  results = FLAGS.results or os.path.join(REPO, "results", folder)
  if not FLAGS.report_only:
    for scene in scene_list:
      if not re.search(FLAGS.only, scene.name):
        continue
      path = os.path.join(results, f"{scene.name}.json")
      if os.path.exists(path):
        print(f"done     {scene.name}")
        continue
      if scene.needs and not os.path.isdir(os.path.join(defaults.data_root(), scene.needs)):
        print(f"no data  {scene.name} ({scene.needs})")
        continue
      r = run_scene(scene, FLAGS.lo_steps, FLAGS.scratch, results, validation)
      print(f"ran      {scene.name}: " + ", ".join(
          f"{g['L']}:{g['scale']:g} rho {g['criterion']:.3f} PSNR {g['psnr']:.2f}"
          for g in r["grid"]), flush=True)
  scenes = load_results(results)
  if len(scenes) >= 2:
    text, frozen = report(scenes, FLAGS.docs, os.path.dirname(results), FLAGS.views)
    print(text.split("\n## ")[0])
    print(f"frozen: tune.warp={frozen['warp']}, tune.relative={frozen['relative']}, "
          f"tune.threshold={frozen['threshold']:.4g}")


def cli():
  """The tool's entry point (python -m experiments.<tool>)."""
  define_flags()
  tool.run(sys.modules[__name__], main)


if __name__ == "__main__":
  cli()
