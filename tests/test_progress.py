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


def test_a_render_bar_counts_whole_views_by_rays_and_ends_with_rays_per_second(capsys):
  import warnings  # pylint: disable=import-outside-toplevel
  counts = []
  with warnings.catch_warnings():
    warnings.simplefilter("error")   # tqdm's 'clamping frac' would raise here
    with progress.Render(3, "views", 100, "evaluate") as bar:
      for rays in (64, 64, 64, 64, 44):  # chunks cross view boundaries
        bar.advance(rays)
        counts.append(bar.bar.n)
  assert counts == [0, 1, 1, 2, 3] and bar.rays == 300   # whole views only
  lines = [l for l in _lines(capsys.readouterr().err) if l.strip()]
  assert "| 3/3 [" in lines[-1] and lines[-1].endswith("rays/s]"), lines[-1]
  assert sum("100%" in l for l in lines) == 1 and not any("<-" in l for l in lines), lines


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



def test_a_short_training_bar_shows_rays_per_second_and_labels_the_curve(capsys):
  cfg = ml_collections.ConfigDict(dict(max_seconds=0.0, batch_rays=64, steps=10,
                                       stop_at_step=0, budget_steps=0))
  bar = ProgressBar("lo", cfg, 0, 0.0)
  for step in range(1, 6):   # shorter than any log interval
    bar.advance(step, 0.1, 0.1 * step)
  bar.evaluating()
  assert "rendering the held-out curve" in str(bar.bar)
  bar.resume()
  assert "rays/s=640" in str(bar.bar), str(bar.bar)
  for step in range(6, 11):
    bar.advance(step, 0.1, 0.1 * step)
  bar.close()
  last = _lines(capsys.readouterr().err)[-1]
  assert "10/10" in last and "rays/s=640" in last, last
