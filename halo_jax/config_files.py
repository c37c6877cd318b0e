"""Where a --config file is: as given, else among the configs shipped in the package.

The repository's `configs/` folder is installed as `halo_jax.configs`, so
`--config=blender.py:lego_8view_cpu` (or `configs/blender.py:...`) works from
any directory once halo-jax is installed, not only inside a clone.
"""
import importlib.util
import copy
import os
import sys


def shipped_folder() -> str:
  """The folder of the installed halo_jax.configs package ('' if none)."""
  try:
    spec = importlib.util.find_spec("halo_jax.configs")
  except ImportError:
    return ""
  locations = list(spec.submodule_search_locations or []) if spec else []
  return locations[0] if locations else ""


def resolve(spec: str) -> str:
  """'configs/blender.py:lego' -> an existing path with the same ':variant'.

  Unchanged when the path exists or no shipped config has its file name (the
  config loader then names the missing file).
  """
  path, sep, variant = spec.partition(":")
  if os.path.exists(path):
    return spec
  folder = shipped_folder()
  if folder:
    candidate = os.path.join(folder, os.path.basename(path))
    if os.path.exists(candidate):
      return candidate + sep + variant
  return spec


def resolve_argv(argv=None, flag: str = "--config"):
  """argv with the value of --config=SPEC resolved (both '--config=X' and '--config X')."""
  argv = list(sys.argv if argv is None else argv)
  for i, arg in enumerate(argv):
    if arg.startswith(flag + "="):
      argv[i] = flag + "=" + resolve(arg[len(flag) + 1:])
    elif arg == flag and i + 1 < len(argv):
      argv[i + 1] = resolve(argv[i + 1])
  return argv


def split_flags(variant: str, flags=("cpu",)):
  """'lego_8view_cpu' -> (['lego', '8view'], {'cpu'}): a config file's
  variant as its '_'-separated parts, with the trailing ones in `flags` taken
  off. A method is not part of a variant (halo_jax/configure.py)."""
  parts, found = variant.split("_") if variant else [], set()
  while parts and parts[-1] in flags:
    found.add(parts.pop())
  return parts, found


def dotted_fields(tree, prefix: str = "") -> dict:
  """{'a': {'b': 1}} -> {'a.b': 1}: a nested dict (a config's to_dict(), the
  command line's overrides) as the dotted fields `set_field` takes."""
  out = {}
  for k, v in tree.items():
    if isinstance(v, dict):
      out.update(dotted_fields(v, f"{prefix}{k}."))
    else:
      out[prefix + k] = v
  return out


def laid_over(tree: dict, over: dict) -> dict:
  """A copy of the nested dict `tree` with each leaf of the nested dict
  `over` set in it (a stage section and the plan a protocol made of it:
  halo_jax/protocol.py)."""
  out = copy.deepcopy(dict(tree))
  for dotted, value in dotted_fields(dict(over)).items():
    *path, field = dotted.split(".")
    node = out
    for part in path:
      node = node[part]
    node[field] = value
  return out
