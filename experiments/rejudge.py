"""Re-judges every committed run record with today's collapse rule
(halo_jax/stages/collapse.py), so that no record carries a verdict of an
older rule.

- The held-out verdict of each rendering stage is recomputed from the
  record's own held-out PSNR and the best constant image of the same views,
  loaded as the run loaded them (its resolved config); nothing is rendered.
- The training verdicts of a run made before today's rule (a commit older
  than RULE_COMMIT: the rule that skips the crop's batches and judges the
  ray field) cannot be re-judged: a record keeps no per-stage training
  curve. They become 'unjudged', and the old words move to
  `learned_older_rule` with the commit that judged them.
- Every JSON file under results/ is read, whatever its name or layout: a
  record is a dict with `stages` and `learned`, at the top of a file or
  under a file's `methods` (a GPU run's). A record without a resolved
  config keeps its held-out verdict (its views cannot be loaded as it
  loaded them) and has its training verdicts re-judged.

  python -m experiments.rejudge            # rewrites the files that change
  python -m experiments.rejudge --dry_run  # says what would change
"""
import glob
import json
import os
import subprocess
import sys

from absl import app, flags
import ml_collections

from halo_jax import datasets
from experiments.bench import run_file
from experiments.bench.paths import REPO
from halo_jax.stages import collapse

flags.DEFINE_string("results", os.path.join(REPO, "results"), "Result files' root.")
flags.DEFINE_bool("dry_run", False, "Say what would change; write nothing.")
FLAGS = flags.FLAGS

# The commit that made today's training verdict (judged after the crop's
# batches, the ray field judged against its targets' constant).
RULE_COMMIT = "24f6b69"


def older_than_rule(commit: str):
  """True where `commit` is a strict ancestor of RULE_COMMIT, None where git
  cannot say (a commit from elsewhere)."""
  if not commit:
    return None
  if commit.startswith(RULE_COMMIT):
    return False
  out = subprocess.run(["git", "-C", REPO, "merge-base", "--is-ancestor", commit, RULE_COMMIT],
                       capture_output=True, check=False)
  return {0: True, 1: False}.get(out.returncode)


def _data_config(record) -> ml_collections.ConfigDict:
  """The record's data config, its scene folder found under $HALO_DATA when
  the recorded path is not on this machine."""
  data = dict(record["resolved_config"]["data"])
  root = data.get("root") or ""
  if root and not os.path.isdir(root):
    base = os.environ.get("HALO_DATA", os.path.join(REPO, "data"))
    for dataset in ("nerf_synthetic", "nerf_llff_data", "dnerf", "stanford_lf"):
      if f"/{dataset}/" in root:
        data["root"] = os.path.join(base, dataset, root.split(f"/{dataset}/", 1)[1])
  return ml_collections.ConfigDict(data)


_CONSTANTS = {}


def constant_of(record):
  """The best constant image's PSNR on the record's held-out views (cached
  per data config), or None where its data is absent."""
  cfg = _data_config(record)
  key = json.dumps(cfg.to_dict(), sort_keys=True)
  if key not in _CONSTANTS:
    try:
      _CONSTANTS[key] = collapse.constant_psnr(datasets.load(cfg, "").test.images)
    except (OSError, datasets.DataError) as e:
      print(f"  no data for {cfg.get('root') or cfg.kind}: {e}", file=sys.stderr)
      _CONSTANTS[key] = None
  return _CONSTANTS[key]


def rejudge(record) -> dict:
  """The record with today's verdicts (a new dict; the input is not changed)."""
  out = dict(record)
  rc = record.get("resolved_config")
  constant = constant_of(record) if rc else None
  if constant is not None:
    out["heldout_learned"] = {
        n: collapse.heldout(s["psnr"], constant, rc[n]["collapse"]["margin_db"])["verdict"]
        for n, s in record["stages"].items() if "psnr" in s}
  commit = (record.get("provenance") or {}).get("git", {}).get("commit")
  if (record.get("learned") and "learned_older_rule" not in record
      and older_than_rule(commit)):
    out["learned_older_rule"] = {"commit": commit[:7], "verdicts": record["learned"]}
    out["learned"] = {n: collapse.UNJUDGED for n in record["learned"]}
  return out


def is_record(value) -> bool:
  return isinstance(value, dict) and "stages" in value and "learned" in value


def records_of(content) -> dict:
  """{where: record} of a result file's content: '' for a record at its top,
  'methods.<m>' for each record under its `methods`."""
  if is_record(content):
    return {"": content}
  methods = content.get("methods") if isinstance(content, dict) else None
  if isinstance(methods, dict):
    return {f"methods.{m}": r for m, r in methods.items() if is_record(r)}
  return {}


def main(argv):
  del argv
  changed = same = 0
  for path in sorted(glob.glob(os.path.join(FLAGS.results, "**", "*.json"), recursive=True)):
    with open(path) as f:
      try:
        content = json.load(f)
      except json.JSONDecodeError:
        continue
    found = records_of(content)
    new_content = content
    for where, record in found.items():
      new = rejudge(record)
      if new == record:
        same += 1
        continue
      changed += 1
      rel = os.path.relpath(path, FLAGS.results) + (f" [{where}]" if where else "")
      for field in ("learned", "heldout_learned"):
        if new.get(field) != record.get(field):
          print(f"{rel}: {field} {record.get(field)} -> {new.get(field)}")
      if where:
        new_content = dict(new_content, methods=dict(new_content["methods"],
                                                     **{where.split(".", 1)[1]: new}))
      else:
        new_content = new
    if new_content is not content and not FLAGS.dry_run:
      run_file.write_json(path, new_content)
  print(f"{changed} record(s) {'would change' if FLAGS.dry_run else 'changed'}, {same} "
        "already today's")


if __name__ == "__main__":
  app.run(main)
