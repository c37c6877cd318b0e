"""The full set of fields every config has, with the paper's values (and the authors' code's, where the paper gives none).

Config files under `configs/` start from `base_config()` and change a few fields,
so every run, whatever its file, carries every field and overrides such as
`--config.lo.encoding.L=6` always find their target.
"""
import os

import ml_collections


def model_section(width=256, depth=8, use_viewdirs=False):
  """An MLP's fields (a NeRF's trunk, the ray fields')."""
  return ml_collections.ConfigDict(dict(
      width=width, depth=depth, skips=(4,), use_viewdirs=use_viewdirs, dir_freqs=4,
      density_bias=-1.0))


def _nerf_model(use_viewdirs):
  m = model_section(use_viewdirs=use_viewdirs)
  m.kind = "nerf"                    # models.MODELS: 'nerf', 'deform' (times), 'epi' (light fields)
  m.density_activation = "softplus"  # or 'relu' (the original NeRF)
  # the trunk's matmul dtype, 'float32' or 'bfloat16' (models.COMPUTE_DTYPES)
  m.compute_dtype = "float32"
  m.deform_width = 128               # deform only: the deformation MLP
  m.deform_depth = 4
  return m


def _train(steps, batch_rays, lr_init, lr_final):
  """Fields shared by every stage's training loop."""
  return dict(
      steps=steps,
      batch_rays=batch_rays,
      # Run each step's batch in this many equal parts, summing their gradients:
      # the same step (per-ray PRNG keys), but each part's activations stay in
      # cache (2.4x the matmul rate of a 128-wide MLP on CPU). 1: whole batch.
      microbatches=1,
      lr_init=lr_init,
      lr_final=lr_final,
      # > 0: the rate falls as a polynomial of this power from lr_init to
      # lr_final over `steps` (mmcv's Poly, the authors' schedule); 0: NeRF's
      # log-linear decay as lr_decay_steps below says
      lr_power=0.0,
      # 0: the rate falls log-linearly from lr_init to lr_final over `steps`;
      # > 0: lr_init * (lr_final / lr_init) ** (step / lr_decay_steps), a
      # schedule that does not depend on the step cap (the original NeRF's)
      lr_decay_steps=0,
      # seconds this stage may train, made a step count after timing its first
      # steps here (stages/budget.py; 0: none; a budget sets it for untabled sizes)
      max_seconds=0.0,
      min_steps=0,  # the fewest steps a budget gives a stage; later shares pay (not the last's)
      # (the step count and reference clock a protocol works out are in the
      # config's separate `plan` section: halo_jax/protocol.py)
      # stop after this step, as a time cap would, with every schedule (the
      # learning rate's, FreeNeRF's mask) still spanning `steps` (0: at `steps`)
      stop_at_step=0,
      schedule_span="steps",  # or 'stage': protocol.SPANNED spans the steps trained
      # stop with an error after this many non-finite steps in a row (each is
      # skipped, leaving the parameters as they were; 0: never stop)
      max_nonfinite=20,
      checkpoint_every=1000,  # steps between checkpoints (and one at the end)
      log_every=100,          # steps between metrics.jsonl lines
      eval_every=0,           # steps between held-out evaluations (0: only at the end)
      eval_every_s=0.0,       # or seconds of training time between them
      # whether the stage learned anything (stages/collapse.py): its median
      # training PSNR over the last `window` of its steps must be margin_db
      # above the best constant image's; stages shorter than after_steps are
      # not judged
      collapse=dict(margin_db=1.0, after_steps=200, window=0.2),
  )


