"""Data sets of the paper's tasks: synthetic generators (``make_*``) and loaders of measured data."""

from ._pendulum_images import make_pendulum_images, render_pendulum
from ._synthetic import make_duffing, make_pendulum, make_reaction_diffusion

__all__ = [
    "make_duffing",
    "make_pendulum",
    "make_pendulum_images",
    "make_reaction_diffusion",
    "render_pendulum",
]
