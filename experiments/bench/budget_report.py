"""The budget study's page (docs/results/budget_study.md): HALO against
nerf_tuned at a quarter, one and four times the validation suite's budget.

The three points are suites of one protocol (experiments/bench/suites.py,
BUDGET_STUDY): budget_60, validation (240 reference seconds) and budget_960,
each on the study's scenes (BUDGET_SCENES) and its validation views, pooled
by code fingerprint as every suite page is (report.pool). Per scene kind it
says whether HALO's margin rises, holds or falls with the budget, and, from
the 960-s runs' curves, where nerf_tuned's held-out PSNR stops rising while
its training PSNR still climbs. Nothing here is typed by hand.
"""
import os

import matplotlib
import matplotlib.ticker

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # pylint: disable=g-import-not-at-top
import numpy as np  # pylint: disable=g-import-not-at-top

from experiments.bench import budget_studies, code_version, equal_chance, host_spread  # pylint: disable=g-import-not-at-top
from experiments.bench import probe_report, suites  # pylint: disable=g-import-not-at-top
from experiments.bench.report_common import BASELINE, collapsed_methods, stat  # pylint: disable=g-import-not-at-top

METHOD = "halo"
PAGE = "budget_study"
# A lead that moves less than this between the smallest and largest budget
# holds (the size of the project's rule for a default: 0.3 dB).
TREND_DB = 0.3
# Training PSNR is a batch's; its level at a time is the median of the
# records within this many reference seconds either side.
TRAIN_WINDOW_S = 60.0
# The 960-s study's goals (issue 77): halo ahead on all but one validation
# scene; the mean lead over the scenes where neither method collapsed; and
# each scene kind whose HALO has a Lo-NeRF stage.
GOAL_BEHIND_AT_MOST = 1
GOAL_MEAN_DB = 1.0
GOAL_KIND_DB = 0.5


def study(all_suites) -> dict:
  """{budget_s: {scene: {method: [record]}}} from report's pooled suites
  ({(suite, mode): {scene: {method: [record]}}}), the study's scenes only."""
  out = {}
  for name, budget_s in suites.BUDGET_STUDY.items():
    scenes = all_suites.get((name, "budget"), {})
    out[budget_s] = {s: by for s, by in scenes.items() if s in suites.BUDGET_SCENES}
  return out


def scene_kind(by_method) -> str:
  """The scene kind of a scene's records ({method: [record]})."""
  return code_version.kind_of(next(r for rs in by_method.values() for r in rs)["config"])


def every_scene(all_suites, suite="budget_960") -> dict:
  """{scene: {method: [record]}} of `suite` on every validation scene it
  covers, in the validation suite's order."""
  runs = all_suites.get((suite, "budget"), {})
  return {s.name: runs[s.name] for s in suites.SUITES[suite].scenes if s.name in runs}


def _spread_cell(x, spread):
  """A margin beside its kind's host spread (None: not measured)."""
  if spread is None:
    return "-"
  return f"±{spread:.2f}" + (" (inside)" if x is not None and abs(x) <= spread else "")


