"""`python -m experiments.throughput`: experiments/bench/throughput.py run from a clone."""
from experiments.bench import throughput

if __name__ == "__main__":
  throughput.cli()
