"""HALO's stage trainers. Importing the package registers every trainer in
`base.TRAINERS` (the radiance field, the ray field, the light field) and
the loss terms that live in modules of their own (unseen, teach); the
pipeline that runs them is halo_jax.pipeline."""
from halo_jax.stages import base, epi, radiance, ray, teach, unseen  # noqa: F401  (registry entries)
from halo_jax.stages.state import StageState, load, save, stage_dir
from halo_jax.stages.workdir import WorkdirMismatch, check_workdir

__all__ = ["StageState", "WorkdirMismatch", "base", "check_workdir", "load", "save",
           "stage_dir"]
