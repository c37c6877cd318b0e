"""The authors' light-field pieces (methods/halo_authors.py) against numpy
transcriptions of their code (lsongx/halo, static/vcnerf: NormalEmbedder,
EPINeLFUvSt's sampler, NeLFEPIField's layer sizes) on fixed inputs."""
import math
import os

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from conftest import editable, resolved  # pylint: disable=g-import-not-at-top

from conftest import SHARED_DATA
from halo_jax import configure, encoding, lightfield, protocol, ray_fields, samplers
from halo_jax.datasets import llff
from halo_jax.configure import finish  # pylint: disable=g-import-not-at-top


def _their_normal_embedder(inputs, freqs):
  """NormalEmbedder.forward with include_input=False, scale 1, shift 0: for
  each frequency, sin then cos of inputs * f (inputs [N, D])."""
  embeds = []
  for f in freqs:
    for func in (np.sin, np.cos):
      embeds.append(func(inputs * f))
  return np.concatenate(embeds, -1)


@pytest.mark.parametrize("span", [1.0, 0.35])
def test_axis_features_are_their_normal_embedder(span):
  # Their coordinate spans `span` units where ours spans 2 (centred), their
  # frequencies are radians per their unit: f = 4 pi b / span for our b.
  # (An offset of their coordinate is a phase, which the first layer absorbs.)
  rng = np.random.default_rng(0)
  ours_x = rng.uniform(-1, 1, (7, 2)).astype(np.float32)
  b = encoding.axis_frequencies(3, 10, 5.09)
  theirs = _their_normal_embedder(ours_x.astype(np.float64) * span / 2,
                                  b.astype(np.float64) * 4 * np.pi / span)
  ours = np.asarray(encoding.axis_fourier_features(jnp.asarray(ours_x), b))
  assert ours.shape == (7, 40)
  np.testing.assert_allclose(ours, theirs, atol=2e-5)


def test_axis_frequencies_are_sorted_half_normal():
  f = encoding.axis_frequencies(0, 200000, 2.0)
  assert np.all(f >= 0) and np.all(np.diff(f) >= 0)
  # E|N(0, s^2)| = s sqrt(2 / pi)
  assert abs(f.mean() - 2.0 * np.sqrt(2 / np.pi)) < 0.01
  # keeping the lowest of a larger draw: the first few of the same sorted draw
  np.testing.assert_array_equal(encoding.axis_frequencies(1, 1, 16.0, num_drawn=10),
                                encoding.axis_frequencies(1, 10, 16.0)[:1])


def _their_sampler(nelf_epi, near, far, it, converge_iter, converge_range, sample_num,
                   rand_base, t_rand):
  """EPINeLFUvSt.update_sample_near_far + get_epi_sample(perturb=True) for one
  ray, with the uniforms given; returns the samples and their dist."""
  if it > converge_iter:
    percent = converge_range
  else:
    progress = it / converge_iter
    percent = (1 - progress) + converge_range * progress
  sample_near = nelf_epi - percent * (far - near) / 2
  sample_near = near if sample_near < near else sample_near
  sample_near = sample_near * percent + (1 - percent) * near
  sample_far = nelf_epi + percent * (far - near) / 2
  sample_far = far if sample_far > far else sample_far
  sample_far = sample_far * percent + (1 - percent) * far
  running = int(sample_num * percent / 2)
  base = np.linspace(0, 1, running)
  pred = rand_base[:running] * (sample_far - sample_near) + sample_near
  s = np.sort(np.concatenate([base, pred]))
  mids = 0.5 * (s[1:] + s[:-1])
  upper = np.concatenate([mids, s[-1:]])
  lower = np.concatenate([s[:1], mids])
  s = lower + (upper - lower) * t_rand[:2 * running]
  dist = s[1:] - s[:-1]
  return s, np.concatenate([dist, dist[-1:]]), percent


