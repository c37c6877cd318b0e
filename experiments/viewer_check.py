"""halo-view on finished runs of every scene kind, in headless Chromium: a
screenshot of each (docs/images/viewer_<kind>.png) and the time from a camera move
to the first image and to the settled one (results/viewer_latency.json).

  python -m experiments.viewer_check --runs=/tmp/viewer_runs [--train_s=60]

Trains what is missing first (halo, the CPU configs, --train_s each): the
built-in lattice (360), LLFF fern (forward-facing), D-NeRF hook (dynamic) and
the Stanford knights (light field); the last three need ../shared/data or
$HALO_DATA, and a kind whose data is absent is skipped. Needs Debian's
chromium and `pip install playwright viser`.
"""
import json
import os
import subprocess
import sys
import time

from absl import app, flags, logging
import numpy as np

from experiments.bench import git_state  # noqa: E402
from halo_jax.cli import view

FLAGS = flags.FLAGS
flags.DEFINE_string("runs", "/tmp/viewer_runs", "where the runs are (trained if missing)")
flags.DEFINE_integer("train_s", 60, "training budget of a missing run, seconds")
flags.DEFINE_integer("size", 100, "the settled image's height")
flags.DEFINE_integer("moves", 5, "camera moves timed per kind")
flags.DEFINE_string("out", "results/viewer_latency.json", "the timings")

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
DATA = os.environ.get("HALO_DATA", os.path.join(ROOT, "..", "shared", "data"))
KINDS = {  # kind: (config, the data it needs, or '')
    "360": ("procedural.py:lattice_8view_cpu", ""),
    "forward": ("llff.py:fern_4view_cpu", "nerf_llff_data/fern"),
    "dynamic": ("dnerf.py:hook_cpu", "dnerf/hook"),
    "light_field": ("stanford_lf.py:knights_cpu", "stanford_lf/knights"),
}
CHROMIUM_ARGS = ["--no-sandbox", "--disable-gpu", "--use-gl=swiftshader",
                 "--enable-unsafe-swiftshader", "--disable-background-networking",
                 "--disable-component-update", "--disable-sync", "--no-first-run"]


def _train(kind, workdir):
  config, data = KINDS[kind]
  if os.path.exists(os.path.join(workdir, "hi", "final", "config.json")):
    return True
  if data and not os.path.exists(os.path.join(DATA, data)):
    print(f"{kind}: skipped, {os.path.join(DATA, data)} is absent")
    return False
  cmd = [sys.executable, "-m", "halo_jax.cli.train", f"--config=configs/{config}",
         f"--workdir={workdir}", f"--config.budget_s={FLAGS.train_s}"]
  if data:
    cmd.append(f"--config.data.root={os.path.join(DATA, data)}")
  subprocess.run(cmd, check=True, cwd=ROOT)
  return True


def _wait(cond, seconds=120):
  end = time.time() + seconds
  while not cond() and time.time() < end:
    time.sleep(0.02)
  return cond()


def _settled(session, n):
  return any(k == 1 for k, _ in session.timings[n:])


def _move(session, controls, kind, i):
  """The i-th timed move: an orbit step (a (u, v) step on a light field)."""
  if kind == "light_field":
    u, v = controls["uv"].value
    controls["uv"].value = (float(np.clip(u + 0.05, -1, 1)), float(v))
  else:
    cam = session.client.camera
    pos = np.asarray(cam.position)
    a = np.deg2rad(4.0 if i % 2 else -4.0)
    rot = np.array([[np.cos(a), -np.sin(a), 0], [np.sin(a), np.cos(a), 0], [0, 0, 1]])
    cam.position = rot @ pos if kind != "forward" else pos + np.array([0.02, 0, 0])
  session.request()


def _pose_for_screenshot(session, controls, kind):
  """A step back from the first held-out camera, so that the cameras and the
  field both show; halfway through time on a dynamic scene."""
  if kind == "dynamic":
    controls["time"].value = 0.5
    controls["cameras"].value = False  # the figure is small beside its cameras
  if kind == "light_field":
    return
  cam = session.client.camera
  pos = np.asarray(cam.position)
  if kind == "forward":
    back = np.asarray(_rotation_of(cam))[:, 2]  # OpenCV: the camera looks down +z
    cam.position = pos - 0.3 * back
  else:
    cam.position = 1.5 * pos


def _rotation_of(cam):
  from halo_jax.cli import view as v  # pylint: disable=g-import-not-at-top
  return v._rotation(np.asarray(cam.wxyz))  # pylint: disable=protected-access


