"""Lo-NeRF's foreground start (stages/batches.py): which pixels are
foreground, and the share of each early batch drawn from them."""
import jax
import numpy as np

from halo_jax.stages import batches


def test_foreground_pixels():
  rgb = np.ones((6, 3), np.float32)
  rgb[1] = [0.2, 0.3, 0.4]
  rgb[4] = [1.0, 0.9, 1.0]      # 0.1 off white in one channel: foreground
  rgb[5] = [0.97, 1.0, 1.0]     # within the threshold: background
  np.testing.assert_array_equal(batches.foreground_pixels(rgb, 1.0), [1, 4])
  # nothing but background: every pixel, so drawing from it cannot fail
  np.testing.assert_array_equal(batches.foreground_pixels(np.ones((3, 3)), 1.0), [0, 1, 2])


def test_early_batches_take_their_share_from_the_foreground():
  n, h, w = 2, 8, 8
  rgb = np.ones((n * h * w, 3), np.float32)
  fg = np.array([5, 77, 100])
  rgb[fg] = 0.3
  index = batches.index_data(n, h, w, 0.5)
  index["fg_idx"] = batches.foreground_pixels(rgb, 1.0)
  index = jax.device_put(index)
  keys = jax.random.split(jax.random.PRNGKey(0), 2)
  draw = jax.jit(lambda step: batches.draw(keys[0], keys[1], step, n * h * w, 64, index, 0,
                                           False, 50, 0.5))
  early, late = np.asarray(draw(3)), np.asarray(draw(50))
  assert np.isin(early[:32], fg).all()                       # the first half: foreground
  assert not np.isin(early[32:], fg).all()                   # the rest: all pixels
  np.testing.assert_array_equal(late, np.asarray(batches.draw(keys[0], keys[1], 50, n * h * w,
                                                              64, index, 0)))
