"""`python experiments/method_table.py`: experiments/bench/method_table.py run from a clone."""
import os
import sys

# run as a script from a clone: its root on the path, for the experiments package
sys.path.insert(0, os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
from experiments.bench import method_table

if __name__ == "__main__":
  method_table.cli()
