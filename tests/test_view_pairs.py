"""View pairs for the frequency criterion: projections, NDC inversion, and a
pixel baseline reached on analytic scenes of every kind."""
import numpy as np
import pytest

from halo_jax import camera
from halo_jax.frequency import view_pairs
from halo_jax.datasets import base
from halo_jax.datasets.base import Dataset, Views
from halo_jax.datasets.llff import NDCViews
from halo_jax.datasets.stanford_lf import LightFieldViews
from halo_jax.geometry import Geometry


def test_projection_inverts_pixel_rays():
  c2w = camera.spherical_camera(4.0, 30.0, 20.0)[None]
  h, w, f = 12, 16, 20.0
  o, d = camera.pixel_rays(c2w[0], h, w, f)
  pts = (o + 2.5 * d)[None]
  px = view_pairs.project(c2w, f, h, w, pts)[0]
  i, j = np.meshgrid(np.arange(w) + 0.5, np.arange(h) + 0.5, indexing="xy")
  np.testing.assert_allclose(px[..., 0], i, atol=1e-4)
  np.testing.assert_allclose(px[..., 1], j, atol=1e-4)


def test_ndc_depth_maps_back_onto_the_world_ray():
  c2w = np.eye(4, dtype=np.float32)[None]
  views = NDCViews(np.zeros((1, 6, 8, 3), np.float32), c2w, 10.0, ("a",))
  o, d = camera.pixel_rays(c2w[0], 6, 8, 10.0)
  for t_ndc in (0.1, 0.5, 0.9):
    render = {"depth": np.full((1, 6, 8), t_ndc, np.float32)}
    pts = view_pairs.world_points(views, render, ndc=True)[0]
    # on the pixel's world ray (the camera sits at the origin) ...
    cos = (pts * d).sum(-1) / np.linalg.norm(pts, axis=-1)
    np.testing.assert_allclose(cos, 1.0, atol=1e-5)
    # ... at the world depth NDC t stands for: from the near plane z = -1,
    # z_ndc = -1 + 2 t = 1 + 2 / z, so -z = 1 / (1 - t)
    np.testing.assert_allclose(-pts[..., 2], 1.0 / (1.0 - t_ndc), rtol=1e-4)


def _render_rays_sphere(o, d, t=None, radius=1.0):
  del t
  b = (o * d).sum(-1)
  disc = b ** 2 - ((o * o).sum(-1) - radius ** 2)
  hit = disc > 0
  depth = np.where(hit, -b - np.sqrt(np.maximum(disc, 0)), 0.0)
  rgb = np.repeat(hit[..., None], 3, -1).astype(np.float32)
  return {"rgb": rgb, "depth": depth.astype(np.float32), "acc": hit.astype(np.float32)}


def _train_views(n=6, h=40, w=40, focal=50.0, times=None):
  c2w = np.stack([camera.spherical_camera(4.0, 60.0 * i, 15.0 + 5 * i) for i in range(n)])
  return Views(np.zeros((n, h, w, 3), np.float32), c2w.astype(np.float32), focal,
               tuple(map(str, range(n))), times)


@pytest.mark.parametrize("dynamic", [False, True])
def test_orbit_pairs_reach_the_pixel_baseline(dynamic):
  times = np.linspace(0, 1, 6).astype(np.float32) if dynamic else None
  train = _train_views(times=times)
  ds = Dataset(train, train, 2.0, 6.0, 4.0,
               facts=base.ORBIT_TIME if dynamic else base.ORBIT)
  out = view_pairs.make(_render_rays_sphere, ds, num=4, size=32, shift_px=1.5, seed=0,
                        chunk=4096)
  assert out["kind"] == ("orbit_time" if dynamic else "orbit")
  assert out["a"].shape == (4, 32, 32, 3) and out["b"].shape == (4, 32, 32, 3)
  np.testing.assert_allclose(out["shift_px"], 1.5, rtol=0.03)
  assert np.all(out["steps"] > 0) and np.all(out["steps"] < 10)


