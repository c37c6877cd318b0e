"""The package's shape: imports go one way through the layers, without
cycles; modules and functions stay small; every registry entry is usable."""
import ast
import pathlib

import pytest

from halo_jax import datasets, models, samplers
from halo_jax.frequency import view_pairs
from halo_jax.methods import METHODS
from halo_jax.stages import base, terms

PACKAGE = pathlib.Path(__file__).resolve().parent.parent / "halo_jax"

# Bottom to top: numerics, models and data, training, entry points. A module
# may import modules of its own layer or below.
LAYERS = (
    {"registry", "types", "geometry", "rays", "trig", "encoding", "camera", "rng", "samplers", "render", "raycast",
     "losses", "metrics", "lightfield", "frequency", "frequency.spectrum", "plots", "provenance", "visibility",
     "tensorboard", "video", "image_files", "config_files", "tables", "step_table", "progress",
     "atomic", "frozen", "sampler_switch"},
    {"models", "ray_fields", "datasets", "checkpoint", "parallel", "evaluate", "defaults",
     "light_field_defaults", "camera_paths", "frequency.view_pairs",
     "workdir_lock"},
    {"stages", "frequency.tuning", "validate", "methods", "configure", "pipeline", "user_errors",
     "protocol",
     "restore", "runs", "viewer"},
    {"cli", "integrations"},
)


def module_name(path: pathlib.Path) -> str:
  rel = path.relative_to(PACKAGE).with_suffix("")
  parts = list(rel.parts)
  if parts[-1] == "__init__":
    parts.pop()
  return ".".join(parts)


def layer_of(name: str) -> int:
  """The layer of halo_jax.<name>: its own entry, else its top package's."""
  for i in reversed(range(len(LAYERS))):
    if name in LAYERS[i] or name.split(".")[0] in LAYERS[i]:
      return i
  raise AssertionError(f"halo_jax.{name} is in no layer of tests/test_architecture.py")


def imports_of(path: pathlib.Path, known) -> set:
  """The halo_jax modules `path` imports by name (not their parent packages)."""
  out = set()
  for node in ast.walk(ast.parse(path.read_text())):
    if isinstance(node, ast.Import):
      out.update(a.name[len("halo_jax."):] for a in node.names if a.name.startswith("halo_jax."))
    elif isinstance(node, ast.ImportFrom) and node.module and (
        node.module == "halo_jax" or node.module.startswith("halo_jax.")):
      mod = node.module[len("halo_jax."):] if node.module != "halo_jax" else ""
      for a in node.names:
        sub = f"{mod}.{a.name}" if mod else a.name
        out.add(sub if sub in known else mod)
  return {m for m in out if m}


def graph():
  paths = {module_name(p): p for p in PACKAGE.rglob("*.py")}
  return {name: imports_of(p, paths) for name, p in paths.items() if name}


def upward_imports(g):
  return [f"halo_jax.{a} (layer {layer_of(a)}) imports halo_jax.{b} (layer {layer_of(b)})"
          for a, deps in sorted(g.items()) for b in sorted(deps) if layer_of(b) > layer_of(a)]


def find_cycle(g):
  """One import cycle of graph g as a list of names, or None."""
  state, stack = {}, []

  def visit(n):
    state[n] = "open"
    stack.append(n)
    for m in sorted(g.get(n, ())):
      if state.get(m) == "open":
        return stack[stack.index(m):] + [m]
      if m not in state:
        found = visit(m)
        if found:
          return found
    stack.pop()
    state[n] = "done"
    return None

  for n in sorted(g):
    if n not in state:
      found = visit(n)
      if found:
        return found
  return None


def test_every_import_goes_down_or_sideways():
  bad = upward_imports(graph())
  assert not bad, "upward imports:\n" + "\n".join(bad)


def test_no_import_cycles():
  cycle = find_cycle(graph())
  assert cycle is None, "import cycle: " + " -> ".join(cycle)


