"""The count of a budgeted stage whose sizes the step table lacks: it times
its own first steps and fixes how many it takes in its share of the budget
(stages/budget.py), once; one that would pass its sampler switch fixes it
again after timing as many steps past the switch (the steps after it cost
their own time). A resumed stage keeps what it fixed (`budget.read_fixed`)."""
from typing import Optional, Tuple

from halo_jax.stages import budget


class SelfTimed:
  """A self-measuring stage's count and this machine's step times.

  last: the loop's last step (provisional until `fixed` and not
  `after_pending`); step_s, after_s: the measured seconds of a step before
  and past the switch (0.0: not yet)."""

  def __init__(self, cfg, workdir: str, name: str, switch_step: int, start: Tuple[int, float]):
    self.cfg, self.workdir, self.name, self.switch_step = cfg, workdir, name, switch_step
    self.start_step, self.start_wall = start
    fixed = budget.read_fixed(workdir, name) if cfg.max_seconds else None
    self.fixed = fixed is not None
    self.last = fixed["steps"] if fixed else budget.last_step(cfg)
    self.step_s = fixed["step_s"] if fixed else 0.0
    self.after_s = fixed.get("after_step_s", 0.0) if fixed else 0.0
    self.after_pending = bool(fixed and fixed.get("after_pending", False))
    self.after_from: Optional[Tuple[int, float]] = None  # (step, wall_s) at the switch

  def seconds(self, first: int, last: int) -> float:
    """This machine's seconds of steps first+1 .. last, as measured."""
    return budget.measured_seconds(self.step_s, self.after_s, self.switch_step, first, last)

  def due(self, step: int, wall_s: float) -> bool:
    """Whether the count is to be fixed after `step` (the caller then waits
    for the step in flight and calls `fix`)."""
    if not self.cfg.max_seconds:
      return False
    if not self.fixed:
      return step - self.start_step >= budget.MEASURE_STEPS or wall_s >= self.cfg.max_seconds
    return (self.after_pending and self.after_from is not None
            and (step - self.after_from[0] >= budget.MEASURE_STEPS or step >= self.last))

  def at_switch(self, step: int, wall_s: float):
    """The loop is at its switch (or resumed past it): steps are timed from here."""
    if self.after_from is None:
      self.after_from = (step, wall_s)

  def fix(self, step: int, wall_s: float) -> str:
    """Fixes the count after `step` at `wall_s` training seconds; returns
    what it fixed, in words."""
    switched = self.after_from[0] if self.after_from else None
    if self.fixed:  # timed past the switch
      self.after_s = (wall_s - self.after_from[1]) / max(step - switched, 1)
    elif switched is not None and self.start_step < switched < step:  # passed it while timing
      self.step_s = (self.after_from[1] - self.start_wall) / (switched - self.start_step)
      self.after_s = (wall_s - self.after_from[1]) / (step - switched)
    else:  # one rate (a run resumed past its switch times only the steps after it)
      self.step_s = (wall_s - self.start_wall) / max(step - self.start_step, 1)
      self.after_s = self.step_s if switched is not None else 0.0
    self.last = max(step, budget.fixed_count(self.cfg, self.step_s, self.after_s,
                                             self.switch_step))
    self.fixed = True
    self.after_pending = bool(self.switch_step) and not self.after_s and self.last > self.switch_step
    if self.after_pending:
      rate = f"{self.step_s:.4g} s a step fixes {self.last} until its steps past its switch are timed"
    elif self.after_s:
      rate = (f"{self.step_s:.4g} s a step, and {self.after_s:.4g} s past its switch at "
              f"{self.switch_step}, fix {self.last} steps")
    else:
      rate = f"{self.step_s:.4g} s a step fixes {self.last} steps"
    return f"{rate} for its {self.cfg.max_seconds:.1f} s"

  def write(self):
    budget.write_fixed(self.workdir, self.name, self.last, self.step_s, self.after_s,
                       self.after_pending)
