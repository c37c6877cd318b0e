"""Two-plane light fields: EPI alignment against ray geometry, the alpha
schedule, the Stanford loader, and smoke runs of the joint and baseline stages."""
import functools
import json
import os

import imageio.v3 as iio
import jax
import jax.numpy as jnp
import numpy as np
import pytest

from conftest import SHARED_DATA
from halo_jax import configure, datasets, lightfield, pipeline, registry, render
from halo_jax.datasets import stanford_lf
from halo_jax.stages import base, batches, epi, radiance, terms
from conftest import editable  # pylint: disable=g-import-not-at-top
from halo_jax.configure import finish  # pylint: disable=g-import-not-at-top

KNIGHTS = os.path.join(SHARED_DATA, "stanford_lf", "knights")


def two_plane_ray_hits(u, point):
  """Where the ray from camera (u, 0) on the plane z=0 through a 3D point
  (X, Z) meets the image plane z=1: s = u + (X - u) / Z."""
  x, z = point
  return u + (x - u) / z


def test_epi_alignment_matches_ray_geometry():
  # A 3D point (X, Y, Z) seen from two cameras: the image-plane hits differ,
  # the aligned (s', t', theta) must not, and s' is what the camera at
  # (u*, v*) = (0, 0) sees. Geometry: ds/du = 1 - 1/Z, so delta = 1/Z - 1.
  X, Y, Z = 0.3, -0.2, 1.7
  delta = 1.0 / Z - 1.0
  theta = np.arctan2(1.0, delta)
  cams = np.array([[-0.5, -0.5], [0.5, 0.25]])
  st = np.stack([[two_plane_ray_hits(u, (X, Z)), two_plane_ray_hits(v, (Y, Z))]
                 for u, v in cams])
  assert not np.allclose(st[0], st[1])
  pts = lightfield.epi_points(jnp.asarray(cams), jnp.asarray(st), jnp.full((2,), theta))
  np.testing.assert_allclose(pts[0], pts[1], atol=1e-6)
  np.testing.assert_allclose(pts[0, :2], [X / Z, Y / Z], atol=1e-6)  # the centre camera's view
  np.testing.assert_allclose(pts[0, 2], theta, atol=1e-7)


def test_alpha_schedule_values():
  got = [float(lightfield.alpha_schedule(s, 20000, 0.5)) for s in (0, 5000, 10000, 20000, 40000)]
  np.testing.assert_allclose(got, [1.0, 0.875, 0.75, 0.5, 0.5])


def test_consist_targets_on_a_diffuse_ray_with_one_surface():
  # Window [0.2, 0.8] in tau, 6 samples: a thin surface in the second interval
  # (0.3-0.4) over a faint haze everywhere. The mode is that interval's
  # midpoint; the expected tau is pulled towards the window's centre.
  edges = jnp.linspace(0.2, 0.8, 7)
  sigma = jnp.array([0.5, 8.0, 0.5, 0.5, 0.5, 0.5])
  out = render.volume_render(sigma, jnp.zeros((6, 3)), edges, white_background=False)
  weights = np.asarray(out["weights"])
  mids = 0.25 + 0.1 * np.arange(6)
  np.testing.assert_allclose(epi.consist_target(out, "max_weight"), 0.35, atol=1e-6)
  np.testing.assert_allclose(epi.consist_target(out, "expected"),
                             (weights * mids).sum() / weights.sum(), rtol=1e-5)
  assert float(epi.consist_target(out, "expected")) > 0.36
  with pytest.raises(ValueError, match="joint.target"):
    epi.consist_target(out, "median")


def test_theta_bounds():
  # zero disparity is theta = pi/2; larger disparity (nearer) is smaller theta
  n, f = stanford_lf.theta_bounds((-1.0, 2.0), 256, 17)
  assert n < np.pi / 2 < f
  np.testing.assert_allclose(1 / np.tan(n), 2.0 * (2 / 256) * 8, rtol=1e-6)
  np.testing.assert_allclose(1 / np.tan(f), -1.0 * (2 / 256) * 8, rtol=1e-6)
  with pytest.raises(datasets.DataError, match="min < max"):
    stanford_lf.theta_bounds((1.0, 1.0), 256, 17)


