"""The 2D toy (experiments/toy2d.py): coordinates and a short run."""
import numpy as np
import pytest

from experiments import toy2d


def test_upsampled_grid_box_filters_to_the_training_grid():
  g, up = toy2d.grid(8, 1, 4.0), toy2d.grid(8, 4, 4.0)
  np.testing.assert_allclose(up.reshape(8, 4, 8, 4, 2).mean((1, 3)), g, atol=1e-6)
  # unit = size / 2 puts the image on [-1, 1].
  assert -1 < g.min() < -0.8 and 0.8 < g.max() < 1


@pytest.mark.slow
def test_short_run_reports_both_fields_and_tasks():
  res, images = toy2d.run(steps=20, seeds=1, width=16, depth=2)
  for key in ("interp_mse", "extrap_mse", "train_mse"):
    assert set(res[key]) == {"lo", "hi"}
    assert all(np.isfinite(v) and v >= 0 for v in res[key].values())
  assert images["hi_interp"].shape == (256, 256, 3)
  assert images["mask"].sum() == 64 * 64 - 24 * 24
