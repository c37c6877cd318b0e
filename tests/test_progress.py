"""halo_jax/progress.py, the one helper behind every bar, and the training
bar of a stage that fixes its own step count (stages/progress.py)."""

import ml_collections

from halo_jax import progress
from halo_jax.stages.progress import ProgressBar


def _lines(err):
  return err.replace("\r", "\n").splitlines()


def test_a_loop_bar_counts_its_items_on_stderr(capsys):
  assert list(progress.steps(iter("abc"), "runs", "suite")) == ["a", "b", "c"]
  out, err = capsys.readouterr()
  assert out == ""
  assert _lines(err)[-1].startswith("suite: 100%") and "| 3/3 [" in _lines(err)[-1]


def test_a_render_bar_counts_views_by_rays_and_ends_with_rays_per_second(capsys):
  with progress.Render(3, "views", 100, "evaluate") as bar:
    for rays in (64, 64, 64, 64, 44):  # chunks cross view boundaries
      bar.advance(rays)
  last = _lines(capsys.readouterr().err)[-1]
  assert "3.0/3 views" in last and "rays/s]" in last, last
  assert bar.rays == 300


def test_a_self_measuring_stage_bar_turns_to_steps_and_names_its_floor(capsys):
  cfg = ml_collections.ConfigDict(dict(max_seconds=2.0, batch_rays=8, steps=1000,
                                       stop_at_step=0, budget_steps=0))
  bar = ProgressBar("hi", cfg, 0, 0.0)
  assert bar.timed
  for step in range(1, 21):
    bar.advance(step, 0.05, 0.05 * step)
  # 0.5 s a step would give 4 steps in 2 s; a floor of 100 keeps it training
  bar.to_steps(20, 100, 2.0, 0.5)
  assert not bar.timed and bar.bar.total == 100 and bar.bar.n == 20
  for step in range(21, 101):
    bar.advance(step, 0.5, 0.5 * step)
  bar.set_postfix()
  bar.close()
  last = _lines(capsys.readouterr().err)[-1]
  assert "100/100" in last and "floor=100 steps, past its 2 s share" in last, last

