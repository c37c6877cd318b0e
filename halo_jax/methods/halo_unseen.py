"""halo+unseen: HALO with L_unseen on Lo-NeRF and Hi-NeRF (stages/unseen.py).

HALO's L_empty keeps Hi-NeRF empty where Lo-NeRF is empty, but nothing keeps
Lo-NeRF from filling space with fog that the training rays cannot see (white
on a white background), and Hi-NeRF, started as Lo's copy, keeps it. This
method adds one term to both NeRF stages: the mean density at random points
that no training camera sees. The low-frequency field carries that push to
the fog beside those points (docs/results/ablation_fog.md). Only where held-out cameras surround the object (sphere
rays); on forward-facing and light-field scenes every point a test view sees
is in a training frustum, and the method is HALO unchanged.
"""
from halo_jax.methods import base, halo

WEIGHT = 0.01

# Sphere rays: the 360-degree scenes, static ('sphere') and in time ('dynamic').
_TERM = {"lo.unseen.weight": WEIGHT, "hi.unseen.weight": WEIGHT}

METHOD = base.Method("HALO with L_unseen: Lo and Hi kept empty where no training camera looks",
                     base.on_top_of(halo.METHOD, {"sphere": _TERM, "dynamic": _TERM}),
                     role=base.REPORTED)
