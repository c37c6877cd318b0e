"""A study's run that a suite has already made: the same resolved config, so
the same figures (the code fingerprint checks the code), adopted instead of
trained again (halo_jax/bench/ablations.py)."""
import functools
import json
import os

from halo_jax import config_files, defaults, protocol
from halo_jax.bench import benchmark, suites


def _comparable(resolved: dict) -> dict:
  """A resolved config's dotted fields, its scene folder without the
  machine's data root (or, for a built-in scene, the scratch folder it was
  generated in)."""
  out = config_files.dotted_fields(resolved)  # a new dict: `resolved` is not changed
  if out.get("data.kind") == "procedural":
    out.pop("data.root", None)
  elif out.get("data.root"):
    out["data.root"] = os.path.join(*os.path.normpath(out["data.root"]).split(os.sep)[-2:])
  return out


@functools.lru_cache(maxsize=1)
def _defaults() -> dict:
  """The base config's dotted fields (what a field added since a record means)."""
  return config_files.dotted_fields(json.loads(defaults.base_config().to_json_best_effort()))


# Fields a method states and the protocol applies (protocol.resolve): their
# whole effect is in other resolved fields (init_from_lo, encoding.with_lo),
# which are compared.
STATED_FOR_RESOLVE = ("copy_lo_under_budget",)


def _same_config(mine: dict, theirs: dict) -> bool:
  """Equal dotted configs, a field the older record lacks counting as equal
  where `mine` has its default (a field added since, whose default is the
  behaviour before it: the code fingerprint checks that)."""
  base = _defaults()
  added = {k: v for k, v in mine.items()
           if k not in theirs and k.rsplit(".", 1)[-1] not in STATED_FOR_RESOLVE}
  return (all(mine.get(k) == v for k, v in theirs.items())
          and all(k in base and base[k] == v for k, v in added.items()))


def identical_suite_run(c, scene, method, seed, results):
  """(path, record) of a finished suite run (mode 'budget') whose resolved
  config is `c`'s, or None: a variant without overrides on the validation
  suite's terms is that suite's run, and its figures are already measured."""
  mine = _comparable(json.loads(protocol.resolve(c).to_json_best_effort()))
  for name in sorted(suites.SUITES):
    path = benchmark.result_path(results, name, "budget", scene, method, seed)
    if os.path.exists(path):
      with open(path) as f:
        record = json.load(f)
      if _same_config(mine, _comparable(record["resolved_config"])):
        return path, record
  return None
