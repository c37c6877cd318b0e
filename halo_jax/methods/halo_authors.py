"""halo_authors: HALO as the authors' code runs it (lsongx/halo, `static/`),
where that differs from `halo`. Built for two-plane light fields; the scene
config gives the protocol (views, sizes, steps, budget), this module the
authors' model and sampler at those sizes (docs/differences.md).

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
"""
from halo_jax import geometry
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
  hi.fourier.update(axis=True, st_features=FEATURES, uv_std=hi.joint.uv_std, uv_features=1,
                    uv_drawn=FEATURES)
  hi.model.update(density_activation="relu", density_bias=0.0, color_width=hi.model.width)
  hi.density_noise = 1.0


def apply(c):
  two_plane(c)   # the method's geometries keep it to light fields
  return c


METHOD = base.Method("HALO as the authors' code runs it (light fields)", apply,
                     geometries=frozenset({geometry.Geometry.TWO_PLANE}), dynamic=False)
