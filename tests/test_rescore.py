"""rescore.py: a variant that changes only how a run renders is scored on its
reference's trained run; one that changes what trains is refused."""
import pytest

from halo_jax import frozen, restore
from halo_jax.configure import finish
from experiments.bench import fingerprint, rescore, suites

LATTICE = next(s for s in suites.VALIDATION_SCENES if s.name == "lattice")


def _config(tmp_path, overrides=()):
  return fingerprint.suite_config(LATTICE, "halo", str(tmp_path), overrides=overrides)


def test_only_render_fields_may_differ(tmp_path):
  ref = _config(tmp_path)
  dense = _config(tmp_path, (("hi.sampler.dense_eval_after", 1000),
                             ("hi.sampler.dense_eval_samples", 96)))
  assert rescore.render_fields(ref, dense) == (("hi.sampler.dense_eval_after", 1000),
                                               ("hi.sampler.dense_eval_samples", 96))
  assert rescore.render_fields(ref, ref) == ()
  with pytest.raises(rescore.NotRenderOnly, match="hi.sampler.num_samples"):
    rescore.render_fields(ref, _config(tmp_path, (("hi.sampler.num_samples", 64),)))
  selecting = frozen.thaw(dense)
  selecting.hi.select_best = True
  with pytest.raises(rescore.NotRenderOnly, match="select_best"):
    rescore.render_fields(ref, finish(selecting))


def test_a_render_field_a_run_stored_before_it_existed_is_added():
  stored = frozen.thaw(_config("/tmp/halo_rescore_test"))
  del stored.hi.sampler["dense_eval_after"]
  got = restore._laid_over(frozen.freeze(stored), (("hi.sampler.dense_eval_after", 5),))  # pylint: disable=protected-access
  assert got.hi.sampler.dense_eval_after == 5
  with pytest.raises(KeyError):
    restore._laid_over(frozen.freeze(stored), (("hi.sampler.no_such_field", 5),))  # pylint: disable=protected-access


@pytest.mark.slow
def test_a_run_scored_again_gives_its_record_and_a_render_field_moves_it(tmp_path):
  """A fingerprint-sized lattice run: scored as trained, its record's PSNR;
  rendered densely from its first Hi step, another."""
  from halo_jax import runs  # pylint: disable=import-outside-toplevel
  c, _ = fingerprint.configure(LATTICE, "halo", str(tmp_path))
  workdir = str(tmp_path / "run")
  record = runs.run_method(c, workdir)
  same = rescore.rescored(record, workdir, (), False)
  assert same["psnr"] == pytest.approx(record["psnr"], abs=rescore.SAME_DB)
  dense = rescore.rescored(record, workdir, (("hi.sampler.dense_eval_after", 1),), False)
  assert abs(dense["psnr"] - record["psnr"]) > 0.01
  assert dense["stages"]["hi"]["psnr"] == dense["psnr"]
  assert dense["stages"]["lo"] == record["stages"]["lo"]   # what trained is the reference's
  with pytest.raises(rescore.NotRenderOnly, match="not the record's run"):
    rescore.rescored(dict(record, psnr=record["psnr"] + 1.0), workdir, (), False)


def test_a_variant_is_rendered_on_the_run_of_its_training_fields():
  from experiments.bench.study_types import Variant  # pylint: disable=import-outside-toplevel
  switched = (("hi.sampler.switch_step", 2000), ("hi.sampler.switch_samples", 64))
  dense = Variant("d", "halo", switched + (("hi.sampler.dense_eval_after", 2000),
                                           ("hi.sampler.dense_eval_samples", 128)))
  trained = rescore.as_trained(dense)
  assert trained.overrides == switched + (("hi.sampler.dense_eval_after", 0),)
  assert trained.method == "halo"
  plain = Variant("p", "halo", switched)
  assert rescore.as_trained(plain) is plain


def test_a_suite_record_adopted_from_a_study_is_found_in_the_studys_workdir():
  from experiments.bench import paths  # pylint: disable=import-outside-toplevel
  own = ("/s/budget_960/budget/lattice/nerf_tuned/seed1",)
  record = {"suite": "budget_960"}
  assert paths.workdirs_of("/s", record, "budget", LATTICE, "nerf_tuned", 1) == own
  record["adopted_from"] = {"path": "ablations/hi_window_960/lattice/twin/seed1.json"}
  assert paths.workdirs_of("/s", record, "budget", LATTICE, "nerf_tuned", 1) == own + (
      "/s/ablations/hi_window_960/lattice/twin/seed1",)
