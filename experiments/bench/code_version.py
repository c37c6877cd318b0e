"""Which code made a result, judged by the numbers it makes: the fingerprint.

A record names the commit its run started from and whether the tree was
modified. The commit's code tree (git_state.code_tree: a hash of the
training code's files) names the code exactly, but two trees can make the
same numbers (a refactor, a comment). So a tree's fingerprint is measured:
`experiments/same_numbers.py --record` makes the fingerprint run
(experiments/bench/fingerprint.py: a short real run of the 'budget' protocol,
every stage past every step switch) of every method on one CPU-suite scene
of each kind, and hashes, per method, every logged loss, held-out figure,
step count and collapse verdict. Records of one method pool when their fingerprints agree, and a record
is current when its fingerprint is the one the newest measured commit has
(so that a page is a function of results/ alone; `same_numbers.py --record`
after a change of the training code brings the newest commit forward).
Nobody lists neutral commits by hand: a change that moves no number measures
the same fingerprint.

results/fingerprints.json: {code tree: {"commit", "definition", "methods":
{method: fingerprint}, "scenes", "views", "versions", "time_utc"}}. An entry
without "definition" was measured by the earlier definition (3 steps a stage,
no budget, no evaluation during training); fingerprints of two definitions
never compare equal, and "current" is judged among DEFINITION's entries.

The fingerprint sees what the runs compute, not how fast. Under the 'budget'
protocol speed no longer moves what a run trains (the step table fixes the
counts); records still carry their stages' step rates, and the reports show
them, so a slower code is seen.
"""
import hashlib
import json
import os
import subprocess
import time

from experiments.bench.paths import REPO
from experiments.bench import git_state

FILE = os.path.join(REPO, "results", "fingerprints.json")

# The fingerprint run's definition that entries are measured with now.
DEFINITION = "run-2"

UNRECORDED = "unrecorded"   # the machine of an entry measured before entries named it
UNMEASURED = "unmeasured"   # the record's tree has no fingerprint for its method
MODIFIED = "modified tree"  # the run's training code was not a commit's


def load(path: str = FILE) -> dict:
  if not os.path.exists(path):
    return {}
  with open(path) as f:
    return json.load(f)


def kind_of(config: str) -> str:
  """'configs/dnerf.py:hook_cpu' -> 'dnerf': a record's dataset, its config
  file (the reports' grouping; halo_jax.datasets.scene_kind is the geometry a
  recipe is chosen by). A fingerprint is measured per dataset (one
  fingerprint scene each), so a change of one kind's recipe leaves the other
  kinds' records current."""
  return os.path.splitext(os.path.basename(config.split(":")[0]))[0] if config else ""


def _scene_kinds() -> dict:
  from experiments.bench import suites  # pylint: disable=import-outside-toplevel
  return {s.name: kind_of(s.config) for s in suites.CPU.scenes}


def of_runs(runs: dict, method: str, kind: str = ""):
  """The fingerprint of `method` in same_numbers' figures {"<scene>/<method>":
  {...}} (of its runs on scenes of `kind` alone, where given): 12 hex digits
  of a hash over its runs, or None where it has none."""
  kinds = _scene_kinds() if kind else {}
  mine = {k: v for k, v in runs.items() if k.rsplit("/", 1)[-1] == method
          and (not kind or kinds.get(k.rsplit("/", 1)[0]) == kind)}
  if not mine:
    return None
  return hashlib.sha256(json.dumps(mine, sort_keys=True).encode()).hexdigest()[:12]


def kinds_of_runs(runs: dict, method: str) -> dict:
  """{kind: of_runs(runs, method, kind)} over the kinds `method` ran."""
  kinds = _scene_kinds()
  ran = {kinds.get(k.rsplit("/", 1)[0]) for k in runs if k.rsplit("/", 1)[-1] == method}
  return {k: of_runs(runs, method, k) for k in sorted(x for x in ran if x)}


def machine() -> str:
  """What XLA's CPU code depends on beside the versions: the CPU's model and
  widest vector extension. The same code and versions compute other last
  bits on another CPU (measured: every method's fingerprint at 9aa1915 moved
  between two sessions' machines with nothing else changed)."""
  info = {}
  try:
    with open("/proc/cpuinfo") as f:
      for line in f:
        k, _, v = line.partition(":")
        info.setdefault(k.strip(), v.strip())
  except OSError:
    return "unknown"
  flags = set(info.get("flags", "").split())
  isa = next((x for x in ("avx512f", "avx2", "avx", "sse4_2") if x in flags), "base")
  return (f"{info.get('model name', '?')} (family {info.get('cpu family', '?')}, "
          f"model {info.get('model', '?')}, {isa})")