def every_scene_lines(runs, budget_s: float, spread=None, found=None) -> list:
  """The page's section on the largest budget over every validation scene:
  per scene both methods' mean and seeds, its kind's host spread
  ({kind: dB}; host_spread.py) and per kind and overall the mean lead with
  and without the scenes where a run collapsed; then the reruns (`found`,
  host_spread.pairs) that measure the spread."""
  wanted = {s.name: s.seeds for s in suites.BUDGET_960.scenes}
  spread = spread or {}
  rows = []
  for s, by in runs.items():
    x = lead(by)
    bad = collapsed_methods(by, (METHOD, BASELINE))
    kind = scene_kind(by)
    cells = [f"{np.mean([r['psnr'] for r in by[m]]):.2f} ({len(by[m])})" if m in by else "-"
             for m in (METHOD, BASELINE)]
    rows.append(f"| {kind} | {s} | {cells[0]} | {cells[1]} | "
                + ("-" if x is None else f"{x:+.2f}") + f" | {_spread_cell(x, spread.get(kind))} | "
                + f"{wanted.get(s, '-')} | " + (", ".join(bad) if bad else "none") + " |")
  pairs = [s for s, by in runs.items() if lead(by) is not None]
  if not pairs:
    return []
  return [f"## {budget_s:g} s on every validation scene", "",
          f"halo against {BASELINE} at {budget_s:g} reference seconds on each validation scene "
          f"that has runs of both ({len(pairs)} of {len(wanted)} so far; the seeds wanted in "
          "the `seeds` column). PSNR is the mean over seeds (seeds in brackets); `host "
          "spread` is the scene kind's (below), `inside` where the margin is no larger.", "",
          f"| kind | scene | {METHOD} | {BASELINE} | Δ | host spread | seeds | collapsed |",
          "|---|---|---|---|---|---|---|---|", *rows, "", every_scene_summary(runs) + ".", "",
          goals_line(runs, len(wanted), spread), "",
          *host_spread.lines(found or {}, code_version.kind_of, budget_s)]


def goals_line(runs, wanted: int, spread=None) -> str:
  """The study's goals (GOAL_*) against `runs`' leads, each met or not, the
  scenes and kinds that miss one named (their mechanism is the probes'), a
  scene behind marked where its margin is inside its kind's host spread
  ({kind: dB})."""
  spread = spread or {}
  leads = {s: lead(by) for s, by in runs.items() if lead(by) is not None}
  gone = {s for s, by in runs.items() if collapsed_methods(by, (METHOD, BASELINE))}
  behind = {s: x for s, x in leads.items() if x <= 0}
  kept = [x for s, x in leads.items() if s not in gone]
  kinds = {}
  for s in leads:
    if any("lo" in r.get("stages", {}) for r in runs[s][METHOD]):  # HALO has a Lo stage there
      kinds.setdefault(scene_kind(runs[s]), []).append(leads[s])
  short = {k: float(np.mean(v)) for k, v in sorted(kinds.items()) if np.mean(v) < GOAL_KIND_DB}
  met = lambda ok: "met" if ok else "**not met**"  # noqa: E731
  part = f" ({len(leads)} of {wanted} scenes so far)" if len(leads) < wanted else ""
  mean_kept = float(np.mean(kept)) if kept else float("nan")
  return (f"Goals{part}: ahead on all but {GOAL_BEHIND_AT_MOST}: "
          f"{met(len(behind) <= GOAL_BEHIND_AT_MOST)} (behind: "
          + (", ".join(f"{s} {x:+.2f}" + (
              f", inside its kind's host spread ±{spread[scene_kind(runs[s])]:.2f}"
              if abs(x) <= spread.get(scene_kind(runs[s]), -1.0) else "")
              for s, x in behind.items()) or "none") + "); "
          f"mean at least {GOAL_MEAN_DB:+.1f} dB where neither method collapsed: "
          f"{met(mean_kept >= GOAL_MEAN_DB)} ({mean_kept:+.2f}); each kind with a Lo stage "
          f"at least {GOAL_KIND_DB:+.1f} dB: {met(not short)}"
          + (" (" + ", ".join(f"{k} {x:+.2f}" for k, x in short.items()) + ")" if short else "")
          + ". What each shortfall is made of: the probes below.")


def every_scene_summary(runs) -> str:
  """'Ahead on a of n; mean ... Per kind: ...' over the scenes of `runs` with
  both methods ('' for none): the page's closing line and the README's clause."""
  kinds, gone = {}, set()
  for s, by in runs.items():
    if collapsed_methods(by, (METHOD, BASELINE)):
      gone.add(s)
    if lead(by) is not None:
      kind = scene_kind(by)
      kinds.setdefault(kind, []).append((s, lead(by)))
  pairs = [(s, x) for v in kinds.values() for s, x in v]
  if not pairs:
    return ""
  mean = lambda xs: f"{np.mean(xs):+.2f}" if xs else "-"  # noqa: E731
  kept = [x for s, x in pairs if s not in gone]
  return (f"Ahead on {sum(x > 0 for _, x in pairs)} of {len(pairs)}; mean "
          f"{mean([x for _, x in pairs])} dB (each scene weighs the same), {mean(kept)} dB "
          f"without the scenes where a run collapsed ({', '.join(sorted(gone)) or 'none'}). "
          "Per kind: " + "; ".join(f"{k} {mean([x for _, x in v])} ({len(v)})"
                                   for k, v in sorted(kinds.items())))


