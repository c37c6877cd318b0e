"""`python -m experiments.calibrate_frequency`: experiments/bench/calibrate_frequency.py run from a clone."""
from experiments.bench import calibrate_frequency

if __name__ == "__main__":
  calibrate_frequency.cli()
