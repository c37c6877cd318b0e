"""HALO and our few-shot protocols, registered with nerfbaselines.

  export NERFBASELINES_REGISTER=$PWD/halo_jax/integrations/nerfbaselines_spec.py
  export HALO_JAX_PYTHON=$PWD/.venv/bin/python   # optional: an existing halo-jax env
  nerfbaselines train --method halo --data external://blender-dietnerf/lego-n8

nerfbaselines loads this file in its own process and environment, so it
imports no jax. Where HALO_JAX_PYTHON names a Python with halo-jax, the
method runs there (nerfbaselines_venv.py); else nerfbaselines' conda
backend builds an environment and installs this source tree into it.
"""
import importlib.util
import os
import sys

from nerfbaselines import register

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))


def _source_package():
  """nerfbaselines loads this file in its own process and environment, where
  halo-jax is not installed, and then imports the method class by module
  name (`method_class` below): there the package is loaded from this source
  tree by its location (nothing is added to the import path)."""
  if importlib.util.find_spec("halo_jax") is not None:
    return
  folder = os.path.join(ROOT, "halo_jax")
  spec = importlib.util.spec_from_file_location(
      "halo_jax", os.path.join(folder, "__init__.py"), submodule_search_locations=[folder])
  package = importlib.util.module_from_spec(spec)
  sys.modules["halo_jax"] = package
  spec.loader.exec_module(package)


_source_package()
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