def record(commit: str, runs: dict, views: int, path: str = FILE, digests=None) -> str:
  """Stores the fingerprints of every method in `runs` (same_numbers' figures
  at `commit`, on this machine) under the commit's code tree; returns a line
  saying so. An entry of an earlier definition is replaced, not added to; a
  measurement on another machine than the entry's goes beside it, under
  "machines". digests: step_table_digests() of the commit's table (None: not
  recorded, for an older commit's)."""
  tree = git_state.code_tree(commit)
  table = load(path)
  methods = sorted({k.rsplit("/", 1)[-1] for k in runs})
  mine = machine()
  if table.get(tree, {}).get("definition") != DEFINITION:
    table[tree] = {"commit": commit, "definition": DEFINITION, "methods": {}, "machine": mine}
  entry = table[tree]
  where = (entry if entry.get("machine", UNRECORDED) == mine
           else entry.setdefault("machines", {}).setdefault(mine, {"methods": {}}))
  where["methods"].update({m: of_runs(runs, m) for m in methods})
  where.setdefault("kinds", {}).update({m: kinds_of_runs(runs, m) for m in methods})
  where.update(versions=git_state.collect(measure_peak=False)["versions"],
               time_utc=time.strftime("%Y-%m-%dT%H:%M:%SZ", time.gmtime()))
  if digests is not None:
    entry["step_table"] = digests
  entry.update(commit_time=commit_time(commit),
               scenes=sorted({k.rsplit("/", 1)[0] for k in runs}), views=views)
  with open(path, "w") as f:
    json.dump(table, f, indent=1, sort_keys=True)
    f.write("\n")
  return f"recorded {len(methods)} fingerprints for code tree {tree} ({commit[:7]}) in {path}"


def suite_step_keys() -> dict:
  """{method: the step-table keys its runs in the suites use} (not the
  studies' variants, whose records carry their own step counts)."""
  from experiments.bench import benchmark, step_times  # pylint: disable=import-outside-toplevel
  keys = {}
  for suite, scene, method in step_times.pairs(groups=step_times.SUITE_GROUPS):
    c = benchmark.configure(suite, scene, method, 0, "budget", "/tmp/halo_step_table_digest")
    keys.setdefault(method, set()).update(step_times.keys_of(c).values())
  return keys


def step_table_digests(path: str = "") -> dict:
  """{method: 12 hex digits of the committed step table's entries (step and
  set-up seconds) for every key the suites use for the method}: the
  fingerprint run writes its own table, so this companion is what sees a
  change of the committed one (a changed entry moves a suite's step counts)."""
  from halo_jax import step_table  # pylint: disable=import-outside-toplevel
  entries = step_table.load(path)
  return {m: hashlib.sha256(json.dumps(
      {k: [entries.get(k, {}).get("step_s"), entries.get(k, {}).get("setup_s")]
       for k in sorted(ks)}, sort_keys=True).encode()).hexdigest()[:12]
          for m, ks in sorted(suite_step_keys().items())}


def step_table_changes(table: dict, now: dict = None) -> list:
  """The methods whose committed step-table entries differ from those the
  newest fingerprint was measured with (now: step_table_digests(), computed
  where not given); [] where they agree or the entry predates the check."""
  measured = newest(table)[1].get("step_table")
  if not measured:
    return []
  now = step_table_digests() if now is None else now
  return sorted(m for m in set(measured) | set(now) if measured.get(m) != now.get(m))


def modified(rec: dict) -> bool:
  """Whether the record's run used training code that no commit holds (an
  old record, without code_dirty, counts any modification)."""
  git = rec.get("provenance", {}).get("git", {})
  return bool(git.get("code_dirty") or (git.get("dirty") and "code_dirty" not in git))


def tree_of(rec: dict):
  """The code tree of a record's commit: stored, or computed from the commit
  as trees were defined when records stored none (None where git does not
  know it)."""
  git = rec.get("provenance", {}).get("git", {})
  return git.get("code_tree") or (git_state.code_tree(git["commit"], with_data=True)
                                  if git.get("commit") else None)


def _trees_of(rec: dict):
  """The keys a record's code may be measured under, in turn: its tree, and
  its commit's tree by today's definition (an old commit measured again)."""
  yield tree_of(rec)
  commit = rec.get("provenance", {}).get("git", {}).get("commit")
  if commit:
    yield git_state.code_tree(commit)


