"""`python experiments/report.py`: halo_jax/bench/report.py run from a clone."""
from halo_jax.bench import report

if __name__ == "__main__":
  report.cli()
