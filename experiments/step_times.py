"""`python -m experiments.step_times`: experiments/bench/step_times.py run from a clone."""
from experiments.bench import step_times

if __name__ == "__main__":
  step_times.cli()
