"""freenerf: FreeNeRF (Yang, Pavone, Wang, CVPR 2023), its Blender 8-view setting.

The original NeRF (methods/nerf_paper.py; FreeNeRF's Blender code is the
DietNeRF code base's NeRF with the same settings) plus its two terms:
- frequency regularisation: a mask on the P.E. bands of points and view
  directions that opens linearly, one band after another, until 90% of the
  training steps (their reg_end_ratio 0.9); models.band_weights;
- occlusion regularisation: the mean density of the 20 samples nearest the
  camera, weight 0.01 (their Blender configs' weight and near range);
  losses.occlusion. Their code notes that on Blender it matters little.
"""
from halo_jax import geometry
from halo_jax.methods import base, nerf_paper

FREQ_REG_END = 0.9
OCCLUSION_WEIGHT = 0.01
OCCLUSION_NUM_NEAR = 20


TABLE = {"hi.freq_reg.end": FREQ_REG_END, "hi.occlusion.weight": OCCLUSION_WEIGHT,
         "hi.occlusion.num_near": OCCLUSION_NUM_NEAR}

METHOD = base.Method("FreeNeRF: the paper's NeRF with a P.E. mask that opens over 90% of "
                     "training and an occlusion loss",
                     base.on_top_of(nerf_paper.METHOD, base.every_kind(TABLE)),
                     geometries=geometry.SPATIAL, role=base.COMPARED)
