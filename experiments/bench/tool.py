"""How a benchmark tool launches from its driver (python experiments/<tool>.py)."""
import sys

from absl import app, flags


def run(module, main):
  """absl-runs `main` with `module`'s flags as the launch's key flags and its
  docstring as the usage --help prints (the launching file is a wrapper)."""
  sys.modules["__main__"].__doc__ = module.__doc__
  flags.adopt_module_key_flags(module)
  app.run(main)