def lead(by_method):
  """halo's mean PSNR less nerf_tuned's (None unless both ran)."""
  if METHOD not in by_method or BASELINE not in by_method:
    return None
  return (np.mean([r["psnr"] for r in by_method[METHOD]])
          - np.mean([r["psnr"] for r in by_method[BASELINE]]))


def change(leads):
  """HALO's margin (its lead, negative where it trails) at the largest budget
  less its margin at the smallest; None with fewer than two budgets."""
  budgets = sorted(b for b, v in leads.items() if v is not None)
  return leads[budgets[-1]] - leads[budgets[0]] if len(budgets) >= 2 else None


def trend(leads) -> str:
  """'rises', 'holds' or 'falls': `change` against TREND_DB."""
  moved = change(leads)
  if moved is None:
    return "-"
  return "rises" if moved >= TREND_DB else "falls" if moved <= -TREND_DB else "holds"


# A held-out curve this far under its peak at the end counts as falling.
FALL_DB = 0.1


def _train_level(records, at_s):
  """Median training PSNR within TRAIN_WINDOW_S of `at_s`, over the runs."""
  pts = [p for r in records for t, p in r.get("train_curve", [])
         if abs(t - at_s) <= TRAIN_WINDOW_S]
  return float(np.median(pts)) if pts else None


def overfitting(records) -> dict:
  """Where a method's held-out curve (mean over runs, on its curve views)
  peaks, and what its held-out and training PSNR do from there to the end:
  {'peak_s', 'peak', 'end_s', 'heldout_change', 'train_change'} (None where a
  run lacks a curve)."""
  curves = [np.asarray(r["curve"], np.float64) for r in records if r.get("curve")]
  if not curves or len({len(c) for c in curves}) != 1:
    return None
  t = curves[0][:, 0]
  mean = np.mean([c[:, 1] for c in curves], 0)
  i = int(np.argmax(mean))
  train_peak, train_end = _train_level(records, t[i]), _train_level(records, t[-1])
  return {"peak_s": float(t[i]), "peak": float(mean[i]), "end_s": float(t[-1]),
          "heldout_change": float(mean[-1] - mean[i]),
          "train_change": (None if train_peak is None or train_end is None
                           else train_end - train_peak)}


def overfitting_sentence(method, o) -> str:
  if o is None:
    return f"{method}: no curve."
  if o["peak_s"] >= o["end_s"]:
    return (f"{method}'s held-out PSNR still rises at {o['end_s']:.0f} s "
            f"({o['peak']:.2f} dB on the curve views).")
  train = ("" if o["train_change"] is None else
           f", while its training PSNR moves {o['train_change']:+.2f} dB")
  return (f"{method}'s held-out PSNR peaks at {o['peak_s']:.0f} s ({o['peak']:.2f} dB on "
          f"the curve views) and moves {o['heldout_change']:+.2f} dB by "
          f"{o['end_s']:.0f} s{train}.")


def falling_curve(by_method) -> str:
  """halo's overfitting sentence where its held-out curve ends more than
  FALL_DB under its peak, else ''."""
  o = overfitting(by_method.get(METHOD, []))
  return (overfitting_sentence(METHOD, o) if o and o["peak_s"] < o["end_s"]
          and o["heldout_change"] < -FALL_DB else "")


def lo_psnrs(by_method):
  """halo's Lo-NeRF PSNR at the end of its stage, per run that scored it."""
  return [r["stages"]["lo"]["psnr"] for r in by_method.get(METHOD, [])
          if "psnr" in r.get("stages", {}).get("lo", {})]


