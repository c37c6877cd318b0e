"""The suite page's tables and plots, from pooled records ({scene: {method:
[record, ...]}}, report.pool): per scene, over scenes, the goals per scene
kind, by stage, on validation views, and where the runs came from."""
import collections
import warnings

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # pylint: disable=g-import-not-at-top
import numpy as np  # pylint: disable=g-import-not-at-top

from halo_jax import runs  # pylint: disable=g-import-not-at-top
from experiments.bench import code_version  # pylint: disable=g-import-not-at-top
from experiments.bench.report_common import (  # pylint: disable=g-import-not-at-top
    BASELINE, collapsed_methods, in_method_order, mean_pm, stat)


def curve_on_grid(records, grid):
  """Each record's held-out curve, linearly interpolated between its points, on
  `grid` seconds: [seeds, len(grid)] (NaN outside a run's first and last point)."""
  rows = []
  for r in records:
    if not r["curve"]:
      continue
    t, p = np.asarray(r["curve"], np.float64).T
    rows.append(np.interp(grid, t, p, left=np.nan, right=np.nan))
  return np.asarray(rows)


def seconds_to_reach(records, level):
  return runs.seconds_to_reach(records, level)


def common_level(by_method):
  """The median over runs of their held-out curve peaks, less 0.5 dB."""
  return runs.common_level([r for rs in by_method.values() for r in rs], of="median")


def scene_table(by_method):
  base = [r["psnr"] for r in by_method.get(BASELINE, [])]
  level = common_level(by_method)
  head = ("| method | seeds | PSNR | SSIM | LPIPS | Δ PSNR vs nerf_tuned | steps (last stage) | "
          f"s to {level:.1f} dB |" if level else "| method | seeds | PSNR | SSIM | LPIPS | "
          "Δ PSNR vs nerf_tuned | steps (last stage) | s to common PSNR |")
  lines = [head, "|---|---|---|---|---|---|---|---|"]
  for m in in_method_order(by_method):
    rs = by_method[m]
    psnr, _ = stat([r["psnr"] for r in rs])
    ssim = mean_pm(np.asarray([r["ssim"] for r in rs]), 3)
    lp = [r["lpips"] for r in rs if r.get("lpips") is not None]
    lpips = mean_pm(np.asarray(lp), 3) if lp else "-"
    delta = "-"
    if base and m != BASELINE:
      delta = f"{np.mean([r['psnr'] for r in rs]) - np.mean(base):+.2f}"
    last = [list(r["stages"].values())[-1]["step"] for r in rs]
    reach = seconds_to_reach(rs, level) if level else None
    lines.append(f"| {m} | {len(rs)} | {psnr} | {ssim} | {lpips} | {delta} | "
                 f"{int(np.mean(last))} | {'-' if reach is None else f'{reach:.0f}'} |")
  return "\n".join(lines)


def plot_scene(by_method, title, path):
  fig, ax = plt.subplots(figsize=(6, 4))
  end = max(t for rs in by_method.values() for r in rs for t, _ in r["curve"] or [(1, 0)])
  grid = np.linspace(0, end, 200)
  for i, m in enumerate(in_method_order(by_method)):
    ys = curve_on_grid(by_method[m], grid)
    if ys.size == 0:
      continue
    with warnings.catch_warnings():  # grid points before any seed's first point are NaN
      warnings.simplefilter("ignore", RuntimeWarning)
      lo, hi, mean = np.nanmin(ys, 0), np.nanmax(ys, 0), np.nanmean(ys, 0)
    ax.fill_between(grid, lo, hi, color=f"C{i}", alpha=0.2, lw=0)
    ax.plot(grid, mean, color=f"C{i}", label=f"{m} ({len(by_method[m])})")
    for r in by_method[m]:  # the measured points
      if r["curve"]:
        ax.plot(*np.asarray(r["curve"]).T, ".", color=f"C{i}", ms=4)
  ax.set_xlabel("training seconds")
  ax.set_ylabel("held-out PSNR (dB), curve views")
  ax.set_title(title, fontsize=10)
  ax.grid(alpha=0.3)
  ax.legend(fontsize=8)
  fig.tight_layout()
  fig.savefig(path, dpi=110)
  plt.close(fig)


def complete_scenes(scenes):
  """Scenes where every method run anywhere in the suite has at least one result."""
  all_methods = {m for by in scenes.values() for m in by}
  return [s for s, by in scenes.items() if all_methods <= set(by)]


