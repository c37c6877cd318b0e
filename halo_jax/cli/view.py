"""Opens a run in the browser (viser): the field from the camera you move.

  halo-view --workdir=DIR [--stage=hi] [--port=8080] [--size=100]

The page shows the training (blue) and held-out (grey) cameras with their
images, and the stage drawn from the viewer's camera: first at a quarter of
--size, then at --size once the camera has stopped. The panel switches the
stage (Lo, Hi, ...) and the output (colour, depth, opacity); dynamic scenes
get a time slider, light fields a (u, v) pad in place of the free camera.
Pointed at a run still training, it shows the training stage at its latest
checkpoint and the loss and held-out PSNR curves so far, looking again every
POLL_S seconds (`halo-train --view` starts it beside training).
The drawing lives in halo_jax/viewer.py.
"""
import dataclasses
import os
import socket
import subprocess
import sys
import threading
import time
from typing import Any, Dict

from absl import app, flags
import numpy as np

from halo_jax import plots, user_errors, viewer
from halo_jax.geometry import Geometry
from halo_jax.cli import launch

FLAGS = flags.FLAGS
PREVIEW = 4           # the first image of a move is --size divided by this
SETTLE_S = 0.15       # a camera still this long gets the full-size image


@dataclasses.dataclass(frozen=True)
class Served:
  """A running viewer: the viser server, its panel, its tabs and the event
  that stops its polling."""
  server: Any
  controls: Dict[str, Any]
  sessions: Dict[int, "Session"]
  stopped: threading.Event

  def close(self):
    self.stopped.set()
    self.server.stop()


class PortInUse(user_errors.ConfigError):
  """The port the viewer was asked to serve on is taken."""


def define_flags():
  flags.DEFINE_string("workdir", None, "A run folder written by halo-train.")
  flags.DEFINE_string("stage", None, "Stage shown first (default: the last finished).")
  flags.DEFINE_string("host", "127.0.0.1", "Address to serve on.")
  flags.DEFINE_integer("port", 8080, "Port to serve on.")
  flags.DEFINE_integer("size", 100, "Height in pixels of the settled image.")
  flags.DEFINE_string("data_root", "", "Scene folder, if not where the run found it.")
  flags.DEFINE_float("wait_s", 0.0, "Wait this long for a run starting in the workdir.")
  flags.mark_flags_as_required(["workdir"])


def check_port(host: str, port: int) -> None:
  """PortInUse naming the port when something already listens there (viser
  would move to another port without saying so on the page's address)."""
  with socket.socket(socket.AF_INET, socket.SOCK_STREAM) as s:
    # as the server will: a port a closed server left in TIME_WAIT is free
    s.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
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
    if self.controls["stage"].value not in self.field.stages:
      return  # nothing has finished or checkpointed yet
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
  """A quaternion (w, x, y, z) as a rotation matrix [3, 3] (viser's own)."""
  import viser.transforms as vtf  # pylint: disable=g-import-not-at-top
  wxyz = np.asarray(wxyz, np.float64)
  return vtf.SO3(wxyz / np.linalg.norm(wxyz)).as_matrix()


def _quaternion(rot):
  """A rotation matrix [3, 3] as a unit quaternion (w, x, y, z)."""
  import viser.transforms as vtf  # pylint: disable=g-import-not-at-top
  return vtf.SO3.from_matrix(np.asarray(rot)).wxyz


