"""The browser viewer's drawing (halo_jax/viewer.py) and command
(halo_jax/cli/view.py): a camera at a held-out view draws what the
evaluation rendered there; bad input is one line and exit 2."""
import os
import socket
import subprocess
import sys

import numpy as np
import pytest

from conftest import pipeline_config
from halo_jax import evaluate, pipeline, restore, viewer
from halo_jax.configure import finish  # pylint: disable=g-import-not-at-top

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


@pytest.fixture(scope="module")
def finished_run(scene_root, tmp_path_factory):
  wd = str(tmp_path_factory.mktemp("run"))
  pipeline.run(finish(pipeline_config(scene_root, steps=2)), wd)
  return wd


def test_poses_go_to_opencv_axes_and_back():
  rng = np.random.default_rng(0)
  q = rng.normal(size=4)
  from halo_jax.cli import view  # pylint: disable=g-import-not-at-top
  rot = view._rotation(q)  # pylint: disable=protected-access
  np.testing.assert_allclose(rot @ rot.T, np.eye(3), atol=1e-12)
  np.testing.assert_allclose(view._rotation(view._quaternion(rot)), rot, atol=1e-9)  # pylint: disable=protected-access
  c2w = np.eye(4)
  c2w[:3, :3], c2w[:3, 3] = rot, rng.normal(size=3)
  r_cv, pos = viewer.opencv_pose(c2w)
  # OpenCV looks down +z, OpenGL down -z: the same viewing direction
  np.testing.assert_allclose(r_cv[:, 2], -c2w[:3, 2])
  np.testing.assert_allclose(viewer.opengl_c2w(r_cv, pos), c2w, atol=1e-12)


def test_a_camera_at_a_heldout_view_draws_what_evaluation_rendered(finished_run):
  field = viewer.FieldView(finished_run)
  assert field.stages == ["lo", "hi"]
  test = field.dataset.test
  cam = viewer.Camera(c2w=test.c2w[1], fov_y=viewer.fov_y(test))
  run = restore.load(finished_run, "hi")
  want = evaluate.render_views(run.render, test, run.config.eval.chunk, indices=[1])
  got = field.render("hi", cam, test.height, test.width)
  np.testing.assert_allclose(got["rgb"], want["rgb"][0], atol=1e-5)
  for output in viewer.OUTPUTS:
    image, seconds = field.draw("lo", cam, 20, 30, output)
    assert image.shape == (20, 30, 3) and image.dtype == np.uint8 and seconds > 0
  assert not np.array_equal(field.draw("hi", cam, 20, 30, "color")[0],
                            field.draw("lo", cam, 20, 30, "color")[0])


def _view(*args):
  return subprocess.run([sys.executable, "-m", "halo_jax.cli.view", *args],
                        capture_output=True, text=True, timeout=300, cwd=ROOT)


@pytest.mark.slow
def test_a_workdir_with_nothing_to_show_is_one_line(tmp_path):
  r = _view(f"--workdir={tmp_path}")
  assert r.returncode == 2 and "Traceback" not in r.stderr
  assert r.stderr.strip().splitlines()[-1].startswith(f"error: {tmp_path}: no run here")


@pytest.mark.slow
def test_a_port_in_use_is_one_line(finished_run):
  with socket.socket() as s:
    s.bind(("127.0.0.1", 0))
    s.listen()
    port = s.getsockname()[1]
    r = _view(f"--workdir={finished_run}", f"--port={port}")
  assert r.returncode == 2 and "Traceback" not in r.stderr
  assert f"--port={port}" in r.stderr.strip().splitlines()[-1]


CHROMIUM = "/usr/bin/chromium"
CHROMIUM_ARGS = ["--no-sandbox", "--disable-gpu", "--use-gl=swiftshader",
                 "--enable-unsafe-swiftshader", "--disable-background-networking",
                 "--disable-component-update", "--disable-sync", "--no-first-run"]


def _wait(cond, seconds):
  import time  # pylint: disable=g-import-not-at-top
  end = time.time() + seconds
  while not cond() and time.time() < end:
    time.sleep(0.05)
  return cond()


