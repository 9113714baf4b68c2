"""Data sets of the paper's tasks (synthetic generators ``make_*``, loaders of measured data) and
:func:`make_windows` / :func:`estimate_derivative` to build training data from your own recordings."""

from ._base import get_data_home
from ._causal_chamber import fetch_light_tunnel, fetch_wind_tunnel
from ._causal_chamber_simulated import make_light_tunnel_simulated, make_wind_tunnel_simulated
from ._measured import fetch_cascaded_tanks, fetch_hare_lynx, fetch_silverbox, load_pendulum_freeswing
from ._pendulum_images import make_pendulum_images, render_pendulum
from ._synthetic import make_duffing, make_pendulum, make_reaction_diffusion
from ._windows import estimate_derivative, make_windows

__all__ = [
    "estimate_derivative",
    "fetch_cascaded_tanks",
    "fetch_hare_lynx",
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
    "make_windows",
    "render_pendulum",
]
