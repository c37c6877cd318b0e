"""`python experiments/ablations.py`: halo_jax/bench/ablations.py run from a clone."""
from halo_jax.bench import ablations

if __name__ == "__main__":
  ablations.cli()
