"""A stage's sampler switch: from a step on, the stage trains (and is scored)
with more samples a ray.

A field trained long enough to sharpen its surface is undersampled by the
samples that suited its first steps, and a dearer sampler from the start
would cost a short run most of its steps. So a stage may switch once:
`sampler.switch_step` (0: never) steps are taken with the stage's sampler,
every step after them with `switch_samples` samples of kind `switch_kind`
('' : the same kind). Switching to another kind sets its first pass
(`num_coarse`, read by the importance kinds) to the stage's own
`num_samples`: switching `depth_guided` to `depth_guided_fine` keeps the
window's samples and adds `switch_samples` drawn from their weights.

A run too short to pass its switch computes exactly what it did without one.
Under the 'budget' protocol the step table prices the steps after the switch
by their own key (`step_table.after_switch_key`), and the reference clock
(stages/loop.py) runs at that rate past it (protocol.resolve).

This module is configuration only: the radiance stage builds a second step
and renderer from `sampler_fields`.
"""
from typing import Dict

from halo_jax import frozen


def switch_step(cfg) -> int:
  """The stage config's switch step (0: none)."""
  return int(cfg.get("sampler", {}).get("switch_step", 0) or 0)


def after(cfg, step) -> bool:
  """Whether the stage's `step`-th step (counted from 1), or a field scored
  after `step` steps, is past its switch."""
  s = switch_step(cfg)
  return bool(s) and step > s


def sampler_fields(sampler_cfg) -> Dict[str, object]:
  """{field: value} of the sampler section after the switch (the switch
  itself cleared)."""
  kind = sampler_cfg.switch_kind or sampler_cfg.kind
  out = {"kind": kind, "num_samples": int(sampler_cfg.switch_samples), "switch_step": 0}
  if kind != sampler_cfg.kind:
    out["num_coarse"] = int(sampler_cfg.num_samples)
  return out


def overrides(config, name) -> Dict[str, object]:
  """{dotted field: value} turning stage `name` of `config` into its
  sampler after the switch."""
  fields = sampler_fields(config[name].sampler)
  return {f"{name}.sampler.{k}": v for k, v in fields.items()}


def switched(config, name):
  """A new frozen config: `config` whose stage `name` samples from its first
  step as it does after its switch (what the step table's after-switch key
  is measured on)."""
  return frozen.replaced(config, overrides(config, name))


def stage_after(cfg):
  """A new frozen stage section: `cfg` sampling as it does after its switch."""
  return frozen.replaced(cfg, {f"sampler.{k}": v for k, v in sampler_fields(cfg.sampler).items()})
