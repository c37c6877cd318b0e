"""A finished run's error-against-time front: the parameters each stage saved
at the method's training times (eval.front_s; halo_jax/stages/snapshots.py),
each scored after training on every held-out view, so that scoring costs no
training time and never shortens it.

While a stage that makes no images trains (HALO's ray field), the method's
output is the last stage before it that does: its point at such a time is
that stage's final state.
"""
import dataclasses

import numpy as np

from halo_jax import evaluate, restore
from halo_jax.stages import base, order, snapshots


def with_params(run: restore.Restored, params, step: int) -> restore.Restored:
  """`run` with its stage's parameters replaced (by a snapshot's)."""
  states = dict(run.states)
  states[run.stage] = states[run.stage].replace(params=params, step=step)
  render = base.renderer_of(run.config, run.stage, run.dataset, states)
  return dataclasses.replace(run, states=states, render=render)


def _scores(run: restore.Restored, views, with_lpips: bool, step=None) -> dict:
  r = evaluate.render_views(run.render, views, run.config.eval.chunk,
                            desc=f"front {run.stage}" + ("" if step is None else f" @{step}"))
  per = evaluate.score(np.clip(r["rgb"], 0.0, 1.0), views.images, with_lpips)
  return {k: float(np.mean(v)) for k, v in per.items()}


def evaluate_front(workdir: str, with_lpips: bool = True, data_root: str = "") -> list:
  """[{'at_s', 'wall_s', 'stage', 'step', 'psnr', 'ssim'[, 'lpips']}, ...] by
  time: each saved point of the run's output stage and the stages it needs,
  scored on the run's held-out views (those its final evaluation used)."""
  out = restore.load(workdir, None, data_root)
  views = out.dataset.test
  points, shown = [], None  # shown: the last stage so far that makes images, restored
  finals = {}  # its final scores, scored once and only when a point needs them
  for name in order.needed(out.config, out.stage):
    saved = snapshots.read_index(workdir, name)
    if base.trainer_of(out.config, name).renderer is None:
      if saved and shown is not None:
        if shown.stage not in finals:
          finals[shown.stage] = _scores(shown, views, with_lpips)
        points += [dict(p, stage=shown.stage, step=None, **finals[shown.stage]) for p in saved]
      continue
    run = restore.load(workdir, name, data_root)
    like = run.states[name].params
    for p in saved:
      params = snapshots.load_params(workdir, name, p["step"], like)
      points.append(dict(p, stage=name,
                         **_scores(with_params(run, params, p["step"]), views, with_lpips,
                                  p["step"])))
    shown = run
  return sorted(points, key=lambda p: p["at_s"])