@pytest.mark.slow
@pytest.mark.skipif(not os.path.exists(CHROMIUM), reason="needs Debian's chromium")
def test_the_page_in_a_real_browser_shows_the_field_and_follows_the_camera(finished_run,
                                                                          tmp_path):
  """halo-view's page in headless Chromium: the field is drawn (the page is
  not blank), and moving the camera through the viewer's Python API changes
  what the page shows."""
  playwright = pytest.importorskip("playwright.sync_api")
  import imageio.v2 as imageio  # pylint: disable=g-import-not-at-top
  from halo_jax.cli import view  # pylint: disable=g-import-not-at-top
  with socket.socket() as s:
    s.bind(("127.0.0.1", 0))
    port = s.getsockname()[1]
  # frusta hidden: what changes on the page is the field alone
  served = view.start(finished_run, port=port, size=48, cameras=False)
  sessions = served.sessions
  try:
    with playwright.sync_playwright() as p:
      browser = p.chromium.launch(executable_path=CHROMIUM, args=CHROMIUM_ARGS)
      page = browser.new_page(viewport={"width": 480, "height": 360})
      page.goto(f"http://127.0.0.1:{port}")
      assert _wait(lambda: sessions, 60), "no browser tab connected"
      session = next(iter(sessions.values()))
      assert _wait(lambda: any(k == 1 for k, _ in session.timings), 120)
      page.wait_for_timeout(1500)
      page.screenshot(path=str(tmp_path / "before.png"))
      cam = session.client.camera
      n = len(session.timings)
      cam.position = np.asarray(cam.position) * 1.5  # step back from the scene
      session.request()
      assert _wait(lambda: any(k == 1 for k, _ in session.timings[n:]), 120)
      before = imageio.imread(tmp_path / "before.png")[..., :3].astype(float)

      def page_moved():
        # a loaded machine may paint the new frame seconds after it is sent
        page.screenshot(path=str(tmp_path / "after.png"))
        after = imageio.imread(tmp_path / "after.png")[..., :3].astype(float)
        return np.abs(before - after).mean() > 5

      moved = _wait(page_moved, 60)
      browser.close()
  finally:
    served.close()
  after = imageio.imread(tmp_path / "after.png")[..., :3].astype(float)
  assert before.std() > 10 and after.std() > 10, "a blank page"
  assert moved, "the page did not follow the camera within 60 s"


@pytest.mark.slow
def test_a_run_still_training_shows_its_latest_checkpoint_and_curves(scene_root, tmp_path):
  """Pointed at a run paused in Hi-NeRF (stepped from this thread,
  stages/pacing.py), the viewer lists Hi at its latest checkpoint beside the
  finished Lo, draws it, and follows the next checkpoint."""
  from halo_jax import plots  # pylint: disable=g-import-not-at-top
  from halo_jax.stages import pacing  # pylint: disable=g-import-not-at-top
  wd = str(tmp_path / "run")
  c = pipeline_config(scene_root, steps=4)
  paced = pacing.Paced(lambda p: pipeline.run(finish(c), wd, None, p))
  while (rec := paced.step()).stage != "hi" or rec.step < 2:
    pass
  def save_now(run):  # a checkpoint at the step reached (the loop's own may be there)
    if run.mngr.latest_step() != int(run.state["step"]):
      run.save(int(run.state["step"]))
  paced.pacer.call(save_now)
  field = viewer.FieldView(wd)
  assert field.stages == ["lo", "hi"] and field.live == ("hi", 2)
  cam = viewer.Camera(c2w=field.dataset.test.c2w[0], fov_y=viewer.fov_y(field.dataset.test))
  at_two = field.draw("hi", cam, 16, 16)[0]
  assert not np.array_equal(at_two, field.draw("lo", cam, 16, 16)[0])
  paced.step()
  paced.pacer.call(save_now)
  assert field.refresh() and field.live == ("hi", 3)
  assert not np.array_equal(at_two, field.draw("hi", cam, 16, 16)[0])
  image = plots.training_curves(viewer.read_records(wd))
  assert image.ndim == 3 and image.std() > 0
  paced.step()
  paced.join()
  assert field.refresh() and field.live is None and field.stages == ["lo", "hi"]


def test_hi_shows_where_its_depth_leaves_the_ray_fields_window(finished_run):
  """HALO's Hi is guided: the viewer adds the ray field's depth and the
  pixels whose rendered depth lies outside the sampling window; Lo is not."""
  from halo_jax import samplers  # pylint: disable=g-import-not-at-top
  field = viewer.FieldView(finished_run)
  assert field.outputs("lo") == viewer.OUTPUTS
  assert field.outputs("hi") == viewer.OUTPUTS + viewer.GUIDE_OUTPUTS
  test = field.dataset.test
  cam = viewer.Camera(c2w=test.c2w[0], fov_y=viewer.fov_y(test))
  r = field.render("hi", cam, 12, 12)
  r = field._with_guide("hi", cam, r, 12, 12)  # pylint: disable=protected-access
  guide, sampler = field.guide("hi")
  lo, hi = samplers.depth_window(r["ray_depth"], field.dataset.near, field.dataset.far,
                                 sampler.window, sampler.near_only)
  outside = (r["depth"] < np.asarray(lo)) | (r["depth"] > np.asarray(hi))
  np.testing.assert_array_equal(r["miss"], outside & (r["acc"] > 0.5))
  image, _ = field.draw("hi", cam, 12, 12, "window misses")
  red = (image[..., 0] > 200) & (image[..., 1] < 60)
  np.testing.assert_array_equal(red, r["miss"])
  assert guide.geometry == field.dataset.geometry
