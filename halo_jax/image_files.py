"""Image files written so that a failed write leaves no writer open.

imageio's plugins hold the file open until they are closed, and the PNG
writer encodes on close: when that fails (a full disk) the file stays open
and the plugin's finaliser fails the same way later, printing a traceback
after the run's one error line. So the image is encoded in memory and the
bytes written through a plain file object, which a `with` block closes
whatever happens.
"""
import os

import imageio.v3 as iio


def write(path: str, image, extension: str = "", **kwargs) -> None:
  """Writes `image` (an array, or frames for an animated format) to `path`,
  in the format `extension` (default: the path's) names; kwargs are the
  format plugin's (e.g. duration, loop)."""
  data = iio.imwrite("<bytes>", image, extension=extension or os.path.splitext(path)[1],
                     **kwargs)
  with open(path, "wb") as f:
    f.write(data)
