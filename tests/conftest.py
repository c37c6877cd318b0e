"""Shared fixtures: a tiny config on the procedural scene, sized for CPU tests."""
import atexit
import json
import os
import shutil
import tempfile

import numpy as np
import pytest

# One compilation cache for the session and the subprocesses it starts: the
# tests compile the same tiny steps again and again (each pipeline.run jits
# its own closures; each launched process starts cold).
if "JAX_COMPILATION_CACHE_DIR" not in os.environ:
  os.environ["JAX_COMPILATION_CACHE_DIR"] = tempfile.mkdtemp(prefix="halo_jax_test_xla_")
  atexit.register(shutil.rmtree, os.environ["JAX_COMPILATION_CACHE_DIR"], True)
os.environ.setdefault("JAX_PERSISTENT_CACHE_MIN_COMPILE_TIME_SECS", "0")
os.environ.setdefault("JAX_PERSISTENT_CACHE_MIN_ENTRY_SIZE_BYTES", "0")
# The tests' programs are tiny and mostly compiled once: XLA's backend
# optimisations cost more time than they save (about half of a step's
# compilation). Results are checked against references with tolerances, and
# runs compared with each other share the flag; benchmarks run without it.
FAST_COMPILE = "--xla_backend_optimization_level=0"
if FAST_COMPILE not in os.environ.get("XLA_FLAGS", ""):
  os.environ["XLA_FLAGS"] = f"{os.environ.get('XLA_FLAGS', '')} {FAST_COMPILE}".strip()

from halo_jax import defaults, methods

# Real scenes: $HALO_DATA, else ../shared/data beside the checkout; tests that
# need them skip when they are absent.
SHARED_DATA = os.environ.get(
    "HALO_DATA", os.path.join(os.path.dirname(__file__), "..", "..", "shared", "data"))


def tiny_config(method="halo"):
  """The procedural scene at test size, as `method` ('': the neutral NeRF a
  scene's config is before a method is applied)."""
  c = defaults.base_config()
  c.data.kind = "procedural"
  c.data.factor = 2          # 32x32 images
  c.data.procedural_size = 64
  c.data.train_views = "r_0,r_13,r_26,r_39"
  c.data.test_views = "r_0,r_100"
  c.eval.chunk = 1024
  c.eval.curve_views = 1
  for name in ("lo", "hi"):
    c[name].model.update(width=32, depth=2, skips=())
    c[name].sampler.update(num_samples=8, num_coarse=8)
    c[name].update(batch_rays=64, steps=6, checkpoint_every=3, log_every=2, eval_every=3,
                   precrop_steps=2)
  c.ray.model.update(width=32, depth=2, skips=())
  c.ray.update(batch_rays=64, steps=6, checkpoint_every=3, log_every=2, bank_rays=512)
  c.hi.empty.update(num_rays=16, num_samples=8, bank_rays=512)
  return methods.apply(c, method) if method else c


def pipeline_config(root, steps, parts=1, data_parallel=False):
  """tiny_config for a lo -> ray -> hi run on the scene at `root`, Hi started
  from Lo, every step logged, each step's batch run in `parts` parts."""
  c = tiny_config()
  c.data.root = root
  c.hi.encoding.with_lo = True
  c.hi.init_from_lo = True
  c.lo.precrop_steps = 2     # keeps the centre crop's code path in these runs
  c.parallel.data_parallel = data_parallel
  for name in ("lo", "ray", "hi"):
    c[name].update(steps=steps, log_every=1, microbatches=parts)
  return c


@pytest.fixture
def config():
  return tiny_config()


@pytest.fixture(scope="session")
def scene_root(tmp_path_factory):
  from halo_jax.datasets import procedural
  return procedural.generate(str(tmp_path_factory.mktemp("scene")), size=64)


def stage_losses(workdir, stage):
  """[(step, loss)] the stage logged while training (metrics.jsonl)."""
  with open(os.path.join(workdir, "metrics.jsonl")) as f:
    rows = [json.loads(line) for line in f]
  return [(r["step"], r["loss"]) for r in rows
          if r.get("stage") == stage and "loss" in r and not r.get("heldout")]


def assert_trained(workdir, stage, config, margin_db=0.5):
  """The stage fits its training views better than any constant image can:
  the median of its last five logged training PSNRs, past its centre crop and
  foreground phase (whose batches are not drawn like the whole views), is
  `margin_db` above the best constant image of the training pixels. Learning
  the mean colour alone reaches that constant and no more."""
  from halo_jax import datasets
  from halo_jax.stages import collapse
  cfg = config[stage]
  after = max(cfg.get("precrop_steps", 0), cfg.get("fg_steps", 0))
  with open(os.path.join(workdir, "metrics.jsonl")) as f:
    rows = [json.loads(line) for line in f]
  psnr = [r["psnr"] for r in rows if r.get("stage") == stage and "psnr" in r
          and not r.get("heldout") and r["step"] > after]
  assert len(psnr) >= 2, f"{stage}: only {len(psnr)} training PSNRs logged past step {after}"
  constant = collapse.constant_psnr(datasets.load(config.data, "").train.images)
  end = float(np.median(psnr[-5:]))
  assert end >= constant + margin_db, (
      f"{stage}: training PSNR {end:.2f} dB, not {margin_db} dB above the constant "
      f"image's {constant:.2f}")


def assert_beats_constant_heldout(info, stage):
  """The stage's held-out render is its collapse margin better than the best
  constant image of those views (pipeline's 'heldout_learned'): it learned
  something that holds off its training views."""
  verdict = info["heldout_learned"]
  assert verdict["verdict"] == "learned", (
      f"{stage}: held-out PSNR {verdict['psnr']:.2f} dB, not {verdict['margin_db']} dB above "
      f"the best constant image's {verdict['constant_psnr']:.2f}")


def editable(scene, method, overrides=None):
  """configure.compose's config as a mutable copy, for a test that edits it
  by hand (then configure.finish makes it a run's value again)."""
  from halo_jax import configure, frozen
  return frozen.thaw(configure.compose(scene, method, overrides))


def resolved(config):
  """protocol.resolve of a mutable config with its stage graph (in place)."""
  from halo_jax import protocol
  from halo_jax.stages import order
  return protocol.resolve(config, order.graph(config))


# HALO_TOY_METHOD=1 registers test_new_method's toy (one module, one registry
# line) for the whole session: the suite must pass with a method added that
# no test names (python -m pytest -q tests with it set).
if os.environ.get("HALO_TOY_METHOD"):
  import test_new_method  # pylint: disable=g-import-not-at-top
  exec(compile(test_new_method.TOY, "toy_method.py", "exec"), {})  # pylint: disable=exec-used
