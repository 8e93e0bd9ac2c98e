"""Neural building blocks shared by the paper packages.

- :mod:`.diffusion`: DDPM schedules, the forward process, the posterior, x0-parameterised
  sampling, classifier-free guidance and reconstruction guidance (NIFTY §3.1, Eq. 2–4);
- :mod:`.embeddings`: step, Fourier and positional embeddings;
- :mod:`.pointnet`: a PointNet encoder for point clouds;
- :mod:`.transformer`: an MDM/NIFTY-style transformer denoiser;
- :mod:`.mlp`: a plain MLP and the activations by name;
- :mod:`.cvae`: Gaussian KL, reparameterisation;
- :mod:`.moe`: mixture-of-experts layers with blended weights (SAMP Eq. 2);
- :mod:`.denoisers`: an x0-predicting MLP denoiser for vectors (2-D points, short trajectories).
"""
from .cvae import gaussian_kl, reparameterize
from .mlp import ACTIVATIONS, MLP
from .denoisers import MLPDenoiser
from .diffusion import (
    NoiseSchedule,
    classifier_free_x0,
    cosine_schedule,
    guided_x0,
    linear_schedule,
    p_mean_from_x0,
    q_posterior,
    q_sample,
    SamplingRecord,
    best_of_n,
    sample,
    sample_with_record,
    train_denoiser,
    training_loss,
)
from .embeddings import FourierFeatures, PositionalEncoding, SinusoidalEmbedding, TimestepEmbedding, sinusoid_table
from .moe import GatingNetwork, MixtureOfExpertsLinear, MoEMLP
from .pointnet import PointNetEncoder
from .transformer import TransformerDenoiser

__all__ = [
    "NoiseSchedule", "cosine_schedule", "linear_schedule", "q_sample", "q_posterior", "p_mean_from_x0",
    "classifier_free_x0", "guided_x0", "sample", "sample_with_record", "SamplingRecord", "best_of_n",
    "training_loss", "train_denoiser",
    "SinusoidalEmbedding", "TimestepEmbedding", "FourierFeatures", "PositionalEncoding", "sinusoid_table",
    "PointNetEncoder",
    "TransformerDenoiser", "MLPDenoiser",
    "gaussian_kl", "reparameterize", "MLP", "ACTIVATIONS",
    "MixtureOfExpertsLinear", "GatingNetwork", "MoEMLP",
]
