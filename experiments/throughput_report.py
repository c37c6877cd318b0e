"""`python -m experiments.throughput_report`: experiments/bench/throughput_report.py run from a clone."""
from experiments.bench import throughput_report

if __name__ == "__main__":
  throughput_report.cli()
