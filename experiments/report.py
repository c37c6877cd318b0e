"""`python -m experiments.report`: experiments/bench/report.py run from a clone."""
from experiments.bench import report

if __name__ == "__main__":
  report.cli()
