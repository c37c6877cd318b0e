"""`python experiments/benchmark.py`: halo_jax/bench/benchmark.py run from a clone."""
from halo_jax.bench import benchmark

if __name__ == "__main__":
  benchmark.cli()
