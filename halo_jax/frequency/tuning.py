"""Choosing Lo-NeRF's P.E. frequency without extra data (HALO sec. 4.1).

Short Lo-NeRFs are trained from the highest frequency of `config.tune.grid`
to the lowest; for each, pairs of nearby views (halo_jax/frequency/view_pairs.py: orbit
neighbours, spiral neighbours in NDC, a fixed time per pair for dynamic
scenes) are rendered at the criterion resolution and compared with the
scale-free `spectrum.relative_spectrum_difference` (rho); the first (L, s)
whose rho falls below `config.tune.threshold` is chosen. The threshold was
calibrated across scenes by leave-one-scene-out (docs/frequency.md). Held-out
PSNR is measured for the report only; it never enters the choice.
"""
import json
import os
import sys
from typing import List, Tuple

import numpy as np

from halo_jax import frozen, progress, protocol
from halo_jax.frequency import spectrum, view_pairs
from halo_jax.stages import base, collapse, order
from halo_jax.stages.state import load


def parse_grid(spec) -> List[Tuple[int, float]]:
  """'10:1,5:8,5:32' (or a list of (L, s)) -> [(L, s)] sorted from the highest
  frequency 2^(L-1)/s to the lowest."""
  if isinstance(spec, str):
    try:
      points = [(int(p.split(":")[0]), float(p.split(":")[1])) for p in spec.split(",") if p]
    except (IndexError, ValueError) as e:
      raise ValueError(f"tune.grid={spec!r}: expected 'L:s,L:s,...'") from e
  else:
    points = [(int(L), float(s)) for L, s in spec]
  if not points:
    raise ValueError(f"tune.grid={spec!r} is empty")
  return sorted(points, key=lambda p: (-(2.0 ** (p[0] - 1)) / p[1], -p[0]))


def lo_renderer(lo_config, dataset, lo_state):
  """The finished Lo stage as fn(o, d[, t]) -> {'rgb', 'depth', 'acc'}."""
  return base.renderer_of(lo_config, "lo", dataset, {"lo": lo_state})


def criterion_of(render, dataset, config) -> dict:
  """rho of `render` (a finished Lo field) on the scene's view pairs:
  {'criterion' (the form config.tune.warp selects), 'criterion_plain',
  'criterion_warped', 'per_pair', 'shift_px', 'steps', 'pair_kind'}."""
  t = config.tune
  pairs = view_pairs.make(render, dataset, t.num_pairs, t.size, t.shift_px, t.seed,
                          config.eval.chunk)
  rho = lambda b: [float(spectrum.relative_spectrum_difference(
      pairs["a"][i:i + 1], b[i:i + 1], t.mask_fraction)) for i in range(len(b))]
  plain, warped = rho(pairs["b"]), rho(pairs["b_warped"])
  per_pair = warped if t.warp else plain
  return {"criterion": float(np.mean(per_pair)), "per_pair": per_pair,
          "criterion_plain": float(np.mean(plain)), "criterion_warped": float(np.mean(warped)),
          "shift_px": [float(x) for x in pairs["shift_px"]],
          "steps": [float(x) for x in pairs["steps"]], "pair_kind": pairs["kind"]}


def point_config(config, L, scale):
  """The short Lo-NeRF run of one grid point."""
  c = frozen.thaw(config)
  c.stages = "lo"
  protocol.steps(c)
  c.lo.encoding.L, c.lo.encoding.scale = int(L), float(scale)
  c.lo.encoding.auto = False
  # The points train as the threshold was calibrated: lo_steps steps, with no
  # time cap unless lo_seconds sets one (a launch's budget does not apply).
  c.lo.max_seconds = float(c.tune.lo_seconds)
  if c.tune.lo_steps:
    c.lo.steps = c.tune.lo_steps
  return frozen.freeze(protocol.resolve(c, order.graph(c)))


def point_dir(workdir, L, scale):
  return os.path.join(workdir, f"L{L}_s{scale:g}")


def tune(config, workdir: str, dataset, run_stages, full_grid: bool = False) -> dict:
  """Runs the search; writes and returns {'grid': [...], 'chosen': {'L', 'scale'}, ...}.

  Grid points already finished in `workdir` are reused, so a killed search
  resumes. Without full_grid the search stops at the first point below the
  threshold. The choice and its 'note' come from `decide`: never Hi-NeRF's
  own frequency unannounced. A point whose Lo-NeRF collapsed (learned
  nothing, stages/collapse.py) is kept in the grid with `collapsed: True`
  and its criterion, and is never chosen. run_stages: halo_jax.pipeline.run
  (passed in, so that this module does not import the pipeline that calls it).
  """
  t = config.tune
  grid, chosen = [], None
  for L, s in progress.steps(parse_grid(t.grid), "grid points", "frequency search"):
    wd = point_dir(workdir, L, s)
    c = point_config(config, L, s)
    try:
      info = run_stages(c, wd, dataset)["lo"]   # a finished point is restored, not retrained
    except collapse.Collapsed as e:
      info = e.infos["lo"]                      # its state is saved all the same
    trainer = base.trainer_of(c, "lo")
    lo_state = load(wd, "lo", trainer.params_like(c, "lo", dataset))
    crit = criterion_of(lo_renderer(c, dataset, lo_state), dataset, c)
    ev = info.get("eval", {})
    grid.append({"L": L, "scale": s, "max_freq": 2.0 ** (L - 1) / s,
                 "criterion": crit["criterion"], "per_pair": crit["per_pair"],
                 "criterion_plain": crit["criterion_plain"],
                 "criterion_warped": crit["criterion_warped"],
                 "shift_px": crit["shift_px"], "pair_kind": crit["pair_kind"],
                 "psnr": ev.get("psnr"), "ssim": ev.get("ssim"), "lpips": ev.get("lpips"),
                 "wall_s": info["wall_s"], "steps": info["step"],
                 "collapsed": collapse.collapsed(info)})
    row = grid[-1]
    row["score"] = score(row["criterion"], grid[0]["criterion"], t.relative)
    if chosen is None and row["score"] < t.threshold and not row["collapsed"]:
      chosen = {"L": L, "scale": s}
      if not full_grid:
        break
  hi = config.hi.encoding
  chosen, note = decide(grid, parse_grid(t.grid), t.threshold, 2.0 ** (hi.L - 1) / hi.scale)
  result = {"grid": grid, "chosen": chosen, "below_threshold": note["below_threshold"],
            "note": note["text"], "threshold": t.threshold, "full_grid": full_grid}
  with open(os.path.join(workdir, "results.json"), "w") as f:
    json.dump(result, f, indent=1)
  return result


