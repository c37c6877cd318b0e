"""The documentation's own checks: every relative link resolves, and each
topic page states the current state in about a screenful (history goes to
docs/notes/, generated tables to docs/results/)."""
import glob
import os
import re

import pytest

REPO = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
PAGES = sorted([os.path.join(REPO, "README.md")] + glob.glob(os.path.join(REPO, "docs", "*.md"))
               + glob.glob(os.path.join(REPO, "docs", "notes", "*.md"))
               + glob.glob(os.path.join(REPO, "docs", "results", "*.md")))
LINK = re.compile(r"\]\(([^)\s]+)\)")
TOPIC_PAGE_MAX_LINES = 200


@pytest.mark.parametrize("page", PAGES, ids=lambda p: os.path.relpath(p, REPO))
def test_relative_links_resolve(page):
  with open(page) as f:
    text = f.read()
  missing = []
  for target in LINK.findall(text):
    if re.match(r"^[a-z]+:", target) or target.startswith("#"):
      continue  # a URL or an anchor on the same page
    path = os.path.normpath(os.path.join(os.path.dirname(page), target.split("#")[0]))
    if not os.path.exists(path):
      missing.append(target)
  assert not missing, f"{os.path.relpath(page, REPO)} links to missing files: {missing}"


def test_topic_pages_are_short():
  long = {os.path.relpath(p, REPO): n for p in glob.glob(os.path.join(REPO, "docs", "*.md"))
          if (n := sum(1 for _ in open(p))) > TOPIC_PAGE_MAX_LINES}
  assert not long, f"docs pages over {TOPIC_PAGE_MAX_LINES} lines (move history to docs/notes/): {long}"
