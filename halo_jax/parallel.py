"""Data parallelism with jax.sharding: one mesh axis over the ray batch.

Parameters, optimiser state and the training-ray bank are replicated on every
device; each step's batch of rays is sharded over the 'batch' axis with a
sharding constraint right after it is drawn, so XLA partitions every per-ray
computation and all-reduces the gradients. The maths is the single-device
step's; only the order of the final reductions differs.

Multi-host (`parallel.multihost=True`): `jax.distributed.initialize` joins the
processes before any device is used, and the mesh spans every process's
devices.
"""
from typing import Optional

import jax
import numpy as np
from jax.sharding import Mesh, NamedSharding, PartitionSpec

BATCH = "batch"


def initialize(cfg) -> None:
  """Joins a multi-process job when cfg.multihost (coordinator from cfg or the
  cluster's environment); a no-op otherwise.

  CPU processes reduce over gloo. A process whose peer stops sending
  heartbeats for cfg.heartbeat_s seconds is terminated by the JAX
  distributed service with a message saying another task died, so a lost
  peer ends the job instead of hanging it.
  """
  if not cfg.multihost:
    return
  jax.config.update("jax_cpu_collectives_implementation", "gloo")
  kwargs = dict(heartbeat_timeout_seconds=int(cfg.heartbeat_s))
  if cfg.coordinator:
    kwargs.update(coordinator_address=cfg.coordinator, num_processes=cfg.num_processes,
                  process_id=cfg.process_id)
  jax.distributed.initialize(**kwargs)


def is_primary() -> bool:
  """Whether this process writes the job's files (process 0)."""
  return jax.process_index() == 0


def to_local(tree):
  """Arrays replicated over several processes' devices as this process's
  copy, so that host-side code (rendering, saving, the next stage) can use
  them; other leaves unchanged."""
  def local(x):
    if isinstance(x, jax.Array) and not x.is_fully_addressable:
      return x.addressable_data(0)
    return x
  return jax.tree_util.tree_map(local, tree)


def make_mesh(cfg) -> Optional[Mesh]:
  """A 1-D mesh over all devices when cfg.data_parallel, else None (one device)."""
  if not cfg.data_parallel:
    return None
  return Mesh(np.asarray(jax.devices()), (BATCH,))


def check_batch(mesh: Optional[Mesh], batch: int, what: str) -> None:
  if mesh is not None and batch % mesh.size:
    raise ValueError(f"{what}={batch} is not divisible by the {mesh.size} devices of the "
                     "data-parallel mesh")


def replicate(tree, mesh: Optional[Mesh]):
  """Places every leaf of `tree` on every device of `mesh` (identity without one)."""
  if mesh is None:
    return tree
  if jax.process_count() > 1:
    # every process holds the same values; each places them on its devices
    tree = jax.tree_util.tree_map(np.asarray, tree)
  return jax.device_put(tree, NamedSharding(mesh, PartitionSpec()))


def shard_batch(x, mesh: Optional[Mesh]):
  """Constrains x [B, ...] to be split over the mesh's batch axis (inside jit)."""
  if mesh is None:
    return x
  return jax.lax.with_sharding_constraint(x, NamedSharding(mesh, PartitionSpec(BATCH)))
