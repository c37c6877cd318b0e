"""halo+freenerf: HALO with FreeNeRF's frequency schedule on Hi-NeRF's own P.E.

The two regularise different things (HALO: where the density may be, from a
low-frequency field; FreeNeRF: which frequencies the field may use, early in
training), so they can be combined; no published work does. Lo-NeRF's part
of Hi-NeRF's encoding (hi.encoding.with_lo) is left unmasked: it is low
frequency already.
"""
from halo_jax.methods import base, freenerf, halo


TABLE = {"hi.freq_reg.end": freenerf.FREQ_REG_END}

METHOD = base.Method("HALO with FreeNeRF's P.E. schedule on Hi-NeRF",
                     base.on_top_of(halo.METHOD, base.every_kind(TABLE)), role=base.COMPARED)
