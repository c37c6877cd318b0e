"""A step's batch run in equal parts (`<stage>.microbatches`): the part a loss
reads, and the check that the parts divide the batch."""
import jax

from halo_jax import parallel


def part_of(x, part):
  """Part i of `num` equal parts of x [B, ...] along its first axis (x itself
  when part is None). part = (i, num), i may be traced; num divides B."""
  if part is None:
    return x
  i, num = part
  size = x.shape[0] // num
  return jax.lax.dynamic_slice_in_dim(x, i * size, size)


def check_parts(cfg, batch: int, what: str, mesh=None) -> None:
  """Raises unless cfg.microbatches splits `batch` (and each part splits over
  the data-parallel mesh)."""
  parts = cfg.microbatches
  if parts < 1 or batch % parts:
    raise ValueError(f"microbatches={parts} does not divide {what}={batch}")
  parallel.check_batch(mesh, batch // parts,
                       what if parts == 1 else f"{what}/microbatches")