def _measurements(entry: dict):
  """(machine, {method: fingerprint}, {method: {kind: fingerprint}}) of each
  machine's measurement in a table entry."""
  yield entry.get("machine", UNRECORDED), entry.get("methods", {}), entry.get("kinds", {})
  for mach, sub in entry.get("machines", {}).items():
    yield mach, sub.get("methods", {}), sub.get("kinds", {})


def classes(method: str, table: dict, kind: str = "") -> dict:
  """{code tree: fingerprint} for `method` (on scenes of `kind`, where
  given): trees whose code computes the same numbers share one fingerprint.
  Two trees are the same code where one machine measured them equal, over
  every kind or over `kind` (and so on, transitively), since the last bits
  follow the machine (`machine`). A class is named by the fingerprint of its
  earliest commit as first measured, so that a page's names stay put when a
  new machine measures old code or another kind's recipe changes."""
  parent = {}

  def find(t):
    while parent[t] != t:
      parent[t] = parent[parent[t]]
      t = parent[t]
    return t
  groups = {}
  for tree, entry in table.items():
    for mach, methods, kinds in _measurements(entry):
      fp = methods.get(method)
      if fp:
        parent[tree] = tree
        groups.setdefault((mach, "", fp), []).append(tree)
      kfp = kinds.get(method, {}).get(kind) if kind else None
      if fp and kfp:
        groups.setdefault((mach, kind, kfp), []).append(tree)
  for trees in groups.values():
    for t in trees[1:]:
      parent[find(t)] = find(trees[0])
  members = {}
  for t in parent:
    members.setdefault(find(t), []).append(t)
  out = {}
  for trees in members.values():
    first = min(trees, key=lambda t: (table[t].get("commit_time", ""), t))
    name = next(methods[method] for _, methods, _ in _measurements(table[first])
                if methods.get(method))
    out.update({t: name for t in trees})
  return out


def of_record(rec: dict, table: dict) -> str:
  """The record's fingerprint for its method on its scene's kind (its code
  tree's class: `classes`), or MODIFIED / UNMEASURED."""
  if modified(rec):
    return MODIFIED
  kind = kind_of(rec.get("config", ""))
  measured = classes(rec.get("method"), table, kind)
  return next((measured[t] for t in _trees_of(rec) if t in measured), UNMEASURED)


def newest(table: dict):
  """(code tree, entry) of the newest commit measured (by commit time) under
  DEFINITION (any definition where none is), or (None, {}) for an empty table. Pages judge "current" against it, so that
  they are a function of results/ alone; same_numbers --record after a
  change of the training code moves it."""
  if not table:
    return None, {}
  mine = [t for t in table if table[t].get("definition") == DEFINITION] or list(table)
  tree = max(mine, key=lambda t: (table[t].get("commit_time", ""), t))
  return tree, table[tree]


def current(method: str, table: dict, kind: str = ""):
  """The fingerprint (class: `classes`) of `method` (on `kind`) at the newest
  measured commit (None where that measurement has no run of the method)."""
  return classes(method, table, kind).get(newest(table)[0])


def commit_time(commit: str) -> str:
  try:
    return subprocess.run(["git", "-C", REPO, "show", "-s", "--format=%cI", commit],
                          capture_output=True, text=True, check=True).stdout.strip()
  except (OSError, subprocess.SubprocessError):
    return ""


def choose(records, table):
  """(fingerprint, chosen records, set-aside records) of one method's records:
  the measured fingerprint with the most records (the newest run breaks a
  tie); records of other fingerprints, unmeasured trees or modified trees are
  set aside."""
  by = {}
  for r in records:
    fp = of_record(r, table)
    if fp not in (MODIFIED, UNMEASURED):
      by.setdefault(fp, []).append(r)
  if not by:
    return None, [], list(records)
  newest = lambda rs: max(r.get("provenance", {}).get("time_utc", "") for r in rs)  # noqa: E731
  fp = max(by, key=lambda k: (len(by[k]), newest(by[k])))
  return fp, by[fp], [r for r in records if r not in by[fp]]


def of_records(records, table) -> str:
  """The fingerprints of `records`, as met, joined by ', '."""
  seen = []
  for r in records:
    fp = of_record(r, table)
    if fp not in seen:
      seen.append(fp)
  return ", ".join(seen)
