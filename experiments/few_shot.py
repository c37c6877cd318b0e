"""Every method on one scene at the same training wall-clock: the compare command.

  python experiments/few_shot.py --config=configs/default.py --workdir=/tmp/halo_default

The same as `halo-compare` (halo_jax/cli/compare.py, which documents the flags).
"""
from halo_jax.cli import compare

if __name__ == "__main__":
  compare.cli()
