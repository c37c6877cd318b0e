"""A small committed result file of finished runs ({'runs': [record, ...]}),
added to one run at a time so that a killed experiment resumes."""
import json
import os


def read(path: str) -> dict:
  if not os.path.exists(path):
    return {"runs": []}
  with open(path) as f:
    return json.load(f)


def write_json(path: str, obj) -> None:
  """Writes `obj` to `path` atomically: a killed write leaves no half file."""
  os.makedirs(os.path.dirname(path) or ".", exist_ok=True)
  with open(path + ".tmp", "w") as f:
    json.dump(obj, f, indent=1)
  os.replace(path + ".tmp", path)


def append(path: str, data: dict, record: dict) -> None:
  """Adds `record` to `data` and writes the file atomically."""
  data["runs"].append(record)
  write_json(path, data)
