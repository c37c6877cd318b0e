"""A study's run that a suite has already made: the same resolved config and
the same code fingerprint, so the same figures, adopted instead of trained
again (experiments/bench/ablations.py)."""
import functools
import glob
import hashlib
import json
import os
import subprocess

from absl import logging

from halo_jax import config_files, defaults, protocol
from experiments.bench import git_state
from experiments.bench import benchmark, code_version, suites
from experiments.bench.paths import REPO

UNVOUCHED = (code_version.MODIFIED, code_version.UNMEASURED)


def _comparable(resolved: dict) -> dict:
  """A resolved config's dotted fields, its scene folder without the
  machine's data root (or, for a built-in scene, the scratch folder it was
  generated in)."""
  # as the stages train it (a plan laid over its stages), so that a record
  # written before the plan was a section of its own compares alike
  out = _unreached_switches_off(config_files.dotted_fields(protocol.applied(resolved)))
  if out.get("data.kind") == "procedural":
    out.pop("data.root", None)
  elif out.get("data.root"):
    out["data.root"] = os.path.join(*os.path.normpath(out["data.root"]).split(os.sep)[-2:])
  return out


def _unreached_switches_off(fields: dict) -> dict:
  """Dotted fields with the sampler switch of each stage that never reaches it
  set to the base config's (none): a stage that trains no more steps than its
  `sampler.switch_step` computes exactly what it computes without the switch
  (halo_jax/sampler_switch.py), so a default switch that a short run does not
  reach leaves that run's record standing. A switch_step of 0 is no switch,
  whatever the other switch fields say. The same for dense held-out renders
  (sampler.dense_eval_after) in a stage that stops short of them."""
  base = _defaults()
  out = dict(fields)
  for key, switch in fields.items():
    if not key.endswith(".sampler.switch_step"):
      continue
    stage = key[:-len(".sampler.switch_step")]
    # the stage's last step, as stages/budget.last_step counts it
    steps = min([n for n in (fields.get(f"{stage}.{f}", 0) for f in
                             ("steps", "stop_at_step", "budget_steps")) if n] or [0])
    if not switch or (steps and steps <= switch):
      _reset(out, base, stage, ("switch_step", "switch_samples", "switch_kind"))
    # held-out renders turn dense once the stage has trained dense_eval_after steps
    after = fields.get(f"{stage}.sampler.dense_eval_after", 0)
    if not after or (steps and steps < after):
      _reset(out, base, stage, ("dense_eval_after", "dense_eval_samples"))
  return out


def _reset(out: dict, base: dict, stage: str, fields) -> None:
  for field in fields:
    dotted = f"{stage}.sampler.{field}"
    if dotted in base:
      out[dotted] = base[dotted]


@functools.lru_cache(maxsize=1)
def _defaults() -> dict:
  """The base config's dotted fields (what a field added since a record means)."""
  return config_files.dotted_fields(json.loads(defaults.base_config().to_json_best_effort()))


# Fields a method states and the protocol applies (protocol.resolve): their
# whole effect is in other resolved fields (init_from_lo, encoding.with_lo),
# which are compared.
STATED_FOR_RESOLVE = ("copy_lo_under_budget",)
# Fields that name where other fields' values came from (the scene file's
# sizes: 'paper' or 'cpu'), whose whole effect is in those fields.
LABELS = ("sizing",)


def _same_config(mine: dict, theirs: dict) -> bool:
  """Equal dotted configs, a field the older record lacks counting as equal
  where `mine` has its default (a field added since, whose default is the
  behaviour before it: the code fingerprint checks that)."""
  base = _defaults()
  added = {k: v for k, v in mine.items()
           if k not in theirs and k.rsplit(".", 1)[-1] not in STATED_FOR_RESOLVE + LABELS}
  return (all(mine.get(k) == v for k, v in theirs.items())
          and all(k in base and base[k] == v for k, v in added.items()))


def run_config(record: dict) -> dict:
  """The resolved config of a record's run: its `resolved_config`, with the
  render fields a rescored record was scored with (rescore.py) laid over."""
  fields = dict((record.get("rescored_from") or {}).get("fields", ()))
  # {dotted: value} is a one-level overlay whose keys dotted_fields keeps as they are.
  return config_files.laid_over(record["resolved_config"], fields)


def same_resolved(mine: dict, theirs: dict) -> bool:
  """Whether two resolved configs (JSON dicts, `theirs` possibly older)
  train the same run, by the rule adoption uses."""
  return _same_config(_comparable(mine), _comparable(theirs))


def running_fingerprint(method: str, table: dict, config: str = "") -> str:
  """The fingerprint of `method` on the kind of scene `config` names, for the
  code this process runs (its checkout's code tree in `table`);
  code_version.MODIFIED or UNMEASURED where it has none."""
  return code_version.of_record({"method": method, "config": config,
                                 "provenance": {"git": git_state.git_state()}}, table)


def identical_suite_run(c, scene, method, seed, results, table=None, mine_fp=None):
  """(path, record) of a finished suite run (mode 'budget') whose resolved
  config is `c`'s and whose code computes what this code does, or None: a
  variant without overrides on the validation suite's terms is that suite's
  run, and its figures are already measured. A record of the same config
  whose fingerprint is not this code's (`mine_fp`, by default the running
  checkout's in `table`, results/fingerprints.json), or that no measured
  fingerprint vouches for, is refused with a warning: its run is trained."""
  return _vouched(same_config_runs(c, scene, method, seed, results), scene, method, table,
                  mine_fp)


