"""`python experiments/report.py`: experiments/bench/report.py run from a clone."""
import os
import sys

# run as a script from a clone: its root on the path, for the experiments package
sys.path.insert(0, os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
from experiments.bench import report

if __name__ == "__main__":
  report.cli()
