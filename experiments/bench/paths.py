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
