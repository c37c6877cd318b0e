"""HALO: Lo-NeRF -> ray field -> Hi-NeRF (or the scene kind's variant of it:
no ray field on dynamic scenes, one joint stage on light fields; the scene
configs build that protocol).

One setting of the paper's own mechanisms is HALO's here, chosen on the val
frames (docs/results/ablation_dnerf_hi.md): on dynamic scenes Hi-NeRF,
started as Lo-NeRF's exact copy, trains at the paper's rate (5e-4 to
5e-5), not the CPU configs' fourfold rate, which suits fields trained from
scratch (the baseline keeps it); at that rate Hi drifted below its start.
Every HALO method (halo+freenerf, halo+unseen, halo_auto) applies this first.
"""
from halo_jax import datasets
from halo_jax.methods import base

COPY_LR = (5e-4, 5e-5)  # Hi-NeRF's rate after an exact copy of Lo, dynamic scenes


def apply(c):
  if datasets.spec_of(c.data).dynamic and c.hi.init_from_lo:
    c.hi.lr_init, c.hi.lr_final = COPY_LR
  return c


METHOD = base.Method("HALO: a low-frequency field guides and regularises Hi-NeRF", apply)
