"""halo_jax/image_files.py: images round-trip, and a write to a full disk
raises once and leaves nothing open to fail again at exit."""
import gc
import os
import sys

import imageio.v3 as iio
import numpy as np
import pytest

from halo_jax import image_files


def test_round_trip(tmp_path):
  img = np.random.default_rng(0).integers(0, 256, (7, 5, 3), dtype=np.uint8)
  path = str(tmp_path / "a.png")
  image_files.write(path, img)
  np.testing.assert_array_equal(iio.imread(path), img)
  frames = np.stack([img, 255 - img])
  image_files.write(str(tmp_path / "a.gif"), frames, duration=100, loop=0)
  assert iio.imread(str(tmp_path / "a.gif"), index=None).shape[0] == 2


@pytest.mark.skipif(not os.path.exists("/dev/full"), reason="needs /dev/full")
def test_a_full_disk_raises_once_and_leaves_nothing_open():
  unraisable = []
  hook = sys.unraisablehook
  sys.unraisablehook = unraisable.append
  try:
    with pytest.raises(OSError):  # /dev/full: every write fails with ENOSPC
      image_files.write("/dev/full", np.zeros((64, 64, 3), np.uint8), extension=".png")
    gc.collect()
  finally:
    sys.unraisablehook = hook
  assert not unraisable, [u.exc_value for u in unraisable]
