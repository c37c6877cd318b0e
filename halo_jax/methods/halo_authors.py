"""halo_authors: HALO as the authors' code runs it (lsongx/halo, `static/`),
where that differs from `halo`. Built for two-plane light fields and LLFF;
the scene config gives the protocol (views, sizes, steps, budget), this
module the authors' model and sampler at those sizes (docs/differences.md).

Light fields (their EPINeLFUvSt with NeLFEPIField and EPIField):
- encodings: their NormalEmbedder, sorted |N(0, std)| frequencies applied to
  each coordinate, 10 per coordinate for (s, t) and (u, v), 5 for theta; the
  radiance field's colour reads only the lowest (u, v) pair of a draw of 10;
- the ray field (joint.field='nelf'): as large as the radiance field, with a
  tau hidden layer and a colour head over all of (u, v)'s features, trained
  on the pixels and on random rays between the cameras (512 of every 3072);
- the sampler ('joint_blended'): half the samples evenly over the range, half
  uniform in a window around the ray field's depth, its width falling to
  half the range and blended towards the range ends;
- density relu(raw + N(0, 1)), no bias; the colour's hidden layer as wide as
  the trunk.

LLFF (their EPINeLFRays, configs/epi_nelf_sparse_llff_*.py): the same joint
light field on world rays cut by two planes (data.kind 'llff_planes'), not
NDC, and no Lo-NeRF; points placed by depth between the planes; (s, t) and
the depth encoded by octaves (their BaseEmbedder: scale 8 and 1), (u, v) by
axis-aligned frequencies of std 8 rad per scene unit; the ray field's colour
without (u, v); every sample evenly over a window that narrows to a tenth of
the range; L_consist on the largest weight's depth, on as many random rays as
training rays, which the radiance field renders over the whole depth range.
"""
import math

from halo_jax import defaults, geometry
from halo_jax.methods import base, halo

# Their random rays per step for L_consist, a share of the training batch (512 of 3072).
RANDOM_RAY_SHARE = 512 / 3072
WINDOW_FINAL = 0.5          # their epi_converge_range: the window's final width share
FEATURES = 10               # their NormalEmbedder's nb_freqs for (u, v) and (s, t)


def two_plane(c):
  halo.two_plane(c)
  hi = c.hi
  hi.sampler.kind = "joint_blended"
  parts = max(hi.microbatches, 1)
  random_rays = int(hi.batch_rays * RANDOM_RAY_SHARE) // parts * parts
  hi.joint.update(full_range=0.5, alpha_final=WINDOW_FINAL, target="expected",
                  random_rays=random_rays, color_weight=1.0, nerf_consist_weight=0.0,
                  field="nelf", num_features=FEATURES)
  hi.joint.model.update(width=hi.model.width, depth=hi.model.depth, skips=tuple(hi.model.skips))
  hi.fourier.update(st_kind="axis", theta_kind="axis", uv_kind="axis", st_features=FEATURES,
                    uv_std=hi.joint.uv_std, uv_features=1, uv_drawn=FEATURES)
  hi.model.update(density_activation="relu", density_bias=0.0, color_width=hi.model.width)
  hi.density_noise = 1.0
  hi.fourier.theta_features = 5   # their epi_embedder's nb_freqs


# LLFF (their epi_nelf_sparse_llff_trex.py)
LLFF_UV_STD = 8.0 / (2 * math.pi)   # their 8 rad per scene unit, in cycles
LLFF_ST_SCALE = 8.0                 # BaseEmbedder scale of (s, t)
LLFF_DEPTH_SCALE = 1.0              # ... and of the depth fraction
LLFF_WINDOW_FINAL = 0.1
# their window narrows in 12k iterations, 0.6 of the 20k their light fields take
LLFF_WINDOW_SHARE = 0.6


def ndc(c):
  """LLFF as their joint light field on two planes (replaces the NDC pipeline)."""
  c.data.kind = "llff_planes"
  c.stages = "hi"
  hi = c.hi
  with hi.unlocked():  # the scene config is locked; the light-field stage adds fields
    defaults.light_field_stage(hi)
  hi.random_background = True    # their EPINeLFRays' background='random'
  hi.precrop_steps = 0
  hi.empty.weight = 0.0
  hi.sampler.kind = "joint_blended_even"
  hi.joint.update(full_range=0.0, alpha_final=LLFF_WINDOW_FINAL,
                  alpha_steps=max(1, round(LLFF_WINDOW_SHARE * hi.joint.alpha_steps)),
                  target="max_weight", random_rays=hi.batch_rays, color_weight=1.0,
                  nerf_consist_weight=0.0, field="nelf", num_features=FEATURES,
                  uv_kind="axis", uv_std=LLFF_UV_STD, st_kind="octaves", std=LLFF_ST_SCALE,
                  color_uv=False, random_full=True)
  hi.joint.model.update(width=hi.model.width, depth=hi.model.depth, skips=tuple(hi.model.skips))
  hi.fourier.update(st_kind="octaves", st_std=LLFF_ST_SCALE, st_features=FEATURES,
                    theta_kind="octaves", theta_std=LLFF_DEPTH_SCALE, theta_features=FEATURES,
                    uv_kind="axis", uv_std=LLFF_UV_STD, uv_features=1, uv_drawn=FEATURES)
  hi.model.update(density_activation="relu", density_bias=0.0, color_width=hi.model.width)
  hi.density_noise = 1.0


KINDS = {"two_plane": two_plane, "ndc": ndc}


def apply(c):
  KINDS[halo.scene_kind(c)](c)   # the method's geometries keep it to these kinds
  return c


METHOD = base.Method("HALO as the authors' code runs it (light fields, LLFF)", apply,
                     geometries=frozenset({geometry.Geometry.TWO_PLANE, geometry.Geometry.NDC}),
                     dynamic=False)
