"""nerf_tuned: the NeRF baseline the CPU protocols were tuned with.

The scene's Hi-NeRF trained alone: stratified samples
(config.baseline.num_samples), softplus density with density noise 1.0, rays
drawn from all training images, the scene's centre crop, and no regulariser.
It is stronger than the original NeRF (methods/nerf_paper.py), which
collapses with few views.
"""
from halo_jax.methods import base


def _microbatches(c):
  """Keeps the samples in each micro-batch (its cache footprint) as the
  scene's Hi-NeRF has them, with the baseline's sample count."""
  parts = c.hi.microbatches * c.baseline.num_samples // c.hi.sampler.num_samples
  return parts if parts > 1 and c.hi.batch_rays % parts == 0 else c.hi.microbatches


TABLE = {
    "stages": "hi",
    "hi.sampler.kind": "stratified",
    "hi.microbatches": _microbatches,     # before the count it reads changes
    "hi.sampler.num_samples": lambda c: c.baseline.num_samples,
    "hi.precrop_steps": lambda c: c.lo.precrop_steps,
}


def apply(c):
  return base.set_fields(c, TABLE)


METHOD = base.Method("NeRF, one MLP, stratified samples, softplus density, noise 1.0", apply,
                     role=base.COMPARED)
