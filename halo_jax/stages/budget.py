"""The time budget, in one place: how `budget_s` is split over a method's
stages, what each stage may still spend when it starts, and when a stage's
loop stops.

A method's `budget_s` > 0 is split over the stages its output stage needs by
`budget_shares`, normalised over those stages, so that a launch of one stage
gets the time it gets in a full run and a one-stage baseline gets all of it.
A stage that reaches its `steps` cap before its share leaves the rest to the
next; one that runs past its share (its `min_steps` floor) takes the excess
from the next, so the method trains for `budget_s`; the last stage's floor is
the only way past it. Training seconds exclude compilation and held-out
evaluations; work a stage does before its loop (rendering targets, a bank of
rays) is taken from its own share.
"""
import copy

from halo_jax.stages.order import needed


def split(config):
  """A copy of config whose stages' max_seconds split config.budget_s by
  share over the stages config.final_stage needs (none without a budget)."""
  config = copy.deepcopy(config)
  if config.budget_s > 0:
    names = needed(config, config.final_stage)
    total = sum(config.budget_shares[n] for n in names)
    for n in names:
      config[n].max_seconds = config.budget_s * config.budget_shares[n] / total
  return config


def cumulative(config) -> dict:
  """{stage: seconds of a split config's budget given to the method's stages
  up to and including it}."""
  until, total = {}, 0.0
  for n in needed(config, config.final_stage):
    total += config[n].max_seconds
    until[n] = total
  return until


def start_stage(config, name, until, spent):
  """Sets stage `name`'s max_seconds to what is left of the budget up to it
  (`until`, cumulative's) after `spent` seconds of the stages before it."""
  if config.budget_s > 0:
    config[name].max_seconds = max(until[name] - spent, 1e-3)


def minus_seconds(cfg, seconds):
  """A copy of a stage config whose time cap leaves room for `seconds` the stage
  already spent outside the loop (e.g. rendering Lo-NeRF targets)."""
  cfg = copy.deepcopy(cfg)
  if cfg.max_seconds:
    cfg.max_seconds = max(cfg.max_seconds - seconds, 1e-3)
  return cfg


def last_step(cfg) -> int:
  """The step a stage's loop ends at: `steps`, or `stop_at_step` when set and sooner."""
  return min(cfg.steps, cfg.stop_at_step or cfg.steps)


def out_of_time(cfg, wall_s, step) -> bool:
  """Whether the stage stops before `step` after `wall_s` training seconds:
  its time cap is reached and `step` is past its floor of steps
  (min(min_steps, steps)), so that no stage of a method is left untrained on
  a slow machine."""
  return bool(cfg.max_seconds) and wall_s >= cfg.max_seconds and step > min(cfg.min_steps,
                                                                              cfg.steps)


def past_time_cap(cfg, wall_s, start, step) -> bool:
  """Whether a loop from `start` to `step` trained past its time cap because
  of its floor of steps."""
  return bool(cfg.max_seconds and wall_s > cfg.max_seconds and start < step <= cfg.min_steps)
