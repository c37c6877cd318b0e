"""Training-step throughput of each stage against the machine's measured matmul peak.

  python -m experiments.throughput --config=configs/blender.py:lego_8view_cpu
  python -m experiments.throughput_report   # docs/results/throughput.md from the files

Measures, in one process: the matmul peak (a large jitted fp32 matmul), then
for the Lo, ray and Hi training steps and the NeRF baseline step, and for
every compared method its output stage's training step and held-out render
chunk ('<method> train', '<method> render'): seconds per step, rays/s,
samples/s, FLOPs per step from XLA's cost analysis, and the share of the peak. Uses random-initialised fields on the procedural scene's
geometry (throughput does not depend on the weights). Writes one result file,
results/throughput/<config>/<machine>/<UTC time>_<commit>.json, committed so
that the next measurement is compared with it (experiments/throughput_report.py).
"""
import functools
import os
import sys
import time

from absl import flags, logging
import jax
import jax.numpy as jnp
import numpy as np
from ml_collections import config_flags

from experiments.bench import run_file, throughput_report, tool, trace_summary
from experiments.bench.paths import REPO
from halo_jax import camera, geometry, models, ray_fields
from experiments.bench import git_state
from halo_jax import config_files, frozen, methods, raycast, samplers
from halo_jax.cli import config_of_flags
from halo_jax.rays import Pixels, Rays, Targets
from halo_jax.stages import batches, radiance, ray, terms
from halo_jax.stages import step as train_step

FLAGS = flags.FLAGS
config_flags.DEFINE_config_file("config", "configs/default.py", "Config (path[:variant]).")
flags.DEFINE_string("results", os.path.join(REPO, "results", "throughput"),
                    "Result files' root: <results>/<config>/<machine>/<time>_<commit>.json.")
flags.DEFINE_integer("repeats", 10, "Timed steps per round.")
flags.DEFINE_integer("rounds", 3, "Rounds per measurement; the fastest is reported.")
flags.DEFINE_list("measure", ["lo", "ray", "hi", "nerf", "render", "methods"],
                  "Which steps to time (a subset for a quick sweep; the committed "
                  "measurements time all).")
flags.DEFINE_bool("trace", False, "Also trace `repeats` steps of each measured step with "
                  "jax.profiler and record where the device time goes (experiments/bench/trace_summary.py).")
flags.DEFINE_integer("peak_n", 2048, "Size n of the n x n x n fp32 matmul that measures the "
                     "peak (2048 fills 2 CPU cores; a GPU needs 8192).")


def _best_of_rounds(one_round):
  """Seconds per call: the best of `rounds` runs of one_round() (which makes
  `repeats` calls and waits for them), the least disturbed by whatever else
  the machine runs."""
  best = float("inf")
  for _ in range(FLAGS.rounds):
    t = time.perf_counter()
    one_round()
    best = min(best, (time.perf_counter() - t) / FLAGS.repeats)
  return best


def _time(fn, *args):
  jax.block_until_ready(fn(*args))
  return _best_of_rounds(lambda: jax.block_until_ready([fn(*args)
                                                        for _ in range(FLAGS.repeats)]))


def _flops(fn, *args):
  """XLA's flop count of fn(*args) (fn jitted here, whatever it calls jitted
  inside). fn is built from models with XLA's sin and cos (as_xla): the
  polynomials that replace them (halo_jax/trig.py) do more multiply-adds,
  which are not useful work."""
  cost = jax.jit(fn).lower(*args).compile().cost_analysis()
  cost = cost[0] if isinstance(cost, (list, tuple)) else cost
  return float(cost.get("flops", 0.0))


def matmul_peak(n, dtype=jnp.float32):
  """GFLOP/s of an n x n x n matmul at JAX's default precision (the
  precision the training steps use: TF32 on recent NVIDIA GPUs), of fp32
  operands, or of bfloat16 ones with fp32 sums (models.dense's form). Random
  operands: constant ones or zeros can run faster than real data."""
  ka, kb = jax.random.split(jax.random.PRNGKey(0))
  a = jax.random.normal(ka, (n, n), jnp.float32).astype(dtype)
  b = jax.random.normal(kb, (n, n), jnp.float32).astype(dtype)
  mm = jax.jit(lambda a, b: jnp.dot(a, b, preferred_element_type=jnp.float32))
  return 2.0 * n ** 3 / _time(mm, a, b) / 1e9


def _rays(n, key=0):
  o, d = camera.random_hemisphere_rays(jax.random.PRNGKey(key), n, 4.03, 0.7)
  return np.asarray(o), np.asarray(d)


def as_xla(config):
  """A copy of config whose models evaluate sin and cos with XLA's own
  functions: the form FLOPs are counted on."""
  return frozen.replaced(config, {"sin_cos": "xla"})


