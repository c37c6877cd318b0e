"""Methods as data: the paper's NeRF and FreeNeRF pieces against closed forms
and numpy, the method registry and config variants, validate()'s rules, and
short runs of every method through the unchanged pipeline."""
import json
import os

import jax
import jax.numpy as jnp
import numpy as np
from unittest import mock

import pytest

from conftest import assert_trained, tiny_config
from halo_jax import config_files, configure, losses, methods, models, pipeline, protocol, raycast, samplers, validate
from halo_jax.registry import ConfigError
from halo_jax.stages import batches
from halo_jax.stages import step as train_step
from conftest import editable  # pylint: disable=g-import-not-at-top
from halo_jax.configure import finish  # pylint: disable=g-import-not-at-top


def freenerf_mask_reference(L, t, T):
  """FreeNeRF's published mask for one coordinate (their get_freq_reg_mask
  with pos_enc_length = L), written out with numpy."""
  if t >= T:
    return np.ones(L)
  mask = np.zeros(L)
  ptr = min(L * t / T + 1, L)
  k = int(ptr)
  mask[:k] = 1.0
  if k < L:
    mask[k] = ptr - k
  return mask


@pytest.mark.parametrize("L", [4, 10])
def test_band_weights_match_freenerf_mask(L):
  T = 900
  for t in (0, 1, 45, 90, 91, 450, 809, 810, 899, 900, 2000):
    got = np.asarray(models.band_weights(min(t / T, 1.0), L, 3)).reshape(L, 3)
    np.testing.assert_allclose(got, np.repeat(freenerf_mask_reference(L, t, T)[:, None], 3, 1),
                               atol=1e-6, err_msg=f"t={t}")


def test_masked_encoding_keeps_the_input_and_hides_high_bands():
  x = jax.random.uniform(jax.random.PRNGKey(0), (5, 3), minval=-1, maxval=1)
  full = models.masked_positional_encoding(x, 6, 1.0, None)
  np.testing.assert_array_equal(models.masked_positional_encoding(x, 6, 1.0, 1.0), full)
  start = np.asarray(models.masked_positional_encoding(x, 6, 1.0, 0.0))
  # [x (3), sin (6 bands x 3), cos (6 x 3)]: only x and band 0 survive
  keep = np.zeros(3 + 36, bool)
  keep[:6] = True
  keep[21:24] = True
  np.testing.assert_array_equal(start[:, keep], np.asarray(full)[:, keep])
  np.testing.assert_array_equal(start[:, ~keep], 0.0)


def test_occlusion_loss_is_the_mean_density_nearest_the_camera():
  sigma = np.random.default_rng(0).uniform(0, 5, (7, 64)).astype(np.float32)
  np.testing.assert_allclose(losses.occlusion(jnp.asarray(sigma), 20), sigma[:, :20].mean(),
                             rtol=1e-6)


def test_relu_density_is_zero_below_its_threshold():
  m = models.NeRFMLP(pos_freqs=2, width=8, depth=1, skips=(), use_viewdirs=False,
                     density_bias=0.0, density_activation="relu")
  x = jax.random.normal(jax.random.PRNGKey(1), (256, 3))
  sigma, _ = m.apply({"params": models.init_nerf(m, "nerf", 0)}, x, x)
  assert np.any(np.asarray(sigma) == 0.0) and np.all(np.asarray(sigma) >= 0.0)


