"""Error-against-time fronts in the benchmark's report: per scene, each
method's held-out PSNR (and LPIPS) at the training seconds its run saved
(experiments/bench/front_scores.py), the seconds each needs to reach nerf_tuned's
final PSNR, its figures, and the README's fronts table.

A record's front is its list of points {'at_s', 'wall_s', 'psnr', 'lpips',
'final'?}; the mean front of a scene's seeds matches points by saved time.
"""
import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # pylint: disable=g-import-not-at-top
import numpy as np  # pylint: disable=g-import-not-at-top

from experiments.bench import code_version  # pylint: disable=g-import-not-at-top
from experiments.bench.report_common import (  # pylint: disable=g-import-not-at-top
    BASELINE, in_method_order, mean_pm)


def front_of(record):
  """[(seconds, PSNR, LPIPS or None), ...] of a record's error-against-time
  front: its snapshot times, then its final state at its end, all in the
  seconds its budget counts (the reference clock's under the 'budget'
  protocol; a wall-clock record's final `at_s` is its training seconds)."""
  return [(p["at_s"], p["psnr"], p.get("lpips")) for p in record.get("front", [])]


def front_values(records, at_s):
  """The records' front PSNRs at snapshot time `at_s` (None: the final state)."""
  return [p["psnr"] for r in records for p in r.get("front", [])
          if (p.get("final") if at_s is None else p.get("at_s") == at_s and not p.get("final"))]


def mean_front(records):
  """(seconds [P], mean PSNR [P], PSNR [seeds, P], LPIPS [seeds, P]) over the
  records with a front: points matched by their snapshot time, the final
  state last (its seconds the mean over seeds)."""
  fronts = [front_of(r) for r in records if r.get("front")]
  if not fronts:
    return None
  n = min(len(f) for f in fronts)  # seeds share the snapshot times; the end is last
  arr = np.asarray([[(t, p, np.nan if l is None else l) for t, p, l in f[:n - 1] + f[-1:]]
                    for f in fronts], np.float64)
  return arr[:, :, 0].mean(0), arr[:, :, 1].mean(0), arr[:, :, 1], arr[:, :, 2]


def seconds_to_level(records, level):
  """The first saved point (snapshot time, or the end) at which the mean over
  seeds of the records' fronts is at or above `level` dB; None if none is.
  An upper bound: the level may be passed between two saved points."""
  f = mean_front(records)
  if f is None:
    return None
  return next((float(t) for t, p in zip(f[0], f[1]) if p >= level - 1e-9), None)