def write_light_field(root, grid=5, size=16, disparity_px=0.5):
  """A fronto-parallel textured plane seen from a grid x grid camera array:
  view (r, c) shifts the texture by disparity_px pixels per grid step."""
  os.makedirs(root, exist_ok=True)
  x = np.arange(size)
  centre = (grid - 1) / 2
  for r in range(grid):
    for c in range(grid):
      sx, sy = np.broadcast_arrays(x[None, :] - (c - centre) * disparity_px,
                                   x[:, None] - (r - centre) * disparity_px)
      img = np.stack([0.5 + 0.4 * np.sin(sx * 0.7), 0.5 + 0.4 * np.cos(sy * 0.5),
                      0.5 + 0.2 * np.sin((sx + sy) * 0.3)], -1)
      iio.imwrite(os.path.join(root, f"out_{r:02d}_{c:02d}_0.0_0.0.png"),
                  (img * 255).round().astype(np.uint8))
  return root


def lf_config(root):
  from configs import stanford_lf as cfg_lf
  c = editable(cfg_lf.get_config("scene_cpu"), "halo")
  c.data.update(root=root, train_views="00_00,00_04,04_00,04_04", test_views="02_02,01_03",
                disparity_px=(-1.0, 1.0), grid_signs=(1.0, 1.0))
  c.protocol, c.budget_s = "steps", 0.0
  c.eval.update(chunk=256, curve_views=1, lpips=False)
  c.hi.model.update(width=16, depth=2)
  c.hi.joint.model.update(width=16, depth=2)
  c.hi.sampler.num_samples = 8
  c.hi.update(batch_rays=64, steps=6, checkpoint_every=3, log_every=2, eval_every=3)
  c.hi.joint.update(alpha_steps=4, alpha_final=0.25)
  return c


def test_loader_coordinates(tmp_path):
  root = write_light_field(str(tmp_path / "lf"))
  ds = datasets.load(lf_config(root).data)
  np.testing.assert_allclose(ds.train.uv, [[-1, -1], [1, -1], [-1, 1], [1, 1]])
  np.testing.assert_allclose(ds.test.uv, [[0, 0], [0.5, -0.5]])
  o, d = ds.test.rays()
  assert o.shape == d.shape == (2, 16, 16, 3)
  np.testing.assert_allclose(d[0, 0, 0], [-15 / 16, -15 / 16, 1])
  assert ds.near < np.pi / 2 < ds.far


@pytest.mark.parametrize("change, message", [
    (dict(root="/nonexistent/lf"), r"data.root='/nonexistent/lf' does not exist: set HALO_DATA"),
    (dict(test_views="09_09"), r"views \['09_09'\] named in the config are not in the grid"),
])
def test_bad_light_field_input(tmp_path, change, message):
  root = write_light_field(str(tmp_path / "lf"))
  c = lf_config(root)
  c.data.update(**change)
  with pytest.raises(datasets.DataError, match=message):
    datasets.load(c.data)


def test_other_size_view_named(tmp_path):
  root = write_light_field(str(tmp_path / "lf"))
  iio.imwrite(os.path.join(root, "out_04_04_0.0_0.0.png"), np.zeros((8, 8, 3), np.uint8))
  with pytest.raises(datasets.DataError, match="out_04_04_0.0_0.0.png: size 8x8"):
    datasets.load(lf_config(root).data)


@pytest.mark.parametrize("baseline,full_range,random_background",
                         [(False, 0.0, False), (False, 0.5, True), (True, 0.0, False)])
