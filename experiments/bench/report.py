"""Turns benchmark result files into docs/results/ pages, plots and the README summary.

  python -m experiments.report [--results=results] [--docs=docs/results]

For every suite and mode under --results (results/<suite>/<mode>/<scene>/
<method>/seed<k>.json, written by experiments/benchmark.py) it writes
docs/results/<suite>_<mode>.md: per scene, each method's held-out PSNR /
SSIM / LPIPS as mean +- standard deviation over seeds, the steps trained,
the gap to nerf_tuned, and the seconds to reach a common PSNR (the median of
the runs' curve peaks less 0.5 dB; '-' for a method some seed of which never
reaches it);
then the mean over the scenes where every method has a result; the machines
and commits the runs came from. Plots: held-out PSNR against training
seconds, one band (min to max over seeds) and mean line per method, one
figure per scene. The README's results block (between its
`<!-- results:begin -->` / `<!-- results:end -->` markers) is regenerated
from the same files. A "By stage" section sets each multi-stage method's
Lo-NeRF beside its output and names every run whose later stage ended below
an earlier one. Fronts (error against training time, the README's
headline where a suite has them) are experiments/bench/fronts_report.py's. Nothing
here is typed by hand.
"""
import collections
import functools
import glob
import json
import os
import re
import sys

from absl import flags
import numpy as np

from experiments.bench import (budget_report, ci_records, code_version, fronts_report,
                               host_spread, report_common, tool)
from experiments.bench.paths import REPO
from experiments.bench.report_common import (BASELINE, METHOD_ORDER, collapsed_methods,
                                          in_method_order, stat)
from experiments.bench.suite_tables import (FAILURE_DROP_DB, claims, over_scenes_table,
                                         plot_scene, provenance_lines,
                                         scene_table, stage_table, summary_table,
                                         validation_table, scene_overrides)

FLAGS = flags.FLAGS


def define_flags():
  """Defined on launch, not on import (the tests import this module beside benchmark.py)."""
  flags.DEFINE_string("results", os.path.join(REPO, "results"), "Result files' root.")
  flags.DEFINE_string("docs", os.path.join(REPO, "docs", "results"), "Output folder.")
  flags.DEFINE_string("readme", os.path.join(REPO, "README.md"), "README to update ('': none).")



def load(results_root):
  """{(suite, mode): {scene: {method: [record, ...]}}} from the result files."""
  out = collections.defaultdict(lambda: collections.defaultdict(dict))
  for path in sorted(glob.glob(os.path.join(results_root, "*", "*", "*", "*", "seed*.json"))):
    suite, mode, scene, method = path.split(os.sep)[-5:-1]
    if suite in ("ablations", "trials"):  # reported by their studies and notes
      continue
    if mode == host_spread.MODE:  # a suite's runs trained again: the budget study's host spread
      continue
    with open(path) as f:
      out[(suite, mode)][scene].setdefault(method, []).append(json.load(f))
  return out


def pool(scenes, table):
  """(pooled scenes, versions): each method keeps, per scene kind, only its
  records of one code fingerprint (code_version.choose; a fingerprint is
  measured per kind), so no table mixes the numbers of two codes. versions:
  {method: {'fingerprint' (the most records'), 'by_kind' (kinds of another
  fingerprint), 'runs', 'current', 'aside': [(scene, record, why), ...]}}."""
  methods = in_method_order({m: 1 for by in scenes.values() for m in by})
  pooled = collections.defaultdict(dict)
  versions = {}
  for m in methods:
    tagged = [(s, r) for s, by in sorted(scenes.items()) for r in by.get(m, [])]
    kinds = collections.defaultdict(list)
    for s, r in tagged:
      kinds[code_version.kind_of(r.get("config", ""))].append(r)
    fps, chosen, aside = {}, [], []
    for kind, records in sorted(kinds.items()):
      fps[kind], c, a = code_version.choose(records, table)
      chosen += c
      aside += a
    for s, r in tagged:
      if any(r is c for c in chosen):
        pooled[s].setdefault(m, []).append(r)
    why = lambda r: code_version.of_record(r, table)  # noqa: E731
    rates = [final_steps_per_s(r) for r in chosen]
    rates = [x for x in rates if x]
    counts = collections.Counter()
    for kind, fp in fps.items():
      counts[fp] += sum(any(r is c for c in chosen) for r in kinds[kind])
    fp = counts.most_common(1)[0][0] if counts else None
    versions[m] = {"fingerprint": fp, "runs": len(chosen),
                   "by_kind": {k: f for k, f in fps.items() if f != fp},
                   "steps_per_s": float(np.median(rates)) if rates else None,
                   "current": all(f is not None and f == code_version.current(m, table, k)
                                  for k, f in fps.items()) and bool(fps),
                   "newest": (code_version.newest(table)[1].get("commit") or "?")[:7],
                   "aside": [(s, r, why(r)) for s, r in tagged if any(r is a for a in aside)],
                   "step_table_changed": m in _step_table_changes(json.dumps(table))}
  return dict(pooled), versions