def _radiance_stage(L, scale, use_viewdirs, steps, num_samples, sampler):
  """A radiance-field stage (trainer 'radiance'): the fields every such stage reads."""
  cfg = ml_collections.ConfigDict(_train(steps, 3072, 5e-4, 1e-4))
  cfg.kind = "radiance"
  # time_L, time_scale: the time encoding of a dynamic (model.kind='deform') field.
  cfg.encoding = ml_collections.ConfigDict(dict(L=L, scale=float(scale), time_L=0,
                                                time_scale=1.0))
  cfg.model = _nerf_model(use_viewdirs)
  cfg.sampler = ml_collections.ConfigDict(dict(
      kind=sampler,         # samplers.SAMPLERS: 'stratified', 'hierarchical', 'coarse_fine',
                            # 'depth_guided', 'depth_guided_fine', 'joint'
      num_samples=num_samples,
      num_coarse=64,        # hierarchical, coarse_fine, depth_guided_fine: first-pass samples
      coarse_weight=0.1,    # hierarchical, coarse_fine: weight of the first pass's L_rec
      coarse_model=False,   # coarse_fine: the first pass has its own MLP (the original NeRF)
      window=0.3,           # depth_guided: r, half window as a fraction of far - near
      near_only=False,      # depth_guided: tighten only the near side (authors' code)
      # depth_guided: r falls from window_start over window_steps (0: none); num_full
      # of the samples span all of [near, far], where the window may miss a surface
      window_start=0.0, window_steps=0, num_full=0,
      # held-out renders of a stage that trained at least dense_eval_after steps
      # (0: never) use dense_eval_samples stratified samples instead (stages/radiance.py)
      dense_eval_after=0, dense_eval_samples=64,
      # after switch_step steps (0: never) the stage trains, and is scored, with
      # switch_samples samples of kind switch_kind ('' : its own) (sampler_switch.py)
      switch_step=0, switch_samples=64, switch_kind="",
  ))
  # L_unseen (stages/unseen.py): mean density at random points that fewer
  # than min_views training cameras see (weight 0: off; methods/halo_unseen.py)
  cfg.unseen = ml_collections.ConfigDict(dict(weight=0.0, num_points=2048,
                                              bank_points=262144, min_views=1))
  cfg.density_noise = 1.0
  cfg.precrop_steps = 500
  cfg.precrop_frac = 0.5
  cfg.one_image = False     # draw each step's rays from one random training view
  # for the first fg_steps steps, fg_fraction of each batch from the pixels
  # that are not the white background (stages/batches.py; 0: off)
  cfg.fg_steps = 0
  cfg.fg_fraction = 0.5
  # Start from Lo-NeRF's weights: every layer of equal shape (the authors'
  # option, input layers excluded), or exactly Lo's function with
  # encoding.with_lo, which prepends Lo-NeRF's P.E. to this stage's (not for
  # the 'lo' stage itself).
  cfg.init_from_lo = False
  cfg.copy_lo_under_budget = False  # both of those under a budget (protocol.resolve)
  # keep the parameters that score best on data.select_views at the held-out
  # evaluations (eval_every / eval_every_s), not the last (stages/selection.py)
  cfg.select_best = False
  # with init_from_lo and without with_lo: keep the fresh skip layer too (the
  # authors' hf_load_lf drops both layers that read the encoding, fc0 and fc4)
  cfg.init_skip_fresh = False
  cfg.encoding.with_lo = False
  return cfg


def teach_section() -> ml_collections.ConfigDict:
  """L_teach's settings (stages/teach.py; weight 0: off, methods/halo_teach.py
  switches it on): its weight at the stage's first step (falling linearly to
  0 at its last); bank rays Hi renders a step; samples a ray (Lo's bank and
  Hi's render); random rays Lo renders once, twice with their neighbours; Lo
  is sure where its opacity is at least acc_min on the ray and its neighbour,
  at depths depth_tol of the range apart; the neighbour is the ray time_step
  later (dynamic) or turned by jitter radians (static)."""
  return ml_collections.ConfigDict(dict(
      weight=0.0, num_rays=256, num_samples=64, bank_rays=65536, acc_min=0.95,
      depth_tol=0.02, time_step=0.02, jitter=0.002))


