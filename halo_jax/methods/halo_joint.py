"""halo_joint: HALO's joint scheme on 3D scenes (the paper's LLFF variant).

Lo-NeRF, then Hi-NeRF trained together with a low-frequency ray field that
follows Lo-NeRF's depth (L_consist) and places Hi's samples in a window that
narrows from the whole ray to HALO's two-stage window r (sampler 'joint'),
so the two schemes differ only in training the ray field with Hi.
"""
from halo_jax import geometry
from halo_jax.methods import base, halo


TABLE = {"stages": "lo,hi", "hi.sampler.kind": "joint",
         "hi.joint.alpha_final": base.Derived(lambda c, scene: c.hi.sampler.window)}

METHOD = base.Method("HALO's joint scheme: the ray field trained with Hi-NeRF",
                     base.on_top_of(halo.METHOD, base.every_kind(TABLE)),
                     geometries=geometry.SPATIAL,
                     dynamic=False)
