"""The two-plane light-field stage's fields: a radiance stage of
halo_jax/defaults.py turned into the light-field trainer's (stages/epi.py),
for the Stanford light fields' configs and the authors' LLFF recipe."""
import ml_collections

from halo_jax.defaults import model_section as _model


def light_field_stage(cfg):
  """Turns a radiance stage into the two-plane light-field stage (trainer
  'light_field', model 'epi') and adds the fields only it reads."""
  cfg.kind = "light_field"
  cfg.model.kind = "epi"
  # Composite training rays onto a random colour per ray, so partial opacity
  # costs (the authors' light-field code).
  cfg.random_background = False
  # Gaussian Fourier features of the EPI point (s', t', theta) and the view
  # (u, v): the authors' feature counts. Its stds are the authors', whose features
  # are sin(f x) with s, t in pixels / 1024 (the image spans 1): their st std
  # 64 is our 5.09 (encoding.fourier_std_from_angular(64, 1)); their theta
  # std 8 over their ~1 rad range makes ~0.8 cycles across it, ours over the
  # knights' 0.19 rad ~1. The colour gets the raw (u, v) (uv_features=0; the
  # input itself always reaches the colour), as the authors' colour reads
  # only its lowest sin/cos pair.
  # *_kind: each input's encoder (encoding.fourier_encode): 'gaussian'
  # matrices, or the authors' 'axis' (NormalEmbedder) or 'octaves'
  # (BaseEmbedder, std read as the scale); the colour reads the lowest
  # uv_features of uv_drawn.
  cfg.fourier = ml_collections.ConfigDict(dict(
      st_std=5.09, st_features=10, theta_std=8.0, theta_features=5, uv_std=1.0,
      uv_features=0, uv_drawn=0, st_kind="gaussian", theta_kind="gaussian",
      uv_kind="gaussian", seed=0))
  cfg.model.color_width = 0   # the colour's hidden layer (0: half the width)
  cfg.joint.update(
      # L_consist's tau_nerf: 'expected' (the paper) or 'max_weight'
      target="expected",
      # share of the samples stratified over the whole range instead of the
      # window (0: the paper's formula; the authors' code uses 0.5), so
      # density outside the window can still form
      full_range=0.0,
      # rays per step drawn between the training cameras (uv in their box, st
      # anywhere) on which the ray field alone follows the radiance field
      # (0: none, the paper; the authors' code uses 512 with batches of 3072)
      random_rays=0,
      # weight of the ray field's own colour loss (0: no colour head, the
      # paper); above 0 it is trained on the pixels and, on the random rays,
      # on the radiance field's colour (the authors' code, weight 1)
      color_weight=0.0,
      # L_consist's weight into the radiance field (its tau pulled towards the
      # ray field's). The paper's formula has no stop-gradient; the authors'
      # code trains only the ray field (0)
      nerf_consist_weight=0.0,
      # the ray field: 'oblique' (ray_fields.EPIRayField, Gaussian features
      # of (u, v, s, t); uv_std, where not 0, replaces std for (u, v)) or
      # 'nelf' (the authors' NeLFRayField: num_features per coordinate of
      # kind uv_kind, st_kind; its colour reads (u, v)'s features with color_uv)
      field="oblique", uv_kind="axis", st_kind="axis", color_uv=True,
      # render the random rays over the whole range instead of the current
      # window (blended samplers only; the authors' LLFF code)
      random_full=False,
      std=1.0, uv_std=0.0, num_features=16, seed=0, model=_model(width=128, depth=4))
  cfg.joint.model.skips = ()
  return cfg
