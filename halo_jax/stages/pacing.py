"""Training driven one step at a time from another thread.

A harness that owns the loop (nerfbaselines calls `train_iteration(step)`
once a step) cannot hand control to our host loop (stages/loop.py), which
runs a whole stage. `Paced` runs the pipeline in a thread of its own whose
loop waits for a turn before every step: the driver's `step()` grants one
turn and returns that step's record, and `call(fn)` runs fn(run) on the
training thread between two steps (a checkpoint, say), so the training
state is only ever touched by the thread that trains.
"""
import dataclasses
import queue
import threading
from typing import Any, Callable, Dict, Optional


@dataclasses.dataclass(frozen=True)
class StepRecord:
  """One paced step: its stage, the stage's step number, the parameters
  after it (device arrays) and its loss terms as floats."""
  stage: str
  step: int
  params: Any
  metrics: Dict[str, float]


class Pacer:
  """The meeting point of a stage loop (`wait_turn`, `report`) and a driver
  (`step`, `call`)."""

  def __init__(self):
    self._orders = queue.Queue()    # driver -> loop: ("step",) or ("call", fn)
    self._results = queue.Queue()   # loop -> driver: ("step", record), ("call", value),
                                    # ("done", None) or ("error", exception)

  # The training thread's side.
  def wait_turn(self, run) -> None:
    """Blocks until the driver grants a step; runs the calls it sends meanwhile."""
    while True:
      order = self._orders.get()
      if order[0] == "step":
        return
      try:
        self._results.put(("call", order[1](run)))
      except Exception as e:  # pylint: disable=broad-except
        self._results.put(("error", e))

  def report(self, record: StepRecord) -> None:
    self._results.put(("step", record))

  def finish(self, error: Optional[BaseException] = None) -> None:
    self._results.put(("error", error) if error is not None else ("done", None))

  # The driver's side.
  def _answer(self):
    kind, value = self._results.get()
    if kind == "error":
      raise value
    return kind, value

  def step(self) -> Optional[StepRecord]:
    """Takes one training step; None once the run has no steps left."""
    self._orders.put(("step",))
    kind, value = self._answer()
    return value if kind == "step" else None

  def call(self, fn: Callable) -> Any:
    """fn(run) on the training thread at its next wait (run: the stage loop's
    state, stages/loop.py's _Run); its value."""
    self._orders.put(("call", fn))
    return self._answer()[1]


class Paced:
  """A pipeline run (fn(pacer) -> infos) on a thread of its own, stepped by
  the caller."""

  def __init__(self, run_fn: Callable[[Pacer], Any]):
    self.pacer = Pacer()
    self.infos = None
    self.finished = False

    def target():
      try:
        self.infos = run_fn(self.pacer)
        self.pacer.finish()
      except BaseException as e:  # pylint: disable=broad-except
        self.pacer.finish(e)

    self._thread = threading.Thread(target=target, name="halo-train", daemon=True)
    self._thread.start()

  def step(self) -> Optional[StepRecord]:
    if self.finished:
      return None
    record = self.pacer.step()
    self.finished = record is None
    return record

  def join(self) -> Any:
    """Lets the run end after its last step (its final saves) and returns
    pipeline.run's infos."""
    if not self.finished:
      self.step()
    self._thread.join()
    return self.infos
