"""HALO (the paper's Figure 2): a low-frequency field guides and regularises
the high-frequency one. The scene's config gives the protocol (data, model
sizes, budgets); this module gives the method, per scene kind:

  kind       stages          what a stage hands the next        Hi-NeRF's sampler  loss terms
  sphere     lo -> ray -> hi Lo's depth trains the ray field;    depth_guided       L_rec + 0.1 L_empty
                             the ray field places Hi's samples;  doubled after      (Lo's opacity on
                             Lo's weights start Hi (budgeted)    2000 steps (CPU)   random rays)
  ndc        lo -> ray -> hi as sphere; the ray field learns     depth_guided,      L_rec
                             the training rays only              a quarter over
                                                                 the whole ray
  dynamic    lo -> hi        Lo's weights start Hi (exact copy); stratified         L_rec + 0.1 L_empty
                             Lo's opacity on random rays at                         (random times)
                             random times (querying Lo is cheap)
  two_plane  hi              a ray field trained with the        joint              L_rec + L_consist
                             radiance field places its samples

"Budgeted": under a training-time budget (the CPU protocols) Hi-NeRF starts
as an exact copy of Lo-NeRF (Lo's P.E. kept in Hi's input), since the few
thousand steps a budget allows do not bring a Hi-NeRF trained from scratch
back to where Lo already is; the paper's step counts train Hi from scratch.

Further settings of the paper's own mechanisms are HALO's here, each
chosen on validation views (docs/validation.md; docs/results/ablation_fog.md,
ablation_lo_start.md, ablation_dnerf_hi.md); every HALO method (halo+freenerf,
halo+unseen, halo_auto) applies them first:
- sphere: Lo-NeRF trains on whole images from its first step, without NeRF's
  centre crop: during the crop Lo filled space with white fog that the
  training rays, seeing the white background through it, could not reject.
  Instead, half of each batch of its first FG_STEPS steps comes from the
  pixels that are not the background: without that, on a small or thin
  object Lo could stay the empty field, which matches the white background
  everywhere but on the object.
- sphere: once Hi-NeRF has trained SWITCH_STEP steps, it trains with twice
  its samples in the window, where it has fewer than the baseline: a field
  trained long has a surface sharper than its 32 samples in the window
  resolve. Its held-out views are then rendered with twice those again,
  stratified over the whole ray (the baseline's sampler at its count): the
  window misses parts of a long-trained surface that Hi's field holds. The
  switch comes after the steps a short budget allows, so those runs are
  unchanged (base.sample_switch, sampler_switch.py;
  docs/results/ablation_hi_window_960.md).
- ndc: a quarter of Hi-NeRF's samples span the whole ray beside the window
  (FULL_FRACTION; the rest in the window, at the same cost): on a
  forward-facing scene the window misses the surface on a few percent of
  rays, which carry a large share of Hi's error, and Hi then ended below its
  own Lo (docs/results/ablation_hi_window_*.md; the 360-degree scenes, where
  the window holds the surface, lose by it). Lo-NeRF's P.E. has scale 1 at
  every size (NDC_LO_SCALE): NDC coordinates span [-1, 1], where the 360-degree
  scale of the paper-size configs (32: a top frequency of 0.5) leaves Lo
  nearly linear; on fern's frequency grid the held-out PSNR peaks at scale 1
  and falls 1.2 dB by a top frequency of 1 (results/frequency_val/fern_4view.json).
- dynamic: Hi-NeRF, started as Lo's exact copy, trains at the paper's rate
  (5e-4 to 5e-5), not the CPU configs' fourfold one, which suits fields
  trained from scratch (the baseline keeps it).
"""
from halo_jax import geometry
from halo_jax.methods import base

EMPTY_WEIGHT = 0.1        # lambda of L_empty
# The paper's per-protocol lambda (data.protocol): 0.01 on the one-side views.
PROTOCOL_EMPTY_WEIGHT = {"lego_oneside": 0.01}
COPY_LR = (5e-4, 5e-5)    # Hi-NeRF's rate after an exact copy of Lo, dynamic scenes
FG_STEPS, FG_FRACTION = 200, 0.5  # Lo-NeRF's foreground start, sphere scenes
DYNAMIC_SHARES = dict(lo=0.3, ray=0.0, hi=0.7)  # no ray stage to share the budget with
FULL_FRACTION = 0.25      # share of Hi's samples over the whole ray, ndc scenes
SWITCH_STEP = 2000        # Hi's step after which its samples double, sphere scenes
NDC_LO_SCALE = 1.0        # Lo-NeRF's P.E. scale on NDC coordinates, at every size


# data.protocol is the scene's list of views (the paper's 8-view or one-side)
_empty_weight = base.Derived(
    lambda c, scene: PROTOCOL_EMPTY_WEIGHT.get(c.data.protocol, EMPTY_WEIGHT))




def _on_white(value, field):
  """Lo's foreground start: only where the background is white (photos of a
  room have no background to tell from)."""
  return base.Derived(lambda c, scene: value if c.data.white_background else c.lo[field])


# The table above as data: per scene kind, the fields HALO sets on the
# scene's config (base.Table). `hi.copy_lo_under_budget` leaves
# the start to protocol.resolve, the one reader of the protocol, so the order
# in which the budget and the method are given does not matter.
KINDS = {
    "sphere": {
        "stages": "lo,ray,hi",
        "hi.sampler.kind": "depth_guided",
        # at the CPU sizes Hi has fewer samples than the baseline (32 in the
        # window against 64 over the ray); the paper's 128 outnumber its 64
        **base.sample_switch(SWITCH_STEP),
        "hi.empty.weight": _empty_weight,
        "lo.precrop_steps": 0,
        "lo.fg_steps": _on_white(FG_STEPS, "fg_steps"),
        "lo.fg_fraction": _on_white(FG_FRACTION, "fg_fraction"),
        "hi.copy_lo_under_budget": True,
    },
    "ndc": {
        "stages": "lo,ray,hi",
        "hi.sampler.kind": "depth_guided",
        # every ray hits the scene: no background to keep empty, and no
        # hemisphere of cameras to draw random rays from
        "hi.empty.weight": 0.0,
        "ray.random_fraction": 0.0,
        "ray.bank_rays": 0,
        "hi.sampler.num_full": base.Derived(
            lambda c, scene: int(c.hi.sampler.num_samples * FULL_FRACTION)),
        "lo.encoding.scale": NDC_LO_SCALE,
        "hi.copy_lo_under_budget": True,
    },
    "dynamic": {
        "stages": "lo,hi",
        **{f"budget_shares.{k}": v for k, v in DYNAMIC_SHARES.items()},
        "hi.init_from_lo": True,          # Hi starts as Lo's exact function
        "hi.encoding.with_lo": True,
        "hi.sampler.kind": "stratified",
        "hi.empty.weight": _empty_weight,
        # the baseline's centre crop, so that the two differ by Lo's help
        "hi.precrop_steps": base.Derived(lambda c, scene: c.lo.precrop_steps),
        "hi.lr_init": COPY_LR[0],
        "hi.lr_final": COPY_LR[1],
    },
    "two_plane": {
        "stages": "hi",
        "hi.sampler.kind": "joint",
        "hi.empty.weight": 0.0,           # every pixel is the scene: no background
    },
}
assert set(KINDS) == {"dynamic"} | {g.value for g in geometry.Geometry} == set(base.KINDS)


METHOD = base.Method("HALO: a low-frequency field guides and regularises Hi-NeRF", KINDS,
                     role=base.COMPARED)