def front_table(by_method):
  """Per method, from the runs with a front: held-out PSNR (all views) at each
  snapshot time and at the end, and the seconds to reach nerf_tuned's final
  PSNR (seconds_to_level), also as a ratio to nerf_tuned's own."""
  with_front = {m: [r for r in rs if r.get("front")] for m, rs in by_method.items()}
  with_front = {m: rs for m, rs in with_front.items() if rs}
  if not with_front:
    return ""
  times = sorted({p["at_s"] for rs in with_front.values() for r in rs
                  for p in r["front"] if not p.get("final")})
  base = with_front.get(BASELINE)
  level = float(np.mean([r["psnr"] for r in base])) if base else None
  ref = seconds_to_level(base, level) if base else None
  head = ["method", "seeds"] + [f"{t:g} s" for t in times] + ["end"]
  if level is not None:
    head += [f"s to {level:.2f} dB (nerf_tuned's end)", "× nerf_tuned's"]
  lines = ["| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
  for m in in_method_order(with_front):
    rs = with_front[m]
    cells = []
    for t in times:
      v = front_values(rs, t)
      cells.append(mean_pm(np.asarray(v)) if v else "-")
    cells.append(mean_pm(np.asarray([r["psnr"] for r in rs])))
    if level is not None:
      t = seconds_to_level(rs, level)
      cells.append("not reached" if t is None else f"{t:.0f}")
      cells.append(f"{t / ref:.2f}" if t is not None and ref else "-")
    lines.append(f"| {m} | {len(rs)} | " + " | ".join(cells) + " |")
  return "\n".join(lines)


def _time_ticks(ax, ticks):
  """A log time axis labelled at the front's points (seconds), one label
  where the seeds' ends (240, 241 s) would overprint."""
  shown = []
  for t in sorted(ticks):
    if not shown or t > 1.05 * shown[-1]:
      shown.append(t)
  ax.set_xscale("log")
  ax.minorticks_off()
  ax.set_xticks(shown, [str(t) for t in shown])


def plot_front(by_method, title, path):
  """Held-out PSNR and LPIPS (every view) against training seconds: the mean
  over seeds at each front point, the spread as a band."""
  fig, axes = plt.subplots(1, 2, figsize=(10, 4))
  ticks = set()
  for i, m in enumerate(in_method_order(by_method)):
    f = mean_front(by_method[m])
    if f is None:
      continue
    t, _, psnr, lpips = f
    ticks |= {round(float(x)) for x in t}
    for ax, y in zip(axes, (psnr, lpips)):
      if np.isnan(y).all():
        continue
      ax.fill_between(t, y.min(0), y.max(0), color=f"C{i}", alpha=0.2, lw=0)
      ax.plot(t, y.mean(0), "o-", color=f"C{i}", ms=3, label=f"{m} ({len(y)})")
  for ax, what in zip(axes, ("PSNR (dB)", "LPIPS (VGG)")):
    _time_ticks(ax, ticks)
    ax.set_xlabel("training seconds")
    ax.set_ylabel(f"held-out {what}, every view")
    ax.grid(alpha=0.3)
  axes[0].legend(fontsize=8)
  fig.suptitle(title, fontsize=10)
  fig.tight_layout()
  fig.savefig(path, dpi=110)
  plt.close(fig)


def reach_ratio(by_method, method="halo"):
  """(seconds, ratio) for `method` to reach nerf_tuned's final PSNR (the mean
  over seeds) on its front, the ratio to nerf_tuned's own seconds to it
  (front_table's columns); None where either has no front or never reaches it."""
  base = [r for r in by_method.get(BASELINE, []) if r.get("front")]
  runs_ = [r for r in by_method.get(method, []) if r.get("front")]
  if not base or not runs_:
    return None
  level = float(np.mean([r["psnr"] for r in base]))
  t, ref = seconds_to_level(runs_, level), seconds_to_level(base, level)
  if t is None or not ref:
    return None
  return t, t / ref


def plot_fronts_overview(scenes, path, methods=(BASELINE, "halo")):
  """One panel per scene with fronts: `methods`' mean held-out PSNR (every
  view) against training seconds, the spread over seeds as a band, and
  nerf_tuned's final PSNR as a dashed line. Returns the scenes drawn."""
  drawn = [s for s in sorted(scenes)
           if any(r.get("front") for m in methods for r in scenes[s].get(m, []))]
  if not drawn:
    return []
  cols = min(3, len(drawn))
  rows = -(-len(drawn) // cols)
  fig, axes = plt.subplots(rows, cols, figsize=(3.4 * cols, 2.6 * rows), squeeze=False)
  for ax, scene in zip(axes.flat, drawn):
    ticks = set()
    for i, m in enumerate(methods):
      f = mean_front(scenes[scene].get(m, []))
      if f is None:
        continue
      t, mean, psnr, _ = f
      ticks |= {round(float(x)) for x in t}
      ax.fill_between(t, psnr.min(0), psnr.max(0), color=f"C{i}", alpha=0.2, lw=0)
      ax.plot(t, mean, "o-", color=f"C{i}", ms=3, label=f"{m} ({len(psnr)})")
    base = [r for r in scenes[scene].get(BASELINE, []) if r.get("front")]
    if base:  # the level reach_ratio uses: nerf_tuned's runs with a front
      ax.axhline(np.mean([r["psnr"] for r in base]), color="k", ls="--", lw=0.8)
    _time_ticks(ax, ticks)
    ax.set_title(scene, fontsize=9)
    ax.grid(alpha=0.3)
    ax.tick_params(labelsize=7)
  for ax in axes.flat[len(drawn):]:
    ax.axis("off")
  axes[0, 0].legend(fontsize=7)
  fig.supxlabel("training seconds", fontsize=9)
  fig.supylabel("held-out PSNR (dB), every view", fontsize=9)
  fig.tight_layout()
  fig.savefig(path, dpi=100)
  plt.close(fig)
  return drawn


def paired_fronts(scenes, method="halo"):
  """{scene: {method: records, nerf_tuned: records}}, the records with a
  front, for the scenes where both methods have one."""
  pairs = {s: {m: [r for r in scenes[s].get(m, []) if r.get("front")]
               for m in (method, BASELINE)} for s in sorted(scenes)}
  return {s: by for s, by in pairs.items() if all(by.values())}


def fronts_rows(key, scenes, method="halo"):
  """The README's table for a suite with fronts: per scene, `method` /
  nerf_tuned held-out PSNR (every view, mean over the seeds with a front) at
  each saved time and at the end, then `method`'s seconds to nerf_tuned's
  end and the ratio to nerf_tuned's own (reach_ratio), and the code
  fingerprints (code_version) of each method's records with a front. Returns
  its lines."""
  suite, mode = key
  with_front = paired_fronts(scenes, method)
  times = sorted({p["at_s"] for by in with_front.values() for rs in by.values()
                  for r in rs for p in r["front"] if not p.get("final")})
  head = (["suite", "scene", "seeds"] + [f"{t:g} s" for t in times]
          + ["end", f"{method}: s to nerf_tuned's end (× its time)", "code fingerprints"])
  lines = ["| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
  for scene, by in with_front.items():
    cells = []
    for t in times + [None]:
      means = [front_values(by[m], t) for m in (method, BASELINE)]
      cells.append(" / ".join(f"{np.mean(v):.2f}" if v else "-" for v in means))
    reach = reach_ratio(by, method)
    cells.append("not reached" if reach is None else f"{reach[0]:.0f} ({reach[1]:.2f})")
    table = code_version.load()
    cells.append(" / ".join(code_version.of_records([r for r in by[m] if r.get("front")], table)
                            for m in (method, BASELINE)))
    lines.append(f"| [{suite}/{mode}](docs/results/{suite}_{mode}.md) | {scene} | "
                 f"{len(by[method])} / {len(by[BASELINE])} | " + " | ".join(cells) + " |")
  return lines
