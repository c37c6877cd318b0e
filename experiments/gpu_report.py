"""`python -m experiments.gpu_report`: experiments/bench/gpu_report.py run from a clone."""
from experiments.bench import gpu_report

if __name__ == "__main__":
  gpu_report.cli()
