"""halo+teach: HALO with the frozen Lo-NeRF as Hi-NeRF's teacher for the whole
of Hi's run (L_teach, stages/teach.py).

HALO unchanged, plus one term on Hi-NeRF: on random rays where Lo-NeRF is
sure of a surface (opaque on the ray and on its neighbour in time or
direction, at nearly the same depth), Hi's depth and opacity follow Lo's,
with a weight that falls linearly to 0 at Hi's last step. On sphere rays
only (360-degree scenes, static and dynamic), where L_empty's random rays
are; D-NeRF is where Hi falls below its own Lo (docs/results/budget_study.md).
A candidate, run on request (the `lo_teacher` study), not a default.
"""
from halo_jax.methods import base, halo

WEIGHT = 0.1

_TERM = {"hi.teach.weight": WEIGHT}

METHOD = base.Method("HALO with L_teach: Hi's depth and opacity follow Lo's where Lo is sure, "
                     "fading out over Hi's run",
                     base.on_top_of(halo.METHOD, {"sphere": _TERM, "dynamic": _TERM}))