def test_coarse_fine_uses_the_coarse_mlp_and_composites_both_sample_sets():
  m = models.NeRFMLP(pos_freqs=4, width=16, depth=2, skips=(), use_viewdirs=True)
  fine, coarse = models.init_nerf(m, "nerf", 0), models.init_nerf(m, "nerf", 1)
  cfg = tiny_config().hi.sampler
  cfg.update(kind="coarse_fine", num_coarse=16, num_samples=32)
  o = jnp.tile(jnp.array([[0.0, 0.0, 4.0]]), (8, 1))
  d = jnp.tile(jnp.array([[0.0, 0.0, -1.0]]), (8, 1))
  kw = dict(near=2.0, far=6.0, white_background=True, randomized=True)
  key = jax.random.split(jax.random.PRNGKey(3), 8)  # one key per ray
  outs = raycast.render_rays(m, cfg, fine, o, d, key, coarse_params=coarse, **kw)
  assert outs[0]["weights"].shape == (8, 16) and outs[1]["weights"].shape == (8, 16 + 32 + 1)
  same = raycast.render_rays(m, cfg, fine, o, d, key, **kw)
  # the first pass ran the coarse MLP: a different field gives other weights
  assert not np.allclose(outs[0]["weights"], same[0]["weights"])
  # the union of edges tiles [near, far]
  np.testing.assert_allclose(outs[1]["weights"].sum(-1) + np.exp(
      -np.cumsum(outs[1]["sigma"] * 0, -1))[..., -1] * 0, outs[1]["acc"], rtol=1e-6)
  edges = samplers.merge_edges(jnp.array([[0.0, 0.5, 1.0]]), jnp.array([[0.0, 0.2, 1.0]]))
  np.testing.assert_allclose(edges, [[0.0, 0.0, 0.2, 0.5, 1.0, 1.0]])
  # one key for a batch that draws would give every ray the same jitter
  with pytest.raises(ValueError, match="per-ray keys"):
    raycast.render_rays(m, cfg, fine, o, d, jax.random.PRNGKey(3), **kw)


