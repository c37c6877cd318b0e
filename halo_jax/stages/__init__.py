"""HALO's stages and the driver that runs a stage list, handing states along.

Stage order is fixed (lo -> ray -> hi); `config.stages` picks which ones run
now. A stage that a later one needs but that is not in the list is loaded
from the workdir, where an earlier launch left it.
"""
import copy
import fnmatch
import json
import os

from halo_jax import checkpoint, datasets, models, parallel, tuning
from halo_jax.stages import epi, loop, nerf, ray
from halo_jax.stages.state import StageState, load, save, stage_dir

ORDER = ("lo", "ray", "hi")


def parse_stages(spec) -> tuple:
  names = tuple(s.strip() for s in (spec.split(",") if isinstance(spec, str) else spec) if s.strip())
  bad = [s for s in names if s not in ORDER]
  if bad or not names:
    raise ValueError(f"config.stages={spec!r}: each stage must be one of {ORDER}")
  return tuple(s for s in ORDER if s in names)


def needed(config, stage_list=None) -> tuple:
  """Every stage the requested ones (default config.stages) depend on, in order."""
  want = set(parse_stages(config.stages if stage_list is None else stage_list))
  if "hi" in want:
    if config.hi.sampler.kind == "depth_guided":
      want.add("ray")
    # The 3D joint sampler takes its L_consist targets from Lo-NeRF; the
    # light-field one ('epi') from its own radiance field.
    joint_3d = config.hi.sampler.kind == "joint" and config.hi.model.kind != "epi"
    if config.hi.empty.weight > 0 or config.hi.init_from_lo or joint_3d:
      want.add("lo")
  if "ray" in want:
    want.add("lo")
  return tuple(s for s in ORDER if s in want)


def with_budget(config):
  """A copy of config whose stages' max_seconds split config.budget_s by share.

  Shares are normalised over the stages the whole method needs (those Hi
  needs), so a launch of one stage gets the same time as in a full run, and
  the NeRF baseline (Hi alone) gets all of it.
  """
  config = copy.deepcopy(config)
  if config.budget_s > 0:
    names = needed(config, "hi")
    total = sum(config.budget_shares[n] for n in names)
    for n in names:
      config[n].max_seconds = config.budget_s * config.budget_shares[n] / total
  return config


def _budget_until(config) -> dict:
  """{stage: seconds of the budget given to the method's stages up to and
  including it} (with_budget's max_seconds, summed in order)."""
  until, total = {}, 0.0
  for n in needed(config, "hi"):
    total += config[n].max_seconds
    until[n] = total
  return until


# Fields that say which stages run, how long or how often to log, evaluate and
# save, and the frequency search's settings (a search's choice is kept in
# <workdir>/tune and reused); they may change between launches in one workdir.
# Every other field must match the config the workdir was started with.
RELAUNCH_FIELDS = ("stages", "budget_s", "eval.*", "tune.*", "parallel.*", "*.steps",
                   "*.max_seconds",
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
    checkpoint.write_config(path, config)
    return
  try:
    with open(path) as f:
      before = json.load(f)
  except json.JSONDecodeError as e:
    raise WorkdirMismatch(f"{path}: malformed JSON ({e}); not a halo-jax workdir?") from e
  a, b = _flatten(before), _flatten(now)
  differ = sorted(k for k in set(a) | set(b) if a.get(k, "<absent>") != b.get(k, "<absent>")
                  and not any(fnmatch.fnmatchcase(k, p) for p in RELAUNCH_FIELDS))
  if differ:
    shown = ", ".join(f"{k}: {a.get(k, '<absent>')!r} -> {b.get(k, '<absent>')!r}"
                      for k in differ[:8])
    raise WorkdirMismatch(
        f"{path}: this workdir holds a run made with another config ({len(differ)} fields "
        f"differ: {shown}{', ...' if len(differ) > 8 else ''}). Use a new --workdir, or "
        f"delete the workdir to start over.")


def _params_like(config, name, dataset):
  if config[name].get("model", {}).get("kind") == "epi":
    return epi.params_like(config, name)
  if name == "ray":
    m = models.ray_field_from_config(config.ray, dataset.near, dataset.far)
    return ray.init_params(m, config.seed)
  params = nerf.init_params(models.nerf_from_config(config, name), config.seed)
  if config[name].sampler.kind == "joint":
    m = models.ray_field_from_config(config.ray, dataset.near, dataset.far)
    return {"nerf": params, "ray": nerf.init_params_ray(m, config.seed)}
  return params


def _info_path(workdir, name):
  return os.path.join(stage_dir(workdir, name), "final", "info.json")


def run(config, workdir: str, dataset=None) -> dict:
  """Runs `config.stages` in `workdir`; returns {stage: info} for the stages run.

  info holds the stage's training seconds ('wall_s'), steps, skipped steps and,
  for NeRF stages, the held-out evaluation.
  """
  check_workdir(config, workdir)
  config = with_budget(config)
  dataset = dataset or datasets.load(config.data, workdir)
  run_now = parse_stages(config.stages)
  if config.lo.encoding.get("auto", False) and "lo" in needed(config):
    # The search's own training time is not part of this run's budget.
    config.lo.encoding.L, config.lo.encoding.scale = tuning.chosen_encoding(
        config, workdir, dataset)
  log = loop.MetricsLog(workdir)
  mesh = parallel.make_mesh(config.parallel)
  states, infos, wall = {}, {}, 0.0
  until = _budget_until(config)
  for name in needed(config):
    if name not in run_now:
      states[name] = load(workdir, name, _params_like(config, name, dataset))
      with open(_info_path(workdir, name)) as f:
        wall += json.load(f)["wall_s"]
      continue
    if config.budget_s > 0:
      # A stage that reached its step cap before its share of the budget
      # leaves the rest to the next, so the method trains for budget_s.
      config[name].max_seconds = max(config[name].max_seconds, until[name] - wall)
    if name == "ray":
      state, info = ray.train(config, dataset, workdir, states["lo"], log, wall, mesh)
    elif config[name].model.kind == "epi":
      state, info = epi.train(config, dataset, workdir, name, log, wall, mesh)
    else:
      state, info = nerf.train(config, dataset, workdir, name, states.get("lo"),
                               states.get("ray"), log, wall, mesh)
    wall += info["wall_s"]
    info.update(step=int(state.step), cumulative_wall_s=wall)
    save(workdir, state)
    with open(_info_path(workdir, name), "w") as f:
      json.dump(info, f, indent=1)
    states[name], infos[name] = state, info
  return infos


__all__ = ["StageState", "WorkdirMismatch", "check_workdir", "run", "parse_stages", "needed", "ORDER", "load", "save"]
