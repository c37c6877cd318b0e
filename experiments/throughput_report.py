"""`python experiments/throughput_report.py`: halo_jax/bench/throughput_report.py run from a clone."""
from halo_jax.bench import throughput_report

if __name__ == "__main__":
  throughput_report.cli()