def hi_minus_lo(by_method):
  """What Hi-NeRF adds to halo's Lo-NeRF, mean over runs (None without Lo)."""
  lo = lo_psnrs(by_method)
  return (float(np.mean([r["psnr"] for r in by_method[METHOD]]) - np.mean(lo)) if lo
          else None)


def scene_rows(by_budget, scene):
  rows = []
  for m in (BASELINE, METHOD):
    cells = []
    for b in sorted(by_budget):
      rs = by_budget[b].get(scene, {}).get(m, [])
      cells.append(f"{stat([r['psnr'] for r in rs])[0]} ({len(rs)})" if rs else "-")
    rows.append(f"| {m} | " + " | ".join(cells) + " |")
  lo = {b: lo_psnrs(by_budget[b].get(scene, {})) for b in by_budget}
  if any(lo.values()):
    rows.append("| halo's Lo-NeRF | " + " | ".join(
        f"{stat(lo[b])[0]}" if lo[b] else "-" for b in sorted(by_budget)) + " |")
    gain = {b: hi_minus_lo(by_budget[b].get(scene, {})) for b in by_budget}
    rows.append("| Hi − Lo | " + " | ".join(
        "-" if gain[b] is None else f"{gain[b]:+.2f}" for b in sorted(by_budget)) + " |")
  leads = {b: lead(by_budget[b].get(scene, {})) for b in by_budget}
  rows.append("| Δ halo − nerf_tuned | " + " | ".join(
      "-" if leads[b] is None else f"{leads[b]:+.2f}" for b in sorted(by_budget)) + " |")
  return rows, leads


def plot_scene(by_budget, scene, path):
  """Left: each run's final PSNR (all validation views) against its budget,
  a line through the means. Right: each run's own held-out curve (curve
  views) and, for the 960-s runs, its training PSNR."""
  fig, (left, right) = plt.subplots(1, 2, figsize=(10, 3.8))
  for i, m in enumerate((BASELINE, METHOD)):
    means = []
    for b in sorted(by_budget):
      rs = by_budget[b].get(scene, {}).get(m, [])
      left.plot([b] * len(rs), [r["psnr"] for r in rs], "o", color=f"C{i}", ms=4, alpha=0.6)
      means.append((b, np.mean([r["psnr"] for r in rs])) if rs else None)
      for r in rs:
        if r.get("curve"):
          right.plot(*np.asarray(r["curve"]).T, "-", color=f"C{i}",
                     lw=1.6 if b == max(by_budget) else 0.8, alpha=0.9)
        if b == max(by_budget) and r.get("train_curve"):
          right.plot(*np.asarray(r["train_curve"]).T, ":", color=f"C{i}", lw=0.8, alpha=0.6)
    pts = [p for p in means if p is not None]
    if pts:
      left.plot(*zip(*pts), "-", color=f"C{i}", label=m)
      right.plot([], [], "-", color=f"C{i}", label=f"{m} held-out")
      right.plot([], [], ":", color=f"C{i}", label=f"{m} training batches")
  left.set_xscale("log")
  left.set_xticks(sorted(by_budget), [f"{b:g}" for b in sorted(by_budget)])
  left.xaxis.set_minor_locator(matplotlib.ticker.NullLocator())
  left.set_xlabel("budget (reference seconds)")
  left.set_ylabel("final PSNR (dB), validation views")
  right.set_xlabel("reference seconds")
  right.set_ylabel("PSNR (dB)")
  for ax in (left, right):
    ax.grid(alpha=0.3)
    ax.legend(fontsize=7)
  fig.suptitle(scene, fontsize=10)
  fig.tight_layout()
  fig.savefig(path, dpi=100)
  plt.close(fig)


def mean_leads(by_budget):
  """{budget: mean over the scenes with both methods at every budget of the lead}."""
  scenes = [s for s in suites.BUDGET_SCENES
            if all(lead(by_budget[b].get(s, {})) is not None for b in by_budget)]
  return {b: (float(np.mean([lead(by_budget[b][s]) for s in scenes])) if scenes else None)
          for b in by_budget}, scenes


