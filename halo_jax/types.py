"""The type names the interfaces share (numerics layer: imports nothing of
halo_jax). Shapes are in each field's docstring; these say what kind of
object a field holds."""
from typing import Any, Dict, Union

import jax
import ml_collections
import numpy as np

# A device or host array (host arrays where a stage prepares data with numpy).
Array = Union[jax.Array, np.ndarray]
# A run or stage config (the ml-collections tree configs/*.py build).
Config = ml_collections.ConfigDict
# A Flax parameter pytree ({'params': ...}'s contents, or {'nerf': ..., 'ray': ...}).
Params = Dict[str, Any]
# A pytree of arrays (data put on device, aux metrics).
Tree = Any
