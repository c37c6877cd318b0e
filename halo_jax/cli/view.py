"""Opens a run in the browser (viser): the field from the camera you move.

  halo-view --workdir=DIR [--stage=hi] [--port=8080] [--size=100]

The page shows the training (blue) and held-out (grey) cameras with their
images, and the stage drawn from the viewer's camera: first at a quarter of
--size, then at --size once the camera has stopped. The panel switches the
stage (Lo, Hi, ...) and the output (colour, depth, opacity); dynamic scenes
get a time slider, light fields a (u, v) pad in place of the free camera.
The drawing lives in halo_jax/viewer.py.
"""
import dataclasses
import socket
import threading
import time
from typing import Any, Dict

from absl import app, flags, logging
import numpy as np

from halo_jax import user_errors, viewer
from halo_jax.geometry import Geometry

FLAGS = flags.FLAGS
PREVIEW = 4           # the first image of a move is --size divided by this
SETTLE_S = 0.15       # a camera still this long gets the full-size image


@dataclasses.dataclass(frozen=True)
class Served:
  server: Any
  controls: Dict[str, Any]
  sessions: Dict[int, "Session"]


class PortInUse(user_errors.ConfigError):
  """The port the viewer was asked to serve on is taken."""


def define_flags():
  flags.DEFINE_string("workdir", None, "A run folder written by halo-train.")
  flags.DEFINE_string("stage", None, "Stage shown first (default: the last finished).")
  flags.DEFINE_string("host", "127.0.0.1", "Address to serve on.")
  flags.DEFINE_integer("port", 8080, "Port to serve on.")
  flags.DEFINE_integer("size", 100, "Height in pixels of the settled image.")
  flags.DEFINE_string("data_root", "", "Scene folder, if not where the run found it.")
  flags.mark_flags_as_required(["workdir"])


def check_port(host: str, port: int) -> None:
  """PortInUse naming the port when something already listens there (viser
  would move to another port without saying so on the page's address)."""
  with socket.socket(socket.AF_INET, socket.SOCK_STREAM) as s:
    try:
      s.bind((host, port))
    except OSError as e:
      raise PortInUse(f"--port={port}: {host}:{port} is in use ({e.strerror}); pick another "
                      "port") from None