def check(kind, workdir, page_of, png):
  """(the first-image and settled-image seconds of each move) on kind's run."""
  served = view.start(workdir, port=8791, size=FLAGS.size)
  sessions, controls = served.sessions, served.controls
  try:
    page = page_of()
    page.goto("http://127.0.0.1:8791")
    assert _wait(lambda: sessions), "no tab connected"
    session = next(iter(sessions.values()))
    assert _wait(lambda: _settled(session, 0), 300)  # the first image pays for compiling
    _pose_for_screenshot(session, controls, kind)
    n = len(session.timings)
    session.request()
    assert _wait(lambda: _settled(session, n))
    try:  # software WebGL's notice would cover a corner of the shot
      page.locator(".mantine-Notification-closeButton").first.click(timeout=2000)
    except Exception:  # pylint: disable=broad-except
      pass
    page.wait_for_timeout(1500)
    page.screenshot(path=png)
    if "window misses" in controls["output"].options:  # HALO's Hi: where the window misses
      n = len(session.timings)
      controls["output"].value = "window misses"
      assert _wait(lambda: _settled(session, n))
      page.wait_for_timeout(1500)
      page.screenshot(path=png.replace(".png", "_window.png"))
      controls["output"].value = "color"
    moves = []
    for i in range(FLAGS.moves):
      n = len(session.timings)
      _move(session, controls, kind, i)
      assert _wait(lambda: _settled(session, n))
      first = session.timings[n][1]
      settled = next(s for k, s in session.timings[n:] if k == 1)
      moves.append({"first_image_s": first, "settled_s": settled})
    page.close()
    return moves
  finally:
    served.close()


def main(argv):
  del argv
  logging.set_verbosity(logging.WARNING)
  from playwright.sync_api import sync_playwright  # pylint: disable=g-import-not-at-top
  results = {}
  with sync_playwright() as p:
    browser = p.chromium.launch(executable_path="/usr/bin/chromium", args=CHROMIUM_ARGS)
    for kind in KINDS:
      workdir = os.path.join(FLAGS.runs, kind)
      if not _train(kind, workdir):
        continue
      png = os.path.join(ROOT, "docs", "images", f"viewer_{kind}.png")
      moves = check(kind, workdir, lambda: browser.new_page(
          viewport={"width": 800, "height": 520}), png)
      results[kind] = {"config": KINDS[kind][0], "size": FLAGS.size, "moves": moves,
                       "first_image_s_max": max(m["first_image_s"] for m in moves),
                       "settled_s_max": max(m["settled_s"] for m in moves)}
      print(f"{kind}: first image {results[kind]['first_image_s_max']:.2f} s at worst, "
            f"settled ({FLAGS.size} px) {results[kind]['settled_s_max']:.2f} s, {png}")
    browser.close()
  record = {"kinds": results, "provenance": git_state.collect()}
  with open(os.path.join(ROOT, FLAGS.out), "w") as f:
    json.dump(record, f, indent=1)
  with open(os.path.join(ROOT, "docs", "results", "viewer_latency.md"), "w") as f:
    f.write(report(record))


def report(record) -> str:
  """docs/results/viewer_latency.md's text from the result file's record."""
  prov = record["provenance"]
  git = prov.get("git", {})
  lines = ["# halo-view: seconds from a camera move to an image",
           "",
           f"Generated by `experiments/viewer_check.py` from "
           f"[results/viewer_latency.json](../../results/viewer_latency.json): "
           f"{prov.get('cpu', {}).get('model', 'CPU')}, {prov.get('cpu', {}).get('cores_used')} "
           f"cores, commit {str(git.get('commit', '?'))[:12]}"
           f"{' (a modified tree)' if git.get('dirty') else ''}, headless "
           "Chromium on the same machine. Each kind's run is its CPU config trained for "
           "the check's budget; each move is an orbit step (a (u, v) step on the light "
           "field), timed from the move to the image sent to the page: the first at a "
           "quarter of the height, the settled one at the full height after the camera "
           "has been still for 0.15 s.",
           "",
           "| kind | config | height | moves | first image, s (worst) | settled image, s "
           "(worst) |",
           "|---|---|---|---|---|---|"]
  for kind, r in record["kinds"].items():
    lines.append(f"| {kind} | `{r['config']}` | {r['size']} | {len(r['moves'])} | "
                 f"{r['first_image_s_max']:.2f} | {r['settled_s_max']:.2f} |")
  return "\n".join(lines) + "\n"


if __name__ == "__main__":
  app.run(main)
