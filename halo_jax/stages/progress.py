"""The training loop's progress bar (halo_jax/progress.py's bars)."""
import math

from halo_jax import progress as bars
from halo_jax.stages.budget import last_step


class ProgressBar:
  """A bar over the stage's steps, showing steps and rays/s. A stage that
  measures its own step time (max_seconds, no reference entry) counts its
  seconds until it has fixed its step count, then its steps (`to_steps`)."""

  def __init__(self, name, cfg, start_step, start_wall_s):
    self.name, self.timed = name, bool(cfg.max_seconds)
    self.rays = cfg.get("batch_rays", 0)  # 0: no rays/s shown
    self.start_step, self.start_wall = start_step, start_wall_s
    if self.timed:
      # a stage resumed past its budget starts full (tqdm cannot format n > total)
      total = round(cfg.max_seconds, 1)
      self.bar = bars.bar(total, name, "s", initial=min(round(start_wall_s, 1), total),
                          bar_format="{l_bar}{bar}| {n:.0f}/{total:.0f} s "
                                     "[{elapsed}<{remaining}{postfix}]")
    else:
      last = last_step(cfg)
      self.bar = bars.bar(last, name, "step", initial=min(start_step, last))
    self.shown = {}
    self.compiling = True  # until the first step: the bar is up while the step compiles
    self.bar.set_postfix_str("compiling the step")

  def to_steps(self, step, last, share_s, step_s):
    """The stage fixed `last` steps at `step_s` s a step: the bar counts steps
    from `step`, and says so where a floor keeps it past its `share_s` s."""
    self.bar.close()
    self.timed = False
    self.bar = bars.bar(last, self.name, "step", initial=min(step, last))
    if last > math.ceil(share_s / max(step_s, 1e-9)):
      self.shown["floor"] = f"{last} steps, past its {share_s:.0f} s share"

  def advance(self, step, seconds, wall_s):
    if self.compiling:
      self.compiling = False
      self.bar.set_postfix_str("", refresh=False)
    if self.timed:  # the last step ends past the budget: the bar stops at its total
      self.bar.update(max(0.0, min(seconds, self.bar.total - self.bar.n)))
    else:
      self.bar.update(1)
    if self.rays and wall_s > self.start_wall:
      rate = self.rays * (step - self.start_step) / (wall_s - self.start_wall)
      self.shown.update(step=step, **{"rays/s": f"{rate:.3g}"})
      self.bar.set_postfix(**self.shown, refresh=False)  # every bar, however short

  def evaluating(self):
    """Says so on the bar while the held-out curve renders (a bar of its
    own counts its views); `resume` then keeps that time out of the rate."""
    self.bar.set_postfix_str("rendering the held-out curve")

  def resume(self):
    self.bar.set_postfix(**self.shown, refresh=False)
    self.bar.unpause()

  def set_postfix(self, **shown):
    self.shown.update(shown)
    self.bar.set_postfix(**self.shown, refresh=False)

  def close(self):
    self.bar.close()