class Session:
  """One browser tab: its panel, and a thread that draws the newest request."""

  def __init__(self, client, field: viewer.FieldView, controls, size: int):
    self.client, self.field, self.controls, self.size = client, field, controls, size
    self._version, self._wake = 0, threading.Condition()
    self._asked = time.perf_counter()
    # (scale, seconds from the request to the image sent) of each image drawn
    self.timings = []
    threading.Thread(target=self._loop, daemon=True).start()
    client.camera.on_update(lambda _: self.request())
    self.request()

  def request(self):
    with self._wake:
      self._version += 1
      self._asked = time.perf_counter()
      self._wake.notify()

  def _camera(self):
    cam, c = self.client.camera, self.controls
    rot = _rotation(np.asarray(cam.wxyz))
    kwargs = {"c2w": viewer.opengl_c2w(rot, np.asarray(cam.position)), "fov_y": float(cam.fov)}
    if "uv" in c:
      kwargs["uv"] = tuple(c["uv"].value)
    if "time" in c:
      kwargs["time"] = float(c["time"].value)
    return viewer.Camera(**kwargs), float(cam.aspect)

  def _draw(self, scale):
    cam, aspect = self._camera()
    h = max(8, self.size // scale)
    image, _ = self.field.draw(self.controls["stage"].value, cam, h,
                               max(8, int(round(h * aspect))), self.controls["output"].value)
    self.client.scene.set_background_image(image, format="jpeg")
    self.timings.append((scale, time.perf_counter() - self._asked))

  def _loop(self):
    seen = 0
    while True:
      with self._wake:
        while self._version == seen:
          self._wake.wait()
        seen = self._version
      self._draw(PREVIEW)
      time.sleep(SETTLE_S)
      if self._version == seen:  # the camera has stopped: the full image
        self._draw(1)


def _rotation(wxyz):
  """A unit quaternion (w, x, y, z) as a rotation matrix [3, 3]."""
  w, x, y, z = wxyz / np.linalg.norm(wxyz)
  return np.array([[1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
                   [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
                   [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)]])


def _quaternion(rot):
  """A rotation matrix [3, 3] as a unit quaternion (w, x, y, z)."""
  import viser.transforms as vtf  # pylint: disable=g-import-not-at-top
  return vtf.SO3.from_matrix(np.asarray(rot)).wxyz


def add_cameras(server, field: viewer.FieldView, visible: bool = True):
  """Frusta of the training (blue) and held-out (grey) views, with their
  images, and a checkbox that shows or hides them."""
  ds = field.dataset
  if ds.geometry == Geometry.TWO_PLANE:
    return
  frusta = []
  shown = server.gui.add_checkbox("cameras", visible)

  @shown.on_update
  def _(_):
    for f in frusta:
      f.visible = shown.value

  for split, views, color in (("train", ds.train, (40, 90, 220)), ("test", ds.test,
                                                                   (150, 150, 150))):
    step = max(1, views.height // 64)
    for i, name in enumerate(views.names):
      rot, pos = viewer.opencv_pose(views.c2w[i])
      frusta.append(server.scene.add_camera_frustum(
          f"/cameras/{split}/{name}", fov=viewer.fov_y(views),
          aspect=views.width / views.height, scale=0.15 * max(ds.radius, 1.0), color=color,
          image=(np.clip(views.images[i, ::step, ::step], 0, 1) * 255).astype(np.uint8),
          wxyz=_quaternion(rot), position=pos, visible=visible))


def add_controls(server, field: viewer.FieldView, first_stage: str):
  """The panel: stage, output, and time or (u, v) where the scene has them."""
  ds = field.dataset
  c = {"stage": server.gui.add_dropdown("stage", tuple(field.stages), initial_value=first_stage),
       "output": server.gui.add_dropdown("output", viewer.OUTPUTS, initial_value="color")}
  if ds.dynamic:
    c["time"] = server.gui.add_slider("time", 0.0, 1.0, 0.01, 0.0)
  if ds.geometry == Geometry.TWO_PLANE:
    c["uv"] = server.gui.add_vector2("(u, v)", tuple(float(x) for x in ds.train.uv.mean(0)),
                                     min=(-1.0, -1.0), max=(1.0, 1.0), step=0.01)
  return c


def start(workdir, stage=None, host="127.0.0.1", port=8080, size=100, data_root="",
          cameras=True):
  """Starts the viewer; returns a Served (the server, its panel's controls
  and {client id: Session}). cameras: whether the camera frusta start shown."""
  import viser  # pylint: disable=g-import-not-at-top
  field = viewer.FieldView(workdir, data_root)
  if stage is not None and stage not in field.stages:
    raise user_errors.ConfigError(f"--stage={stage}: {workdir} has finished {field.stages}")
  check_port(host, port)
  server = viser.ViserServer(host=host, port=port, verbose=False)
  server.scene.set_up_direction("+y" if field.dataset.geometry == Geometry.NDC else "+z")
  add_cameras(server, field, cameras)
  controls = add_controls(server, field, stage or field.stages[-1])
  sessions = {}
  first = field.dataset.test

  @server.on_client_connect
  def _(client):
    if hasattr(first, "c2w"):
      rot, pos = viewer.opencv_pose(first.c2w[0])
      client.camera.wxyz, client.camera.position = _quaternion(rot), pos
      client.camera.fov = viewer.fov_y(first)
    sessions[client.client_id] = Session(client, field, controls, size)

  for handle in controls.values():
    handle.on_update(lambda _: [s.request() for s in list(sessions.values())])
  return Served(server, controls, sessions)


def main(argv):
  del argv
  logging.set_verbosity(logging.WARNING)
  with user_errors.reported():
    server = start(FLAGS.workdir, FLAGS.stage, FLAGS.host, FLAGS.port, FLAGS.size,
                   FLAGS.data_root).server
  print(f"halo-view: http://{FLAGS.host}:{FLAGS.port} (Ctrl-C stops it)", flush=True)
  try:
    while True:
      time.sleep(3600)
  except KeyboardInterrupt:
    server.stop()


def cli():
  """The halo-view console script."""
  define_flags()
  app.run(main)


if __name__ == "__main__":
  cli()
