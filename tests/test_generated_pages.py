"""Every generated page and the README's results block, regenerated from
results/ and compared with what is committed: a figure edited by hand, or a
result file committed without its page, fails here with the command that
regenerates it."""
import json
import os
import subprocess

import pytest

from experiments import faults
from experiments.bench import (ablations, budget_report, calibrate_frequency, code_version,
                            gpu_report, method_table, report, throughput_report)

REPO = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
RESULTS = os.path.join(REPO, "results")
DOCS = os.path.join(REPO, "docs", "results")


def _read(path):
  with open(path) as f:
    return f.read()


def _same(path, text, command):
  committed = _read(path)
  if committed != text:
    a, b = committed.splitlines(), text.splitlines()
    first = next((i for i, (x, y) in enumerate(zip(a, b)) if x != y), min(len(a), len(b)))
    pytest.fail(f"{os.path.relpath(path, REPO)} differs from its results at line {first + 1}:\n"
                f"  committed:   {a[first] if first < len(a) else '(end)'}\n"
                f"  regenerated: {b[first] if first < len(b) else '(end)'}\n"
                f"regenerate it: {command}")


def _full_history():
  """Old records name only their commit: their code tree needs the history."""
  try:
    shallow = subprocess.run(["git", "-C", REPO, "rev-parse", "--is-shallow-repository"],
                             capture_output=True, text=True, check=True).stdout.strip()
  except (OSError, subprocess.CalledProcessError):
    pytest.skip("not a git checkout: records' code trees cannot be read")
  if shallow == "true":
    pytest.skip("a shallow clone: older records' code trees cannot be read")


def test_suite_pages_and_the_readme_block(tmp_path):
  _full_history()
  table = code_version.load()
  suites, versions = {}, {}
  for key, scenes in sorted(report.load(RESULTS).items()):
    suites[key], versions[key] = report.pool(scenes, table)
  for (suite, mode), scenes in suites.items():
    name = report.write_suite(suite, mode, scenes, str(tmp_path), versions[(suite, mode)],
                              plots=False)  # the page's text does not depend on its figures
    _same(os.path.join(DOCS, f"{name}.md"), _read(tmp_path / f"{name}.md"),
          "python -m experiments.report")
  budget_line = budget_report.write(suites, str(tmp_path), RESULTS)
  _same(os.path.join(DOCS, f"{budget_report.PAGE}.md"),
        _read(tmp_path / f"{budget_report.PAGE}.md"), "python -m experiments.report")
  readme = tmp_path / "README.md"
  readme.write_text(_read(os.path.join(REPO, "README.md")))
  assert report.update_readme(str(readme), report.readme_block(suites, str(tmp_path), versions,
                                                               budget_line))
  _same(os.path.join(REPO, "README.md"), readme.read_text(), "python -m experiments.report")


@pytest.mark.parametrize("name", sorted(ablations.STUDIES))
def test_study_pages(name):
  path = os.path.join(DOCS, f"ablation_{name}.md")
  if not os.path.isdir(os.path.join(RESULTS, "ablations", name)):
    # a study without runs yet: what there is to check is that no page claims any
    assert not os.path.exists(path), f"{path}: a page without result files"
    return
  _same(path, ablations.report(name, ablations.STUDIES[name], RESULTS),
        f"python -m experiments.ablations --study={name} --report_only")


def test_gpu_page(tmp_path):
  _same(os.path.join(DOCS, "gpu.md"),
        gpu_report.page(gpu_report.load(os.path.join(RESULTS, "gpu")), str(tmp_path)),
        "python -m experiments.gpu_report")


def test_throughput_page():
  _full_history()
  _same(os.path.join(DOCS, "throughput.md"),
        throughput_report.page(throughput_report.load(os.path.join(RESULTS, "throughput"))),
        "python -m experiments.throughput_report")


@pytest.mark.parametrize("views", sorted(calibrate_frequency.VIEWS))
def test_frequency_calibration_pages(views, tmp_path):
  _, folder, page = calibrate_frequency.VIEWS[views]
  scenes = calibrate_frequency.load_results(os.path.join(RESULTS, folder))
  if len(scenes) < 2:
    assert not os.path.exists(os.path.join(DOCS, f"{page}.md")), f"{page}.md without results"
    pytest.skip(f"results/{folder}: fewer than 2 scenes")
  text, _ = calibrate_frequency.report(scenes, str(tmp_path), RESULTS, views)
  _same(os.path.join(DOCS, f"{page}.md"), text,
        f"python -m experiments.calibrate_frequency --views={views} --report_only")


