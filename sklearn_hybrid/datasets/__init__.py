"""Data sets of the paper's tasks: synthetic generators (``make_*``) and loaders of measured data."""

from ._base import get_data_home
from ._causal_chamber import (
    fetch_light_tunnel,
    fetch_wind_tunnel,
    make_light_tunnel_simulated,
    make_wind_tunnel_simulated,
)
from ._measured import fetch_cascaded_tanks, fetch_silverbox, load_pendulum_freeswing
from ._pendulum_images import make_pendulum_images, render_pendulum
from ._synthetic import make_duffing, make_pendulum, make_reaction_diffusion

__all__ = [
    "fetch_cascaded_tanks",
    "fetch_light_tunnel",
    "fetch_silverbox",
    "fetch_wind_tunnel",
    "get_data_home",
    "load_pendulum_freeswing",
    "make_light_tunnel_simulated",
    "make_wind_tunnel_simulated",
    "make_duffing",
    "make_pendulum",
    "make_pendulum_images",
    "make_reaction_diffusion",
    "render_pendulum",
]