def step_throughput(loss_fn, cfg, params, data, rays_per_step, samples_per_ray, flops_loss_fn):
  """Times loss_fn's training step; its FLOPs are counted on flops_loss_fn,
  the same loss on models with XLA's sin and cos (as_xla)."""
  tx = train_step.optimizer(cfg)
  step = train_step.make_step(loss_fn, tx, cfg.microbatches)
  params = jax.tree_util.tree_map(jnp.copy, params)  # the step donates its input
  state = train_step.initial_state(params, tx)
  key = jax.random.PRNGKey(0)
  # XLA counts a scan's body once, so FLOPs come from the whole-batch step:
  # the parts do the same arithmetic.
  flops = _flops(train_step.make_step(flops_loss_fn, tx), state, data, key)
  fn = lambda s: step(s, data, key)
  # Donation consumes the state, so time chains of steps.
  state, _, _ = fn(state)
  jax.block_until_ready(state)
  def one_round():
    nonlocal state
    for _ in range(FLAGS.repeats):
      state, loss, _ = fn(state)
    float(loss)
  dt = _best_of_rounds(one_round)
  r = {"s_per_step": dt, "microbatches": cfg.microbatches, "rays_per_s": rays_per_step / dt,
       "samples_per_s": rays_per_step * samples_per_ray / dt, "gflops": flops / 1e9,
       "gflops_per_s": flops / dt / 1e9}
  if FLAGS.trace:
    r["trace"] = trace_summary.profile(one_round, FLAGS.repeats)
  return r


def render_throughput(c, rf, rf_params, o, d, rf_xla):
  """A held-out render chunk of config c's Hi field with its own sampler
  (forward only; guided by `rf` where the sampler reads a guide; a coarse
  field of its own where it has one), its FLOPs counted with `rf_xla` and an
  Hi field of as_xla(c)."""
  near, far = c.data.near, c.data.far
  sc = c.hi.sampler
  model = models.nerf_from_config(c, "hi")
  eval_fn = lambda m, g, b: raycast.make_eval_fn(  # pylint: disable=unnecessary-lambda-assignment
      m, sc, near=near, far=far, white_background=True, guide_model=g, radius=4.03,
      block_rays=b)
  guided = samplers.SAMPLERS.get(sc.kind).guided
  ev = {c.eval.block_rays: eval_fn(model, rf if guided else None, c.eval.block_rays),
        0: eval_fn(models.nerf_from_config(as_xla(c), "hi"), rf_xla if guided else None, 0)}
  hp = models.init_nerf(model, c.hi.model.kind, 0)
  coarse = models.init_nerf(model, c.hi.model.kind, 1) if sc.get("coarse_model") else None
  chunk = c.eval.chunk
  oc, dc = jnp.asarray(o[:chunk]), jnp.asarray(d[:chunk])
  g = rf_params if guided else None
  fn = functools.partial(ev[c.eval.block_rays], coarse_params=coarse)
  dt = _time(fn, hp, g, oc, dc)
  # blocks: the same arithmetic, counted once
  fl = _flops(functools.partial(ev[0], coarse_params=coarse), hp, g, oc, dc)
  points = sc.num_samples + (sc.num_coarse if samplers.SAMPLERS.get(sc.kind).importance else 0)
  r = {"s_per_step": dt, "block_rays": c.eval.block_rays, "rays_per_s": chunk / dt,
       "samples_per_s": chunk * points / dt,
       "gflops": fl / 1e9, "gflops_per_s": fl / dt / 1e9}
  if FLAGS.trace:
    r["trace"] = trace_summary.profile(
        lambda: jax.block_until_ready([fn(hp, g, oc, dc) for _ in range(FLAGS.repeats)]),
        FLAGS.repeats)
  return r


def main(argv):
  del argv
  logging.set_verbosity(logging.WARNING)
  config = config_of_flags(FLAGS["config"], "halo")
  measure_all(config)