@functools.lru_cache(maxsize=4)
def _step_table_changes(table_json: str) -> tuple:
  return tuple(code_version.step_table_changes(json.loads(table_json)))


def final_steps_per_s(rec):
  """The last stage's training steps per second (a time-budgeted run's step
  count rests on it; the fingerprint does not see speed)."""
  stages = rec.get("stages") or {}
  if not stages:
    return None
  last = stages[list(stages)[-1]]
  return last.get("steps_per_s") or (last["step"] / last["wall_s"] if last.get("wall_s") else None)


def version_lines(versions):
  """The page's 'Code versions' section: what each method's figures pool, and
  every run set aside (another fingerprint, an unmeasured or modified tree)."""
  out = ["## Code versions", "",
         "Each method's figures on this page pool only its runs of one code fingerprint "
         "(`experiments/bench/code_version.py`: the hash of what the method's fingerprint runs, "
         "short real runs of every stage on every scene kind, compute; measured per code tree "
         "by `experiments/same_numbers.py --record`). "
         "Current: the newest measured commit "
         f"({next(iter(versions.values()))['newest'] if versions else '?'}) measures the same "
         "fingerprint for the method. The fingerprint does not see speed: the final "
         "stage's steps per second show a change of it.", "",
         "| method | fingerprint pooled | runs pooled | current | final stage's steps/s "
         "(median of pooled runs) | runs set aside |",
         "|---|---|---|---|---|---|"]
  for m, v in versions.items():
    why = collections.Counter(w for _, _, w in v["aside"])
    aside = ", ".join(f"{n} ({w})" for w, n in sorted(why.items())) or "none"
    rate = v.get("steps_per_s")
    out.append(f"| {m} | {v['fingerprint'] or 'none measured'} | {v['runs']} | "
               f"{'yes' if v['current'] else '**no**'} | "
               f"{'-' if rate is None else f'{rate:.2f}'} | {aside} |")
  rows = [(s, m, r, w) for m, v in versions.items() for s, r, w in v["aside"]]
  if rows:
    out += ["", "Runs set aside (not in any table above or below):", "",
            "| scene | method | seed | commit | why | PSNR |", "|---|---|---|---|---|---|"]
    for s, m, r, w in sorted(rows, key=lambda x: (x[0], x[1], x[2].get("seed", 0))):
      commit = ((r.get("provenance", {}).get("git") or {}).get("commit") or "?")[:7]
      out.append(f"| {s} | {m} | {r.get('seed', '?')} | {commit} | {w} | {r['psnr']:.2f} |")
  return out + [""]


def scene_sections(name, mode, scenes, docs, plots=True) -> list:
  """The suite page's lines per scene: its table, its PSNR curve and, where the
  runs saved fronts, its error against training time (writing the figures
  with `plots`)."""
  out = []
  for scene in sorted(scenes):
    by = scenes[scene]
    cfg = next(iter(by.values()))[0]["config"]
    png = f"{name}_{scene}.png"
    if plots:
      plot_scene(by, f"{scene} ({cfg}), {mode}", os.path.join(docs, png))
    n_views = next(iter(by.values()))[0]["num_views"]
    changes = scene_overrides(by)
    changes = f" Changed: {changes}." if changes else ""
    out += [f"## {scene}", "", f"`{cfg}`, {n_views} held-out views.{changes}", "",
            scene_table(by), "",
            f"![held-out PSNR against training seconds]({png})", ""]
    fronts = fronts_report.front_table(by)
    if fronts:
      front_png = f"{name}_{scene}_front.png"
      if plots:
        fronts_report.plot_front(by, f"{scene}: error against training time",
                                 os.path.join(docs, front_png))
      out += ["Error against training time, on every held-out view: each run's state "
              "saved at these training seconds and scored after training.", "", fronts, "",
              f"![held-out PSNR and LPIPS against training seconds]({front_png})", ""]
  return out