def over_scenes_table(scenes):
  """Per method: the mean over scenes of its mean PSNR, over the scenes where
  it and nerf_tuned both ran, and on how many of them it beats nerf_tuned;
  then the same mean Δ without the scenes where a run of either collapsed
  (named), so that no pooled mean silently includes a collapsed run."""
  methods = in_method_order({m: 1 for by in scenes.values() for m in by})
  lines = ["| method | scenes | mean PSNR | mean Δ vs nerf_tuned | scenes ahead of nerf_tuned "
           "| mean Δ without collapsed runs (scenes left out) |",
           "|---|---|---|---|---|---|"]
  for m in methods:
    both = [s for s, by in scenes.items() if m in by and BASELINE in by]
    if not both:
      continue
    ps = [np.mean([r["psnr"] for r in scenes[s][m]]) for s in both]
    ds = [p - np.mean([r["psnr"] for r in scenes[s][BASELINE]]) for p, s in zip(ps, both)]
    ahead = sum(d > 0 for d in ds)
    gone = [s for s in both if collapsed_methods(scenes[s], (m, BASELINE))]
    kept = [d for d, s in zip(ds, both) if s not in gone]
    without = (("-" if not kept else f"{np.mean(kept):+.2f}")
               + f" ({', '.join(gone) if gone else 'none'})")
    lines.append(f"| {m} | {len(both)} | {np.mean(ps):.2f} | "
                 f"{'-' if m == BASELINE else f'{np.mean(ds):+.2f}'} | "
                 f"{'-' if m == BASELINE else f'{ahead} of {len(both)}'} | "
                 f"{'-' if m == BASELINE else without} |")
  return "\n".join(lines)


def summary_table(scenes):
  """One row per scene, one column per method: mean held-out PSNR (and its
  spread over seeds), the scene's config changes where the suite made any."""
  methods = in_method_order({m: 1 for by in scenes.values() for m in by})
  changes = any(scene_overrides(by) for by in scenes.values())
  head = "| scene | " + ("changes to the config | " if changes else "") + " | ".join(methods)
  lines = [head + " |", "|---|" + ("---|" if changes else "") + "---|" * len(methods)]
  for scene in sorted(scenes):
    by = scenes[scene]
    cells = [stat([r["psnr"] for r in by[m]])[0] if m in by else "" for m in methods]
    extra = [scene_overrides(by) or "none"] if changes else []
    lines.append(f"| {scene} | " + " | ".join(extra + cells) + " |")
  return "\n".join(lines)


def scene_overrides(by_method):
  rec = next(iter(by_method.values()))[0]
  return ", ".join(f"`{k}={v}`" for k, v in rec.get("scene_overrides") or [])


def curve_drop(records) -> float:
  """Mean over runs of (curve peak - last curve point), dB: how far a method's
  held-out PSNR has fallen from its best by the end of training, the
  few-shot failure's signature (0 while it is still rising)."""
  drops = [max(p for _, p in r["curve"]) - r["curve"][-1][1] for r in records if r["curve"]]
  return float(np.mean(drops)) if drops else float("nan")


FAILURE_DROP_DB = 0.5  # a curve that falls this far from its peak shows the failure

# The margins over NeRF the project set itself, per scene kind (dB): lego's
# +1.5 (the paper's 8-view setting), D-NeRF's +0.5, the light field's +1. A
# kind with no stated number is not judged.
GOALS_DB = {"blender": 1.5, "dnerf": 0.5, "stanford_lf": 1.0}


def claims(scenes, method="halo"):
  """The issues' goals, checked on these results: `method` against each NeRF
  baseline per scene kind (the mean over the kind's scenes of the mean over
  seeds, each scene weighing the same) against the margin stated for the
  kind (GOALS_DB), and whether the baseline's curve shows the few-shot
  failure; then per scene, where it trails a baseline, FreeNeRF included."""
  kinds = collections.defaultdict(list)
  for scene, by in scenes.items():
    if method in by:
      kinds[code_version.kind_of(by[method][0]["config"])].append(scene)
  mean = lambda rs: float(np.mean([r["psnr"] for r in rs]))  # pylint: disable=unnecessary-lambda-assignment
  lines = [f"| scene kind | scenes | baseline | {method} - baseline (dB) | scenes where the "
           f"baseline's curve falls ≥ {FAILURE_DROP_DB} dB | stated goal (dB) | met |",
           "|---|---|---|---|---|---|---|"]
  for kind in sorted(kinds):
    for base in ("nerf_paper", "nerf_tuned"):
      both = [s for s in sorted(kinds[kind]) if base in scenes[s]]
      if not both:
        continue
      gap = np.mean([mean(scenes[s][method]) - mean(scenes[s][base]) for s in both])
      failing = [s for s in both if curve_drop(scenes[s][base]) >= FAILURE_DROP_DB]
      goal = GOALS_DB.get(kind)
      met = "no goal stated" if goal is None else "yes" if gap >= goal else "**no**"
      lines.append(f"| {kind} | {', '.join(both)} | {base} | {gap:+.2f} | "
                   f"{', '.join(failing) or 'none'} | "
                   f"{'-' if goal is None else f'+{goal:g}'} | {met} |")
  rows = []
  for scene in sorted(scenes):
    by = scenes[scene]
    for base in ("freenerf", "nerf_tuned", "nerf_paper"):
      if method in by and base in by:
        gap = mean(by[method]) - mean(by[base])
        rows.append((scene, base, gap, len(by[method]), len(by[base])))
  per_scene = ["| scene | baseline | " + method + " - baseline (dB) | seeds | verdict |",
               "|---|---|---|---|---|"]
  for scene, base, gap, n, nb in rows:
    verdict = f"{method} ahead" if gap > 0 else f"**{method} trails {base}**"
    per_scene.append(f"| {scene} | {base} | {gap:+.2f} | {n} / {nb} | {verdict} |")
  return "\n".join(lines), "\n".join(per_scene)


