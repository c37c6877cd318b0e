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
  """Joins a multi-host job when cfg.multihost (coordinator from cfg or the
  cluster's environment); a no-op otherwise."""
  if not cfg.multihost:
    return
  kwargs = {}
  if cfg.coordinator:
    kwargs = dict(coordinator_address=cfg.coordinator, num_processes=cfg.num_processes,
                  process_id=cfg.process_id)
  jax.distributed.initialize(**kwargs)


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
  return jax.device_put(tree, NamedSharding(mesh, PartitionSpec()))


def shard_batch(x, mesh: Optional[Mesh]):
  """Constrains x [B, ...] to be split over the mesh's batch axis (inside jit)."""
  if mesh is None:
    return x
  return jax.lax.with_sharding_constraint(x, NamedSharding(mesh, PartitionSpec(BATCH)))
