"""What nerfbaselines asks of the method before it starts one: shared by the
method (nerfbaselines_method.py, in halo-jax's environment) and by the
spec and the venv proxy (in nerfbaselines' own). Imports no jax."""

METHOD_ID = "halo"


def method_info() -> dict:
  """nerfbaselines' MethodInfo of this method."""
  return {"method_id": METHOD_ID, "required_features": frozenset(("color",)),
          "supported_camera_models": frozenset(("pinhole",)),
          "supported_outputs": ("color", "depth", "accumulation"),
          "can_resume_training": True, "viewer_default_resolution": 100}