@pytest.mark.parametrize("guide, it", [(0.5, 0), (0.1, 5000), (0.93, 20000), (0.4, 30000)])
def test_blended_sampler_is_theirs(guide, it):
  # their raw range [0, 1] is our tau range at near 0, far 1
  rng = np.random.default_rng(it)
  rand_base, t_rand = rng.uniform(size=64), rng.uniform(size=128)
  s, dist, percent = _their_sampler(guide, 0.0, 1.0, it, 20000, 0.5, 128, rand_base, t_rand)
  width = float(lightfield.alpha_schedule(it, 20000, 0.5))
  assert width == pytest.approx(percent, abs=1e-6)
  half = len(s) // 2
  edges = np.asarray(samplers.blended_edges_of(
      jnp.asarray(rand_base[:half], jnp.float32), jnp.asarray(t_rand[:2 * half], jnp.float32),
      guide, 0.0, 1.0, width, half))
  np.testing.assert_allclose(edges[:-1], s, atol=1e-6)       # their points: our left edges
  np.testing.assert_allclose(np.diff(edges), dist, atol=1e-6)  # their dist: our lengths


def test_blended_window_narrows_around_the_guide_and_keeps_the_range():
  lo, hi = samplers.blended_window(jnp.array([0.0, 0.5, 1.0]), 0.0, 1.0, 1.0)
  np.testing.assert_allclose(lo, [0.0, 0.0, 0.5])
  np.testing.assert_allclose(hi, [0.5, 1.0, 1.0])
  lo, hi = samplers.blended_window(jnp.array(0.5), 0.0, 1.0, 0.5)
  # half-width 0.25 around 0.5, then blended halfway to the ends
  assert (float(lo), float(hi)) == pytest.approx((0.125, 0.875))


def test_blended_eval_edges_are_deterministic_and_sorted():
  a = samplers.blended_edges(jax.random.PRNGKey(0), 0.3, 0.0, 1.0, 0.5, 16, 8, False)
  b = samplers.blended_edges(jax.random.PRNGKey(1), 0.3, 0.0, 1.0, 0.5, 16, 8, False)
  np.testing.assert_array_equal(a, b)
  assert a.shape == (17,) and np.all(np.diff(np.asarray(a)) >= 0)


