"""`python experiments/gpu_report.py`: halo_jax/bench/gpu_report.py run from a clone."""
from halo_jax.bench import gpu_report

if __name__ == "__main__":
  gpu_report.cli()
