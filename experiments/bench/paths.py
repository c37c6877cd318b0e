"""Where the benchmark's files live: the clone holding this package, whose
results/ and docs/ the tools read and write (their --results and --docs flags
point elsewhere)."""
import os

REPO = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))


def result_path(results, suite_name, mode, scene, method, seed):
  """A suite run's record."""
  return os.path.join(results, suite_name, mode, scene.name, method, f"seed{seed}.json")


def workdir_of(scratch, suite_name, mode, scene, method, seed):
  """A suite run's workdir (checkpoints, renders)."""
  return os.path.join(scratch, suite_name, mode, scene.name, method, f"seed{seed}")


def workdirs_of(scratch, record, mode, scene, method, seed) -> tuple:
  """Where under `scratch` the suite run of `record` may have trained: its
  own workdir, then, for a record adopted from a study's run
  (adopt.identical_study_run), that run's (ablations.py's layout)."""
  own = workdir_of(scratch, record["suite"], mode, scene, method, seed)
  adopted = (record.get("adopted_from") or {}).get("path", "")
  if adopted.startswith("ablations" + os.sep):
    return own, os.path.join(scratch, os.path.splitext(adopted)[0])
  return (own,)