def test_one_image_batches_stay_in_one_view_and_its_crop():
  n, h, w = 5, 8, 6
  index = jax.device_put(batches.index_data(n, h, w, 0.5))
  for s in range(20):
    key = jax.random.PRNGKey(s)
    k1, k2 = jax.random.split(key)
    idx = np.asarray(batches.draw(k1, k2, 100, n * h * w, 64, index, 10, one_image=True))
    assert len(set(idx // (h * w))) == 1
    crop = np.asarray(batches.draw(k1, k2, 0, n * h * w, 64, index, 10, one_image=True))
    assert set(crop % (h * w)) <= set(batches.crop_pixels(h, w, 0.5))


def test_lr_decay_steps_gives_the_original_schedule():
  c = tiny_config().hi
  c.update(lr_init=5e-4, lr_final=5e-5, steps=100)
  over_cap = train_step.schedule(c)
  np.testing.assert_allclose([float(over_cap(0)), float(over_cap(100))], [5e-4, 5e-5], rtol=1e-5)
  c.lr_decay_steps = 500000  # the original NeRF's: 10x per 500k steps, whatever the cap
  original = train_step.schedule(c)
  for step in (0, 100, 1000, 250000):
    np.testing.assert_allclose(float(original(step)), 5e-4 * 0.1 ** (step / 500000), rtol=1e-5)


def test_a_variant_names_a_scene_and_no_method():
  from configs import blender
  assert config_files.split_flags("lego_8view_cpu") == (["lego", "8view"], {"cpu"})
  assert config_files.split_flags("8view_ff_cpu", ("cpu", "ff")) == (["8view"], {"cpu", "ff"})
  assert blender.get_config("lego_8view_cpu").method == ""
  with pytest.raises(ValueError, match="unknown variant 'lego_8view_cpu_nerf_paper'"):
    blender.get_config("lego_8view_cpu_nerf_paper")


def test_methods_configure_the_stages_they_describe():
  c = configure.load("configs/blender.py:lego_8view_cpu", "halo")
  paper = configure.load("configs/blender.py:lego_8view_cpu", "nerf_paper")
  assert paper.method == "nerf_paper" and paper.stages == "hi"
  assert (paper.hi.sampler.kind, paper.hi.sampler.num_coarse, paper.hi.sampler.num_samples) == (
      "coarse_fine", 64, 128)
  assert paper.hi.model.density_activation == "relu" and paper.hi.density_noise == 0.0
  assert paper.hi.one_image and paper.hi.batch_rays == 1024
  free = configure.load("configs/blender.py:lego_8view_cpu", "freenerf")
  assert free.hi.freq_reg.end == 0.9 and free.hi.occlusion.weight == 0.01
  both = configure.load("configs/blender.py:lego_8view_cpu", "halo+freenerf")
  assert pipeline.needed(both) == ("lo", "ray", "hi") and both.hi.freq_reg.end == 0.9
  for name in methods.METHODS.names():
    validate.validate(configure.load("configs/blender.py:lego_8view_cpu", name))
  neutral = tiny_config(method="")
  assert neutral.method == ""
  with pytest.raises(ConfigError, match="method='dietnerf' is not a known method"):
    methods.apply(neutral, "dietnerf")
  # a method is applied once: HALO's settings must not reach a baseline
  with pytest.raises(ValueError, match="already method 'halo'.*configure.compose"):
    methods.apply(c, "nerf_tuned")
  # an override wins over what the method sets
  assert configure.load("configs/blender.py:lego_8view_cpu", "nerf_paper",
                        {"hi.batch_rays": 64}).hi.batch_rays == 64


def _llff():
  from configs import llff
  return editable(llff.get_config("fern_4view_cpu"), "halo")


def _dnerf():
  from configs import dnerf
  return editable(dnerf.get_config("lego_cpu"), "halo")


def _knights():
  from configs import stanford_lf
  return editable(stanford_lf.get_config("knights_cpu"), "halo")


def _set(make, **fields):
  def build():
    c = make()
    for path, value in fields.items():
      *parents, leaf = path.split("__")
      node = c
      for p in parents:
        node = node[p]
      node[leaf] = value
    return c
  return build


RULES = [
    (_set(_llff, hi__empty__weight=0.1),
     r"hi.empty \(loss term 'empty'\) takes sphere rays, not data.kind='llff' \(ndc rays\)"),
    (_set(tiny_config, lo__batch_rays=0), r"lo.batch_rays=0: must be a positive integer"),
    (_set(_knights, hi__freq_reg__end=0.9),
     r"hi.freq_reg.end=0.9: the light-field stage has no P.E. bands"),
    (_set(tiny_config, data__procedural_scene="cube"),
     r"data.procedural_scene='cube': must be one of \['lattice', 'sparse', 'spheres', 'textured', 'thin'\]"),
    (_set(tiny_config, lo__lr_init=float("nan")), r"lo.lr_init=nan: must be a positive number"),
    (_set(tiny_config, hi__microbatches=3), r"hi.microbatches=3 does not divide hi.batch_rays=64"),
    (_set(tiny_config, hi__sampler__kind="importance"),
     r"hi.sampler.kind='importance' is not a known sampler"),
    (_set(tiny_config, hi__sampler__num_samples=0),
     r"hi.sampler.num_samples=0: must be a positive integer"),
    (_set(tiny_config, stages="lo,rays"), r"config.stages='lo,rays': each stage must be one of"),
    (_set(tiny_config, protocol="budget", budget_s=10.0, budget_shares__lo=0.0, budget_shares__ray=0.0,
          budget_shares__hi=0.0), r"budget_shares .* sum to more than 0"),
    (_set(_dnerf, hi__sampler__kind="depth_guided"),
     r"hi.sampler.kind='depth_guided' .* data.kind='dnerf'"),
    (_set(_dnerf, stages="lo,ray,hi"), r"ray.kind='ray_field' .*|the ray field has no time input"),
    (_set(_knights, hi__sampler__kind="coarse_fine"), r"light fields use one of"),
    (_set(_knights, lo__encoding__auto=True),
     r"lo.encoding.auto=True: the frequency rule picks Lo-NeRF's P.E., .*'stanford_lf'"),
    (_set(tiny_config, hi__kind="nerf"), r"hi.kind='nerf' is not a known stage trainer"),
    (_set(tiny_config, final_stage="out"), r"final_stage='out': must be one of"),
]


@pytest.mark.parametrize("make, message", RULES, ids=[m for _, m in RULES])
def test_validate_names_the_field(make, message):
  with pytest.raises(ConfigError, match=message):
    validate.validate(make())


def test_every_shipped_config_validates():
  for spec in ("configs/default.py", "configs/blender.py:lego_8view",
               "configs/blender.py:lego_oneside_cpu", "configs/llff.py:fern_4view_cpu",
               "configs/dnerf.py:lego", "configs/stanford_lf.py:knights"):
    for name in ("halo", "nerf_tuned") + (("halo_joint",) if "llff" in spec else ()):
      validate.validate(configure.load(spec, name))


def test_auto_frequency_is_accepted_for_every_kind_with_a_lo_nerf():
  from configs import dnerf, llff
  for c in (editable(llff.get_config("fern_4view_cpu"), "halo"),
            editable(dnerf.get_config("hook_cpu"), "halo"), tiny_config()):
    c.lo.encoding.auto = True
    validate.validate(c)


def test_auto_frequency_on_a_light_field_is_refused_before_any_work(tmp_path):
  from halo_jax import pipeline  # pylint: disable=g-import-not-at-top
  c = _knights()
  c.lo.encoding.auto = True
  c.data.root = str(tmp_path / "no_such_scene")  # nothing is read before the refusal
  with pytest.raises(ConfigError, match=r"lo.encoding.auto=True"):
    pipeline.run(finish(c), str(tmp_path / "run"))
  assert not os.path.exists(tmp_path / "run" / "tune")


def test_llff_with_empty_loss_is_refused_before_any_work(tmp_path):
  from test_llff import llff_config, write_llff
  c = llff_config(write_llff(str(tmp_path / "scene")))
  c.hi.empty.weight = 0.1
  wd = str(tmp_path / "run")
  with pytest.raises(ConfigError, match=r"hi.empty .* data.kind='llff'"):
    pipeline.run(finish(c), wd)
  assert not os.path.exists(wd)


@pytest.mark.slow
@pytest.mark.parametrize("name", ["nerf_paper", "freenerf", "halo+freenerf"])
def test_method_trains_through_the_pipeline(name, scene_root, tmp_path):
  c = tiny_config(name)
  c.data.root = scene_root
  if name != "halo+freenerf":  # keep the tiny sizes: the method's own are for real runs
    c.hi.sampler.update(num_coarse=8, num_samples=8)
    c.hi.update(batch_rays=64, microbatches=1, steps=6, precrop_steps=2)
  c.hi.update(steps=60, log_every=1, checkpoint_every=30, lr_init=5e-3, lr_final=5e-3)
  wd = str(tmp_path / "run")
  infos = pipeline.run(finish(c), wd)
  assert infos["hi"]["step"] == 60 and infos["hi"]["skipped"] == 0
  assert np.isfinite(infos["hi"]["eval"]["psnr"])
  assert_trained(wd, "hi", c)
  log = [json.loads(line) for line in open(os.path.join(wd, "metrics.jsonl"))]
  if name == "freenerf":
    assert any("occlusion" in r for r in log)
  from halo_jax import stages
  from halo_jax.stages import base
  state = stages.load(wd, "hi", base.trainer_of(c, "hi").params_like(c, "hi", None))
  assert ("coarse" in state.params) == (name != "halo+freenerf")


def test_halo_settings_reach_every_halo_method_and_no_baseline():
  from halo_jax.methods import halo
  hook_spec, spheres_spec = "configs/dnerf.py:hook_cpu", "configs/procedural.py:spheres_8view_cpu"
  for name in ("halo", "halo+freenerf", "halo+unseen", "halo_auto"):
    hook = configure.load(hook_spec, name)
    assert (hook.hi.lr_init, hook.hi.lr_final) == halo.COPY_LR, name
    assert configure.load(spheres_spec, name).lo.precrop_steps == 0, name
  assert hook.lo.precrop_steps == 200  # dynamic scenes keep Lo's crop (not measured without)
  assert configure.load(spheres_spec, "nerf_tuned").hi.precrop_steps == 200
  assert configure.load(hook_spec, "nerf_tuned").hi.lr_init == 2e-3
  assert configure.load(spheres_spec, "halo").hi.lr_init == 2e-3  # static: unchanged
  # forward-facing: a quarter of Hi's samples over the whole ray, at every size
  for spec, samples in (("configs/llff.py:fern_4view_cpu", 32), ("configs/llff.py:fern_4view", 128)):
    for name in ("halo", "halo+freenerf"):
      fern = configure.load(spec, name).hi.sampler
      assert (fern.kind, fern.num_samples, fern.num_full) == ("depth_guided", samples,
                                                              samples // 4), (spec, name)
  assert configure.load(spheres_spec, "halo").hi.sampler.num_full == 0
  assert configure.load("configs/llff.py:fern_4view_cpu", "nerf_tuned").hi.sampler.num_full == 0


# Every shipped scene variant, one per protocol and size.
SCENE_SPECS = ("configs/default.py", "configs/blender.py:lego_8view", "configs/blender.py:lego_8view_cpu",
               "configs/blender.py:lego_oneside_cpu", "configs/dnerf.py:hook_cpu",
               "configs/dnerf.py:lego", "configs/llff.py:fern_4view_cpu",
               "configs/stanford_lf.py:knights", "configs/stanford_lf.py:knights_cpu",
               "configs/procedural.py:spheres_8view_cpu")
BASELINES = ("nerf_tuned", "nerf_paper", "freenerf")


@pytest.mark.parametrize("spec", SCENE_SPECS)
def test_scene_configs_are_a_neutral_nerf(spec):
  # A scene's file holds the protocol; the stages, samplers and loss weights
  # are the method's.
  c = configure.load_scene(spec)
  assert c.method == "" and c.stages == "hi", spec
  assert c.hi.sampler.kind == "stratified", spec
  assert not (c.hi.init_from_lo or c.hi.encoding.with_lo), spec
  weights = (c.hi.empty.weight, c.hi.occlusion.weight, c.hi.freq_reg.end, c.lo.unseen.weight,
             c.hi.unseen.weight)
  assert weights == (0.0,) * 5, spec


def test_a_field_added_to_halo_reaches_no_baseline(monkeypatch):
  from halo_jax.methods import halo
  specs = ("configs/blender.py:lego_8view_cpu", "configs/dnerf.py:hook_cpu",
           "configs/llff.py:fern_4view_cpu", "configs/stanford_lf.py:knights_cpu")

  def resolved():
    out = {}
    for spec in specs:
      for name in BASELINES + ("halo",):
        try:
          out[spec, name] = configure.load(spec, name).to_dict()
        except ConfigError:
          pass
    return out

  before = resolved()

  for name, table in list(halo.KINDS.items()):
    monkeypatch.setitem(halo.KINDS, name,
                        {**table, "hi.density_noise": 0.123, "hi.model.width": 7})
  after = resolved()
  assert set(before) == set(after)
  for spec, name in before:
    if name == "halo":  # the dummy field did reach HALO itself
      assert after[spec, name]["hi"]["model"]["width"] == 7, spec
    else:
      assert after[spec, name] == before[spec, name], (spec, name)


def test_a_method_refuses_a_scene_kind_it_does_not_run_on():
  with pytest.raises(ConfigError) as e:
    configure.load("configs/stanford_lf.py:knights_cpu", "nerf_paper")
  assert "\n" not in str(e.value)
  assert "'nerf_paper' does not run on data.kind='stanford_lf'" in str(e.value)
  with pytest.raises(ConfigError, match="'halo_joint' .* static scenes only"):
    configure.load("configs/dnerf.py:hook_cpu", "halo_joint")


def test_the_joint_scheme_is_a_method():
  joint = configure.load("configs/llff.py:fern_4view_cpu", "halo_joint")
  assert joint.method == "halo_joint" and joint.stages == "lo,hi"
  assert joint.hi.sampler.kind == "joint"
  assert joint.hi.joint.alpha_final == joint.hi.sampler.window  # ends at the two-stage window
  two_stage = configure.load("configs/llff.py:fern_4view_cpu", "halo")
  assert (two_stage.stages, two_stage.hi.sampler.kind) == ("lo,ray,hi", "depth_guided")


def test_the_extending_example_is_one_file_and_one_line(monkeypatch):
  # docs/extending.md's method, run from the page itself: registered with one
  # line, it runs on every scene file and differs from nerf_tuned
  # only where it says.
  import re  # pylint: disable=g-import-not-at-top
  import types  # pylint: disable=g-import-not-at-top
  page = open(os.path.join(os.path.dirname(__file__), "..", "docs", "extending.md")).read()
  code = re.search(r"```python\n(# halo_jax/methods/nerf_empty.py\n.*?)```", page, re.S).group(1)
  module = types.ModuleType("nerf_empty")
  exec(compile(code, "docs/extending.md", "exec"), module.__dict__)  # pylint: disable=exec-used
  monkeypatch.setitem(methods.METHODS._entries, "nerf+empty", module.METHOD)  # pylint: disable=protected-access
  c = configure.load("configs/blender.py:lego_8view_cpu", "nerf+empty")
  validate.validate(c)
  assert c.method == "nerf+empty" and pipeline.needed(c) == ("lo", "hi")
  base = configure.load("configs/blender.py:lego_8view_cpu", "nerf_tuned").to_dict()
  got = c.to_dict()
  assert (got.pop("stages"), got["hi"]["empty"].pop("weight"), got.pop("method")) == (
      "lo,hi", 0.1, "nerf+empty")
  for field in ("stages", "method"):
    base.pop(field)
  base["hi"]["empty"].pop("weight")
  for tree in (got, base):  # the step counts the budget resolves differ with the stages run
    tree.pop("plan")
  assert got == base
  with pytest.raises(ConfigError, match="'nerf\\+empty' does not run on data.kind='llff'"):
    configure.load("configs/llff.py:fern_4view_cpu", "nerf+empty")


def test_a_method_table_writes_values_then_overrides_then_derived_fields():
  from halo_jax.methods import base
  table = {"hi.sampler.num_samples": 12,
           "baseline.num_samples": base.Derived(lambda c, scene: c.hi.sampler.num_samples + 1)}
  toy = base.Method("toy", base.every_kind(table))
  c = configure.load_scene("configs/blender.py:lego_8view_cpu")
  rules = base.write_values(c, toy.table("sphere"))
  assert c.hi.sampler.num_samples == 12 and [r[0] for r in rules] == ["baseline.num_samples"]
  base.write_derived(c, c, rules)
  assert c.baseline.num_samples == 13
  # an override of the source moves the derived field; an override of the
  # derived field wins over its rule
  with mock.patch.dict(methods.METHODS._entries, {"toy": toy}):  # pylint: disable=protected-access
    got = configure.compose("configs/blender.py:lego_8view_cpu", "toy",
                            {"hi.sampler.num_samples": 20})
    assert (got.hi.sampler.num_samples, got.baseline.num_samples) == (20, 21)
    got = configure.compose("configs/blender.py:lego_8view_cpu", "toy",
                            {"baseline.num_samples": 7})
    assert (got.hi.sampler.num_samples, got.baseline.num_samples) == (12, 7)
  with pytest.raises(KeyError, match="hi.sampler.num_sample'; nearest: hi.sampler.num_samples"):
    base.write_values(c, {"hi.sampler.num_sample": 3})
  with pytest.raises(KeyError, match="hi.sampler.num_sample"):
    base.write_values(c, {"hi.sampler.num_sample": base.Derived(lambda c, scene: 3)})


def test_halo_is_its_table_on_each_scene_kind():
  from halo_jax.methods import base, halo
  for spec, kind in (("configs/blender.py:lego_8view_cpu", "sphere"),
                     ("configs/llff.py:fern_4view_cpu", "ndc"),
                     ("configs/dnerf.py:hook_cpu", "dynamic"),
                     ("configs/stanford_lf.py:knights_cpu", "two_plane")):
    composed = configure.load(spec, "halo")
    scene = configure.load_scene(spec)
    c = composed.to_dict()
    for dotted, value in halo.KINDS[kind].items():
      if isinstance(value, base.Derived):  # its rule, on the composed config
        value = value.rule(composed, scene)
      node = c
      for part in dotted.split("."):
        node = node[part]
      assert node == value, (spec, dotted)


def test_lo_nerf_on_ndc_has_its_own_scale_at_every_size():
  from halo_jax.methods import halo
  for spec in ("configs/llff.py:fern_4view", "configs/llff.py:fern_4view_cpu",
               "configs/llff.py:trex_3view"):
    assert configure.load(spec, "halo").lo.encoding.scale == halo.NDC_LO_SCALE == 1.0, spec
  # the 360-degree paper-size scale (the authors' 32) is the scene's, untouched
  assert configure.load("configs/blender.py:lego_8view", "halo").lo.encoding.scale == 32.0
  assert configure.load("configs/llff.py:fern_4view", "nerf_tuned").lo.encoding.scale == 32.0


def test_freenerf_mask_is_fully_open_at_90_percent_of_the_steps_a_run_trains():
  """FreeNeRF's schedule spans the run (their reg_end_ratio 0.9 of it): under
  a budget, the budget's count; under a stop_at_step, that; else `steps`."""
  from halo_jax.stages import budget, radiance
  spec = "configs/blender.py:lego_8view_cpu"
  runs = {"budget 60 s": configure.compose(spec, "freenerf", protocol=60.0),
          "budget 960 s": configure.compose(spec, "freenerf", protocol=960.0),
          "stopped": configure.compose(spec, "freenerf", {"hi.stop_at_step": 300},
                                       protocol="steps"),
          "paper": configure.compose("configs/blender.py:lego_8view", "freenerf")}
  lengths = set()
  for name, c in runs.items():
    c = protocol.effective(c)  # as the stages train it
    n = budget.last_step(c.hi)
    lengths.add(n)
    assert n < c.hi.steps or name == "paper", name
    bands = c.hi.encoding.L
    open_at = lambda step: np.asarray(models.band_weights(  # noqa: E731
        radiance.band_fraction(c.hi, step), bands, 3))
    assert open_at(int(np.ceil(0.9 * n))).min() == 1.0, name          # fully open
    assert open_at(int(0.8 * n)).min() < 1.0, name                    # not before
    assert float(radiance.band_fraction(c.hi, 0.45 * n)) == pytest.approx(0.5), name
  assert len(lengths) == 4
  # halo+freenerf's Hi, started from Lo under a budget, the same
  both = protocol.effective(configure.compose(spec, "halo+freenerf", protocol=240.0))
  n = budget.last_step(both.hi)
  assert float(radiance.band_fraction(both.hi, 0.9 * n)) == 1.0 and n == both.hi.budget_steps


def test_halo_doubles_hi_samples_after_its_switch_where_it_has_fewer_than_the_baseline():
  from halo_jax.methods import halo
  cpu = configure.load("configs/blender.py:lego_8view_cpu", "halo").hi.sampler
  assert (cpu.num_samples, cpu.switch_step, cpu.switch_samples) == (32, halo.SWITCH_STEP, 64)
  assert configure.load("configs/procedural.py:spheres_8view_cpu", "halo+freenerf") \
      .hi.sampler.switch_step == halo.SWITCH_STEP
  # the paper's 128 samples in the window outnumber the baseline's 64: no switch
  assert configure.load("configs/blender.py:lego_8view", "halo").hi.sampler.switch_step == 0
  assert configure.load("configs/blender.py:lego_8view_cpu", "halo_auto") \
      .hi.sampler.switch_step == halo.SWITCH_STEP
  # the other kinds: none
  for spec, name in (("configs/llff.py:fern_4view_cpu", "halo"),
                     ("configs/dnerf.py:hook_cpu", "halo")):
    assert configure.load(spec, name).hi.sampler.switch_step == 0, (spec, name)
  # an override wins over the rule
  off = configure.load("configs/blender.py:lego_8view_cpu", "halo",
                       overrides={"hi.sampler.switch_step": 0})
  assert off.hi.sampler.switch_step == 0


def test_the_baseline_takes_the_same_switch_where_halo_has_it():
  """nerf_tuned doubles its samples at HALO's switch step on the scenes where
  HALO does (360-degree, CPU sizes), from its own 64 to 128: the twin of the
  hi_window study, which the study's records are adopted as."""
  from halo_jax.methods import halo
  from experiments.bench import budget_studies
  for spec in ("configs/blender.py:lego_8view_cpu", "configs/procedural.py:spheres_8view_cpu"):
    s = configure.load(spec, "nerf_tuned").hi.sampler
    assert (s.kind, s.num_samples, s.switch_step, s.switch_samples) == \
        ("stratified", 64, halo.SWITCH_STEP, 128), spec
  # the variants that passed the rule change nothing in the defaults now: the
  # twin rendered with 256 samples past the switch, and HALO with 128
  study = budget_studies.STUDIES["hi_window_960"]
  spec = "configs/procedural.py:spheres_8view_cpu"
  for method, name in (("nerf_tuned", f"{budget_studies.BASELINE_TWIN}+dense_eval_256"),
                       ("halo", "samples_64_after_2000+dense_eval_128")):
    v = next(v for v in study.variants if v.name == name)
    assert configure.load(spec, method, overrides=dict(v.overrides)).to_dict() == \
        configure.load(spec, method).to_dict(), name
    s = configure.load(spec, method).hi.sampler
    assert (s.dense_eval_after, s.dense_eval_samples) == (
        halo.SWITCH_STEP, 2 * s.switch_samples), method
  # no switch, no dense renders
  off = configure.load(spec, "nerf_tuned", overrides={"hi.sampler.switch_step": 0}).hi.sampler
  assert off.dense_eval_after == 0
  for spec, name in (("configs/blender.py:lego_8view", "nerf_tuned"),      # paper sizes
                     ("configs/llff.py:fern_4view_cpu", "nerf_tuned"),
                     ("configs/dnerf.py:hook_cpu", "nerf_tuned"),
                     ("configs/blender.py:lego_8view_cpu", "nerf_paper")):
    assert configure.load(spec, name).hi.sampler.switch_step == 0, (spec, name)
