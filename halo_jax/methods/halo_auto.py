"""HALO with Lo-NeRF's P.E. frequency chosen by the frequency rule
(halo_jax/frequency/tuning.py) instead of set by hand: the search runs once in the
run's workdir before training, outside the training budget."""
from halo_jax import geometry
from halo_jax.methods import base, halo


METHOD = base.Method("HALO, Lo-NeRF's frequency chosen by the frequency rule",
                     base.on_top_of(halo.METHOD, base.every_kind({"lo.encoding.auto": True})),
                     geometries=geometry.SPATIAL)
