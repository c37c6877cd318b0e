"""Random draws keyed per ray, so a batch run in parts draws what it draws whole.

A training step may cut its ray batch into parts (micro-batches, which keep
each part's activations in cache). With one key per ray, row r of every draw
comes from key r alone, so the parts see exactly the numbers the whole batch
would. `key` below is one PRNG key (uint32 [2]) or per-ray keys (uint32
[R, 2]); with per-ray keys `shape[0]` must be R.
"""
import enum

import jax


class Stream(enum.IntEnum):
  """Offsets added to `config.seed` for the run's independent host-side
  draws, one per purpose, so that no two purposes share a stream by accident.
  (Model initialisation and the per-step keys use `config.seed` itself.)"""
  EMPTY_BANK = 1       # L_empty's bank of random rays (stages/terms.py)
  RAY_RANDOM_BANK = 2  # the ray field's random hemisphere rays (stages/ray.py)
  RAY_TARGET_RAYS = 3  # which training rays Lo-NeRF labels for the ray field
  UNSEEN_BANK = 5      # L_unseen's bank of points (stages/unseen.py)
  TEACH_BANK = 6       # L_teach's bank of random rays (stages/teach.py)


def stream_seed(seed: int, stream: Stream) -> int:
  """The seed of `stream` in a run seeded `seed`."""
  return seed + int(stream)


def is_per_ray(key) -> bool:
  return key.ndim == 2


def split(key, num: int):
  """`num` keys (each one key, or [R, 2] per-ray keys like `key`)."""
  if is_per_ray(key):
    keys = jax.vmap(lambda k: jax.random.split(k, num))(key)  # [R, num, 2]
    return [keys[:, i] for i in range(num)]
  return list(jax.random.split(key, num))


def uniform(key, shape, minval=0.0, maxval=1.0):
  """Uniform draws of `shape` in [minval, maxval)."""
  if is_per_ray(key):
    _check_rows(key, shape)
    return jax.vmap(lambda k: jax.random.uniform(k, shape[1:], minval=minval,
                                                 maxval=maxval))(key)
  return jax.random.uniform(key, shape, minval=minval, maxval=maxval)


def normal(key, shape):
  """Standard normal draws of `shape`."""
  if is_per_ray(key):
    _check_rows(key, shape)
    return jax.vmap(lambda k: jax.random.normal(k, shape[1:]))(key)
  return jax.random.normal(key, shape)


def _check_rows(key, shape):
  if not shape or shape[0] != key.shape[0]:
    raise ValueError(f"per-ray keys [{key.shape[0]}, 2] cannot draw shape {tuple(shape)}: "
                     "its first axis must be the rays")
