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


def test_a_rescored_record_takes_its_earlier_stages_validation_from_its_reference(tmp_path):
  import hashlib  # pylint: disable=import-outside-toplevel
  import json  # pylint: disable=import-outside-toplevel
  from experiments.bench import adopt  # pylint: disable=import-outside-toplevel
  lo = {"psnr": 20.0, "ssim": 0.7, "learned": "learned"}
  reference = {"validation": {"split": "val", "num_views": 2, "stages": {
      "lo": lo, "hi": {"psnr": 23.0, "ssim": 0.9, "learned": "learned"}}}}
  path = tmp_path / "budget_960" / "r.json"
  path.parent.mkdir()
  path.write_text(json.dumps(reference))
  digest = hashlib.sha256(path.read_bytes()).hexdigest()
  record = {"resolved_config": {"data": {"test_split": "val", "test_views": "all"}},
            "stages": {"lo": {"psnr": 20.0}, "ray": {}, "hi": {"psnr": 24.0}},
            "psnr": 24.0, "ssim": 0.92, "num_views": 2, "heldout_learned": {"lo": "learned",
                                                                            "hi": "learned"},
            "rescored_from": {"path": "budget_960/r.json", "sha256": digest,
                              "fields": [["hi.sampler.dense_eval_after", 2000]]}}
  got = adopt.validation_from(record, "val", str(tmp_path))
  assert got == {"split": "val", "num_views": 2, "stages": {
      "lo": lo, "hi": {"psnr": 24.0, "ssim": 0.92, "learned": "learned"}}}
  # a reference changed since, a render field of an earlier stage, or none: not derived
  assert adopt.validation_from(dict(record, rescored_from=dict(
      record["rescored_from"], sha256="0" * 64)), "val", str(tmp_path)) is None
  assert adopt.validation_from(dict(record, rescored_from=dict(
      record["rescored_from"], fields=[["lo.sampler.dense_eval_after", 1]])), "val",
      str(tmp_path)) is None
  plain = {k: v for k, v in record.items() if k != "rescored_from"}
  assert adopt.validation_from(plain, "val", str(tmp_path)) is None
  # one scored stage needs no reference
  single = dict(plain, stages={"hi": {"psnr": 24.0}}, heldout_learned={"hi": "learned"})
  assert adopt.validation_from(single, "val")["stages"] == {
      "hi": {"psnr": 24.0, "ssim": 0.92, "learned": "learned"}}
