"""Science models and networks of the paper's six tasks, built from the package's public pieces.

Science functions (theta = their numeric keyword defaults):
:func:`pendulum_f`, :func:`duffing_f`, :func:`diffusion_f`, :func:`wind_tunnel_f`,
:func:`light_tunnel_f` (and :func:`make_light_tunnel_f` for other image sizes).
Networks for ``residual=``: :func:`wind_tunnel_net`, :func:`light_tunnel_unet`,
:class:`PendulumImagesNet` (with the callable structure :class:`PendulumImagesStructure`);
the MLP 128x2 and the CNN 16x2 are the built-in ``"mlp"`` and ``"cnn"``.
"""

from .networks import (FeedForward, FrameDecoder, ImageEncoder, UNet, light_tunnel_unet,
                       wind_tunnel_net)
from .pendulum_images import PendulumImagesNet, PendulumImagesStructure, latent_trajectories
from .science import (THETA_BOUNDS, diffusion_f, duffing_f, fan_speed_ratio, laplacian,
                      light_tunnel_colour, light_tunnel_f, make_light_tunnel_f, pendulum_f,
                      wind_tunnel_f)

__all__ = [
    "THETA_BOUNDS",
    "FeedForward",
    "FrameDecoder",
    "ImageEncoder",
    "PendulumImagesNet",
    "PendulumImagesStructure",
    "UNet",
    "diffusion_f",
    "duffing_f",
    "fan_speed_ratio",
    "laplacian",
    "latent_trajectories",
    "light_tunnel_colour",
    "light_tunnel_f",
    "light_tunnel_unet",
    "make_light_tunnel_f",
    "pendulum_f",
    "wind_tunnel_f",
    "wind_tunnel_net",
]