def test_the_checks_catch_what_they_look_for():
  g = graph()
  # the real graph has edges (the tests above are not vacuous) ...
  assert "raycast" in g["stages.radiance"] and "stages.base" in g["pipeline"]
  assert "stages.radiance" in g["stages"]  # the package registers its trainers
  # ... and a graph with an upward import and a cycle is caught
  bad = {"encoding": {"models"}, "models": {"stages.loop"}, "stages.loop": {"models"}}
  assert len(upward_imports(bad)) == 2
  assert find_cycle(bad) == ["models", "stages.loop", "models"]
  assert (layer_of("cli.train"), layer_of("cli.render"), layer_of("render")) == (3, 3, 0)


def test_modules_and_functions_stay_small():
  long = []
  for p in PACKAGE.rglob("*.py"):
    src = p.read_text()
    if len(src.splitlines()) > 400:
      long.append(f"{p.name}: {len(src.splitlines())} lines")
    for node in ast.walk(ast.parse(src)):
      if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)):
        n = node.end_lineno - node.lineno + 1
        if n > 60:
          long.append(f"{p.name}:{node.lineno} {node.name}: {n} lines")
  assert not long, "\n".join(long)


@pytest.mark.parametrize("registry, expected", [
    (datasets.LOADERS, {"blender", "procedural", "dnerf", "llff", "stanford_lf", "capture",
                        "capture_ff", "llff_planes"}),
    (models.MODELS, {"nerf", "deform", "epi"}),
    (samplers.SAMPLERS, {"stratified", "hierarchical", "coarse_fine", "depth_guided",
                         "depth_guided_fine", "joint",
                           "joint_blended", "joint_blended_even"}),
    (terms.TERMS, {"consist", "empty", "occlusion", "lf_consist", "lf_nerf_consist", "lf_color",
                   "lf_random", "unseen"}),
    (base.TRAINERS, {"radiance", "ray_field", "light_field"}),
    (METHODS, {"halo", "nerf_tuned", "nerf_paper", "freenerf", "halo+freenerf", "halo_auto",
               "halo+unseen", "halo_joint", "halo_authors"}),
    (view_pairs.PAIR_KINDS, {"orbit", "orbit_time", "spiral", "uv"}),
])
def test_registries_hold_every_entry(registry, expected):
  import halo_jax.pipeline  # noqa: F401  (registers the stage trainers)
  # none lost; a new entry (a method module and its registry line) needs no edit here
  assert expected <= set(registry.names())


def _accepts(fn, protocol) -> bool:
  """Whether `fn` takes the arguments the Protocol's __call__ names."""
  import inspect
  names = list(inspect.signature(protocol.__call__).parameters)[1:]  # less self
  try:
    inspect.signature(fn).bind(*names)
  except TypeError:
    return False
  return True


class _RuleFn:  # base.Derived's rule(config, scene)
  def __call__(self, config, scene): ...


def test_registry_entries_keep_their_typed_interfaces():
  import halo_jax.pipeline  # noqa: F401  (registers the stage trainers)
  from halo_jax.methods import base as method_base
  bad = []
  fields = {"requires": base.RequiresFn, "params_like": base.ParamsLikeFn,
            "train": base.TrainFn, "check": base.CheckFn, "renderer": base.RendererFn,
            "guide": base.GuideFn}
  for name, t in base.TRAINERS.items():
    bad += [f"trainer {name}.{f}" for f, p in fields.items()
            if getattr(t, f) is not None and not _accepts(getattr(t, f), p)]
  fields = {"active": terms.ActiveFn, "weight": terms.WeightFn, "value": terms.ValueFn,
            "needs": terms.NeedsFn, "prepare": terms.PrepareFn}
  for name, t in terms.TERMS.items():
    bad += [f"term {name}.{f}" for f, p in fields.items()
            if getattr(t, f) is not None and not _accepts(getattr(t, f), p)]
  # a method is data: per scene kind a table of values, edits and derived rules
  for n, m in METHODS.items():
    for kind, table in m.tables.items():
      bad += [f"method {n}.tables[{kind!r}]"] if kind not in method_base.KINDS else []
      bad += [f"method {n} {kind} {f}: rule" for f, v in table.items()
              if isinstance(v, method_base.Derived) and not _accepts(v.rule, _RuleFn)]
  assert not bad, "entries whose callables do not take their interface's arguments: " + str(bad)
  # the check itself can fail
  assert not _accepts(lambda a, b, c: None, terms.ActiveFn)
  assert not _accepts(lambda ctx, extra: None, base.TrainFn)