def test_method_table_block():
  # the columns the page has, as the configs make them now (a method
  # registered since is added when the page is regenerated)
  page = os.path.join(DOCS, "methods.md")
  names = method_table.documented(_read(page))
  assert len(names) >= 9, names
  _same(page, method_table.splice(_read(page), method_table.generate(names)),
        "python -m experiments.method_table")


def test_failures_page():
  with open(os.path.join(RESULTS, "faults.json")) as f:
    rows = json.load(f)
  _same(os.path.join(REPO, "docs", "results", "failures.md"), faults.report(rows),
        "python -m experiments.faults")



def test_viewer_latency_page():
  from experiments import viewer_check
  with open(os.path.join(RESULTS, "viewer_latency.json")) as f:
    record = json.load(f)
  _same(os.path.join(DOCS, "viewer_latency.md"), viewer_check.report(record),
        "python -m experiments.viewer_check (it re-times the viewer)")


def test_the_readme_main_job_block_is_its_record(tmp_path):
  """The README's main-job block (halo-compare's own table and lines, its time,
  the plot) is made from the committed run (results/main_job/default.json),
  and that run is the README's command."""
  from experiments import main_job
  with open(main_job.RECORD) as f:
    record = json.load(f)
  readme = tmp_path / "README.md"
  readme.write_text(_read(os.path.join(REPO, "README.md")))
  assert report.update_readme(str(readme), main_job.block(record), "main_job"), \
      "README.md lost its <!-- main_job:begin --> / <!-- main_job:end --> lines"
  _same(os.path.join(REPO, "README.md"), readme.read_text(),
        "python -m experiments.main_job --report_only")
  assert record["command"] == main_job.COMMAND and main_job.COMMAND in _read(
      os.path.join(REPO, "README.md")), "the README's main command is not the recorded one"
  assert not any("constant" in str(r.get("heldout_learned")) for r in record["methods"].values())


def test_every_typed_gpu_figure_is_a_dated_record_of_a_named_commit():
  """docs/gpu.md types figures that no generator writes (runs made before
  result files, or on jax versions other than the pinned ones): each section
  that holds a PSNR says it is a dated record and names the commit and the
  versions it was made with, and the commit is one git knows."""
  import re
  _full_history()
  text = _read(os.path.join(REPO, "docs", "gpu.md"))
  sections = re.split(r"\n(?=### )", text)
  checked = 0
  for section in sections:
    if not section.startswith("### ") or not re.search(r"\b\d\d\.\d\d\b", section):
      continue
    title = section.splitlines()[0]
    assert "dated record" in section, f"docs/gpu.md {title!r}: figures without 'dated record'"
    assert re.search(r"\bjax \d+\.\d+\.\d+", section), f"{title!r}: no jax version"
    commits = re.findall(r"\b[0-9a-f]{7}\b", section)
    assert commits, f"docs/gpu.md {title!r}: no commit named"
    for c in commits:
      subprocess.run(["git", "-C", REPO, "cat-file", "-e", f"{c}^{{commit}}"], check=True)
    checked += 1
  assert checked >= 3


def test_the_readme_ci_sentence_is_the_newest_ci_record(tmp_path):
  from experiments.bench import ci_records
  newest = ci_records.newest()
  assert newest, "results/ci holds no CI record"
  readme = tmp_path / "README.md"
  readme.write_text(_read(os.path.join(REPO, "README.md")))
  assert report.update_readme(str(readme), ci_records.readme_sentence(newest), "ci"), \
      "README.md lost its <!-- ci:begin --> / <!-- ci:end --> lines"
  _same(os.path.join(REPO, "README.md"), readme.read_text(), "python -m experiments.report")


def test_the_stability_page_is_its_record():
  from experiments import stability
  with open(stability.RECORD) as f:
    record = json.load(f)
  assert all(row["ok"] for row in record["rows"]), "a stability row failed when recorded"
  _same(stability.PAGE, stability.page(record), "python -m experiments.stability --report_only")


def test_the_toy_page_is_its_records():
  from experiments import toy2d
  records = toy2d.records()
  assert toy2d.RECORD in records, "results/toy2d.json (the paper-size toy) is missing"
  _same(toy2d.PAGE, toy2d.page(records), "python -m experiments.toy2d --report_only")
