"""L_unseen: the frustum test against a numpy projection, the loss's closed
form, and the term on a real run (halo+unseen)."""
import json
import os

import jax.numpy as jnp
import numpy as np
import pytest

from conftest import assert_trained, tiny_config
from halo_jax import camera, configure, losses, pipeline, protocol, visibility
from conftest import editable  # pylint: disable=g-import-not-at-top
from halo_jax.configure import finish  # pylint: disable=g-import-not-at-top


def _numpy_in_frustum(point, c2w, focal, width, height):
  """The same test written out with a plain inverse and a loop-free projection."""
  p = np.linalg.inv(c2w) @ np.append(point, 1.0)
  x, y, z = p[:3]
  if z >= 0:  # OpenGL: in front means negative z
    return False
  return abs(focal * x / -z) <= width / 2 and abs(focal * y / -z) <= height / 2


def test_seen_count_matches_a_numpy_projection():
  rng = np.random.default_rng(0)
  c2w = np.stack([camera.spherical_camera(4.0, az, el)
                  for az, el in ((0, 10), (90, 40), (200, 70), (300, 5))])
  points = rng.uniform(-4.5, 4.5, (2000, 3))
  focal, w, h = 60.0, 100, 80
  got = np.asarray(visibility.seen_count(jnp.asarray(points, jnp.float32),
                                         visibility.world_to_camera(jnp.asarray(c2w)),
                                         focal, w, h))
  want = np.array([sum(_numpy_in_frustum(p, c, focal, w, h) for c in c2w) for p in points])
  np.testing.assert_array_equal(got, want)
  assert 0 < (want == 0).mean() < 1 and (want >= 2).any()  # the draw covers every case


def test_the_centre_is_seen_by_every_camera_and_a_point_behind_one_by_none():
  c2w = np.stack([camera.spherical_camera(4.0, az, 20) for az in (0, 120, 240)])
  w2c = visibility.world_to_camera(jnp.asarray(c2w))
  behind = 1.5 * c2w[0, :3, 3]  # beyond camera 0, outside the others' narrow views
  count = visibility.seen_count(jnp.asarray([[0.0, 0.0, 0.0], behind]), w2c, 50.0, 40, 40)
  assert count.tolist() == [3, 0]


def test_unseen_density_is_the_mean_over_unseen_points_only():
  sigma = jnp.array([1.0, 2.0, 3.0, 10.0])
  unseen = jnp.array([True, False, True, False])
  np.testing.assert_allclose(float(losses.unseen_density(sigma, unseen)), 2.0)
  assert float(losses.unseen_density(sigma, jnp.zeros(4, bool))) == 0.0


def test_halo_unseen_is_halo_plus_one_term_on_both_nerfs_and_left_out_where_all_is_seen():
  from configs import llff, procedural
  halo = editable(procedural.get_config("spheres_8view_cpu"), "halo")
  ours = editable(procedural.get_config("spheres_8view_cpu"), "halo+unseen")
  assert (ours.lo.unseen.weight, ours.hi.unseen.weight) == (0.01, 0.01)
  ours.lo.unseen.weight = ours.hi.unseen.weight = 0.0
  ours.method = "halo"
  assert configure.finish(ours).to_dict() == halo.to_dict()  # steps from halo's table entries
  fern = editable(llff.get_config("fern_4view_cpu"), "halo+unseen")
  assert fern.lo.unseen.weight == fern.hi.unseen.weight == 0.0


@pytest.mark.slow
def test_l_unseen_lowers_lo_nerfs_density_where_no_camera_looks(config, scene_root, tmp_path):
  # The same Lo-NeRF run twice, the term on (weight 1) and effectively off
  # (weight 1e-9, so that its value is still logged): the unseen density
  # ends lower with it, and the photometric fit is not broken.
  c = tiny_config("halo+unseen")
  c.data.root = scene_root
  c.eval.lpips = False
  c.stages = "lo"
  c.lo.update(steps=120, log_every=5, lr_init=5e-3, lr_final=5e-3, fg_steps=4)
  ends, psnr = {}, {}
  for weight in (1.0, 1e-9):
    c.lo.unseen.update(num_points=512, bank_points=8192, weight=weight)
    wd = str(tmp_path / f"w{weight}")
    infos = pipeline.run(finish(c), wd)
    assert infos["lo"]["skipped"] == 0
    psnr[weight] = infos["lo"]["eval"]["psnr"]
    log = [json.loads(line) for line in open(os.path.join(wd, "metrics.jsonl"))]
    ends[weight] = [r["unseen"] for r in log if r.get("stage") == "lo" and "unseen" in r][-1]
  assert ends[1.0] < 0.5 * ends[1e-9]
  # the photometric fit is not broken: with the term on, Lo still fits its
  # training views better than a constant image, and the held-out PSNR is finite
  assert_trained(str(tmp_path / "w1.0"), "lo", c)
  assert np.isfinite(psnr[1.0])
