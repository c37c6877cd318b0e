"""`python experiments/throughput.py`: halo_jax/bench/throughput.py run from a clone."""
from halo_jax.bench import throughput

if __name__ == "__main__":
  throughput.cli()
