"""nerf_tuned: the NeRF baseline the CPU protocols were tuned with.

The scene's Hi-NeRF trained alone: stratified samples
(config.baseline.num_samples), softplus density with density noise 1.0, rays
drawn from all training images, the scene's centre crop, and no regulariser.
It is stronger than the original NeRF (methods/nerf_paper.py), which
collapses with few views.
"""
from halo_jax.methods import base


def apply(c, num_samples: int = 0):
  c.stages = "hi"
  c.hi.sampler.kind = "stratified"
  hi_samples = c.hi.sampler.num_samples
  c.hi.sampler.num_samples = num_samples or c.baseline.num_samples
  # Keep the samples in each micro-batch (its cache footprint) as Hi-NeRF's.
  parts = c.hi.microbatches * c.hi.sampler.num_samples // hi_samples
  if parts > 1 and c.hi.batch_rays % parts == 0:
    c.hi.microbatches = parts
  c.hi.precrop_steps = c.lo.precrop_steps
  return c


METHOD = base.Method("NeRF, one MLP, stratified samples, softplus density, noise 1.0", apply,
                     role=base.COMPARED)
