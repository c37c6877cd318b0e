"""The command-line entry points, one module per console script:

  halo-train    halo_jax/cli/train.py     train a method's stages
  halo-eval     halo_jax/cli/evaluate.py  score a finished stage on a split
  halo-render   halo_jax/cli/render.py    videos along a camera path
  halo-compare  halo_jax/cli/compare.py   every method on one scene, equal time
  halo-sweep    halo_jax/cli/sweep.py     a grid of config overrides

Each is also `python -m halo_jax.cli.<name>`. Nothing below this package
imports it. The commands that take a --config take the method apart from it
(--method, or --methods for halo-compare): the config file names a scene,
halo_jax/configure.py makes it into the method.
"""
import contextlib
import sys

from absl import app, flags, logging
from ml_collections import config_flags

from halo_jax import config_files, configure, frozen, methods, user_errors, workdir_lock


def define_method_flag():
  """--method, for the commands that train one method from --config."""
  flags.DEFINE_enum("method", "halo", sorted(methods.METHODS.names()),
                    "The method trained on --config's scene (halo_jax/methods).")


def define_config_flag(help_string: str = "Scene config (path[:variant])."):
  """--config: a scene config file, with its dotted overrides as
  --config.<field>=VALUE (ml_collections parses and type-checks them)."""
  config_flags.DEFINE_config_file("config", None, help_string, lock_config=True)


def config_of_flags(config_flag, method: str, overrides=None):
  """The run's frozen config: --config's scene made into `method` with
  --config's dotted overrides (then `overrides`, a command's own), by
  configure.compose, the composition every entry point shares.
  config_flag: FLAGS['config']."""
  fields = config_files.dotted_fields(config_flags.get_override_values(config_flag))
  fields.update(overrides or {})
  return configure.compose(config_flags.get_config_filename(config_flag), method, fields)


def config_refusal(argv) -> str:
  """The one-line refusal of argv's --config, or ''. Refused: a config file
  that does not exist, a variant its file rejects (configs raise ValueError
  naming the variants they know), and the first --config.<field>=VALUE whose
  field the scene's config lacks (with the nearest field names).
  ml_collections would refuse each too, in a traceback, while parsing flags;
  any other error in a config file is a bug and keeps its traceback."""
  spec = next((a.split("=", 1)[1] for a in argv if a.startswith("--config=")), None)
  fields = [a.split("=", 1)[0][len("--config."):] for a in argv if a.startswith("--config.")]
  if not spec:
    return ""
  try:
    scene = configure.load_scene(spec)
  except (FileNotFoundError, ValueError) as e:
    return f"--config={spec}: {e}"
  for field in fields:
    try:
      frozen.get_field(scene, field)
    except KeyError as e:
      return f"--config.{field}: {e.args[0]} ({spec})"
  return ""


def run_app(main, argv=None):
  """absl's app.run of `main` with --config's spec resolved
  (config_files.resolve_argv), after a config that does not load or a
  mistyped override field is refused in one line and exit 2."""
  argv = config_files.resolve_argv(argv)
  refused = config_refusal(argv)
  if refused:
    print(f"error: {refused}", file=sys.stderr)
    raise SystemExit(user_errors.EXIT_CODE)
  app.run(main, argv=argv)


@contextlib.contextmanager
def launch(workdir: str = ""):
  """One command's launch, the same for every command: absl's logging quieted
  (orbax logs every save at INFO), bad input reported as one line and exit 2
  instead of a traceback, and `workdir`, where given, locked for the launch
  (a command that trains locks through pipeline.run instead)."""
  logging.set_verbosity(logging.WARNING)
  lock = workdir_lock.hold(workdir) if workdir else contextlib.nullcontext()
  with user_errors.reported(), lock:
    yield