def where_halo_leads(by_budget, scenes) -> str:
  """'at every budget on a (+x → +y dB), at 60 s on b, and at none on c':
  the scenes grouped by the budgets at which HALO's mean leads."""
  budgets = sorted(by_budget)
  groups = {}
  for s in scenes:
    leads = [lead(by_budget[b][s]) for b in budgets]
    ahead = tuple(b for b, x in zip(budgets, leads) if x > 0)
    label = (f"{s} ({leads[0]:+.2f} to {leads[-1]:+.2f} dB)" if ahead else s)
    groups.setdefault(ahead, []).append(label)
  parts = []
  for ahead, names in sorted(groups.items(), key=lambda kv: -len(kv[0])):
    when = ("at every budget" if len(ahead) == len(budgets) else "at no budget" if not ahead
            else "at " + " and ".join(f"{b:g} s" for b in ahead) + " only")
    parts.append(f"{when} on {', '.join(names)}")
  return "; ".join(parts)


def readme_sentence(by_budget) -> str:
  """The README's line: the mean lead at each budget and, per scene, the
  budgets at which HALO leads (empty until every scene of the study has
  both methods at every budget)."""
  means, scenes = mean_leads(by_budget)
  if len(scenes) < len(suites.BUDGET_SCENES):  # a partial study says nothing in the README
    return ""
  figures = ", ".join(f"{means[b]:+.2f} dB at {b:g}" for b in sorted(means))
  return (f"[Budget study](docs/results/{PAGE}.md), validation views, {len(scenes)} scenes: "
          f"halo − nerf_tuned {figures} reference seconds on average; HALO leads "
          f"{where_halo_leads(by_budget, scenes)}." + without_collapsed(by_budget, scenes))


def without_collapsed(by_budget, scenes) -> str:
  """The sentence naming the scenes where a run of either method collapsed
  at some budget, with the means over the other scenes."""
  gone = {}
  for b in sorted(by_budget):
    for s in scenes:
      for m in collapsed_methods(by_budget[b][s], (METHOD, BASELINE)):
        gone.setdefault(s, []).append(f"{m} at {b:g} s")
  if not gone:
    return " No run of either method collapsed."
  named = "; ".join(f"{s} ({', '.join(w)})" for s, w in sorted(gone.items()))
  kept = [s for s in scenes if s not in gone]
  if not kept:
    return f" Runs collapsed on every scene: {named}."
  figures = ", ".join(f"{np.mean([lead(by_budget[b][s]) for s in kept]):+.2f} dB at {b:g}"
                      for b in sorted(by_budget))
  return (f" The means pool scenes where a run collapsed: {named}; without them "
          f"({len(kept)} scenes), {figures} reference seconds.")


