"""A workdir remembers the config it was started with; a relaunch with
another config is refused (only the fields that say what runs now, for how
long and how often to log may change)."""
import fnmatch
import json
import os

from halo_jax import checkpoint, parallel, protocol

# Fields that say which stages run, how long or how often to log, evaluate and
# save, and the frequency search's settings (a search's choice is kept in
# <workdir>/tune and reused); they may change between launches in one workdir.
# Every other field must match the config the workdir was started with.
RELAUNCH_FIELDS = ("stages", "budget_s", "eval.*", "tune.*", "parallel.*", "*.steps",
                   "*.max_seconds", "*.stop_at_step",
                   "*.eval_every", "*.eval_every_s", "*.log_every", "*.checkpoint_every")


class WorkdirMismatch(ValueError):
  """The workdir holds a run made with another config."""


def _flatten(tree, prefix=""):
  out = {}
  for k, v in tree.items():
    key = f"{prefix}{k}"
    if isinstance(v, dict):
      out.update(_flatten(v, key + "."))
    else:
      out[key] = list(v) if isinstance(v, tuple) else v
  return out


def check_workdir(config, workdir: str) -> None:
  """Raises WorkdirMismatch if `workdir` was started with a different config;
  records the config as `<workdir>/config.json` on the first launch."""
  path = os.path.join(workdir, "config.json")
  now = json.loads(config.to_json_best_effort())
  if not os.path.exists(path):
    if parallel.is_primary():
      checkpoint.write_config(path, config)
    return
  try:
    with open(path) as f:
      before = json.load(f)
  except json.JSONDecodeError as e:
    raise WorkdirMismatch(f"{path}: malformed JSON ({e}); not a halo-jax workdir?") from e
  # compared as the stages train them: a workdir started before the plan
  # was a section of its own (its stages held those fields) still matches
  a, b = _flatten(protocol.applied(before)), _flatten(protocol.applied(now))
  differ = sorted(k for k in set(a) | set(b) if a.get(k, "<absent>") != b.get(k, "<absent>")
                  and not any(fnmatch.fnmatchcase(k, p) for p in RELAUNCH_FIELDS))
  if differ:
    shown = ", ".join(f"{k}: {a.get(k, '<absent>')!r} -> {b.get(k, '<absent>')!r}"
                      for k in differ[:8])
    raise WorkdirMismatch(
        f"{path}: this workdir holds a run made with another config ({len(differ)} fields "
        f"differ: {shown}{', ...' if len(differ) > 8 else ''}). Use a new --workdir, or "
        f"delete the workdir to start over.")
