"""halo-jax: HALO (low-frequency neural fields for few-shot view synthesis) in JAX/Flax."""