def test_uv_pairs_move_by_the_closed_form_step():
  h, w, n = 20, 30, 4
  uv = np.array([[-1, -1], [1, -1], [-1, 1], [1, 1]], np.float32) * 0.5
  train = LightFieldViews(np.zeros((n, h, w, 3), np.float32), uv, tuple("abcd"))
  theta = 1.3
  ds = Dataset(train, train, 1.2, 1.4, 0.0, False, Geometry.TWO_PLANE, facts=base.UV_PLANE)
  tau = (theta - 1.2) / 0.2

  def render(o, d, t=None):
    del d, t
    shape = o.shape[:-1]
    return {"rgb": np.zeros((*shape, 3), np.float32), "depth": np.full(shape, tau, np.float32),
            "acc": np.ones(shape, np.float32)}

  out = view_pairs.make(render, ds, num=3, size=10, shift_px=0.5, seed=1, chunk=4096)
  assert out["kind"] == "uv" and out["a"].shape == (3, 10, 15, 3)
  # a point at angle theta moves cot(theta) in s per unit u; s spans 2 over w = 15 px
  want = 0.5 / (15 / 2.0 / np.tan(theta))
  np.testing.assert_allclose(out["steps"], want, rtol=1e-4)
  np.testing.assert_allclose(out["shift_px"], 0.5, rtol=1e-4)


def test_spiral_pairs_reach_the_pixel_baseline():
  rng = np.random.default_rng(0)
  n = 5
  c2w = np.repeat(np.eye(4, dtype=np.float32)[None], n, 0)
  c2w[:, :3, 3] = rng.normal(0, 0.5, (n, 3))
  train = NDCViews(np.zeros((n, 30, 40, 3), np.float32), c2w, 35.0, tuple(map(str, range(n))))
  ds = Dataset(train, train, 0.0, 1.0, 0.0, False, Geometry.NDC,
               depth_bounds=np.tile([[2.0, 8.0]], (n, 1)), facts=base.SPIRAL)

  def render(o, d, t=None):
    """A fronto-parallel wall at world z = -4, in NDC depth (camera near z = 0):
    z_ndc = 1 - 2 / 4 = 0.5 on the NDC ray o' + t d' from o'_z = -1."""
    del t
    t_ndc = (0.5 - o[..., 2]) / d[..., 2]
    shape = o.shape[:-1]
    return {"rgb": np.zeros((*shape, 3), np.float32), "depth": t_ndc.astype(np.float32),
            "acc": np.ones(shape, np.float32)}

  out = view_pairs.make(render, ds, num=4, size=24, shift_px=1.0, seed=0, chunk=4096)
  assert out["kind"] == "spiral" and out["a"].shape == (4, 24, 32, 3)
  np.testing.assert_allclose(out["shift_px"], 1.0, rtol=0.1)


def test_a_scene_kind_without_view_pairs_is_refused():
  train = _train_views()
  ds = Dataset(train, train, 2.0, 6.0, 4.0, facts=base.SceneFacts("", ("orbit",), "t"))
  with pytest.raises(ValueError, match="declares no view pairs"):
    view_pairs.make(_render_rays_sphere, ds, num=2, size=16, shift_px=1.0, seed=0, chunk=256)


def test_every_scene_kind_declares_known_pairs_and_paths():
  from halo_jax import datasets
  for name, spec in datasets.LOADERS.items():
    # '' where the frequency rule cannot run (a kind without a Lo-NeRF)
    assert spec.facts.pair_kind in view_pairs.PAIR_KINDS or spec.facts.pair_kind == "", name
    assert spec.facts.path_kinds and spec.facts.depth_units, name


def test_warping_b_onto_a_removes_what_the_camera_move_explains():
  """A light field of a plane at one EPI angle whose colour is linear in the
  plane's coordinate s': b resampled onto a is a (bilinear is exact on a
  linear image), away from the frame's edge, while b itself is shifted."""
  h, w, n, theta = 16, 24, 3, 1.2
  uv = np.array([[-1, -1], [1, -1], [-1, 1], [1, 1]], np.float32) * 0.5
  train = LightFieldViews(np.zeros((4, h, w, 3), np.float32), uv, tuple("abcd"))
  ds = Dataset(train, train, 1.1, 1.3, 0.0, False, Geometry.TWO_PLANE, facts=base.UV_PLANE)

  def render(o, d, t=None):
    del t
    s_plane = d[..., 0] + o[..., 0] / np.tan(theta)        # s' = s + u cot(theta)
    rgb = np.repeat((0.5 + 0.2 * s_plane)[..., None], 3, -1)
    shape = o.shape[:-1]
    return {"rgb": rgb.astype(np.float32), "acc": np.ones(shape, np.float32),
            "depth": np.full(shape, (theta - 1.1) / 0.2, np.float32)}

  out = view_pairs.make(render, ds, num=n, size=h, shift_px=2.0, seed=0, chunk=4096)
  inner = (slice(None), slice(None), slice(3, -3))
  assert np.abs(out["b"] - out["a"])[inner].max() > 0.01
  np.testing.assert_allclose(out["b_warped"][inner], out["a"][inner], atol=1e-5)