# Modes whose records no longer decide anything, and why (their pages stay).
SUPERSEDED = {"time": (
    "**Superseded.** These runs trained for 240 s of this machine's wall-clock, so their "
    "step counts, and their figures, followed the machine's speed that day. They are kept "
    "because the step table of the `budget` protocol was built from seeds 0 and 1 "
    "(`python -m experiments.step_times --from_records`); the current figures are the `budget` mode's.")}
# The suites and modes the README's headlines are computed from: the test
# views, then the validation views (whose per-scene table is its page's).
HEADLINES = (("cpu", "budget"), ("validation", "budget"))


def write_suite(suite, mode, scenes, docs, versions=None, plots=True):
  """Writes docs/<suite>_<mode>.md (and, with `plots`, its figures); returns its name."""
  name = f"{suite}_{mode}"
  out = [f"# Suite `{suite}`, mode `{mode}`", "",
         "Generated by `python -m experiments.report` from "
         f"`results/{suite}/{mode}/`; do not edit by hand. Runs: "
         f"`python -m experiments.benchmark --suite={suite} --mode={mode}`. "
         "PSNR / SSIM / LPIPS (VGG) are the mean ± standard deviation over seeds on each "
         "scene's held-out views; Δ is the difference of means to `nerf_tuned`. The curve "
         "columns and plots use the first few held-out views (`eval.curve_views`), "
         "evaluated during training.", ""]
  if mode in SUPERSEDED:
    out += [SUPERSEDED[mode], ""]
  out += [l for l in provenance_lines(scenes) if l] + [""]
  if versions is not None:
    out += version_lines(versions)
  out += report_common.collapse_lines(
      [(f"{scene}/{m}/seed{r.get('seed', '?')}", r) for scene, by in sorted(scenes.items())
       for m, rs in sorted(by.items()) for r in rs]) + [""]
  out += ["## Held-out PSNR", "", summary_table(scenes), ""]
  out += ["## Over scenes", "", over_scenes_table(scenes), ""]
  if any("halo" in by for by in scenes.values()):
    by_kind, per_scene = claims(scenes)
    out += ["## The goals, checked", "",
            "HALO against each NeRF baseline per scene kind (the mean over the kind's scenes "
            "of the mean over seeds, each scene weighing the same), against the margin the "
            "project's issues stated for the kind (`report.GOALS_DB`; met only at or above "
            "it). The failure column says where the baseline's held-out curve ends "
            f"≥ {FAILURE_DROP_DB} dB below its peak. Then per scene, where HALO trails a "
            "baseline, FreeNeRF included.", "", by_kind, "", per_scene, ""]
  stages = stage_table(scenes)
  if stages:
    out += ["## By stage", "",
            "Each multi-stage method's Lo-NeRF at the end of its stage against the method's "
            "output, on the same held-out views; a run whose later stage ended below an "
            "earlier one is named. Steps per stage let a slow machine be told from a stage "
            "that did not train.", "", stages, ""]
  validation = validation_table(scenes)
  if validation:
    out += ["### By stage, on validation views", "",
            "The same comparison on every view of the scene's validation split (D-NeRF's "
            "`val` frames), each stage scored after training from its final checkpoint: "
            "where settings are chosen, so that no choice rests on the test views.", "",
            validation, ""]
  out += scene_sections(name, mode, scenes, docs, plots)
  with open(os.path.join(docs, f"{name}.md"), "w") as f:
    f.write("\n".join(out))
  return name