def identical_study_run(c, scene, method, seed, results, table=None, mine_fp=None):
  """(path, record) of a finished study run (not adopted) of `c`'s resolved
  config by code that computes what this code does, or None: the other way
  round from identical_suite_run, a variant a study measured that has since
  become the default is the suite's run. A rescored run (rescore.py) is its
  reference's training scored with the render fields it names: its config
  is the two together (run_config), and its curve is the reference's renders."""
  mine, runs = _comparable(json.loads(c.to_json_best_effort())), []
  for path in sorted(glob.glob(os.path.join(results, "ablations", "*", scene.name, "*",
                                            f"seed{seed}.json"))):
    with open(path) as f:
      record = json.load(f)
    if (record.get("method") == method and not record.get("adopted_from")
        and "resolved_config" in record
        and _same_config(mine, _comparable(run_config(record)))):
      runs.append((path, record))
  return _vouched(runs, scene, method, table, mine_fp)


def _vouched(runs, scene, method, table, mine_fp):
  """The first of `runs` ([(path, record)]) whose code's measured fingerprint
  is the running code's, or None (each other refused with a warning)."""
  table = code_version.load() if table is None else table
  mine_fp = running_fingerprint(method, table, scene.config) if mine_fp is None else mine_fp
  for path, record in runs:
    theirs_fp = code_version.of_record(record, table)
    if theirs_fp == mine_fp and mine_fp not in UNVOUCHED:
      return path, record
    logging.warning("not adopted: %s has this run's config, but its code's fingerprint "
                    "is %s and this code's %s (same_numbers.py --record measures it)",
                    path, theirs_fp, mine_fp)
  return None


def validation_from(record: dict, split: str, results: str = ""):
  """The suite's `validation` field (benchmark.score_validation) that a
  record already holds, or None: where its held-out views are every view of
  `split`, the final stage's figures (with SSIM and a held-out verdict in the
  record) are what scoring it again computes. The other scored stages' are
  only in the `validation` of a rescored record's reference (rescore.py,
  under `results`, the repository's by default; unchanged since), which
  rendered them as they are: its render fields are the final stage's."""
  data = record["resolved_config"]["data"]
  scored = [n for n, stage in record["stages"].items() if "psnr" in stage]
  final = list(record["stages"])[-1]
  if (data.get("test_split") != split or data.get("test_views") != "all" or not scored
      or scored[-1] != final or final not in record.get("heldout_learned", {})):
    return None
  stages = {final: {"psnr": record["psnr"], "ssim": record["ssim"],
                    "learned": record["heldout_learned"][final]}}
  if len(scored) > 1:
    earlier = _reference_validation(record, split, results)
    if earlier is None or any(n not in earlier for n in scored[:-1]):
      return None
    stages = {**{n: earlier[n] for n in scored[:-1]}, **stages}
  return {"split": split, "num_views": record["num_views"], "stages": stages}


def _reference_validation(record: dict, split: str, results: str):
  """{stage: scores} of the validation of the run a rescored record renders,
  where that record is unchanged (its sha256) and scored `split`; else None."""
  source = record.get("rescored_from") or {}
  path = os.path.join(results or os.path.join(REPO, "results"), source["path"]) \
      if source.get("path") else ""
  final = list(record["stages"])[-1]
  if not os.path.isfile(path) or any(not f.startswith(final + ".")
                                     for f, _ in source.get("fields", ())):
    return None
  with open(path, "rb") as f:
    raw = f.read()
  if hashlib.sha256(raw).hexdigest() != source.get("sha256"):
    return None
  validation = json.loads(raw).get("validation") or {}
  return validation.get("stages") if validation.get("split") == split else None


def same_config_runs(c, scene, method, seed, results):
  """[(path, record)] of the finished suite runs (mode 'budget') of `scene`,
  `method` and `seed` whose resolved config is `c`'s (composed), whatever
  code made them."""
  mine = _comparable(json.loads(c.to_json_best_effort()))  # c is composed: resolved
  out = []
  for name in sorted(suites.SUITES):
    path = benchmark.result_path(results, name, "budget", scene, method, seed)
    if os.path.exists(path):
      with open(path) as f:
        record = json.load(f)
      if _same_config(mine, _comparable(record["resolved_config"])):
        out.append((path, record))
  return out


def source(path: str, results: str) -> dict:
  """What an adopted record names of the record it copies: its path
  under `results`, the sha256 of its bytes, and the last commit that wrote
  that file (None where git cannot say: a file not committed yet)."""
  with open(path, "rb") as f:
    digest = hashlib.sha256(f.read()).hexdigest()
  out = subprocess.run(["git", "-C", os.path.dirname(os.path.abspath(path)), "log", "-1",
                        "--format=%H", "--", os.path.abspath(path)],
                       capture_output=True, text=True, check=False)
  return {"path": os.path.relpath(path, results), "sha256": digest,
          "commit": out.stdout.strip() or None}

