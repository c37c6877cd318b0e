"""halo-jax inside other tools (nerfbaselines): entry points like halo_jax/cli,
built on the same pipeline."""
