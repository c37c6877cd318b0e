"""Choosing Lo-NeRF's P.E. frequency without extra data (HALO sec. 4.1).

Short Lo-NeRFs are trained from the highest frequency of `config.tune.grid`
to the lowest; for each, pairs of nearby views are rendered and compared
with `frequency.spectrum_difference`; the first (L, s) whose criterion falls
below `config.tune.threshold` is chosen. Held-out PSNR is measured for the
report only; it never enters the choice.

Nearby pairs: camera a at a random azimuth and at an elevation drawn between
the lowest and highest training camera, on the training cameras' sphere,
looking at the origin; camera b is camera a moved `angle_deg` along its
orbit (same elevation). Both are rendered at the training resolution.
"""
import copy
import json
import os
import sys
from typing import List, Tuple

import numpy as np

from halo_jax import camera, frequency, models, raycast
from halo_jax.stages import radiance
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


def nearby_pairs(c2w_train, num_pairs: int, angle_deg: float, seed: int):
  """[N, 2, 4, 4] camera pairs `angle_deg` apart on the training cameras' sphere."""
  pos = np.asarray(c2w_train)[:, :3, 3].astype(np.float64)
  radius = float(np.linalg.norm(pos, axis=-1).mean())
  elev = np.degrees(np.arcsin(np.clip(pos[:, 2] / np.linalg.norm(pos, axis=-1), -1, 1)))
  rng = np.random.default_rng(seed)
  az = rng.uniform(0.0, 360.0, num_pairs)
  el = rng.uniform(elev.min(), elev.max(), num_pairs)
  return np.stack([np.stack([camera.spherical_camera(radius, a, e),
                             camera.spherical_camera(radius, a + angle_deg, e)])
                   for a, e in zip(az, el)])


def render_pairs(eval_fn, pairs, height, width, focal, chunk):
  """Renders [N, 2] cameras -> two [N, H, W, 3] image stacks."""
  rays = [camera.pixel_rays(c, height, width, focal) for c in pairs.reshape(-1, 4, 4)]
  o = np.stack([r[0] for r in rays])
  d = np.stack([r[1] for r in rays])
  rgb = raycast.render_chunked(eval_fn, o, d, chunk)["rgb"]
  rgb = rgb.reshape(len(pairs), 2, height, width, 3)
  return rgb[:, 0], rgb[:, 1]


def lo_criterion(lo_state, dataset, tune_cfg, chunk) -> dict:
  """The criterion of a finished Lo-NeRF: {'criterion', 'per_pair'}."""
  model = models.nerf_from_config(lo_state.config, "lo")
  render = raycast.make_eval_fn(model, lo_state.config.lo.sampler, near=dataset.near,
                                far=dataset.far, white_background=dataset.white_background,
                                block_rays=lo_state.config.eval.block_rays)
  eval_fn = lambda o, d: render(lo_state.params["nerf"], None, o, d)
  pairs = nearby_pairs(dataset.train.c2w, tune_cfg.num_pairs, tune_cfg.angle_deg,
                       tune_cfg.seed)
  a, b = render_pairs(eval_fn, pairs, dataset.train.height, dataset.train.width,
                      dataset.train.focal, chunk)
  per_pair = [float(frequency.spectrum_difference(a[i:i + 1], b[i:i + 1],
                                                   tune_cfg.mask_fraction))
              for i in range(len(pairs))]
  return {"criterion": float(np.mean(per_pair)), "per_pair": per_pair}


def point_config(config, L, scale):
  """The short Lo-NeRF run of one grid point."""
  c = copy.deepcopy(config)
  c.stages = "lo"
  c.budget_s = 0.0
  c.lo.encoding.L, c.lo.encoding.scale = int(L), float(scale)
  c.lo.encoding.auto = False
  if c.tune.lo_seconds:
    c.lo.max_seconds = c.tune.lo_seconds
  if c.tune.lo_steps:
    c.lo.steps = c.tune.lo_steps
  return c


