"""A small committed result file of finished runs ({'runs': [record, ...]}),
added to one run at a time so that a killed experiment resumes."""
import json
import os

from halo_jax import atomic


def read(path: str) -> dict:
  if not os.path.exists(path):
    return {"runs": []}
  with open(path) as f:
    return json.load(f)


def write_json(path: str, obj) -> None:
  """Writes `obj` to `path` atomically: a killed write leaves no half file."""
  atomic.write_json(path, obj, indent=1)


def append(path: str, data: dict, record: dict) -> None:
  """Adds `record` to `data` and writes the file atomically."""
  data["runs"].append(record)
  write_json(path, data)