def _hi_extras(cfg):
  """The fields only the output stage reads: HALO's regularisers and sampler
  options, and the baselines' (FreeNeRF's) terms, all off here."""
  cfg.empty = ml_collections.ConfigDict(dict(
      weight=0.0,           # lambda of L_empty (0 leaves the loss and the Lo bank out)
      tau=0.01,             # Lo-NeRF opacity below which a random ray counts as empty
      num_rays=1024,        # empty rays per step
      num_samples=64,       # uniform samples for both renderings of those rays
      bank_rays=65536,      # random rays rendered once by the frozen Lo-NeRF
      start_step=0,
      density_noise=0.0,    # Hi's density noise on those rays (the authors' 1.0)
  ))
  # sampler.kind='joint': a low-frequency ray field trained with this stage
  # (L_consist) places the samples in tau_ray +- alpha, alpha falling linearly
  # from 1 to alpha_final over alpha_steps (docs/scene_kinds.md).
  cfg.joint = ml_collections.ConfigDict(dict(consist_weight=1.0, alpha_final=0.5,
                                             alpha_steps=20000))
  # FreeNeRF (methods/freenerf.py): the P.E. bands open linearly until
  # end * steps (0: no mask), and the occlusion loss on the density of the
  # num_near samples nearest the camera (weight 0: off).
  cfg.freq_reg = ml_collections.ConfigDict(dict(end=0.0))
  cfg.occlusion = ml_collections.ConfigDict(dict(weight=0.0, num_near=10))
  # L_teach (stages/teach.py; methods/halo_teach.py): Hi follows Lo where Lo is sure
  cfg.teach = teach_section()
  return cfg


def data_root(*parts) -> str:
  """A path under the datasets folder: $HALO_DATA, else ./data (the layout each
  loader expects is in README.md)."""
  return os.path.join(os.environ.get("HALO_DATA", "data"), *parts)


def _data():
  """The scene and its views (data.kind: a datasets.LOADERS entry)."""
  return ml_collections.ConfigDict(dict(
      kind="blender",          # 'blender' | 'procedural' | 'dnerf' | 'stanford_lf' | 'llff'
      rays="",                 # '' (the kind's own rays) or another form its files are read
                               # in, which a method may choose: llff's 'planes' (datasets)
      # the published protocol these views are ('' for none): a method may
      # hold the paper's setting for one (methods/halo.py)
      protocol="",
      root="",                 # scene folder, e.g. data/nerf_synthetic/lego
      factor=2,                # integer downscale (2: 400x400, 8: 100x100)
      train_views="all",       # 'all', 'every:K', a list of names, or 'r_2,r_16,...'
      test_views="all",
      test_split="test",
      # model selection (a stage's select_best): views of `select_split`
      # that are neither training nor test views ('' : none), e.g. the
      # authors' 13 Blender val views, 'every:8' of 'val'
      select_views="",
      select_split="val",
      near=2.0,
      far=6.0,
      white_background=True,
      procedural_size=100,     # image size of the generated scene
      procedural_scene="spheres",  # datasets.procedural.SCENES
      # stanford_lf: disparity range (pixels per grid step at the files' size)
      # that bounds the EPI angle every ray is sampled in, and the signs of u, v
      # along growing grid column, row (datasets/stanford_lf.py says why -1)
      disparity_px=(-2.0, 1.0),
      grid_signs=(-1.0, -1.0),
  ))


def _parallel():
  """Data parallelism and multi-host settings (halo_jax.parallel)."""
  return ml_collections.ConfigDict(dict(
      data_parallel=False,   # shard each step's rays over all local (or all hosts') devices
      multihost=False,       # jax.distributed.initialize before training
      coordinator="",        # host:port of process 0 ('' : from the cluster environment)
      num_processes=1,
      process_id=0,
      heartbeat_s=100,       # a process whose peer is silent this long is terminated
  ))