def _their_nelf_field_params(layers, hid, emb, color_uv):
  """NeLFEPIField's parameter count (fc0..fc{layers-1}, skip at layers // 2,
  nelf_epi_fc, nelf_epi_out, color_fc, color_out)."""
  count = 2 * emb * hid + hid
  for i in range(1, layers):
    count += ((hid + 2 * emb) if i == layers // 2 else hid) * hid + hid
  count += hid * hid + hid + hid + 1
  count += (hid + color_uv) * hid + hid + hid * 3 + 3
  return count


def test_nelf_ray_field_has_their_layers():
  model = ray_fields.NeLFRayField(width=256, depth=8, skips=(4,), num_features=10)
  params = model.init(jax.random.PRNGKey(0), jnp.zeros((1, 4)))["params"]
  count = sum(x.size for x in jax.tree_util.tree_leaves(params))
  # their knights config: emb_dims = color_uv_dims = 2 * 2 * 10
  assert count == _their_nelf_field_params(8, 256, 40, 40)
  tau, rgb = model.apply({"params": params}, jnp.zeros((5, 4)))
  assert tau.shape == (5,) and rgb.shape == (5, 3)


@pytest.mark.parametrize("w", [1.0, 0.5, 0.1, 0.0])
def test_blended_window_length_is_one_minus_w_plus_w_squared(w):
  # away from the range ends: w * (w R) + (1 - w) R of the range R
  lo, hi = samplers.blended_window(jnp.array(3.0), 1.0, 5.0, w)
  assert float(hi - lo) == pytest.approx((1 - w + w * w) * 4.0, rel=1e-6)


def test_halo_authors_config_on_knights():
  c = configure.load("configs/stanford_lf.py:knights", "halo_authors")
  hi = c.hi
  assert hi.sampler.kind == "joint_blended" and hi.joint.field == "nelf"
  assert hi.fourier.st_kind == "axis" and hi.fourier.uv_features == 1 and hi.fourier.uv_drawn == 10
  assert (hi.joint.model.width, hi.joint.model.depth) == (256, 8)
  assert hi.joint.color_weight == 1.0
  assert hi.model.density_activation == "relu" and hi.density_noise == 1.0
  # batch_stanfordlf_dataset.py:155-166: batch_size fresh random rays a step,
  # whatever the batch (aug_points is never read: epi_nelf_uv_st.py:109)
  cpu = configure.load("configs/stanford_lf.py:knights_cpu", "halo_authors").hi
  assert (hi.joint.random_rays, cpu.joint.random_rays) == (hi.batch_rays, cpu.batch_rays)
  # ..._lego_knights.py:108-110: Poly power 1 per iteration to min_lr 5e-6 over
  # the run; epi_converge_iter 250 * 80 of its 80k iterations
  for stage in (hi, cpu):
    assert (stage.lr_power, stage.lr_final, stage.schedule_span) == (1.0, 5e-6, "stage")
    assert stage.joint.alpha_steps == round(stage.steps * 20000 / 80000)


def test_halo_authors_llff_schedule_is_theirs():
  # epi_nelf_sparse_llff_trex.py: Poly power 2 to 5e-6 over 100 epochs of
  # RepeatDataset(times=5) over 4 views of 504 x 378 rays in batches of 3072;
  # epi_converge_iter 1200 * 10 of those iterations
  iterations = 100 * 5 * (4 * 504 * 378 // 3072)   # 248 whole batches an epoch
  assert iterations == 124000
  for variant in ("fern_4view", "fern_4view_cpu"):
    hi = configure.load(f"configs/llff.py:{variant}", "halo_authors").hi
    assert (hi.lr_power, hi.lr_final, hi.schedule_span) == (2.0, 5e-6, "stage")
    assert hi.joint.alpha_steps == pytest.approx(hi.steps * 12000 / iterations, abs=1)


def test_halo_authors_refuses_dynamic_scenes():
  with pytest.raises(ValueError, match="halo_authors.*does not run.*static scenes only"):
    configure.load("configs/dnerf.py:lego_cpu", "halo_authors")


def test_depth_points_align_a_scene_point_seen_from_two_cameras():
  # a slab in a tilted frame; a 3D point seen from two camera centres off
  # the (u, v) plane: aligned to u* = 0, both rays give the same (s', t')
  # at the point's depth (the closed form of their sample_st_by_epi)
  from halo_jax.datasets import llff_planes
  rot = np.linalg.qr(np.random.default_rng(1).normal(size=(3, 3)))[0]
  slab = llff_planes.LightSlab(np.array([0.1, -0.2, 0.3]), rot[:, 0], rot[:, 1], rot[:, 2], 6.0)
  near, far = 1.2, slab.far
  x = slab.origin + 0.4 * rot[:, 0] - 0.3 * rot[:, 1] + 3.5 * rot[:, 2]
  centres = np.stack([slab.origin + 0.2 * rot[:, 0] + 0.05 * rot[:, 2],
                      slab.origin - 0.3 * rot[:, 1] - 0.02 * rot[:, 2]])
  uv, st = slab.coords(centres, x - centres)
  tau = (3.5 - near) / (far - near)
  pts = np.asarray(lightfield.depth_points(jnp.asarray(uv), jnp.asarray(st),
                                           jnp.full((2,), tau, jnp.float32), near, far))
  np.testing.assert_allclose(pts[0, :2], pts[1, :2], atol=1e-5)
  # and it is where the central camera's ray through the point meets the (s, t) plane
  np.testing.assert_allclose(pts[0, :2], np.array([0.4, -0.3]) * far / 3.5, atol=1e-5)


def test_even_blended_sampler_spreads_the_window_evenly():
  edges = np.asarray(samplers.blended_edges(jax.random.PRNGKey(0), 0.5, 0.0, 1.0, 0.1, 8, 0,
                                            False, even=True))
  lo, hi = (float(v) for v in samplers.blended_window(jnp.array(0.5), 0.0, 1.0, 0.1))
  np.testing.assert_allclose(edges[:-1], np.linspace(lo, hi, 8), atol=1e-6)


def test_halo_authors_on_llff_is_their_light_field_on_two_planes():
  c = configure.load("configs/llff.py:fern_4view_cpu", "halo_authors")
  # the scene stays LLFF; the method reads its photos as rays between two planes
  assert (c.data.kind, c.data.rays) == ("llff", "planes")
  assert c.stages == "hi" and c.hi.kind == "light_field"
  assert c.hi.sampler.kind == "joint_blended_even" and c.hi.joint.target == "max_weight"
  assert c.hi.joint.random_rays == c.hi.batch_rays and not c.hi.joint.color_uv
  assert c.hi.fourier.st_kind == "octaves" and c.hi.fourier.theta_features == 10


def test_octave_features_are_their_base_embedder():
  # BaseEmbedder.__call__ with include_input=False: for each 2^k, sin then
  # cos of inputs / scale * 2^k (their LLFF (s, t) at scale 8, depth at 1)
  x = np.random.default_rng(2).uniform(-4, 4, (6, 2))
  for scale in (8.0, 1.0):
    freqs = 2.0 ** np.linspace(0, 9, 10)
    theirs = np.concatenate([f(x / scale * k) for k in freqs for f in (np.sin, np.cos)], -1)
    ours = encoding.axis_fourier_features(jnp.asarray(x, jnp.float32),
                                          encoding.octave_frequencies(10, scale))
    np.testing.assert_allclose(np.asarray(ours), theirs, atol=3e-5)


def test_a_blended_window_of_width_zero_is_the_whole_range():
  lo, hi = samplers.blended_window(jnp.array([0.1, 0.9]), 1.2, 6.0, 0.0)
  np.testing.assert_allclose(lo, [1.2, 1.2])
  np.testing.assert_allclose(hi, [6.0, 6.0])


def test_halo_authors_on_blender_is_their_static_recipe():
  c = configure.load("configs/blender.py:lego_8view", "halo_authors")
  hi = c.hi
  # render_utils.py:18-28: ReLU density in both NeRFs; :82 the argmax depth
  assert c.stages == "lo,ray,hi" and c.ray.depth_target == "max_weight_open_end"
  for stage in (c.lo, c.hi):
    assert (stage.model.density_activation, stage.model.density_bias) == ("relu", 0.0)
  # nelf_nerf360.py:164: the ray field's opacity loss on the training rays,
  # at consist_loss_weight (1); :198, the same on the random rays, is
  # commented out, while :197 keeps their depth term (random_fraction 0.5)
  assert (c.ray.acc_weight, c.ray.random_acc, c.ray.random_fraction) == (1.0, False, 0.5)
  assert hi.sampler.near_only and not hi.model.use_viewdirs and hi.precrop_steps == 1000
  # L_empty from step 0 on 8-view lego (lf_hf_nerf_8view_gpu.py:17: empty_start_iter='0')
  assert (hi.empty.density_noise, hi.empty.num_samples, hi.empty.start_step) == (1.0, 128, 0)
  # lego: Hi from Lo but for the encoding's layers, 5e-3 falling with power 1 to
  # their absolute min_lr (nelf_nerf_synthetic_hotdog_sparse_hfnerf.py: Poly, min_lr=5e-6)
  assert hi.init_from_lo and hi.init_skip_fresh and not hi.encoding.with_lo
  assert (hi.lr_init, hi.lr_power, hi.schedule_span) == (pytest.approx(5e-3), 1.0, "stage")
  assert hi.lr_final == 5e-6
  # their loaded rate as it stands, also where the CPU config's base rate is 4x the paper's
  assert configure.load("configs/blender.py:lego_8view_cpu", "halo_authors").hi.lr_init == 5e-3
  drums = configure.load("configs/blender.py:drums_8view", "halo_authors").hi
  assert (drums.lr_init, drums.lr_final, drums.lr_power) == (5e-4, pytest.approx(5e-6), 2.0)
  assert drums.empty.start_step == 2000 and not drums.init_from_lo
  one = configure.load("configs/blender.py:lego_oneside", "halo_authors")
  assert (one.lo.steps, one.ray.steps, one.hi.steps) == (4200, 42000, 28000)
  assert one.hi.precrop_steps == 1000 and one.hi.empty.weight == 0.01
  # lf_hf_nerf_oneside.py sets no empty_start_iter: the hfnerf config's 5e3
  assert one.hi.empty.start_step == 5000 and one.hi.lr_final == 5e-6
  for scene in ("chair", "ship", "materials", "hotdog"):
    assert configure.load(f"configs/blender.py:{scene}_8view",
                          "halo_authors").hi.empty.start_step == 0


def test_authors_lo_nerf_is_their_lfnerf_config():
  """configs/nelf_nerf_synthetic_hotdog_sparse_lfnerf.py as
  scripts/lf_hf_nerf_8view_gpu.py:29-35 launches it (no overrides) and
  lf_hf_nerf_oneside.py:15-24 (scale 1, 3 epochs)."""
  from halo_jax.stages import step
  lo = configure.load("configs/blender.py:lego_8view", "halo_authors").lo
  # :10-11 BaseEmbedder nb_freqs=5, scale=32; :50 coarse_field use_dirs=False
  assert (lo.encoding.L, lo.encoding.scale, lo.model.use_viewdirs) == (5, 32.0, False)
  # :61 alpha_noise_std=1.0; :82 precrop_frac=0.5, to 1 at iteration 500 (:128)
  # of 10 epochs (:103) x 100 repeats (:85) x 8 images, one image a batch = 8000
  assert (lo.density_noise, lo.precrop_frac) == (1.0, 0.5)
  assert lo.steps == 8000 and lo.precrop_steps == 500
  # :97 Adam lr 5e-4; :102 Poly power 2, min_lr 1e-4 (absolute), over the run
  assert (lo.lr_init, lo.lr_final, lo.lr_power, lo.schedule_span) == (5e-4, 1e-4, 2.0, "stage")
  rate = step.schedule(lo)
  assert float(rate(0)) == pytest.approx(5e-4) and float(rate(8000)) == pytest.approx(1e-4)
  assert float(rate(4000)) == pytest.approx(1e-4 + 4e-4 * 0.5 ** 2)
  # one side: scale 1 (:21), 3 epochs (:22) of 14 images: 4200 iterations
  one = configure.load("configs/blender.py:lego_oneside", "halo_authors").lo
  assert (one.encoding.scale, one.steps, one.precrop_steps) == (1.0, 4200, 500)
  # under a budget the crop is the same share of the steps Lo trains
  c = protocol.effective(configure.load("configs/blender.py:lego_8view_cpu", "halo_authors",
                                        {"protocol": "steps", "budget_s": 0.0,
                                         "lo.stop_at_step": 480}))
  assert (c.lo.steps, c.lo.precrop_steps) == (480, round(round(500 / 8000 * 1500) * 480 / 1500))
  assert float(step.schedule(c.lo)(480)) == pytest.approx(1e-4)


def test_authors_schedules_span_the_steps_hi_trains():
  # Hi stopped at 736 of its 6000-step cap: the crop (1000 of 80k), L_empty's
  # start on drums (2000 of 80k) and the Poly rate span the 736 steps
  from halo_jax.stages import step
  over = {"protocol": "steps", "budget_s": 0.0, "hi.stop_at_step": 736}
  for scene, start in (("lego", 0), ("drums", 2000)):
    c = configure.load(f"configs/blender.py:{scene}_8view_cpu", "halo_authors", over)
    hi = protocol.effective(c).hi  # the spanned schedules are the protocol's plan
    assert hi.steps == 736
    assert hi.precrop_steps == round(round(1000 * 6000 / 80000) * 736 / 6000) == 9
    assert hi.empty.start_step == (round(round(start * 6000 / 80000) * 736 / 6000) if start
                                   else 0)
    assert float(step.schedule(hi)(736)) == pytest.approx(5e-6)
    again = protocol.effective(configure.finish(c))   # idempotent
    assert (again.hi.steps, again.hi.precrop_steps) == (736, 9)
    assert (c.hi.steps, c.hi.precrop_steps) == (6000, 75)  # as the method states them
  # `halo` keeps its schedules on the cap
  ours = (configure.load("configs/blender.py:lego_8view_cpu", "halo", over)).hi
  assert (ours.steps, ours.schedule_span) == (6000, "steps")


def test_authors_schedules_span_the_budgets_count(tmp_path):
  # under the budget protocol the count comes from the step table
  import json
  from halo_jax import step_table
  c = editable("configs/llff.py:fern_4view_cpu", "halo_authors")
  table = tmp_path / "table.json"
  table.write_text(json.dumps({"entries": {step_table.key(c, "hi"): {"step_s": 0.5,
                                                                     "setup_s": 0.0}}}))
  c.step_table = str(table)
  hi = protocol.effective(resolved(c)).hi
  assert hi.budget_steps == hi.steps == math.ceil(c.budget_s / 0.5)
  assert hi.joint.alpha_steps == round(round(6000 * 12000 / 124000) * hi.steps / 6000)
  assert hi.lr_power == 2.0 and hi.lr_final == 5e-6


def test_poly_schedule_is_mmcvs():
  import ml_collections
  from halo_jax.stages import step
  cfg = ml_collections.ConfigDict(dict(lr_init=5e-4, lr_final=5e-6, lr_power=2.0, steps=1000,
                                       lr_decay_steps=0))
  fn = step.schedule(cfg)
  for it in (0, 250, 999, 1000):
    # mmcv Poly: (base - min) (1 - it / max)^power + min
    assert float(fn(it)) == pytest.approx((5e-4 - 5e-6) * (1 - it / 1000) ** 2 + 5e-6, rel=1e-5)


def _their_argmax_depth(sigma, z, dists):
  """Their compositing (render_utils.py:18-28) and depth target (:82) in
  numpy: ReLU density, the last interval 2e10, z of the argmax weight."""
  dists = np.concatenate([dists[:-1], [2e10]])
  alpha = 1.0 - np.exp(-np.maximum(sigma, 0.0) * dists)
  weights = alpha * np.cumprod(np.concatenate([[1.0], 1.0 - alpha + 1e-10]))[:-1]
  return z[np.argmax(weights)]


@pytest.mark.parametrize("case", ["empty", "faint_last", "surface", "two_surfaces"])
def test_open_end_depth_target_is_their_argmax(case):
  from halo_jax import render
  edges = np.linspace(2.0, 6.0, 9)
  z, dists = 0.5 * (edges[:-1] + edges[1:]), np.diff(edges)
  sigma = {"empty": np.zeros(8),                      # all-zero weights: index 0
           "faint_last": np.r_[np.zeros(7), 1e-3],    # the passing light stops last
           "surface": np.r_[np.zeros(3), 0.4, 0.0, 0.0, 0.0, 1e-3],
           "two_surfaces": np.r_[0.0, 0.1, 0.0, 0.0, 3.0, 0.0, 0.0, 0.0]}[case]
  weights = render.volume_render(jnp.asarray(sigma, jnp.float32), jnp.zeros((8, 3)),
                                 jnp.asarray(edges, jnp.float32))["weights"]
  ours = float(render.open_end_max_depth(weights, jnp.asarray(sigma, jnp.float32),
                                         jnp.asarray(edges, jnp.float32)))
  assert ours == pytest.approx(_their_argmax_depth(sigma, z, dists))
  assert ours == pytest.approx({"empty": z[0], "faint_last": z[-1], "surface": z[-1],
                                "two_surfaces": z[4]}[case])


def test_open_end_target_in_lo_targets_and_an_unknown_target_is_refused():
  from halo_jax import raycast
  class Empty:   # a ReLU field with no density at all
    def apply(self, variables, points, view, *a, **k):
      return jnp.zeros(points.shape[:-1]), jnp.zeros(points.shape[:-1] + (3,))
  o = jnp.zeros((2, 3)); d = jnp.array([[0.0, 0.0, 1.0]] * 2)
  depth, acc = raycast.lo_targets(Empty(), {}, o, d, num_samples=8, near=2.0, far=6.0,
                                  white_background=False, target="max_weight_open_end")
  np.testing.assert_allclose(depth, [2.25, 2.25])   # their index 0: the first sample
  np.testing.assert_allclose(acc, [0.0, 0.0])
  from halo_jax import validate
  bad = configure.load("configs/blender.py:lego_8view_cpu", "halo", {"ray.depth_target": "far"})
  with pytest.raises(ValueError, match="ray.depth_target='far'.*must be one of"):
    validate.validate(bad)


@pytest.mark.slow
def test_select_best_keeps_the_parameters_that_scored_best(tmp_path):
  # the built-in scene, Hi alone; selection on its val cameras every 5 steps
  from halo_jax import pipeline
  c = configure.load("configs/procedural.py:spheres_8view_cpu", "nerf_tuned", {
      "data.procedural_size": 32, "data.test_views": "r_0,r_100", "data.select_views": "every:25",
      "hi.steps": 12, "hi.eval_every": 5, "hi.select_best": True, "hi.model.width": 32,
      "hi.batch_rays": 128, "hi.sampler.num_samples": 8, "baseline.num_samples": 8,
      "protocol": "steps", "budget_s": 0.0, "eval.curve_views": 1})
  pipeline.run(finish(c), str(tmp_path))
  import json
  with open(tmp_path / "metrics.jsonl") as f:
    scored = [json.loads(l) for l in f if "select_psnr" in l]
  assert [r["step"] for r in scored] == [5, 10, 12]
  best = max(scored, key=lambda r: r["select_psnr"])
  with open(tmp_path / "hi" / "best" / "record.json") as f:
    assert json.load(f) == {"step": best["step"], "psnr": pytest.approx(best["select_psnr"])}


def test_select_best_needs_selection_views_and_never_a_test_view(tmp_path):
  from halo_jax import datasets, validate
  from halo_jax.registry import ConfigError
  c = configure.load("configs/procedural.py:spheres_8view_cpu", "nerf_tuned",
                     {"hi.select_best": True})
  with pytest.raises(ConfigError, match="hi.select_best=True needs data.select_views"):
    validate.validate(c)
  c = configure.load("configs/procedural.py:spheres_8view_cpu", "nerf_tuned", {
      "data.procedural_size": 16, "data.test_views": "r_0", "data.select_views": "r_0",
      "data.select_split": "test"})
  with pytest.raises(datasets.DataError, match="holds test views"):
    datasets.load(c.data, str(tmp_path))


FERN = os.path.join(SHARED_DATA, "nerf_llff_data", "fern")


@pytest.mark.skipif(not os.path.exists(FERN), reason="shared LLFF data absent")
def test_llff_planes_rays_and_spiral(tmp_path):
  from halo_jax import camera_paths, datasets
  from halo_jax.datasets import llff_planes
  c = configure.load("configs/llff.py:fern_4view_cpu", "halo_authors", {"data.root": FERN})
  ds = datasets.load(c.data, str(tmp_path))
  o, d = ds.train.rays()
  assert np.all(o[..., 2] == 0) and np.all(d[..., 2] == 1)
  # near is 0.9 x the nearest bound, far the farthest (their no-NDC LLFF)
  bounds = llff.read_poses(FERN)[3]
  assert (ds.near, ds.far) == pytest.approx((0.9 * bounds.min(), bounds.max()))
  assert ds.epi_slope == "depth"
  views = camera_paths.views_for("spiral", ds, 3)
  assert isinstance(views, llff_planes.PlaneRayViews) and views.rays()[0].shape[0] == 3
