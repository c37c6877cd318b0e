"""Files written whole or not at all: a killed write leaves the old file (or
none), never half of a new one. Every writer of a run's small files uses it."""
import json
import os


def write_text(path: str, text: str) -> None:
  """Writes `text` to `path` through a temporary file beside it."""
  os.makedirs(os.path.dirname(path) or ".", exist_ok=True)
  tmp = path + ".tmp"
  with open(tmp, "w") as f:
    f.write(text)
  os.replace(tmp, path)


def write_json(path: str, obj, **dump_kwargs) -> None:
  """`obj` as JSON (json.dumps' keyword arguments) at `path`, atomically."""
  write_text(path, json.dumps(obj, **dump_kwargs))