def _tune():
  """The frequency search (halo_jax.frequency.tuning)."""
  return ml_collections.ConfigDict(dict(
      grid="10:1,7:1,5:1,4:1,5:4,5:16",  # L:s points, searched high to low frequency
      # The first point whose rho (frequency.relative_spectrum_difference) is
      # below the threshold is chosen; threshold and form were chosen on the
      # validation views of 11 scenes (docs/results/frequency_calibration_val.md).
      threshold=0.8475,
      # warp: compare a with b resampled onto a by Lo's depth (view_pairs.warp_onto),
      # so that rho sees only what the camera move does not explain;
      # relative: compare rho / rho at the grid's first point (Hi's frequency).
      warp=False,
      relative=True,
      num_pairs=8,           # nearby view pairs rendered per point
      size=64,               # criterion resolution: the renders' short side in pixels
      shift_px=1.0,          # pair baseline: median displacement of the surface, in those pixels
      mask_fraction=0.01,    # share of the largest spectrum coefficients dropped (beside DC)
      seed=0,
      lo_seconds=0.0,        # time cap of each short Lo-NeRF (0: none)
      lo_steps=0,            # step cap of each short Lo-NeRF (0: lo.steps)
  ))


def _ray_stage():
  """The ray-field stage (trainer 'ray_field')."""
  r = ml_collections.ConfigDict(_train(24000, 4096, 5e-4, 5e-6))
  r.kind = "ray_field"
  r.encoding = ml_collections.ConfigDict(dict(L=10, scale=32.0))
  r.model = model_section()
  r.radius = 0.0              # sphere of the ray parametrisation (0: camera radius)
  r.depth_target = "max_weight"  # one of raycast.DEPTH_TARGETS
  r.acc_weight = 1.0          # L_ray's opacity term (0: depth alone)
  r.random_acc = True         # ... on the random rays too (False: training rays alone)
  r.random_fraction = 0.5     # share of each batch drawn from random hemisphere rays
  r.bank_rays = 262144        # random rays rendered once by the frozen Lo-NeRF
  r.lo_samples = 0            # samples for the Lo-NeRF targets (0: Lo's own count)
  # Training rays whose Lo-NeRF targets are rendered, drawn once at random
  # (0: every training pixel). Rendering 4 LLFF views at 504x378 with Lo
  # takes longer than a CPU budget gives the whole stage.
  r.target_rays = 0
  return r


def _eval():
  """Held-out rendering and scoring."""
  return ml_collections.ConfigDict(dict(
      chunk=4096,          # rays per jitted rendering call
      # Render each chunk in blocks of this many rays, one after another (0: the
      # whole chunk at once, for GPUs). On CPU blocks that fit in cache are
      # several times faster (raycast.in_blocks).
      block_rays=0,
      curve_views=5,       # held-out views used for the PSNR curve (final eval uses all)
      save_images=True,
      lpips=True,          # LPIPS-VGG in the final evaluation (needs H, W >= 32)
      flicker_frames=24,   # dynamic scenes: frames of the fixed-camera video for flicker
      # The method's training seconds at which each stage saves its parameters
      # for the error-against-time front, scored after training on every
      # held-out view (experiments/bench/front_scores.py); () for none.
      front_s=(),
  ))


def base_config() -> ml_collections.ConfigDict:
  """All fields, set to the paper's full-resolution Blender protocol."""
  c = ml_collections.ConfigDict()
  c.seed = 0
  # The method (halo_jax.methods) that made this config ('' until one has):
  # methods.apply makes it into one method, once; the pipeline reads stages.
  c.method = ""
  # The stages to train now (the ones they need are restored). A scene's
  # config is a neutral NeRF (Hi alone, stratified samples, no regulariser);
  # a method (halo_jax.methods) sets its own stages, samplers and terms.
  c.stages = "hi"
  c.final_stage = "hi"        # the stage whose field the method outputs
  c.sizing = "paper"   # the scene file's sizes: 'paper', or 'cpu' (cpu_sized)
  # 'paper', 'steps' or 'budget' (budget_s reference seconds: halo_jax/protocol.py);
  # step_table: '' for the shipped halo_jax/step_table.json
  c.protocol, c.budget_s, c.step_table = "paper", 0.0, ""
  c.budget_shares = ml_collections.ConfigDict(dict(lo=0.25, ray=0.10, hi=0.65))
  c.data = _data()
  c.lo = _radiance_stage(L=5, scale=32, use_viewdirs=False, steps=8000, num_samples=128,
                         sampler="stratified")
  c.hi = _hi_extras(_radiance_stage(L=10, scale=1, use_viewdirs=True, steps=80000,
                                    num_samples=128, sampler="stratified"))
  c.hi.lr_final = 5e-5
  c.hi.precrop_steps = 0
  # auto: choose lo.encoding.L / scale with the frequency criterion before
  # training (halo_jax/frequency/tuning.py; the search runs in <workdir>/tune once).
  c.lo.encoding.auto = False
  # How the encodings' sin and cos are evaluated (halo_jax/trig.py):
  # "polynomial", vectorised multiply-adds (a CPU evaluates XLA's one element
  # at a time), or "xla". Both agree to about 2e-7.
  c.sin_cos = "polynomial"
  c.parallel = _parallel()
  c.tune = _tune()
  c.ray = _ray_stage()
  # The NeRF baselines (methods/): stratified samples per ray of nerf_tuned.
  c.baseline = ml_collections.ConfigDict(dict(num_samples=64))
  c.eval = _eval()
  return c


