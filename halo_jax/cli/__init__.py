"""The command-line entry points, one module per console script:

  halo-train    halo_jax/cli/train.py     train a method's stages
  halo-eval     halo_jax/cli/evaluate.py  score a finished stage on a split
  halo-render   halo_jax/cli/render.py    videos along a camera path
  halo-compare  halo_jax/cli/compare.py   every method on one scene, equal time
  halo-sweep    halo_jax/cli/sweep.py     a grid of config overrides

Each is also `python -m halo_jax.cli.<name>`. Nothing below this package
imports it.
"""