def headline(scenes, method="halo", versions=None) -> str:
  """One sentence: `method` against nerf_tuned over the scenes where both ran
  (the mean over scenes of the mean over seeds), and the scenes it trails."""
  stale = [m for m in (method, BASELINE) if versions and not versions[m]["current"]]
  if stale:  # the headline pools only the newest measured code's runs
    newest = versions[stale[0]]["newest"]
    return (f"no figures: the runs of {' and '.join(stale)} are not of the newest measured "
            f"code's fingerprint ({newest}); rerun them or measure their code "
            "(docs/benchmark.md).")
  both = sorted(s for s, by in scenes.items() if method in by and BASELINE in by)
  if not both:
    return ""
  delta = {s: np.mean([r["psnr"] for r in scenes[s][method]])
           - np.mean([r["psnr"] for r in scenes[s][BASELINE]]) for s in both}
  seeds = sorted({len(scenes[s][m]) for s in both for m in (method, BASELINE)})
  behind = ", ".join(f"{s} ({d:+.2f})" for s, d in sorted(delta.items()) if d <= 0)
  kinds = collections.defaultdict(list)
  for s in both:
    kinds[code_version.kind_of(scenes[s][method][0]["config"])].append(delta[s])
  per_kind = ", ".join(f"{k} {np.mean(v):+.2f} ({len(v)})" for k, v in sorted(kinds.items()))
  return (f"{method} against {BASELINE} on the {len(both)} scenes both ran "
          f"({seeds[0] if len(seeds) == 1 else f'{seeds[0]}-{seeds[-1]}'} "
          f"seed{'' if seeds == [1] else 's'} "
          f"each): {np.mean(list(delta.values())):+.2f} dB on average (each scene weighs "
          f"the same), ahead on {sum(d > 0 for d in delta.values())} of {len(both)}"
          + (f"; behind or level on {behind}." if behind else ".")
          + f" Per scene kind (scenes): {per_kind}." + _without_collapsed(scenes, delta, method)
          + (" " + _fingerprint_note(versions, (method, BASELINE)) if versions else ""))


def _without_collapsed(scenes, delta, method) -> str:
  """The sentence naming the scenes where a run of `method` or the baseline
  collapsed (a stage's verdict, training or held-out), with the mean over the
  other scenes: a pooled mean never silently includes a collapsed run."""
  gone = {s: collapsed_methods(scenes[s], (method, BASELINE)) for s in delta}
  gone = {s: ms for s, ms in gone.items() if ms}
  if not gone:
    return " No run of either method collapsed."
  named = ", ".join(f"{s} ({' and '.join(ms)})" for s, ms in sorted(gone.items()))
  kept = [d for s, d in delta.items() if s not in gone]
  rest = (f"{np.mean(kept):+.2f} dB over the other {len(kept)}, ahead on "
          f"{sum(d > 0 for d in kept)} of them" if kept else "no scene is left")
  return (f" The mean pools scenes where a run collapsed: {named}; without them, {rest}.")


def _fingerprint_note(versions, methods) -> str:
  parts = []
  for m in methods:
    v = versions[m]
    same = "the same" if v["current"] else "otherwise"
    kinds = "".join(f", {k} {f}" for k, f in sorted(v.get("by_kind", {}).items()))
    parts.append(f"{m} {v['fingerprint']}{kinds} ({v['runs']} runs"
                 f"{', ' + str(len(v['aside'])) + ' set aside' if v['aside'] else ''}; the newest "
                 f"measured code, {v['newest']}, computes {same}"
                 + ("; **the committed step table's entries for it changed since that "
                    "measurement: rerun `same_numbers.py --record`**"
                    if v.get("step_table_changed") else "") + ")")
  return "Code fingerprints: " + "; ".join(parts) + "."


