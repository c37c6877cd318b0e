"""How fast the paper-size MLP's matrix products can run on this device.

The profile of the paper-size Hi step (docs/throughput.md) puts most of its
time in the products of 256-wide layers over ~393k points (3072 rays x 128
samples). This script measures, in one process, what bounds them:

  peak        an n x n x n fp32 matmul (XLA's default precision: TF32 on a GPU)
  gemm        one layer-shaped product [points, 256] x [256, 256], fp32 and bf16
              operands: the ceiling of any MLP built from separate GEMMs
  mlp         forward + backward of an 8x256 ReLU MLP with a skip (the paper's
              Hi trunk, 63 P.E. inputs, 4 outputs), three ways:
                xla         plain jnp layers, XLA free to fuse the ReLU mask
                            into its GEMMs (what flax's Dense gives)
                split_vjp   each layer a custom_vjp whose backward materialises
                            the masked gradient behind an optimization
                            barrier, so every product is a plain GEMM
                bf16        plain layers with bfloat16 operands, fp32 sums

Each figure is the median of --repeats timed calls after a warm-up, reported
as ms and as TFLOP/s against the measured peak. Writes --out (JSON).

  python -m experiments.dense_bench --points=393216 --out=/tmp/dense.json
"""
import functools
import json
import statistics
import time

from absl import app, flags
import jax
import jax.numpy as jnp

FLAGS = flags.FLAGS


def define_flags():
  """Defined on launch, not on import (the tests import this module beside others)."""
  flags.DEFINE_integer("points", 393216, "rows of every product (rays x samples)")
  flags.DEFINE_integer("width", 256, "layer width")
  flags.DEFINE_integer("peak_n", 8192, "n of the n x n x n matmul that measures the peak")
  flags.DEFINE_integer("repeats", 20, "timed calls per figure")
  flags.DEFINE_string("out", "", "JSON file for the figures ('' : print only)")


IN_FEATURES = 63   # 3 + 3 x 2 x 10: P.E. with L = 10
DEPTH = 8
SKIP = 4           # the input joins the 5th layer's input, as in NeRF


def _time(fn, *args):
  """Median seconds of fn(*args) (compiled and warmed first)."""
  jax.block_until_ready(fn(*args))
  times = []
  for _ in range(FLAGS.repeats):
    start = time.perf_counter()
    jax.block_until_ready(fn(*args))
    times.append(time.perf_counter() - start)
  return statistics.median(times)


def _layer_shapes(width):
  """[(fan_in, fan_out)] of the trunk, the skip widening the 5th layer."""
  shapes = []
  for i in range(DEPTH):
    fan_in = IN_FEATURES if i == 0 else width + (IN_FEATURES if i == SKIP else 0)
    shapes.append((fan_in, width))
  return shapes + [(width, 4)]


def mlp_flops(points, width):
  """Forward + backward FLOPs of the products: 3 x 2 x points x sum(fan_in x fan_out)."""
  return 6 * points * sum(a * b for a, b in _layer_shapes(width))


def init_params(key, width):
  params = []
  for fan_in, fan_out in _layer_shapes(width):
    key, sub = jax.random.split(key)
    params.append((jax.random.normal(sub, (fan_in, fan_out)) * (2.0 / fan_in) ** 0.5,
                   jnp.zeros((fan_out,))))
  return params


def dense_relu_xla(x, w, b):
  return jax.nn.relu(x @ w + b)


@jax.custom_vjp
def dense_relu_split(x, w, b):
  return jax.nn.relu(x @ w + b)


def _split_fwd(x, w, b):
  y = jax.nn.relu(x @ w + b)
  return y, (x, w, y > 0)


def _split_bwd(res, g):
  x, w, mask = res
  # materialised before the products, so neither GEMM takes the mask as a fused prologue
  gm = jax.lax.optimization_barrier(jnp.where(mask, g, 0.0))
  return gm @ w.T, x.T @ gm, gm.sum(0)


dense_relu_split.defvjp(_split_fwd, _split_bwd)


def mlp(params, x, layer, dtype):
  """[points, 63] -> [points, 4] through the trunk; `layer` computes one hidden layer."""
  inputs = x
  h = x
  for i, (w, b) in enumerate(params[:-1]):
    if i == SKIP:
      h = jnp.concatenate([h, inputs], -1)
    h = layer(h.astype(dtype), w.astype(dtype), b.astype(dtype)).astype(jnp.float32)
  w, b = params[-1]
  return h @ w + b


def loss(params, x, target, layer, dtype):
  return jnp.mean((mlp(params, x, layer, dtype) - target) ** 2)


def main(argv):
  del argv
  n, width = FLAGS.points, FLAGS.width
  key = jax.random.PRNGKey(0)
  results = {"device": str(jax.devices()[0]), "points": n, "width": width,
             "jax": jax.__version__}

  a = jax.random.normal(key, (FLAGS.peak_n, FLAGS.peak_n))
  peak_s = _time(jax.jit(lambda a: a @ a), a)
  peak = 2 * FLAGS.peak_n ** 3 / peak_s / 1e12
  results["peak_tflops"] = peak
  print(f"peak ({FLAGS.peak_n}^3 fp32 matmul): {peak:.1f} TFLOP/s")

  x = jax.random.normal(key, (n, width))
  w = jax.random.normal(key, (width, width)) / width ** 0.5
  for name, dtype in (("gemm_fp32", jnp.float32), ("gemm_bf16", jnp.bfloat16)):
    s = _time(jax.jit(lambda x, w: x @ w), x.astype(dtype), w.astype(dtype))
    tf = 2 * n * width * width / s / 1e12
    results[name] = {"ms": s * 1e3, "tflops": tf, "share_of_peak": tf / peak}
    print(f"{name} [{n},{width}]x[{width},{width}]: {s * 1e3:.3f} ms, {tf:.1f} TFLOP/s, "
          f"{100 * tf / peak:.0f}% of peak")

  params = init_params(key, width)
  xin = jax.random.normal(key, (n, IN_FEATURES))
  target = jax.random.normal(key, (n, 4))
  flops = mlp_flops(n, width)
  for name, layer, dtype in (("mlp_xla", dense_relu_xla, jnp.float32),
                             ("mlp_split_vjp", dense_relu_split, jnp.float32),
                             ("mlp_bf16", dense_relu_xla, jnp.bfloat16)):
    step = jax.jit(jax.grad(functools.partial(loss, layer=layer, dtype=dtype)))
    s = _time(step, params, xin, target)
    tf = flops / s / 1e12
    results[name] = {"ms": s * 1e3, "tflops": tf, "share_of_peak": tf / peak}
    print(f"{name}: forward + backward {s * 1e3:.3f} ms, {tf:.1f} TFLOP/s, "
          f"{100 * tf / peak:.0f}% of peak")
  if FLAGS.out:
    with open(FLAGS.out, "w") as f:
      json.dump(results, f, indent=1)


if __name__ == "__main__":
  define_flags()
  app.run(main)