@pytest.mark.slow
def test_joint_and_baseline_smoke(tmp_path, baseline, full_range, random_background):
  from halo_jax.methods import base, nerf_tuned
  root = write_light_field(str(tmp_path / "lf"))
  c = lf_config(root)
  c.hi.joint.full_range = full_range
  c.hi.random_background = random_background
  if baseline:  # nerf_tuned's table on the light-field stage
    base.write_derived(c, c, base.write_values(c, nerf_tuned.METHOD.table("two_plane")))
  assert pipeline.needed(c) == ("hi",)
  wd = str(tmp_path / "run")
  infos = pipeline.run(finish(c), wd)
  # six steps learn nothing here (200 do not either: the collapse check
  # stops them); what the smoke run claims is that its figure is its render's:
  # each view's PSNR is that of the written [truth | render | depth] panel
  for name, view in infos["hi"]["eval"]["per_view"].items():
    panel = iio.imread(os.path.join(wd, "hi", "eval", f"{name}.png")).astype(np.float64) / 255
    truth, render_rgb, _ = np.split(panel[..., :3], 3, axis=1)
    psnr = -10 * np.log10(np.mean((render_rgb - truth) ** 2))
    assert view["psnr"] == pytest.approx(psnr, abs=0.05)
  log = [json.loads(l) for l in open(os.path.join(wd, "metrics.jsonl"))]
  train = [r for r in log if "loss" in r]
  assert all(np.isfinite(r["loss"]) for r in train)
  if not baseline:
    # logged at steps 2, 4, 6 from the step counts 1, 3, 5 the loss saw
    assert [r["alpha"] for r in train] == pytest.approx([0.8125, 0.4375, 0.25])
    assert all(r["consist"] >= 0 for r in train)
  else:
    assert all("consist" not in r for r in train)


def joint_loss_grads(c, setting, values):
  """epi.loss_fn's (aux, grads) at key 3, step 2 for each value of
  c.hi.joint.<setting>, the fields built anew for each (a colour head adds
  parameters; the others start equal). Returns (dataset, data, {value: (aux,
  grads)})."""
  ds = datasets.load(c.data)
  out = {}
  for v in values:
    c.hi.joint[setting] = v
    ctx = base.StageContext(c, "hi", ds, "", {})
    data = jax.device_put(terms.stage_data(ctx, c.hi, batches.pixels_of(ds.train, None),
                                           terms.active_terms(c.hi)))
    model, ray_model = epi.models_from_config(c, "hi")
    loss = functools.partial(epi.loss_fn, model=model, ray_model=ray_model, cfg=c.hi,
                             theta_n=ds.near, theta_f=ds.far)
    (_, aux), grads = jax.value_and_grad(loss, has_aux=True)(
        epi.init_params(model, ray_model, 0), data, jax.random.PRNGKey(3), 2)
    out[v] = aux, grads
  return ds, data, out


def assert_leaves_equal(a, b):
  for x, y in zip(jax.tree_util.tree_leaves(a), jax.tree_util.tree_leaves(b), strict=True):
    np.testing.assert_array_equal(x, y)


def max_leaf_difference(a, b):
  return max(float(jnp.max(jnp.abs(x - y)))
             for x, y in zip(jax.tree_util.tree_leaves(a), jax.tree_util.tree_leaves(b),
                             strict=True))


@pytest.mark.slow
def test_random_rays_train_the_ray_field_only(tmp_path):
  """L_consist on random rays between the cameras moves the ray field's
  gradient and leaves the radiance field's exactly as it was."""
  c = lf_config(write_light_field(str(tmp_path / "lf")))
  _, data, out = joint_loss_grads(c, "random_rays", (0, 16))
  # (u, v) spans the corner cameras; (s, t) the 16-pixel centres, +-15/16
  edge = 15 / 16
  np.testing.assert_allclose(data.terms["lf_random"],
                             [[-1, -1, -edge, -edge], [1, 1, edge, edge]], atol=1e-6)
  assert float(out[16][0]["consist_random"]) > 0
  assert_leaves_equal(out[0][1]["nerf"], out[16][1]["nerf"])
  assert max_leaf_difference(out[0][1]["ray"], out[16][1]["ray"]) > 1e-6


