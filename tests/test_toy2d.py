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
def test_lo_interpolates_smoothly_and_only_hi_reaches_the_board():
  """The toy's two claims (docs/frequency.md), at test size: with 8 pixels per
  unit Lo's P.E. interpolates the image to 4x with a fraction of Hi's error;
  with 32 (the image on [-1, 1]) Lo's highest frequency is below the
  checkerboard's, so only Hi continues it into the masked corner."""
  res, images = toy2d.run(steps=400, seeds=1, width=64, depth=3, unit=8.0)
  assert res["interp_mse"]["lo"] < 0.5 * res["interp_mse"]["hi"]
  assert images["hi_interp"].shape == (256, 256, 3)
  assert images["mask"].sum() == 64 * 64 - 24 * 24
  res, _ = toy2d.run(steps=400, seeds=1, width=64, depth=3, unit=32.0)
  assert res["extrap_mse"]["hi"] < 0.25 * res["extrap_mse"]["lo"]
  for key in ("interp_mse", "extrap_mse", "train_mse"):
    assert set(res[key]) == {"lo", "hi"}
