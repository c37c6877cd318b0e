"""Starting Hi-NeRF from Lo-NeRF's weights (the authors' per-scene option)."""
import jax
import jax.numpy as jnp


def transfer_from_lo(hi_params, lo_params, lo_inputs_first: bool = False, fresh_skips=()):
  """Hi-NeRF parameters initialised from Lo-NeRF's.

  Layers of equal shape are copied; the rest (the view-direction branch, and
  the input layer over other features: the authors' option) keep their fresh
  initialisation. With `lo_inputs_first` (Hi-NeRF's encoding starts with Lo's
  P.E., `hi.encoding.with_lo`), a kernel whose inputs extend Lo's (the input
  and skip layers) gets Lo's rows first and zeros for the extra Hi features,
  so the Hi-NeRF starts as the same function as the Lo-NeRF. The trunk
  layers `dense_<i>` for i in `fresh_skips` (the skip layers, which also read
  the encoding) keep their fresh initialisation too: the authors' option
  drops both their fc0 and fc4.
  """
  fresh = {"dense_0"} | {f"dense_{i}" for i in fresh_skips}
  flat_lo = dict(jax.tree_util.tree_leaves_with_path(lo_params))

  def pick(path, x):
    src = flat_lo.get(path)
    if src is None or src.ndim != x.ndim:
      return x
    # Without lo_inputs_first the input layer reads other features than Lo's,
    # even where the widths happen to agree.
    if not lo_inputs_first and any(getattr(k, "key", None) in fresh for k in path):
      return x
    if src.shape == x.shape:
      return src
    if (lo_inputs_first and x.ndim == 2 and src.shape[1] == x.shape[1]
        and src.shape[0] < x.shape[0]):
      return jnp.zeros_like(x).at[:src.shape[0]].set(src)
    return x
  return jax.tree_util.tree_map_with_path(pick, hi_params)
