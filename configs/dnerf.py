"""D-NeRF dynamic scenes: time as a low-frequency input (SPEC.md sec. 5).

Variants (the string after the colon):
  lego        the paper's few-shot protocol (every 8th training image, the 20
              test views) with full-size models
  lego_cpu    the same views, CPU-sized models and a wall-clock budget
Append a method's name for that method (halo_jax.methods): `_nerf_tuned`
(alias `_nerf`: the same dynamic Hi model trained alone, without the Lo
model's regulariser and not started from it).

HALO here has no ray field (SPEC sec. 5: querying the Lo field is cheap): Lo is
a deformation field with low frequencies in x and t; Hi is the same model with
high frequencies, trained from scratch and regularised by L_empty on random
rays at random times.

The data defaults to $HALO_DATA/dnerf/tiny_dnerf_data.npz (lego at 100x100,
composited on black); a D-NeRF folder (transforms_*.json with 'time' per
frame) works too: --config.data.root=PATH --config.data.factor=8
--config.data.white_background=True.
"""
import os

from halo_jax import defaults, methods

CPU_BUDGET_S = 600.0


def _dynamic(c):
  """Both NeRF stages become deformation fields; the ray stage is left out."""
  c.stages = "lo,hi"
  for name in ("lo", "hi"):
    c[name].model.kind = "deform"
    c[name].model.use_viewdirs = False  # Lo has none; D-NeRF lego is nearly diffuse
  # SPEC sec. 5: the authors lower TiNeuVox's P.E. to 4 for x and 4 for t in Lo
  # (Hi: 10 and 8).
  c.lo.encoding.update(L=4, scale=1.0, time_L=4)
  c.hi.encoding.update(L=10, scale=1.0, time_L=8)
  # Hi trains from scratch, as the baseline does (precrop included), and Lo
  # acts only through L_empty (SPEC sec. 5). Started as a copy of Lo instead
  # (the static scenes' choice), Hi keeps Lo's errors on the frames Lo fits
  # worst (docs/dynamic.md).
  c.hi.init_from_lo = False
  c.hi.encoding.with_lo = False
  c.hi.precrop_steps = c.lo.precrop_steps
  c.hi.sampler.kind = "stratified"
  c.hi.sampler.num_samples = c.lo.sampler.num_samples
  # The baseline is the same Hi model with the same samples, minus Lo's help.
  c.baseline.num_samples = c.hi.sampler.num_samples
  return c


def get_config(arg: str = "lego"):
  parts, flags, method = methods.split_variant(arg)
  cpu = "cpu" in flags
  if parts != ["lego"]:
    raise ValueError(f"unknown variant {arg!r}: use lego or lego_cpu, optionally with a method name")
  c = defaults.base_config()
  c.data.update(kind="dnerf", factor=1, white_background=False, train_views="every:8",
                test_views="all",
                root=os.path.join(os.environ.get("HALO_DATA", "../shared/data"), "dnerf",
                                  "tiny_dnerf_data.npz"))
  # TiNeuVox-S: 20k steps of 4096 rays for the model HALO regularises.
  c.lo.update(steps=20000, batch_rays=4096)
  c.hi.update(steps=20000, batch_rays=4096)
  c.budget_shares.update(lo=0.3, ray=0.0, hi=0.7)
  if cpu:
    defaults.cpu_sized(c, CPU_BUDGET_S)
    c.budget_shares.update(lo=0.3, ray=0.0, hi=0.7)
    for name in ("lo", "hi"):
      c[name].model.update(deform_width=64, deform_depth=3)
  _dynamic(c)
  c.eval.chunk = 10000
  return methods.apply(c, method)
