"""The fingerprint run (experiments/bench/fingerprint.py): the CPU suite's run at
shrunk sizes, every stage past every switch the suite's run crosses, on the
'budget' protocol's reference clock; and the table of fingerprints
(code_version.py) across definitions."""
import json
import os
import subprocess
import sys

import pytest

from halo_jax import config_files, protocol, step_table
from experiments.bench import code_version, fingerprint, suites
from halo_jax.stages import collapse
from halo_jax.stages.order import needed

REPO = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
SCENES = {s.name: s for s in suites.CPU.scenes}
KINDS = ("lattice", "lego_8view", "dnerf_hook", "fern_4view", "knights")


def _runs():
  return [(SCENES[n], m) for n in KINDS for m in SCENES[n].methods]


def _switches(cfg):
  return [v for v in (fingerprint._get(cfg, f) for f in fingerprint.SWITCHES) if v]  # pylint: disable=protected-access


@pytest.mark.parametrize("scene,method", _runs(), ids=lambda x: getattr(x, "name", x))
def test_every_stage_passes_every_switch_the_suite_run_crosses(scene, method, tmp_path):
  full = protocol.effective(fingerprint.suite_config(scene, method, str(tmp_path)))
  c, counts = fingerprint.configure(scene, method, str(tmp_path))
  c = protocol.effective(c)
  assert set(counts) == set(needed(full, full.final_stage))
  for name, count in counts.items():
    reached = full[name].budget_steps or full[name].steps
    crossed = [v for v in _switches(full[name]) if v <= reached]
    room = (collapse.MIN_RECORDS + 1) * full[name].log_every
    assert count == max(crossed, default=0) + room  # the collapse check judges past it
    assert c[name].budget_steps == count            # the protocol gives exactly that
    # the reference clock spans the suite's budget, so fronts and curves fall in the run
    assert c[name].ref_offset_s + count * c[name].ref_step_s == pytest.approx(
        sum(c.budget_shares[n] for n in list(counts)[:list(counts).index(name) + 1])
        / sum(c.budget_shares[n] for n in counts) * full.budget_s, rel=1e-9)
  assert c.protocol == "budget" and c.budget_s == full.budget_s


def test_only_sizes_change_from_the_suite_run(tmp_path):
  scene = SCENES["lego_8view"]
  full = fingerprint.suite_config(scene, "halo", str(tmp_path))
  c, _ = fingerprint.configure(scene, "halo", str(tmp_path))
  a, b = (config_files.dotted_fields(x.to_dict()) for x in (full, c))
  sized = {f"{n}.{f}" for n in ("lo", "ray", "hi") for f, _ in fingerprint.STAGE_SIZES}
  sized |= {f for f, _ in fingerprint.CONFIG_SIZES}
  bookkeeping = {"step_table", "eval.lpips", "eval.save_images", "eval.flicker_frames"}
  bookkeeping |= {f"{n}.checkpoint_every" for n in ("lo", "ray", "hi")}
  bookkeeping |= {k for k in a if k.startswith("plan.")}  # the counts the protocol works out
  moved = {k for k in a if a[k] != b[k]} - sized - bookkeeping
  assert not moved
  assert b["lo.model.width"] < a["lo.model.width"]
  assert b["hi.batch_rays"] < a["hi.batch_rays"]


def test_its_table_keys_are_the_shrunk_configs(tmp_path):
  scene = SCENES["lego_8view"]
  c, counts = fingerprint.configure(scene, "halo", str(tmp_path))
  table = step_table.load(c.step_table)
  assert set(table) == {step_table.key(c, n) for n in counts}
  assert not set(table) & set(step_table.load())  # never the reference machine's entries


