"""The library is the method and a user's commands: no module under
halo_jax/ runs git, measures the machine's peak, writes the clone's README,
docs, results or step table, or imports the benchmark (experiments/)."""
import pathlib
import re

import pytest

PACKAGE = pathlib.Path(__file__).resolve().parent.parent / "halo_jax"
SOURCES = sorted(PACKAGE.rglob("*.py"))

# what a module would have to say to do one of those things
FORBIDDEN = {
    "runs git": re.compile(r"""["']git["']"""),
    "times a peak": re.compile(r"matmul_peak|peak_gflops"),
    "imports the benchmark": re.compile(r"^\s*(from|import)\s+experiments\b", re.M),
    # an open for writing, or the table cache's reset that follows a write
    "writes the step table": re.compile(
        r"""step_table\.json["'][^\n]*["']w["']|_read\.cache_clear\(\)"""),
    "names the clone's pages or results": re.compile(
        r"""["'](README\.md|docs/|results/|docs|results)["']"""),
    "climbs to the clone's root": re.compile(
        r"dirname\(os\.path\.dirname\(os\.path\.dirname\(os\.path\.abspath\(__file__"),
}
# nerfbaselines loads this file by path in its own process; it puts the clone
# on that process's path to import the package, and writes nothing there
ALLOWED = {("integrations/nerfbaselines_spec.py", "climbs to the clone's root")}


def test_the_package_has_sources():
  assert len(SOURCES) > 50


@pytest.mark.parametrize("what", sorted(FORBIDDEN))
def test_no_library_module_does_what_only_the_benchmark_may(what):
  found = []
  for path in SOURCES:
    rel = path.relative_to(PACKAGE).as_posix()
    if (rel, what) not in ALLOWED and FORBIDDEN[what].search(path.read_text()):
      found.append(rel)
  assert not found, f"{what}: {found}"


def test_the_checks_catch_what_they_name():
  """Each pattern matches the line it is there to catch (a test that cannot fail is no test)."""
  caught = {
      "runs git": 'subprocess.run(["git", "-C", repo, "rev-parse", "HEAD"])',
      "times a peak": "p = matmul_peak_gflops()",
      "imports the benchmark": "from experiments.bench import suites",
      "writes the step table": 'open(os.path.join(here, "step_table.json"), "w")',
      "names the clone's pages or results": 'open(os.path.join(REPO, "README.md"), "w")',
      "climbs to the clone's root":
          "REPO = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))",
  }
  assert set(caught) == set(FORBIDDEN)
  for what, line in caught.items():
    assert FORBIDDEN[what].search(line), what