def readme_block(all_suites, docs=None, versions=None, budget_line=""):
  """The README's results: for a suite whose runs have fronts, HALO's and
  nerf_tuned's error against training time per scene (fronts_rows), the
  fronts figure (written to `docs` when given) and the count of scenes where
  HALO reaches nerf_tuned's end in at most half its time; for the others,
  each method's final PSNR per scene."""
  shown = {k: v for k, v in sorted(all_suites.items())
           if k[0] not in ("smoke", "auto", "ingredients", "validation", "budget_60",
                           "budget_960")
           and k[1] not in SUPERSEDED}
  has_front = {k: any(r.get("front") for by in scenes.values() for rs in by.values()
                      for r in rs) for k, scenes in shown.items()}
  out = []
  for key in HEADLINES:
    if key in all_suites:
      out += [f"[`{key[0]}/{key[1]}`](docs/results/{key[0]}_{key[1]}.md), final PSNR: "
              + headline(all_suites[key], versions=(versions or {}).get(key)), ""]
  if budget_line:
    out += [budget_line, ""]
  finals = ["| suite | scene | " + " | ".join(METHOD_ORDER) + " |",
            "|---|---|" + "---|" * len(METHOD_ORDER)]
  for (suite, mode), scenes in shown.items():
    if has_front[(suite, mode)]:
      continue
    for scene in sorted(scenes):
      by = scenes[scene]
      cells = [stat([r["psnr"] for r in by[m]])[0] if m in by else "" for m in METHOD_ORDER]
      finals.append(f"| [{suite}/{mode}](docs/results/{suite}_{mode}.md) | {scene} | "
                    + " | ".join(cells) + " |")
  for key, scenes in shown.items():
    if not has_front[key]:
      continue
    suite, mode = key
    out += [f"`{suite}/{mode}`, error against training time: held-out PSNR on every view, "
            "halo / nerf_tuned (mean over seeds), at each saved training time and at the "
            "end; every method's final figures are behind the link.", ""]
    out += fronts_report.fronts_rows(key, scenes) + [""]
    if docs:
      png = f"{suite}_{mode}_fronts.png"
      drawn = fronts_report.plot_fronts_overview(scenes, os.path.join(docs, png))
      both = [s for s in fronts_report.paired_fronts(scenes) if s in drawn]
      half = sum(1 for s in both
                 if (fronts_report.reach_ratio(scenes[s]) or (None, 1.0))[1] <= 0.5)
      out += [f"HALO reaches nerf_tuned's final PSNR in at most half of nerf_tuned's time "
              f"on {half} of the {len(both)} scenes where both have fronts (the dashed line; "
              "a time is the first saved point at or above it, an upper bound).", "",
              f"![fronts](docs/results/{png})", ""]
  if len(finals) > 2:
    out += finals
  return "\n".join(out).rstrip("\n")


def update_readme(path, block, marker="results"):
  """Replaces what README `path` holds between its `<!-- marker:begin -->`
  and `<!-- marker:end -->` lines by `block`; False where it has no such lines."""
  with open(path) as f:
    text = f.read()
  pattern = re.compile(rf"(<!-- {marker}:begin -->)\n.*?(<!-- {marker}:end -->)", re.S)
  if not pattern.search(text):
    return False
  with open(path, "w") as f:
    f.write(pattern.sub(lambda m: m.group(1) + "\n" + block + "\n" + m.group(2), text))
  return True


def main(argv):
  del argv
  os.makedirs(FLAGS.docs, exist_ok=True)
  table = code_version.load()
  suites, versions = {}, {}
  for key, scenes in sorted(load(FLAGS.results).items()):
    suites[key], versions[key] = pool(scenes, table)
  for (suite, mode), scenes in sorted(suites.items()):
    name = write_suite(suite, mode, scenes, FLAGS.docs, versions[(suite, mode)])
    print("wrote", os.path.join(FLAGS.docs, name + ".md"))
  budget_line = budget_report.write(suites, FLAGS.docs, FLAGS.results)
  print("wrote", os.path.join(FLAGS.docs, budget_report.PAGE + ".md"))
  if FLAGS.readme and update_readme(FLAGS.readme, readme_block(suites, FLAGS.docs, versions,
                                                                budget_line)):
    print("updated", FLAGS.readme)
  ci = ci_records.newest()
  if FLAGS.readme and ci and update_readme(FLAGS.readme, ci_records.readme_sentence(ci), "ci"):
    print("updated", FLAGS.readme, "CI sentence from", os.path.relpath(ci.path, REPO))


def cli():
  """The tool's entry point (python -m experiments.<tool>)."""
  define_flags()
  tool.run(sys.modules[__name__], main)


if __name__ == "__main__":
  cli()
