"""`python -m experiments.benchmark`: experiments/bench/benchmark.py run from a clone."""
from experiments.bench import benchmark

if __name__ == "__main__":
  benchmark.cli()
