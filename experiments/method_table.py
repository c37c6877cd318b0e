"""`python -m experiments.method_table`: experiments/bench/method_table.py run from a clone."""
from experiments.bench import method_table

if __name__ == "__main__":
  method_table.cli()