@pytest.mark.slow
def test_ray_field_colour_head_trains_the_ray_field_only(tmp_path):
  """The ray field's colour loss (on the pixels and, on random rays, towards
  the radiance field's colour) leaves the radiance field's gradient exactly
  as without a colour head, and changes the ray field's trunk gradient."""
  c = lf_config(write_light_field(str(tmp_path / "lf")))
  c.hi.joint.random_rays = 16
  _, _, out = joint_loss_grads(c, "color_weight", (0.0, 1.0))
  (aux0, grads0), (aux1, grads1) = out[0.0], out[1.0]
  assert set(grads1["ray"]) == set(grads0["ray"]) | {"color_hidden", "color"}
  assert 0 < float(aux1["ray_psnr"]) < 60 and float(aux1["color_random"]) > 0
  assert float(aux1["consist"]) == pytest.approx(float(aux0["consist"]))
  assert_leaves_equal(grads0["nerf"], grads1["nerf"])
  assert max_leaf_difference(grads0["ray"]["trunk"], grads1["ray"]["trunk"]) > 1e-6
  # the colour head's output: one colour per ray, inside [0, 1] up to the margin
  model, ray_model = epi.models_from_config(c, "hi")
  assert ray_model.color
  params = epi.init_params(model, ray_model, 0)
  _, rgb = ray_model.apply({"params": params["ray"]}, jnp.zeros((5, 7, 4)))
  assert rgb.shape == (5, 7, 3) and float(rgb.min()) >= -1e-3 and float(rgb.max()) <= 1 + 1e-3


@pytest.mark.slow
def test_nerf_consist_weight_trains_the_radiance_field_only(tmp_path):
  """joint.nerf_consist_weight moves the radiance field's gradient by the
  gradient of w * mean (tau_ray - tau_nerf)^2 with tau_ray fixed, and leaves
  the ray field's exactly as it was."""
  c = lf_config(write_light_field(str(tmp_path / "lf")))
  ds, data, out = joint_loss_grads(c, "nerf_consist_weight", (0.0, 0.5))
  grads0, grads1 = out[0.0][1], out[0.5][1]
  assert_leaves_equal(grads0["ray"], grads1["ray"])
  # the difference is the pull's own gradient, computed here independently
  # from a render with the same key (jax.random.split as _loss_fn splits it)
  model, ray_model = epi.models_from_config(c, "hi")
  params = epi.init_params(model, ray_model, 0)
  def pull(nerf):
    k_idx, k_ren = jax.random.split(jax.random.PRNGKey(3))
    idx = jax.random.randint(k_idx, (c.hi.batch_rays,), 0, data.pixels.rgb.shape[0])
    keys = jax.random.split(k_ren, c.hi.batch_rays)
    out = epi.render_rays(model, ray_model, c.hi, dict(params, nerf=nerf),
                          data.pixels.rays.take(idx), keys, radiance.joint_window(c.hi, 2),
                          theta_n=ds.near, theta_f=ds.far, randomized=True,
                          noise=c.hi.density_noise)
    tau = render.normalized_depth(out["depth"], out["acc"])
    return 0.5 * jnp.mean((jax.lax.stop_gradient(out["tau_ray"]) - tau) ** 2)
  expected = jax.grad(pull)(params["nerf"])
  for a, b, e in zip(jax.tree_util.tree_leaves(grads0["nerf"]),
                     jax.tree_util.tree_leaves(grads1["nerf"]),
                     jax.tree_util.tree_leaves(expected), strict=True):
    np.testing.assert_allclose(b - a, e, rtol=1e-3, atol=1e-7)
  assert max(float(jnp.max(jnp.abs(e))) for e in jax.tree_util.tree_leaves(expected)) > 1e-7


@pytest.mark.parametrize("uv_features", [0, 4])
def test_view_input_reaches_only_the_colour(uv_features):
  """(u, v) never reaches the density; without Fourier features it reaches
  the colour layer as raw coordinates, so that layer is affine in (u, v)."""
  from halo_jax import models
  model = models.EPINeRF(st_features=8, theta_features=4, uv_features=uv_features, width=16,
                         depth=2, skips=())
  pts = jax.random.uniform(jax.random.PRNGKey(0), (32, 3))
  uvs = [jnp.full((32, 2), -0.5), jnp.full((32, 2), 0.5), jnp.zeros((32, 2))]
  params = model.init(jax.random.PRNGKey(1), pts, uvs[0])
  outs = [model.apply(params, pts, uv, capture_intermediates=True) for uv in uvs]
  for (sigma, _), _ in outs[1:]:
    np.testing.assert_array_equal(sigma, outs[0][0][0])
  view = [o[1]["intermediates"]["view"]["__call__"][0] for o in outs]
  midpoint_gap = float(jnp.max(jnp.abs(view[2] - (view[0] + view[1]) / 2)))
  assert float(jnp.max(jnp.abs(view[0] - view[1]))) > 1e-3
  if uv_features:
    assert midpoint_gap > 1e-3
  else:
    assert midpoint_gap < 1e-5


