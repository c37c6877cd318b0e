"""The Method record and its tables, apart from the registry so method
modules can import them.

A method declares, per scene kind, a table of dotted config fields: values,
structural edits of a section (`Edit`), and derived fields (`Derived`).
configure.compose writes them in one order, whatever the entry point:
the scene's config, then the table's values and edits, then the user's
overrides, then each derived field not overridden, in the table's order.
So a derived field follows its source whether a table or an override set
it, and nothing a method sets depends on the order the user's choices came in.
"""
import dataclasses
from typing import Any, Callable, Dict, Mapping, Tuple

from halo_jax import frozen, geometry
from halo_jax.types import Config

# The scene kinds a method's tables are keyed by (datasets.scene_kind).
KINDS = ("sphere", "ndc", "dynamic", "two_plane")


@dataclasses.dataclass(frozen=True)
class Derived:
  """A field computed after the overrides: rule(config, scene) -> value.
  config is the run's config with every value, override and earlier derived
  field set; scene is the scene's config as its file built it (its facts,
  before any method or override). A rule reads no protocol field: the
  protocol is resolved after it (halo_jax/protocol.py)."""
  rule: Callable[[Config, Config], Any]


@dataclasses.dataclass(frozen=True)
class Edit:
  """A structural change of the section at the table's key, made with its
  fields unlocked: fn(section) may add fields (a stage turned into another
  trainer's). Applied with the values, before the overrides."""
  fn: Callable[[Config], Any]


# One table: dotted field -> value, Edit or Derived, in the order written.
Table = Mapping[str, Any]


@dataclasses.dataclass(frozen=True)
class Method:
  """summary: one line for tables and --help; tables: scene kind -> Table
  (a kind without one is a kind the method does not run on); geometries:
  the ray geometries of the scenes it runs on; dynamic: whether it runs on
  time-dependent scenes; role: COMPARED (halo-compare's default and the
  benchmark's suites), REPORTED (the suites only) or "" (run on request)."""
  summary: str
  tables: Mapping[str, Table]
  geometries: frozenset = geometry.ALL
  dynamic: bool = True
  role: str = ""

  def table(self, kind: str) -> Dict[str, Any]:
    return dict(self.tables.get(kind, {}))


COMPARED, REPORTED = "compared", "reported"


def every_kind(table: Table) -> Dict[str, Table]:
  """The same table on every scene kind."""
  return {k: dict(table) for k in KINDS}


def sample_switch(step: int) -> Dict[str, Derived]:
  """Table entries for long runs at the CPU sizes, where a method's Hi samples
  too sparsely and a short run never reaches `step`: once Hi has trained
  `step` steps its samples double, and its held-out views are rendered with
  twice those again, stratified over the whole ray (for HALO's window and
  the baseline alike; docs/results/ablation_hi_window_960.md). The paper
  sizes keep their config's. Written after the table's num_samples."""
  cpu = lambda rule, field: Derived(  # noqa: E731
      lambda c, scene: rule(c.hi.sampler) if c.sizing == "cpu" else c.hi.sampler[field])
  return {
      "hi.sampler.switch_step": cpu(lambda s: step, "switch_step"),
      "hi.sampler.switch_samples": Derived(lambda c, scene: 2 * c.hi.sampler.num_samples),
      # past the switch as set, overrides included (0: no switch, no dense renders)
      "hi.sampler.dense_eval_after": cpu(lambda s: s.switch_step, "dense_eval_after"),
      "hi.sampler.dense_eval_samples": cpu(lambda s: 2 * s.switch_samples,
                                           "dense_eval_samples"),
  }


def on_top_of(first: Method, tables: Mapping[str, Table]) -> Dict[str, Table]:
  """`first`'s tables with `tables` (kind -> table) written after them: a
  field in both takes the later setting."""
  return {k: {**first.table(k), **tables.get(k, {})} for k in first.tables}


def write_values(c: Config, table: Table) -> Tuple[Tuple[str, Derived], ...]:
  """Writes `table`'s values and edits into c, in order; returns its derived
  fields, in order, for `write_derived`. KeyError naming a field no config has."""
  rules = []
  for dotted, value in table.items():
    if isinstance(value, Derived):
      frozen.set_field(c, dotted, frozen.get_field(c, dotted))  # names a missing field now
      rules.append((dotted, value))
    elif isinstance(value, Edit):
      section = frozen.get_field(c, dotted)
      with section.unlocked():
        value.fn(section)
    else:
      frozen.set_field(c, dotted, value)
  return tuple(rules)


def write_derived(c: Config, scene: Config, rules, skip=()) -> Config:
  """Sets each derived field of `rules` but those in `skip` (the overrides)."""
  for dotted, derived in rules:
    if dotted not in skip:
      frozen.set_field(c, dotted, derived.rule(c, scene))
  return c
