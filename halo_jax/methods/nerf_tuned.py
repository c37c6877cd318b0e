"""nerf_tuned: the NeRF baseline the CPU protocols were tuned with.

The scene's Hi-NeRF trained alone: stratified samples
(config.baseline.num_samples), softplus density with density noise 1.0, rays
drawn from all training images, the scene's centre crop, and no regulariser.
It is stronger than the original NeRF (methods/nerf_paper.py), which
collapses with few views. On 360-degree scenes at the CPU sizes it takes
the same chance as HALO's Hi there: twice its samples once it has trained
halo.SWITCH_STEP steps (the sampler switch, after the steps a short budget
allows), and its held-out views rendered with twice those again, which
pass the default rule for the baseline too
(docs/results/ablation_hi_window_960.md).
"""
from halo_jax.methods import base, halo


def parts_for(scene, samples: int, batch_rays: int) -> int:
  """The micro-batches that keep each part's samples (its cache footprint)
  as the scene's Hi-NeRF has them, at `samples` a ray."""
  parts = scene.hi.microbatches * samples // scene.hi.sampler.num_samples
  return parts if parts > 1 and batch_rays % parts == 0 else scene.hi.microbatches


TABLE = {
    "stages": "hi",
    "hi.sampler.kind": "stratified",
    "hi.sampler.num_samples": base.Derived(lambda c, scene: c.baseline.num_samples),
    "hi.microbatches": base.Derived(
        lambda c, scene: parts_for(scene, c.hi.sampler.num_samples, c.hi.batch_rays)),
    "hi.precrop_steps": base.Derived(lambda c, scene: c.lo.precrop_steps),
}


SPHERE = {**TABLE, **base.sample_switch(halo.SWITCH_STEP)}


METHOD = base.Method("NeRF, one MLP, stratified samples, softplus density, noise 1.0",
                     {**base.every_kind(TABLE), "sphere": SPHERE}, role=base.COMPARED)
