"""`python experiments/method_table.py`: halo_jax/bench/method_table.py run from a clone."""
from halo_jax.bench import method_table

if __name__ == "__main__":
  method_table.cli()
