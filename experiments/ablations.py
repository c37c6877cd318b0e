"""`python -m experiments.ablations`: experiments/bench/ablations.py run from a clone."""
from experiments.bench import ablations

if __name__ == "__main__":
  ablations.cli()