def write(all_suites, docs, results="") -> str:
  """Writes the page and its figures (with the probes under `results`, when
  given); returns the README sentence."""
  by_budget = study(all_suites)
  budgets = sorted(by_budget)
  head = "| method | " + " | ".join(f"{b:g} s" for b in budgets) + " |"
  out = ["# Budget study: where HALO's lead holds", "",
         "Generated by `python -m experiments.report` from `results/budget_60/`, "
         "`results/validation/` and `results/budget_960/` (the study's scenes); do not edit. "
         "Runs: `python -m experiments.benchmark --suite=budget_60` and `--suite=budget_960` (the 240-s point is "
         "the validation suite's). Every run is on the validation suite's terms: the `budget` "
         "protocol's reference seconds (the same steps on any machine), one core, each "
         "scene's validation views. PSNR is the mean ± std over seeds (seeds in brackets) on "
         "every validation view; the curves are on the first two (`eval.curve_views`). "
         "`halo's Lo-NeRF` is its PSNR at the end of its stage on the same views, `Hi − Lo` "
         "what Hi-NeRF adds to it.", "",
         "HALO's Lo-NeRF and ray field have step caps (1500 and 3000 in the CPU configs): at "
         "960 s they reach them, and the rest of the budget goes to Hi-NeRF.", ""]
  means, scenes = mean_leads(by_budget)
  if scenes:
    out += ["## Over scenes", "", f"Mean over {', '.join(scenes)} (each scene weighs the "
            "same) of halo − nerf_tuned: " + ", ".join(
                f"{means[b]:+.2f} dB at {b:g} s" for b in budgets)
            + f"; HALO's margin {trend(means)} ({change(means):+.2f} dB from {budgets[0]:g} "
            f"to {budgets[-1]:g} s; a move of {TREND_DB} dB or more counts).", ""]
  out += ["## Per scene kind", "", "| kind | scenes | " + " | ".join(
      f"Δ at {b:g} s" for b in budgets) + " | HALO's margin |", "|---|---|" + "---|" * len(budgets)
      + "---|"]
  kinds = {}
  for s in suites.BUDGET_SCENES:
    recs = [r for b in budgets for rs in by_budget[b].get(s, {}).values() for r in rs]
    if recs:
      kinds.setdefault(code_version.kind_of(recs[0]["config"]), []).append(s)
  for kind, names in sorted(kinds.items()):
    leads = {b: [lead(by_budget[b].get(s, {})) for s in names] for b in budgets}
    leads = {b: (float(np.mean(v)) if all(x is not None for x in v) else None)
             for b, v in leads.items()}
    out.append(f"| {kind} | {', '.join(names)} | " + " | ".join(
        "-" if leads[b] is None else f"{leads[b]:+.2f}" for b in budgets)
        + f" | {trend(leads)} |")
  out.append("")
  for s in suites.BUDGET_SCENES:
    if not any(s in by_budget[b] for b in budgets):
      continue
    rows, _ = scene_rows(by_budget, s)
    png = f"{PAGE}_{s}.png"
    plot_scene(by_budget, s, os.path.join(docs, png))
    top = by_budget[budgets[-1]].get(s, {})
    out += [f"## {s}", "", head, "|---|" + "---|" * len(budgets), *rows, "",
            *(f"- {overfitting_sentence(m, overfitting(top[m]))}" for m in (BASELINE, METHOD)
              if m in top), "", f"![{s}]({png})", ""]
  runs = every_scene(all_suites)
  found = {}
  if results:
    table = code_version.load()

    def same_code(record, git):
      fp = code_version.of_record(record, table)
      return fp not in (code_version.UNMEASURED, code_version.MODIFIED) and fp == \
          code_version.of_record(dict(record, provenance={"git": git}), table)
    found = {**host_spread.pairs(runs, host_spread.reruns(results, "budget_960")),
             **host_spread.probe_pairs(runs, [p for (b, _), ps in probe_report.probes(
                 results).items() if b == budgets[-1] for p in ps], same_code)}
  out += every_scene_lines(runs, budgets[-1], host_spread.by_kind(found, code_version.kind_of),
                           found)
  if results:
    out += equal_chance.section(runs, results, budgets[-1])
    out += probe_report.other_scenes_section(
        results, {s: x for s, by in runs.items() for x in [lead(by)] if x is not None and x < 0})
    out += probe_report.dense_eval_section(
        results, budget_studies.STUDIES[f"hi_window_{budgets[-1]:g}"].scenes, budgets[-1])
    out += probe_report.probe_section(probe_report.probes(results), by_budget, hi_minus_lo,
                                      lead, overfit=falling_curve)
  with open(os.path.join(docs, f"{PAGE}.md"), "w") as f:
    f.write("\n".join(out))
  runs = every_scene(all_suites)
  summary = every_scene_summary(runs)
  pairs = sum(lead(by) is not None for by in runs.values())
  clause = (f" At {budgets[-1]:g} s on every validation scene ({pairs} of "
            f"{len(suites.BUDGET_960.scenes)} so far with both methods): "
            + summary[0].lower() + summary[1:].replace(". Per kind: ", "; per kind ") + "."
            if summary else "")
  sentence = readme_sentence(by_budget)   # a partial study says nothing in the README
  return (sentence + clause) if sentence else ""
