"""The stability suite (experiments/bench/stability_cases.py): every stiff case within its
tolerance of a closed form or float64 reference, every value and gradient finite."""
import jax.numpy as jnp
import numpy as np
import pytest

from halo_jax import encoding
from experiments.bench import stability_cases as stability


@pytest.mark.parametrize("case", stability.CASES, ids=lambda c: c.__name__)
def test_case_within_tolerance(case):
  checks = case()
  assert checks
  bad = [f"{c.case} / {c.quantity}: error {c.error:.3g} > tol {c.tol:.3g} or finite={c.finite}"
         for c in checks if not c.ok]
  assert not bad, "\n".join(bad)


def test_naive_encoding_fails_the_bound_the_compensated_one_meets():
  # Guards the suite itself: the tolerance separates the two formulations.
  x = jnp.asarray(np.random.default_rng(0).uniform(-1e3, 1e3, (2048, 1)), jnp.float32)
  L, s = 16, 7.0
  ang = np.asarray(x, np.float64)[:, None, :] / s * (2.0 ** np.arange(L))[:, None]
  ang = ang.reshape(len(x), -1)
  want = np.concatenate([np.sin(ang), np.cos(ang)], -1)
  tol = 2 * stability.EPS32 * (4 + np.abs(ang).max() * 2.0 ** -11)
  naive = np.abs(np.asarray(encoding.naive_positional_encoding(x, L, s)) - want).max()
  ours = np.abs(np.asarray(encoding.positional_encoding(x, L, s, False)) - want).max()
  assert ours <= tol < naive