def point_dir(workdir, L, scale):
  return os.path.join(workdir, f"L{L}_s{scale:g}")


def tune(config, workdir: str, dataset, run_stages, full_grid: bool = False) -> dict:
  """Runs the search; writes and returns {'grid': [...], 'chosen': {'L', 'scale'}, ...}.

  Grid points already finished in `workdir` are reused, so a killed search
  resumes. Without full_grid the search stops at the first point below the
  threshold. The choice and its 'note' come from `decide`: never Hi-NeRF's
  own frequency unannounced. run_stages: halo_jax.pipeline.run (passed in,
  so that this module does not import the pipeline that calls it).
  """
  t = config.tune
  grid, chosen = [], None
  for L, s in parse_grid(t.grid):
    wd = point_dir(workdir, L, s)
    c = point_config(config, L, s)
    info = run_stages(c, wd, dataset)["lo"]   # a finished point is restored, not retrained
    lo_state = load(wd, "lo", radiance.init_params(c, "lo", dataset))
    crit = lo_criterion(lo_state, dataset, t, config.eval.chunk)
    ev = info.get("eval", {})
    grid.append({"L": L, "scale": s, "max_freq": 2.0 ** (L - 1) / s,
                 "criterion": crit["criterion"], "per_pair": crit["per_pair"],
                 "psnr": ev.get("psnr"), "ssim": ev.get("ssim"), "lpips": ev.get("lpips"),
                 "wall_s": info["wall_s"], "steps": info["step"]})
    if chosen is None and crit["criterion"] < t.threshold:
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


def _fmt(L, s):
  return f"L={L}, s={s:g}"


def decide(rows, grid, threshold, hi_freq):
  """The search's choice from the scored points `rows` (high to low frequency,
  each with L, scale, criterion) out of `grid` (parse_grid order).

  The first point below the threshold, except that the rule never hands back
  Hi-NeRF's frequency (2^(L-1)/s >= hi_freq) unannounced: when the first
  point already passes, the grid did not bracket the answer, and the choice
  is the highest grid point below Hi-NeRF's frequency; when none passes, the
  lowest-frequency point. Returns ({'L', 'scale'}, {'below_threshold',
  'text'}), text '' for a plain pick and a sentence otherwise.
  """
  passing = [i for i, r in enumerate(rows) if r["criterion"] < threshold]
  freq = lambda L, s: 2.0 ** (L - 1) / s
  if not passing:
    L, s = grid[-1]
    low = min(rows, key=lambda r: r["criterion"])
    return {"L": L, "scale": s}, {"below_threshold": False, "text": (
        f"no grid point fell below the threshold {threshold:g} (lowest criterion "
        f"{low['criterion']:.4g} at {_fmt(low['L'], low['scale'])}); chose the lowest-frequency "
        f"point {_fmt(L, s)}")}
  first = rows[passing[0]]
  pick = {"L": first["L"], "scale": first["scale"]}
  if passing[0] > 0:
    return pick, {"below_threshold": True, "text": ""}
  below_hi = [(L, s) for L, s in grid if freq(L, s) < hi_freq]
  if freq(first["L"], first["scale"]) >= hi_freq and below_hi:
    L, s = below_hi[0]
    return {"L": L, "scale": s}, {"below_threshold": True, "text": (
        f"the first grid point {_fmt(first['L'], first['scale'])} (Hi-NeRF's frequency or "
        f"above) already passed the threshold {threshold:g} (criterion "
        f"{first['criterion']:.4g}), so the grid does not bracket this scene's answer; chose "
        f"{_fmt(L, s)}, the highest grid point below Hi-NeRF's frequency")}
  return pick, {"below_threshold": True, "text": (
      f"the first grid point {_fmt(first['L'], first['scale'])} already passed the threshold "
      f"{threshold:g} (criterion {first['criterion']:.4g}): the grid may not reach high "
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