def test_ray_field_uv_std_rescales_only_the_uv_rows():
  from halo_jax import encoding, ray_fields
  base = ray_fields.ray_field_matrix(0, 16, 4.0)
  np.testing.assert_array_equal(base, encoding.fourier_matrix(3, 4, 16, 4.0))
  mixed = ray_fields.ray_field_matrix(0, 16, 4.0, uv_std=0.5)
  np.testing.assert_allclose(mixed[:2], base[:2] / 8.0, rtol=1e-6)   # (u, v): std 0.5
  np.testing.assert_array_equal(mixed[2:], base[2:])                 # (s, t): std 4
  # the model reads that matrix: its first layer sees the rescaled features
  field = ray_fields.EPIRayField(std=4.0, uv_std=0.5, num_features=16, width=8, depth=1)
  rays = jax.random.uniform(jax.random.PRNGKey(0), (8, 4), minval=-1, maxval=1)
  params = field.init(jax.random.PRNGKey(1), rays)
  _, state = field.apply(params, rays, capture_intermediates=True)
  dense = state["intermediates"]["trunk"]["dense_0"]["__call__"][0]
  feats = encoding.gaussian_fourier_features(rays, mixed)
  kernel = params["params"]["trunk"]["dense_0"]
  np.testing.assert_allclose(dense, feats @ kernel["kernel"] + kernel["bias"], atol=1e-5)


def test_random_background_costs_only_transparency():
  keys = jax.random.split(jax.random.PRNGKey(0), 4096)
  rgb = jnp.full((4096, 3), 0.25)
  # opaque rays keep their colour exactly
  np.testing.assert_array_equal(epi.with_random_background(rgb, jnp.ones(4096), keys), rgb)
  # empty rays show a uniform colour: mean 1/2, variance 1/12 per channel
  empty = np.asarray(epi.with_random_background(jnp.zeros((4096, 3)), jnp.zeros(4096), keys))
  assert empty.min() >= 0 and empty.max() < 1
  np.testing.assert_allclose(empty.mean(0), 0.5, atol=0.02)
  np.testing.assert_allclose(empty.var(0), 1 / 12, atol=0.005)
  # each ray's colour comes from its own key: the halves draw as the whole
  half = epi.with_random_background(jnp.zeros((2048, 3)), jnp.zeros(2048), keys[2048:])
  np.testing.assert_array_equal(half, empty[2048:])


@pytest.mark.skipif(not os.path.exists(KNIGHTS), reason="shared Stanford data absent")
def test_knights_views_and_bounds():
  from configs import stanford_lf as cfg_lf
  c = editable(cfg_lf.get_config("knights_cpu"), "halo")
  c.data.root = KNIGHTS
  ds = datasets.load(c.data)
  assert ds.train.names == ("04_04", "04_12", "12_04", "12_12")
  # grid_signs (-1, -1): u, v fall as the column and row grow
  np.testing.assert_allclose(ds.train.uv, [[0.5, 0.5], [-0.5, 0.5], [0.5, -0.5], [-0.5, -0.5]])
  assert ds.test.images.shape == (4, 256, 256, 3)
  # the bounds, in closed form: a disparity of p px per grid step over 16 grid
  # steps across u in [-1, 1] of a 256-px-wide image is an EPI slope of
  # p * (2 / 256) / (2 / 16); theta = atan2(1, slope), the nearest point
  # (the largest disparity) at the smallest theta
  lo_px, hi_px = c.data.disparity_px
  assert ds.near == pytest.approx(np.arctan2(1.0, hi_px * 16 / 256), abs=1e-12)
  assert ds.far == pytest.approx(np.arctan2(1.0, lo_px * 16 / 256), abs=1e-12)
  assert 0 < ds.near < np.pi / 2 < ds.far < np.pi


