"""nerf_paper: the original NeRF (Mildenhall et al. 2020), as the HALO paper's
NeRF row reports it (taken from DietNeRF's table).

From the NeRF authors' Blender settings: two MLPs, a coarse one with 64
stratified samples and a fine one with 128 importance samples composited
together with the coarse ones; ReLU density; no density noise on 360-degree
scenes (1.0 on forward-facing ones, as their LLFF settings); view
directions; 1024 rays per step from one training image; a centre crop of 0.5
for the first 500 steps; Adam 5e-4 decaying 10x per 500k steps; both passes'
L_rec weighted 1. The model width and depth are the scene config's (the
paper's 8x256 in the full protocols, the CPU size in *_cpu ones), so that
the comparison is of the method, not of the model size.
"""
from halo_jax import geometry
from halo_jax.methods import base, nerf_tuned

RAYS_PER_STEP = 1024


def _microbatches(c, scene):
  """~4x nerf_tuned's samples per ray: 4x nerf_tuned's parts keeps each
  part's activations the same size (CPU cache; see defaults.cpu_sized)."""
  m = nerf_tuned.parts_for(scene, c.baseline.num_samples, scene.hi.batch_rays)
  return min(4 * m, RAYS_PER_STEP // 16) if m > 1 else m


def _table(density_noise: float):
  return {
    "hi.sampler.kind": "coarse_fine",
    "hi.sampler.num_coarse": 64,
    "hi.sampler.num_samples": 128,
    "hi.sampler.coarse_model": True,
    "hi.sampler.coarse_weight": 1.0,
    "hi.model.density_activation": "relu",
    "hi.model.density_bias": 0.0,
    "hi.model.use_viewdirs": True,
    "hi.density_noise": density_noise,
    "hi.batch_rays": RAYS_PER_STEP,
    "hi.one_image": True,
    "hi.precrop_steps": 500,
    "hi.precrop_frac": 0.5,
    "hi.lr_init": 5e-4,
    "hi.lr_final": 5e-5,
    "hi.lr_decay_steps": 500000,
    "hi.microbatches": base.Derived(_microbatches),
}


# nerf_tuned's Hi-NeRF alone (without the sampler switch, our baseline's own),
# then these; density noise on forward-facing scenes only
TABLES = {k: {**nerf_tuned.TABLE, **_table(1.0 if k == "ndc" else 0.0)} for k in base.KINDS}

METHOD = base.Method("NeRF as published: coarse + fine MLPs, ReLU density, one image a step",
                     TABLES, geometries=geometry.SPATIAL, role=base.COMPARED)
