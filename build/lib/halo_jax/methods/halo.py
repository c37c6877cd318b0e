"""HALO: Lo-NeRF -> ray field -> Hi-NeRF (or the scene kind's variant of it:
no ray field on dynamic scenes, one joint stage on light fields). The scene
configs are written as HALO's protocol, so this method changes nothing."""
from halo_jax.methods import base

METHOD = base.Method("HALO: a low-frequency field guides and regularises Hi-NeRF",
                     lambda c: c)