def score(criterion: float, first: float, relative: bool) -> float:
  """What the threshold is compared with: rho itself, or (relative) rho over
  the rho of the grid's first point, Hi-NeRF's frequency."""
  return criterion / max(first, 1e-12) if relative else criterion


def _fmt(L, s):
  return f"L={L}, s={s:g}"


def decide(rows, grid, threshold, hi_freq):
  """The search's choice from the scored points `rows` (high to low frequency,
  each with L, scale, criterion and optionally the score the threshold is
  compared with, else the criterion) out of `grid` (parse_grid order).

  The first point below the threshold that did not collapse (rows with
  `collapsed` true are never chosen), except that the rule never hands back
  Hi-NeRF's frequency (2^(L-1)/s >= hi_freq) unannounced: when the first
  point already passes, the grid did not bracket the answer, and the choice
  is the highest grid point below Hi-NeRF's frequency; when none passes, the
  lowest-frequency point. Returns ({'L', 'scale'}, {'below_threshold',
  'text'}), text '' for a plain pick and a sentence otherwise.
  """
  crit = lambda r: r.get("score", r["criterion"])
  learned = [r for r in rows if not r.get("collapsed")]
  if not learned:
    raise RuntimeError(f"every grid point's Lo-NeRF collapsed ({len(rows)} points of "
                       f"tune.grid): there is no frequency to choose; see the points' "
                       "info.json (tune.lo_steps may be too few for this scene)")
  passing = [i for i, r in enumerate(rows) if crit(r) < threshold and not r.get("collapsed")]
  freq = lambda L, s: 2.0 ** (L - 1) / s
  dead = {(r["L"], r["scale"]) for r in rows if r.get("collapsed")}
  if not passing:
    L, s = [p for p in grid if p not in dead][-1]
    low = min(rows, key=crit)
    return {"L": L, "scale": s}, {"below_threshold": False, "text": (
        f"no grid point fell below the threshold {threshold:g} (lowest criterion "
        f"{crit(low):.4g} at {_fmt(low['L'], low['scale'])}); chose the lowest-frequency "
        f"point {_fmt(L, s)}")}
  first = rows[passing[0]]
  pick = {"L": first["L"], "scale": first["scale"]}
  if passing[0] > 0:
    return pick, {"below_threshold": True, "text": ""}
  below_hi = [(L, s) for L, s in grid if freq(L, s) < hi_freq and (L, s) not in dead]
  if freq(first["L"], first["scale"]) >= hi_freq and below_hi:
    L, s = below_hi[0]
    return {"L": L, "scale": s}, {"below_threshold": True, "text": (
        f"the first grid point {_fmt(first['L'], first['scale'])} (Hi-NeRF's frequency or "
        f"above) already passed the threshold {threshold:g} (criterion "
        f"{crit(first):.4g}), so the grid does not bracket this scene's answer; chose "
        f"{_fmt(L, s)}, the highest grid point below Hi-NeRF's frequency")}
  return pick, {"below_threshold": True, "text": (
      f"the first grid point {_fmt(first['L'], first['scale'])} already passed the threshold "
      f"{threshold:g} (criterion {crit(first):.4g}): the grid may not reach high "
      "enough to bracket this scene's answer")}


def chosen_encoding(config, workdir: str, dataset, run_stages) -> Tuple[int, float]:
  """(L, s) for `lo.encoding.auto`: from `<workdir>/tune/results.json` if a
  search already ran there, else runs it."""
  tune_dir = os.path.join(workdir, "tune")
  path = os.path.join(tune_dir, "results.json")
  if os.path.exists(path):
    with open(path) as f:
      result = json.load(f)
  else:
    os.makedirs(tune_dir, exist_ok=True)
    result = tune(config, tune_dir, dataset, run_stages)
  chosen = result["chosen"]
  if result.get("note"):  # said on every launch that uses the choice
    print(f"lo.encoding.auto: {result['note']}", file=sys.stderr)
  print(f"lo.encoding.auto: Lo-NeRF uses {_fmt(chosen['L'], chosen['scale'])} "
        f"({os.path.relpath(path)})", file=sys.stderr)
  return int(chosen["L"]), float(chosen["scale"])
