"""`python experiments/calibrate_frequency.py`: halo_jax/bench/calibrate_frequency.py run from a clone."""
from halo_jax.bench import calibrate_frequency

if __name__ == "__main__":
  calibrate_frequency.cli()
