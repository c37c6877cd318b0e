"""HALO and our few-shot protocols, registered with nerfbaselines.

  export NERFBASELINES_REGISTER=$PWD/halo_jax/integrations/nerfbaselines_spec.py
  export HALO_JAX_PYTHON=$PWD/.venv/bin/python   # optional: an existing halo-jax env
  nerfbaselines train --method halo --data external://blender-dietnerf/lego-n8

nerfbaselines loads this file in its own process and environment, so it
imports no jax. Where HALO_JAX_PYTHON names a Python with halo-jax, the
method runs there (nerfbaselines_venv.py); else nerfbaselines' conda
backend builds an environment and installs this source tree into it.
"""
import os
import sys

from nerfbaselines import register

# nerfbaselines loads this file in its own process and then imports the
# method class by module name (`method_class` below): the one place the
# source tree goes on the import path, since halo-jax is not installed there.
ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
if ROOT not in sys.path:
  sys.path.insert(0, ROOT)

from halo_jax.integrations import nerfbaselines_datasets, nerfbaselines_info  # noqa: E402

_METADATA = {
    "name": "HALO (halo-jax)",
    "description": "Low-frequency neural fields for few-shot view synthesis: Lo-NeRF, a ray "
                   "field distilled from it, and Hi-NeRF sampled by the ray field (JAX/Flax).",
    "paper_title": "Harnessing Low-Frequency Neural Fields for Few-Shot View Synthesis",
    "paper_authors": ["Liangchen Song", "Zhong Li", "Xuan Gong", "Lele Chen", "Zhang Chen",
                      "Yi Xu", "Junsong Yuan"],
    "link": "https://github.com/lsongx/halo",
    "licenses": [{"name": "Apache 2.0", "url": "https://www.apache.org/licenses/LICENSE-2.0"}],
}

_INFO = nerfbaselines_info.method_info()
_SPEC = {
    "id": nerfbaselines_info.METHOD_ID,
    "method_class": "halo_jax.integrations.nerfbaselines_method:HaloMethod",
    "conda": {
        "environment_name": "halo-jax",
        "python_version": "3.11",
        "install_script": f"python -m pip install -e {ROOT!r}\n",
    },
    "metadata": _METADATA,
    "presets": {"cpu": {"cpu": True}},
    "required_features": sorted(_INFO["required_features"]),
    "supported_camera_models": sorted(_INFO["supported_camera_models"]),
    "supported_outputs": list(_INFO["supported_outputs"]),
    "implementation_status": {"blender-dietnerf": "working", "llff-regnerf": "working",
                              "blender": "working", "llff": "working"},
}
if os.environ.get("HALO_JAX_PYTHON"):
  _SPEC = {**_SPEC, "method_class": "halo_jax.integrations.nerfbaselines_venv:HaloInVenv",
           "backends_order": ["python"]}
register(_SPEC)
nerfbaselines_datasets.register_all(register)