def add_cameras(server, field: viewer.FieldView, visible: bool = True):
  """Frusta of the training (blue) and held-out (grey) views, with their
  images, and the checkbox that shows or hides them (returned; None for a
  light field, whose cameras are a (u, v) grid)."""
  ds = field.dataset
  if ds.geometry == Geometry.TWO_PLANE:
    return None
  frusta = []
  shown = server.gui.add_checkbox("cameras", visible)

  @shown.on_update
  def _(_):
    for f in frusta:
      f.visible = shown.value

  centres = ds.train.c2w[:, :3, 3]
  # frusta sized by the cameras' spread round their centre: small beside an
  # object seen from all round, and beside a forward-facing capture's small moves
  scale = 0.15 * float(np.linalg.norm(centres - centres.mean(0), axis=-1).mean())
  for split, views, color in (("train", ds.train, (40, 90, 220)), ("test", ds.test,
                                                                   (150, 150, 150))):
    step = max(1, views.height // 64)
    for i, name in enumerate(views.names):
      rot, pos = viewer.opencv_pose(views.c2w[i])
      frusta.append(server.scene.add_camera_frustum(
          f"/cameras/{split}/{name}", fov=viewer.fov_y(views),
          aspect=views.width / views.height, scale=scale, thickness=0.03 * scale, color=color,
          image=(np.clip(views.images[i, ::step, ::step], 0, 1) * 255).astype(np.uint8),
          wxyz=_quaternion(rot), position=pos, visible=visible))
  return shown


def add_controls(server, field: viewer.FieldView, first_stage: str):
  """The panel: stage, output, and time or (u, v) where the scene has them."""
  ds = field.dataset
  c = {"status": server.gui.add_markdown(_status(field)),
       "stage": server.gui.add_dropdown("stage", tuple(field.stages) or ("-",),
                                        initial_value=first_stage),
       "output": server.gui.add_dropdown(
           "output", field.outputs(first_stage) if field.stages else viewer.OUTPUTS,
           initial_value="color")}
  if ds.dynamic:
    c["time"] = server.gui.add_slider("time", 0.0, 1.0, 0.01, 0.0)
  if ds.geometry == Geometry.TWO_PLANE:
    c["uv"] = server.gui.add_vector2("(u, v)", tuple(float(x) for x in ds.train.uv.mean(0)),
                                     min=(-1.0, -1.0), max=(1.0, 1.0), step=0.01)
  with server.gui.add_folder("curves", expand_by_default=False):
    c["curves"] = server.gui.add_image(plots.training_curves(viewer.read_records(field.workdir)))
  return c


POLL_S = 2.0  # how often the viewer looks for new checkpoints and log lines


def _status(field: viewer.FieldView) -> str:
  if field.live:
    return f"**{field.live[0]}** training: checkpoint at step {field.live[1]}"
  return "finished: " + ", ".join(field.stages) if field.stages else "waiting for a checkpoint"


def follow(field: viewer.FieldView, controls, sessions, stop: threading.Event):
  """Every POLL_S: new stages and checkpoints join the stage list (and the
  tabs redraw), and the curves and status line are brought up to date."""
  while not stop.wait(POLL_S):
    try:
      changed = field.refresh()
    except Exception:  # pylint: disable=broad-except
      continue  # a checkpoint being written or deleted under us: look again later
    controls["curves"].image = plots.training_curves(viewer.read_records(field.workdir))
    if changed:
      controls["status"].content = _status(field)
      if field.stages:
        controls["stage"].options = tuple(field.stages)
      for s in list(sessions.values()):
        s.request()


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
  shown = add_cameras(server, field, cameras)
  controls = add_controls(server, field, stage or (field.stages or ["-"])[-1])
  if shown is not None:
    controls["cameras"] = shown
  sessions = {}
  stop = threading.Event()
  threading.Thread(target=follow, args=(field, controls, sessions, stop), daemon=True).start()
  first = field.dataset.test

  @server.on_client_connect
  def _(client):
    if hasattr(first, "c2w"):
      rot, pos = viewer.opencv_pose(first.c2w[0])
      client.camera.wxyz, client.camera.position = _quaternion(rot), pos
      client.camera.fov = viewer.fov_y(first)
    sessions[client.client_id] = Session(client, field, controls, size)

  @controls["stage"].on_update
  def _(_):  # a guided stage adds the ray field's depth and window
    if controls["stage"].value in field.stages:
      outputs = field.outputs(controls["stage"].value)
      if controls["output"].value not in outputs:
        controls["output"].value = "color"
      controls["output"].options = outputs

  for key in ("stage", "output", "time", "uv"):
    if key not in controls:
      continue
    controls[key].on_update(lambda _: [s.request() for s in list(sessions.values())])
  return Served(server, controls, sessions, stop)


def launch_beside(workdir: str, port: int):
  """halo-view on `workdir` in a process of its own, for a run starting now:
  it waits for the run to appear, draws on one CPU thread (and a tenth of a
  GPU's memory) so training keeps the machine, and outlives the training
  command (its own session: Ctrl-C there does not reach it)."""
  env = dict(os.environ)
  env["XLA_FLAGS"] = (env.get("XLA_FLAGS", "") + " --xla_cpu_multi_thread_eigen=false "
                      "intra_op_parallelism_threads=1").strip()
  env.update(XLA_PYTHON_CLIENT_PREALLOCATE="false", XLA_PYTHON_CLIENT_MEM_FRACTION="0.1")
  proc = subprocess.Popen([sys.executable, "-m", "halo_jax.cli.view", f"--workdir={workdir}",
                           f"--port={port}", "--wait_s=300"], env=env, start_new_session=True)
  print(f"halo-view: http://127.0.0.1:{port} (pid {proc.pid}; it stays up after training: "
        f"kill {proc.pid} to stop it)", flush=True)
  return proc


def wait_for_run(workdir: str, seconds: float) -> None:
  """Waits up to `seconds` for a run starting in `workdir` to write its config."""
  end = time.time() + seconds
  while not os.path.exists(os.path.join(workdir, "config.json")) and time.time() < end:
    time.sleep(0.5)


def main(argv):
  del argv
  with launch():
    wait_for_run(FLAGS.workdir, FLAGS.wait_s)
    served = start(FLAGS.workdir, FLAGS.stage, FLAGS.host, FLAGS.port, FLAGS.size,
                   FLAGS.data_root)
  print(f"halo-view: http://{FLAGS.host}:{FLAGS.port} (Ctrl-C stops it)", flush=True)
  try:
    while True:
      time.sleep(3600)
  except KeyboardInterrupt:
    served.close()


def cli():
  """The halo-view console script."""
  define_flags()
  app.run(main)


if __name__ == "__main__":
  cli()