def stage_regressions(stages):
  """[(earlier stage, its PSNR, later stage, its PSNR)] where a later stage of
  a run ended below an earlier one; `stages` is a record's 'stages' (held-out
  views) or its ['validation']['stages']."""
  scored = [(n, st["psnr"]) for n, st in stages.items() if "psnr" in st]
  return [(a, pa, b, pb) for i, (a, pa) in enumerate(scored) for b, pb in scored[i + 1:]
          if pb < pa]


def stage_table(scenes):
  """Per scene and multi-stage method: Lo-NeRF's held-out PSNR at the end of
  its stage beside the method's final PSNR, and every run whose later stage
  ended below an earlier one."""
  lines = ["| scene | method | seeds | Lo PSNR | final PSNR | final - Lo | steps per stage "
           "(mean) | runs whose later stage ended below an earlier |",
           "|---|---|---|---|---|---|---|---|"]
  for scene in sorted(scenes):
    for m in in_method_order(scenes[scene]):
      rs = scenes[scene][m]
      with_lo = [r for r in rs if "psnr" in r["stages"].get("lo", {})]
      if not with_lo:
        continue
      lo = np.asarray([r["stages"]["lo"]["psnr"] for r in with_lo])
      final = np.asarray([r["psnr"] for r in with_lo])
      steps = ", ".join(f"{n} {np.mean([r['stages'][n]['step'] for r in rs]):.0f}"
                        for n in rs[0]["stages"])
      flags_ = [f"seed{r['seed']}: {b} {pb:.2f} < {a} {pa:.2f}" for r in with_lo
                for a, pa, b, pb in stage_regressions(r["stages"])]
      lines.append(f"| {scene} | {m} | {len(with_lo)} | {mean_pm(lo)} | {mean_pm(final)} | "
                   f"{np.mean(final - lo):+.2f} | {steps} | "
                   f"{'**' + '; '.join(flags_) + '**' if flags_ else 'none'} |")
  return "\n".join(lines) if len(lines) > 2 else ""


def validation_table(scenes):
  """Per scene and multi-stage method, from the runs scored on the scene's
  validation split: Lo-NeRF's PSNR there beside the method's output's, and
  every run whose later stage ended below an earlier one on those views."""
  lines = ["| scene | method | seeds | views | Lo PSNR | final PSNR | final - Lo | "
           "runs whose later stage ended below an earlier |", "|---|---|---|---|---|---|---|---|"]
  for scene in sorted(scenes):
    for m in in_method_order(scenes[scene]):
      rs = [r for r in scenes[scene][m] if "lo" in r.get("validation", {}).get("stages", {})]
      if not rs:
        continue
      lo = np.asarray([r["validation"]["stages"]["lo"]["psnr"] for r in rs])
      final = np.asarray([list(r["validation"]["stages"].values())[-1]["psnr"] for r in rs])
      flags_ = [f"seed{r['seed']}: {b} {pb:.2f} < {a} {pa:.2f}" for r in rs
                for a, pa, b, pb in stage_regressions(r["validation"]["stages"])]
      views = ", ".join(sorted({f"{r['validation']['num_views']} {r['validation']['split']}"
                                for r in rs}))
      lines.append(f"| {scene} | {m} | {len(rs)} | {views} | {mean_pm(lo)} | {mean_pm(final)} | "
                   f"{np.mean(final - lo):+.2f} | "
                   f"{'**' + '; '.join(flags_) + '**' if flags_ else 'none'} |")
  return "\n".join(lines) if len(lines) > 2 else ""


def provenance_lines(scenes):
  recs = [r for by in scenes.values() for rs in by.values() for r in rs]
  prov = [r.get("provenance", {}) for r in recs]
  commits = sorted({(p.get("git") or {}).get("commit", "?")[:7] for p in prov})
  dirty = sum(bool((p.get("git") or {}).get("dirty")) for p in prov)
  devices = sorted({f"{p.get('device', {}).get('kind')} x{p.get('device', {}).get('count')}, "
                    f"{p.get('cpu', {}).get('model')}, {p.get('cpu', {}).get('cores_used')} "
                    "core(s)" for p in prov})
  peaks = [p.get("matmul_peak_gflops") for p in prov if p.get("matmul_peak_gflops")]
  versions = sorted({f"jax {p.get('versions', {}).get('jax')}, flax "
                     f"{p.get('versions', {}).get('flax')}" for p in prov})
  if all(r.get("mode") == "steps" for r in recs):
    budget = f"{sorted({r.get('target_steps') for r in recs})} steps"
  else:
    budget = f"{sorted({r.get('budget_s') for r in recs})} s"
  return [f"- runs: {len(recs)}; training budget per run: {budget}",
          f"- machines: {'; '.join(devices)}",
          f"- measured matmul peak: {min(peaks):.0f}-{max(peaks):.0f} GFLOP/s" if peaks else "",
          f"- software: {'; '.join(versions)}",
          f"- commits: {', '.join(commits)} ({dirty} runs from a modified tree)"]