def _box(x, r):
  """Mean over (2r+1)^2 windows (edges clamped), via cumulative sums."""
  p = np.pad(x, r, mode="edge")
  c = np.pad(p.cumsum(0).cumsum(1), ((1, 0), (1, 0)))
  k = 2 * r + 1
  return (c[k:, k:] - c[:-k, k:] - c[k:, :-k] + c[:-k, :-k]) / k ** 2


@pytest.mark.skipif(not os.path.exists(KNIGHTS), reason="shared Stanford data absent")
def test_knights_disparity_sign_and_range():
  # Photo-consistency checks the convention independently of the loader's
  # maths: for each candidate delta, view (8,10) is shifted by where the
  # model says a point of that delta lands. The best delta per textured
  # pixel must fall inside the configured [theta_n, theta_f] for most
  # pixels, and the knights, which stand in front of the wall, must get a
  # larger delta (rendering composites from the largest delta, the nearest).
  from configs import stanford_lf as cfg_lf
  c = editable(cfg_lf.get_config("knights_cpu"), "halo")
  c.data.update(root=KNIGHTS, test_views="08_06,08_10")
  ds = datasets.load(c.data)
  a, b = ds.test.images[0].mean(-1), ds.test.images[1].mean(-1)
  du = float(ds.test.uv[1, 0] - ds.test.uv[0, 0])       # 0.5
  w = a.shape[1]
  deltas = np.linspace(-0.3, 0.3, 121)
  costs = []
  for delta in deltas:
    # s_b = s_a - du * delta  ->  shift in pixels = -du * delta * w / 2
    shift = -du * delta * w / 2
    x = np.arange(w) + shift
    x0 = np.clip(np.floor(x).astype(int), 0, w - 2)
    f = np.clip(x - x0, 0, 1)
    warped = b[:, x0] * (1 - f) + b[:, x0 + 1] * f      # b sampled where a's points land
    costs.append(_box(np.abs(a - warped), 5))
  best_all = deltas[np.argmin(np.stack(costs), 0)]
  assert np.median(best_all[110:200, 30:110]) > np.median(best_all[10:60, 40:220])  # knights > wall
  best = best_all[20:-20, 40:-40]
  gy, gx = np.gradient(a)
  textured = np.hypot(gx, gy)[20:-20, 40:-40]
  best = best[textured > np.percentile(textured, 80)]
  lo_delta, hi_delta = 1 / np.tan(ds.far), 1 / np.tan(ds.near)
  inside = np.mean((best >= lo_delta - 0.01) & (best <= hi_delta + 0.01))
  assert inside > 0.9, (inside, np.percentile(best, [5, 50, 95]), lo_delta, hi_delta)


@pytest.mark.slow
def test_full_range_keeps_the_sample_count_and_rejects_an_empty_window():
  from configs import stanford_lf as cfg_lf
  c = editable(cfg_lf.get_config("scene_cpu"), "halo")
  c.hi.sampler.num_samples = 8
  c.hi.joint.full_range = 0.5
  model, ray_model = epi.models_from_config(c, "hi")
  params = epi.init_params(model, ray_model, 0)
  rays = epi.two_plane_rays(jnp.zeros((5, 2)), jnp.linspace(-1, 1, 10).reshape(5, 2))
  keys = jax.random.split(jax.random.PRNGKey(0), 5)
  render_fn = functools.partial(epi.render_rays, model, ray_model, c.hi, params, rays, keys,
                                0.1, theta_n=1.0, theta_f=2.0, randomized=True)
  assert render_fn()["weights"].shape == (5, 8)
  c.hi.joint.full_range = 0.9
  with pytest.raises(ValueError, match="full_range"):
    render_fn()
  with pytest.raises(registry.ConfigError, match="hi.joint.full_range=0.9"):
    epi.check(c, "hi", datasets.spec_of(c.data))