def measure_all(c):
  """Times each stage's step and a render chunk of config `c` (HALO's); writes
  and prints the result file."""
  overrides = config_files.dotted_fields(config_flags.get_override_values(FLAGS["config"]))
  near, far = c.data.near, c.data.far
  n_data = 80000
  o, d = _rays(n_data)
  rgb = np.random.default_rng(0).uniform(size=(n_data, 3)).astype(np.float32)
  index = {"crop_idx": np.arange(n_data, dtype=np.int32), "crop_pix": np.arange(64, dtype=np.int32),
           "view_pixels": np.full((), n_data, np.int32),
           "fg_idx": np.arange(n_data, dtype=np.int32)}   # Lo's foreground start draws from it
  pixels = Pixels(Rays(o, d), rgb, index)
  peak = matmul_peak(FLAGS.peak_n)  # measured again at the end; the larger is the peak
  results = {"peak_gflops": peak, "device": str(jax.devices()[0]), "steps": {}}

  def nerf_step(label, config, name, guide=None, wanted=None):
    if not (label in FLAGS.measure if wanted is None else wanted):
      return
    cfg = config[name]
    model = models.nerf_from_config(config, name)
    guide_model = guide_xla = guide_params = None
    if cfg.sampler.kind == "depth_guided":
      guide_model, guide_xla, guide_params = guide
    prepared = {}
    if "empty" in cfg and cfg.empty.weight > 0:
      prepared["empty"] = terms.EmptyBank(Rays(o, d), np.zeros(n_data, np.float32),
                                          np.arange(n_data, dtype=np.int32))
    data = batches.StageData(pixels, prepared, guide_params)
    loss = lambda m, g: functools.partial(radiance.loss_fn, s=radiance.loss_settings(  # pylint: disable=unnecessary-lambda-assignment
        cfg, m, near=near, far=far, white=True, radius=4.03, guide_model=g))
    lf, lf_xla = loss(model, guide_model), loss(models.nerf_from_config(as_xla(config), name),
                                                guide_xla)
    samples = cfg.sampler.num_samples + (cfg.sampler.num_coarse
                                         if cfg.sampler.kind in ("hierarchical", "coarse_fine")
                                         else 0)
    params = {"nerf": models.init_nerf(model, cfg.model.kind, 0)}
    r = step_throughput(lf, cfg, params, jax.device_put(data), cfg.batch_rays, samples, lf_xla)
    results["steps"][label] = r

  nerf_step("lo", c, "lo")
  rf = ray_fields.ray_field_from_config(c.ray, near, far, c.sin_cos)
  rf_xla = ray_fields.ray_field_from_config(c.ray, near, far, "xla")
  rf_params = {"ray": ray_fields.init_ray_field(rf, 0)}
  targets = Targets(Rays(o, d), np.full(n_data, 4.0, np.float32), np.ones(n_data, np.float32))
  rdata = ray.RayStageData(targets, targets)
  n_rand = int(round(c.ray.batch_rays * c.ray.random_fraction))
  ray_loss = lambda m: functools.partial(  # pylint: disable=unnecessary-lambda-assignment
      ray.loss_fn, model=m, guide_geometry=geometry.Geometry.SPHERE, radius=4.03, far=far,
      n_train=c.ray.batch_rays - n_rand, n_random=n_rand)
  if "ray" in FLAGS.measure:
    results["steps"]["ray"] = step_throughput(ray_loss(rf), c.ray, rf_params,
                                              jax.device_put(rdata), c.ray.batch_rays, 1,
                                              ray_loss(rf_xla))
  nerf_step("hi", c, "hi", guide=(rf, rf_xla, rf_params["ray"]))
  # the baseline with the command line's overrides too (a dtype, a size)
  nerf_step("nerf", config_of_flags(FLAGS["config"], "nerf_tuned"), "hi")
  if "render" in FLAGS.measure:  # held-out rendering with the Hi field
    results["steps"]["render"] = render_throughput(c, rf, rf_params["ray"], o, d, rf_xla)
  if "methods" in FLAGS.measure:  # every compared method: its output stage, trained and rendered
    for m in methods.with_role(methods.base.COMPARED):
      mc = config_of_flags(FLAGS["config"], m)
      nerf_step(f"{m} train", mc, "hi", guide=(rf, rf_xla, rf_params["ray"]), wanted=True)
      results["steps"][f"{m} render"] = render_throughput(mc, rf, rf_params["ray"], o, d, rf_xla)
  write_and_print(results, peak, overrides)


def write_and_print(results, peak, overrides):
  """Completes the result file (the larger of two peak measurements, the
  shares of it, the config, provenance), writes it and prints the table."""
  peak = results["peak_gflops"] = max(peak, matmul_peak(FLAGS.peak_n))
  # context for bfloat16 layers; every share stays against the fp32 peak
  results["peak_bf16_gflops"] = matmul_peak(FLAGS.peak_n, jnp.bfloat16)
  for r in results["steps"].values():
    r["share_of_peak"] = r["gflops_per_s"] / peak
  results["config"] = config_flags.get_config_filename(FLAGS["config"])
  results["overrides"] = {k: str(v) for k, v in overrides.items()}
  results["flags"] = {"repeats": FLAGS.repeats, "rounds": FLAGS.rounds, "peak_n": FLAGS.peak_n,
                      "measure": list(FLAGS.measure)}
  results["provenance"] = git_state.collect(measure_peak=False)
  path = throughput_report.result_path(FLAGS.results, results)
  run_file.write_json(path, results)
  print(f"matmul peak: {peak:.0f} GFLOP/s fp32, {results['peak_bf16_gflops']:.0f} bf16 "
        f"({results['device']})")
  print(f"{'step':7} {'ms':>7} {'rays/s':>9} {'samples/s':>11} {'GFLOP':>7} {'GFLOP/s':>8} {'peak':>6}")
  for name, r in results["steps"].items():
    print(f"{name:7} {1e3 * r['s_per_step']:7.1f} {r['rays_per_s']:9.0f} {r['samples_per_s']:11.0f} "
          f"{r['gflops']:7.2f} {r['gflops_per_s']:8.1f} {100 * r['share_of_peak']:5.1f}%")
  for name, r in results["steps"].items():
    if "trace" in r:
      print(trace_summary.format_summary(name, r["trace"]))
  print("wrote", path)


def cli():
  """The tool's entry point (python -m experiments.<tool>)."""
  tool.run(sys.modules[__name__], main)


if __name__ == "__main__":
  cli()
