"""HALO: Lo-NeRF -> ray field -> Hi-NeRF (or the scene kind's variant of it:
no ray field on dynamic scenes, one joint stage on light fields; the scene
configs build that protocol).

Two settings of the paper's own mechanisms are HALO's here, each chosen on
validation views (docs/results/ablation_fog.md, ablation_dnerf_hi.md).
Every HALO method (halo+freenerf, halo+unseen, halo_auto) applies them first.
- On static scenes that cameras surround, Lo-NeRF trains on whole images
  from its first step, without NeRF's centre crop. During the crop, Lo
  filled space with white fog that the training rays seeing the white
  background through it could not reject, and on one seed in two it never
  cleared.
- On dynamic scenes Hi-NeRF, started as Lo-NeRF's exact copy, trains at the
  paper's rate (5e-4 to 5e-5), not the CPU configs' fourfold rate, which
  suits fields trained from scratch (the baseline keeps it); at that rate
  Hi drifted below its start on the val frames.
"""
from halo_jax import datasets, geometry
from halo_jax.methods import base

COPY_LR = (5e-4, 5e-5)  # Hi-NeRF's rate after an exact copy of Lo, dynamic scenes


def apply(c):
  spec = datasets.spec_of(c.data)
  if spec.geometry == geometry.Geometry.SPHERE and not spec.dynamic and c.lo.kind == "radiance":
    c.lo.precrop_steps = 0
  if spec.dynamic and c.hi.init_from_lo:
    c.hi.lr_init, c.hi.lr_final = COPY_LR
  return c


METHOD = base.Method("HALO: a low-frequency field guides and regularises Hi-NeRF", apply)