def test_a_definition_replaces_the_earlier_one_and_current_is_judged_within_it(tmp_path):
  try:
    head = subprocess.run(["git", "-C", REPO, "rev-parse", "HEAD"], capture_output=True,
                          text=True, check=True).stdout.strip()
  except (OSError, subprocess.CalledProcessError):
    pytest.skip("not a git checkout")
  from experiments.bench import git_state
  tree = git_state.code_tree(head)
  path = str(tmp_path / "fingerprints.json")
  old = {tree: {"commit": head, "methods": {"halo": "aaaaaaaaaaaa", "freenerf": "bbbbbbbbbbbb"},
                "commit_time": "2000-01-01"},
         "f" * 12: {"commit": "0" * 40, "methods": {"halo": "cccccccccccc"},
                    "commit_time": "2999-01-01"}}
  with open(path, "w") as f:
    json.dump(old, f)
  figures = {"lattice/halo": {"losses": {"lo": [[50, 0.1]]}, "psnr": [12.0]}}
  code_version.record(head, figures, views=1, path=path)
  table = code_version.load(path)
  assert table[tree]["definition"] == code_version.DEFINITION
  assert set(table[tree]["methods"]) == {"halo"}  # the earlier definition's freenerf is gone
  # the later commit measured by the earlier definition is not "newest"
  assert code_version.newest(table)[0] == tree
  assert code_version.current("halo", table) == code_version.of_runs(figures, "halo")


@pytest.mark.slow
def test_a_fingerprint_run_trains_its_counts_on_the_reference_clock(tmp_path):
  """lattice/nerf_tuned end to end: the steps it was given, the front's
  snapshots and the curve's points at the steps of their reference times,
  judged learned, scored."""
  out = tmp_path / "figures.json"
  subprocess.run([sys.executable, "-m", "experiments.same_numbers",
                  f"--out={out}", "--scenes=lattice", "--methods=nerf_tuned"], check=True,
                 cwd=REPO)
  r = json.loads(out.read_text())["lattice/nerf_tuned"]
  c, counts = fingerprint.configure(SCENES["lattice"], "nerf_tuned", str(tmp_path))
  hi = protocol.effective(c).hi
  clock = lambda step: hi.ref_offset_s + hi.ref_setup_s + step * hi.ref_step_s  # noqa: E731
  assert r["steps"] == counts and not r["collapsed"]
  # a snapshot is the first step whose reference clock reaches its time; a
  # curve point the first whose clock is eval_every_s past the last point's
  steps = range(1, counts["hi"] + 1)
  assert r["snapshots"]["hi"] == [next(s for s in steps if clock(s) >= t)
                                  for t in c.eval.front_s]
  curve, last = [], clock(0)
  for s in steps:
    if clock(s) - last >= hi.eval_every_s:
      curve.append(s)
      last = clock(s)
  assert curve and curve[0] < counts["hi"]
  assert [s for s, _ in r["heldout"]["hi"]] == sorted(set(curve) | {counts["hi"]})
  assert len(r["psnr"]) == 1 and r["psnr"][0] > 8.0
  assert [s for s, _ in r["losses"]["hi"]] == list(range(c.hi.log_every, counts["hi"] + 1,
                                                         c.hi.log_every))


def test_a_run_past_a_sampler_switch_is_fingerprinted_past_it(tmp_path):
  """A study variant whose Hi switches its sampler within the suite's run:
  the fingerprint run crosses the switch too, and its table prices the steps
  after it (at the same rate, so the count is exact)."""
  scene = SCENES["lego_8view"]
  switch = (("hi.sampler.switch_step", 100), ("hi.sampler.switch_samples", 64))
  c, counts = fingerprint.configure(scene, "halo", str(tmp_path), overrides=switch)
  full = protocol.effective(fingerprint.suite_config(scene, "halo", str(tmp_path),
                                                     overrides=switch))
  assert full.hi.ref_switch_step == 100        # the suite's run passes it
  crossed = [v for v in _switches(full.hi) if v <= full.hi.budget_steps]
  assert counts["hi"] == max(crossed) + (collapse.MIN_RECORDS + 1) * full.hi.log_every
  assert step_table.after_switch_key(c, "hi") in step_table.load(c.step_table)
  trained = protocol.effective(c)
  assert trained.hi.budget_steps == counts["hi"] and trained.hi.ref_switch_step == 100