def cpu_sized(c: ml_collections.ConfigDict, budget_s: float) -> ml_collections.ConfigDict:
  """Shrinks a config to `budget_s` reference seconds on one CPU core (protocol.py).

  The HALO stages share the budget as `budget_shares` says. The choices were
  measured on lego 8-view at 100x100 (docs/notes/2026-11-22-lego-cpu.md):
  - Lo-NeRF: 128x4 MLP, 32 samples, 4x the paper's rate, P.E. L=5, s=1 (the
    paper's one-side Lo): s=32's near-linear features need more steps.
  - Hi-NeRF: the same 128x4 trunk with 32 samples in the ray field's window
    (r=0.3), under a budget started as Lo's exact copy (methods/halo.py).
  - No view directions for either NeRF: with 8 views at 100x100 there is too
    little data to learn view dependence, and Lo-NeRF has none to copy.
  - nerf_tuned: the same 128x4 model with 64 stratified samples.
  Steps are caps that the time budget normally reaches first; the learning
  rate decays over them.
  """
  c.sizing = "cpu"
  c.protocol, c.budget_s = "budget", float(budget_s)
  c.budget_shares.update(lo=0.30, ray=0.07, hi=0.63)
  c.eval.chunk = 8192
  # Cache-sized work on CPU (experiments/throughput.py): training steps in
  # parts of 128 rays x 32 samples, renders in blocks of 256 rays.
  c.eval.block_rays = 256
  c.lo.microbatches = 8
  c.hi.microbatches = 8
  c.lo.encoding.scale = 1.0
  c.lo.sampler.num_samples = 32
  c.lo.update(batch_rays=1024, steps=1500, lr_init=2e-3, lr_final=2e-4, precrop_steps=200,
              checkpoint_every=500, log_every=50)
  c.ray.model.update(width=128, depth=4, skips=())
  c.ray.update(batch_rays=2048, steps=3000, bank_rays=32768, target_rays=131072,
               checkpoint_every=1000, log_every=100)
  # Floors under the time shares: every stage of HALO trains on any machine.
  c.lo.min_steps = 100
  c.ray.min_steps = 200
  c.hi.min_steps = 100
  # The frequency search's short Lo-NeRFs: the length its threshold was
  # calibrated at (experiments/calibrate_frequency.py).
  c.tune.lo_steps = 300
  c.hi.sampler.num_samples = 32
  c.hi.empty.update(num_rays=256, num_samples=32, bank_rays=32768)
  # 4x the paper's rate, for Hi-NeRF and the NeRF baseline alike: a few
  # thousand steps are all the budget allows, and both gain from it (docs/notes/2026-11-22-lego-cpu.md).
  c.hi.update(batch_rays=1024, steps=6000, lr_init=2e-3, lr_final=2e-4, checkpoint_every=500,
              log_every=50)
  for name in ("lo", "hi"):
    c[name].model.update(width=128, depth=4, skips=(), use_viewdirs=False)
  return c
