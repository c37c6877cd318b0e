"""experiments/bench/trace_summary.py: the union of kernel intervals, kernel kinds,
and a real trace of a jitted step on the CPU."""
import jax
import jax.numpy as jnp
import pytest

from experiments.bench import trace_summary


def test_union_counts_overlaps_once():
  # [0,4) and [2,6) overlap on [2,4): union 6; [10,11) is apart; [3,5) is inside.
  assert trace_summary._union_ns([(2, 6), (0, 4), (10, 11), (3, 5)]) == 7
  assert trace_summary._union_ns([]) == 0


@pytest.mark.parametrize("name, kind", [
    ("sm90_xmma_gemm_f32f32_tf32f32_f32_tn_n_tilesize128x128x32", "matmul"),
    ("gemm_fusion_dot_34", "matmul"),
    ("void cutlass::Kernel2<cutlass_80_tensorop_s1688gemm_128x256>", "matmul"),
    ("input_reduce_select_fusion_3", "reduce"),
    ("loop_convert_fusion_5", "elementwise"),
    ("Memcpy DtoD", "copy"),
    ("mystery_kernel", "other"),
])
def test_kernel_kind(name, kind):
  assert trace_summary.kernel_kind(name) == kind


def test_profile_of_a_cpu_step():
  f = jax.jit(lambda a: jnp.tanh(a @ a).sum())
  a = jnp.ones((256, 256))
  n = 3
  run = lambda: jax.block_until_ready([f(a) for _ in range(n)])
  run()
  s = trace_summary.profile(run, n)
  assert s["steps"] == n and s["kernels_per_step"] > 0
  assert 0 < s["busy_ms"] <= s["wall_ms"] * 1.05  # the union never exceeds the wall
  assert 0.0 <= s["idle_share"] < 1.0
  assert abs(sum(s["kernel_share_by_kind"].values()) - 1.0) < 1e-9
  assert s["top_kernels"] and s["top_kernels"][0]["ms"] > 0
  assert "ms a step" in trace_summary.format_summary("f", s)
