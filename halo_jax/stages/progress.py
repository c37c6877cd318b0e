"""The training loop's progress bar."""
import tqdm

from halo_jax.stages.budget import last_step


class ProgressBar:
  """tqdm over training seconds when the stage has a time budget (so its ETA
  is the budget's), else over steps; shows steps and rays/s either way."""

  def __init__(self, name, cfg, start_step, start_wall_s):
    self.timed = bool(cfg.max_seconds)
    self.rays = cfg.get("batch_rays", 0)  # 0: no rays/s shown
    self.start_step, self.start_wall = start_step, start_wall_s
    if self.timed:
      # a stage resumed past its budget starts full (tqdm cannot format n > total)
      total = round(cfg.max_seconds, 1)
      self.bar = tqdm.tqdm(total=total, initial=min(round(start_wall_s, 1), total),
                           desc=name, unit="s", dynamic_ncols=True, mininterval=1.0,
                           bar_format="{l_bar}{bar}| {n:.0f}/{total:.0f} s "
                                      "[{elapsed}<{remaining}{postfix}]")
    else:
      last = last_step(cfg)
      self.bar = tqdm.tqdm(total=last, initial=min(start_step, last), desc=name, unit="step",
                           dynamic_ncols=True, mininterval=1.0)
    self.shown = {}

  def advance(self, step, seconds, wall_s):
    if self.timed:  # the last step ends past the budget: the bar stops at its total
      self.bar.update(max(0.0, min(seconds, self.bar.total - self.bar.n)))
    else:
      self.bar.update(1)
    if self.rays and wall_s > self.start_wall:
      rate = self.rays * (step - self.start_step) / (wall_s - self.start_wall)
      self.shown.update(step=step, **{"rays/s": f"{rate:.3g}"})

  def set_postfix(self, **shown):
    self.shown.update(shown)
    self.bar.set_postfix(**self.shown, refresh=False)

  def close(self):
    self.bar.close()
