"""Sweeps config fields from the command line: the sweep command.

  python experiments/sweep.py --config=configs/blender.py:lego_8view_cpu --workdir=DIR \
      --sweep=lo.encoding.L=3,5,7

The same as `halo-sweep` (halo_jax/cli/sweep.py, which documents the flags).
"""
from halo_jax.cli import sweep

if __name__ == "__main__":
  sweep.cli()
